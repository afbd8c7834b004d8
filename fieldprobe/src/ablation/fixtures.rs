//! Small made-up ablation results, for tests and for trying report renderers without training.

use std::path::Path;

use super::entry::{AblationEntry, SeedRun, Status};
use crate::evaluate::{CategoryMetrics, PredictionScores};
use crate::metrics::Metrics;
use crate::variants::AblationFile;

/// Metrics of one chair category whose objects `o0, o1, …` scored `ious`.
pub fn metrics(ious: &[f32]) -> Metrics {
    let per_object: Vec<(String, f32)> = ious
        .iter()
        .enumerate()
        .map(|(i, v)| (format!("o{i}"), *v))
        .collect();
    let iou = ious.iter().sum::<f32>() / ious.len() as f32;
    let cm = CategoryMetrics {
        iou,
        centre_iou: iou,
        outside_hull: 0.0,
        visual_hull_iou: 0.7,
        mean_shape_iou: Some(0.3),
        mean_gt_shape_iou: None,
        silhouette_iou: None,
        objects: ious.len(),
        views: 24,
        per_object,
        mesh: None,
    };
    Metrics {
        experiment: "t".into(),
        mean_iou: iou,
        centre_iou: iou,
        outside_hull: 0.0,
        visual_hull_iou: 0.7,
        mean_shape_iou: Some(0.3),
        mean_gt_shape_iou: None,
        silhouette_iou: None,
        per_category: [("chair".to_string(), cm)].into(),
        split: "test".into(),
        resolution: 32,
        subsamples: 4,
        maxpool: Default::default(),
        steps: 10,
        train_seconds: 5.0,
        train_decoder_points: 1000,
        eval_seconds: 1.0,
        eval_grid_points: 5000,
        final_loss: Some(0.1),
        final_silhouette_loss: Some(0.09),
        final_regularizer_loss: Some(0.01),
        backend: "flex".into(),
        device: "cpu".into(),
    }
}

/// A finished seed with those metrics and loss history; each object meshed from one view, with
/// surface metrics that follow its IoU (Chamfer-L1 `0.1·(1 − iou)`, normal consistency
/// `0.5 + 0.4·iou`).
pub fn run(seed: u64, ious: &[f32], hist: &[(usize, f32)]) -> SeedRun {
    let predictions = ious
        .iter()
        .enumerate()
        .map(|(i, &iou)| PredictionScores {
            category: "chair".into(),
            object: format!("o{i}"),
            view: Some(0),
            iou,
            centre_iou: iou,
            outside_hull: 0.0,
            visual_hull_iou: 0.7,
            mesh_iou: Some(iou),
            chamfer_l1: Some(0.1 * (1.0 - iou)),
            fscore: Some(iou),
            normal_consistency: Some(0.5 + 0.4 * iou),
            mesh_file: None,
        })
        .collect();
    SeedRun {
        seed,
        metrics: metrics(ious),
        history: hist.to_vec(),
        predictions,
    }
}

/// A one-category ablation file (`base_name = "full"`, paper IoU 0.548) with `variants` appended.
pub fn file_with(variants: &str) -> AblationFile {
    let text = format!(
        "name = \"abl\"\nbase_name = \"full\"\nbase_paper_iou = 0.548\npaper_table = \"Table 4, chair\"\n\
         [data]\ndir = \"datasets/abl\"\ncategories = [\"chair\"]\n[probe]\nanchors = 8\nrays_per_view = 4\n\
         ray_sampler = {{ type = \"uniform\" }}\nanchor_sampler = {{ type = \"uniform\" }}\n[train]\nsteps = 10\n{variants}"
    );
    AblationFile::parse(&text, Path::new("abl.toml")).unwrap()
}

/// The loss history of every finished entry of [`four_entries`].
pub const HISTORY: [(usize, f32); 2] = [(5, 0.2), (10, 0.1)];

/// A base and three variants in every state: the base (IoUs 0.60, 0.62, 0.61) and `normal`
/// (0.40, 0.42, 0.41) finished with [`HISTORY`], `naive` failed, `extra` not run yet.
pub fn four_entries() -> (AblationFile, Vec<Status>) {
    let file = file_with(
        "[[variants]]\nname = \"normal\"\npaper_iou = 0.482\nprobe = { ray_sampler = { type = \"normal\" } }\n\
         [[variants]]\nname = \"naive\"\npaper_iou = 0.524\nprobe = { assignment = \"naive\" }\n\
         [[variants]]\nname = \"extra\"\nseed = 4\n",
    );
    let finished = |i: usize, ious: &[f32]| {
        Status::Finished(Box::new(AblationEntry::new(
            &file.entries[i],
            &[run(0, ious, &HISTORY)],
        )))
    };
    let status = vec![
        finished(0, &[0.60, 0.62, 0.61]),
        finished(1, &[0.40, 0.42, 0.41]),
        Status::Failed("the loss became NaN | at step 3".into()),
        Status::Pending,
    ];
    (file, status)
}
