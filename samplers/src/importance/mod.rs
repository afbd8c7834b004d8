//! Importance samplers (paper §3.1, "Importance Sampling"): rays and anchors are drawn from
//! Gaussian mixtures placed on the object's contours, so that probing concentrates where the
//! occupancy changes.
//!
//! Both samplers read the paper's density `P(x) = ∫ κ(x', x; σ) W(x') dx'` literally, with the
//! contour map `W` a piecewise-constant function over pixels (2D) or voxels (3D): a sample picks a
//! cell with probability proportional to its weight, is placed uniformly inside that cell, then
//! gets an isotropic Gaussian offset of standard deviation `σ`. The uniform jitter matters because
//! the paper's `σ = 0.007` is far smaller than a cell (0.22 pixels at 64², 0.22 voxels at 32³):
//! without it the density would be a comb of spikes at the cell centres.
//!
//! * Rays (`type = "importance"`, [`ImportanceRays`]): `W_r = |∇²s|`, the absolute 5-point
//!   Laplacian of the silhouette `s` ([`contour_map`]); `σ` in normalized image units.
//! * Anchors (`type = "importance"`, [`ImportanceAnchors`]): the visual hull of all the views on
//!   a `resolution³` grid, mean-filtered with a 3×3×3 box, `W_p = 4m(1 − m)`
//!   ([`hull_contour_weights`]); `σ` in world units. The hull is cached per object.
//!
//! The module is split by what is sampled: [`rays`] (2D), [`anchors`] (3D, with the per-object
//! hull cache); what both share (bandwidth checks, the Gaussian pair, the discrete kernel
//! distribution) is here.

pub mod anchors;
pub mod rays;
#[cfg(test)]
mod tests;

pub use anchors::{HullContour, ImportanceAnchorSampler, ImportanceAnchors, hull_contour_weights};
pub use rays::{ImportanceRays, contour_map};

use rand::{Rng, RngCore};

/// The paper's kernel bandwidth `σ` (§3.1).
fn default_bandwidth() -> f32 {
    0.007
}

fn default_resolution() -> usize {
    32
}

fn default_cache_objects() -> usize {
    4096
}

fn check_bandwidth(sigma: f32, max: f32, what: &str) -> Result<(), String> {
    if sigma > 0.0 && sigma <= max {
        Ok(())
    } else {
        Err(format!(
            "{what}.bandwidth must be in (0, {max}], got {sigma}"
        ))
    }
}

fn check_fraction(f: f32, what: &str) -> Result<(), String> {
    if (0.0..=1.0).contains(&f) {
        Ok(())
    } else {
        Err(format!(
            "{what}.uniform_fraction must be in [0, 1], got {f}"
        ))
    }
}

/// Two independent standard normal samples (Box–Muller, both branches: half the `ln`/`sqrt` of
/// two calls to [`standard_normal`](fieldprobe_core::probe::sampler::standard_normal)).
fn normal_pair(rng: &mut dyn RngCore) -> (f32, f32) {
    let u1: f32 = rng.random_range(f32::EPSILON..1.0);
    let u2: f32 = rng.random();
    let r = (-2.0 * u1.ln()).sqrt();
    let (s, c) = (std::f32::consts::TAU * u2).sin_cos();
    (r * c, r * s)
}

/// Whether this sample is one of the `fraction` drawn uniformly (consumes no randomness at 0).
fn uniform_draw(fraction: f32, rng: &mut dyn RngCore) -> bool {
    fraction > 0.0 && rng.random::<f32>() < fraction
}

/// A discrete distribution over cells (flat indices) with positive weights, drawn by inverting
/// the cumulative sum.
#[derive(Clone, Debug, Default, PartialEq)]
struct Kernels {
    cells: Vec<u32>,
    /// Inclusive running sums of the weights of `cells`.
    cumulative: Vec<f64>,
}

impl Kernels {
    /// One kernel per cell with a positive weight.
    fn from_weights(weights: &[f32]) -> Self {
        let mut k = Self::default();
        let mut total = 0.0f64;
        for (i, &w) in weights.iter().enumerate() {
            if w > 0.0 {
                total += w as f64;
                k.cells.push(i as u32);
                k.cumulative.push(total);
            }
        }
        k
    }

    fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// A cell drawn with probability proportional to its weight. Must not be empty.
    fn draw(&self, rng: &mut dyn RngCore) -> usize {
        let total = *self.cumulative.last().expect("no kernels to draw from");
        let u = rng.random::<f64>() * total;
        // First running sum above `u`: cell `i` is hit with probability `w_i / total`.
        let i = self.cumulative.partition_point(|&c| c <= u);
        self.cells[i.min(self.cells.len() - 1)] as usize
    }

    /// Bytes held, for the cache's accounting in docs and tests.
    fn bytes(&self) -> usize {
        self.cells.len() * (size_of::<u32>() + size_of::<f64>())
    }
}
