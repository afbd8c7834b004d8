//! FieldProbe data: the world of the NMR protocol, without burn.
//!
//! Everything here is plain CPU code that the method reads but that knows nothing of the method:
//!
//! * [`geometry`] — the NMR/SoftRas camera (24 views, NDC, rays) and ray intervals.
//! * [`mesh`], [`mesh_files`], [`image`], [`render`] — triangle meshes (`.obj`, `.off`, `.ply`,
//!   `.stl` in; `.obj`, `.ply` out), silhouettes, the CPU rasterizer that makes Kato-style views.
//! * [`grid`], [`voxelize`], [`inside`], [`hull`] — NMR's voxel placement and voxelization, exact
//!   inside tests, the visual hull; [`winding`] — winding numbers at many points (a tree of
//!   dipoles) for meshes that are not closed.
//! * [`procedural`], [`category`], [`dataset`] — seeded shapes in the paper's six categories and
//!   the published dataset layouts (Kato's npz, DVR's folders).
//! * [`extract`] — meshes from any scalar field (MISE + marching cubes).
//! * [`io`] — atomic writes, used by every writer; [`error`] — the error type naming file and field.
//!
//! Its tests build and run without compiling burn: `cargo tree -p fieldprobe-data` shows none.

pub mod category;
pub mod dataset;
pub mod error;
pub mod extract;
pub mod geometry;
pub mod grid;
pub mod hull;
pub mod image;
pub mod inside;
pub mod io;
pub mod mesh;
pub mod mesh_files;
pub mod procedural;
pub mod render;
pub mod voxelize;
pub mod winding;

pub use category::Category;
pub use error::{Error, Result};
pub use grid::{GridFrame, VoxelGrid};
pub use image::Silhouette;
pub use mesh::TriMesh;
