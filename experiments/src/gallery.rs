//! `gallery.png`: what a run predicts for a few test objects, one row each —
//!
//! ```text
//! input image | predicted vs true silhouette at 3 views | turntable of the extracted mesh (4 frames)
//! ```
//!
//! The input is the object's first evaluated view. Silhouettes are rendered from the field
//! (`eval::render_field_silhouette` through the run's aggregator; with the max, the dense max-pool probe) at the input view and at the views a
//! quarter and a half turn away (+6 and +12 of NMR's 24), coloured as in
//! [`crate::pictures::silhouette_overlay`]: grey both, red predicted only, blue true only. The
//! turntable shows the mesh the metrics use.
//!
//! Each row's input is also saved as an RGBA PNG in `inputs/<category>_<id>_v<view>.png`, the
//! kind of picture `reconstruct --image` takes.

use std::path::Path;

use anyhow::Result;
use burn::prelude::*;
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::eval::{encode_views, extract_field_mesh, render_field_silhouette};
use fieldprobe_core::field::Field;
use fieldprobe_core::geometry::NUM_VIEWS;
use fieldprobe_core::probe::Aggregator;

use crate::{pictures, plot};
use fieldprobe::evaluate::{GalleryMeshes, eval_views, gallery_key};
use fieldprobe::experiment::EvalConfig;
use fieldprobe::loader::CategoryData;

/// Panel side in pixels.
const PANEL: u32 = 128;
/// Turntable frames per row.
const FRAMES: usize = 4;
/// Offsets of the silhouette views from the input view.
const VIEW_OFFSETS: [usize; 3] = [0, 6, 12];

/// One gallery row: which object and view it shows.
#[derive(Clone, Debug, PartialEq)]
pub struct GalleryRow {
    pub category: String,
    pub id: String,
    pub view: usize,
    /// The input picture, relative to the run directory.
    pub input: String,
    /// Faces of the extracted mesh (0: the field is empty at ½).
    pub faces: usize,
}

/// Writes `dir/gallery.png` of the first `cfg.gallery_objects` test objects of each category
/// and their inputs to `dir/inputs/`; returns its rows (none, and no file, when
/// `gallery_objects` is 0). Meshes come from `meshes` (those evaluation extracted) and are
/// extracted here only when evaluation made none.
pub fn write(
    dir: &Path,
    model: &dyn Field,
    aggregator: &dyn Aggregator,
    data: &[CategoryData],
    meshes: &GalleryMeshes,
    cfg: &EvalConfig,
    device: &Device,
) -> Result<Vec<GalleryRow>> {
    let mut rows = Vec::new();
    let mut panels: Vec<Vec<image::RgbImage>> = Vec::new();
    let view = eval_views(cfg.views)[0];
    for cat in data {
        for (obj, id) in cat.eval.iter().zip(&cat.eval_ids).take(cfg.gallery_objects) {
            let latents = encode_views(model, obj, device);
            let z = latents.map(|l| l.narrow(0, view, 1));
            let s = obj.image_size;
            let n = 4 * s * s;
            let input = &obj.images[view * n..(view + 1) * n];
            let rel = format!("inputs/{}_{id}_v{view:02}.png", cat.category.name());
            let png = dir.join(&rel);
            write_atomic(&png, |w| {
                pictures::input_rgba(input, s)
                    .write_to(w, image::ImageFormat::Png)
                    .map_err(std::io::Error::other)
            })?;
            let mut row = vec![pictures::fit(&pictures::input_image(input, s, 1), PANEL)];
            for off in VIEW_OFFSETS {
                let w = (view + off) % NUM_VIEWS;
                let cam = &obj.supervision.cameras[w];
                let pred = render_field_silhouette(
                    model,
                    z.as_ref(),
                    cam,
                    cfg.silhouette_samples,
                    aggregator,
                    device,
                );
                let overlay =
                    pictures::silhouette_overlay(&pred, &obj.supervision.silhouettes[w], 1);
                row.push(pictures::fit(&overlay, PANEL));
            }
            let extracted;
            let mesh = match meshes.get(&gallery_key(cat.category, id)) {
                Some(m) => m,
                None => {
                    extracted = extract_field_mesh(model, z.as_ref(), &cfg.extract, device);
                    &extracted
                }
            };
            row.extend(pictures::turntable(mesh, FRAMES, PANEL as usize));
            panels.push(row);
            rows.push(GalleryRow {
                category: cat.category.name().into(),
                id: id.clone(),
                view,
                input: rel,
                faces: mesh.faces.len(),
            });
        }
    }
    if !panels.is_empty() {
        plot::write_png(
            &dir.join("gallery.png"),
            &plot::grid(&panels, 4, plot::WHITE),
        )?;
    }
    Ok(rows)
}
