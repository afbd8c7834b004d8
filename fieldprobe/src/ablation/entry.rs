//! An ablation's entries: one finished run per seed ([`SeedRun`]), their mean as
//! `ablation.json` lists it ([`AblationEntry`]), and where each entry stands ([`Status`]).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::evaluate::{CategoryMetrics, MeshMetrics, PredictionScores};
use crate::metrics::Metrics;
use crate::variants::Variant;

/// One finished entry as `ablation.json` lists it: the mean over its seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AblationEntry {
    /// The entry's name (`base_name` for the base).
    pub variant: String,
    /// Its run directory, relative to the ablation directory.
    pub dir: String,
    /// The overrides of the base, `key = value` (empty for the base).
    pub overrides: Vec<String>,
    /// The paper's IoU for this row, if the file gives one.
    pub paper_iou: Option<f32>,
    /// Mean over seeds of the max-pool IoU (NMR protocol).
    pub mean_iou: f32,
    /// The training seeds, and the mean IoU of each.
    #[serde(default)]
    pub seeds: Vec<u64>,
    #[serde(default)]
    pub seed_ious: Vec<f32>,
    /// Per seed and evaluation object (`s<seed>/<category>/<id>`): its IoU.
    #[serde(default)]
    pub per_seed_object: BTreeMap<String, f32>,
    /// Per seed and evaluation object, as `per_seed_object`: the mean over its meshed views of
    /// Chamfer-L1 and of normal consistency (empty without meshes or ground-truth meshes), so
    /// that rows are paired on the surface metrics too.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub per_seed_object_chamfer: BTreeMap<String, f32>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub per_seed_object_normals: BTreeMap<String, f32>,
    /// Means over seeds of the centre-sampled IoU, the share of volume outside the visual hull,
    /// and the mesh metrics (averaged over categories; absent without meshes).
    #[serde(default)]
    pub centre_iou: f32,
    #[serde(default)]
    pub outside_hull: f32,
    #[serde(default)]
    pub mesh_iou: Option<f32>,
    #[serde(default)]
    pub chamfer_l1: Option<f32>,
    #[serde(default)]
    pub normal_consistency: Option<f32>,
    /// The first seed's per-category metrics.
    pub per_category: BTreeMap<String, CategoryMetrics>,
    pub visual_hull_iou: f32,
    pub mean_shape_iou: Option<f32>,
    /// Summed over seeds.
    pub train_seconds: f64,
    pub eval_seconds: f64,
    /// Field evaluations of the silhouette term in training, summed over seeds
    /// (`Metrics::train_decoder_points`).
    #[serde(default)]
    pub train_decoder_points: u64,
    pub steps: usize,
    /// Means over seeds of the last logged interval's loss and its terms.
    pub final_loss: Option<f32>,
    #[serde(default)]
    pub final_silhouette_loss: Option<f32>,
    #[serde(default)]
    pub final_regularizer_loss: Option<f32>,
    /// The first seed's training loss history: `(step, mean loss of the logged interval)`.
    pub loss_history: Vec<(usize, f32)>,
}

fn mean_f32(v: impl IntoIterator<Item = f32>) -> Option<f32> {
    let v: Vec<f32> = v.into_iter().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f32>() / v.len() as f32)
}

/// The mean of a per-category mesh metric over the categories that have it.
fn mesh_mean(m: &Metrics, f: impl Fn(&MeshMetrics) -> Option<f32>) -> Option<f32> {
    mean_f32(
        m.per_category
            .values()
            .filter_map(|c| c.mesh.as_ref().and_then(&f)),
    )
}

/// One finished training run of an entry.
#[derive(Clone, Debug)]
pub struct SeedRun {
    pub seed: u64,
    pub metrics: Metrics,
    pub history: Vec<(usize, f32)>,
    /// Its `objects.csv` (empty when the run has none).
    pub predictions: Vec<PredictionScores>,
}

