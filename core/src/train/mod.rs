//! Training a field model from silhouettes by ray-based field probing.
//!
//! One step: draw `batch` training objects (with replacement) and for each a random input view;
//! probe each object on the CPU (samplers + binned assignment, in parallel over objects); then on
//! the device encode the input images, evaluate φ at all anchors, gather and aggregate per ray,
//! and take an Adam step on `L = L_sil + Σ regularizers` (paper eq. 2 and 8). `L_sil` is the
//! paper's: per object, the sum over its supervision views of the mean squared error over the
//! view's `N_r` rays, averaged over the batch's objects — i.e. the mean over all rays times the
//! number of views per object. The scale matters only beside a regularizer: with it, the paper's
//! `λ = 1e-2` weighs the two terms as the paper does (a plain mean would make λ `views`× too
//! strong: with 8 views, enough to stall training at CPU scale).
//!
//! Everything random in a step derives from `(seed, step)`, so a run is reproducible on the CPU
//! backend and a resumed run continues exactly as the uninterrupted one would (weights are
//! initialized from the device seed; see [`Trainer::new`]).

pub mod checkpoint;
mod fit;
mod upload;

pub use fit::{TrainHooks, TrainRun};
pub use upload::{DeviceBatch, UploadedStep};

use std::time::Instant;

use burn::optim::{AdamConfig, ModuleOptimizer, MultiGradientsParams};
use burn::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::field::{Field, FieldModel, FieldModelConfig};
use crate::geometry::NUM_VIEWS;
use crate::object::ObjectViews;
use crate::probe::{
    Aggregator, AnchorSampler, ObjectProbe, ProbeBatch, ProbeSpec, RayMarcher, RaySampler,
    RayValues,
};
use crate::regularize::{FieldQuery, Regularizer};

/// The built components of a run.
#[derive(Debug)]
pub struct Components {
    pub ray_sampler: Box<dyn RaySampler>,
    pub anchor_sampler: Box<dyn AnchorSampler>,
    pub aggregator: Box<dyn Aggregator>,
    /// Dense ray marching instead of field probing: each ray reads the field at its own samples
    /// inside the cube ([`crate::probe::march`]); the anchor sampler then draws only the points
    /// regularizers see. `None`: the paper's probing.
    pub march: Option<Box<dyn RayMarcher>>,
    /// Where ray–anchor assignment runs: `None` binned on the CPU (the prefetch worker), or
    /// tensor kernels on this device ([`crate::probe::assign_on_device`], the same pairs;
    /// `probe.assign_on = "device"`), for GPU runs where the CPU's assignment would be the
    /// bottleneck.
    pub assign_device: Option<Device>,
    /// The loss terms added to the silhouette loss (the loss is their sum); none is the
    /// silhouette loss alone.
    pub regularizers: Vec<Box<dyn Regularizer>>,
}

/// Optimization settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainSpec {
    /// Optimizer steps.
    pub steps: usize,
    /// Objects per step (paper: 8).
    #[serde(default = "TrainSpec::default_batch")]
    pub batch: usize,
    /// Adam learning rate (paper: 1e-4).
    #[serde(default = "TrainSpec::default_lr")]
    pub lr: f64,
    /// If set, the learning rate follows a cosine from `lr` at the first step down to `lr_final`
    /// at the last (what long fits need to settle details); unset keeps `lr` constant (the
    /// paper's setting).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lr_final: Option<f64>,
    /// Write a checkpoint every this many steps (and at the end); 0 = only at the end.
    #[serde(default = "TrainSpec::default_checkpoint_every")]
    pub checkpoint_every: usize,
    /// A `.safetensors` file with every tensor of the model (`experiments export` writes one)
    /// that a fresh run starts from instead of random weights: fine-tuning, or another
    /// dataset. Read once at step 0; `--resume` continues from the checkpoint instead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub init_from: Option<std::path::PathBuf>,
    /// Steps whose probes (sampling and assignment, on the CPU) wait prepared ahead, made on a
    /// worker thread while the device runs the current step (default 2; 0 prepares each step in
    /// turn). Every step's probes depend only on the seed and the step index, so the results are
    /// the same either way.
    #[serde(default = "TrainSpec::default_prefetch")]
    pub prefetch: usize,
    /// Devices a step's batch is split over, data-parallel (default 1): the first `devices`
    /// adapters of the backend (wgpu: GPUs; flex has one CPU device, so `devices = 2` runs two
    /// replicas on it, which exercises the machinery but is not faster). See
    /// [`Trainer::data_parallel`].
    #[serde(
        default = "TrainSpec::default_devices",
        skip_serializing_if = "TrainSpec::is_one_device"
    )]
    pub devices: usize,
}

