//! The paper's single-view model (§3, Fig. 3): image encoder → latent → latent-conditioned MLP
//! decoder with a sigmoid.

use burn::prelude::*;
use fieldprobe_core::field::{Field, FieldModel, FieldModelConfig};
use serde::{Deserialize, Serialize};

use crate::blocks::{Decoder, DecoderConfig, Encoder, EncoderConfig};

/// `[model] type = "single_view"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SingleViewConfig {
    /// Latent size (paper: 128).
    #[serde(default = "SingleViewConfig::paper_latent")]
    pub latent: usize,
    #[serde(default)]
    pub encoder: EncoderConfig,
    #[serde(default)]
    pub decoder: DecoderConfig,
}

impl SingleViewConfig {
    pub(crate) fn paper_latent() -> usize {
        128
    }
}

impl Default for SingleViewConfig {
    fn default() -> Self {
        Self {
            latent: Self::paper_latent(),
            encoder: EncoderConfig::default(),
            decoder: DecoderConfig::default(),
        }
    }
}

#[typetag::serde(name = "single_view")]
impl FieldModelConfig for SingleViewConfig {
    fn decoder_macs_per_point(&self) -> Option<usize> {
        Some(self.decoder.macs_per_point())
    }

    fn validate(&self) -> Result<(), String> {
        if self.latent == 0 {
            return Err("model.latent must be positive".into());
        }
        self.encoder.validate()?;
        self.decoder.validate()
    }

    fn uses_image(&self) -> bool {
        true
    }

    fn init(&self, device: &Device) -> Box<dyn FieldModel> {
        Box::new(SingleView {
            encoder: self.encoder.init(self.latent, device),
            decoder: self.decoder.init(self.latent, device),
        })
    }

    fn load_pretrained(&self, model: &mut dyn FieldModel) -> Result<(), String> {
        self.encoder.load_pretrained("encoder", model)
    }
}

fieldprobe_core::register_component!(
    Representation,
    "single_view",
    "the paper's occupancy network: ResNet image encoder → latent → MLP decoder, φ = sigmoid(out)",
    r#"type = "single_view"
latent = 128
encoder = { channels = [64, 128, 256, 512], blocks = [2, 2, 2, 2], in_channels = 4 }
decoder = { hidden = [2048, 1024, 512, 256, 128], frequencies = 0 }"#
);

/// The paper's single-view model.
#[derive(Module, Debug)]
pub struct SingleView {
    pub encoder: Encoder,
    pub decoder: Decoder,
}

impl Field for SingleView {
    fn encode(&self, images: Tensor<4>) -> Option<Tensor<2>> {
        Some(self.encoder.forward(images))
    }

    fn logits(&self, latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        self.decoder.forward(latent, points)
    }
}
