//! FieldProbe core: everything the method needs that is not a plugin.
//!
//! * [`geometry`] — the NMR/SoftRas camera of the published data, pixels ↔ rays, projection.
//! * [`data`] — meshes, silhouettes, the CPU rasterizer, voxelizations, the visual hull,
//!   procedural shapes and the published dataset layouts (Kato's npz, DVR's folders).
//! * [`field`] — the representation traits: [`field::Field`] (φ(z, p)), [`field::FieldModel`]
//!   (trainable, checkpointable) and their TOML side; implementations live in `fieldprobe-models`.
//! * [`probe`] — samplers, ray–anchor assignment, aggregation, training batches.
//! * [`regularize`] — the regularizer trait; [`registry`] — pluggable components.
//! * [`train`] — the training loop and checkpoints; [`eval`] — 3D IoU in the NMR protocol.
//! * [`extract`] — meshes from a field: MISE refinement + crack-free marching cubes, `.obj`/`.ply`.
//!
//! Conventions are fixed by `DESIGN.md` §4 and pinned by tests against hand-worked numbers and an
//! independently computed golden file.

pub mod data;
pub mod error;
pub mod eval;
pub mod extract;
pub mod field;
pub mod geometry;
pub mod probe;
pub mod registry;
pub mod regularize;
pub mod train;

// Re-exported for `register_component!` in plugin crates.
#[doc(hidden)]
pub use inventory;

pub use error::{Error, Result};
