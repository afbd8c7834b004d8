//! The eikonal term of signed-distance fields (Gropp et al. 2020, IGR; used by VolSDF and NeuS):
//! `λ · mean (|∇s(p)| − 1)²` over points `p`, which makes the network's output a distance rather
//! than any function with the right zero set. Silhouettes constrain only where `s` changes sign
//! (through `φ = sigmoid(−s/β)`), so without it `s` is free everywhere else.
//!
//! `∇s` is taken by central differences at step `delta` along the three axes (6 evaluations per
//! point; the same finite-difference machinery as the paper's normal consistency, and no
//! second-order autodiff). The points are the step's sampled anchors (a strided subset of at most
//! `max_points`, split evenly over the batch's objects): they cover the probed region, the visual
//! hull and its surroundings, which is where silhouettes leave `s` unconstrained.
//!
//! It needs a representation with a signed distance (`[model] type = "sdf"`); an experiment that
//! pairs it with an occupancy network is rejected when it is loaded.

use burn::prelude::*;
use fieldprobe_core::field::FieldModelConfig;
use fieldprobe_core::register_component;
use fieldprobe_core::regularize::{FieldQuery, Regularizer, RegularizerConfig};
use serde::{Deserialize, Serialize};

/// `[regularizers.eikonal] type = "eikonal"`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Eikonal {
    /// λ, the factor of the term in the total loss (IGR and VolSDF: 0.1).
    #[serde(default = "Eikonal::default_weight")]
    pub weight: f32,
    /// The finite-difference step (default 0.005, a sixth of a 32³ voxel).
    #[serde(default = "Eikonal::default_delta")]
    pub delta: f32,
    /// At most this many anchors per step have their gradient evaluated; 0 = all.
    #[serde(default = "Eikonal::default_max_points")]
    pub max_points: usize,
}

impl Eikonal {
    fn default_weight() -> f32 {
        0.1
    }
    fn default_delta() -> f32 {
        0.005
    }
    fn default_max_points() -> usize {
        2048
    }

    /// Checks the ranges; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        crate::common::check_weight(self.weight)?;
        if !(self.delta > 0.0 && self.delta < 0.1) {
            return Err(format!("delta must be in (0, 0.1), got {}", self.delta));
        }
        Ok(())
    }

    /// The term for anchors `[B, N, 3]` under any signed distance (`[B, M, 3]` → `[B, M]`,
    /// object `b`'s points through object `b`'s field); analytic fields can be passed directly.
    pub fn loss_with<F>(&self, distance: F, anchors: &Tensor<3>) -> Option<Tensor<1>>
    where
        F: Fn(Tensor<3>) -> Tensor<2>,
    {
        if self.weight == 0.0 {
            return None;
        }
        let [b, all, _] = anchors.dims();
        let n = if self.max_points == 0 {
            all
        } else {
            all.min((self.max_points / b.max(1)).max(1))
        };
        if n == 0 {
            return None;
        }
        let device = anchors.device();
        let centres = crate::common::strided_subset(anchors, n);
        // [B, 6n, 3]: +x, −x, +y, −y, +z, −z offsets of every centre, one block per offset.
        let mut shifted = Vec::with_capacity(6);
        for axis in 0..3 {
            for sign in [1.0f32, -1.0] {
                let mut o = [0.0f32; 3];
                o[axis] = sign * self.delta;
                let offset = Tensor::<1>::from_floats(o, &device).reshape([1, 1, 3]);
                shifted.push(centres.clone() + offset);
            }
        }
        let s = distance(Tensor::cat(shifted, 1)); // [B, 6n]
        let part = |k: usize| s.clone().narrow(1, k * n, n);
        let inv = 1.0 / (2.0 * self.delta);
        let grad_sq = (0..3)
            .map(|a| {
                (part(2 * a) - part(2 * a + 1))
                    .mul_scalar(inv)
                    .powi_scalar(2)
            })
            .reduce(|x, y| x + y)
            .expect("three axes");
        let norm = grad_sq.add_scalar(1e-12).sqrt();
        Some(
            norm.sub_scalar(1.0)
                .powi_scalar(2)
                .mean()
                .mul_scalar(self.weight),
        )
    }
}

impl Default for Eikonal {
    fn default() -> Self {
        Self {
            weight: Self::default_weight(),
            delta: Self::default_delta(),
            max_points: Self::default_max_points(),
        }
    }
}

