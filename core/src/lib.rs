//! FieldProbe core: everything the method needs that is not a plugin.
//!
//! * [`geometry`] — the NMR/SoftRas camera of the published data, pixels ↔ rays, projection.
//! * [`data`] — meshes, silhouettes, the CPU rasterizer, voxelizations, the visual hull,
//!   procedural shapes and the published dataset layouts (Kato's npz, DVR's folders).
//!
//! Conventions are fixed by `DESIGN.md` §4 and pinned by tests against hand-worked numbers and an
//! independently computed golden file.

pub mod data;
pub mod error;
pub mod geometry;

pub use error::{Error, Result};
