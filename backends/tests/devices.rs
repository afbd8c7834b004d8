//! The same small computation on flex and on wgpu (a hardware GPU or Mesa's software Vulkan
//! device in CI) agrees with a plain reference.

use burn::tensor::{Tensor, TensorData};
use fieldprobe_backends::BackendChoice;

fn reference(a: &[f32], b: &[f32], n: usize) -> Vec<f32> {
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            out[i * n + j] = (0..n)
                .map(|k| a[i * n + k] * b[k * n + j])
                .sum::<f32>()
                .tanh();
        }
    }
    out
}

fn run(choice: BackendChoice) {
    let n = 17;
    let a: Vec<f32> = (0..n * n)
        .map(|i| ((i * 37 % 11) as f32 - 5.0) * 0.05)
        .collect();
    let b: Vec<f32> = (0..n * n)
        .map(|i| ((i * 13 % 7) as f32 - 3.0) * 0.07)
        .collect();
    let sel = choice.select();
    let ta = Tensor::<2>::from_data(TensorData::new(a.clone(), [n, n]), &sel.device);
    let tb = Tensor::<2>::from_data(TensorData::new(b.clone(), [n, n]), &sel.device);
    let got: Vec<f32> = ta.matmul(tb).tanh().try_into_vec_as::<f32>().unwrap();
    let want = reference(&a, &b, n);
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-4, "{}: {g} vs {w}", sel.description);
    }
}

#[test]
fn flex_matches_reference() {
    run(BackendChoice::Flex);
}

#[test]
fn wgpu_matches_reference() {
    run(BackendChoice::Wgpu);
}

#[test]
fn auto_always_resolves() {
    let sel = BackendChoice::Auto.select();
    assert!(
        sel.backend == "flex" || sel.backend == "wgpu",
        "{}",
        sel.description
    );
}
