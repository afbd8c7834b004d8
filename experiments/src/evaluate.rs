//! Evaluating a trained model on an experiment's data, in the NMR protocol, with the references
//! that give the numbers context (see `fieldprobe_core::eval`).

use std::collections::BTreeMap;

use burn::prelude::*;
use fieldprobe_core::eval::{
    encode_views, mean_shape, object_hull, predict_grids, render_field_silhouette,
};
use fieldprobe_core::field::FieldModel;
use fieldprobe_core::geometry::NUM_VIEWS;
use indicatif::ProgressBar;
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

/// Evaluates `model` (in evaluation mode, on the plain `device`) on every category.
pub fn evaluate(
    model: &FieldModel,
    data: &[CategoryData],
    cfg: &EvalConfig,
    per_object_fit: bool,
    device: &Device,
) -> BTreeMap<String, CategoryMetrics> {
    let views = eval_views(cfg.views);
    let total: usize = data.iter().map(|c| c.eval.len()).sum();
    let bar = ProgressBar::new(total as u64).with_style(crate::progress::style("eval"));
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
        for ((obj, gt), id) in cat.eval.iter().zip(&cat.eval_gt).zip(&cat.eval_ids) {
            let preds = predict_grids(model, obj, &views, res, device);
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
            if per_object_fit {
                let latent = encode_views(model, obj, device);
                let s: Vec<f32> = obj
                    .supervision
                    .cameras
                    .iter()
                    .zip(&obj.supervision.silhouettes)
                    .enumerate()
                    .map(|(v, (cam, gt_sil))| {
                        let z = latent.as_ref().map(|l| l.clone().narrow(0, v, 1));
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
            bar.inc(1);
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
            },
        );
    }
    bar.finish_and_clear();
    out
}