impl Regularizer for Eikonal {
    fn loss(&self, field: &FieldQuery<'_>, anchors: &Tensor<3>) -> Option<Tensor<1>> {
        self.loss_with(
            |p| {
                field.signed_distance(p).expect(
                    "eikonal: the representation has no signed distance \
                     (an experiment checks this when it is loaded)",
                )
            },
            anchors,
        )
    }
}

#[typetag::serde(name = "eikonal")]
impl RegularizerConfig for Eikonal {
    fn build(&self) -> Result<Box<dyn Regularizer>, String> {
        self.validate()?;
        Ok(Box::new(*self))
    }

    fn check_model(&self, model: &dyn FieldModelConfig) -> Result<(), String> {
        if model.has_signed_distance() {
            Ok(())
        } else {
            Err(format!(
                "the eikonal term needs a representation with a signed distance (for example \
                 [model] type = \"sdf\"); {} has none",
                serde_json::to_value(model)
                    .ok()
                    .and_then(|v| v.get("type").and_then(|t| t.as_str().map(String::from)))
                    .map_or("this model".to_string(), |t| format!("type = \"{t}\""))
            ))
        }
    }
}

register_component!(
    Regularizer,
    "eikonal",
    "IGR's eikonal term λ·mean(|∇s| − 1)² by central differences at the sampled anchors (needs an SDF representation)",
    r#"type = "eikonal"
weight = 0.1
delta = 0.005
max_points = 2048"#
);

#[cfg(test)]
mod tests {
    use super::*;

