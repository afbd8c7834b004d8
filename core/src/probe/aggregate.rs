//! Aggregators: one prediction per ray from the field values at the anchors it meets.

use std::fmt::Debug;

use burn::prelude::*;
use serde::{Deserialize, Serialize};

/// Turns the field values at the anchors of each ray into the ray's prediction ψ.
pub trait Aggregator: Send + Sync + Debug {
    /// `values` `[R, K]`: φ at the anchors of each ray, padded; `valid` `[R, K]` marks real
    /// entries. Padded entries hold 0. A ray with no anchor must predict 0 ("nothing probed, no
    /// occupancy seen"): such a ray then adds a constant `label²` to the loss and no gradient.
    fn aggregate(&self, values: Tensor<2>, valid: Tensor<2, Bool>) -> Tensor<1>;
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
    fn aggregate(&self, values: Tensor<2>, valid: Tensor<2, Bool>) -> Tensor<1> {
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
            .aggregate(values, valid)
            .try_into_vec_as::<f32>()
            .unwrap();
        assert_eq!(out, vec![0.9, 0.4, 0.0]);
    }
}
