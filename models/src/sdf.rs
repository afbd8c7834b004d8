//! A signed-distance representation trained from silhouettes (in the spirit of VolSDF and NeuS):
//! the decoder outputs a signed distance `s(z, p)` (negative inside), and the occupancy that
//! probing aggregates is `φ = sigmoid(−s/β)` with a learnable sharpness β > 0. The surface is the
//! zero set, i.e. `φ = ½`, so evaluation reads it exactly as it reads an occupancy network.
//!
//! Two choices, both the common ones:
//! * **Geometric initialization.** `s = MLP(z, p) + (|p| − r₀)`: at initialization the field is
//!   roughly the distance to a sphere of radius `r₀` (SAL/IGR initialize their networks to a
//!   sphere for the same reason: a distance-like start that the eikonal term keeps distance-like).
//!   `sphere = 0` turns it off.
//! * **β.** `β = β_min + exp(b)` with `b` a trained scalar, started at `beta`; `β_min` (1e-3, a
//!   thirtieth of a voxel) keeps the sigmoid from becoming a step that has no gradient.
//!
//! Without an eikonal regularizer (`[regularizers.eikonal] type = "eikonal"`) nothing makes `s` a
//! distance: only `−s/β` is constrained by silhouettes.

use burn::module::Param;
use burn::prelude::*;
use burn::tensor::activation::sigmoid;
use fieldprobe_core::field::{Field, FieldModel, FieldModelConfig};
use serde::{Deserialize, Serialize};

use crate::blocks::{Decoder, DecoderConfig, Encoder, EncoderConfig};

/// Smallest β: the sigmoid stays at least this wide.
pub const BETA_MIN: f32 = 1e-3;

/// `[model] type = "sdf"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SdfConfig {
    /// Latent size; 0 makes a per-object field (no encoder; needs `data.object`).
    #[serde(default = "crate::single_view::SingleViewConfig::paper_latent")]
    pub latent: usize,
    /// The image encoder (unused when `latent = 0`).
    #[serde(default)]
    pub encoder: EncoderConfig,
    /// The decoder; by default the paper's widths with a latent, the per-object MLP without.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decoder: Option<DecoderConfig>,
    /// Initial β of `φ = sigmoid(−s/β)`, in the units of the unit cube (default 0.02, about
    /// two thirds of a 32³ voxel).
    #[serde(default = "SdfConfig::default_beta")]
    pub beta: f32,
    /// Radius of the initial sphere (0 = no geometric initialization).
    #[serde(default = "SdfConfig::default_sphere")]
    pub sphere: f32,
}

impl SdfConfig {
    fn default_beta() -> f32 {
        0.02
    }
    fn default_sphere() -> f32 {
        0.3
    }

    /// The decoder this config builds.
    pub fn decoder(&self) -> DecoderConfig {
        self.decoder.clone().unwrap_or_else(|| {
            if self.latent == 0 {
                DecoderConfig::per_object()
            } else {
                DecoderConfig::default()
            }
        })
    }
}

impl SdfConfig {
    /// The module itself (what [`FieldModelConfig::init`] boxes).
    pub fn build(&self, device: &Device) -> Sdf {
        let b = (self.beta - BETA_MIN).ln();
        Sdf {
            encoder: (self.latent > 0).then(|| self.encoder.init(self.latent, device)),
            decoder: self.decoder().init(self.latent, device),
            log_beta: Param::from_tensor(Tensor::from_floats([b], device)),
            sphere: self.sphere,
        }
    }
}

impl Default for SdfConfig {
    fn default() -> Self {
        Self {
            latent: crate::single_view::SingleViewConfig::paper_latent(),
            encoder: EncoderConfig::default(),
            decoder: None,
            beta: Self::default_beta(),
            sphere: Self::default_sphere(),
        }
    }
}

#[typetag::serde(name = "sdf")]
impl FieldModelConfig for SdfConfig {
    fn decoder_macs_per_point(&self) -> Option<usize> {
        Some(self.decoder().macs_per_point())
    }

    fn validate(&self) -> Result<(), String> {
        if !(self.beta > BETA_MIN && self.beta.is_finite()) {
            return Err(format!(
                "model.beta must be a number above {BETA_MIN}, got {}",
                self.beta
            ));
        }
        if !(0.0..0.5).contains(&self.sphere) {
            return Err(format!(
                "model.sphere must be in [0, 0.5) (a radius in the unit cube), got {}",
                self.sphere
            ));
        }
        if self.latent > 0 {
            self.encoder.validate()?;
        }
        self.decoder().validate()
    }

    fn uses_image(&self) -> bool {
        self.latent > 0
    }

    fn has_signed_distance(&self) -> bool {
        true
    }

    fn init(&self, device: &Device) -> Box<dyn FieldModel> {
        Box::new(self.build(device))
    }

    fn load_pretrained(&self, model: &mut dyn FieldModel) -> Result<(), String> {
        if self.latent == 0 {
            return Ok(());
        }
        self.encoder.load_pretrained("encoder", model)
    }
}

fieldprobe_core::register_component!(
    Representation,
    "sdf",
    "a signed-distance field, φ = sigmoid(−sdf/β) with β learned (VolSDF/NeuS-style); latent = 0 fits one object",
    r#"type = "sdf"
latent = 128
encoder = { channels = [64, 128, 256, 512], blocks = [2, 2, 2, 2], in_channels = 4 }
decoder = { hidden = [2048, 1024, 512, 256, 128], frequencies = 0 }
beta = 0.02
sphere = 0.3"#
);

