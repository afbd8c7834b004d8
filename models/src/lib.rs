//! FieldProbe representations: [`FieldModel`](fieldprobe_core::field::FieldModel) plugins.
//!
//! * [`single_view`] — the paper's model: a ResNet-style image encoder → latent → an MLP decoder
//!   whose output is the logit of occupancy (`[model] type = "single_view"`).
//! * [`per_object`] — no encoder: an MLP of (Fourier-encoded) position that fits one object from
//!   its silhouettes (`type = "per_object"`).
//! * [`sdf`] — a signed-distance field whose occupancy is `sigmoid(−sdf/β)` with a learnable β
//!   (`type = "sdf"`), image-conditioned or per-object.
//!
//! Each is a burn module implementing [`Field`](fieldprobe_core::field::Field) plus a typetag
//! config; nothing outside this crate names them, so a representation written in another crate
//! (see `examples/custom-model`) is a peer of these.

pub mod blocks;
pub mod per_object;
pub mod sdf;
pub mod single_view;

pub use blocks::{Decoder, DecoderConfig, Encoder, EncoderConfig, Stem};
pub use per_object::{PerObject, PerObjectConfig};
pub use sdf::{Sdf, SdfConfig};
pub use single_view::{SingleView, SingleViewConfig};
