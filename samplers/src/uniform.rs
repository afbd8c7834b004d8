//! Uniform samplers: the naive baseline the paper's importance sampling improves on.

use fieldprobe_core::geometry::PixelPos;
use fieldprobe_core::probe::{
    AnchorSampler, AnchorSamplerConfig, RaySampler, RaySamplerConfig, Supervision,
};
use fieldprobe_core::register_component;
use glam::Vec3;
use rand::{Rng, RngCore};
use serde::{Deserialize, Serialize};

/// Pixel positions uniform over the image (continuous, sub-pixel).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UniformRays {}

impl RaySampler for UniformRays {
    fn sample_pixels(
        &self,
        object: &Supervision,
        _view: usize,
        n: usize,
        rng: &mut dyn RngCore,
    ) -> Vec<PixelPos> {
        let size = object.image_size();
        (0..n).map(|_| uniform_pixel(size, rng)).collect()
    }
}

/// One position uniform over a `size`² image (continuous, `[-½, size − ½]²`).
pub fn uniform_pixel(size: usize, rng: &mut dyn RngCore) -> PixelPos {
    let hi = size as f32 - 0.5;
    PixelPos {
        col: rng.random_range(-0.5..hi),
        row: rng.random_range(-0.5..hi),
    }
}

#[typetag::serde(name = "uniform")]
impl RaySamplerConfig for UniformRays {
    fn build(&self) -> Result<Box<dyn RaySampler>, String> {
        Ok(Box::new(*self))
    }
}

register_component!(
    RaySampler,
    "uniform",
    "pixels uniform over the image",
    r#"type = "uniform""#
);

/// Points uniform in the cube `[-extent, extent]³`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UniformAnchors {
    /// Half side of the cube (objects live in `[-0.5, 0.5]³`).
    #[serde(default = "UniformAnchors::default_extent")]
    pub extent: f32,
}

impl UniformAnchors {
    fn default_extent() -> f32 {
        0.5
    }
}

impl Default for UniformAnchors {
    fn default() -> Self {
        Self {
            extent: Self::default_extent(),
        }
    }
}

impl UniformAnchors {
    /// One point uniform in the cube.
    pub fn point(&self, rng: &mut dyn RngCore) -> Vec3 {
        let e = self.extent;
        Vec3::new(
            rng.random_range(-e..e),
            rng.random_range(-e..e),
            rng.random_range(-e..e),
        )
    }
}

impl AnchorSampler for UniformAnchors {
    fn sample_anchors(&self, _object: &Supervision, n: usize, rng: &mut dyn RngCore) -> Vec<Vec3> {
        (0..n).map(|_| self.point(rng)).collect()
    }
}

#[typetag::serde(name = "uniform")]
impl AnchorSamplerConfig for UniformAnchors {
    fn build(&self) -> Result<Box<dyn AnchorSampler>, String> {
        if !(self.extent > 0.0 && self.extent.is_finite()) {
            return Err(format!(
                "anchor_sampler.extent must be positive, got {}",
                self.extent
            ));
        }
        Ok(Box::new(*self))
    }
}

register_component!(
    AnchorSampler,
    "uniform",
    "anchors uniform in the cube [-extent, extent]³",
    "type = \"uniform\"\nextent = 0.5"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{assert_even_quadrants, blank};
    use rand::SeedableRng;

    #[test]
    fn uniform_rays_fill_the_image_evenly() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let px = UniformRays {}.sample_pixels(&blank(), 0, 64_000, &mut rng);
        assert!(
            px.iter()
                .all(|p| (-0.5..63.5).contains(&p.col) && (-0.5..63.5).contains(&p.row))
        );
        // Quadrant counts of a uniform sample: each ≈ n/4 within 4σ of a binomial.
        assert_even_quadrants(&px);
    }

    #[test]
    fn uniform_anchors_have_uniform_moments() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let a = UniformAnchors { extent: 0.5 }.sample_anchors(&blank(), 50_000, &mut rng);
        let n = a.len() as f32;
        let mean = a.iter().copied().sum::<Vec3>() / n;
        let var = a.iter().map(|p| (*p - mean) * (*p - mean)).sum::<Vec3>() / n;
        // U(-0.5, 0.5): mean 0, variance 1/12.
        assert!(mean.abs().max_element() < 0.01, "{mean:?}");
        assert!(
            (var - Vec3::splat(1.0 / 12.0)).abs().max_element() < 0.003,
            "{var:?}"
        );
        assert!(a.iter().all(|p| p.abs().max_element() <= 0.5));
        assert!(UniformAnchors { extent: -1.0 }.build().is_err());
    }
}
