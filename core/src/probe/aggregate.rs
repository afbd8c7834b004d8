//! Aggregators: one prediction per ray from the field values at the anchors it meets.

use std::fmt::Debug;

use burn::prelude::*;
use serde::{Deserialize, Serialize};

/// What an aggregator sees of a batch of rays: per ray, the anchors it meets, padded to `K`.
#[derive(Debug)]
pub struct RayValues {
    /// `[R, K]` φ at the anchors of each ray; padded entries hold 0.
    pub values: Tensor<2>,
    /// `[R, K]` whether an entry is a real anchor.
    pub valid: Tensor<2, Bool>,
    /// `[R, K]` each anchor's depth along its ray (distance from the camera centre along the
    /// ray's unit direction, world units); present when the aggregator
    /// [uses geometry](Aggregator::uses_geometry). Padded entries hold 0.
    pub depth: Option<Tensor<2>>,
    /// `[R, K]` each anchor's distance from its ray's line (≤ the support radius τ for an
    /// assigned anchor); present when the aggregator uses geometry. Padded entries hold 0.
    pub distance: Option<Tensor<2>>,
}

impl RayValues {
    /// Values and mask only (for aggregators that do not use geometry).
    pub fn new(values: Tensor<2>, valid: Tensor<2, Bool>) -> Self {
        Self {
            values,
            valid,
            depth: None,
            distance: None,
        }
    }
}

/// Turns the field values at the anchors of each ray into the ray's prediction ψ.
pub trait Aggregator: Send + Sync + Debug {
    /// One prediction per ray. A ray with no anchor must predict 0 ("nothing probed, no
    /// occupancy seen"): such a ray then adds a constant `label²` to the loss and no gradient.
    fn aggregate(&self, rays: RayValues) -> Tensor<1>;

    /// Whether [`aggregate`](Self::aggregate) reads [`RayValues::depth`] and
    /// [`RayValues::distance`]: they cost two more `[R, K]` tensors per step, so training and
    /// evaluation build them only for aggregators that ask (order-aware compositing, support
    /// kernels). Default: no.
    fn uses_geometry(&self) -> bool {
        false
    }
}

/// The TOML/serde side of an aggregator.
#[typetag::serde(tag = "type")]
pub trait AggregatorConfig: Send + Sync + Debug {
    fn build(&self) -> Result<Box<dyn Aggregator>, String>;
}

/// Max pooling along the ray (paper eq. 1): the ray is inside iff some anchor on it is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaxPool {}

impl Aggregator for MaxPool {
    fn aggregate(&self, rays: RayValues) -> Tensor<1> {
        let RayValues { values, valid, .. } = rays;
        // φ ∈ (0, 1), so 0 is neutral for the max and is the empty ray's prediction.
        values
            .mask_fill(valid.bool_not(), 0.0)
            .max_dim(1)
            .squeeze_dim(1)
    }
}

#[typetag::serde(name = "max")]
impl AggregatorConfig for MaxPool {
    fn build(&self) -> Result<Box<dyn Aggregator>, String> {
        Ok(Box::new(*self))
    }
}

crate::register_component!(
    Aggregator,
    "max",
    "max-pool of φ over the anchors a ray meets (paper eq. 1); 0 for a ray that meets none",
    r#"type = "max""#
);

/// A temperature-controlled soft maximum (the Boltzmann operator): `ψ = Σ φᵢ·wᵢ` with
/// `w = softmax(φ/T)` over the anchors a ray meets. It lies between their mean (`T → ∞`) and their
/// max (`T → 0`, the paper's eq. 1), and unlike the max it passes a gradient to every anchor on
/// the ray, not only the largest: a smoother, less sparse training signal, at the price of a
/// prediction that no longer says "some anchor is inside". A ray with no anchor predicts 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftMax {
    /// T, in units of φ (default 0.05: anchors more than ~0.2 below the ray's max weigh < 2 %).
    #[serde(default = "SoftMax::default_temperature")]
    pub temperature: f32,
}

impl SoftMax {
    fn default_temperature() -> f32 {
        0.05
    }
}

impl Default for SoftMax {
    fn default() -> Self {
        Self {
            temperature: Self::default_temperature(),
        }
    }
}

