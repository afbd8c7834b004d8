//! `make-dataset`: procedural shapes or a folder of meshes (`.obj`, `.off`, `.ply`, `.stl`, the
//! ShapeNetCore v1/v2 layouts, optional split lists) → the published dataset layout
//! (made by `fieldprobe::make`), with a contact sheet of what was made.

use std::path::PathBuf;

use anyhow::Result;
use fieldprobe::data::Category;
use fieldprobe::data::dataset::{Layout, Split};
use fieldprobe::data::voxelize::Voxelizer;
use fieldprobe::make::{DatasetSource, DatasetSpec, layout_name, make_dataset};

/// Arguments of `make-dataset`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory (created if needed).
    #[arg(long)]
    out: PathBuf,
    /// Procedural categories, by name or synset (default: all six).
    #[arg(long, value_delimiter = ',', conflicts_with = "meshes")]
    categories: Option<Vec<Category>>,
    /// Procedural objects per category in the train split.
    #[arg(long, default_value_t = 8)]
    train: usize,
    /// Procedural objects per category in the val split.
    #[arg(long, default_value_t = 2)]
    val: usize,
    /// Procedural objects per category in the test split.
    #[arg(long, default_value_t = 4)]
    test: usize,
    /// Seed of the procedural generator.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Use meshes instead: `MESH_DIR/<category name or synset>/` holding `<id>.obj` (`.off`,
    /// `.ply`, `.stl`) files or ShapeNetCore folders (`<id>/model.obj`,
    /// `<id>/models/model_normalized.obj`).
    #[arg(long)]
    meshes: Option<PathBuf>,
    /// Split that mesh-source objects go into (without --split-list, or for a list whose name
    /// says no split).
    #[arg(long, default_value = "test")]
    split: Split,
    /// A split list (one object id per line, e.g. SoftRas's `softras_train.lst`); its split is
    /// read from its name. Repeat for several splits; objects no list names are skipped.
    #[arg(long = "split-list", requires = "meshes")]
    split_lists: Vec<PathBuf>,
    /// Ground-truth voxelization: `nmr` (the published protocol) or `winding`.
    #[arg(long, default_value = "nmr")]
    voxelizer: Voxelizer,
    /// Sub-pixels per pixel side for anti-aliased silhouettes.
    #[arg(long, default_value_t = 4)]
    supersample: usize,
    /// Layout to write: `kato` (npz files) or `dvr` (folders of PNGs).
    #[arg(long, default_value = "kato", value_parser = parse_layout)]
    layout: Layout,
    /// Objects per category shown in `contact_sheet.png`.
    #[arg(long, default_value_t = 3)]
    sheet_objects: usize,
}

fn parse_layout(s: &str) -> Result<Layout, String> {
    match s {
        "kato" => Ok(Layout::Kato),
        "dvr" => Ok(Layout::Dvr),
        _ => Err(format!("unknown layout '{s}': expected kato or dvr")),
    }
}

pub fn run(args: Args) -> Result<()> {
    let source = match &args.meshes {
        Some(dir) => DatasetSource::Meshes {
            dir: dir.clone(),
            split: args.split,
            split_lists: args.split_lists.clone(),
        },
        None => DatasetSource::Procedural {
            categories: args
                .categories
                .clone()
                .unwrap_or_else(|| Category::ALL.to_vec()),
            counts: [args.train, args.val, args.test],
            seed: args.seed,
        },
    };
    let spec = DatasetSpec {
        out: args.out.clone(),
        source,
        voxelizer: args.voxelizer,
        supersample: args.supersample,
        layout: args.layout,
    };
    let made = make_dataset(&spec)?;
    let sheet = args.out.join("contact_sheet.png");
    crate::contact_sheet::write(&sheet, &made.sets, args.sheet_objects)?;
    let total: usize = made.sets.iter().map(|s| s.len()).sum();
    println!(
        "made {total} objects in {:.1} s ({:.1} objects/s) → {} ({} layout); contact sheet {}",
        made.seconds,
        total as f64 / made.seconds.max(1e-9),
        args.out.display(),
        layout_name(args.layout),
        sheet.display()
    );
    for set in &made.sets {
        println!(
            "  {:<10} {} {:<5} {:>5} objects",
            set.category.name(),
            set.category.synset(),
            set.split.name(),
            set.len()
        );
    }
    Ok(())
}
