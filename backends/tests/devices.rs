//! The same small computation on flex and on wgpu (a hardware GPU or Mesa's software Vulkan
//! device in CI) agrees with a plain reference.

use burn::tensor::{Tensor, TensorData};
use fieldprobe_backends::{BackendChoice, Device, testing};

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

fn run(device: &Device, description: &str) {
    let n = 17;
    let a: Vec<f32> = (0..n * n)
        .map(|i| ((i * 37 % 11) as f32 - 5.0) * 0.05)
        .collect();
    let b: Vec<f32> = (0..n * n)
        .map(|i| ((i * 13 % 7) as f32 - 3.0) * 0.07)
        .collect();
    let ta = Tensor::<2>::from_data(TensorData::new(a.clone(), [n, n]), device);
    let tb = Tensor::<2>::from_data(TensorData::new(b.clone(), [n, n]), device);
    let got: Vec<f32> = ta.matmul(tb).tanh().try_into_vec_as::<f32>().unwrap();
    let want = reference(&a, &b, n);
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-4, "{description}: {g} vs {w}");
    }
}

#[test]
fn flex_matches_reference() {
    let sel = BackendChoice::Flex.select().unwrap();
    run(&sel.device, &sel.description);
}

/// Skipped with one line where wgpu has no Vulkan driver; failed by a watchdog if it stalls.
#[test]
fn wgpu_matches_reference() {
    let name = "wgpu_matches_reference";
    let Some(device) = testing::wgpu_or_skip(name) else {
        return;
    };
    testing::with_deadline(name, testing::DEVICE_TEST_DEADLINE, move || {
        run(&device, "wgpu")
    });
}

/// `auto` resolves on every machine, and never to wgpu where wgpu has no Vulkan driver.
#[test]
fn auto_always_resolves() {
    let sel = testing::with_deadline(
        "auto_always_resolves",
        testing::DEVICE_TEST_DEADLINE,
        || BackendChoice::Auto.select().unwrap(),
    );
    if fieldprobe_backends::wgpu_unavailable().is_some() {
        assert_eq!(sel.backend, "flex", "{}", sel.description);
    }
    assert!(
        sel.backend == "flex" || sel.backend == "wgpu",
        "{}",
        sel.description
    );
}

/// Where wgpu has no Vulkan driver, asking for it is refused with what to install, without
/// opening an adapter.
#[test]
fn wgpu_without_vulkan_is_refused_with_what_to_install() {
    match fieldprobe_backends::wgpu_unavailable() {
        Some(reason) => {
            let e = BackendChoice::Wgpu.select().unwrap_err().to_string();
            assert!(
                e.contains(&reason) && e.contains("mesa-vulkan-drivers"),
                "{e}"
            );
        }
        None => eprintln!("a Vulkan driver is present; nothing to refuse here"),
    }
}
