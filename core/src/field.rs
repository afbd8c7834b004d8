//! Representations: what a field model is to the rest of FieldProbe.
//!
//! A representation (the paper's occupancy network, a per-object MLP, a signed-distance field, a
//! user's own) is a burn [`Module`] that implements [`Field`]: how it reads images into latents
//! and how it maps points to logits. Every such module is a [`FieldModel`] through a blanket
//! impl, which adds what training and checkpoints need (an optimizer step, saving, loading) in
//! object-safe form. Its TOML side is a [`FieldModelConfig`] registered with typetag, like every
//! other plugin (`[model] type = "single_view" | "per_object" | "sdf" | …`).
//!
//! # Why a trait object over a generic module
//!
//! burn modules are not object safe (`Module: Clone`, generic visitors and mappers, an associated
//! record type), so `Box<dyn Module>` does not exist. The choice here: the *module* stays a
//! concrete type, and the blanket [`FieldModel`] impl is monomorphized once per representation,
//! so everything that walks the module's parameters (gradients, the Adam step, records) runs on
//! the concrete type. The rest of the pipeline holds a `Box<dyn FieldModel>` and calls it a few
//! times per step (encode, logits, optimize): one virtual call against milliseconds of tensor
//! work, so nothing is lost by not making the training loop generic, and the loop, evaluation,
//! checkpoints and the CLI exist once instead of once per representation.
//!
//! Evaluation reads a field only through [`Field`]: its occupancy and the [`level`](Field::level)
//! at which the representation puts its surface (an occupancy network's ½, an SDF's zero set).

use std::fmt::Debug;
use std::path::Path;

use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer, MultiGradientsParams};
use burn::prelude::*;
use burn::tensor::Gradients;
use burn::tensor::activation::sigmoid;

use crate::weights::{self, Import, ImportReport};

/// A field φ(z, p) ∈ (0, 1): the occupancy probability of point `p` given latent `z`.
pub trait Field: Send + Debug {
    /// Latent codes `[B, Z]` of input images `[B, 4, S, S]` (RGBA in `[0, 1]`); `None` for a
    /// representation that does not read images (a per-object fit).
    fn encode(&self, images: Tensor<4>) -> Option<Tensor<2>>;

    /// The logits `[B, N]` of φ at `points` `[B, N, 3]` given latents `[B, Z]`:
    /// `φ = sigmoid(logits)`. Finite differences (the normal-consistency regularizer) are taken
    /// of them, since they keep a gradient where φ saturates.
    fn logits(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2>;

    /// Occupancy `[B, N]` at `points` `[B, N, 3]`: what probing aggregates along rays and what
    /// evaluation voxelizes.
    fn occupancy(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        sigmoid(self.logits(latent, points))
    }

    /// The occupancy at which this representation puts its surface: inside is
    /// `occupancy ≥ level`. ½ for an occupancy network; for an SDF with
    /// `occupancy = sigmoid(−sdf/β)` also ½, the zero set.
    fn level(&self) -> f32 {
        0.5
    }

    /// The signed distance `[B, N]` (negative inside), for representations that have one; what
    /// an eikonal regularizer constrains. `None` by default.
    fn signed_distance(&self, _latent: Option<Tensor<2>>, _points: Tensor<3>) -> Option<Tensor<2>> {
        None
    }
}

/// A trainable field: a [`Field`] that can take optimizer steps and be checkpointed.
///
/// Implemented for every burn [`Module`] that is a [`Field`]; a representation never implements
/// it by hand.
pub trait FieldModel: Field {
    /// A copy of the model (burn modules share their parameters' storage until written).
    fn clone_model(&self) -> Box<dyn FieldModel>;
    /// The model in evaluation mode (no autodiff graph is recorded).
    fn valid_model(&self) -> Box<dyn FieldModel>;
    /// One optimizer step with the gradients of a loss computed through this model.
    fn optimize(&mut self, optim: &mut ModuleOptimizer, lr: f64, grads: Gradients);
    /// A replica on `device` for data-parallel training (burn's `Module::fork`: the same
    /// parameter ids, its own autodiff graph).
    fn fork_to(&self, device: &Device) -> Box<dyn FieldModel>;
    /// The gradients of a loss computed through this model (a replica), by parameter id.
    fn gradients(&self, grads: Gradients) -> GradientsParams;
    /// One optimizer step with the replicas' gradients, summed per parameter
    /// (`ModuleOptimizer::step_multi`); the updated model is then moved to `device`.
    fn optimize_multi(
        &mut self,
        optim: &mut ModuleOptimizer,
        lr: f64,
        grads: MultiGradientsParams,
        device: &Device,
    );
    /// Writes the weights to `path` (burn's `.bpk`).
    fn save_weights(&self, path: &Path) -> Result<(), String>;
    /// Replaces the weights by those at `path`; fails if they do not fit this model's shapes.
    fn load_weights(&mut self, path: &Path) -> Result<(), String>;
    /// Writes the weights to `path` as safetensors, tensors named by module path, `metadata`
    /// in the header ([`crate::weights::export`]).
    fn export_safetensors(&self, path: &Path, metadata: &[(String, String)]) -> Result<(), String>;
    /// Reads weights from a safetensors file by name ([`crate::weights::import`]).
    fn import_safetensors(&mut self, path: &Path, spec: &Import) -> Result<ImportReport, String>;
    /// Number of scalar parameters.
    fn parameters(&self) -> usize;
}

impl<M: Module + Field + 'static> FieldModel for M {
    fn clone_model(&self) -> Box<dyn FieldModel> {
        Box::new(self.clone())
    }

