//! FieldProbe core: everything the method needs that is not a plugin.
//!
//! * [`data`] (the `fieldprobe-data` crate, no burn) — meshes, silhouettes, the CPU rasterizer,
//!   voxelizations, the visual hull, procedural shapes and the published dataset layouts (Kato's
//!   npz, DVR's folders); re-exported with its [`geometry`] (the NMR camera) and [`extract`]
//!   (meshes from a field) at this crate's root.
//! * [`field`] — the representation traits: [`field::Field`] (φ(z, p)), [`field::FieldModel`]
//!   (trainable, checkpointable) and their TOML side; implementations live in `fieldprobe-models`.
//! * [`object`] — an object's input images and supervision, read by training and evaluation.
//! * [`probe`] — samplers, ray–anchor assignment, aggregation, training batches.
//! * [`regularize`] — the regularizer trait; [`registry`] — pluggable components.
//! * [`train`] — the training loop and checkpoints; [`eval`] — 3D IoU in the NMR protocol;
//!   [`weights`] — safetensors export and import by tensor name.
//!
//! Conventions are fixed by `DESIGN.md` §4 and pinned by tests against hand-worked numbers and an
//! independently computed golden file.

pub mod eval;
pub mod field;
pub mod object;
pub mod probe;
pub mod registry;
pub mod regularize;
pub mod train;
pub mod weights;

// Re-exported for `register_component!` in plugin crates.
#[doc(hidden)]
pub use inventory;

pub use fieldprobe_data as data;
pub use fieldprobe_data::{Error, Result, error, extract, geometry};
