//! Evaluating a trained model on an experiment's data, in the NMR protocol, with the references
//! that give the numbers context (see `fieldprobe_core::eval`).

use std::collections::BTreeMap;

use std::path::Path;

use anyhow::Result;
use burn::prelude::*;
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::data::voxelize::voxelize_nmr;
use fieldprobe_core::data::{Category, TriMesh, VoxelGrid};
use fieldprobe_core::eval::surface::{
    SurfaceMetrics, SurfaceSample, outer_surface, sample_surface, surface_metrics,
};
use fieldprobe_core::eval::{
    encode_views, extract_field_mesh, mean_shape, object_hull, predict_all_views,
    render_field_silhouette,
};
use fieldprobe_core::extract::write_ply;
use fieldprobe_core::field::Field;
use fieldprobe_core::geometry::NUM_VIEWS;
use fieldprobe_core::probe::Aggregator;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::experiment::EvalConfig;
use crate::loader::CategoryData;

/// Metrics of one category. Every IoU is at 32³ in the NMR protocol: a field's voxel is
/// occupied when φ reaches ½ anywhere in it (max over `eval.subsamples³` points; see
/// `fieldprobe_core::eval::occupancy`), the references are converted the same way.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CategoryMetrics {
    /// Mean max-pool IoU of the model over objects × input views.
    pub iou: f32,
    /// The same predictions read only at the voxel centres (not dilated like the ground truth:
    /// a secondary number that pays over-sized fields).
    #[serde(default)]
    pub centre_iou: f32,
    /// Mean share of each prediction's voxels that lie outside the object's 24-view visual hull
    /// (both max-pooled): volume grown where the silhouettes say nothing is.
    #[serde(default)]
    pub outside_hull: f32,
    /// Mean IoU of each object's 24-view visual hull.
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
    /// Per object: id and mean max-pool IoU.
    pub per_object: Vec<(String, f32)>,
    /// Metrics of extracted meshes (absent when `eval.mesh_views = 0`).
    #[serde(default)]
    pub mesh: Option<MeshMetrics>,
}

/// `min(k, n)` indices spread evenly over `0..n`, the first at 0 (none when `k` is 0): how the
/// evaluated views, the meshed views and the reference objects are picked.
fn evenly_spaced(n: usize, k: usize) -> Vec<usize> {
    let k = k.min(n);
    (0..k).map(|j| j * n / k).collect()
}

/// The training objects the mean-shape references are built from: `eval.reference_objects` of
/// the `n`, evenly spaced (0 = all).
fn reference_picks(n: usize, reference_objects: usize) -> Vec<usize> {
    evenly_spaced(
        n,
        if reference_objects == 0 {
            n
        } else {
            reference_objects
        },
    )
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
    evenly_spaced(NUM_VIEWS, n)
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
    /// The max-pool IoU of the same predictions, for comparison.
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
    evenly_spaced(views.len(), n)
        .into_iter()
        .map(|i| views[i])
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

/// The scores of one prediction (an object seen from one input view): a row of `objects.csv`.
/// Mesh columns are empty for views that were not meshed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PredictionScores {
    pub category: String,
    pub object: String,
    /// The input view (empty for a per-object fit, which reads no image).
    pub view: Option<usize>,
    /// Max-pool IoU (the NMR protocol).
    pub iou: f32,
    /// The same prediction read at voxel centres.
    pub centre_iou: f32,
    /// Share of the predicted voxels outside the object's 24-view visual hull.
    pub outside_hull: f32,
    /// The object's 24-view visual hull IoU (the same on every row of the object).
    pub visual_hull_iou: f32,
    /// NMR-protocol IoU of the extracted mesh.
    pub mesh_iou: Option<f32>,
    pub chamfer_l1: Option<f32>,
    pub fscore: Option<f32>,
    pub normal_consistency: Option<f32>,
    /// The saved mesh, relative to the run directory (`eval.save_meshes`).
    pub mesh_file: Option<String>,
}

