//! A step's batch on the device.
//!
//! The CPU prepares a step as host vectors ([`PreparedStep`]); the device reads tensors. The
//! vectors are *moved* into tensors once ([`PreparedStep::upload`]), so no step copies its
//! anchors, `[R, K]` index, mask or labels on the host, and with prefetch on, the upload runs on
//! the prefetch worker with the sampling, off the training loop's path (on a GPU the transfer
//! overlaps the previous step). Only what the step's components read is uploaded: the ray
//! geometry when the aggregator uses it, the sampled anchors when there are regularizers.

use burn::prelude::*;

use super::{Components, PreparedStep, shard_ranges};

/// A prepared step's tensors on one device: the whole batch, or one device's shard of it under
/// data parallelism.
#[derive(Clone, Debug)]
pub struct DeviceBatch {
    /// Objects in this batch (or shard).
    pub objects: usize,
    /// Anchors per object in `anchors`.
    pub anchors_per_object: usize,
    /// Rays, and padded anchors per ray, of `index` and `valid`.
    pub rays: usize,
    pub width: usize,
    /// Supervision views per object; `L_sil` sums the per-view means over them.
    pub views_per_object: usize,
    /// The 0-based step the batch was drawn for (step-dependent regularizers read it).
    pub step: usize,
    /// `[B, 4, S, S]` input images, if the model reads images.
    pub images: Option<Tensor<4>>,
    /// `[B, N, 3]` the points rays read.
    pub anchors: Tensor<3>,
    /// `[R·K]` indices into the flat `[B·N + 1]` values (`B·N` is the padding).
    pub index: Tensor<1, Int>,
    /// `[R, K]` whether an entry is a real anchor.
    pub valid: Tensor<2, Bool>,
    /// `[R, K]` depth along and distance from the ray of each entry, when the aggregator reads
    /// ray geometry.
    pub geometry: Option<(Tensor<2>, Tensor<2>)>,
    /// `[R]` silhouette targets.
    pub labels: Tensor<1>,
    /// `[B, S, 3]` every sampled anchor, when regularizers read them.
    pub sampled: Option<Tensor<3>>,
}

impl DeviceBatch {
    /// Moves `prepared`'s host vectors into tensors on `device` (no host copy).
    pub fn upload(prepared: PreparedStep, comps: &Components, device: &Device) -> Self {
        let PreparedStep {
            batch: b,
            images,
            step,
            ..
        } = prepared;
        let (nb, n, rk) = (b.objects, b.anchors_per_object, [b.rays, b.width]);
        let images =
            images.map(|(px, s)| Tensor::from_data(TensorData::new(px, [nb, 4, s, s]), device));
        let geometry = comps.aggregator.uses_geometry().then(|| {
            (
                Tensor::from_data(TensorData::new(b.depth, rk), device),
                Tensor::from_data(TensorData::new(b.distance, rk), device),
            )
        });
        let sampled = (!comps.regularizers.is_empty()).then(|| {
            Tensor::from_data(
                TensorData::new(b.sampled, [nb, b.sampled_per_object, 3]),
                device,
            )
        });
        Self {
            objects: nb,
            anchors_per_object: n,
            rays: b.rays,
            width: b.width,
            views_per_object: b.views_per_object,
            step,
            images,
            anchors: Tensor::from_data(TensorData::new(b.anchors, [nb, n, 3]), device),
            index: Tensor::from_data(TensorData::new(b.index, [b.rays * b.width]), device),
            valid: Tensor::from_data(TensorData::new(b.valid, rk), device),
            geometry,
            labels: Tensor::from_data(TensorData::new(b.labels, [b.rays]), device),
            sampled,
        }
    }
}

/// A step ready for the device: its batch split over the training devices (one shard on one
/// device), with the host-side counts its [`StepStats`](super::StepStats) report.
#[derive(Debug)]
pub struct UploadedStep {
    /// One batch per device, in device order (fewer when the batch has fewer objects).
    pub shards: Vec<DeviceBatch>,
    /// Objects, rays and ray–anchor pairs of the whole step.
    pub objects: usize,
    pub rays: usize,
    pub pairs: usize,
    /// Points the rays read (objects × anchors kept per object).
    pub points: usize,
    pub probe_seconds: f64,
    /// The 0-based step the batch was drawn for.
    pub step: usize,
}

impl PreparedStep {
    /// The step's tensors on `devices`: the whole batch moved onto a single device, or split by
    /// objects ([`shard_ranges`], [`PreparedStep::shard`]) with one shard per device.
    pub fn upload(self, comps: &Components, devices: &[Device]) -> UploadedStep {
        assert!(!devices.is_empty(), "at least one device");
        let b = &self.batch;
        let (objects, rays, pairs) = (b.objects, b.rays, b.pairs);
        let points = b.objects * b.anchors_per_object;
        let (probe_seconds, step) = (self.probe_seconds, self.step);
        let shards = if devices.len() == 1 {
            vec![DeviceBatch::upload(self, comps, &devices[0])]
        } else {
            shard_ranges(objects, devices.len())
                .into_iter()
                .zip(devices)
                .map(|(range, device)| DeviceBatch::upload(self.shard(range), comps, device))
                .collect()
        };
        UploadedStep {
            shards,
            objects,
            rays,
            pairs,
            points,
            probe_seconds,
            step,
        }
    }
}
