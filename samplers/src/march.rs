//! Depths along a ray for dense ray marching (`[probe] march = { … }`), the baseline that field
//! probing is measured against (`fieldprobe_core::probe::march`).
//!
//! Both split the ray's interval inside the cube into `samples` equal bins:
//!
//! * `fixed`: the bin centres, the same depths every step (a deterministic quadrature; thin
//!   parts between two sample planes are never seen);
//! * `stratified`: one uniform draw per bin, NeRF's coarse sampler: every depth gets probed over
//!   the steps, and each step's estimate stays spread along the ray.

use fieldprobe_core::probe::{RayMarcher, RayMarcherConfig};
use fieldprobe_core::register_component;
use rand::{Rng, RngCore};
use serde::{Deserialize, Serialize};

/// Bin centres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixedDepths {
    pub samples: usize,
}

/// One uniform depth per bin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StratifiedDepths {
    pub samples: usize,
}

/// Bin `i` of `n` equal bins of `[near, far]`: its start and width.
fn bin(near: f32, far: f32, n: usize, i: usize) -> (f32, f32) {
    let width = (far - near) / n as f32;
    (near + i as f32 * width, width)
}

fn check_samples(samples: usize) -> Result<(), String> {
    if !(1..=1024).contains(&samples) {
        return Err(format!("samples must be in 1..=1024, got {samples}"));
    }
    Ok(())
}

impl RayMarcher for FixedDepths {
    fn samples(&self) -> usize {
        self.samples
    }

    fn depths(&self, near: f32, far: f32, _rng: &mut dyn RngCore) -> Vec<f32> {
        (0..self.samples)
            .map(|i| {
                let (start, width) = bin(near, far, self.samples, i);
                start + 0.5 * width
            })
            .collect()
    }
}

impl RayMarcher for StratifiedDepths {
    fn samples(&self) -> usize {
        self.samples
    }

    fn depths(&self, near: f32, far: f32, rng: &mut dyn RngCore) -> Vec<f32> {
        (0..self.samples)
            .map(|i| {
                let (start, width) = bin(near, far, self.samples, i);
                start + rng.random::<f32>() * width
            })
            .collect()
    }
}

#[typetag::serde(name = "fixed")]
impl RayMarcherConfig for FixedDepths {
    fn build(&self) -> Result<Box<dyn RayMarcher>, String> {
        check_samples(self.samples)?;
        Ok(Box::new(*self))
    }
}

#[typetag::serde(name = "stratified")]
impl RayMarcherConfig for StratifiedDepths {
    fn build(&self) -> Result<Box<dyn RayMarcher>, String> {
        check_samples(self.samples)?;
        Ok(Box::new(*self))
    }
}

register_component!(
    RayMarcher,
    "fixed",
    "dense ray marching: φ read at the centres of `samples` equal bins of each ray inside the unit cube",
    "type = \"fixed\"\nsamples = 32"
);

register_component!(
    RayMarcher,
    "stratified",
    "dense ray marching: one uniform depth in each of `samples` equal bins of each ray inside the unit cube (NeRF's coarse sampler)",
    "type = \"stratified\"\nsamples = 32"
);

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn fixed_depths_are_the_bin_centres() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let d = FixedDepths { samples: 4 }.depths(2.0, 3.0, &mut rng);
        assert_eq!(d, vec![2.125, 2.375, 2.625, 2.875]);
        assert!(FixedDepths { samples: 0 }.build().is_err());
    }

    /// Each bin's draws are uniform in the bin: per bin, the mean is the centre and the variance
    /// `w²/12` within 5 standard errors, no draw leaves its bin, and the depths increase.
    #[test]
    fn stratified_depths_are_uniform_within_each_bin() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (n, bins, near, far) = (20_000, 8, 2.2f32, 3.4f32);
        let marcher = StratifiedDepths { samples: bins };
        let mut sum = vec![0.0f64; bins];
        let mut sq = vec![0.0f64; bins];
        for _ in 0..n {
            let d = marcher.depths(near, far, &mut rng);
            assert!(d.windows(2).all(|w| w[0] <= w[1]));
            for (i, &t) in d.iter().enumerate() {
                let (start, width) = bin(near, far, bins, i);
                assert!(t >= start && t <= start + width, "{t} outside bin {i}");
                let u = ((t - start) / width) as f64;
                sum[i] += u;
                sq[i] += u * u;
            }
        }
        for i in 0..bins {
            let mean = sum[i] / n as f64;
            let var = sq[i] / n as f64 - mean * mean;
            // U(0, 1): mean ½ (sd of the mean √(1/12n)), variance 1/12 (sd ≈ √(1/180n)).
            let se_mean = (1.0 / (12.0 * n as f64)).sqrt();
            let se_var = (1.0 / (180.0 * n as f64)).sqrt();
            assert!((mean - 0.5).abs() < 5.0 * se_mean, "bin {i}: mean {mean}");
            assert!(
                (var - 1.0 / 12.0).abs() < 5.0 * se_var,
                "bin {i}: var {var}"
            );
        }
        assert!(StratifiedDepths { samples: 2000 }.build().is_err());
    }
}
