//! A per-object field: an MLP of (Fourier-encoded) position, no latent, fitted to one object from
//! its silhouettes (`fit-one`). The representation of the paper's decoder without the encoder.

use burn::prelude::*;
use fieldprobe_core::field::{Field, FieldModel, FieldModelConfig};
use serde::{Deserialize, Serialize};

use crate::blocks::{Decoder, DecoderConfig};

/// `[model] type = "per_object"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerObjectConfig {
    #[serde(default = "DecoderConfig::per_object")]
    pub decoder: DecoderConfig,
}

impl Default for PerObjectConfig {
    fn default() -> Self {
        Self {
            decoder: DecoderConfig::per_object(),
        }
    }
}

#[typetag::serde(name = "per_object")]
impl FieldModelConfig for PerObjectConfig {
    fn decoder_macs_per_point(&self) -> Option<usize> {
        Some(self.decoder.macs_per_point())
    }

    fn validate(&self) -> Result<(), String> {
        self.decoder.validate()
    }

    fn uses_image(&self) -> bool {
        false
    }

    fn init(&self, device: &Device) -> Box<dyn FieldModel> {
        Box::new(PerObject {
            decoder: self.decoder.init(0, device),
        })
    }
}

fieldprobe_core::register_component!(
    Representation,
    "per_object",
    "an occupancy MLP of Fourier-encoded position fitted to one object (needs data.object)",
    r#"type = "per_object"
decoder = { hidden = [256, 256, 256, 128], frequencies = 5 }"#
);

/// A per-object occupancy field.
#[derive(Module, Debug)]
pub struct PerObject {
    pub decoder: Decoder,
}

impl Field for PerObject {
    fn encode(&self, _images: Tensor<4>) -> Option<Tensor<2>> {
        None
    }

    fn logits(&self, _latent: Option<Tensor<2>>, points: Tensor<3>) -> Tensor<2> {
        self.decoder.forward(None, points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A per-object decoder's parameters are its multiply-adds per point plus one bias per unit.
    #[test]
    fn multiply_adds_per_point_match_the_weights() {
        let config = PerObjectConfig {
            decoder: DecoderConfig {
                hidden: vec![48, 32, 16],
                frequencies: 3,
            },
        };
        let model = config.init(&Device::flex().autodiff());
        let macs = config.decoder_macs_per_point().unwrap();
        assert_eq!(macs, (3 + 18) * 48 + 48 * 32 + 32 * 16 + 16);
        assert_eq!(model.parameters(), macs + 48 + 32 + 16 + 1);
    }
}
