//! Evaluating a trained model on an experiment's data, in the NMR protocol, with the references
//! that give the numbers context (see `fieldprobe_core::eval`).

use std::collections::BTreeMap;

use std::path::Path;

use anyhow::Result;
use burn::prelude::*;
use fieldprobe_core::data::voxelize::voxelize_nmr;
use fieldprobe_core::data::{TriMesh, VoxelGrid};
use fieldprobe_core::eval::surface::{
    SurfaceMetrics, SurfaceSample, outer_surface, sample_surface, surface_metrics,
};
use fieldprobe_core::eval::{
    encode_views, extract_field_mesh, mean_shape, object_hull, predict_grids,
    render_field_silhouette,
};
use fieldprobe_core::field::FieldModel;
use fieldprobe_core::geometry::NUM_VIEWS;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::data::CategoryData;
use crate::experiment::EvalConfig;

/// Metrics of one category.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CategoryMetrics {
    /// Mean 3D IoU of the model over objects × input views.
    pub iou: f32,
    /// Mean IoU of each object's 24-view visual hull (centre test).
    pub visual_hull_iou: f32,
    /// Mean IoU of the category mean shape (mean of training visual hulls, ≥ ½); absent for a
    /// per-object fit.
    pub mean_shape_iou: Option<f32>,
    /// Mean IoU of the mean training ground truth (≥ ½), a prior that needs 3D data.
    pub mean_gt_shape_iou: Option<f32>,
    /// Mean IoU of the fitted field's rendered silhouettes vs the input ones (per-object fits).
    pub silhouette_iou: Option<f32>,
    pub objects: usize,
    /// Input views per object.
    pub views: usize,
    /// Per object: id and mean IoU.
    pub per_object: Vec<(String, f32)>,
    /// Metrics of extracted meshes (absent when `eval.mesh_views = 0`).
    #[serde(default)]
    pub mesh: Option<MeshMetrics>,
}

fn mean(v: &[f32]) -> f32 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f32>() / v.len() as f32
    }
}

/// The input views used per object: `n` evenly spaced of the 24.
pub fn eval_views(n: usize) -> Vec<usize> {
    (0..n).map(|i| i * NUM_VIEWS / n).collect()
}

/// Metrics of the meshes extracted from a category's predictions (see [`evaluate`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshMetrics {
    /// Input views meshed per object.
    pub views: usize,
    /// Meshes extracted (objects × views).
    pub meshes: usize,
    /// Meshes that came out empty (scored as the worst case, not skipped).
    pub empty: usize,
    /// NMR-protocol IoU of the extracted meshes: NMR's surface voxelization + fill of each mesh
    /// against the ground-truth voxels.
    pub iou: f32,
    /// The 32³ grid IoU of the same predictions, for comparison.
    pub grid_iou: f32,
    /// Chamfer-L1 (not ×10), F-score and normal consistency against the ground-truth meshes;
    /// absent when the dataset has no meshes (`DATA/meshes/<synset>/<id>.obj`).
    pub chamfer_l1: Option<f32>,
    pub fscore: Option<f32>,
    pub normal_consistency: Option<f32>,
    /// Points sampled per surface, and the F-score threshold.
    pub surface_points: usize,
    pub fscore_threshold: f32,
}

/// The views of `views` that are meshed: `n` evenly spaced among them.
pub fn meshed_views(views: &[usize], n: usize) -> Vec<usize> {
    (0..n.min(views.len()))
        .map(|i| views[i * views.len() / n.min(views.len())])
        .collect()
}

/// The reference sample of a ground-truth mesh: `cfg.surface_points` points on its outer surface
/// (see `eval::surface::outer_surface`), drawn with `seed`.
pub fn reference_surface(mesh: &TriMesh, cfg: &EvalConfig, seed: u64) -> SurfaceSample {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    outer_surface(mesh, sample_surface(mesh, cfg.surface_points, &mut rng))
}

/// [`reference_surface`] of the ground-truth mesh at `path`, if the dataset has it.
fn gt_surface(path: &Path, cfg: &EvalConfig, seed: u64) -> Result<Option<SurfaceSample>> {
    if !path.is_file() {
        return Ok(None);
    }
    Ok(Some(reference_surface(
        &TriMesh::load_obj(path)?,
        cfg,
        seed,
    )))
}

/// One prediction's mesh scores: mesh IoU, grid IoU, surface metrics.
struct MeshScore {
    iou: f32,
    grid_iou: f32,
    empty: bool,
    surface: Option<SurfaceMetrics>,
}

/// Scores the mesh extracted from one latent against an object's ground truth.
pub fn score_mesh(
    mesh: &TriMesh,
    gt_voxels: &VoxelGrid,
    gt_surface: Option<&SurfaceSample>,
    cfg: &EvalConfig,
    seed: u64,
) -> (f32, Option<SurfaceMetrics>) {
    let iou = voxelize_nmr(mesh, gt_voxels.resolution()).iou(gt_voxels);
    let surface = gt_surface.map(|gt| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let pred = sample_surface(mesh, cfg.surface_points, &mut rng);
        surface_metrics(&pred, gt, cfg.fscore_threshold)
    });
    (iou, surface)
}

