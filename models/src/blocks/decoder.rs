//! The implicit decoder: an MLP of `[z, γ(p)]` with ReLUs and one linear output (paper: FC
//! 2048-1024-512-256-128-1). The output is the representation's raw scalar: the logit of
//! occupancy for an occupancy network, the signed distance for an SDF.
//!
//! The first layer is split into a latent part and a point part, `W·[z, γ(p)] = W_z·z + W_p·γ(p)`,
//! so the latent is multiplied once per object instead of once per point: the same function as the
//! concatenation, without materializing `[B, N, Z]`. `γ` is an optional Fourier encoding
//! (`frequencies = F` adds `sin(2^k π p), cos(2^k π p)` for `k < F`), useful for the per-object
//! fit; the paper's model uses `F = 0` (raw coordinates).

use burn::nn::{Linear, LinearConfig};
use burn::prelude::*;
use burn::tensor::activation::relu;
use serde::{Deserialize, Serialize};

/// Decoder widths and encoding.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecoderConfig {
    /// Hidden widths (paper: [2048, 1024, 512, 256, 128]).
    #[serde(default = "DecoderConfig::paper_hidden")]
    pub hidden: Vec<usize>,
    /// Fourier frequencies of the point encoding (0 = raw coordinates, as in the paper).
    #[serde(default)]
    pub frequencies: usize,
}

impl Default for DecoderConfig {
    fn default() -> Self {
        Self {
            hidden: Self::paper_hidden(),
            frequencies: 0,
        }
    }
}

impl DecoderConfig {
    fn paper_hidden() -> Vec<usize> {
        vec![2048, 1024, 512, 256, 128]
    }

    /// The per-object default: narrower, with a Fourier encoding for detail.
    pub fn per_object() -> Self {
        Self {
            hidden: vec![256, 256, 256, 128],
            frequencies: 5,
        }
    }

    pub fn validate(&self) -> Result<(), String> {
        if self.hidden.is_empty() || self.hidden.contains(&0) {
            return Err(format!(
                "model.decoder.hidden must be non-empty positive widths, got {:?}",
                self.hidden
            ));
        }
        if self.frequencies > 12 {
            return Err(format!(
                "model.decoder.frequencies = {} is more than 12",
                self.frequencies
            ));
        }
        Ok(())
    }

    /// Size of the encoded point.
    pub fn point_dim(&self) -> usize {
        3 + 6 * self.frequencies
    }

    /// Multiply-adds per point: the encoded point into the first layer, the hidden layers, the
    /// output (the latent enters as one bias per object, not per point).
    pub fn macs_per_point(&self) -> usize {
        let last = *self.hidden.last().unwrap_or(&0);
        self.point_dim() * self.hidden.first().unwrap_or(&0)
            + self.hidden.windows(2).map(|w| w[0] * w[1]).sum::<usize>()
            + last
    }

    /// Builds a decoder for latents of size `latent` (0 = no latent).
    pub fn init(&self, latent: usize, device: &Device) -> Decoder {
        let h0 = self.hidden[0];
        let mut layers = Vec::new();
        for w in self.hidden.windows(2) {
            layers.push(LinearConfig::new(w[0], w[1]).init(device));
        }
        let last = *self.hidden.last().expect("validated");
        Decoder {
            latent_in: (latent > 0)
                .then(|| LinearConfig::new(latent, h0).with_bias(false).init(device)),
            point_in: LinearConfig::new(self.point_dim(), h0).init(device),
            hidden: layers,
            out: LinearConfig::new(last, 1).init(device),
            frequencies: self.frequencies,
        }
    }
}

/// The decoder module.
#[derive(Module, Debug)]
pub struct Decoder {
    latent_in: Option<Linear>,
    point_in: Linear,
    hidden: Vec<Linear>,
    out: Linear,
    frequencies: usize,
}

impl Decoder {
    /// `γ(p)`: `[B, N, 3]` → `[B, N, 3 + 6F]`.
    pub fn encode_points(&self, points: Tensor<3>) -> Tensor<3> {
        if self.frequencies == 0 {
            return points;
        }
        let mut parts = vec![points.clone()];
        for k in 0..self.frequencies {
            let scaled = points
                .clone()
                .mul_scalar(std::f32::consts::PI * (1u32 << k) as f32);
            parts.push(scaled.clone().sin());
            parts.push(scaled.cos());
        }
        Tensor::cat(parts, 2)
    }

    /// The raw output `[B, N]` at `points` `[B, N, 3]`, given latents `[B, Z]` (or none for a
    /// decoder built without a latent).
    pub fn forward(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        let mut x = self.point_in.forward(self.encode_points(points));
        if let (Some(layer), Some(z)) = (&self.latent_in, latent) {
            let zb: Tensor<3> = layer.forward(z).unsqueeze_dim(1);
            x = x + zb;
        }
        let mut x = relu(x);
        for layer in &self.hidden {
            x = relu(layer.forward(x));
        }
        let logits: Tensor<3> = self.out.forward(x);
        logits.squeeze_dim(2)
    }
}
