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

use super::assign::{Assignment, AssignmentPolicy, Probe, RaySet, assign_binned};
use super::sampler::{AnchorSampler, RaySampler, Supervision};
use crate::geometry::NUM_VIEWS;

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
    pub anchors: Vec<Vec3>,
    pub rays: RaySet,
    pub assignment: Assignment,
    /// Per assigned pair (aligned with `assignment.anchors`): the anchor's depth along the ray
    /// and its distance from the ray's line ([`RayValues`](super::RayValues)' geometry).
    pub pair_depth: Vec<f32>,
    pub pair_distance: Vec<f32>,
}

impl ObjectProbe {
    /// Samples anchors and rays for `object` and assigns them.
    pub fn sample(
        object: &Supervision,
        spec: &ProbeSpec,
        rays: &dyn RaySampler,
        anchors: &dyn AnchorSampler,
        rng: &mut dyn RngCore,
    ) -> Self {
        let anchor_points = anchors.sample_anchors(object, spec.anchors, rng);
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
        let assignment = assign_binned(Probe {
            cameras: &object.cameras,
            silhouettes: &object.silhouettes,
            anchors: &anchor_points,
            rays: &set,
            radius: spec.radius,
            policy: spec.assignment,
        });
        let (pair_depth, pair_distance) = pair_geometry(object, &anchor_points, &set, &assignment);
        Self {
            anchors: anchor_points,
            rays: set,
            assignment,
            pair_depth,
            pair_distance,
        }
    }
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
    /// Concatenates object probes (all with the same number of anchors).
    ///
    /// With `compact`, each object keeps only the anchors that some ray meets (filled up, with
    /// anchors no ray meets, to the batch's largest such count so that the batch stays
    /// rectangular): an anchor on no ray contributes nothing to `L_sil`, and at CPU-scale
    /// densities most anchors are on no ray, so this removes most decoder work without changing
    /// a single ray's prediction. At paper scale nearly every anchor is met and it changes
    /// nothing. Regularizers see every sampled anchor either way ([`ProbeBatch::sampled`]).
    /// `compact = false` is the plain reference.
    pub fn assemble(objects: &[ObjectProbe], compact: bool) -> Self {
        let n = objects.first().map_or(0, |o| o.anchors.len());
        assert!(
            objects.iter().all(|o| o.anchors.len() == n),
            "equal anchor counts"
        );
        // Per object: anchors in kept order (compacted: met ones first; else as sampled) and how
        // many some ray meets.
        let orders: Vec<(Vec<u32>, usize)> = objects
            .iter()
            .map(|o| {
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
        // The batch's largest met count (all `n` when not compacting).
        let kept = orders.iter().map(|o| o.1).max().unwrap_or(0).max(1).min(n);
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
        let mut position = vec![0i32; n];
        for (b, (o, (order, _))) in objects.iter().zip(&orders).enumerate() {
            for (i, &a) in order[..kept].iter().enumerate() {
                anchors.extend(o.anchors[a as usize].to_array());
                position[a as usize] = i as i32;
            }
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
            .flat_map(|o| o.anchors.iter().flat_map(|a| a.to_array()))
            .collect();
        Self {
            objects: objects.len(),
            anchors_per_object: kept,
            sampled,
            sampled_per_object: n,
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
}
