//! A tiny single-view training run: the loss falls, runs are reproducible on the CPU backend, a
//! resumed run continues exactly, a non-finite loss stops with a clear error, and the same run
//! works on wgpu (Mesa's software Vulkan device in CI).

use std::sync::Mutex;

use fieldprobe_backends::{BackendChoice, Device, testing};
use fieldprobe_core::data::Category;
use fieldprobe_core::data::dataset::{ObjectRecord, ObjectSet, Split};
use fieldprobe_core::data::procedural::{generate, object_rng};
use fieldprobe_core::data::render::RenderOptions;
use fieldprobe_core::data::voxelize::Voxelizer;
use fieldprobe_core::field::FieldModelConfig;
use fieldprobe_core::object::ObjectViews;
use fieldprobe_core::probe::{
    AssignmentPolicy, Composite, MaxPool, ObjectProbe, ProbeBatch, ProbeSpec, SoftMax,
};
use fieldprobe_core::regularize::Regularizer;
use fieldprobe_core::train::{
    Components, DeviceBatch, PreparedStep, StepStats, TrainError, TrainRun, TrainSpec, Trainer,
    checkpoint, prepare_step, probe_loss, step_rng,
};
use fieldprobe_models::{
    DecoderConfig, EncoderConfig, PerObjectConfig, SdfConfig, SingleViewConfig,
};
use fieldprobe_regularizers::{Eikonal, NormalConsistency};
use fieldprobe_samplers::{StratifiedDepths, UniformAnchors, UniformRays};

/// burn's flex RNG is process-wide: tests that seed it must not interleave.
static SEEDED: Mutex<()> = Mutex::new(());

fn objects(n: usize) -> Vec<ObjectViews> {
    let opts = RenderOptions {
        supersample: 2,
        ..Default::default()
    };
    let mut set = ObjectSet::new(Category::Chair, Split::Train);
    for i in 0..n {
        let mesh = generate(
            Category::Chair,
            &mut object_rng(11, Category::Chair, 0, i as u64),
        );
        set.push(
            format!("c{i}"),
            &ObjectRecord::from_mesh(&mesh, Voxelizer::Nmr, &opts),
        );
    }
    (0..n).map(|i| ObjectViews::from_set(&set, i)).collect()
}

/// A small per-object field: learns one object in tens of steps, so "the loss falls" is quick to
/// check through the whole probing pipeline.
fn per_object() -> PerObjectConfig {
    PerObjectConfig {
        decoder: DecoderConfig {
            hidden: vec![64, 64],
            frequencies: 3,
        },
    }
}

/// A small single-view model (encoder with batch norm + decoder).
fn model() -> SingleViewConfig {
    SingleViewConfig {
        latent: 16,
        encoder: EncoderConfig {
            channels: vec![8, 16],
            blocks: vec![1, 1],
            in_channels: 4,
            ..EncoderConfig::default()
        },
        decoder: DecoderConfig {
            hidden: vec![32, 32],
            frequencies: 0,
        },
    }
}

fn comps() -> Components {
    Components {
        ray_sampler: Box::new(UniformRays {}),
        anchor_sampler: Box::new(UniformAnchors::default()),
        aggregator: Box::new(MaxPool {}),
        march: None,
        assign_device: None,
        regularizers: Vec::new(),
    }
}

/// A copy of `prepared` on `device`, for tests that read a prepared step again afterwards.
fn upload(prepared: &PreparedStep, c: &Components, device: &Device) -> DeviceBatch {
    DeviceBatch::upload(prepared.clone(), c, device)
}

const SPEC: ProbeSpec = ProbeSpec {
    anchors: 512,
    rays_per_view: 64,
    views: 4,
    radius: 0.04,
    assignment: AssignmentPolicy::Naive,
};

fn train(
    config: &dyn FieldModelConfig,
    device: &Device,
    data: &[ObjectViews],
    steps: usize,
) -> Vec<f32> {
    train_with(config, &comps(), device, data, steps)
}

/// Trains through the library's loop ([`Trainer::fit`]): batch 2, constant lr 3e-3, seed 5;
/// returns every step's loss.
fn train_with(
    config: &dyn FieldModelConfig,
    c: &Components,
    device: &Device,
    data: &[ObjectViews],
    steps: usize,
) -> Vec<f32> {
    let mut t = Trainer::new(config, device, 5);
    let schedule = schedule(steps, 0);
    let run = TrainRun {
        objects: data,
        comps: c,
        probe: &SPEC,
        schedule: &schedule,
        uses_image: config.uses_image(),
        seed: 5,
    };
    let mut losses = Vec::new();
    t.fit(&run, None, &mut |_: &Trainer, s: &StepStats| {
        losses.push(s.loss)
    })
    .unwrap();
    losses
}

