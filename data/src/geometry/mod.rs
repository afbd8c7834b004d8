//! Cameras and rays in the conventions of the published NMR/SoftRas data (`DESIGN.md` §4).

pub mod camera;
pub mod ray;

pub use camera::{
    Camera, NMR_DISTANCE, NMR_ELEVATION_DEG, NMR_HALF_ANGLE_DEG, NUM_VIEWS, PixelPos,
};
pub use ray::Ray;
