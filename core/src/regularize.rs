//! Regularizers: extra loss terms on the field, evaluated around the step's sampled anchors.

use std::fmt::Debug;

use burn::prelude::*;

use crate::field::{Field, FieldModelConfig};

/// φ for one batch (its latents fixed), queryable at arbitrary points — what a regularizer needs
/// for finite differences around anchors.
#[derive(Debug)]
pub struct FieldQuery<'a> {
    pub model: &'a dyn Field,
    pub latent: Option<Tensor<2>>,
    /// The 0-based index of the optimizer step this loss is for (a term evaluated only every
    /// k-th step reads it).
    pub step: usize,
}

impl FieldQuery<'_> {
    /// φ at `points` `[B, M, 3]` → `[B, M]`.
    pub fn eval(&self, points: Tensor<3>) -> Tensor<2> {
        self.model.occupancy(self.latent.clone(), points)
    }

    /// The logits of φ at `points` `[B, M, 3]` → `[B, M]` (`φ = sigmoid(logits)`).
    pub fn logits(&self, points: Tensor<3>) -> Tensor<2> {
        self.model.logits(self.latent.clone(), points)
    }

    /// The signed distance at `points` `[B, M, 3]` → `[B, M]`, if the representation has one.
    pub fn signed_distance(&self, points: Tensor<3>) -> Option<Tensor<2>> {
        self.model.signed_distance(self.latent.clone(), points)
    }
}

/// A weighted loss term on the field.
pub trait Regularizer: Send + Sync + Debug {
    /// The term (already multiplied by its weight) around the step's anchors `[B, N, 3]`: every
    /// anchor the samplers drew for each object, whether a ray met it or not (the inside of a
    /// silhouette, which no ray constrains, is where a prior matters most). `None` when it
    /// contributes nothing this step. A regularizer evaluates the field itself where it needs it.
    fn loss(&self, field: &FieldQuery<'_>, anchors: &Tensor<3>) -> Option<Tensor<1>>;
}

/// The TOML/serde side of a regularizer.
#[typetag::serde(tag = "type")]
pub trait RegularizerConfig: Send + Sync + Debug {
    fn build(&self) -> Result<Box<dyn Regularizer>, String>;

    /// Whether this term can act on `model`'s representation (an eikonal term needs a signed
    /// distance); checked when an experiment is loaded, so a mismatch is a config error, not a
    /// failure mid-run. The error says what the term needs.
    fn check_model(&self, _model: &dyn FieldModelConfig) -> Result<(), String> {
        Ok(())
    }
}