fn schedule(steps: usize, checkpoint_every: usize) -> TrainSpec {
    TrainSpec {
        steps,
        batch: 2,
        lr: 3e-3,
        lr_final: None,
        checkpoint_every,
        init_from: None,
        prefetch: 2,
        devices: 1,
    }
}

/// Probes prepared ahead on a worker thread make exactly the serial loop's batches: the same
/// losses at every step (so the same weights after each), with a regularizer that reads the
/// step index, an importance sampler with its cache, and a loop stopped early by a hook-free
/// shorter schedule then resumed.
#[test]
fn prefetched_training_equals_the_serial_loop() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(2);
    let dev = BackendChoice::Flex.select().unwrap().device;
    let c = Components {
        anchor_sampler: Box::new(
            fieldprobe_samplers::ImportanceAnchorSampler::new(
                fieldprobe_samplers::ImportanceAnchors::default(),
            )
            .unwrap(),
        ),
        regularizers: vec![Box::new(NormalConsistency {
            every: 3,
            epsilon: 0.5,
            max_anchors: 64,
            ..NormalConsistency::default()
        })],
        ..comps()
    };
    let losses = |prefetch: usize, pause_at: Option<usize>| {
        let mut t = Trainer::new(&model(), &dev, 5);
        let mut out = Vec::new();
        let mut record =
            |_: &Trainer, s: &StepStats| out.push((s.step, s.loss, s.regularizer_loss));
        for steps in pause_at.into_iter().chain([12]) {
            let schedule = TrainSpec {
                prefetch,
                ..schedule(steps, 0)
            };
            let run = TrainRun {
                objects: &data,
                comps: &c,
                probe: &SPEC,
                schedule: &schedule,
                uses_image: true,
                seed: 5,
            };
            t.fit(&run, None, &mut record).unwrap();
        }
        out
    };
    let serial = losses(0, None);
    assert_eq!(serial.len(), 12);
    assert!(serial.iter().any(|s| s.2 > 0.0), "the regularizer acted");
    for (prefetch, pause) in [(1, None), (3, None), (2, Some(5))] {
        assert_eq!(
            losses(prefetch, pause),
            serial,
            "prefetch {prefetch}, paused at {pause:?}"
        );
    }
}

fn falls(losses: &[f32]) {
    let k = losses.len() / 4;
    let first: f32 = losses[..k].iter().sum::<f32>() / k as f32;
    let last: f32 = losses[losses.len() - k..].iter().sum::<f32>() / k as f32;
    assert!(
        last < 0.8 * first,
        "loss should fall: {first} → {last} ({losses:?})"
    );
}

#[test]
fn flex_training_lowers_the_loss_and_is_reproducible() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(1);
    let dev = BackendChoice::Flex.select().unwrap().device;
    let a = train(&per_object(), &dev, &data, 60);
    falls(&a);
    assert_eq!(
        a,
        train(&per_object(), &dev, &data, 60),
        "same seed, same losses"
    );
    let single = train(&model(), &dev, &objects(2), 10);
    assert!(single.iter().all(|l| l.is_finite()));
    assert_eq!(
        single,
        train(&model(), &dev, &objects(2), 10),
        "single-view: same seed, same losses"
    );
}

/// The signed-distance representation, added through the `FieldModel` trait alone, trains from
/// silhouettes on the same probing loss, with the eikonal term beside it; its checkpoint (β
/// included) restores exactly.
#[test]
fn sdf_with_the_eikonal_term_learns_from_silhouettes() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(1);
    let dev = BackendChoice::Flex.select().unwrap().device;
    let sdf = SdfConfig {
        latent: 0,
        decoder: Some(DecoderConfig {
            hidden: vec![64, 64],
            frequencies: 3,
        }),
        beta: 0.05,
        ..SdfConfig::default()
    };
    let c = Components {
        regularizers: vec![Box::new(Eikonal::default())],
        ..comps()
    };
    let losses = train_with(&sdf, &c, &dev, &data, 60);
    assert!(losses.iter().all(|l| l.is_finite()));
    falls(&losses);

    let dir = tempfile::tempdir().unwrap();
    let mut t = Trainer::new(&sdf, &dev, 2);
    for s in 0..3 {
        t.step(prepare_step(&data, &c, &SPEC, 1, false, 2, s), &c, 1e-2)
            .unwrap();
    }
    checkpoint::save(&t, dir.path()).unwrap();
    let mut back = checkpoint::load(&sdf, &dev, dir.path()).unwrap();
    let next = prepare_step(&data, &c, &SPEC, 1, false, 2, 3);
    let a = t.step(next.clone(), &c, 1e-2).unwrap().loss;
    let b = back.step(next, &c, 1e-2).unwrap().loss;
    assert!((a - b).abs() <= 1e-6 * a.abs().max(1.0), "{a} vs {b}");
}

