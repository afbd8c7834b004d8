//! FieldProbe regularizers.
//!
//! | `type` | term |
//! |---|---|
//! | `none` | no regularization (the paper's "no regularizer" row of Table 2) |

pub mod none;

pub use none::NoRegularizer;
