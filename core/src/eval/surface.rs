//! Surface metrics between a predicted and a ground-truth mesh, as Occupancy Networks (Mescheder
//! et al. 2019) and DVR (Niemeyer et al. 2020) report them, computed on points sampled uniformly
//! by area from both surfaces:
//!
//! * **accuracy** — mean distance from predicted points to the nearest ground-truth point;
//! * **completeness** — mean distance from ground-truth points to the nearest predicted point;
//! * **Chamfer-L1** — `½ (accuracy + completeness)` (papers print it ×10);
//! * **normal consistency** — mean `|n · n'|` between a point's normal and its nearest
//!   neighbour's on the other surface, averaged over both directions;
//! * **F-score at τ** (Tatarchenko et al. 2019) — the harmonic mean of precision (predicted
//!   points within τ of the ground truth) and recall (ground-truth points within τ of the
//!   prediction).
//!
//! Distances are in the units of the NMR frame, where an object's largest extent is 1 (the same
//! normalization as Occupancy Networks' unit cube), so τ = 0.01 is 1 % of the object's size.
//!
//! An empty prediction gets the worst values the field's cube allows (Chamfer-L1 = √3, its
//! diagonal; F-score and normal consistency 0) rather than being skipped, so that a model that
//! often predicts nothing cannot look good on average.
//!
//! Ground-truth meshes that are unions of overlapping closed parts (the procedural shapes, many
//! ShapeNet models) have surface inside other parts; [`outer_surface`] drops those samples with
//! the generalized winding number, so that completeness measures the union's boundary.

use glam::Vec3;
use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::data::mesh::TriMesh;
use crate::data::winding::FastWinding;

/// Points on a surface with their unit normals (orientation is irrelevant to every metric here).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceSample {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
}

/// `n` points uniformly distributed by area over `mesh` (faces of zero area are never drawn),
/// with their faces' normals; empty for a mesh without area.
pub fn sample_surface(mesh: &TriMesh, n: usize, rng: &mut impl Rng) -> SurfaceSample {
    let mut cumulative = Vec::with_capacity(mesh.faces.len());
    let mut total = 0.0f64;
    for f in 0..mesh.faces.len() {
        let [a, b, c] = mesh.triangle(f);
        total += f64::from((b - a).cross(c - a).length()) * 0.5;
        cumulative.push(total);
    }
    let mut out = SurfaceSample::default();
    if total <= 0.0 || !total.is_finite() {
        return out;
    }
    for _ in 0..n {
        let u = rng.random::<f64>() * total;
        let f = cumulative
            .partition_point(|&c| c <= u)
            .min(mesh.faces.len() - 1);
        let [a, b, c] = mesh.triangle(f);
        // Uniform barycentric point: reflect the unit square's upper half into the triangle.
        let (mut s, mut t) = (rng.random::<f32>(), rng.random::<f32>());
        if s + t > 1.0 {
            (s, t) = (1.0 - s, 1.0 - t);
        }
        out.points.push(a + (b - a) * s + (c - a) * t);
        out.normals.push((b - a).cross(c - a).normalize_or_zero());
    }
    out
}

/// Keeps the samples on the boundary of the solid that `mesh` encloses: a point is on it iff just
/// off it, on one side, is outside the solid. Outside, the generalized winding number `|w|` is 0;
/// inside any part it is at least 1. So a sample is kept when `min |w(p ± ε n)| < ½` (ε = 10⁻⁴,
/// far below any feature of a unit-size object; at `p` itself `w` is ill-defined, as `p` lies on
/// a face). Walls inside another part are dropped; where two parts share a coplanar face, both
/// copies are kept (that patch counts twice). Assumes consistently oriented parts. The winding
/// number comes from [`FastWinding`] (a tree of dipoles, tested against the exact sum), so a
/// 100k-face ShapeNet mesh takes seconds, not the hours of one solid angle per face and point.
pub fn outer_surface(mesh: &TriMesh, sample: SurfaceSample) -> SurfaceSample {
    const EPS: f32 = 1e-4;
    let winding = FastWinding::new(mesh);
    let keep: Vec<bool> = {
        use rayon::prelude::*;
        sample
            .points
            .par_iter()
            .zip(&sample.normals)
            .map(|(&p, &n)| {
                // Short-circuits: with outward normals the first side is usually outside.
                let outside = |q: Vec3| winding.winding(q).abs() < 0.5;
                outside(p + n * EPS) || outside(p - n * EPS)
            })
            .collect()
    };
    let mut out = SurfaceSample::default();
    for ((p, n), k) in sample.points.into_iter().zip(sample.normals).zip(keep) {
        if k {
            out.points.push(p);
            out.normals.push(n);
        }
    }
    out
}