/// Every batch entry carries its anchor's depth along the ray and distance from it (what a
/// geometric aggregator reads), recomputed here from the cameras, and padding carries zeros.
#[test]
fn batches_carry_each_pairs_depth_and_distance() {
    let data = objects(1);
    let c = comps();
    let sup = &data[0].supervision;
    let probe = ObjectProbe::sample(
        sup,
        &SPEC,
        c.ray_sampler.as_ref(),
        c.anchor_sampler.as_ref(),
        &mut step_rng(3, 0, 1),
    );
    for compact in [false, true] {
        let b = ProbeBatch::assemble(std::slice::from_ref(&probe), compact);
        let mut checked = 0;
        for r in 0..b.rays {
            let ray = sup.cameras[probe.rays.views[r] as usize].ray(probe.rays.pixels[r]);
            for k in 0..b.width {
                let e = r * b.width + k;
                if !b.valid[e] {
                    assert_eq!((b.depth[e], b.distance[e]), (0.0, 0.0));
                    continue;
                }
                let i = b.index[e] as usize;
                let a = glam::Vec3::from_slice(&b.anchors[3 * i..3 * i + 3]);
                let t = (a - ray.origin).dot(ray.direction);
                let d = (a - ray.origin - ray.direction * t).length();
                assert!((b.depth[e] - t).abs() < 1e-5 && (b.distance[e] - d).abs() < 1e-5);
                assert!(d <= SPEC.radius + 1e-5, "assigned within τ: {d}");
                checked += 1;
            }
        }
        assert_eq!(checked, b.pairs);
        assert!(checked > 0);
    }
}

/// The second aggregator trains through the same loop.
#[test]
fn soft_max_aggregation_learns_from_silhouettes() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(1);
    let dev = BackendChoice::Flex.select().unwrap().device;
    let c = Components {
        aggregator: Box::new(SoftMax::default()),
        ..comps()
    };
    let losses = train_with(&per_object(), &c, &dev, &data, 60);
    falls(&losses);
}

