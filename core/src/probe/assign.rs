//! Ray–anchor assignment: which anchors' support spheres each probing ray passes through.
//!
//! A ray `o + t·d` (`t ≥ 0`, `|d| = 1`) meets the sphere of radius `τ` around anchor `s` iff the
//! closest point of the half-line to `s` is within `τ`: with `v = s − o` and `t* = max(v·d, 0)`,
//! `|v|² − t*² ≤ τ²`. Both implementations below apply exactly this test, in `f32`, to the same
//! candidates' data, so they return identical pairs:
//!
//! * [`assign_all_pairs`] — the plain reference: every ray against every anchor.
//! * [`assign_binned`] — projects the anchors of each view into the image once, bins them on a
//!   grid of cells as large as the largest projected support radius, and tests each ray only
//!   against the anchors in the 3×3 cells around its pixel. The projected radius bound is exact:
//!   a point `q` of the sphere has depth `≥ z − τ`, so its projection lies within
//!   `f·τ/(z − τ)·(1 + |s_xy|/z)` pixels of the centre's (`f` the focal length in pixels).
//!
//! * [`assign_on_device`] — all pairs with burn tensor kernels on the training device (for GPU
//!   runs; `probe.assign_on = "device"`), identical pairs on a backend that rounds every
//!   operation.
//!
//! Pairs can further be filtered by an [`AssignmentPolicy`]: the paper's boundary-aware rule drops
//! anchors whose silhouette evidence contradicts the ray's label.

pub mod device;

pub use device::assign_on_device;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::data::Silhouette;
use crate::data::hull::projects_inside;
use crate::geometry::{Camera, PixelPos};

/// Which ray–anchor pairs count (paper §3.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AssignmentPolicy {
    /// Every anchor whose sphere the ray meets.
    #[default]
    Naive,
    /// As naive, but a ray through a pixel inside the silhouette (label ≥ ½) ignores anchors
    /// whose centre projects outside the silhouette of the ray's view (bilinear < ½), and a ray
    /// through an outside pixel ignores anchors whose centre projects inside it. The silhouette
    /// of the ray's own view is the evidence: it is exactly what decides the ray's label.
    BoundaryAware,
    /// The other reading of the paper's "anchors inside the object": the evidence is the
    /// object's visual hull of all its views (an anchor is inside when its centre projects
    /// inside every silhouette), the same for every ray. An inside ray then ignores anchors off
    /// the hull even where its own silhouette covers them (behind or in front of the object),
    /// and an outside ray ignores only hull anchors.
    BoundaryAwareHull,
}

/// The probing rays of one object: all views' rays, with the view each belongs to.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RaySet {
    /// View index of each ray (into the object's cameras).
    pub views: Vec<u16>,
    /// Continuous pixel position of each ray in its view.
    pub pixels: Vec<PixelPos>,
    /// Ground-truth silhouette value at the pixel (bilinear), the ray's target.
    pub labels: Vec<f32>,
}

impl RaySet {
    pub fn len(&self) -> usize {
        self.views.len()
    }

    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }
}

/// For each ray, the indices of the anchors it is assigned, in increasing order (CSR layout).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Assignment {
    /// `offsets[r]..offsets[r+1]` indexes `anchors` for ray `r`; `len = rays + 1`.
    pub offsets: Vec<u32>,
    pub anchors: Vec<u32>,
}

impl Assignment {
    /// Anchors assigned to ray `r`.
    pub fn of(&self, r: usize) -> &[u32] {
        &self.anchors[self.offsets[r] as usize..self.offsets[r + 1] as usize]
    }

