//! FieldProbe regularizers.
//!
//! | `type` | term |
//! |---|---|
//! | `eikonal` | IGR's eikonal term `λ·mean(‖∇s‖ − 1)²` by central differences at the sampled anchors, for signed-distance representations |
//! | `none` | no regularization (the paper's "no regularizer" row of Table 2) |
//! | `normal_consistency` | the paper's p-norm normal consistency (§3.2, eq. 7): finite-difference normals of near-surface anchors (φ within ε of 0.5) against those of their 6 neighbours at ±Δd along each axis, times `weight` (λ) |

mod common;
pub mod eikonal;
pub mod none;
pub mod normal_consistency;

pub use eikonal::Eikonal;
pub use none::NoRegularizer;
pub use normal_consistency::NormalConsistency;
