//! `make-dataset`: procedural shapes or a folder of `.obj` meshes → the published dataset layout.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use fieldprobe_core::data::dataset::{
    DatasetInfo, ObjectRecord, ObjectSet, Split, SplitCount, dvr, kato,
};
use fieldprobe_core::data::procedural::{generate, object_rng};
use fieldprobe_core::data::render::RenderOptions;
use fieldprobe_core::data::voxelize::Voxelizer;
use fieldprobe_core::data::{Category, TriMesh};
use rayon::prelude::*;

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
    /// Use meshes instead: `MESH_DIR/<category name or synset>/<id>.obj`.
    #[arg(long)]
    meshes: Option<PathBuf>,
    /// Split that mesh-source objects go into.
    #[arg(long, default_value = "test")]
    split: Split,
    /// Ground-truth voxelization: `nmr` (the published protocol) or `winding`.
    #[arg(long, default_value = "nmr")]
    voxelizer: Voxelizer,
    /// Sub-pixels per pixel side for anti-aliased silhouettes.
    #[arg(long, default_value_t = 4)]
    supersample: usize,
    /// Layout to write: `kato` (npz files) or `dvr` (folders of PNGs).
    #[arg(long, default_value = "kato", value_parser = ["kato", "dvr"])]
    layout: String,
    /// Objects per category shown in `contact_sheet.png`.
    #[arg(long, default_value_t = 3)]
    sheet_objects: usize,
}

/// Where one object comes from.
enum Source {
    Procedural { seed: u64, index: u64 },
    Mesh(TriMesh),
}

/// One category × split to make.
struct Job {
    category: Category,
    split: Split,
    objects: Vec<(String, Source)>,
}

/// Makes a procedural dataset with default rendering settings (used by experiments that generate
/// their data on first run).
pub fn make_procedural(
    out: &Path,
    categories: &[Category],
    [train, val, test]: [usize; 3],
    seed: u64,
) -> Result<()> {
    run(Args {
        out: out.to_path_buf(),
        categories: Some(categories.to_vec()),
        train,
        val,
        test,
        seed,
        meshes: None,
        split: Split::Test,
        voxelizer: Voxelizer::Nmr,
        supersample: 4,
        layout: "kato".into(),
        sheet_objects: 3,
    })
}

pub fn run(args: Args) -> Result<()> {
    let jobs = match &args.meshes {
        Some(dir) => mesh_jobs(dir, args.split)?,
        None => procedural_jobs(&args),
    };
    let total: usize = jobs.iter().map(|j| j.objects.len()).sum();
    if total == 0 {
        bail!("nothing to make: every split has zero objects");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let opts = RenderOptions {
        supersample: args.supersample.max(1),
        ..RenderOptions::default()
    };
    let bar = crate::progress::Progress::new("render", total, 0);
    let start = Instant::now();
    let mut sets = Vec::new();
    let mut counts = Vec::new();
    for job in jobs {
        bar.message(format!("{} {}", job.category, job.split));
        let records: Vec<(String, ObjectRecord)> = job
            .objects
            .par_iter()
            .map(|(id, source)| {
                let record = match source {
                    Source::Procedural { seed, index } => {
                        let mut rng = object_rng(*seed, job.category, job.split.index(), *index);
                        let mesh = generate(job.category, &mut rng);
                        let path = args
                            .out
                            .join("meshes")
                            .join(job.category.synset())
                            .join(format!("{id}.obj"));
                        mesh.write_obj(&path)?;
                        ObjectRecord::from_mesh(&mesh, args.voxelizer, &opts)
                    }
                    Source::Mesh(mesh) => ObjectRecord::from_mesh(mesh, args.voxelizer, &opts),
                };
                bar.inc();
                Ok((id.clone(), record))
            })
            .collect::<Result<_>>()?;
        let mut set = ObjectSet::new(job.category, job.split);
        for (id, rec) in &records {
            set.push(id.clone(), rec);
        }
        match args.layout.as_str() {
            "dvr" => dvr::write(&args.out, &set)?,
            _ => kato::write(&args.out, &set)?,
        }
        counts.push(SplitCount {
            category: job.category,
            synset: job.category.synset().into(),
            split: job.split,
            count: set.len(),
        });
        sets.push(set);
    }
    bar.finish();
    let elapsed = start.elapsed().as_secs_f64();
    DatasetInfo {
        source: if args.meshes.is_some() {
            "meshes"
        } else {
            "procedural"
        }
        .into(),
        seed: args.meshes.is_none().then_some(args.seed),
        voxelizer: args.voxelizer,
        supersample: opts.supersample,
        layout: args.layout.clone(),
        objects: counts,
    }
    .write(&args.out)?;
    let sheet = args.out.join("contact_sheet.png");
    crate::contact_sheet::write(&sheet, &sets, args.sheet_objects)?;
    println!(
        "made {total} objects in {elapsed:.1} s ({:.1} objects/s) → {} ({} layout); contact sheet {}",
        total as f64 / elapsed.max(1e-9),
        args.out.display(),
        args.layout,
        sheet.display()
    );
    for set in &sets {
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

fn procedural_jobs(args: &Args) -> Vec<Job> {
    let categories = args
        .categories
        .clone()
        .unwrap_or_else(|| Category::ALL.to_vec());
    let mut jobs = Vec::new();
    for &category in &categories {
        for (split, n) in [
            (Split::Train, args.train),
            (Split::Val, args.val),
            (Split::Test, args.test),
        ] {
            if n == 0 {
                continue;
            }
            let objects = (0..n)
                .map(|i| {
                    let id = format!("proc_{}_{}_{:05}", category.name(), split.name(), i);
                    (
                        id,
                        Source::Procedural {
                            seed: args.seed,
                            index: i as u64,
                        },
                    )
                })
                .collect();
            jobs.push(Job {
                category,
                split,
                objects,
            });
        }
    }
    jobs
}

/// Loads and validates every mesh before anything is written, so a bad file stops the run early
/// with its name and nothing half-made is left behind.
fn mesh_jobs(dir: &Path, split: Split) -> Result<Vec<Job>> {
    let entries = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read mesh directory {}", dir.display()))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    if folders.is_empty() {
        bail!(
            "{}: expected sub-folders named after categories (e.g. chair/ or 03001627/) holding .obj files",
            dir.display()
        );
    }
    let mut jobs = Vec::new();
    for folder in folders {
        let name = folder
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let category: Category = name
            .parse()
            .map_err(|e: String| anyhow::anyhow!("{}: {e}", folder.display()))?;
        let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
            .with_context(|| format!("cannot read {}", folder.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("obj")))
            .collect();
        files.sort();
        let objects = files
            .into_par_iter()
            .map(|path| {
                let mut mesh = TriMesh::load_obj(&path)?;
                mesh.normalize_unit_cube();
                let id = path
                    .file_stem()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned();
                Ok((id, Source::Mesh(mesh)))
            })
            .collect::<Result<Vec<_>, fieldprobe_core::Error>>()?;
        if objects.is_empty() {
            bail!("{}: no .obj files", folder.display());
        }
        match jobs.iter_mut().find(|j: &&mut Job| j.category == category) {
            Some(job) => job.objects.extend(objects),
            None => jobs.push(Job {
                category,
                split,
                objects,
            }),
        }
    }
    Ok(jobs)
}
