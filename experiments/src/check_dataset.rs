//! `check-dataset`: loads a dataset (generated or published) and checks that its silhouettes,
//! the NMR cameras and its voxels agree, per category.
//!
//! For each object the 24-view visual hull (footprint test, conservative) is carved and compared
//! with the ground-truth voxels: with the right conventions (camera, voxel axis order) nearly all
//! voxels lie inside the hull (`gt_in_hull` ≈ 1); a wrong axis order or camera drops it far
//! below. `hull_iou` is the IoU of that hull against the voxels, the "silhouettes only" reference;
//! `centre_hull_iou` uses the centre-sampled hull instead (see `fieldprobe_core::data::hull`).

use std::path::PathBuf;

use anyhow::{Result, bail};
use fieldprobe_core::data::dataset::{ObjectSet, Split, discover, read_set};
use fieldprobe_core::data::hull::{HullTest, visual_hull};
use fieldprobe_core::geometry::Camera;
use rayon::prelude::*;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Dataset directory (Kato npz files or DVR folders).
    #[arg(long)]
    data: PathBuf,
    /// Only this split (default: all present).
    #[arg(long)]
    split: Option<Split>,
    /// At most this many objects per set (0 = all).
    #[arg(long, default_value_t = 0)]
    limit: usize,
}

pub fn run(args: Args) -> Result<()> {
    let sets = discover(&args.data)?;
    if sets.is_empty() {
        bail!(
            "{}: no dataset found (expected {{synset}}_{{split}}_images.npz or <synset>/softras_{{split}}.lst)",
            args.data.display()
        );
    }
    let cameras = Camera::nmr_views();
    println!(
        "| category | synset | split | layout | objects | silhouette coverage | gt_in_hull | hull_iou | centre_hull_iou |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (category, split, layout) in sets {
        if args.split.is_some_and(|s| s != split) {
            continue;
        }
        let set = read_set(&args.data, category, split, layout)?;
        let n = if args.limit > 0 {
            set.len().min(args.limit)
        } else {
            set.len()
        };
        let stats: Vec<ObjectStats> = (0..n)
            .into_par_iter()
            .map(|i| object_stats(&set, i, &cameras))
            .collect();
        let mean = |f: &dyn Fn(&ObjectStats) -> Option<f32>| {
            let v: Vec<f32> = stats.iter().filter_map(f).collect();
            if v.is_empty() {
                "n/a".to_string()
            } else {
                format!("{:.3}", v.iter().sum::<f32>() / v.len() as f32)
            }
        };
        println!(
            "| {} | {} | {} | {:?} | {} | {} | {} | {} | {} |",
            category,
            category.synset(),
            split,
            layout,
            n,
            mean(&|s| Some(s.coverage)),
            mean(&|s| s.voxels.map(|v| v.gt_in_hull)),
            mean(&|s| s.voxels.map(|v| v.hull_iou)),
            mean(&|s| s.voxels.map(|v| v.centre_hull_iou)),
        );
    }
    Ok(())
}

/// What `check-dataset` measures on one object.
struct ObjectStats {
    /// Mean silhouette coverage over the 24 views.
    coverage: f32,
    /// Hull-vs-voxel agreement, where the layout has voxels.
    voxels: Option<VoxelStats>,
}

#[derive(Clone, Copy)]
struct VoxelStats {
    gt_in_hull: f32,
    hull_iou: f32,
    centre_hull_iou: f32,
}

fn object_stats(set: &ObjectSet, i: usize, cameras: &[Camera]) -> ObjectStats {
    let sils = set.silhouettes(i);
    let coverage = sils
        .iter()
        .map(|s| s.values().sum::<f32>() / s.len() as f32)
        .sum::<f32>()
        / sils.len() as f32;
    let voxels = set.voxel_grid(i).map(|gt| {
        let hull = visual_hull(&sils, cameras, gt.resolution(), HullTest::Footprint);
        let centre = visual_hull(&sils, cameras, gt.resolution(), HullTest::Centre);
        VoxelStats {
            gt_in_hull: gt.fraction_inside(&hull),
            hull_iou: hull.iou(&gt),
            centre_hull_iou: centre.iou(&gt),
        }
    });
    ObjectStats { coverage, voxels }
}