impl TrainSpec {
    fn default_batch() -> usize {
        8
    }
    fn default_lr() -> f64 {
        1e-4
    }
    fn default_checkpoint_every() -> usize {
        500
    }
    fn default_prefetch() -> usize {
        2
    }
    fn default_devices() -> usize {
        1
    }
    /// The default is not written, so that run directories of earlier versions still match
    /// their experiment files on `--resume`.
    fn is_one_device(n: &usize) -> bool {
        *n == 1
    }

    pub fn validate(&self) -> Result<(), String> {
        if self.steps == 0 || self.batch == 0 {
            return Err("train.steps and train.batch must be positive".into());
        }
        if self.devices == 0 || self.devices > self.batch {
            return Err(format!(
                "train.devices must be in 1..=train.batch ({}): each device takes at least one \
                 object of the batch, got {}",
                self.batch, self.devices
            ));
        }
        if !(self.lr > 0.0 && self.lr.is_finite()) {
            return Err(format!(
                "train.lr must be a positive number, got {}",
                self.lr
            ));
        }
        if let Some(f) = self.lr_final
            && !(f > 0.0 && f <= self.lr)
        {
            return Err(format!(
                "train.lr_final must be positive and at most train.lr ({}), got {f}",
                self.lr
            ));
        }
        Ok(())
    }

    /// The learning rate of step `step` (0-based).
    pub fn lr_at(&self, step: usize) -> f64 {
        match self.lr_final {
            None => self.lr,
            Some(end) => {
                let t = step as f64 / (self.steps.max(2) - 1) as f64;
                end + 0.5 * (self.lr - end) * (1.0 + (std::f64::consts::PI * t.min(1.0)).cos())
            }
        }
    }
}

/// Losses and throughput of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepStats {
    pub step: usize,
    pub loss: f32,
    pub silhouette_loss: f32,
    pub regularizer_loss: f32,
    pub rays: usize,
    /// Ray–anchor pairs assigned.
    pub pairs: usize,
    /// Decoder evaluations (anchors plus regularizer stencils are counted by the anchors only).
    pub points: usize,
    /// Seconds spent sampling and assigning on the CPU.
    pub probe_seconds: f64,
    /// Seconds spent on the device (forward, backward, optimizer), synchronized.
    pub device_seconds: f64,
    /// Seconds the training loop waited for this step's probes: `probe_seconds` when they are
    /// prepared in turn, near zero when a prefetch worker keeps up.
    pub wait_seconds: f64,
}

/// A training failure that is the data's or the configuration's fault, not a bug.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    #[error(
        "the loss became {value} at step {step} (silhouette {sil}, regularizer {reg}); stopping. \
         Lower train.lr or check the data; the last checkpoint is kept"
    )]
    NonFinite {
        step: usize,
        value: f32,
        sil: f32,
        reg: f32,
    },
    /// Writing a checkpoint failed (the error names the file).
    #[error(transparent)]
    Checkpoint(#[from] crate::Error),
}

/// A step's host-side inputs.
#[derive(Clone, Debug)]
pub struct PreparedStep {
    pub batch: ProbeBatch,
    /// `[B, 4, S, S]` input images, if the model reads images.
    pub images: Option<(Vec<f32>, usize)>,
    pub probe_seconds: f64,
    /// The 0-based step the batch was drawn for.
    pub step: usize,
}

impl PreparedStep {
    /// The objects `range` of the step with their input images ([`ProbeBatch::shard`]).
    pub fn shard(&self, range: std::ops::Range<usize>) -> Self {
        let images = self.images.as_ref().map(|(px, s)| {
            let per = 4 * s * s;
            (px[range.start * per..range.end * per].to_vec(), *s)
        });
        Self {
            batch: self.batch.shard(range),
            images,
            probe_seconds: self.probe_seconds,
            step: self.step,
        }
    }
}

