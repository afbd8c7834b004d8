//! Normal samplers: the paper's "normal sampling" ablation (Table 4), anchors and rays from
//! `N(0, 0.4)`.

use fieldprobe_core::geometry::PixelPos;
use fieldprobe_core::probe::sampler::{on_image, standard_normal};
use fieldprobe_core::probe::{
    AnchorSampler, AnchorSamplerConfig, RaySampler, RaySamplerConfig, Supervision,
};
use fieldprobe_core::register_component;
use glam::{Vec2, Vec3};
use rand::RngCore;
use serde::{Deserialize, Serialize};

fn default_sigma() -> f32 {
    0.4
}

fn check_sigma(sigma: f32, what: &str) -> Result<(), String> {
    if sigma > 0.0 && sigma.is_finite() {
        Ok(())
    } else {
        Err(format!("{what}.sigma must be positive, got {sigma}"))
    }
}

/// Rays whose NDC coordinates are `~ N(0, σ)` (image centre at 0, edges at ±1); draws that fall
/// off the image are redrawn, since an off-image ray has no label.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormalRays {
    #[serde(default = "default_sigma")]
    pub sigma: f32,
}

impl Default for NormalRays {
    fn default() -> Self {
        Self {
            sigma: default_sigma(),
        }
    }
}

impl RaySampler for NormalRays {
    fn sample_pixels(
        &self,
        object: &Supervision,
        view: usize,
        n: usize,
        rng: &mut dyn RngCore,
    ) -> Vec<PixelPos> {
        let cam = &object.cameras[view];
        let size = object.image_size();
        let mut out = Vec::with_capacity(n);
        while out.len() < n {
            let ndc = Vec2::new(standard_normal(rng), standard_normal(rng)) * self.sigma;
            let px = cam.ndc_to_pixel(ndc);
            if on_image(px, size) {
                out.push(px);
            }
        }
        out
    }
}

#[typetag::serde(name = "normal")]
impl RaySamplerConfig for NormalRays {
    fn build(&self) -> Result<Box<dyn RaySampler>, String> {
        check_sigma(self.sigma, "ray_sampler")?;
        Ok(Box::new(*self))
    }
}

register_component!(
    RaySampler,
    "normal",
    "NDC coordinates ~ N(0, sigma), redrawn when off the image (paper's normal-sampling ablation)",
    "type = \"normal\"\nsigma = 0.4"
);

/// Anchors `~ N(0, σ·I)` around the origin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormalAnchors {
    #[serde(default = "default_sigma")]
    pub sigma: f32,
}

impl Default for NormalAnchors {
    fn default() -> Self {
        Self {
            sigma: default_sigma(),
        }
    }
}

impl AnchorSampler for NormalAnchors {
    fn sample_anchors(&self, _object: &Supervision, n: usize, rng: &mut dyn RngCore) -> Vec<Vec3> {
        (0..n)
            .map(|_| {
                Vec3::new(
                    standard_normal(rng),
                    standard_normal(rng),
                    standard_normal(rng),
                ) * self.sigma
            })
            .collect()
    }
}

#[typetag::serde(name = "normal")]
impl AnchorSamplerConfig for NormalAnchors {
    fn build(&self) -> Result<Box<dyn AnchorSampler>, String> {
        check_sigma(self.sigma, "anchor_sampler")?;
        Ok(Box::new(*self))
    }
}

register_component!(
    AnchorSampler,
    "normal",
    "anchors ~ N(0, sigma·I) (paper's normal-sampling ablation)",
    "type = \"normal\"\nsigma = 0.4"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::blank;
    use rand::SeedableRng;

    #[test]
    fn normal_anchors_have_the_configured_spread() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let a = NormalAnchors { sigma: 0.4 }.sample_anchors(&blank(), 60_000, &mut rng);
        let n = a.len() as f32;
        let var = a.iter().map(|p| *p * *p).sum::<Vec3>() / n;
        assert!(
            (var - Vec3::splat(0.16)).abs().max_element() < 0.005,
            "{var:?}"
        );
        // Radius distribution: P(|p| < σ) for a 3D standard normal is 0.1987.
        let inside = a.iter().filter(|p| p.length() < 0.4).count() as f32 / n;
        assert!((inside - 0.1987).abs() < 0.01, "{inside}");
    }

    #[test]
    fn normal_rays_concentrate_at_the_image_centre() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let sup = blank();
        let px = NormalRays { sigma: 0.4 }.sample_pixels(&sup, 0, 40_000, &mut rng);
        assert!(px.iter().all(|p| on_image(*p, 64)));
        let cam = &sup.cameras[0];
        let ndc: Vec<Vec2> = px.iter().map(|p| cam.pixel_to_ndc(*p)).collect();
        // Within one σ on both axes: (2Φ(1) − 1)² / P(on image)² ≈ 0.4661 / 0.9755.
        let both = ndc
            .iter()
            .filter(|v| v.x.abs() < 0.4 && v.y.abs() < 0.4)
            .count() as f32
            / ndc.len() as f32;
        assert!((both - 0.4778).abs() < 0.01, "{both}");
        assert!(NormalRays { sigma: 0.0 }.build().is_err());
    }
}
