//! Evaluation in the NMR protocol: 3D IoU at 32³ between a field's voxels and the ground-truth
//! voxels, for every test object and each of its 24 views as input; per category, then the mean
//! over categories.
//!
//! A field becomes voxels the way the ground truth was made ([`occupancy`]): a voxel is occupied
//! when φ reaches ½ anywhere in its closed cell (max over the lattice points of its `S³` cells),
//! since NMR's ground truth marks every voxel whose edges the surface crosses. φ read only at the voxel centres is kept as a secondary number
//! (`centre_iou`): it is not dilated like the ground truth, so it caps a perfect field well below 1
//! and pays over-sized fields.
//!
//! References computed on the same objects and converted the same way, so a number always has
//! context:
//! * the 24-view visual hull — what silhouettes alone determine;
//! * the category mean shape — the mean of the training objects' visual hulls, thresholded at ½:
//!   the prior silhouettes alone give; beating it shows the model reads the image;
//! * the mean of the training ground-truth voxels (`mean_gt_shape_iou`), a prior that needs 3D.
//!
//! [`surface`] adds the mesh metrics of Occupancy Networks and DVR (Chamfer-L1, F-score, normal
//! consistency) between an extracted mesh and a ground-truth mesh.

pub mod occupancy;
pub mod surface;

use burn::prelude::*;

use crate::data::hull::projects_inside;
use crate::data::{Silhouette, TriMesh, VoxelGrid};
use crate::extract::{ExtractOptions, extract_mesh};
use crate::field::Field;
use crate::geometry::{Camera, NUM_VIEWS, PixelPos};
use crate::object::ObjectViews;
use crate::probe::{Aggregator, RayValues};
use glam::Vec3;
use occupancy::{FieldVoxels, MaxPoolPath, VoxelProtocol};

/// Points per decoder call when evaluating grids and renders (bounds memory).
const CHUNK: usize = 16_384;

/// φ at `points` (`[M·3]`) for one latent (`[1, Z]` or none), in chunks; `model` should be in
/// evaluation mode (`valid()`), on `device`.
pub fn field_values(
    model: &dyn Field,
    latent: Option<&Tensor<2>>,
    points: &[f32],
    device: &Device,
) -> Vec<f32> {
    let mut out = Vec::with_capacity(points.len() / 3);
    for chunk in points.chunks(CHUNK * 3) {
        let m = chunk.len() / 3;
        let p = Tensor::<3>::from_data(TensorData::new(chunk.to_vec(), [1, m, 3]), device);
        let v = model.occupancy(latent.cloned(), p);
        out.extend(v.try_into_vec_as::<f32>().expect("f32 field values"));
    }
    out
}

/// Latents `[24, Z]` of all views of an object (none for a per-object field).
pub fn encode_views(model: &dyn Field, obj: &ObjectViews, device: &Device) -> Option<Tensor<2>> {
    let s = obj.image_size;
    let px: Vec<f32> = (0..NUM_VIEWS).flat_map(|v| obj.view(v)).collect();
    model.encode(Tensor::<4>::from_data(
        TensorData::new(px, [NUM_VIEWS, 4, s, s]),
        device,
    ))
}

/// The voxels of one latent's field (none for a per-object field) in the max-pool protocol
/// ([`occupancy::field_voxels`] on `protocol`'s grid and lattice), with the centre test beside
/// them. φ is read only inside the field's domain, as for meshes and renders.
pub fn predict_voxels(
    model: &dyn Field,
    latent: Option<&Tensor<2>>,
    protocol: &VoxelProtocol,
    device: &Device,
) -> FieldVoxels {
    let mut field = |p: &[f32]| in_domain(p, |inside| field_values(model, latent, inside, device));
    occupancy::field_voxels(&mut field, protocol, model.level())
}

/// [`predict_voxels`] of an object from its view latents ([`encode_views`]), one per input view
/// in `views` (a single one for a per-object field, which has no latents).
pub fn predict_all_views(
    model: &dyn Field,
    latents: Option<&Tensor<2>>,
    views: &[usize],
    protocol: &VoxelProtocol,
    device: &Device,
) -> Vec<FieldVoxels> {
    match latents {
        Some(latents) => views
            .iter()
            .map(|&v| {
                let z = latents.clone().narrow(0, v, 1);
                predict_voxels(model, Some(&z), protocol, device)
            })
            .collect(),
        None => vec![predict_voxels(model, None, protocol, device)],
    }
}