/// What [`evaluate`] measured, and the meshes a report can show without extracting them again.
#[derive(Debug, Default)]
pub struct Evaluation {
    /// Per category name.
    pub per_category: BTreeMap<String, CategoryMetrics>,
    /// Every prediction's scores, in evaluation order (what `objects.csv` holds).
    pub predictions: Vec<PredictionScores>,
    /// The mesh of the first evaluated view of each of the first `eval.gallery_objects` test
    /// objects per category (what `gallery.png` shows), keyed by `(category name, object id)`;
    /// empty when `eval.mesh_views` is 0 (no meshes were extracted).
    pub gallery_meshes: GalleryMeshes,
    /// Field points evaluated to convert the predictions to voxels (centres and max-pool lattice
    /// points, summed over predictions; meshes and references not counted): most of the
    /// evaluation's cost, and what makes a blurry field slow to evaluate (see
    /// `fieldprobe_core::eval::occupancy`).
    pub grid_points: u64,
}

/// Meshes by [`gallery_key`].
pub type GalleryMeshes = BTreeMap<(String, String), TriMesh>;

/// The key of an object's mesh in [`GalleryMeshes`]: `(category name, object id)`.
pub fn gallery_key(category: Category, id: &str) -> (String, String) {
    (category.name().to_string(), id.to_string())
}

