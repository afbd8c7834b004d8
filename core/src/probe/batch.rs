//! From samplers and an assignment to the tensors of one training step.
//!
//! Per object: anchors from the anchor sampler, rays through pixels of the supervision views from
//! the ray sampler (labels = bilinear silhouette), and the binned assignment. A batch concatenates
//! the objects: anchors `[B, N, 3]`, and for every ray the indices of its anchors in the flat
//! `[B·N]` field values, padded to the longest ray with the index `B·N` (a constant 0 appended to
//! the values) and a validity mask.

use glam::Vec3;
use rand::RngCore;
use rand::seq::index::sample;
use serde::{Deserialize, Serialize};

use super::assign::{Assignment, AssignmentPolicy, Probe, RaySet, assign_binned, assign_on_device};
use super::march::{RayMarcher, march_rays};
use super::sampler::{AnchorSampler, RaySampler, Supervision};
use crate::geometry::NUM_VIEWS;
use burn::prelude::Device;

/// How many anchors and rays to probe per object, and how: the numeric keys of an experiment's
/// `[probe]` table (its components, the samplers and the aggregator, sit beside them there).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    /// Anchors per object (paper: 16000).
    pub anchors: usize,
    /// Rays per supervision view (paper: 4096).
    pub rays_per_view: usize,
    /// Supervision views per object and step, drawn from the 24 (paper: all 24).
    #[serde(default = "ProbeSpec::all_views")]
    pub views: usize,
    /// Support radius τ (paper: 0.03).
    #[serde(default = "ProbeSpec::paper_radius")]
    pub radius: f32,
    /// `naive`, `boundary_aware` or `boundary_aware_hull`.
    #[serde(default)]
    pub assignment: AssignmentPolicy,
}

impl ProbeSpec {
    fn all_views() -> usize {
        NUM_VIEWS
    }

    fn paper_radius() -> f32 {
        0.03
    }

    /// Checks what the types cannot; errors name the key.
    pub fn validate(&self) -> Result<(), String> {
        if self.anchors == 0 || self.rays_per_view == 0 || self.views == 0 || self.views > NUM_VIEWS
        {
            return Err(
                "probe.anchors and probe.rays_per_view must be positive, probe.views in 1..=24"
                    .into(),
            );
        }
        if !(self.radius > 0.0 && self.radius < 0.5) {
            return Err(format!(
                "probe.radius must be in (0, 0.5), got {}",
                self.radius
            ));
        }
        Ok(())
    }
}

/// One object's probe: anchors, rays and their assignment.
#[derive(Clone, Debug)]
pub struct ObjectProbe {
    /// The points the rays read: the anchors (field probing) or the samples along each ray
    /// (dense marching, [`ObjectProbe::march`]).
    pub anchors: Vec<Vec3>,
    /// What regularizers see: every point the anchor sampler drew, whether a ray meets it or not
    /// (for field probing, `anchors` itself).
    pub sampled: Vec<Vec3>,
    pub rays: RaySet,
    pub assignment: Assignment,
    /// Per assigned pair (aligned with `assignment.anchors`): the anchor's depth along the ray
    /// and its distance from the ray's line ([`RayValues`](super::RayValues)' geometry).
    pub pair_depth: Vec<f32>,
    pub pair_distance: Vec<f32>,
}

impl ObjectProbe {
    /// Samples anchors and rays for `object` and assigns them (binned, on the CPU).
    pub fn sample(
        object: &Supervision,
        spec: &ProbeSpec,
        rays: &dyn RaySampler,
        anchors: &dyn AnchorSampler,
        rng: &mut dyn RngCore,
    ) -> Self {
        Self::sample_on(object, spec, rays, anchors, None, rng)
    }

    /// [`sample`](Self::sample) with the assignment on `device` when one is given
    /// ([`assign_on_device`]: the same pairs), else binned on the CPU.
    pub fn sample_on(
        object: &Supervision,
        spec: &ProbeSpec,
        rays: &dyn RaySampler,
        anchors: &dyn AnchorSampler,
        device: Option<&Device>,
        rng: &mut dyn RngCore,
    ) -> Self {
        let anchor_points = anchors.sample_anchors(object, spec.anchors, rng);
        let set = sample_rays(object, spec, rays, rng);
        let probe = Probe {
            cameras: &object.cameras,
            silhouettes: &object.silhouettes,
            anchors: &anchor_points,
            rays: &set,
            radius: spec.radius,
            policy: spec.assignment,
        };
        let assignment = match device {
            Some(d) => assign_on_device(probe, d),
            None => assign_binned(probe),
        };
        let (pair_depth, pair_distance) = pair_geometry(object, &anchor_points, &set, &assignment);
        Self {
            sampled: anchor_points.clone(),
            anchors: anchor_points,
            rays: set,
            assignment,
            pair_depth,
            pair_distance,
        }
    }