    fn anchors(b: usize, n: usize, dev: &Device) -> (Tensor<3>, Vec<[f64; 3]>) {
        let mut x = 0x2545_f491_u64;
        let mut pts = Vec::new();
        for _ in 0..b * n {
            let p: [f64; 3] = std::array::from_fn(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((x >> 33) as f64 / (1u64 << 31) as f64) * 0.8 - 0.4
            });
            pts.push(p);
        }
        let flat: Vec<f32> = pts.iter().flatten().map(|&c| c as f32).collect();
        (
            Tensor::from_data(TensorData::new(flat, [b, n, 3]), dev),
            pts,
        )
    }

    /// `s(p) = a·(|p − c|² + x·y) − r`: gradient norm varies over space.
    fn analytic(p: [f64; 3]) -> f64 {
        let c = [0.05, -0.1, 0.02];
        let d2: f64 = (0..3).map(|i| (p[i] - c[i]).powi(2)).sum();
        1.7 * (d2 + p[0] * p[1]) - 0.2
    }

    fn analytic_tensor(p: Tensor<3>) -> Tensor<2> {
        let dev = p.device();
        let c = Tensor::<1>::from_floats([0.05, -0.1, 0.02], &dev).reshape([1, 1, 3]);
        let d2: Tensor<2> = (p.clone() - c).powi_scalar(2).sum_dim(2).squeeze_dim(2);
        let x: Tensor<2> = p.clone().narrow(2, 0, 1).squeeze_dim(2);
        let y: Tensor<2> = p.narrow(2, 1, 1).squeeze_dim(2);
        (d2 + x * y).mul_scalar(1.7).sub_scalar(0.2)
    }

    /// The plain formulation: every point, exact gradient of the analytic function.
    fn reference(points: &[[f64; 3]], weight: f64) -> f64 {
        let c = [0.05, -0.1, 0.02];
        let sum: f64 = points
            .iter()
            .map(|p| {
                let g = [
                    1.7 * (2.0 * (p[0] - c[0]) + p[1]),
                    1.7 * (2.0 * (p[1] - c[1]) + p[0]),
                    1.7 * 2.0 * (p[2] - c[2]),
                ];
                let n = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                (n - 1.0).powi(2)
            })
            .sum();
        weight * sum / points.len() as f64
    }

    #[test]
    fn matches_the_exact_gradient_reference() {
        let dev = Device::flex();
        let (a, pts) = anchors(2, 100, &dev);
        let cfg = Eikonal {
            max_points: 0,
            ..Eikonal::default()
        };
        let got: f32 = cfg.loss_with(analytic_tensor, &a).unwrap().into_scalar();
        let want = reference(&pts, 0.1);
        // Central differences are exact for a quadratic up to float rounding.
        assert!(
            (got as f64 - want).abs() < 1e-3 * want.max(1e-3),
            "tensor {got} vs reference {want}"
        );
        // And the reference agrees with the analytic function itself (a check of the check).
        let h = 1e-5;
        let p = pts[7];
        let fd = (analytic([p[0] + h, p[1], p[2]]) - analytic([p[0] - h, p[1], p[2]])) / (2.0 * h);
        assert!((fd - 1.7 * (2.0 * (p[0] - 0.05) + p[1])).abs() < 1e-6);
    }

    #[test]
    fn a_true_distance_costs_nothing_and_a_scaled_one_costs_its_excess() {
        let dev = Device::flex();
        let (a, _) = anchors(2, 64, &dev);
        let sphere = |k: f32| {
            move |p: Tensor<3>| -> Tensor<2> {
                p.powi_scalar(2)
                    .sum_dim(2)
                    .sqrt()
                    .squeeze_dim(2)
                    .sub_scalar(0.3)
                    .mul_scalar(k)
            }
        };
        let cfg = Eikonal::default();
        let exact: f32 = cfg.loss_with(sphere(1.0), &a).unwrap().into_scalar();
        assert!(exact < 1e-5, "{exact}");
        let doubled: f32 = cfg.loss_with(sphere(2.0), &a).unwrap().into_scalar();
        assert!((doubled - 0.1).abs() < 1e-3, "{doubled}");
    }

    #[test]
    fn the_cap_takes_a_strided_subset_split_over_objects() {
        let dev = Device::flex();
        let (a, pts) = anchors(2, 100, &dev);
        let cfg = Eikonal {
            max_points: 40,
            ..Eikonal::default()
        };
        let got: f32 = cfg.loss_with(analytic_tensor, &a).unwrap().into_scalar();
        // 20 per object: indices 0, 5, 10, … of each.
        let subset: Vec<[f64; 3]> = (0..2)
            .flat_map(|o| (0..20).map(move |i| o * 100 + i * 5))
            .map(|k| pts[k])
            .collect();
        let want = reference(&subset, 0.1);
        assert!((got as f64 - want).abs() < 1e-3 * want.max(1e-3));
    }

    #[test]
    fn needs_a_signed_distance_and_says_so() {
        let occupancy: Box<dyn FieldModelConfig> = toml::from_str("type = \"per_object\"").unwrap();
        let e = Eikonal::default()
            .check_model(occupancy.as_ref())
            .unwrap_err();
        assert!(
            e.contains("signed distance") && e.contains("per_object"),
            "{e}"
        );
        let sdf: Box<dyn FieldModelConfig> = toml::from_str("type = \"sdf\"\nlatent = 0").unwrap();
        assert!(Eikonal::default().check_model(sdf.as_ref()).is_ok());
        let bad: Result<Box<dyn RegularizerConfig>, _> =
            toml::from_str("type = \"eikonal\"\ndelat = 0.01");
        assert!(bad.unwrap_err().to_string().contains("delat"));
    }

    #[test]
    fn training_on_it_alone_makes_a_field_a_distance() {
        use fieldprobe_core::field::FieldModel;
        use fieldprobe_models::{DecoderConfig, SdfConfig};
        let dev = Device::flex().autodiff();
        dev.seed(4);
        let mut model: Box<dyn FieldModel> = SdfConfig {
            latent: 0,
            decoder: Some(DecoderConfig {
                hidden: vec![32, 32],
                frequencies: 0,
            }),
            sphere: 0.0,
            ..SdfConfig::default()
        }
        .init(&dev);
        let mut optim = burn::optim::AdamConfig::new().init();
        let (a, _) = anchors(1, 256, &dev);
        let cfg = Eikonal {
            weight: 1.0,
            ..Eikonal::default()
        };
        let mut losses = Vec::new();
        for _ in 0..60 {
            let q = FieldQuery {
                model: model.as_ref(),
                latent: None,
                step: 0,
            };
            let loss = cfg.loss(&q, &a).unwrap();
            losses.push(loss.clone().into_scalar::<f32>());
            let grads = loss.backward();
            model.optimize(&mut optim, 1e-2, grads);
        }
        let (first, last) = (losses[0], *losses.last().unwrap());
        assert!(last < 0.2 * first, "{first} → {last}");
    }
}