/// The objects of a batch of `b` split over `k` devices: contiguous ranges whose sizes differ by
/// at most one (the first ones larger); devices beyond `b` get nothing.
pub fn shard_ranges(b: usize, k: usize) -> Vec<std::ops::Range<usize>> {
    let k = k.clamp(1, b.max(1));
    let (q, r) = (b / k, b % k);
    let mut start = 0;
    (0..k)
        .map(|i| {
            let len = q + usize::from(i < r);
            let range = start..start + len;
            start += len;
            range
        })
        .collect()
}

/// The RNG of step `step` for object slot `slot` under `seed`.
pub fn step_rng(seed: u64, step: usize, slot: usize) -> ChaCha8Rng {
    let mut h = seed ^ 0x51_7c_c1_b7_27_22_0a_95;
    for x in [step as u64 + 1, slot as u64 + 1] {
        h = (h ^ x).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29) ^ (h >> 17);
    }
    ChaCha8Rng::seed_from_u64(h)
}

/// Samples and assigns a step's probes on the CPU.
pub fn prepare_step(
    data: &[ObjectViews],
    comps: &Components,
    probe: &ProbeSpec,
    batch: usize,
    uses_images: bool,
    seed: u64,
    step: usize,
) -> PreparedStep {
    let t0 = Instant::now();
    let mut rng = step_rng(seed, step, 0);
    let picks: Vec<(usize, usize)> = (0..batch)
        .map(|_| {
            (
                rng.random_range(0..data.len()),
                rng.random_range(0..NUM_VIEWS),
            )
        })
        .collect();
    let probes: Vec<ObjectProbe> = picks
        .par_iter()
        .enumerate()
        .map(|(slot, &(obj, _))| {
            let mut rng = step_rng(seed, step, slot + 1);
            let (object, rays, anchors) = (
                &data[obj].supervision,
                comps.ray_sampler.as_ref(),
                comps.anchor_sampler.as_ref(),
            );
            match &comps.march {
                None => ObjectProbe::sample_on(
                    object,
                    probe,
                    rays,
                    anchors,
                    comps.assign_device.as_ref(),
                    &mut rng,
                ),
                Some(m) => ObjectProbe::march(object, probe, rays, anchors, m.as_ref(), &mut rng),
            }
        })
        .collect();
    let images = uses_images.then(|| {
        let s = data[0].image_size;
        let v: Vec<f32> = picks
            .iter()
            .flat_map(|&(o, view)| data[o].view(view))
            .collect();
        (v, s)
    });
    PreparedStep {
        batch: ProbeBatch::assemble(&probes, true),
        images,
        probe_seconds: t0.elapsed().as_secs_f64(),
        step,
    }
}

/// The loss of one uploaded batch: `(total, silhouette, sum of the regularizers)`; the last is
/// `None` when there are none or none contributes this step. The batch's tensors are read by
/// handle (cloning a tensor shares its storage), never copied. `b` must have been uploaded with
/// these `comps` ([`DeviceBatch::upload`] keeps only what they read); otherwise this panics.
pub fn probe_loss(
    model: &dyn Field,
    b: &DeviceBatch,
    comps: &Components,
) -> (Tensor<1>, Tensor<1>, Option<Tensor<1>>) {
    let (nb, n) = (b.objects, b.anchors_per_object);
    // A batch uploaded for other components would silently drop a term: refuse it.
    assert!(
        comps.regularizers.is_empty() || b.sampled.is_some(),
        "probe_loss: the batch was uploaded without sampled anchors, but there are regularizers \
         (upload with the same Components)"
    );
    assert!(
        !comps.aggregator.uses_geometry() || b.geometry.is_some(),
        "probe_loss: the aggregator reads ray geometry, but the batch was uploaded without it \
         (upload with the same Components)"
    );
    let device = &b.anchors.device();
    let latent = b.images.clone().and_then(|images| model.encode(images));
    let phi = model.occupancy(latent.clone(), b.anchors.clone());
    let flat = Tensor::cat(vec![phi.reshape([nb * n]), Tensor::zeros([1], device)], 0);
    let values: Tensor<2> = flat.select(0, b.index.clone()).reshape([b.rays, b.width]);
    let mut rays = RayValues::new(values, b.valid.clone());
    if let Some((depth, distance)) = &b.geometry {
        rays.depth = Some(depth.clone());
        rays.distance = Some(distance.clone());
    }
    let pred = comps.aggregator.aggregate(rays);
    let sil = (pred - b.labels.clone())
        .powi_scalar(2)
        .mean()
        .mul_scalar(b.views_per_object as f32);
    let reg = b.sampled.as_ref().and_then(|sampled| {
        let field = FieldQuery {
            model,
            latent,
            step: b.step,
        };
        comps
            .regularizers
            .iter()
            .filter_map(|r| r.loss(&field, sampled))
            .reduce(|a, b| a + b)
    });
    let total = match &reg {
        Some(r) => sil.clone() + r.clone(),
        None => sil.clone(),
    };
    (total, sil, reg)
}

