//! Ray–anchor assignment at the paper's scale: 4096 rays in each of 24 views, 16000 anchors,
//! τ = 0.03. Binned vs the all-pairs reference, side by side in one run (the machine is shared
//! and noisy, so compare the two lines of the same run). Both return identical pairs (tested in
//! `probe::assign`).
//!
//! A second group compares the CPU's binned assignment with the device one
//! (`probe.assign_on = "device"`) on one view's 1024 rays: on flex, and on wgpu's default
//! adapter too with `FIELDPROBE_BENCH_WGPU=1` (needs a Vulkan device; a GPU is where it pays).
//!
//!     cargo bench -p fieldprobe-core --bench assign

use burn::prelude::Device;
use burn::tensor::DeviceKind;
use criterion::{Criterion, criterion_group, criterion_main};
use fieldprobe_core::data::Silhouette;
use fieldprobe_core::geometry::{Camera, PixelPos};
use fieldprobe_core::probe::{
    AssignmentPolicy, Probe, RaySet, assign_all_pairs, assign_binned, assign_on_device,
};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn paper_scale() -> (Vec<Camera>, Vec<Silhouette>, Vec<Vec3>, RaySet) {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let cams = Camera::nmr_views();
    let sils = vec![Silhouette::empty(64); 24];
    let anchors = (0..16_000)
        .map(|_| {
            Vec3::new(
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
            )
        })
        .collect();
    let mut rays = RaySet::default();
    for v in 0..24u16 {
        for _ in 0..4096 {
            rays.views.push(v);
            rays.pixels.push(PixelPos {
                col: rng.random_range(-0.5..63.5),
                row: rng.random_range(-0.5..63.5),
            });
            rays.labels.push(0.0);
        }
    }
    (cams, sils, anchors, rays)
}

fn bench(c: &mut Criterion) {
    let (cams, sils, anchors, rays) = paper_scale();
    let probe = Probe {
        cameras: &cams,
        silhouettes: &sils,
        anchors: &anchors,
        rays: &rays,
        radius: 0.03,
        policy: AssignmentPolicy::Naive,
    };
    let pairs = assign_binned(probe).anchors.len();
    println!(
        "paper scale: {} rays × {} anchors, {} pairs assigned ({:.1} per ray)",
        rays.len(),
        anchors.len(),
        pairs,
        pairs as f64 / rays.len() as f64
    );
    let mut g = c.benchmark_group("assign_paper_scale");
    g.sample_size(10);
    g.bench_function("binned", |b| b.iter(|| assign_binned(probe)));
    g.bench_function("all_pairs", |b| b.iter(|| assign_all_pairs(probe)));
    g.finish();

    let one_view = RaySet {
        views: rays.views[..1024].to_vec(),
        pixels: rays.pixels[..1024].to_vec(),
        labels: rays.labels[..1024].to_vec(),
    };
    let small = Probe {
        rays: &one_view,
        ..probe
    };
    let mut devices = vec![("device_flex", Device::flex())];
    if std::env::var_os("FIELDPROBE_BENCH_WGPU").is_some() {
        devices.push(("device_wgpu", Device::wgpu(DeviceKind::DefaultDevice)));
    }
    let mut g = c.benchmark_group("assign_1024_rays_16000_anchors");
    g.sample_size(10);
    g.bench_function("binned", |b| b.iter(|| assign_binned(small)));
    for (name, device) in devices {
        assert_eq!(assign_on_device(small, &device), assign_binned(small));
        g.bench_function(name, |b| b.iter(|| assign_on_device(small, &device)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
