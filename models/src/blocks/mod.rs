//! Building blocks shared by representations (and available to plugins outside FieldProbe): the
//! image encoder and the latent-conditioned point MLP.

pub mod decoder;
pub mod encoder;

pub use decoder::{Decoder, DecoderConfig};
pub use encoder::{Encoder, EncoderConfig, Stem};
