//! Field models: φ(z, p) ∈ (0, 1), the occupancy probability of point `p` given latent `z`.
//!
//! burn modules are not object-safe, so the model choice is an enum config ([`FieldModelConfig`],
//! `type = "single_view" | "per_object"` in TOML) whose [`init`](FieldModelConfig::init) returns an
//! enum module ([`FieldModel`]), the pattern of burn's own `ActivationConfig`/`Activation`.
//!
//! * `single_view` — the paper's model: a ResNet-style image encoder (trained from scratch) → latent
//!   → latent-conditioned MLP decoder with a sigmoid.
//! * `per_object` — no encoder: an MLP of (Fourier-encoded) position that fits one object from its
//!   silhouettes.

pub mod decoder;
pub mod encoder;

use burn::prelude::*;
use serde::{Deserialize, Serialize};

pub use decoder::{Decoder, DecoderConfig};
pub use encoder::{Encoder, EncoderConfig};

/// Which field model to build.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum FieldModelConfig {
    /// Image encoder + latent-conditioned decoder (paper §3, Fig. 3).
    SingleView {
        /// Latent size (paper: 128).
        #[serde(default = "default_latent")]
        latent: usize,
        #[serde(default)]
        encoder: EncoderConfig,
        #[serde(default)]
        decoder: DecoderConfig,
    },
    /// A position-only MLP fitted to one object.
    PerObject {
        #[serde(default = "DecoderConfig::per_object")]
        decoder: DecoderConfig,
    },
}

fn default_latent() -> usize {
    128
}

impl Default for FieldModelConfig {
    fn default() -> Self {
        FieldModelConfig::SingleView {
            latent: default_latent(),
            encoder: EncoderConfig::default(),
            decoder: DecoderConfig::default(),
        }
    }
}

impl FieldModelConfig {
    /// Checks sizes; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            FieldModelConfig::SingleView {
                latent,
                encoder,
                decoder,
            } => {
                if *latent == 0 {
                    return Err("model.latent must be positive".into());
                }
                encoder.validate()?;
                decoder.validate()
            }
            FieldModelConfig::PerObject { decoder } => decoder.validate(),
        }
    }

    /// Whether the model reads the input image.
    pub fn uses_image(&self) -> bool {
        matches!(self, FieldModelConfig::SingleView { .. })
    }

    /// Builds the model on `device` (use an autodiff device to train).
    pub fn init(&self, device: &Device) -> FieldModel {
        match self {
            FieldModelConfig::SingleView {
                latent,
                encoder,
                decoder,
            } => FieldModel::SingleView(SingleView {
                encoder: encoder.init(*latent, device),
                decoder: decoder.init(*latent, device),
            }),
            FieldModelConfig::PerObject { decoder } => FieldModel::PerObject(PerObject {
                decoder: decoder.init(0, device),
            }),
        }
    }
}

/// The paper's single-view model.
#[derive(Module, Debug)]
pub struct SingleView {
    pub encoder: Encoder,
    pub decoder: Decoder,
}

/// A per-object field (no latent).
#[derive(Module, Debug)]
pub struct PerObject {
    pub decoder: Decoder,
}

/// A trainable occupancy field.
// The variants are module handles (a few hundred bytes each, created once per run); boxing them
// would buy nothing and complicate the Module derive.
#[allow(clippy::large_enum_variant)]
#[derive(Module, Debug)]
pub enum FieldModel {
    SingleView(SingleView),
    PerObject(PerObject),
}

impl FieldModel {
    /// Latent codes `[B, Z]` of input images `[B, 4, S, S]` (RGBA in `[0, 1]`); `None` for a
    /// per-object field.
    pub fn encode(&self, images: Tensor<4>) -> Option<Tensor<2>> {
        match self {
            FieldModel::SingleView(m) => Some(m.encoder.forward(images)),
            FieldModel::PerObject(_) => None,
        }
    }

    /// Occupancy `[B, N]` at points `[B, N, 3]` given latents `[B, Z]`.
    pub fn decode(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        match self {
            FieldModel::SingleView(m) => m.decoder.forward(latent, points),
            FieldModel::PerObject(m) => m.decoder.forward(None, points),
        }
    }

    /// The logits of [`decode`](Self::decode) (`φ = sigmoid(logits)`).
    pub fn decode_logits(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        match self {
            FieldModel::SingleView(m) => m.decoder.forward_logits(latent, points),
            FieldModel::PerObject(m) => m.decoder.forward_logits(None, points),
        }
    }
}
