//! Data: meshes, images, voxels and the published dataset layouts.

pub mod category;
pub mod dataset;
pub mod grid;
pub mod hull;
pub mod image;
pub mod inside;
pub mod mesh;
pub mod procedural;
pub mod render;
pub mod voxelize;

pub use category::Category;
pub use grid::{GridFrame, VoxelGrid};
pub use image::Silhouette;
pub use mesh::TriMesh;