/// Per seed and object (`s<seed>/<category>/<id>`): the mean of `f` over the run's predictions
/// that have it (the meshed views).
fn per_seed_object_mean(
    runs: &[SeedRun],
    f: impl Fn(&PredictionScores) -> Option<f32>,
) -> BTreeMap<String, f32> {
    let mut sums: BTreeMap<String, (f32, usize)> = BTreeMap::new();
    for r in runs {
        for p in &r.predictions {
            if let Some(v) = f(p) {
                let e = sums
                    .entry(format!("s{}/{}/{}", r.seed, p.category, p.object))
                    .or_default();
                e.0 += v;
                e.1 += 1;
            }
        }
    }
    sums.into_iter()
        .map(|(k, (sum, n))| (k, sum / n as f32))
        .collect()
}

impl AblationEntry {
    /// The entry of `variant` from its runs (one per seed, at least one).
    pub fn new(variant: &Variant, runs: &[SeedRun]) -> Self {
        let first = &runs[0].metrics;
        let over = |f: &dyn Fn(&Metrics) -> Option<f32>| {
            let v: Vec<f32> = runs.iter().filter_map(|r| f(&r.metrics)).collect();
            (v.len() == runs.len()).then(|| mean_f32(v)).flatten()
        };
        let per_seed_object = runs
            .iter()
            .flat_map(|r| {
                r.metrics.per_category.iter().flat_map(move |(c, m)| {
                    m.per_object
                        .iter()
                        .map(move |(id, v)| (format!("s{}/{c}/{id}", r.seed), *v))
                })
            })
            .collect();
        Self {
            variant: variant.name.clone(),
            dir: variant.slug.clone(),
            overrides: variant.overrides.clone(),
            paper_iou: variant.paper_iou,
            mean_iou: over(&|m| Some(m.mean_iou)).unwrap_or(0.0),
            seeds: runs.iter().map(|r| r.seed).collect(),
            seed_ious: runs.iter().map(|r| r.metrics.mean_iou).collect(),
            per_seed_object,
            per_seed_object_chamfer: per_seed_object_mean(runs, |p| p.chamfer_l1),
            per_seed_object_normals: per_seed_object_mean(runs, |p| p.normal_consistency),
            centre_iou: over(&|m| Some(m.centre_iou)).unwrap_or(0.0),
            outside_hull: over(&|m| Some(m.outside_hull)).unwrap_or(0.0),
            mesh_iou: over(&|m| mesh_mean(m, |x| Some(x.iou))),
            chamfer_l1: over(&|m| mesh_mean(m, |x| x.chamfer_l1)),
            normal_consistency: over(&|m| mesh_mean(m, |x| x.normal_consistency)),
            per_category: first.per_category.clone(),
            visual_hull_iou: first.visual_hull_iou,
            mean_shape_iou: first.mean_shape_iou,
            train_seconds: runs.iter().map(|r| r.metrics.train_seconds).sum(),
            eval_seconds: runs.iter().map(|r| r.metrics.eval_seconds).sum(),
            train_decoder_points: runs.iter().map(|r| r.metrics.train_decoder_points).sum(),
            steps: first.steps,
            final_loss: over(&|m| m.final_loss),
            final_silhouette_loss: over(&|m| m.final_silhouette_loss),
            final_regularizer_loss: over(&|m| m.final_regularizer_loss),
            loss_history: runs[0].history.clone(),
        }
    }

    /// Per seed and evaluation object (`s<seed>/<category>/<id>`): its IoU. Rows are paired on
    /// these keys, so a pair's noise covers both the objects and the training seeds.
    pub fn per_object(&self) -> BTreeMap<String, f32> {
        if !self.per_seed_object.is_empty() {
            return self.per_seed_object.clone();
        }
        self.per_category
            .iter()
            .flat_map(|(c, m)| {
                m.per_object
                    .iter()
                    .map(move |(id, v)| (format!("{c}/{id}"), *v))
            })
            .collect()
    }
}

/// Where an entry stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    Pending,
    Finished(Box<AblationEntry>),
    Failed(String),
}

/// The finished entries, in file order (the base first).
pub fn finished(status: &[Status]) -> Vec<&AblationEntry> {
    status
        .iter()
        .filter_map(|s| match s {
            Status::Finished(e) => Some(e.as_ref()),
            _ => None,
        })
        .collect()
}