/// Evaluates `model` (in evaluation mode, on the plain `device`) on every category; `mesh_dir`
/// is the dataset's `meshes/` folder (ground-truth meshes for the surface metrics), if any.
pub fn evaluate(
    model: &FieldModel,
    data: &[CategoryData],
    cfg: &EvalConfig,
    per_object_fit: bool,
    mesh_dir: Option<&Path>,
    device: &Device,
) -> Result<BTreeMap<String, CategoryMetrics>> {
    let views = eval_views(cfg.views);
    let total: usize = data.iter().map(|c| c.eval.len()).sum();
    let bar = crate::progress::Progress::new("eval", total, 0);
    let mut out = BTreeMap::new();
    for cat in data {
        let res = cfg.resolution;
        let (mean_hull, mean_gt) = if per_object_fit {
            (None, None)
        } else {
            let hulls: Vec<_> = cat.train.iter().map(|o| object_hull(o, res)).collect();
            (mean_shape(&hulls), mean_shape(&cat.train_gt))
        };
        let (mut ious, mut hull_ious, mut ms, mut mg, mut sils, mut per_object) = (
            Vec::new(),
            Vec::new(),
            Vec::new(),
            Vec::new(),
            Vec::new(),
            Vec::new(),
        );
        let mut mesh_scores: Vec<MeshScore> = Vec::new();
        for (o, ((obj, gt), id)) in cat
            .eval
            .iter()
            .zip(&cat.eval_gt)
            .zip(&cat.eval_ids)
            .enumerate()
        {
            let latents = encode_views(model, obj, device);
            let preds = predict_grids(model, latents.as_ref(), &views, res, device);
            let obj_iou = mean(&preds.iter().map(|p| p.iou(gt)).collect::<Vec<_>>());
            ious.push(obj_iou);
            per_object.push((id.clone(), obj_iou));
            hull_ious.push(object_hull(obj, res).iou(gt));
            if let Some(m) = &mean_hull {
                ms.push(m.iou(gt));
            }
            if let Some(m) = &mean_gt {
                mg.push(m.iou(gt));
            }
            if cfg.mesh_views > 0 {
                let gt_mesh =
                    mesh_dir.map(|d| d.join(cat.category.synset()).join(format!("{id}.obj")));
                let gt_surf = match &gt_mesh {
                    Some(p) => gt_surface(p, cfg, o as u64)?,
                    None => None,
                };
                // (prediction index in `preds`, latent) per meshed view.
                let meshed: Vec<(usize, Option<Tensor<2>>)> = match &latents {
                    Some(l) => meshed_views(&views, cfg.mesh_views)
                        .into_iter()
                        .map(|v| {
                            let i = views
                                .iter()
                                .position(|&w| w == v)
                                .expect("a evaluated view");
                            (i, Some(l.clone().narrow(0, v, 1)))
                        })
                        .collect(),
                    None => vec![(0, None)],
                };
                for (i, z) in meshed {
                    let mesh = extract_field_mesh(model, z.as_ref(), &cfg.extract, device);
                    let (iou, surface) =
                        score_mesh(&mesh, gt, gt_surf.as_ref(), cfg, 1000 + o as u64);
                    mesh_scores.push(MeshScore {
                        iou,
                        grid_iou: preds[i].iou(gt),
                        empty: mesh.faces.is_empty(),
                        surface,
                    });
                }
            }
            if per_object_fit {
                let s: Vec<f32> = obj
                    .supervision
                    .cameras
                    .iter()
                    .zip(&obj.supervision.silhouettes)
                    .enumerate()
                    .map(|(v, (cam, gt_sil))| {
                        let z = latents.as_ref().map(|l| l.clone().narrow(0, v, 1));
                        render_field_silhouette(
                            model,
                            z.as_ref(),
                            cam,
                            cfg.silhouette_samples,
                            device,
                        )
                        .iou(gt_sil)
                    })
                    .collect();
                sils.push(mean(&s));
            }
            bar.inc();
        }
        out.insert(
            cat.category.name().to_string(),
            CategoryMetrics {
                iou: mean(&ious),
                visual_hull_iou: mean(&hull_ious),
                mean_shape_iou: (!ms.is_empty()).then(|| mean(&ms)),
                mean_gt_shape_iou: (!mg.is_empty()).then(|| mean(&mg)),
                silhouette_iou: (!sils.is_empty()).then(|| mean(&sils)),
                objects: cat.eval.len(),
                views: if per_object_fit { 1 } else { views.len() },
                per_object,
                mesh: summarize(&mesh_scores, cfg, cat.eval.len()),
            },
        );
    }
    bar.finish();
    Ok(out)
}

/// The category's mesh metrics from its per-mesh scores (surface metrics only when every object
/// had a ground-truth mesh, so the mean is over the same meshes as the IoU).
fn summarize(scores: &[MeshScore], cfg: &EvalConfig, objects: usize) -> Option<MeshMetrics> {
    if scores.is_empty() {
        return None;
    }
    let surf: Vec<SurfaceMetrics> = scores.iter().filter_map(|s| s.surface).collect();
    let all = surf.len() == scores.len();
    let avg =
        |f: fn(&SurfaceMetrics) -> f32| all.then(|| mean(&surf.iter().map(f).collect::<Vec<_>>()));
    Some(MeshMetrics {
        views: scores.len() / objects.max(1),
        meshes: scores.len(),
        empty: scores.iter().filter(|s| s.empty).count(),
        iou: mean(&scores.iter().map(|s| s.iou).collect::<Vec<_>>()),
        grid_iou: mean(&scores.iter().map(|s| s.grid_iou).collect::<Vec<_>>()),
        chamfer_l1: avg(|m| m.chamfer_l1),
        fscore: avg(|m| m.fscore),
        normal_consistency: avg(|m| m.normal_consistency),
        surface_points: cfg.surface_points,
        fscore_threshold: cfg.fscore_threshold,
    })
}