/// Exact nearest-neighbour queries over a fixed point set, through a uniform grid of buckets
/// searched ring by ring (each ring is a shell of cells one cell further out; the search stops
/// once the best distance found is below the nearest a further ring could be).
#[derive(Clone, Debug)]
pub struct NearestIndex {
    points: Vec<Vec3>,
    lo: Vec3,
    cell: f32,
    dims: [usize; 3],
    /// Bucket `b` holds `order[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl NearestIndex {
    /// Builds the index (about two points per cell, at most 128 cells per axis).
    pub fn new(points: &[Vec3]) -> Self {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &p in points {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if points.is_empty() {
            (lo, hi) = (Vec3::ZERO, Vec3::ZERO);
        }
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        let volume = extent.x * extent.y * extent.z;
        let cell = (volume * 2.0 / points.len().max(1) as f32)
            .cbrt()
            .max(extent.max_element() / 128.0);
        let dims = [0, 1, 2].map(|a| ((extent[a] / cell).floor() as usize + 1).min(129));
        let mut index = Self {
            points: points.to_vec(),
            lo,
            cell,
            dims,
            starts: Vec::new(),
            order: Vec::new(),
        };
        let buckets: Vec<usize> = points.iter().map(|&p| index.bucket(p)).collect();
        let mut counts = vec![0u32; dims[0] * dims[1] * dims[2] + 1];
        for &b in &buckets {
            counts[b + 1] += 1;
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let mut order = vec![0u32; points.len()];
        for (i, &b) in buckets.iter().enumerate() {
            order[fill[b] as usize] = i as u32;
            fill[b] += 1;
        }
        index.starts = counts;
        index.order = order;
        index
    }

    fn cell_of(&self, p: Vec3) -> [usize; 3] {
        let g = (p - self.lo) / self.cell;
        [0, 1, 2].map(|a| (g[a].max(0.0) as usize).min(self.dims[a] - 1))
    }

    fn bucket(&self, p: Vec3) -> usize {
        let [i, j, k] = self.cell_of(p);
        (i * self.dims[1] + j) * self.dims[2] + k
    }

    /// Whether any point lies within `radius` of `q` (closed ball). Looks only at the cells that
    /// the ball's bounding box overlaps, so a query far from every point costs nothing, unlike
    /// [`Self::nearest`], whose search grows ring by ring until it meets a point.
    pub fn within(&self, q: Vec3, radius: f32) -> bool {
        let range = |a: usize| {
            let lo = ((q[a] - radius - self.lo[a]) / self.cell).floor() as i64;
            let hi = ((q[a] + radius - self.lo[a]) / self.cell).floor() as i64;
            lo.max(0)..=hi.min(self.dims[a] as i64 - 1)
        };
        let r2 = radius * radius;
        for i in range(0) {
            for j in range(1) {
                for k in range(2) {
                    let b = ((i as usize * self.dims[1] + j as usize) * self.dims[2]) + k as usize;
                    let bucket = &self.order[self.starts[b] as usize..self.starts[b + 1] as usize];
                    if bucket
                        .iter()
                        .any(|&p| self.points[p as usize].distance_squared(q) <= r2)
                    {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The index of the point nearest to `q` and its distance; `None` for an empty set.
    pub fn nearest(&self, q: Vec3) -> Option<(usize, f32)> {
        if self.points.is_empty() {
            return None;
        }
        let c = self.cell_of(q).map(|v| v as i64);
        let dims = self.dims.map(|v| v as i64);
        let max_ring = *dims.iter().max().expect("three axes");
        let (mut best, mut best_d2) = (0usize, f32::INFINITY);
        for r in 0..=max_ring {
            for i in (c[0] - r).max(0)..=(c[0] + r).min(dims[0] - 1) {
                for j in (c[1] - r).max(0)..=(c[1] + r).min(dims[1] - 1) {
                    let on_shell_ij = (i - c[0]).abs() == r || (j - c[1]).abs() == r;
                    // Off the shell in i and j, only the two k-faces of the ring are new.
                    let ks: Vec<i64> = if on_shell_ij {
                        ((c[2] - r).max(0)..=(c[2] + r).min(dims[2] - 1)).collect()
                    } else {
                        [c[2] - r, c[2] + r]
                            .into_iter()
                            .filter(|&k| (0..dims[2]).contains(&k) && (r > 0 || k == c[2]))
                            .collect()
                    };
                    for k in ks {
                        let b = ((i * dims[1] + j) * dims[2] + k) as usize;
                        for &p in &self.order[self.starts[b] as usize..self.starts[b + 1] as usize]
                        {
                            let d2 = self.points[p as usize].distance_squared(q);
                            if d2 < best_d2 {
                                (best, best_d2) = (p as usize, d2);
                            }
                        }
                    }
                }
            }
            // Every point in ring r + 1 is at least r cells from q's cell, hence from q.
            let reach = r as f32 * self.cell;
            if best_d2 <= reach * reach {
                break;
            }
        }
        Some((best, best_d2.sqrt()))
    }
}

/// The metrics of one prediction (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceMetrics {
    pub chamfer_l1: f32,
    pub accuracy: f32,
    pub completeness: f32,
    pub normal_consistency: f32,
    pub precision: f32,
    pub recall: f32,
    pub fscore: f32,
}

/// Chamfer-L1 given to an empty prediction: the diagonal of the unit cube.
pub const EMPTY_CHAMFER: f32 = 1.732_050_8;

/// For every point of `from`: the distance to the nearest point of `to` and `|n · n'|`.
fn directed(from: &SurfaceSample, to: &SurfaceSample, index: &NearestIndex) -> Vec<(f32, f32)> {
    use rayon::prelude::*;
    from.points
        .par_iter()
        .zip(&from.normals)
        .map(|(&p, &n)| {
            let (j, d) = index.nearest(p).expect("non-empty target");
            (d, n.dot(to.normals[j]).abs())
        })
        .collect()
}

/// Metrics of `pred` against `gt` at F-score threshold `tau`; `gt` must not be empty.
pub fn surface_metrics(pred: &SurfaceSample, gt: &SurfaceSample, tau: f32) -> SurfaceMetrics {
    assert!(!gt.points.is_empty(), "ground-truth sample is empty");
    if pred.points.is_empty() {
        return SurfaceMetrics {
            chamfer_l1: EMPTY_CHAMFER,
            accuracy: EMPTY_CHAMFER,
            completeness: EMPTY_CHAMFER,
            normal_consistency: 0.0,
            precision: 0.0,
            recall: 0.0,
            fscore: 0.0,
        };
    }
    let to_gt = directed(pred, gt, &NearestIndex::new(&gt.points));
    let to_pred = directed(gt, pred, &NearestIndex::new(&pred.points));
    let mean = |v: &[(f32, f32)], f: &dyn Fn(&(f32, f32)) -> f32| {
        (v.iter().map(|x| f64::from(f(x))).sum::<f64>() / v.len() as f64) as f32
    };
    let accuracy = mean(&to_gt, &|x| x.0);
    let completeness = mean(&to_pred, &|x| x.0);
    let precision = mean(&to_gt, &|x| (x.0 <= tau) as u8 as f32);
    let recall = mean(&to_pred, &|x| (x.0 <= tau) as u8 as f32);
    let fscore = if precision + recall > 0.0 {
        2.0 * precision * recall / (precision + recall)
    } else {
        0.0
    };
    SurfaceMetrics {
        chamfer_l1: 0.5 * (accuracy + completeness),
        accuracy,
        completeness,
        normal_consistency: 0.5 * (mean(&to_gt, &|x| x.1) + mean(&to_pred, &|x| x.1)),
        precision,
        recall,
        fscore,
    }
}

#[cfg(test)]
mod tests;
