//! Evaluation in the NMR protocol: 3D IoU at 32³ between the predicted occupancy at the voxel
//! centres of NMR's grid ([`GridFrame`]) and the ground-truth voxels, for every test object and
//! each of its 24 views as input; per category, then the mean over categories.
//!
//! References computed on the same objects, so a number always has context:
//! * the 24-view visual hull (centre test) — what silhouettes alone determine;
//! * the category mean shape — the mean of the training objects' visual hulls, thresholded at ½:
//!   the prior silhouettes alone give; beating it shows the model reads the image;
//! * the mean of the training ground-truth voxels (`mean_gt_shape_iou`), a prior that needs 3D.

use burn::prelude::*;

use crate::data::hull::{HullTest, visual_hull};
use crate::data::{GridFrame, Silhouette, VoxelGrid};
use crate::field::FieldModel;
use crate::geometry::{Camera, NUM_VIEWS, PixelPos};
use crate::train::TrainObject;

/// Points per decoder call when evaluating grids and renders (bounds memory).
const CHUNK: usize = 16_384;

/// World centres of the `res³` grid, `[x][y][z]` order, flattened `[M·3]`.
pub fn grid_points(res: usize) -> Vec<f32> {
    let f = GridFrame::new(res);
    let mut out = Vec::with_capacity(res * res * res * 3);
    for i in 0..res {
        for j in 0..res {
            for k in 0..res {
                out.extend(f.centre(i, j, k).to_array());
            }
        }
    }
    out
}

/// φ at `points` (`[M·3]`) for one latent (`[1, Z]` or none), in chunks; `model` should be in
/// evaluation mode (`valid()`), on `device`.
pub fn field_values(
    model: &FieldModel,
    latent: Option<&Tensor<2>>,
    points: &[f32],
    device: &Device,
) -> Vec<f32> {
    let mut out = Vec::with_capacity(points.len() / 3);
    for chunk in points.chunks(CHUNK * 3) {
        let m = chunk.len() / 3;
        let p = Tensor::<3>::from_data(TensorData::new(chunk.to_vec(), [1, m, 3]), device);
        let v = model.decode(latent.cloned(), p);
        out.extend(v.try_into_vec_as::<f32>().expect("f32 field values"));
    }
    out
}

/// Latents `[24, Z]` of all views of an object (none for a per-object field).
pub fn encode_views(model: &FieldModel, obj: &TrainObject, device: &Device) -> Option<Tensor<2>> {
    let s = obj.image_size;
    let px: Vec<f32> = (0..NUM_VIEWS).flat_map(|v| obj.view(v)).collect();
    model.encode(Tensor::<4>::from_data(
        TensorData::new(px, [NUM_VIEWS, 4, s, s]),
        device,
    ))
}

/// The grid thresholded at ½.
pub fn occupancy_grid(values: &[f32], res: usize) -> VoxelGrid {
    VoxelGrid {
        frame: GridFrame::new(res),
        data: values.iter().map(|&v| v >= 0.5).collect(),
    }
}

/// Predicted voxel grids of an object, one per input view in `views` (a single one for a
/// per-object field).
pub fn predict_grids(
    model: &FieldModel,
    obj: &TrainObject,
    views: &[usize],
    res: usize,
    device: &Device,
) -> Vec<VoxelGrid> {
    let points = grid_points(res);
    match encode_views(model, obj, device) {
        Some(latents) => views
            .iter()
            .map(|&v| {
                let z = latents.clone().narrow(0, v, 1);
                occupancy_grid(&field_values(model, Some(&z), &points, device), res)
            })
            .collect(),
        None => vec![occupancy_grid(
            &field_values(model, None, &points, device),
            res,
        )],
    }
}

/// The centre-test 24-view visual hull of an object.
pub fn object_hull(obj: &TrainObject, res: usize) -> VoxelGrid {
    visual_hull(
        &obj.supervision.silhouettes,
        &obj.supervision.cameras,
        res,
        HullTest::Centre,
    )
}

/// Per-voxel mean of `grids`, thresholded at ½.
pub fn mean_shape(grids: &[VoxelGrid]) -> Option<VoxelGrid> {
    let first = grids.first()?;
    let mut counts = vec![0usize; first.data.len()];
    for g in grids {
        for (c, &b) in counts.iter_mut().zip(&g.data) {
            *c += b as usize;
        }
    }
    Some(VoxelGrid {
        frame: first.frame,
        data: counts.iter().map(|&c| 2 * c >= grids.len()).collect(),
    })
}

/// The silhouette of the field seen by `camera`: a pixel is covered when the maximum of φ over
/// `samples` points along its ray (through the bounding sphere of the unit cube) is at least ½.
pub fn render_field_silhouette(
    model: &FieldModel,
    latent: Option<&Tensor<2>>,
    camera: &Camera,
    samples: usize,
    device: &Device,
) -> Silhouette {
    let s = camera.image_size;
    let centre_depth = camera.eye.length();
    let (near, far) = (centre_depth - 0.9, centre_depth + 0.9);
    let mut points = Vec::with_capacity(s * s * samples * 3);
    for row in 0..s {
        for col in 0..s {
            let ray = camera.ray(PixelPos {
                col: col as f32,
                row: row as f32,
            });
            // Sample by depth along the optical axis so that every ray covers the same slab.
            let cos = ray.direction.dot(camera.forward);
            for k in 0..samples {
                let z = near + (far - near) * (k as f32 + 0.5) / samples as f32;
                points.extend(ray.at(z / cos).to_array());
            }
        }
    }
    let values = field_values(model, latent, &points, device);
    Silhouette {
        size: s,
        data: values
            .chunks(samples)
            .map(|c| {
                if c.iter().cloned().fold(0.0f32, f32::max) >= 0.5 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect(),
    }
}