impl Aggregator for SoftMax {
    fn aggregate(&self, rays: RayValues) -> Tensor<1> {
        let RayValues { values, valid, .. } = rays;
        // Shifted by each ray's max m (a constant for the softmax, so detached): exp((φ − m)/T)
        // ≤ 1 with the largest weight exactly 1, so neither overflow nor underflow of the whole
        // row at small T. Padded entries get weight 0; an empty ray has all weights 0, a
        // numerator of 0 and a guarded denominator of 1.
        let invalid = valid.bool_not();
        let m: Tensor<2> = values
            .clone()
            .mask_fill(invalid.clone(), 0.0)
            .max_dim(1)
            .detach();
        let w = (values.clone() - m)
            .div_scalar(self.temperature)
            .exp()
            .mask_fill(invalid, 0.0);
        let num: Tensor<1> = (values * w.clone()).sum_dim(1).squeeze_dim(1);
        let den: Tensor<1> = w.sum_dim(1).squeeze_dim(1);
        let empty = den.clone().lower_equal_elem(0.0);
        num / den.mask_fill(empty, 1.0)
    }
}

#[typetag::serde(name = "softmax")]
impl AggregatorConfig for SoftMax {
    fn build(&self) -> Result<Box<dyn Aggregator>, String> {
        if !(self.temperature > 0.0 && self.temperature.is_finite()) {
            return Err(format!(
                "temperature must be a positive number, got {}",
                self.temperature
            ));
        }
        Ok(Box::new(*self))
    }
}

crate::register_component!(
    Aggregator,
    "softmax",
    "soft maximum Σφ·softmax(φ/T) over the anchors a ray meets: between their mean and max, gradients to all",
    r#"type = "softmax"
temperature = 0.05"#
);

/// Alpha compositing of the samples as opacities: `ψ = 1 − Π(1 − φᵢ)`, the accumulated opacity
/// of volume rendering (NeRF's `1 − T` at the far end, DVR's and SoftRas' soft silhouettes): the
/// probability that a ray through independent occupancies `φᵢ` is stopped somewhere. The
/// silhouette does not depend on the order of the samples, so no depth is needed. Unlike the max,
/// every sample gets a gradient, `Πⱼ≠ᵢ(1 − φⱼ)`; and its value grows with the number of samples
/// on a ray, so it suits dense marching (a fixed count per ray) better than anchors (a count that
/// varies with the ray's length through the support spheres). An empty ray predicts 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Composite {}

impl Composite {
    /// Transmittance is taken in log space, `Σ ln(1 − φᵢ)`, with `1 − φ` floored here: a product
    /// of hundreds of factors would underflow, and `ln 0` is `−∞`.
    const FLOOR: f32 = 1e-6;
}

impl Aggregator for Composite {
    fn aggregate(&self, rays: RayValues) -> Tensor<1> {
        let RayValues { values, valid, .. } = rays;
        let log_transmittance: Tensor<1> = values
            .neg()
            .add_scalar(1.0)
            .clamp_min(Self::FLOOR)
            .log()
            .mask_fill(valid.bool_not(), 0.0)
            .sum_dim(1)
            .squeeze_dim(1);
        log_transmittance.exp().neg().add_scalar(1.0)
    }
}

#[typetag::serde(name = "composite")]
impl AggregatorConfig for Composite {
    fn build(&self) -> Result<Box<dyn Aggregator>, String> {
        Ok(Box::new(*self))
    }
}