    /// Number of rays.
    pub fn rays(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Largest number of anchors on one ray.
    pub fn max_per_ray(&self) -> usize {
        (0..self.rays())
            .map(|r| self.of(r).len())
            .max()
            .unwrap_or(0)
    }

    fn from_lists(lists: Vec<Vec<u32>>) -> Self {
        let mut offsets = Vec::with_capacity(lists.len() + 1);
        offsets.push(0u32);
        let mut anchors = Vec::new();
        for l in lists {
            anchors.extend_from_slice(&l);
            offsets.push(anchors.len() as u32);
        }
        Self { offsets, anchors }
    }
}

/// The exact ray–sphere test shared by both implementations.
#[inline]
fn meets(origin: Vec3, dir: Vec3, anchor: Vec3, radius_sq: f32) -> bool {
    let v = anchor - origin;
    let t = v.dot(dir).max(0.0);
    v.length_squared() - t * t <= radius_sq
}

/// Whether the policy keeps anchor `a` for a ray of label `label` in view `view`.
fn keeps(
    policy: AssignmentPolicy,
    label: f32,
    inside: &[Vec<bool>],
    view: usize,
    a: usize,
) -> bool {
    match policy {
        AssignmentPolicy::Naive => true,
        AssignmentPolicy::BoundaryAware | AssignmentPolicy::BoundaryAwareHull => {
            inside[view][a] == (label >= 0.5)
        }
    }
}

/// Per view and anchor, whether the anchor's centre projects inside that view's silhouette
/// (only computed for the boundary-aware policy).
fn silhouette_evidence(
    policy: AssignmentPolicy,
    anchors: &[Vec3],
    cameras: &[Camera],
    silhouettes: &[Silhouette],
) -> Vec<Vec<bool>> {
    match policy {
        AssignmentPolicy::Naive => Vec::new(),
        AssignmentPolicy::BoundaryAware => cameras
            .iter()
            .zip(silhouettes)
            .map(|(cam, sil)| {
                anchors
                    .iter()
                    .map(|&a| {
                        let (px, depth) = cam.project(a);
                        depth > 0.0 && sil.bilinear(px) >= 0.5
                    })
                    .collect()
            })
            .collect(),
        AssignmentPolicy::BoundaryAwareHull => {
            let hull: Vec<bool> = anchors
                .iter()
                .map(|&a| projects_inside(silhouettes, cameras, a))
                .collect();
            vec![hull; cameras.len()]
        }
    }
}

/// Everything an assignment needs about one object.
#[derive(Clone, Copy, Debug)]
pub struct Probe<'a> {
    pub cameras: &'a [Camera],
    pub silhouettes: &'a [Silhouette],
    pub anchors: &'a [Vec3],
    pub rays: &'a RaySet,
    /// Support radius τ.
    pub radius: f32,
    pub policy: AssignmentPolicy,
}

/// Reference: every ray against every anchor.
pub fn assign_all_pairs(p: Probe<'_>) -> Assignment {
    let inside = silhouette_evidence(p.policy, p.anchors, p.cameras, p.silhouettes);
    let r2 = p.radius * p.radius;
    let lists = (0..p.rays.len())
        .into_par_iter()
        .map(|r| {
            let view = p.rays.views[r] as usize;
            let cam = &p.cameras[view];
            let dir = cam.ray(p.rays.pixels[r]).direction;
            (0..p.anchors.len())
                .filter(|&a| {
                    meets(cam.eye, dir, p.anchors[a], r2)
                        && keeps(p.policy, p.rays.labels[r], &inside, view, a)
                })
                .map(|a| a as u32)
                .collect()
        })
        .collect();
    Assignment::from_lists(lists)
}

/// Anchors of one view binned by their projected position.
struct ViewBins {
    cell: f32,
    n: usize,
    /// CSR over `n × n` cells.
    starts: Vec<u32>,
    items: Vec<u32>,
    /// Anchors too close to (or behind) the camera for the bound; always tested.
    always: Vec<u32>,
}

