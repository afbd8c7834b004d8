//! What a run measured: `metrics.json` ([`Metrics`]) and what training left for reports
//! ([`Training`]).

use std::collections::BTreeMap;

use fieldprobe_core::eval::occupancy::MaxPoolPath;
use serde::{Deserialize, Serialize};

use crate::evaluate::CategoryMetrics;

/// What `metrics.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Metrics {
    pub experiment: String,
    /// Mean over categories of the model's max-pool IoU (the NMR protocol; see
    /// `evaluate::CategoryMetrics`).
    pub mean_iou: f32,
    /// The same predictions read at the voxel centres only (secondary).
    #[serde(default)]
    pub centre_iou: f32,
    /// Mean share of the predicted voxels outside the 24-view visual hull.
    #[serde(default)]
    pub outside_hull: f32,
    pub visual_hull_iou: f32,
    pub mean_shape_iou: Option<f32>,
    pub mean_gt_shape_iou: Option<f32>,
    /// Per-object fits: mean IoU of the field's rendered silhouettes vs the input ones.
    pub silhouette_iou: Option<f32>,
    pub per_category: BTreeMap<String, CategoryMetrics>,
    pub split: String,
    pub resolution: usize,
    /// Lattice cells per voxel and axis of the max-pool protocol.
    #[serde(default)]
    pub subsamples: usize,
    /// How fields were converted to voxels (`eval.maxpool`).
    #[serde(default)]
    pub maxpool: MaxPoolPath,
    pub steps: usize,
    pub train_seconds: f64,
    /// Field evaluations of the silhouette term over the training steps of this process (the
    /// points the rays read, per step `batch × points per object`; regularizer stencils not
    /// counted): the cost measure that compares probing with dense marching. Like
    /// `train_seconds`, a resumed run counts only the steps it took itself.
    #[serde(default)]
    pub train_decoder_points: u64,
    pub eval_seconds: f64,
    /// Field points the evaluation read to convert the test predictions to voxels
    /// (`evaluate::Evaluation::grid_points`): what `eval_seconds` mostly pays for.
    #[serde(default)]
    pub eval_grid_points: u64,
    pub final_loss: Option<f32>,
    /// The silhouette and regularizer terms of the last logged interval (means).
    #[serde(default)]
    pub final_silhouette_loss: Option<f32>,
    #[serde(default)]
    pub final_regularizer_loss: Option<f32>,
    pub backend: String,
    pub device: String,
}

/// The mean over categories of `f`, over those that have it.
pub fn mean_of(
    m: &BTreeMap<String, CategoryMetrics>,
    f: impl Fn(&CategoryMetrics) -> Option<f32>,
) -> Option<f32> {
    let v: Vec<f32> = m.values().filter_map(f).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f32>() / v.len() as f32)
}

/// What training left for the report.
#[derive(Clone, Debug, Default)]
pub struct Training {
    pub steps: usize,
    pub seconds: f64,
    /// Field evaluations of the silhouette term (see [`Metrics::train_decoder_points`]).
    pub decoder_points: u64,
    /// `(step, mean loss of the interval)`.
    pub history: Vec<(usize, f32)>,
    /// `(step, mean silhouette term, mean regularizer term)` of the same intervals.
    pub terms: Vec<(usize, f32, f32)>,
}
