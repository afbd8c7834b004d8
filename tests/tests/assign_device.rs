//! Ray–anchor assignment on the device (`probe.assign_on = "device"`) against its reference, the
//! CPU's binned assignment: identical pairs on flex (every operation rounded as on the CPU), for
//! the naive and both boundary-aware policies on a procedural chair's silhouettes; on wgpu
//! (Mesa's software Vulkan device in CI) identical up to pairs within rounding of the sphere's
//! boundary, and none of those in practice.

use fieldprobe_backends::{BackendChoice, Device, testing};
use fieldprobe_core::data::Category;
use fieldprobe_core::data::dataset::{ObjectRecord, ObjectSet, Split};
use fieldprobe_core::data::procedural::{generate, object_rng};
use fieldprobe_core::data::render::RenderOptions;
use fieldprobe_core::data::voxelize::Voxelizer;
use fieldprobe_core::object::ObjectViews;
use fieldprobe_core::probe::{
    Assignment, AssignmentPolicy, Probe, RaySet, assign_binned, assign_on_device,
};
use fieldprobe_core::probe::{RaySampler, Supervision};
use fieldprobe_samplers::ImportanceRays;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn chair() -> Supervision {
    let mesh = generate(Category::Chair, &mut object_rng(3, Category::Chair, 0, 0));
    let mut set = ObjectSet::new(Category::Chair, Split::Train);
    let opts = RenderOptions {
        supersample: 2,
        ..Default::default()
    };
    set.push(
        "c".into(),
        &ObjectRecord::from_mesh(&mesh, Voxelizer::Nmr, &opts),
    );
    (*ObjectViews::from_set(&set, 0).supervision).clone()
}

/// Anchors uniform in the cube and rays concentrated on the silhouettes' contours (where the
/// boundary-aware policies decide), in 8 views.
fn probe_inputs(object: &Supervision, seed: u64) -> (Vec<Vec3>, RaySet) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let anchors = (0..3000)
        .map(|_| {
            Vec3::new(
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
            )
        })
        .collect();
    let sampler = ImportanceRays::default();
    let mut rays = RaySet::default();
    for v in (0..24).step_by(3) {
        for px in sampler.sample_pixels(object, v, 200, &mut rng) {
            rays.views.push(v as u16);
            rays.labels.push(object.silhouettes[v].bilinear(px));
            rays.pixels.push(px);
        }
    }
    (anchors, rays)
}

const POLICIES: [AssignmentPolicy; 3] = [
    AssignmentPolicy::Naive,
    AssignmentPolicy::BoundaryAware,
    AssignmentPolicy::BoundaryAwareHull,
];

/// For every policy: the reference and the device's assignment.
fn both(object: &Supervision, device: &Device) -> Vec<(Assignment, Assignment)> {
    let (anchors, rays) = probe_inputs(object, 7);
    POLICIES
        .iter()
        .map(|&policy| {
            let probe = Probe {
                cameras: &object.cameras,
                silhouettes: &object.silhouettes,
                anchors: &anchors,
                rays: &rays,
                radius: 0.03,
                policy,
            };
            (assign_binned(probe), assign_on_device(probe, device))
        })
        .collect()
}

#[test]
fn device_assignment_on_flex_gives_the_binned_pairs() {
    let object = chair();
    let flex = BackendChoice::Flex.select().unwrap().device;
    for ((want, got), policy) in both(&object, &flex).into_iter().zip(POLICIES) {
        assert!(want.anchors.len() > 1000, "{policy:?}: a real test");
        assert_eq!(want, got, "{policy:?}");
    }
    // Chunks: the same pairs when each chunk is one ray (the chunk size only tiles the work).
    let (anchors, rays) = probe_inputs(&object, 8);
    let probe = Probe {
        cameras: &object.cameras,
        silhouettes: &object.silhouettes,
        anchors: &anchors[..10],
        rays: &rays,
        radius: 0.2,
        policy: AssignmentPolicy::BoundaryAware,
    };
    assert_eq!(assign_binned(probe), assign_on_device(probe, &flex));
}

#[test]
fn device_assignment_on_wgpu_gives_the_binned_pairs() {
    let name = "device_assignment_on_wgpu_gives_the_binned_pairs";
    let Some(gpu) = testing::wgpu_or_skip(name) else {
        return;
    };
    let object = chair();
    let results = testing::with_deadline(name, testing::DEVICE_TEST_DEADLINE, move || {
        both(&object, &gpu)
    });
    for ((want, got), policy) in results.into_iter().zip(POLICIES) {
        let total = want.anchors.len();
        let differ = (0..want.rays())
            .map(|r| {
                let (a, b) = (want.of(r), got.of(r));
                a.iter().filter(|x| !b.contains(x)).count()
                    + b.iter().filter(|x| !a.contains(x)).count()
            })
            .sum::<usize>();
        // A fused multiply-add may move a pair lying within ~1e-7 of the boundary; with a few
        // thousand pairs that is at most a handful, and usually none.
        assert!(
            differ <= total / 1000,
            "{policy:?}: {differ} of {total} pairs differ"
        );
        if differ > 0 {
            eprintln!("{policy:?}: {differ} of {total} pairs differ (rounding at the boundary)");
        }
    }
}