/// Evaluates `model` (in evaluation mode, on the plain `device`) on every category (field
/// silhouettes through `aggregator`, the run's); `mesh_dir` is the dataset's `meshes/` folder
/// (ground-truth meshes for the surface metrics), if any; with `save_to` (a run directory) every
/// extracted mesh is written under its `meshes/` as it is made.
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    model: &dyn Field,
    aggregator: &dyn Aggregator,
    data: &[CategoryData],
    cfg: &EvalConfig,
    per_object_fit: bool,
    mesh_dir: Option<&Path>,
    save_to: Option<&Path>,
    device: &Device,
) -> Result<Evaluation> {
    let views = eval_views(cfg.views);
    let mut gallery_meshes = BTreeMap::new();
    let mut predictions = Vec::new();
    let mut grid_points = 0u64;
    let total: usize = data.iter().map(|c| c.eval.len()).sum();
    let bar = crate::progress::bar("eval", total, 0);
    let mut out = BTreeMap::new();
    for cat in data {
        let protocol = cfg.protocol();
        let (mean_hull, mean_gt) = if per_object_fit {
            (None, None)
        } else {
            let picked = reference_picks(cat.train.len(), cfg.reference_objects);
            let hulls: Vec<_> = picked
                .iter()
                .map(|&i| object_hull(&cat.train[i], &protocol).maxpool)
                .collect();
            let gts = picked.iter().map(|&i| &cat.train_gt[i]);
            (mean_shape(&hulls), mean_shape(gts))
        };
        let mut acc = Accumulators::default();
        let mut mesh_scores: Vec<MeshScore> = Vec::new();
        for (o, ((obj, gt), id)) in cat
            .eval
            .iter()
            .zip(&cat.eval_gt)
            .zip(&cat.eval_ids)
            .enumerate()
        {
            let latents = encode_views(model, obj, device);
            let preds = predict_all_views(model, latents.as_ref(), &views, &protocol, device);
            grid_points += preds.iter().map(|p| p.evaluated as u64).sum::<u64>();
            let hull = object_hull(obj, &protocol).maxpool;
            let hull_iou = hull.iou(gt);
            let first_row = predictions.len();
            for (j, p) in preds.iter().enumerate() {
                predictions.push(PredictionScores {
                    category: cat.category.name().to_string(),
                    object: id.clone(),
                    view: latents.is_some().then(|| views[j]),
                    iou: p.maxpool.iou(gt),
                    centre_iou: p.centre.iou(gt),
                    outside_hull: 1.0 - p.maxpool.fraction_inside(&hull),
                    visual_hull_iou: hull_iou,
                    mesh_iou: None,
                    chamfer_l1: None,
                    fscore: None,
                    normal_consistency: None,
                    mesh_file: None,
                });
            }
            let obj_iou = mean(&preds.iter().map(|p| p.maxpool.iou(gt)).collect::<Vec<_>>());
            acc.iou.push(obj_iou);
            acc.centre.extend(preds.iter().map(|p| p.centre.iou(gt)));
            acc.outside
                .extend(preds.iter().map(|p| 1.0 - p.maxpool.fraction_inside(&hull)));
            acc.per_object.push((id.clone(), obj_iou));
            acc.hull.push(hull_iou);
            if let Some(m) = &mean_hull {
                acc.mean_shape.push(m.iou(gt));
            }
            if let Some(m) = &mean_gt {
                acc.mean_gt.push(m.iou(gt));
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
                for (k, (i, z)) in meshed.into_iter().enumerate() {
                    let mesh = extract_field_mesh(model, z.as_ref(), &cfg.extract, device);
                    let (iou, surface) =
                        score_mesh(&mesh, gt, gt_surf.as_ref(), cfg, 1000 + o as u64);
                    let row = &mut predictions[first_row + i];
                    row.mesh_iou = Some(iou);
                    row.chamfer_l1 = surface.map(|m| m.chamfer_l1);
                    row.fscore = surface.map(|m| m.fscore);
                    row.normal_consistency = surface.map(|m| m.normal_consistency);
                    if let Some(run_dir) = save_to {
                        let file = saved_mesh_path(cat.category, id, row.view);
                        write_ply(&mesh, &run_dir.join(&file))?;
                        row.mesh_file = Some(file);
                    }
                    mesh_scores.push(MeshScore {
                        iou,
                        grid_iou: preds[i].maxpool.iou(gt),
                        empty: mesh.faces.is_empty(),
                        surface,
                    });
                    // The first meshed view is the first evaluated one: the gallery's.
                    if k == 0 && o < cfg.gallery_objects {
                        gallery_meshes.insert(gallery_key(cat.category, id), mesh);
                    }
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
                            aggregator,
                            device,
                        )
                        .iou(gt_sil)
                    })
                    .collect();
                acc.silhouette.push(mean(&s));
            }
            bar.inc();
        }
        out.insert(
            cat.category.name().to_string(),
            CategoryMetrics {
                iou: mean(&acc.iou),
                centre_iou: mean(&acc.centre),
                outside_hull: mean(&acc.outside),
                visual_hull_iou: mean(&acc.hull),
                mean_shape_iou: (!acc.mean_shape.is_empty()).then(|| mean(&acc.mean_shape)),
                mean_gt_shape_iou: (!acc.mean_gt.is_empty()).then(|| mean(&acc.mean_gt)),
                silhouette_iou: (!acc.silhouette.is_empty()).then(|| mean(&acc.silhouette)),
                objects: cat.eval.len(),
                views: if per_object_fit { 1 } else { views.len() },
                per_object: acc.per_object,
                mesh: summarize(&mesh_scores, cfg, cat.eval.len()),
            },
        );
    }
    bar.finish();
    Ok(Evaluation {
        per_category: out,
        predictions,
        gallery_meshes,
        grid_points,
    })
}

/// Where a saved test mesh goes in a run directory: `meshes/<synset>/<id>_v<view>.ply`, or
/// `meshes/<synset>/<id>.ply` for a per-object fit (no input view).
pub fn saved_mesh_path(category: Category, id: &str, view: Option<usize>) -> String {
    match view {
        Some(v) => format!("meshes/{}/{id}_v{v:02}.ply", category.synset()),
        None => format!("meshes/{}/{id}.ply", category.synset()),
    }
}