/// The level of a 0/1 indicator field (the visual hull, exact occupancies): any value in (0, 1]
/// separates its two values; ½ by convention. A model's level is its [`Field::level`].
pub const INDICATOR_LEVEL: f32 = 0.5;

/// The surface `φ = opts.threshold` of a model's field for one latent (none for a per-object field),
/// by MISE + marching cubes ([`crate::extract`]). As in [`render_silhouette`], φ is read only
/// inside the field's domain `[-FIELD_HALF_EXTENT, FIELD_HALF_EXTENT]³` and is 0 outside it
/// (never trained there): a shape that fills its domain up to a face is then capped on that face
/// instead of running into the sampled cube's border, where NMR's voxelization would miss it.
pub fn extract_field_mesh(
    model: &dyn Field,
    latent: Option<&Tensor<2>>,
    opts: &ExtractOptions,
    device: &Device,
) -> TriMesh {
    let opts = ExtractOptions {
        threshold: Some(opts.threshold.unwrap_or(model.level())),
        ..opts.clone()
    };
    extract_mesh(
        &mut |points| in_domain(points, |inside| field_values(model, latent, inside, device)),
        &opts,
    )
}

/// `field` at the points (`[M·3]`) inside the field's domain, 0 at the others.
pub fn in_domain(points: &[f32], field: impl FnOnce(&[f32]) -> Vec<f32>) -> Vec<f32> {
    let inside: Vec<bool> = points
        .chunks_exact(3)
        .map(|p| p.iter().all(|c| c.abs() <= FIELD_HALF_EXTENT))
        .collect();
    let kept: Vec<f32> = points
        .chunks_exact(3)
        .zip(&inside)
        .filter(|(_, k)| **k)
        .flat_map(|(p, _)| p.iter().copied())
        .collect();
    let mut values = if kept.is_empty() {
        Vec::new()
    } else {
        field(&kept)
    }
    .into_iter();
    inside
        .iter()
        .map(|&k| {
            if k {
                values.next().expect("one value per point")
            } else {
                0.0
            }
        })
        .collect()
}

/// The 24-view visual hull of an object as a 0/1 field ([`projects_inside`]), points in parallel
/// (every evaluation projects a whole max-pool lattice for each test object and each reference
/// object).
pub fn hull_field(obj: &ObjectViews) -> impl FnMut(&[f32]) -> Vec<f32> + '_ {
    use rayon::prelude::*;
    let sup = &obj.supervision;
    move |points: &[f32]| {
        points
            .par_chunks_exact(3)
            .map(|p| {
                projects_inside(&sup.silhouettes, &sup.cameras, Vec3::from_slice(p)) as u8 as f32
            })
            .collect()
    }
}

/// The 24-view visual hull of an object, converted to voxels like a predicted field
/// ([`occupancy::field_voxels`] of [`hull_field`]). Always by the dense definition: the hull is a
/// 0/1 indicator, on which the fast path's smoothness assumption does not hold, and projecting
/// the whole lattice costs well under a second.
pub fn object_hull(obj: &ObjectViews, protocol: &VoxelProtocol) -> FieldVoxels {
    let dense = VoxelProtocol {
        path: MaxPoolPath::Dense,
        ..*protocol
    };
    occupancy::field_voxels(&mut hull_field(obj), &dense, INDICATOR_LEVEL)
}

/// Per-voxel mean of `grids`, thresholded at ½.
pub fn mean_shape<'a>(grids: impl IntoIterator<Item = &'a VoxelGrid>) -> Option<VoxelGrid> {
    let mut grids = grids.into_iter().peekable();
    let frame = grids.peek()?.frame;
    let mut counts = vec![0usize; grids.peek()?.data.len()];
    let mut n = 0;
    for g in grids {
        n += 1;
        for (c, &b) in counts.iter_mut().zip(&g.data) {
            *c += b as usize;
        }
    }
    Some(VoxelGrid {
        frame,
        data: counts.iter().map(|&c| 2 * c >= n).collect(),
    })
}

/// Half-size of the field's domain: objects are normalized into the cube `[-½, ½]³` (the NMR
/// grid's voxel centres span it), anchors are sampled there, and φ outside it is never trained,
/// so renders read φ only inside it.
pub const FIELD_HALF_EXTENT: f32 = 0.5;

