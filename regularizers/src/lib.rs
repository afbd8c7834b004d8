//! FieldProbe regularizers. An experiment names each one it uses (`[regularizers.<name>]`, as
//! many as it wants; the loss is the silhouette term plus their sum); "no regularizer" (the
//! paper's row of Table 2) is no such table.
//!
//! | `type` | term |
//! |---|---|
//! | `eikonal` | IGR's eikonal term `λ·mean(‖∇s‖ − 1)²` by central differences at the sampled anchors, for signed-distance representations |
//! | `normal_consistency` | the paper's p-norm normal consistency (§3.2, eq. 7): finite-difference normals of near-surface anchors (φ within ε of 0.5) against those of their 6 neighbours at ±Δd along each axis, times `weight` (λ) |

mod common;
pub mod eikonal;
pub mod normal_consistency;

pub use eikonal::Eikonal;
pub use normal_consistency::NormalConsistency;
