//! FieldProbe regularizers: none, and the paper's p-norm normal consistency.
//!
//! Part of the workspace skeleton laid down with the data foundation; the `Regularizer` trait and
//! its implementations arrive with the probing and ablation work.