/// A model with its optimizer and position in training.
pub struct Trainer {
    pub model: Box<dyn FieldModel>,
    pub optim: ModuleOptimizer,
    /// The autodiff device.
    pub device: Device,
    /// Data-parallel training: the autodiff devices a step's batch is split over, the first
    /// being `device` ([`Trainer::data_parallel`]). Empty: everything on `device`.
    pub replicas: Vec<Device>,
    /// Steps done.
    pub step: usize,
    /// Mean loss per logged interval: `(step, loss)`.
    pub history: Vec<(usize, f32)>,
    /// The loss's terms per logged interval: `(step, silhouette, regularizers)` (means).
    pub terms: Vec<(usize, f32, f32)>,
}

impl std::fmt::Debug for Trainer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Trainer")
            .field("step", &self.step)
            .field("device", &self.device)
            .finish_non_exhaustive()
    }
}

impl Trainer {
    /// A fresh model on `device` (made autodiff), its weights drawn from the device RNG seeded
    /// with `seed`.
    pub fn new(config: &dyn FieldModelConfig, device: &Device, seed: u64) -> Self {
        let device = device.clone().autodiff();
        device.seed(seed);
        Self {
            model: config.init(&device),
            optim: AdamConfig::new().init(),
            device,
            replicas: Vec::new(),
            step: 0,
            history: Vec::new(),
            terms: Vec::new(),
        }
    }

    /// Splits every step's batch over `devices` (made autodiff), data-parallel: each device
    /// runs the forward and backward pass of its share of the objects on a replica of the
    /// model, its loss weighted by its share of the batch, and one Adam step (burn's
    /// `step_multi`) applies the sum of the replicas' gradients, so a step is the single-device
    /// step up to float summation order. The model stays on `devices[0]`, which should be
    /// [`Trainer::device`]'s device. Exactly equivalent for representations without batch
    /// statistics (batch norm in the single-view encoder normalizes each shard by its own
    /// statistics) and for regularizers whose term is a mean over objects' points without a
    /// per-step cap (a cap's budget is split between the shards); see README "Many devices".
    pub fn data_parallel(mut self, devices: &[Device]) -> Self {
        if devices.len() > 1 {
            self.replicas = devices.iter().map(|d| d.clone().autodiff()).collect();
            self.device = self.replicas[0].clone();
            self.model = self.model.fork_to(&self.device);
        }
        self
    }

    /// The step's `(loss, silhouette, regularizers)` as numbers (the shards' weighted sums), or
    /// the non-finite-loss error before the optimizer touches the weights.
    fn finite(
        &self,
        [total, sil]: [Tensor<1>; 2],
        reg: Option<Tensor<1>>,
    ) -> Result<(f32, f32, f32), TrainError> {
        let loss: f32 = total.into_scalar();
        let sil: f32 = sil.into_scalar();
        let reg: f32 = reg.map_or(0.0, |r| r.into_scalar());
        if !loss.is_finite() {
            return Err(TrainError::NonFinite {
                step: self.step + 1,
                value: loss,
                sil,
                reg,
            });
        }
        Ok((loss, sil, reg))
    }

    /// The devices a step's batch is uploaded to: the replicas under data parallelism, else the
    /// trainer's device.
    pub fn step_devices(&self) -> Vec<Device> {
        if self.replicas.len() > 1 {
            self.replicas.clone()
        } else {
            vec![self.device.clone()]
        }
    }