    /// The dense ray-marching baseline ([`super::march`]): the same anchors (for regularizers)
    /// and rays as [`sample`](Self::sample) draws from the same RNG, but each ray reads the
    /// field at its own `S` depths inside the cube instead of at the anchors its support
    /// spheres meet.
    pub fn march(
        object: &Supervision,
        spec: &ProbeSpec,
        rays: &dyn RaySampler,
        anchors: &dyn AnchorSampler,
        marcher: &dyn RayMarcher,
        rng: &mut dyn RngCore,
    ) -> Self {
        let sampled = anchors.sample_anchors(object, spec.anchors, rng);
        let set = sample_rays(object, spec, rays, rng);
        let marched = march_rays(object, &set, marcher, rng);
        Self {
            pair_distance: vec![0.0; marched.depth.len()],
            pair_depth: marched.depth,
            anchors: marched.points,
            sampled,
            rays: set,
            assignment: marched.assignment,
        }
    }
}

/// `spec.views` distinct views of the object, `spec.rays_per_view` rays in each (labels: the
/// bilinear silhouette at the pixel).
fn sample_rays(
    object: &Supervision,
    spec: &ProbeSpec,
    rays: &dyn RaySampler,
    rng: &mut dyn RngCore,
) -> RaySet {
    let n_views = object.cameras.len();
    let views = sample(rng, n_views, spec.views.min(n_views)).into_vec();
    let mut set = RaySet::default();
    for v in views {
        for px in rays.sample_pixels(object, v, spec.rays_per_view, rng) {
            set.views.push(v as u16);
            set.labels.push(object.silhouettes[v].bilinear(px));
            set.pixels.push(px);
        }
    }
    set
}

/// Depth along the ray and distance from its line of every assigned pair.
fn pair_geometry(
    object: &Supervision,
    anchors: &[Vec3],
    rays: &RaySet,
    assignment: &Assignment,
) -> (Vec<f32>, Vec<f32>) {
    let mut depth = Vec::with_capacity(assignment.anchors.len());
    let mut distance = Vec::with_capacity(assignment.anchors.len());
    for r in 0..rays.len() {
        let ray = object.cameras[rays.views[r] as usize].ray(rays.pixels[r]);
        for &a in assignment.of(r) {
            let rel = anchors[a as usize] - ray.origin;
            let t = rel.dot(ray.direction);
            depth.push(t);
            distance.push((rel - ray.direction * t).length());
        }
    }
    (depth, distance)
}

/// The host-side tensors of one step.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeBatch {
    /// Objects in the batch.
    pub objects: usize,
    /// Anchors kept per object (all sampled ones unless compacted).
    pub anchors_per_object: usize,
    /// `[B, N, 3]` anchor coordinates.
    pub anchors: Vec<f32>,
    /// `[B, S, 3]` every anchor the samplers drew (`S` per object, in sampled order), whether a
    /// ray meets it or not: what regularizers see.
    pub sampled: Vec<f32>,
    /// Anchors sampled per object (`S`).
    pub sampled_per_object: usize,
    /// Rays in the batch.
    pub rays: usize,
    /// Padded anchors per ray.
    pub width: usize,
    /// `[R, K]` indices into the flat `[B·N + 1]` values; `B·N` is the padding.
    pub index: Vec<i32>,
    /// `[R, K]` whether an entry is a real anchor.
    pub valid: Vec<bool>,
    /// `[R, K]` depth of each entry's anchor along its ray (0 for padding).
    pub depth: Vec<f32>,
    /// `[R, K]` distance of each entry's anchor from its ray's line (0 for padding).
    pub distance: Vec<f32>,
    /// `[R]` silhouette targets.
    pub labels: Vec<f32>,
    /// Ray–anchor pairs assigned (real entries of `index`).
    pub pairs: usize,
    /// Supervision views per object (the first object's distinct ray views; every object of a
    /// step is probed with the same spec). `L_sil` sums the per-view means over them.
    pub views_per_object: usize,
}

/// How many different views a ray set draws from.
fn distinct_views(views: &[u16]) -> usize {
    let mut seen = std::collections::BTreeSet::new();
    seen.extend(views.iter().copied());
    seen.len().max(1)
}

