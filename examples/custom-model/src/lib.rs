//! A `film` representation: the paper's image encoder, but the latent conditions the decoder by
//! feature-wise linear modulation (FiLM, Perez et al. 2018; Occupancy Networks' conditional batch
//! norm is the same idea) of every hidden layer, `h ← relu(h ⊙ (1 + γ_l(z)) + β_l(z))`, instead of
//! being added once at the input. Deeper conditioning lets the latent reshape every layer's
//! features, which is what a decoder that must read the image (not only the category prior)
//! needs.
//!
//! Everything FieldProbe needs of a representation is [`Field`] on a burn module and a typetag
//! [`FieldModelConfig`]; training, checkpoints, evaluation and meshes then work unchanged.

use burn::nn::{Linear, LinearConfig};
use burn::prelude::*;
use burn::tensor::activation::relu;
use fieldprobe_core::field::{Field, FieldModel, FieldModelConfig};
use fieldprobe_core::register_component;
use fieldprobe_models::{Encoder, EncoderConfig};
use serde::{Deserialize, Serialize};

/// `[model] type = "film"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmConfig {
    /// Latent size.
    #[serde(default = "FilmConfig::default_latent")]
    pub latent: usize,
    /// The image encoder (FieldProbe's ResNet-style block).
    #[serde(default)]
    pub encoder: EncoderConfig,
    /// Hidden widths of the decoder; every layer is modulated.
    #[serde(default = "FilmConfig::default_hidden")]
    pub hidden: Vec<usize>,
}

impl FilmConfig {
    fn default_latent() -> usize {
        64
    }
    fn default_hidden() -> Vec<usize> {
        vec![256, 256, 128]
    }

    /// The module itself.
    pub fn build(&self, device: &Device) -> Film {
        let h = &self.hidden;
        Film {
            encoder: self.encoder.init(self.latent, device),
            point_in: LinearConfig::new(3, h[0]).init(device),
            layers: h
                .windows(2)
                .map(|w| LinearConfig::new(w[0], w[1]).init(device))
                .collect(),
            film: h
                .iter()
                .map(|&w| LinearConfig::new(self.latent, 2 * w).init(device))
                .collect(),
            out: LinearConfig::new(*h.last().expect("validated"), 1).init(device),
        }
    }
}

impl Default for FilmConfig {
    fn default() -> Self {
        Self {
            latent: Self::default_latent(),
            encoder: EncoderConfig::default(),
            hidden: Self::default_hidden(),
        }
    }
}

#[typetag::serde(name = "film")]
impl FieldModelConfig for FilmConfig {
    fn validate(&self) -> Result<(), String> {
        if self.latent == 0 {
            return Err("model.latent must be positive".into());
        }
        if self.hidden.is_empty() || self.hidden.contains(&0) {
            return Err(format!(
                "model.hidden must be non-empty positive widths, got {:?}",
                self.hidden
            ));
        }
        self.encoder.validate()
    }

    fn uses_image(&self) -> bool {
        true
    }

    fn init(&self, device: &Device) -> Box<dyn FieldModel> {
        Box::new(self.build(device))
    }
}

register_component!(
    Representation,
    "film",
    "an occupancy decoder whose every hidden layer is FiLM-modulated by the image latent (examples/custom-model)",
    r#"type = "film"
latent = 64
encoder = { channels = [64, 128, 256, 512], blocks = [2, 2, 2, 2], in_channels = 4 }
hidden = [256, 256, 128]"#
);

/// The FiLM-conditioned occupancy network.
#[derive(Module, Debug)]
pub struct Film {
    encoder: Encoder,
    point_in: Linear,
    layers: Vec<Linear>,
    /// Per hidden layer, `z ↦ [γ, β]`.
    film: Vec<Linear>,
    out: Linear,
}

impl Film {
    fn modulate(&self, l: usize, x: Tensor<3>, z: &Tensor<2>) -> Tensor<3> {
        let [b, _, w] = x.dims();
        let gb: Tensor<2> = self.film[l].forward(z.clone());
        let gamma: Tensor<3> = gb.clone().narrow(1, 0, w).reshape([b, 1, w]);
        let beta: Tensor<3> = gb.narrow(1, w, w).reshape([b, 1, w]);
        relu(x * gamma.add_scalar(1.0) + beta)
    }
}

impl Field for Film {
    fn encode(&self, images: Tensor<4>) -> Option<Tensor<2>> {
        Some(self.encoder.forward(images))
    }

    fn logits(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        let z = latent.expect("the film representation reads an image latent");
        let mut x = self.modulate(0, self.point_in.forward(points), &z);
        for (l, layer) in self.layers.iter().enumerate() {
            x = self.modulate(l + 1, layer.forward(x), &z);
        }
        let out: Tensor<3> = self.out.forward(x);
        out.squeeze_dim(2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_latent_changes_the_field_at_every_depth() {
        let dev = Device::flex();
        let cfg = FilmConfig {
            latent: 4,
            encoder: EncoderConfig {
                channels: vec![4],
                blocks: vec![1],
                in_channels: 4,
                ..EncoderConfig::default()
            },
            hidden: vec![8, 8],
        };
        let m = cfg.build(&dev);
        let p = Tensor::<3>::from_data(TensorData::new(vec![0.1f32, -0.2, 0.3], [1, 1, 3]), &dev);
        let z0 = Tensor::<2>::zeros([1, 4], &dev);
        let z1 = Tensor::<2>::ones([1, 4], &dev);
        let a: f32 = m.logits(Some(z0), p.clone()).into_scalar();
        let b: f32 = m.logits(Some(z1), p).into_scalar();
        assert!((a - b).abs() > 1e-6, "{a} vs {b}");
        assert!(m.level() == 0.5);
    }
}
