//! Pieces every finite-difference regularizer of this crate shares.

use burn::prelude::*;

/// `weight` must be a finite number ≥ 0; the error names the key (the experiment adds the table).
pub fn check_weight(weight: f32) -> Result<(), String> {
    if weight >= 0.0 && weight.is_finite() {
        Ok(())
    } else {
        Err(format!("weight must be a finite number ≥ 0, got {weight}"))
    }
}

/// The strided subset `0, all/n, 2·all/n, …` of `n` of each object's `all` anchors
/// (`[B, all, 3]` → `[B, n, 3]`; the anchors themselves when `n ≥ all`): an even, deterministic
/// sample of anchors that the samplers already drew at random.
pub fn strided_subset(anchors: &Tensor<3>, n: usize) -> Tensor<3> {
    let all = anchors.dims()[1];
    if n >= all {
        return anchors.clone();
    }
    let idx: Vec<i32> = (0..n).map(|i| (i * all / n) as i32).collect();
    let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [n]), &anchors.device());
    anchors.clone().select(1, idx)
}