/// Dense ray marching (the baseline of the efficiency comparison) through the same batches and
/// loss: each ray reads exactly its own samples, on the ray inside the cube, objects with fewer
/// samples (rays that miss the cube) are padded with points no ray reads, the silhouette loss
/// equals a plain per-ray compositing in f64, regularizers get the anchors a probing step of
/// the same seed draws, and a field learns from it.
#[test]
fn dense_marching_reads_each_rays_own_samples_and_learns() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(2);
    let samples = 8;
    let c = Components {
        aggregator: Box::new(Composite {}),
        march: Some(Box::new(StratifiedDepths { samples })),
        ..comps()
    };
    let marcher = c.march.as_deref().unwrap();
    let probes: Vec<ObjectProbe> = data
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let (rays, anchors) = (c.ray_sampler.as_ref(), c.anchor_sampler.as_ref());
            let m = ObjectProbe::march(
                &o.supervision,
                &SPEC,
                rays,
                anchors,
                marcher,
                &mut step_rng(3, 0, i),
            );
            let p =
                ObjectProbe::sample(&o.supervision, &SPEC, rays, anchors, &mut step_rng(3, 0, i));
            assert_eq!(m.sampled, p.anchors, "regularizers see probing's anchors");
            assert_eq!(m.rays, p.rays, "and the rays are probing's");
            m
        })
        .collect();
    assert!(
        probes
            .iter()
            .any(|p| p.anchors.len() < p.rays.len() * samples),
        "some uniform rays miss the cube"
    );
    let dev = BackendChoice::Flex.select().unwrap().device;
    let t = Trainer::new(&per_object(), &dev, 4);
    for compact in [false, true] {
        let b = ProbeBatch::assemble(&probes, compact);
        let kept = b.anchors_per_object;
        assert_eq!(kept, probes.iter().map(|p| p.anchors.len()).max().unwrap());
        assert_eq!(b.width, samples);
        let mut first = 0;
        for (o, p) in probes.iter().enumerate() {
            let sup = &data[o].supervision;
            for r in 0..p.rays.len() {
                let ray = sup.cameras[p.rays.views[r] as usize].ray(p.rays.pixels[r]);
                let row = first + r;
                let read: Vec<usize> = (0..b.width)
                    .filter(|&k| b.valid[row * b.width + k])
                    .map(|k| b.index[row * b.width + k] as usize)
                    .collect();
                assert!(read.len() == samples || read.is_empty());
                for (k, &i) in read.iter().enumerate() {
                    assert!(
                        i >= o * kept && i < o * kept + p.anchors.len(),
                        "own object, not padding"
                    );
                    let q = glam::Vec3::from_slice(&b.anchors[3 * i..3 * i + 3]);
                    let depth = b.depth[row * b.width + k];
                    assert!((ray.at(depth) - q).length() < 1e-5);
                    assert!(q.abs().max_element() <= 0.5 + 1e-5);
                }
            }
            first += p.rays.len();
        }
        // The loss against the plain formulation: φ at every sample, composited per ray.
        let prepared = PreparedStep {
            batch: b.clone(),
            images: None,
            probe_seconds: 0.0,
            step: 0,
        };
        let (_, sil, _) = probe_loss(t.model.as_ref(), &upload(&prepared, &c, &t.device), &c);
        let sil: f32 = sil.into_scalar();
        let pts = burn::tensor::Tensor::<3>::from_data(
            burn::tensor::TensorData::new(b.anchors.clone(), [b.objects, kept, 3]),
            &t.device,
        );
        let phi: Vec<f32> = t
            .model
            .occupancy(None, pts)
            .try_into_vec_as::<f32>()
            .unwrap();
        let mut sq = 0.0f64;
        for r in 0..b.rays {
            let transmittance: f64 = (0..b.width)
                .filter(|&k| b.valid[r * b.width + k])
                .map(|k| 1.0 - f64::from(phi[b.index[r * b.width + k] as usize]))
                .product();
            sq += (1.0 - transmittance - f64::from(b.labels[r])).powi(2);
        }
        let want = sq / b.rays as f64 * SPEC.views as f64;
        assert!(
            (f64::from(sil) - want).abs() < 1e-4 * want.max(1e-3),
            "{sil} vs {want}"
        );
    }
    falls(&train_with(&per_object(), &c, &dev, &data[..1], 60));
}

/// Trains `steps` steps of batch 4 with the normal-consistency term uncapped on `devices`
/// (data-parallel when several); returns every step's loss and the final φ at fixed points.
fn train_on(devices: &[Device], steps: usize) -> (Vec<f32>, Vec<f32>) {
    let data = objects(1);
    let c = Components {
        regularizers: vec![Box::new(NormalConsistency {
            epsilon: 0.45,
            max_anchors: 0,
            ..NormalConsistency::default()
        })],
        ..comps()
    };
    let mut t = Trainer::new(&per_object(), &devices[0], 5).data_parallel(devices);
    let schedule = TrainSpec {
        batch: 4,
        devices: devices.len(),
        ..schedule(steps, 0)
    };
    let run = TrainRun {
        objects: &data,
        comps: &c,
        probe: &SPEC,
        schedule: &schedule,
        uses_image: false,
        seed: 5,
    };
    let mut losses = Vec::new();
    let mut regs = 0.0;
    t.fit(&run, None, &mut |_: &Trainer, s: &StepStats| {
        losses.push(s.loss);
        regs += s.regularizer_loss;
    })
    .unwrap();
    assert!(regs > 0.0, "the regularizer acted");
    let probe = burn::tensor::Tensor::<3>::from_data(
        burn::tensor::TensorData::new(
            (0..96)
                .map(|i| (i as f32 * 0.37).sin() * 0.45)
                .collect::<Vec<f32>>(),
            [1, 32, 3],
        ),
        &t.device,
    );
    let phi = t
        .model
        .occupancy(None, probe)
        .try_into_vec_as::<f32>()
        .unwrap();
    (losses, phi)
}