/// Writes `objects.csv`: one row of [`PredictionScores`] per prediction (atomically).
pub fn write_predictions_csv(path: &Path, rows: &[PredictionScores]) -> Result<()> {
    write_atomic(path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        for r in rows {
            csv.serialize(r)?;
        }
        csv.flush()
    })?;
    Ok(())
}

/// Reads an `objects.csv` written by [`write_predictions_csv`]; errors name the file and the row.
pub fn read_predictions_csv(path: &Path) -> Result<Vec<PredictionScores>> {
    let mut csv = csv::Reader::from_path(path)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    csv.deserialize()
        .enumerate()
        .map(|(i, r)| r.map_err(|e| anyhow::anyhow!("{}: row {}: {e}", path.display(), i + 1)))
        .collect()
}

/// A category's per-object (`iou`, `hull`, …) and per-prediction (`centre`, `outside`) scores.
#[derive(Default)]
struct Accumulators {
    iou: Vec<f32>,
    centre: Vec<f32>,
    outside: Vec<f32>,
    hull: Vec<f32>,
    mean_shape: Vec<f32>,
    mean_gt: Vec<f32>,
    silhouette: Vec<f32>,
    per_object: Vec<(String, f32)>,
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

#[cfg(test)]
mod tests {
    use super::{
        PredictionScores, eval_views, meshed_views, read_predictions_csv, reference_picks,
        write_predictions_csv,
    };

    /// `objects.csv` reads back as written, empty mesh columns as `None`; a damaged row is an
    /// error naming the file and the row.
    #[test]
    fn objects_csv_reads_back_what_was_written() {
        let row = |view: Option<usize>, mesh: Option<f32>| PredictionScores {
            category: "chair".into(),
            object: "proc_chair_test_00000".into(),
            view,
            iou: 0.5,
            centre_iou: 0.4,
            outside_hull: 0.25,
            visual_hull_iou: 0.6,
            mesh_iou: mesh,
            chamfer_l1: mesh.map(|m| m / 10.0),
            fscore: mesh,
            normal_consistency: mesh,
            mesh_file: mesh.map(|_| "meshes/03001627/x.ply".into()),
        };
        let rows = vec![
            row(Some(0), Some(0.75)),
            row(Some(6), None),
            row(None, None),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("objects.csv");
        write_predictions_csv(&path, &rows).unwrap();
        assert_eq!(read_predictions_csv(&path).unwrap(), rows);
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        lines[2] = lines[2].replacen(",0.5,", ",half,", 1);
        std::fs::write(&path, lines.join("\n")).unwrap();
        let err = read_predictions_csv(&path).unwrap_err().to_string();
        assert!(
            err.contains("objects.csv") && err.contains("row 2"),
            "{err}"
        );
    }

    #[test]
    fn reference_objects_are_spread_over_the_whole_split() {
        assert_eq!(reference_picks(5, 0), [0, 1, 2, 3, 4]);
        assert_eq!(reference_picks(5, 9), [0, 1, 2, 3, 4]);
        assert_eq!(reference_picks(10, 4), [0, 2, 5, 7]);
        let picked = reference_picks(1000, 256);
        assert_eq!(picked.len(), 256);
        assert!(picked.windows(2).all(|w| w[0] < w[1]));
        assert!(
            *picked.last().unwrap() >= 996,
            "reaches the end of the split"
        );
    }

    /// The view pickers give what their own formulas gave (`i·24/n`; `views[i·len/min(n, len)]`).
    #[test]
    fn views_are_picked_as_before() {
        for n in 1..=24 {
            let old: Vec<usize> = (0..n).map(|i| i * 24 / n).collect();
            assert_eq!(eval_views(n), old, "{n} views");
            for m in 0..=30 {
                let k = m.min(old.len());
                let meshed: Vec<usize> = (0..k).map(|i| old[i * old.len() / k]).collect();
                assert_eq!(meshed_views(&old, m), meshed, "{n} views, {m} meshed");
            }
        }
    }
}
