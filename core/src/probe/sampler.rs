//! Samplers: where to probe. A [`RaySampler`] picks pixel positions in a supervision view (each
//! becomes a probing ray); an [`AnchorSampler`] picks 3D anchor points. Both see only what
//! silhouettes give ([`Supervision`]), never 3D ground truth.
//!
//! Samplers are chosen in TOML by `type = "…"`: each is a serde config registered with typetag
//! (`#[typetag::serde(name = "…")] impl RaySamplerConfig for …`) whose [`build`] validates it and
//! returns the runtime sampler. A new sampler is a new crate that does exactly this and submits a
//! [`crate::registry::Component`] with an example TOML block (see `examples/custom-sampler`).
//!
//! [`build`]: RaySamplerConfig::build

use std::fmt::Debug;

use glam::Vec3;
use rand::{Rng, RngCore};

use crate::data::Silhouette;
use crate::geometry::{Camera, PixelPos};

/// What the samplers (and the assignment) know about one object: its silhouettes and cameras.
#[derive(Clone, Debug, PartialEq)]
pub struct Supervision {
    pub silhouettes: Vec<Silhouette>,
    pub cameras: Vec<Camera>,
}

impl Supervision {
    /// The 24 NMR views of an object.
    pub fn nmr(silhouettes: Vec<Silhouette>) -> Self {
        let cameras = Camera::nmr_views();
        assert_eq!(
            silhouettes.len(),
            cameras.len(),
            "one silhouette per NMR view"
        );
        Self {
            silhouettes,
            cameras,
        }
    }

    /// Image side in pixels.
    pub fn image_size(&self) -> usize {
        self.cameras[0].image_size
    }
}

/// Picks pixel positions (continuous, pixel centres at integers) in one view of an object.
pub trait RaySampler: Send + Sync + Debug {
    fn sample_pixels(
        &self,
        object: &Supervision,
        view: usize,
        n: usize,
        rng: &mut dyn RngCore,
    ) -> Vec<PixelPos>;
}

/// Picks 3D anchor points for one object.
pub trait AnchorSampler: Send + Sync + Debug {
    fn sample_anchors(&self, object: &Supervision, n: usize, rng: &mut dyn RngCore) -> Vec<Vec3>;
}

/// The TOML/serde side of a ray sampler.
#[typetag::serde(tag = "type")]
pub trait RaySamplerConfig: Send + Sync + Debug {
    /// Validates the configuration and builds the sampler; the error says which field is wrong.
    fn build(&self) -> Result<Box<dyn RaySampler>, String>;
}

/// The TOML/serde side of an anchor sampler.
#[typetag::serde(tag = "type")]
pub trait AnchorSamplerConfig: Send + Sync + Debug {
    /// Validates the configuration and builds the sampler; the error says which field is wrong.
    fn build(&self) -> Result<Box<dyn AnchorSampler>, String>;
}

/// A standard normal sample (Box–Muller), so that samplers need no extra distribution crate.
pub fn standard_normal(rng: &mut dyn RngCore) -> f32 {
    let u1: f32 = rng.random_range(f32::EPSILON..1.0);
    let u2: f32 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}

/// Whether a continuous pixel position lies on the image (`[-½, S − ½]²`).
pub fn on_image(px: PixelPos, size: usize) -> bool {
    let hi = size as f32 - 0.5;
    (-0.5..=hi).contains(&px.col) && (-0.5..=hi).contains(&px.row)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn standard_normal_has_unit_moments() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let n = 200_000;
        let xs: Vec<f32> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let mean = xs.iter().sum::<f32>() / n as f32;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / n as f32;
        assert!(
            mean.abs() < 0.01 && (var - 1.0).abs() < 0.02,
            "{mean} {var}"
        );
        let within1 = xs.iter().filter(|x| x.abs() < 1.0).count() as f32 / n as f32;
        assert!((within1 - 0.6827).abs() < 0.005, "{within1}");
    }
}