impl ViewBins {
    fn new(cam: &Camera, anchors: &[Vec3], radius: f32) -> Self {
        let f = cam.focal_px();
        let size = cam.image_size as f32;
        let mut proj = Vec::with_capacity(anchors.len());
        let mut always = Vec::new();
        let mut cell = 1e-3f32;
        for (a, &s) in anchors.iter().enumerate() {
            let c = cam.to_camera(s);
            if c.z <= radius * 1.001 {
                always.push(a as u32);
                continue;
            }
            let (px, _) = cam.project(s);
            let bound = f * radius / (c.z - radius) * (1.0 + (c.x * c.x + c.y * c.y).sqrt() / c.z);
            cell = cell.max(bound);
            proj.push((a as u32, px));
        }
        // Pixel positions of rays lie in [-0.5, size - 0.5]; cells tile that square and are at
        // least as large as every projected radius (rounding the count down), so 3×3 suffice.
        let n = ((size / cell).floor() as usize).clamp(1, 4096);
        let cell = size / n as f32;
        let index = |px: PixelPos| {
            let cx = (((px.col + 0.5) / cell).floor() as i64).clamp(0, n as i64 - 1) as usize;
            let cy = (((px.row + 0.5) / cell).floor() as i64).clamp(0, n as i64 - 1) as usize;
            cy * n + cx
        };
        let mut counts = vec![0u32; n * n + 1];
        for (_, px) in &proj {
            counts[index(*px) + 1] += 1;
        }
        for i in 0..n * n {
            counts[i + 1] += counts[i];
        }
        let starts = counts.clone();
        let mut fill = counts;
        let mut items = vec![0u32; proj.len()];
        for (a, px) in &proj {
            let c = index(*px);
            items[fill[c] as usize] = *a;
            fill[c] += 1;
        }
        Self {
            cell,
            n,
            starts,
            items,
            always,
        }
    }

    /// Anchors whose projection may lie within one cell of `px`.
    fn candidates(&self, px: PixelPos, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.always);
        let n = self.n as i64;
        let cx = ((px.col + 0.5) / self.cell).floor() as i64;
        let cy = ((px.row + 0.5) / self.cell).floor() as i64;
        let (x0, x1) = ((cx - 1).clamp(0, n - 1), (cx + 1).clamp(0, n - 1));
        let (y0, y1) = ((cy - 1).clamp(0, n - 1), (cy + 1).clamp(0, n - 1));
        for y in y0..=y1 {
            for x in x0..=x1 {
                let c = (y * n + x) as usize;
                out.extend_from_slice(
                    &self.items[self.starts[c] as usize..self.starts[c + 1] as usize],
                );
            }
        }
    }
}