/// A signed-distance field.
#[derive(Module, Debug)]
pub struct Sdf {
    pub encoder: Option<Encoder>,
    pub decoder: Decoder,
    /// `b` of `β = β_min + exp(b)`, shape `[1]`.
    pub log_beta: Param<Tensor<1>>,
    /// Radius of the geometric initialization's sphere.
    pub sphere: f32,
}

impl Sdf {
    /// The current β, as a `[1]` tensor (differentiable).
    pub fn beta(&self) -> Tensor<1> {
        self.log_beta.val().exp().add_scalar(BETA_MIN)
    }

    /// The signed distance `[B, N]` at `points` `[B, N, 3]`.
    pub fn distance(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        let raw = self.decoder.forward(latent, points.clone());
        if self.sphere == 0.0 {
            return raw;
        }
        let radius: Tensor<2> = points.powi_scalar(2).sum_dim(2).sqrt().squeeze_dim(2);
        raw + radius.sub_scalar(self.sphere)
    }
}

impl Field for Sdf {
    fn encode(&self, images: Tensor<4>) -> Option<Tensor<2>> {
        self.encoder.as_ref().map(|e| e.forward(images))
    }

    fn logits(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        let inv_beta: Tensor<2> = self.beta().recip().unsqueeze();
        self.distance(latent, points).neg() * inv_beta
    }

    fn occupancy(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        sigmoid(self.logits(latent, points))
    }

    fn signed_distance(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Option<Tensor<2>> {
        Some(self.distance(latent, points))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn per_object(beta: f32) -> SdfConfig {
        SdfConfig {
            latent: 0,
            decoder: Some(DecoderConfig {
                hidden: vec![16, 16],
                frequencies: 0,
            }),
            beta,
            ..SdfConfig::default()
        }
    }

    fn points(dev: &Device) -> Tensor<3> {
        let p: Vec<f32> = (0..60)
            .map(|i| ((i * 37 % 101) as f32 / 101.0) - 0.5)
            .collect();
        Tensor::from_data(TensorData::new(p, [1, 20, 3]), dev)
    }

    #[test]
    fn occupancy_is_the_sigmoid_of_minus_distance_over_beta() {
        let dev = Device::flex();
        let model = per_object(0.05).init(&dev);
        let p = points(&dev);
        let s: Vec<f32> = model
            .signed_distance(None, p.clone())
            .expect("an SDF has a distance")
            .try_into_vec_as()
            .unwrap();
        let occ: Vec<f32> = model.occupancy(None, p).try_into_vec_as().unwrap();
        for (s, o) in s.iter().zip(&occ) {
            let want = 1.0 / (1.0 + (s / 0.05).exp());
            assert!((o - want).abs() < 1e-5, "s {s}: φ {o}, want {want}");
        }
        // Inside (s < 0) reads above the level, outside below: the surface is the zero set.
        assert!(
            s.iter()
                .zip(&occ)
                .all(|(s, o)| (*s < 0.0) == (*o > model.level()))
        );
    }

    #[test]
    fn beta_is_trained() {
        use burn::optim::AdamConfig;
        let dev = Device::flex().autodiff();
        let mut model = per_object(0.05).build(&dev);
        let beta0: f32 = model.beta().into_scalar();
        assert!((beta0 - 0.05).abs() < 1e-6);
        // Sharpen: push φ towards 1 where it is above ½ and towards 0 below. Whatever the
        // weights, a smaller β moves every point towards its target, so the loss's gradient
        // with respect to b (β = β_min + eᵇ) is positive and a step lowers β.
        let p = points(&dev);
        let before: Vec<f32> = model.occupancy(None, p.clone()).try_into_vec_as().unwrap();
        let target: Vec<f32> = before.iter().map(|&o| (o > 0.5) as u8 as f32).collect();
        let target = Tensor::<2>::from_data(TensorData::new(target, [1, 20]), &dev);
        let loss = (model.occupancy(None, p) - target).powi_scalar(2).mean();
        let grads = loss.backward();
        let g: f32 = model
            .log_beta
            .val()
            .grad(&grads)
            .expect("β has a gradient")
            .into_scalar();
        assert!(g > 0.0, "dL/db = {g}");
        model.optimize(&mut AdamConfig::new().init(), 1e-2, grads);
        let beta1: f32 = model.beta().into_scalar();
        assert!(beta1 < beta0, "a step lowers β: {beta0} → {beta1}");
    }

    #[test]
    fn config_rejects_bad_values_by_name() {
        let bad = SdfConfig {
            beta: 0.0,
            ..SdfConfig::default()
        };
        assert!(bad.validate().unwrap_err().contains("model.beta"));
        let bad = SdfConfig {
            sphere: 0.7,
            ..SdfConfig::default()
        };
        assert!(bad.validate().unwrap_err().contains("model.sphere"));
        let cfg: Box<dyn FieldModelConfig> =
            toml::from_str("type = \"sdf\"\nlatent = 0\nbeta = 0.05").unwrap();
        assert!(!cfg.uses_image() && cfg.has_signed_distance());
    }
}
