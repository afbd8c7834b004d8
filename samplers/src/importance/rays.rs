//! Importance rays: pixels from a Gaussian mixture on the silhouette's contour map.

use fieldprobe_core::data::Silhouette;
use fieldprobe_core::geometry::PixelPos;
use fieldprobe_core::probe::sampler::on_image;
use fieldprobe_core::probe::{RaySampler, RaySamplerConfig, Supervision};
use fieldprobe_core::register_component;
use rand::{Rng, RngCore};
use serde::{Deserialize, Serialize};

use super::{
    Kernels, check_bandwidth, check_fraction, default_bandwidth, normal_pair, uniform_draw,
};
use crate::uniform::uniform_pixel;

/// The 2D contour map `W_r` of a silhouette: the absolute value of the 5-point Laplacian
/// `|s(r−1,c) + s(r+1,c) + s(r,c−1) + s(r,c+1) − 4·s(r,c)|`, row-major like the silhouette.
///
/// Off-image values replicate the nearest edge pixel (not zero padding): the image frame is not a
/// boundary of the object, so a shape cut by the frame gets no contour along it, and an
/// all-background or all-foreground image has no contour at all. Non-zero entries form a band
/// about two pixels wide straddling the contour (one pixel on each side of a sharp edge).
pub fn contour_map(s: &Silhouette) -> Vec<f32> {
    let n = s.size as isize;
    let at = |r: isize, c: isize| s.get((r.clamp(0, n - 1) * n + c.clamp(0, n - 1)) as usize);
    let mut w = Vec::with_capacity(s.len());
    for r in 0..n {
        for c in 0..n {
            let lap = at(r - 1, c) + at(r + 1, c) + at(r, c - 1) + at(r, c + 1) - 4.0 * at(r, c);
            w.push(lap.abs());
        }
    }
    w
}

/// Rays from the paper's 2D importance distribution: a pixel is drawn with probability
/// proportional to its contour weight `|∇²s|` ([`contour_map`]), the position is jittered
/// uniformly inside that pixel and offset by `N(0, σ²·I)`. Positions that land off the image are
/// redrawn from scratch (pixel and offsets), so the density is the mixture truncated to the image.
///
/// **Units of `σ` (`bandwidth`)**: normalized image coordinates, the NDC of the camera where the
/// image spans `[-1, 1]` (as in the `normal` sampler), so `σ` in pixels is `σ·S/2`: the default
/// 0.007 is 0.224 pixels at 64². At the NMR camera a world length `l` at the object's depth spans
/// `1.37·l` NDC units, so the same `σ` means about the same width in 2D and in 3D.
///
/// **Fallback**: a silhouette without contour (all background, or all foreground) gives pixels
/// uniform over the image, like `uniform`.
///
/// **`uniform_fraction`** (default 0, the paper's pure importance sampling): each ray is drawn
/// uniformly over the image with this probability instead. Pure contour sampling never
/// supervises the far background or the deep interior of a silhouette; a small fraction keeps
/// some labels there (e.g. against floaters in space no contour ray passes through).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportanceRays {
    /// Kernel standard deviation `σ` in NDC units (image = `[-1, 1]`); default 0.007.
    #[serde(default = "default_bandwidth")]
    pub bandwidth: f32,
    /// Probability that a ray is drawn uniformly over the image instead; default 0.
    #[serde(default)]
    pub uniform_fraction: f32,
}

impl Default for ImportanceRays {
    fn default() -> Self {
        Self {
            bandwidth: default_bandwidth(),
            uniform_fraction: 0.0,
        }
    }
}

impl RaySampler for ImportanceRays {
    fn sample_pixels(
        &self,
        object: &Supervision,
        view: usize,
        n: usize,
        rng: &mut dyn RngCore,
    ) -> Vec<PixelPos> {
        let sil = &object.silhouettes[view];
        let size = sil.size;
        // A 64² map and its running sums cost microseconds: recomputed per call, no cache.
        let kernels = Kernels::from_weights(&contour_map(sil));
        let sigma_px = self.bandwidth * size as f32 * 0.5;
        (0..n)
            .map(|_| {
                if kernels.is_empty() || uniform_draw(self.uniform_fraction, rng) {
                    return uniform_pixel(size, rng);
                }
                loop {
                    let cell = kernels.draw(rng);
                    let (row, col) = ((cell / size) as f32, (cell % size) as f32);
                    let (gc, gr) = normal_pair(rng);
                    let px = PixelPos {
                        col: col + rng.random::<f32>() - 0.5 + sigma_px * gc,
                        row: row + rng.random::<f32>() - 0.5 + sigma_px * gr,
                    };
                    if on_image(px, size) {
                        return px;
                    }
                }
            })
            .collect()
    }
}

#[typetag::serde(name = "importance")]
impl RaySamplerConfig for ImportanceRays {
    fn build(&self) -> Result<Box<dyn RaySampler>, String> {
        check_bandwidth(self.bandwidth, 1.0, "ray_sampler")?;
        check_fraction(self.uniform_fraction, "ray_sampler")?;
        Ok(Box::new(*self))
    }
}

register_component!(
    RaySampler,
    "importance",
    "pixels from a Gaussian mixture on the silhouette contour |Laplacian| (paper §3.1); bandwidth in NDC units",
    "type = \"importance\"\nbandwidth = 0.007\nuniform_fraction = 0.0"
);