impl ProbeBatch {
    /// Concatenates object probes (all with the same number of sampled anchors; the points the
    /// rays read may differ in number, as dense marching's do, and are padded with unread
    /// points at the origin).
    ///
    /// With `compact`, each object keeps only the anchors that some ray meets (filled up, with
    /// anchors no ray meets, to the batch's largest such count so that the batch stays
    /// rectangular): an anchor on no ray contributes nothing to `L_sil`, and at CPU-scale
    /// densities most anchors are on no ray, so this removes most decoder work without changing
    /// a single ray's prediction. At paper scale nearly every anchor is met and it changes
    /// nothing. Regularizers see every sampled anchor either way ([`ProbeBatch::sampled`]).
    /// `compact = false` is the plain reference.
    pub fn assemble(objects: &[ObjectProbe], compact: bool) -> Self {
        let n_sampled = objects.first().map_or(0, |o| o.sampled.len());
        assert!(
            objects.iter().all(|o| o.sampled.len() == n_sampled),
            "equal sampled anchor counts"
        );
        // Per object: anchors in kept order (compacted: met ones first; else as sampled) and how
        // many some ray meets.
        let orders: Vec<(Vec<u32>, usize)> = objects
            .iter()
            .map(|o| {
                let n = o.anchors.len();
                if !compact {
                    return ((0..n as u32).collect(), n);
                }
                let mut met = vec![false; n];
                for &a in &o.assignment.anchors {
                    met[a as usize] = true;
                }
                let (mut order, rest): (Vec<u32>, Vec<u32>) =
                    (0..n as u32).partition(|&a| met[a as usize]);
                let used = order.len();
                order.extend(rest);
                (order, used)
            })
            .collect();
        // The batch's largest met count (all anchors when not compacting), at least 1.
        let kept = orders.iter().map(|o| o.1).max().unwrap_or(0).max(1);
        let pad = (objects.len() * kept) as i32;
        let width = objects
            .iter()
            .map(|o| o.assignment.max_per_ray())
            .max()
            .unwrap_or(0)
            .max(1);
        let rays: usize = objects.iter().map(|o| o.rays.len()).sum();
        let mut index = Vec::with_capacity(rays * width);
        let mut valid = Vec::with_capacity(rays * width);
        let mut depth = Vec::with_capacity(rays * width);
        let mut distance = Vec::with_capacity(rays * width);
        let mut labels = Vec::with_capacity(rays);
        let mut anchors = Vec::with_capacity(objects.len() * kept * 3);
        let mut pairs = 0;
        for (b, (o, (order, _))) in objects.iter().zip(&orders).enumerate() {
            let mut position = vec![0i32; o.anchors.len()];
            let shown = &order[..kept.min(order.len())];
            for (i, &a) in shown.iter().enumerate() {
                anchors.extend(o.anchors[a as usize].to_array());
                position[a as usize] = i as i32;
            }
            anchors.extend(std::iter::repeat_n(0.0, 3 * (kept - shown.len())));
            let base = (b * kept) as i32;
            for r in 0..o.rays.len() {
                let hit = o.assignment.of(r);
                let (from, to) = (
                    o.assignment.offsets[r] as usize,
                    o.assignment.offsets[r + 1] as usize,
                );
                depth.extend_from_slice(&o.pair_depth[from..to]);
                depth.extend(std::iter::repeat_n(0.0, width - hit.len()));
                distance.extend_from_slice(&o.pair_distance[from..to]);
                distance.extend(std::iter::repeat_n(0.0, width - hit.len()));
                pairs += hit.len();
                index.extend(hit.iter().map(|&a| base + position[a as usize]));
                valid.extend(std::iter::repeat_n(true, hit.len()));
                index.extend(std::iter::repeat_n(pad, width - hit.len()));
                valid.extend(std::iter::repeat_n(false, width - hit.len()));
            }
            labels.extend_from_slice(&o.rays.labels);
        }
        let sampled = objects
            .iter()
            .flat_map(|o| o.sampled.iter().flat_map(|a| a.to_array()))
            .collect();
        Self {
            objects: objects.len(),
            anchors_per_object: kept,
            sampled,
            sampled_per_object: n_sampled,
            views_per_object: objects.first().map_or(1, |o| distinct_views(&o.rays.views)),
            anchors,
            rays,
            width,
            index,
            valid,
            depth,
            distance,
            labels,
            pairs,
        }
    }

    /// The objects `range` of this batch as a batch of their own (data-parallel training runs one
    /// shard per device). Every object of a step has the same number of rays, so each shard's
    /// rays are a contiguous block; `anchors_per_object` and `width` stay the batch's, and the
    /// indices are moved to the shard's flat values (padding to its own `B·N`). Each shard's loss
    /// then reads exactly the values the whole batch's does for its objects.
    pub fn shard(&self, range: std::ops::Range<usize>) -> Self {
        assert!(
            range.start < range.end && range.end <= self.objects,
            "a non-empty object range"
        );
        assert!(
            self.rays.is_multiple_of(self.objects),
            "equal rays per object"
        );
        let (n, s, w) = (self.anchors_per_object, self.sampled_per_object, self.width);
        let per = self.rays / self.objects;
        let (o0, o1) = (range.start, range.end);
        let rays = (o0 * per)..(o1 * per);
        let entries = (rays.start * w)..(rays.end * w);
        let (old_pad, pad) = ((self.objects * n) as i32, ((o1 - o0) * n) as i32);
        let base = (o0 * n) as i32;
        let index = self.index[entries.clone()]
            .iter()
            .map(|&i| if i == old_pad { pad } else { i - base })
            .collect();
        let valid: Vec<bool> = self.valid[entries.clone()].to_vec();
        Self {
            objects: o1 - o0,
            anchors_per_object: n,
            anchors: self.anchors[o0 * n * 3..o1 * n * 3].to_vec(),
            sampled: self.sampled[o0 * s * 3..o1 * s * 3].to_vec(),
            sampled_per_object: s,
            rays: rays.len(),
            width: w,
            index,
            pairs: valid.iter().filter(|&&v| v).count(),
            valid,
            depth: self.depth[entries.clone()].to_vec(),
            distance: self.distance[entries].to_vec(),
            labels: self.labels[rays].to_vec(),
            views_per_object: self.views_per_object,
        }
    }
}
