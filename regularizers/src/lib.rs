//! FieldProbe regularizers.
//!
//! | `type` | term |
//! |---|---|
//! | `none` | no regularization (the paper's "no regularizer" row of Table 2) |
//! | `normal_consistency` | the paper's p-norm normal consistency (§3.2, eq. 7): finite-difference normals of near-surface anchors (φ within ε of 0.5) against those of their 6 neighbours at ±Δd along each axis, times `weight` (λ) |

pub mod none;
pub mod normal_consistency;

pub use none::NoRegularizer;
pub use normal_consistency::NormalConsistency;