crate::register_component!(
    Aggregator,
    "composite",
    "alpha compositing 1 − Π(1 − φ) along the ray (volume rendering's accumulated opacity), for dense marching",
    r#"type = "composite""#
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_pool_ignores_padding_and_empty_rays_predict_zero() {
        let dev = Device::flex();
        let values = Tensor::<2>::from_data(
            TensorData::new(vec![0.2f32, 0.9, 0.0, 0.4, 0.3, 0.7, 0.0, 0.0, 0.0], [3, 3]),
            &dev,
        );
        let valid = Tensor::<2, Bool>::from_data(
            TensorData::new(
                vec![true, true, false, true, true, false, false, false, false],
                [3, 3],
            ),
            &dev,
        );
        let out: Vec<f32> = MaxPool {}
            .aggregate(RayValues::new(values, valid))
            .try_into_vec_as::<f32>()
            .unwrap();
        assert_eq!(out, vec![0.9, 0.4, 0.0]);
    }

    #[test]
    fn composite_is_one_minus_the_product_of_transmittances() {
        let dev = Device::flex();
        let values = Tensor::<2>::from_data(
            TensorData::new(vec![0.2f32, 0.5, 0.9, 0.4, 0.3, 0.0, 1.0, 0.0, 0.0], [3, 3]),
            &dev,
        );
        let valid = Tensor::<2, Bool>::from_data(
            TensorData::new(
                vec![true, true, false, true, true, false, true, false, false],
                [3, 3],
            ),
            &dev,
        );
        let out: Vec<f32> = Composite {}
            .aggregate(RayValues::new(values.clone(), valid.clone()))
            .try_into_vec_as::<f32>()
            .unwrap();
        // Padding is ignored; φ = 1 saturates up to the floor; with no valid entry, 0.
        let want = [1.0 - 0.8 * 0.5, 1.0 - 0.6 * 0.7, 1.0 - Composite::FLOOR];
        for (g, w) in out.iter().zip(want) {
            assert!((g - w).abs() < 1e-5, "{out:?}");
        }
        let empty = Tensor::<2, Bool>::from_data(TensorData::new(vec![false; 9], [3, 3]), &dev);
        let none: Vec<f32> = Composite {}
            .aggregate(RayValues::new(values, empty))
            .try_into_vec_as::<f32>()
            .unwrap();
        assert_eq!(none, vec![0.0; 3]);
    }

    /// The plain formulation, ray by ray in f64.
    fn softmax_reference(rows: &[Vec<f32>], t: f64) -> Vec<f64> {
        rows.iter()
            .map(|r| {
                if r.is_empty() {
                    return 0.0;
                }
                let w: Vec<f64> = r.iter().map(|&v| (v as f64 / t).exp()).collect();
                let z: f64 = w.iter().sum();
                r.iter().zip(&w).map(|(&v, w)| v as f64 * w / z).sum()
            })
            .collect()
    }

    #[test]
    fn soft_max_matches_its_reference_and_spans_mean_to_max() {
        let dev = Device::flex();
        let rows: Vec<Vec<f32>> = vec![
            vec![0.2, 0.9, 0.5],
            vec![0.4],
            vec![],
            vec![0.01, 0.02, 0.99, 0.98, 0.3],
        ];
        let width = 5;
        let mut vals = Vec::new();
        let mut mask = Vec::new();
        for r in &rows {
            for k in 0..width {
                vals.push(r.get(k).copied().unwrap_or(0.0));
                mask.push(k < r.len());
            }
        }
        let run = |t: f32| -> Vec<f32> {
            let values =
                Tensor::<2>::from_data(TensorData::new(vals.clone(), [rows.len(), width]), &dev);
            let valid = Tensor::<2, Bool>::from_data(
                TensorData::new(mask.clone(), [rows.len(), width]),
                &dev,
            );
            SoftMax { temperature: t }
                .aggregate(RayValues::new(values, valid))
                .try_into_vec_as::<f32>()
                .unwrap()
        };
        for t in [0.01f32, 0.05, 0.5, 5.0] {
            let got = run(t);
            let want = softmax_reference(&rows, t as f64);
            for (g, w) in got.iter().zip(&want) {
                assert!((*g as f64 - w).abs() < 1e-5, "T {t}: {got:?} vs {want:?}");
            }
        }
        // T → 0 is the max; T → ∞ the mean; an empty ray is 0.
        let cold = run(1e-3);
        assert!((cold[0] - 0.9).abs() < 1e-4 && (cold[3] - 0.99).abs() < 1e-2);
        let hot = run(1e3);
        assert!((hot[0] - (0.2 + 0.9 + 0.5) / 3.0).abs() < 1e-3);
        assert_eq!(cold[2], 0.0);
        let e: Result<Box<dyn AggregatorConfig>, _> =
            serde_json::from_str(r#"{"type":"softmax","temperature":0}"#);
        assert!(e.unwrap().build().unwrap_err().contains("temperature"));
    }
}