/// Data-parallel training (the batch split over devices, replicas' gradients summed by burn's
/// `step_multi`) takes the single-device steps up to float summation order: the same losses at
/// every step and the same field after them, with the (uncapped) regularizer. Two replicas on
/// flex's one CPU device, the case every machine has; and, where a Vulkan driver exists, the
/// CPU and a wgpu device as the two devices (different memories, gradients moved between them).
#[test]
fn data_parallel_training_matches_one_device() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let flex = BackendChoice::Flex.select().unwrap().device;
    let close = |a: &[f32], b: &[f32], what: &str| {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!(
                (x - y).abs() <= 1e-4 * x.abs().max(1e-2),
                "{what}: {a:?} vs {b:?}"
            );
        }
    };
    let (one, phi_one) = train_on(std::slice::from_ref(&flex), 8);
    let (two, phi_two) = train_on(&[flex.clone(), flex.clone()], 8);
    close(&one, &two, "losses, two replicas on flex");
    close(&phi_one, &phi_two, "φ after training, two replicas on flex");
    assert!(one.iter().all(|l| l.is_finite()));

    let name = "data_parallel_training_matches_one_device (flex + wgpu)";
    let Some(gpu) = testing::wgpu_or_skip(name) else {
        return;
    };
    // Fewer steps (each wgpu kernel is compiled on first use) and a looser bound on φ: the two
    // backends round differently, and the Adam steps carry that into the weights.
    let (short, phi_short) = train_on(std::slice::from_ref(&flex), 3);
    let (mixed, phi_mixed) =
        testing::with_deadline(name, testing::DEVICE_TEST_DEADLINE, move || {
            train_on(&[flex, gpu], 3)
        });
    close(&short, &mixed, "losses, flex + wgpu");
    for (x, y) in phi_short.iter().zip(&phi_mixed) {
        assert!(
            (x - y).abs() < 1e-3,
            "φ, flex + wgpu: {phi_short:?} vs {phi_mixed:?}"
        );
    }
}

/// On wgpu: skipped with a line saying what to install where there is no Vulkan driver, and
/// failed by a watchdog (not hung) if the device stalls.
#[test]
fn wgpu_training_lowers_the_loss() {
    let name = "wgpu_training_lowers_the_loss";
    let Some(dev) = testing::wgpu_or_skip(name) else {
        return;
    };
    let a = testing::with_deadline(name, testing::DEVICE_TEST_DEADLINE, move || {
        let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
        train(&per_object(), &dev, &objects(1), 60)
    });
    assert!(a.iter().all(|l| l.is_finite()));
    falls(&a);
}

#[test]
fn resumed_training_continues_exactly() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(2);
    let dev = BackendChoice::Flex.select().unwrap().device;
    let c = comps();
    let dir = tempfile::tempdir().unwrap();
    // The library's loop as `experiments` runs it: a first leg to step 3 that checkpoints (where
    // a kill would have stopped it), then on to step 6 in the same process.
    let leg = |steps: usize| schedule(steps, 3);
    let (first, whole) = (leg(3), leg(6));
    let run = |schedule| TrainRun {
        objects: &data,
        comps: &c,
        probe: &SPEC,
        schedule,
        uses_image: true,
        seed: 9,
    };
    let mut losses = Vec::new();
    let mut record = |_: &Trainer, s: &StepStats| losses.push(s.loss);
    let mut full = Trainer::new(&model(), &dev, 9);
    full.fit(&run(&first), Some(dir.path()), &mut record)
        .unwrap();
    full.fit(&run(&whole), None, &mut record).unwrap();
    let mut resumed = checkpoint::load(&model(), &dev, dir.path()).unwrap();
    assert_eq!(resumed.step, 3);
    let mut rest = Vec::new();
    resumed
        .fit(&run(&whole), None, &mut |_: &Trainer, s: &StepStats| {
            rest.push(s.loss)
        })
        .unwrap();
    assert_eq!((losses.len(), rest.len()), (6, 3));
    for (a, b) in rest.iter().zip(&losses[3..]) {
        assert!(
            (a - b).abs() <= 1e-5 * b.abs().max(1.0),
            "resumed {rest:?} vs uninterrupted {:?}",
            &losses[3..]
        );
    }
}

#[test]
fn a_non_finite_loss_stops_training_with_a_clear_error() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let mut data = objects(1);
    for s in &mut std::sync::Arc::make_mut(&mut data[0].supervision).silhouettes {
        s.values_mut().iter_mut().for_each(|v| *v = f32::NAN);
    }
    let dev = BackendChoice::Flex.select().unwrap().device;
    let c = comps();
    let mut t = Trainer::new(&model(), &dev, 1);
    let err = t
        .step(prepare_step(&data, &c, &SPEC, 1, true, 1, 0), &c, 1e-3)
        .unwrap_err();
    assert!(matches!(err, TrainError::NonFinite { step: 1, .. }));
    assert!(err.to_string().contains("step 1"), "{err}");
    assert_eq!(t.step, 0, "no step was taken");
}