    fn valid_model(&self) -> Box<dyn FieldModel> {
        Box::new(self.valid())
    }

    fn optimize(&mut self, optim: &mut ModuleOptimizer, lr: f64, grads: Gradients) {
        let grads = GradientsParams::from_grads(grads, self);
        *self = optim.step(lr, self.clone(), grads);
    }

    fn fork_to(&self, device: &Device) -> Box<dyn FieldModel> {
        Box::new(self.clone().fork(device))
    }

    fn gradients(&self, grads: Gradients) -> GradientsParams {
        GradientsParams::from_grads(grads, self)
    }

    fn optimize_multi(
        &mut self,
        optim: &mut ModuleOptimizer,
        lr: f64,
        grads: MultiGradientsParams,
        device: &Device,
    ) {
        // step_multi leaves each parameter on the device its gradients were summed on.
        *self = optim.step_multi(lr, self.clone(), grads).fork(device);
    }

    fn save_weights(&self, path: &Path) -> Result<(), String> {
        self.clone().save_file(path).map_err(|e| e.to_string())
    }

    fn load_weights(&mut self, path: &Path) -> Result<(), String> {
        *self = self
            .clone()
            .try_load_file(path)
            .map_err(|e| e.to_string())?;
        Ok(())
    }

    fn export_safetensors(&self, path: &Path, metadata: &[(String, String)]) -> Result<(), String> {
        weights::export(self, path, metadata)
    }

    fn import_safetensors(&mut self, path: &Path, spec: &Import) -> Result<ImportReport, String> {
        weights::import(self, path, spec)
    }

    fn parameters(&self) -> usize {
        self.num_params()
    }
}

/// The TOML/serde side of a representation (`[model] type = "…"`).
#[typetag::serde(tag = "type")]
pub trait FieldModelConfig: Send + Sync + Debug {
    /// Checks sizes; the error names the key (`model.latent must be positive`).
    fn validate(&self) -> Result<(), String>;

    /// Whether the model reads the input image (a single-view model) or fits one object (a
    /// per-object field, which needs `data.object`).
    fn uses_image(&self) -> bool;

    /// Whether [`Field::signed_distance`] of the built model returns a distance.
    fn has_signed_distance(&self) -> bool {
        false
    }

    /// Builds the model on `device` (an autodiff device to train), weights drawn from the
    /// device's RNG.
    fn init(&self, device: &Device) -> Box<dyn FieldModel>;

    /// Multiply-adds per evaluated point of the implicit decoder (what a point costs; the latent's
    /// share is paid once per object), for throughput figures in `experiments bench`. Default:
    /// unknown.
    fn decoder_macs_per_point(&self) -> Option<usize> {
        None
    }

    /// Loads the weights this configuration asks a fresh model to start from (an ImageNet
    /// ResNet for the encoder, say) into `model`, built by [`init`](Self::init). Called once
    /// when training starts from step 0, never on `--resume` or for evaluation (a checkpoint
    /// holds the weights then), so the file is needed only to start. Default: none.
    fn load_pretrained(&self, _model: &mut dyn FieldModel) -> Result<(), String> {
        Ok(())
    }
}