/// The rays of `camera` that meet the field's domain and `samples` evenly spaced points on each
/// inside it: `(pixel index, depths [samples])` per ray, and the points `[rays·samples·3]`.
fn domain_ray_samples(camera: &Camera, samples: usize) -> (Vec<(usize, Vec<f32>)>, Vec<f32>) {
    let s = camera.image_size;
    let bound = Vec3::splat(FIELD_HALF_EXTENT);
    let mut rays = Vec::new();
    let mut points = Vec::new();
    for row in 0..s {
        for col in 0..s {
            let ray = camera.ray(PixelPos {
                col: col as f32,
                row: row as f32,
            });
            if let Some((t0, t1)) = ray.box_interval(-bound, bound) {
                let depths: Vec<f32> = (0..samples)
                    .map(|k| t0 + (t1 - t0) * (k as f32 + 0.5) / samples as f32)
                    .collect();
                for &t in &depths {
                    points.extend(ray.at(t).to_array());
                }
                rays.push((row * s + col, depths));
            }
        }
    }
    (rays, points)
}

/// The silhouette of a field seen by `camera`: a pixel is covered when the maximum of φ over
/// `samples` evenly spaced points of its ray inside the field's domain (the cube
/// `[-FIELD_HALF_EXTENT, FIELD_HALF_EXTENT]³`) is at least `level` — the dense version of the
/// max-pool probe. `field` maps points `[M·3]` to φ `[M]`; a ray that misses the cube is empty.
/// The reference of [`render_field_silhouette`] with the max aggregator.
pub fn render_silhouette(
    camera: &Camera,
    samples: usize,
    level: f32,
    field: impl FnOnce(&[f32]) -> Vec<f32>,
) -> Silhouette {
    let (rays, points) = domain_ray_samples(camera, samples);
    let values = field(&points);
    let mut out = Silhouette::empty(camera.image_size);
    for ((pixel, _), ray_values) in rays.iter().zip(values.chunks(samples)) {
        if ray_values.iter().any(|&v| v >= level) {
            out.values_mut()[*pixel] = 1.0;
        }
    }
    out
}