#[test]
fn compacted_batches_give_the_same_loss_as_full_ones() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(2);
    let c = comps();
    let probes: Vec<ObjectProbe> = data
        .iter()
        .enumerate()
        .map(|(i, o)| {
            ObjectProbe::sample(
                &o.supervision,
                &SPEC,
                c.ray_sampler.as_ref(),
                c.anchor_sampler.as_ref(),
                &mut step_rng(3, 0, i),
            )
        })
        .collect();
    let dev = BackendChoice::Flex.select().unwrap().device;
    let t = Trainer::new(&model(), &dev, 4);
    let image = |o: &ObjectViews| o.view(0).collect::<Vec<f32>>();
    let images: Vec<f32> = data.iter().flat_map(image).collect();
    let loss = |compact: bool| {
        let prepared = PreparedStep {
            batch: ProbeBatch::assemble(&probes, compact),
            images: Some((images.clone(), data[0].image_size)),
            probe_seconds: 0.0,
            step: 0,
        };
        let (_, sil, _) = probe_loss(t.model.as_ref(), &upload(&prepared, &c, &t.device), &c);
        (sil.into_scalar::<f32>(), prepared.batch)
    };
    let (full, full_batch) = loss(false);
    let (compact, compact_batch) = loss(true);
    assert_eq!(full_batch.anchors_per_object, SPEC.anchors);
    assert!(
        compact_batch.anchors_per_object < SPEC.anchors / 2,
        "at this density most anchors are on no ray: kept {}",
        compact_batch.anchors_per_object
    );
    assert_eq!(full_batch.pairs, compact_batch.pairs);
    assert_eq!(full_batch.views_per_object, SPEC.views);
    assert_eq!(full_batch.labels, compact_batch.labels);
    assert!(
        (full - compact).abs() <= 1e-6 * full.abs().max(1e-3),
        "{full} vs {compact}"
    );
}

/// Several regularizers: the loss is the silhouette term plus their sum, and none is the
/// silhouette term alone.
#[test]
fn the_loss_is_the_silhouette_term_plus_every_regularizer() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let data = objects(1);
    let dev = BackendChoice::Flex.select().unwrap().device;
    let sdf = SdfConfig {
        latent: 0,
        decoder: Some(DecoderConfig {
            hidden: vec![32, 32],
            frequencies: 0,
        }),
        sphere: 0.0,
        ..SdfConfig::default()
    };
    let t = Trainer::new(&sdf, &dev, 5);
    let mut rng = step_rng(5, 0, 1);
    let base = comps();
    let probe = ObjectProbe::sample(
        &data[0].supervision,
        &SPEC,
        base.ray_sampler.as_ref(),
        base.anchor_sampler.as_ref(),
        &mut rng,
    );
    let prepared = PreparedStep {
        batch: ProbeBatch::assemble(&[probe], true),
        images: None,
        probe_seconds: 0.0,
        step: 0,
    };
    let terms = |regularizers: Vec<Box<dyn Regularizer>>| {
        let c = Components {
            regularizers,
            ..comps()
        };
        let (total, sil, reg) = probe_loss(t.model.as_ref(), &upload(&prepared, &c, &t.device), &c);
        (
            total.into_scalar::<f32>(),
            sil.into_scalar::<f32>(),
            reg.map(|r| r.into_scalar::<f32>()),
        )
    };
    let eikonal = |weight: f32| -> Box<dyn Regularizer> {
        Box::new(Eikonal {
            weight,
            ..Eikonal::default()
        })
    };
    let (none_total, none_sil, none_reg) = terms(Vec::new());
    assert_eq!((none_total, none_reg), (none_sil, None));
    let (_, _, one) = terms(vec![eikonal(0.1)]);
    let (_, _, other) = terms(vec![eikonal(0.3)]);
    let (total, sil, both) = terms(vec![eikonal(0.1), eikonal(0.3)]);
    let (one, other, both) = (one.unwrap(), other.unwrap(), both.unwrap());
    assert!(
        one > 0.0,
        "the eikonal term of a fresh SDF is positive: {one}"
    );
    assert_eq!(sil, none_sil);
    assert!(
        (both - (one + other)).abs() <= 1e-5 * both,
        "{both} vs {one} + {other}"
    );
    assert!((total - (sil + both)).abs() <= 1e-5 * total, "{total}");
}