    /// [`step`](Self::step) over [`replicas`](Self::replicas): each device's shard of the
    /// objects through its own replica, backward passes launched one after the other (device
    /// work is asynchronous, so the devices overlap), the gradients summed by `step_multi`.
    fn step_data_parallel(
        &mut self,
        uploaded: &UploadedStep,
        comps: &Components,
        lr: f64,
    ) -> Result<(f32, f32, f32), TrainError> {
        let mut grads = MultiGradientsParams::default();
        let mut terms = Vec::new();
        for (part, device) in uploaded.shards.iter().zip(&self.replicas) {
            let share = part.objects as f32 / uploaded.objects as f32;
            let replica = self.model.fork_to(device);
            let (total, sil, reg) = probe_loss(replica.as_ref(), part, comps);
            let total = total.mul_scalar(share);
            let g = total.backward();
            grads.grads.push((replica.gradients(g), device.clone()));
            // Scalars to the main device, so that the terms sum there.
            let here = |t: Tensor<1>| t.mul_scalar(share).to_device(&self.device);
            terms.push((total.to_device(&self.device), here(sil), reg.map(here)));
        }
        let (total, sil, reg) = terms
            .into_iter()
            .reduce(|a, b| {
                let reg = match (a.2, b.2) {
                    (Some(x), Some(y)) => Some(x + y),
                    (x, y) => x.or(y),
                };
                (a.0 + b.0, a.1 + b.1, reg)
            })
            .expect("at least one shard");
        let losses = self.finite([total, sil], reg)?;
        self.model
            .optimize_multi(&mut self.optim, lr, grads, &self.device);
        Ok(losses)
    }

    /// One optimizer step on a prepared batch: uploads it ([`PreparedStep::upload`], moving its
    /// vectors) and takes [`step_uploaded`](Self::step_uploaded).
    pub fn step(
        &mut self,
        prepared: PreparedStep,
        comps: &Components,
        lr: f64,
    ) -> Result<StepStats, TrainError> {
        let uploaded = prepared.upload(comps, &self.step_devices());
        self.step_uploaded(&uploaded, comps, lr)
    }

    /// One optimizer step on a batch already on the device(s) ([`Trainer::step_devices`]).
    pub fn step_uploaded(
        &mut self,
        uploaded: &UploadedStep,
        comps: &Components,
        lr: f64,
    ) -> Result<StepStats, TrainError> {
        let t0 = Instant::now();
        let (loss, sil, reg) = if self.replicas.len() > 1 {
            self.step_data_parallel(uploaded, comps, lr)?
        } else {
            let (total, sil, reg) = probe_loss(self.model.as_ref(), &uploaded.shards[0], comps);
            let grads = total.backward();
            let losses = self.finite([total, sil], reg)?;
            self.model.optimize(&mut self.optim, lr, grads);
            losses
        };
        let _ = self.device.sync();
        self.step += 1;
        Ok(StepStats {
            step: self.step,
            loss,
            silhouette_loss: sil,
            regularizer_loss: reg,
            rays: uploaded.rays,
            pairs: uploaded.pairs,
            points: uploaded.points,
            probe_seconds: uploaded.probe_seconds,
            device_seconds: t0.elapsed().as_secs_f64(),
            wait_seconds: uploaded.probe_seconds,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_schedule_runs_from_lr_to_lr_final() {
        let mut spec = TrainSpec {
            steps: 101,
            batch: 1,
            lr: 1e-3,
            lr_final: Some(1e-5),
            checkpoint_every: 0,
            init_from: None,
            prefetch: 0,
            devices: 1,
        };
        assert!((spec.lr_at(0) - 1e-3).abs() < 1e-12);
        assert!((spec.lr_at(50) - (1e-5 + 0.5 * (1e-3 - 1e-5))).abs() < 1e-12);
        assert!((spec.lr_at(100) - 1e-5).abs() < 1e-12);
        assert!((1..101).all(|s| spec.lr_at(s) <= spec.lr_at(s - 1)));
        spec.lr_final = Some(2e-3);
        assert!(spec.validate().unwrap_err().contains("lr_final"));
        spec.lr_final = None;
        assert_eq!(spec.lr_at(77), 1e-3);
    }
}