/// The silhouette of a model's field (one latent, or none for a per-object field) as training
/// sees it: φ at `samples` evenly spaced points of each pixel's ray inside the field's domain,
/// turned into one prediction per ray by the run's `aggregator` (every sample an "anchor" on the
/// ray, at distance 0 from it), covered where the prediction reaches the model's level. With the
/// max aggregator this is [`render_silhouette`].
pub fn render_field_silhouette(
    model: &dyn Field,
    latent: Option<&Tensor<2>>,
    camera: &Camera,
    samples: usize,
    aggregator: &dyn Aggregator,
    device: &Device,
) -> Silhouette {
    let (rays, points) = domain_ray_samples(camera, samples);
    let mut out = Silhouette::empty(camera.image_size);
    if rays.is_empty() || samples == 0 {
        return out;
    }
    let values = field_values(model, latent, &points, device);
    let shape = [rays.len(), samples];
    let mut input = RayValues::new(
        Tensor::<2>::from_data(TensorData::new(values, shape), device),
        Tensor::<2, Bool>::from_data(
            TensorData::new(vec![true; rays.len() * samples], shape),
            device,
        ),
    );
    if aggregator.uses_geometry() {
        let depth: Vec<f32> = rays.iter().flat_map(|(_, d)| d.iter().copied()).collect();
        input.depth = Some(Tensor::from_data(TensorData::new(depth, shape), device));
        input.distance = Some(Tensor::zeros(shape, device));
    }
    let psi: Vec<f32> = aggregator
        .aggregate(input)
        .try_into_vec_as::<f32>()
        .expect("f32 predictions");
    let level = model.level();
    for ((pixel, _), p) in rays.iter().zip(psi) {
        if p >= level {
            out.values_mut()[*pixel] = 1.0;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// φ of a solid ball of radius `r` at the origin, as a 0/1 field.
    fn ball(r: f32) -> impl FnOnce(&[f32]) -> Vec<f32> {
        move |p: &[f32]| {
            p.chunks(3)
                .map(|q| (Vec3::from_slice(q).length() < r) as u8 as f32)
                .collect()
        }
    }

    #[test]
    fn rendered_ball_matches_its_analytic_silhouette() {
        let r = 0.3;
        for view in [0, 5, 13] {
            let cam = Camera::nmr(view);
            let rendered = render_silhouette(&cam, 96, INDICATOR_LEVEL, ball(r));
            let mut exact = Silhouette::empty(cam.image_size);
            for row in 0..cam.image_size {
                for col in 0..cam.image_size {
                    let ray = cam.ray(PixelPos {
                        col: col as f32,
                        row: row as f32,
                    });
                    if ray.sphere_interval(Vec3::ZERO, r).is_some() {
                        exact.values_mut()[row * cam.image_size + col] = 1.0;
                    }
                }
            }
            let iou = rendered.iou(&exact);
            assert!(iou > 0.97, "view {view}: IoU {iou}");
        }
    }

    #[test]
    fn fields_are_zero_outside_their_domain() {
        let pts = [
            0.0, 0.0, 0.0, 0.6, 0.0, 0.0, 0.1, -0.5, 0.2, 0.0, 0.0, -0.51,
        ];
        let mut seen = 0;
        let v = in_domain(&pts, |inside| {
            seen = inside.len() / 3;
            vec![0.9; inside.len() / 3]
        });
        assert_eq!(seen, 2, "only the points inside are evaluated");
        assert_eq!(v, vec![0.9, 0.0, 0.9, 0.0]);
        // A field occupied everywhere gives the domain's cube, capped inside the sampled one.
        let cube = extract_mesh(
            &mut |p| in_domain(p, |q| vec![1.0; q.len() / 3]),
            &ExtractOptions {
                refinements: 0,
                ..ExtractOptions::default()
            },
        );
        let (lo, hi) = cube.bounds();
        assert!(
            hi.max_element() <= FIELD_HALF_EXTENT + 0.02
                && lo.min_element() >= -FIELD_HALF_EXTENT - 0.02
        );
        assert!(hi.min_element() > 0.45, "{hi}");
    }

    #[test]
    fn field_outside_the_domain_is_not_rendered() {
        // Occupied only outside the cube: nothing of it may show.
        let outside = |p: &[f32]| -> Vec<f32> {
            p.chunks(3)
                .map(|q| {
                    (Vec3::from_slice(q).abs().max_element() > FIELD_HALF_EXTENT + 1e-4) as u8
                        as f32
                })
                .collect()
        };
        let sil = render_silhouette(&Camera::nmr(3), 64, INDICATOR_LEVEL, outside);
        assert!(sil.values().all(|v| v == 0.0));
        // The whole cube is occupied: its projection is covered, and the corners of the image
        // (outside the cube's projection) are not.
        let full = |p: &[f32]| vec![1.0; p.len() / 3];
        let sil = render_silhouette(&Camera::nmr(0), 8, INDICATOR_LEVEL, full);
        let covered = sil.values().filter(|&v| v > 0.5).count();
        assert!(covered > 0 && covered < sil.len());
        assert_eq!(sil.get(0), 0.0);
    }

    /// A ball of radius `r` as a model: logits `(r − |p|)·k`.
    #[derive(Debug)]
    struct Ball(f32);

    impl Field for Ball {
        fn encode(&self, _images: Tensor<4>) -> Option<Tensor<2>> {
            None
        }
        fn logits(&self, _latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
            let r: Tensor<2> = points.powi_scalar(2).sum_dim(2).sqrt().squeeze_dim(2);
            r.neg().add_scalar(self.0).mul_scalar(200.0)
        }
    }

    #[test]
    fn a_models_silhouette_through_the_max_aggregator_is_the_dense_max_probe() {
        use crate::probe::{MaxPool, SoftMax};
        let dev = Device::flex();
        let ball = Ball(0.3);
        let cam = Camera::nmr(5);
        let via_max = render_field_silhouette(&ball, None, &cam, 48, &MaxPool {}, &dev);
        let reference = render_silhouette(&cam, 48, 0.5, |p| field_values(&ball, None, p, &dev));
        assert_eq!(via_max, reference);
        assert!(via_max.values().any(|v| v > 0.0));
        // A soft max lies below the max, so its silhouette is inside the max's; a warm one
        // (nearer the mean) drops rays that graze the ball.
        let warm = SoftMax { temperature: 1.0 };
        let soft = render_field_silhouette(&ball, None, &cam, 48, &warm, &dev);
        let inside = soft.values().zip(via_max.values()).all(|(s, m)| s <= m);
        let fewer = soft.values().sum::<f32>() < via_max.values().sum::<f32>();
        assert!(inside && fewer);
    }
}
