//! The ablation's pictures: every entry's training curve, and `samples.png` (where the base's
//! samplers put rays and anchors against a comparison sampler).

use std::path::Path;

use anyhow::{Result, anyhow};
use fieldprobe::ablation::entry::Status;
use fieldprobe::loader::CategoryData;
use fieldprobe::probe::{AnchorSamplerConfig, RaySamplerConfig};
use fieldprobe::train::step_rng;
use fieldprobe::variants::{AblationFile, inline_of};

use crate::charts::{self, LineChart, Series};
use crate::plot;

/// What `samples.png` shows, for the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SamplesInfo {
    /// E.g. "the first training chair, view 3".
    pub object: String,
    /// The left column's samplers (the base's).
    pub left: String,
    /// The right column's samplers and where they come from.
    pub right: String,
    pub rays: usize,
    pub anchors: usize,
}

/// The view shown in `samples.png` (45° azimuth, like the paper's figure a view off the front).
pub const SAMPLE_VIEW: usize = 3;
/// Zoom of the 64² silhouettes in `samples.png`.
const SAMPLE_ZOOM: u32 = 4;

/// The loss history of every finished entry (entry `i` in colour `i`, labelled with its name),
/// log y; an entry trained with several seeds shows its first seed's curve.
pub fn training_curves(status: &[Status]) -> LineChart {
    let series = status
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s {
            Status::Finished(e) => Some(Series {
                label: e.variant.clone(),
                points: charts::points(&e.loss_history),
                color: plot::color(i).1,
            }),
            _ => None,
        })
        .collect();
    LineChart {
        title: "Training loss per ablation entry".into(),
        x_label: "training step".into(),
        y_label: "loss, mean per logged interval".into(),
        log_y: true,
        markers: false,
        series,
    }
}

/// Draws, for the first training object of the base's first category and view [`SAMPLE_VIEW`],
/// the base's samplers (left column) against a comparison (right column): the first variant that
/// changes a sampler, else `type = "normal"` (the paper's N(0, 0.4) comparison) for both. Top row:
/// one view's rays (`probe.rays_per_view` pixels, dots); bottom row: one object's anchors
/// (`probe.anchors` points) projected into the same view. Dots are red on the left, blue on the
/// right, over the grey silhouette.
pub fn write_samples(
    path: &Path,
    file: &AblationFile,
    data: &[CategoryData],
) -> Result<SamplesInfo> {
    let base = &file.base().experiment;
    let probe = &base.probe;
    let key = |r: &dyn RaySamplerConfig, a: &dyn AnchorSamplerConfig| {
        (
            serde_json::to_string(r).unwrap_or_default(),
            serde_json::to_string(a).unwrap_or_default(),
        )
    };
    let base_key = key(probe.ray_sampler.as_ref(), probe.anchor_sampler.as_ref());
    let other = file.entries[1..].iter().find(|v| {
        let p = &v.experiment.probe;
        key(p.ray_sampler.as_ref(), p.anchor_sampler.as_ref()) != base_key
    });
    let normal_rays: Box<dyn RaySamplerConfig>;
    let normal_anchors: Box<dyn AnchorSamplerConfig>;
    let (rays_b, anchors_b, from): (&dyn RaySamplerConfig, &dyn AnchorSamplerConfig, String) =
        match other {
            Some(v) => (
                v.experiment.probe.ray_sampler.as_ref(),
                v.experiment.probe.anchor_sampler.as_ref(),
                format!("variant '{}'", v.name),
            ),
            None => {
                normal_rays = toml::from_str("type = \"normal\"")?;
                normal_anchors = toml::from_str("type = \"normal\"")?;
                (
                    normal_rays.as_ref(),
                    normal_anchors.as_ref(),
                    "the paper's comparison (no variant changes a sampler)".into(),
                )
            }
        };
    let cat = data
        .first()
        .filter(|c| !c.train.is_empty())
        .ok_or_else(|| {
            anyhow!(
                "{}: no training objects to draw samples of",
                file.path.display()
            )
        })?;
    let object = &cat.train[0].supervision;
    let view = SAMPLE_VIEW.min(object.cameras.len() - 1);
    let sil = &object.silhouettes[view];
    let cam = &object.cameras[view];
    let mut columns = Vec::new();
    for (c, (rc, ac)) in [
        (probe.ray_sampler.as_ref(), probe.anchor_sampler.as_ref()),
        (rays_b, anchors_b),
    ]
    .into_iter()
    .enumerate()
    {
        let where_ = |e: String| anyhow!("{}: samples.png: {e}", file.path.display());
        let rays = rc.build().map_err(where_)?;
        let anchors = ac.build().map_err(where_)?;
        let color = if c == 0 {
            plot::color(3).1
        } else {
            plot::color(0).1
        };
        let mut rng = step_rng(base.seed, 0, 1000 + c);
        let px: Vec<(f32, f32)> = rays
            .sample_pixels(object, view, probe.spec.rays_per_view, &mut rng)
            .iter()
            .map(|p| (p.col, p.row))
            .collect();
        let pts: Vec<(f32, f32)> = anchors
            .sample_anchors(object, probe.spec.anchors, &mut rng)
            .into_iter()
            .filter_map(|a| {
                let (p, depth) = cam.project(a);
                (depth > 0.0).then_some((p.col, p.row))
            })
            .collect();
        let mut top = plot::silhouette_panel(sil, SAMPLE_ZOOM);
        plot::dots(&mut top, &px, SAMPLE_ZOOM, 3, color);
        let mut bottom = plot::silhouette_panel(sil, SAMPLE_ZOOM);
        plot::dots(&mut bottom, &pts, SAMPLE_ZOOM, 2, color);
        columns.push((top, bottom));
    }
    let [(a_top, a_bottom), (b_top, b_bottom)]: [_; 2] = columns.try_into().expect("two columns");
    let img = plot::grid(
        &[vec![a_top, b_top], vec![a_bottom, b_bottom]],
        8,
        image::Rgb([60, 60, 68]),
    );
    plot::write_png(path, &img)?;
    Ok(SamplesInfo {
        object: format!(
            "the first training {} of `{}`, view {view} of 24",
            cat.category.name(),
            base.data.dir.display()
        ),
        left: format!(
            "the base '{}': rays {}, anchors {}",
            file.base().name,
            inline_of(probe.ray_sampler.as_ref()),
            inline_of(probe.anchor_sampler.as_ref())
        ),
        right: format!(
            "{from}: rays {}, anchors {}",
            inline_of(rays_b),
            inline_of(anchors_b)
        ),
        rays: probe.spec.rays_per_view,
        anchors: probe.spec.anchors,
    })
}
