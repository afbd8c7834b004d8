//! The empty regularizer.

use burn::prelude::*;
use fieldprobe_core::register_component;
use fieldprobe_core::regularize::{FieldQuery, Regularizer, RegularizerConfig};
use serde::{Deserialize, Serialize};

/// Adds nothing to the loss.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoRegularizer {}

impl Regularizer for NoRegularizer {
    fn loss(&self, _field: &FieldQuery<'_>, _anchors: &Tensor<3>) -> Option<Tensor<1>> {
        None
    }
}

#[typetag::serde(name = "none")]
impl RegularizerConfig for NoRegularizer {
    fn build(&self) -> Result<Box<dyn Regularizer>, String> {
        Ok(Box::new(*self))
    }
}

register_component!(Regularizer, "none", "no regularization", r#"type = "none""#);