/// Fast assignment by binning projected anchors per view (identical output to
/// [`assign_all_pairs`]).
pub fn assign_binned(p: Probe<'_>) -> Assignment {
    let inside = silhouette_evidence(p.policy, p.anchors, p.cameras, p.silhouettes);
    let bins: Vec<ViewBins> = p
        .cameras
        .par_iter()
        .map(|cam| ViewBins::new(cam, p.anchors, p.radius))
        .collect();
    let r2 = p.radius * p.radius;
    let lists = (0..p.rays.len())
        .into_par_iter()
        .map_init(Vec::new, |cand, r| {
            let view = p.rays.views[r] as usize;
            let cam = &p.cameras[view];
            let px = p.rays.pixels[r];
            let dir = cam.ray(px).direction;
            bins[view].candidates(px, cand);
            let mut hit: Vec<u32> = cand
                .iter()
                .copied()
                .filter(|&a| {
                    meets(cam.eye, dir, p.anchors[a as usize], r2)
                        && keeps(p.policy, p.rays.labels[r], &inside, view, a as usize)
                })
                .collect();
            hit.sort_unstable();
            hit
        })
        .collect();
    Assignment::from_lists(lists)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_probe(
        seed: u64,
        n_anchors: usize,
        n_rays: usize,
        spread: f32,
    ) -> (Vec<Vec3>, RaySet) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let anchors = (0..n_anchors)
            .map(|_| {
                Vec3::new(
                    rng.random_range(-spread..spread),
                    rng.random_range(-spread..spread),
                    rng.random_range(-spread..spread),
                )
            })
            .collect();
        let mut rays = RaySet::default();
        for _ in 0..n_rays {
            rays.views.push(rng.random_range(0..24));
            rays.pixels.push(PixelPos {
                col: rng.random_range(-0.5..63.5),
                row: rng.random_range(-0.5..63.5),
            });
            rays.labels
                .push(if rng.random_bool(0.5) { 1.0 } else { 0.0 });
        }
        (anchors, rays)
    }

    #[test]
    fn binned_equals_all_pairs_on_random_inputs() {
        let cams = Camera::nmr_views();
        let sils: Vec<Silhouette> = (0..24)
            .map(|v| {
                let mut s = Silhouette::empty(64);
                for (i, x) in s.values_mut().iter_mut().enumerate() {
                    *x = (((i / 64) as f32 - 32.0).hypot((i % 64) as f32 - 32.0 + v as f32 * 0.3)
                        < 18.0) as u8 as f32;
                }
                s
            })
            .collect();
        for (seed, spread, radius) in [
            (0, 0.5, 0.03),
            (1, 1.2, 0.05),
            (2, 0.3, 0.01),
            (3, 2.0, 0.2),
        ] {
            let (anchors, rays) = random_probe(seed, 3000, 800, spread);
            for policy in [
                AssignmentPolicy::Naive,
                AssignmentPolicy::BoundaryAware,
                AssignmentPolicy::BoundaryAwareHull,
            ] {
                let p = Probe {
                    cameras: &cams,
                    silhouettes: &sils,
                    anchors: &anchors,
                    rays: &rays,
                    radius,
                    policy,
                };
                let a = assign_all_pairs(p);
                let b = assign_binned(p);
                assert_eq!(a, b, "seed {seed} {policy:?}");
                assert!(
                    a.anchors.len() > 100 && a.max_per_ray() > 1,
                    "the test must exercise hits: {}",
                    a.anchors.len()
                );
            }
        }
    }

    /// The two readings of boundary-aware assignment differ on an anchor inside the ray's own
    /// silhouette but outside another view's: the own-silhouette reading keeps it for an inside
    /// ray, the hull reading drops it; naive keeps it.
    #[test]
    fn hull_reading_drops_anchors_off_the_hull_that_the_own_silhouette_keeps() {
        let cams = [Camera::nmr(0), Camera::nmr(6)];
        let mut full = Silhouette::empty(64);
        full.values_mut().fill(1.0);
        let sils = [full, Silhouette::empty(64)];
        let anchor = Vec3::new(0.05, 0.02, -0.03);
        let (px, _) = cams[0].project(anchor);
        let rays = RaySet {
            views: vec![0],
            pixels: vec![px],
            labels: vec![1.0],
        };
        let kept = |policy| {
            assign_all_pairs(Probe {
                cameras: &cams,
                silhouettes: &sils,
                anchors: &[anchor],
                rays: &rays,
                radius: 0.03,
                policy,
            })
            .of(0)
            .len()
        };
        assert_eq!(kept(AssignmentPolicy::Naive), 1);
        assert_eq!(kept(AssignmentPolicy::BoundaryAware), 1);
        assert_eq!(kept(AssignmentPolicy::BoundaryAwareHull), 0);
    }

    #[test]
    fn ray_through_a_projected_anchor_meets_it_and_far_rays_do_not() {
        let cam = Camera::nmr(5);
        let s = Vec3::new(0.1, -0.2, 0.3);
        let (px, _) = cam.project(s);
        let d = cam.ray(px).direction;
        assert!(meets(cam.eye, d, s, 1e-6));
        let d2 = cam
            .ray(PixelPos {
                col: px.col + 5.0,
                row: px.row,
            })
            .direction;
        assert!(!meets(cam.eye, d2, s, 0.03 * 0.03));
    }
}
