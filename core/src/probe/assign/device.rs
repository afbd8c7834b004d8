//! Ray–anchor assignment with device kernels (burn tensor ops): the same exact test as the CPU
//! implementations, for every ray against every anchor, on whatever device runs training. On a
//! GPU the `R × N` tests are a few elementwise kernels, where the CPU's binned assignment costs
//! ~80 ms per object at paper scale (`cargo bench -p fieldprobe-core --bench assign`); on the
//! CPU backend it is the all-pairs cost and only a reference.
//!
//! The test is written component by component in the order `meets` evaluates it in `f32`
//! (`v = s − o`; `t = max(vₓdₓ + v_yd_y + v_zd_z, 0)`; `(vₓ² + v_y² + v_z²) − t² ≤ τ²`), so on a
//! backend that rounds each operation (flex) the pairs are bit-identical to
//! [`assign_binned`](super::assign_binned)'s. A GPU compiler may contract a multiply and an add
//! into one fused operation, which can move a pair lying within rounding of the sphere's
//! boundary (`|d² − τ²| ~ 1e-7`) to the other side; the tests bound that.
//!
//! Rays go in chunks so that a chunk's `[C, N]` intermediates stay near [`CHUNK_ENTRIES`] values;
//! only the met pairs come back to the host (`argwhere`), not the `R × N` mask.

use burn::prelude::*;
use glam::Vec3;

use super::{Assignment, Probe, silhouette_evidence};
use crate::probe::AssignmentPolicy;

/// Values per `[C, N]` intermediate of one chunk of rays (16 Mi: 64 MiB of f32).
pub const CHUNK_ENTRIES: usize = 1 << 24;

/// Tensors `[1, N]` of one coordinate of every anchor, or `[C, 1]` of every ray's.
fn column(values: impl Iterator<Item = f32>, shape: [usize; 2], device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(values.collect::<Vec<f32>>(), shape), device)
}

/// Assignment on `device`: the pairs of [`assign_all_pairs`](super::assign_all_pairs), each
/// ray's anchors in increasing order.
pub fn assign_on_device(p: Probe<'_>, device: &Device) -> Assignment {
    let (n, r) = (p.anchors.len(), p.rays.len());
    if n == 0 || r == 0 {
        return Assignment {
            offsets: vec![0; r + 1],
            anchors: Vec::new(),
        };
    }
    let r2 = p.radius * p.radius;
    let coord = |a: usize| column(p.anchors.iter().map(|s| s[a]), [1, n], device);
    let (sx, sy, sz) = (coord(0), coord(1), coord(2));
    // The policy's evidence: per view and anchor, inside (1) or not (0); a ray keeps the
    // anchors whose evidence equals its label's side.
    let evidence = (p.policy != AssignmentPolicy::Naive).then(|| {
        let inside = silhouette_evidence(p.policy, p.anchors, p.cameras, p.silhouettes);
        let flat: Vec<i32> = inside.iter().flatten().map(|&b| i32::from(b)).collect();
        Tensor::<2, Int>::from_data(TensorData::new(flat, [inside.len(), n]), device)
    });
    let rays: Vec<(Vec3, Vec3)> = (0..r)
        .map(|i| {
            let cam = &p.cameras[p.rays.views[i] as usize];
            (cam.eye, cam.ray(p.rays.pixels[i]).direction)
        })
        .collect();
    let chunk = (CHUNK_ENTRIES / n).clamp(1, r);
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); r];
    for start in (0..r).step_by(chunk) {
        let end = (start + chunk).min(r);
        let c = end - start;
        let part = &rays[start..end];
        let ray_col = |f: &dyn Fn(&(Vec3, Vec3)) -> f32| column(part.iter().map(f), [c, 1], device);
        let (ox, oy, oz) = (
            ray_col(&|q| q.0.x),
            ray_col(&|q| q.0.y),
            ray_col(&|q| q.0.z),
        );
        let (dx, dy, dz) = (
            ray_col(&|q| q.1.x),
            ray_col(&|q| q.1.y),
            ray_col(&|q| q.1.z),
        );
        let vx = sx.clone() - ox;
        let vy = sy.clone() - oy;
        let vz = sz.clone() - oz;
        let t = (vx.clone() * dx + vy.clone() * dy + vz.clone() * dz).clamp_min(0.0);
        let d2 = (vx.clone() * vx + vy.clone() * vy + vz.clone() * vz) - t.clone() * t;
        let mut met = d2.lower_equal_elem(r2);
        if let Some(ev) = &evidence {
            let views: Vec<i32> = p.rays.views[start..end].iter().map(|&v| v as i32).collect();
            let rows = ev.clone().select(
                0,
                Tensor::<1, Int>::from_data(TensorData::new(views, [c]), device),
            );
            let side: Vec<i32> = p.rays.labels[start..end]
                .iter()
                .map(|&l| i32::from(l >= 0.5))
                .collect();
            let side = Tensor::<2, Int>::from_data(TensorData::new(side, [c, 1]), device);
            met = met.bool_and(rows.equal(side.expand([c, n])));
        }
        let pairs: Vec<i64> = met
            .argwhere()
            .try_into_vec_as::<i64>()
            .expect("integer pair indices");
        for pair in pairs.chunks_exact(2) {
            lists[start + pair[0] as usize].push(pair[1] as u32);
        }
    }
    for l in &mut lists {
        l.sort_unstable();
    }
    Assignment::from_lists(lists)
}
