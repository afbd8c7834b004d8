use std::sync::Mutex;
use std::time::Instant;

use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::Gradients;
use burn::tensor::activation::sigmoid;
use fieldprobe_core::field::{Field, FieldModelConfig};
use fieldprobe_core::probe::{Aggregator, MaxPool};
use fieldprobe_models::{DecoderConfig, EncoderConfig, PerObjectConfig, SingleViewConfig};

use super::*;

/// burn's flex RNG is process-wide: tests that initialize models must not interleave.
static SEEDED: Mutex<()> = Mutex::new(());

type Vec3 = [f64; 3];

/// A deterministic uniform sequence in `[lo, hi)`.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn point(&mut self, e: f64) -> Vec3 {
        [self.next(-e, e), self.next(-e, e), self.next(-e, e)]
    }
}

fn unit_vec(v: Vec3) -> Vec3 {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / l)
}

/// Generic directions: no component near 0 (so every normal component changes at first order).
const DIRECTIONS: [Vec3; 8] = [
    [1.0, 2.0, 3.0],
    [-2.0, 1.0, 1.5],
    [1.0, -1.3, 0.7],
    [-0.8, -1.1, 1.4],
    [1.6, 0.9, -1.2],
    [-1.0, 1.7, -0.6],
    [0.7, -0.9, -1.5],
    [-1.3, -0.8, -0.9],
];

/// Points at radius `r` in the generic directions.
fn on_sphere(r: f64) -> Vec<Vec3> {
    DIRECTIONS
        .iter()
        .map(|&d| unit_vec(d).map(|c| c * r))
        .collect()
}

/// `[B, N, 3]` from per-object point lists (equal lengths).
fn points(objects: &[Vec<Vec3>], device: &Device) -> Tensor<3> {
    let n = objects[0].len();
    let flat: Vec<f32> = objects
        .iter()
        .flat_map(|o| o.iter().flat_map(|p| p.map(|c| c as f32)))
        .collect();
    Tensor::<3>::from_data(TensorData::new(flat, [objects.len(), n, 3]), device)
}

fn scalar(t: Tensor<1>) -> f64 {
    t.into_scalar::<f32>() as f64
}

/// φ = sigmoid(k·(r − |p|)), a ball of radius r (tensor and f64 versions).
fn ball_t(k: f32, r: f32) -> impl Fn(Tensor<3>) -> Tensor<2> {
    move |q: Tensor<3>| {
        let d: Tensor<2> = q.powi_scalar(2).sum_dim(2).sqrt().squeeze_dim(2);
        sigmoid(d.neg().add_scalar(r).mul_scalar(k))
    }
}

fn ball_f(k: f64, r: f64) -> impl Fn(Vec3) -> f64 {
    move |q: Vec3| {
        let d = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        1.0 / (1.0 + (-k * (r - d)).exp())
    }
}

/// φ = 0.5 + a·(r² − |p|²): its central differences are exact, so its finite-difference normals
/// are exactly −p/|p| and the loss is the geometry's alone.
fn quadric_t(a: f32, r: f32) -> impl Fn(Tensor<3>) -> Tensor<2> {
    move |q: Tensor<3>| {
        let d2: Tensor<2> = q.powi_scalar(2).sum_dim(2).squeeze_dim(2);
        d2.neg().add_scalar(r * r).mul_scalar(a).add_scalar(0.5)
    }
}

fn quadric_f(a: f64, r: f64) -> impl Fn(Vec3) -> f64 {
    move |q: Vec3| 0.5 + a * (r * r - (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]))
}

/// φ = h(n·p − c) for a unit normal `n` (tensor version).
fn plane_t(n: Vec3, c: f32, h: impl Fn(Tensor<2>) -> Tensor<2>) -> impl Fn(Tensor<3>) -> Tensor<2> {
    let n = unit_vec(n).map(|c| c as f32);
    move |q: Tensor<3>| {
        let nn = Tensor::<3>::from_data(TensorData::new(n.to_vec(), [1, 1, 3]), &q.device());
        let s: Tensor<2> = (q * nn).sum_dim(2).squeeze_dim(2);
        h(s.sub_scalar(c))
    }
}

fn with(p: f32, delta: f32) -> NormalConsistency {
    NormalConsistency { p, delta, ..occ() }
}

/// The defaults with differences of φ itself: the analytic fields of these tests are occupancies.
fn occ() -> NormalConsistency {
    NormalConsistency {
        differences: Differences::Occupancy,
        ..Default::default()
    }
}

/// The tensor loss of an analytic field on one object's anchors.
fn tensor_loss<F: Fn(Tensor<3>) -> Tensor<2>>(
    cfg: &NormalConsistency,
    f: F,
    anchors: &[Vec<Vec3>],
) -> Option<f64> {
    let dev = Device::flex();
    let a = points(anchors, &dev);
    cfg.loss_with(f, &a).map(scalar)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-30)
}

#[test]
fn defaults_are_the_papers_and_validation_names_the_field() {
    let d = NormalConsistency::default();
    assert_eq!((d.weight, d.p, d.delta), (1e-2, 0.8, 0.03));
    assert_eq!((d.epsilon, d.max_anchors), (0.25, 2048));
    assert!(d.build().is_ok());
    let bad = |f: fn(&mut NormalConsistency), name: &str| {
        let mut c = d;
        f(&mut c);
        let e = c.build().unwrap_err();
        assert!(e.starts_with(&format!("{name} ")), "{name}: {e}");
    };
    bad(|c| c.p = 0.0, "p");
    bad(|c| c.p = f32::NAN, "p");
    bad(|c| c.delta = -0.01, "delta");
    bad(|c| c.epsilon = 0.0, "epsilon");
    bad(|c| c.epsilon = 0.51, "epsilon");
    bad(|c| c.weight = -1.0, "weight");
    bad(|c| c.weight = f32::INFINITY, "weight");
    let edge = NormalConsistency {
        epsilon: 0.5,
        weight: 0.0,
        max_anchors: 0,
        ..d
    };
    assert!(edge.build().is_ok());
}

#[test]
fn the_lattice_has_25_distinct_points_and_each_normal_its_own_pairs() {
    let lat = lattice();
    assert_eq!(lat.offsets.len(), 25);
    assert_eq!(lat.offsets[0], [0, 0, 0], "the centre is column 0");
    for (i, o) in lat.offsets.iter().enumerate() {
        assert!(!lat.offsets[i + 1..].contains(o), "duplicate {o:?}");
        // Every point is within 2 steps on at most two axes.
        assert!(o.iter().map(|c| c.abs()).sum::<i32>() <= 2, "{o:?}");
    }
    let col = |c: i32| lat.offsets[c as usize];
    let pts = normal_points();
    assert_eq!(pts.len(), 7);
    for (i, &q) in pts.iter().enumerate() {
        for a in 0..3 {
            assert_eq!(col(lat.plus[3 * i + a]), add(q, unit(a, 1)));
            assert_eq!(col(lat.minus[3 * i + a]), add(q, unit(a, -1)));
        }
    }
    for (l, &c) in lat.neighbours.iter().enumerate() {
        assert_eq!(col(c), pts[l + 1]);
    }
}

#[test]
fn selection_keeps_passing_anchors_evenly_and_weights_them_unbiasedly() {
    // Object 0: anchors 1, 3, 4, 5, 7, 9 pass (ε = 0.1); object 1: only anchor 2.
    let mut phi = vec![0.9f32; 20];
    for i in [1, 3, 4, 5, 7, 9] {
        phi[i] = 0.5 + 0.01 * i as f32;
    }
    phi[12] = 0.45;
    phi[0] = 0.6; // exactly on the edge: |0.6 − 0.5| = 0.1 (in f32 ≥ 0.1) fails
    let all = select_anchors(&phi, 2, 10, 0.1, 0).unwrap();
    assert_eq!(all.per_object, 6);
    assert_eq!(&all.index[..6], &[1, 3, 4, 5, 7, 9]);
    assert_eq!(all.index[6], 12);
    let w = 1.0 / 20.0;
    assert_eq!(&all.weight[..7], &[w; 7]);
    assert_eq!(&all.weight[7..], &[0.0; 5], "padding weighs nothing");
    // Cap 6 over 2 objects: 3 per object, evenly spaced, each standing for 6/3 anchors.
    let capped = select_anchors(&phi, 2, 10, 0.1, 6).unwrap();
    assert_eq!(capped.per_object, 3);
    assert_eq!(&capped.index[..3], &[1, 4, 7]);
    assert_eq!(&capped.weight[..3], &[2.0 * w; 3]);
    assert_eq!(capped.index[3], 12);
    assert_eq!(&capped.weight[3..], &[w, 0.0, 0.0]);
    // A cap below the batch size still keeps one per object.
    assert_eq!(select_anchors(&phi, 2, 10, 0.1, 1).unwrap().per_object, 1);
    assert_eq!(select_anchors(&[0.9; 20], 2, 10, 0.1, 0), None);
}

/// Angle between two directions, in radians.
fn angle(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (unit_vec(a), unit_vec(b));
    let c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let x = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt().atan2(c)
}

/// The largest angle between the stencil's normals (anchors and neighbours) and −q/|q|.
fn ball_normal_error(delta: f32) -> f64 {
    let dev = Device::flex();
    let f = ball_t(10.0, 0.3);
    let mut anchors = on_sphere(0.3);
    anchors.extend(on_sphere(0.27));
    let a = points(std::slice::from_ref(&anchors), &dev);
    let st = eval_stencil(&f, a, delta, Differences::Occupancy);
    let n: Vec<f32> = st.normals.try_into_vec_as::<f32>().unwrap();
    let mut worst = 0.0f64;
    for (j, x) in anchors.iter().enumerate() {
        for (l, o) in normal_points().iter().enumerate() {
            let q: Vec3 = std::array::from_fn(|a| x[a] + delta as f64 * o[a] as f64);
            let got: Vec3 = std::array::from_fn(|a| n[(j * 7 + l) * 3 + a] as f64);
            let len = got.iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!((len - 1.0).abs() < 1e-4, "unit normal, got |n| = {len}");
            worst = worst.max(angle(got, q.map(|c| -c)));
        }
    }
    worst
}

#[test]
fn ball_finite_difference_normals_match_the_analytic_ones() {
    let fine = ball_normal_error(1e-3);
    assert!(fine < 1e-3, "Δd = 1e-3: angle error {fine} rad");
    let errors: Vec<f64> = [0.1, 0.03, 0.01].map(ball_normal_error).to_vec();
    assert!(
        errors[0] > errors[1] && errors[1] > errors[2],
        "the error should shrink with Δd: {errors:?}"
    );
    // Central differences are second order: Δd / 3 → error / 9.
    assert!(
        errors[1] < errors[0] / 5.0 && errors[2] < errors[1] / 5.0,
        "{errors:?}"
    );
    assert!(errors[0] < 0.1, "{errors:?}");
}

#[test]
fn planes_have_consistent_normals() {
    let mut rng = Lcg(3);
    let anchors: Vec<Vec3> = (0..32).map(|_| rng.point(0.3)).collect();
    let n = [0.3, -0.5, 0.8];
    let objs = vec![anchors.clone()];
    // A linear ramp: central differences are exact, every normal is n.
    let ramp = plane_t(n, 0.05, |s| s.mul_scalar(0.7).add_scalar(0.5));
    let cfg = occ();
    // A curved surface for scale (≈ 2·10⁻³): "zero" below means f32 noise, far under it.
    let ball_loss = tensor_loss(&cfg, ball_t(10.0, 0.3), &[on_sphere(0.3)]).unwrap();
    let ramp_loss = tensor_loss(&cfg, ramp, &objs).unwrap();
    assert!(ramp_loss.abs() < 1e-4 * ball_loss, "ramp: {ramp_loss}");
    // A sigmoid plane along an axis: the gradient has one component, the normals are exact.
    let axis = plane_t([0.0, 1.0, 0.0], 0.05, |s| sigmoid(s.mul_scalar(20.0)));
    let axis_loss = tensor_loss(&cfg, axis, &objs).unwrap();
    assert!(
        axis_loss.abs() < 1e-4 * ball_loss,
        "axis-aligned sigmoid plane: {axis_loss}"
    );
    // An oblique sigmoid plane: only the finite-difference error of a curved profile remains,
    // far below what a curved surface gives.
    let oblique = plane_t(n, 0.0, |s| sigmoid(s.mul_scalar(10.0)));
    let plane_loss = tensor_loss(&cfg, oblique, &objs).unwrap();
    assert!(
        plane_loss < 0.01 * ball_loss,
        "oblique plane {plane_loss} vs ball {ball_loss}"
    );
}

#[test]
fn tensor_loss_matches_the_reference_on_analytic_fields() {
    let mut rng = Lcg(7);
    // Anchors at all distances from the ball's surface: some fail W, some have failing neighbours.
    let anchors: Vec<Vec3> = (0..48)
        .map(|i| {
            let d = unit_vec(rng.point(1.0));
            let r = 0.3 + 0.01 * (i as f64 / 3.0 - 8.0);
            d.map(|c| c * r)
        })
        .collect();
    let (k, r) = (30.0, 0.3);
    let objs = vec![anchors.clone()];
    let f = ball_f(k, r);
    let pass = anchors
        .iter()
        .filter(|&&x| (f(x) - 0.5).abs() < 0.25)
        .count();
    assert!(pass > 8 && pass < 40, "passing anchors: {pass}");
    for (p, delta) in [(0.8, 0.03), (2.0, 0.03), (1.0, 0.01), (0.5, 0.05)] {
        let cfg = with(p, delta);
        let want = reference_loss(&cfg, ball_f(k, r), &anchors);
        let got = tensor_loss(&cfg, ball_t(k as f32, r as f32), &objs).unwrap();
        assert!(
            rel(got, want) < 1e-4,
            "p = {p}, Δd = {delta}: tensor {got} vs reference {want}"
        );
    }
    // Some passing anchor has a failing neighbour at Δd = 0.05 (the case Σ W(y) < 6).
    let partial = anchors.iter().any(|&x| {
        (f(x) - 0.5).abs() < 0.25
            && normal_points()[1..].iter().any(|o| {
                let y: Vec3 = std::array::from_fn(|a| x[a] + 0.05 * o[a] as f64);
                (f(y) - 0.5).abs() >= 0.25
            })
    });
    assert!(partial);
}

/// Per-object φ through the model, one point at a time, for the reference.
fn model_fn<'a>(
    model: &'a dyn Field,
    latent: Option<Tensor<2>>,
    device: &'a Device,
) -> impl Fn(Vec3) -> f64 + 'a {
    model_level(model, latent, device, Differences::Occupancy)
}

/// The differenced function of a model at one point: φ or its logit.
fn model_level<'a>(
    model: &'a dyn Field,
    latent: Option<Tensor<2>>,
    device: &'a Device,
    differences: Differences,
) -> impl Fn(Vec3) -> f64 + 'a {
    move |q: Vec3| {
        let t = Tensor::<3>::from_data(
            TensorData::new(q.map(|c| c as f32).to_vec(), [1, 1, 3]),
            device,
        );
        let v = match differences {
            Differences::Logit => model.logits(latent.clone(), t),
            Differences::Occupancy => model.occupancy(latent.clone(), t),
        };
        v.into_scalar::<f32>() as f64
    }
}

/// An ε that splits the anchors of all objects roughly in half and stays clear of every value
/// the stencils see, so that f32 and f64 agree on W. Returns (ε, margin).
fn clear_epsilon(fs: &[&dyn Fn(Vec3) -> f64], anchors: &[Vec<Vec3>], delta: f64) -> (f32, f64) {
    let mut at_anchor = Vec::new();
    let mut all = Vec::new();
    for (f, objs) in fs.iter().zip(anchors) {
        for &x in objs {
            let d = (f(x) - 0.5).abs();
            at_anchor.push(d);
            all.push(d);
            for o in &normal_points()[1..] {
                let y: Vec3 = std::array::from_fn(|a| x[a] + delta * o[a] as f64);
                all.push((f(y) - 0.5).abs());
            }
        }
    }
    at_anchor.sort_by(f64::total_cmp);
    all.sort_by(f64::total_cmp);
    let (lo, hi) = (
        at_anchor[at_anchor.len() * 3 / 10],
        at_anchor[at_anchor.len() * 7 / 10],
    );
    let (mut best, mut margin) = (lo, 0.0);
    for w in all.windows(2) {
        if w[0] >= lo && w[1] <= hi && (w[1] - w[0]) / 2.0 > margin {
            margin = (w[1] - w[0]) / 2.0;
            best = (w[0] + w[1]) / 2.0;
        }
    }
    (best as f32, margin)
}

fn check_model(config: &dyn FieldModelConfig, latent_size: usize) {
    let dev = Device::flex();
    let model = {
        let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
        dev.seed(17);
        config.init(&dev)
    };
    let mut rng = Lcg(11);
    let (b, n) = (2, 40);
    let anchors: Vec<Vec<Vec3>> = (0..b)
        .map(|_| (0..n).map(|_| rng.point(0.45)).collect())
        .collect();
    let latent = (latent_size > 0).then(|| {
        let z: Vec<f32> = (0..b * latent_size)
            .map(|_| rng.next(-1.0, 1.0) as f32)
            .collect();
        Tensor::<2>::from_data(TensorData::new(z, [b, latent_size]), &dev)
    });
    let row = |o: usize| latent.clone().map(|z| z.narrow(0, o, 1));
    let fs: Vec<_> = (0..b)
        .map(|o| model_fn(model.as_ref(), row(o), &dev))
        .collect();
    let dyn_fs: Vec<&dyn Fn(Vec3) -> f64> = fs.iter().map(|f| f as &dyn Fn(Vec3) -> f64).collect();
    for delta in [0.03f32, 0.1] {
        let (epsilon, margin) = clear_epsilon(&dyn_fs, &anchors, delta as f64);
        assert!(margin > 2e-6, "no clear ε: margin {margin}");
        let a = points(&anchors, &dev);
        let field = FieldQuery {
            model: model.as_ref(),
            latent: latent.clone(),
            step: 0,
        };
        for (p, differences) in [
            (0.8f32, Differences::Occupancy),
            (2.0, Differences::Occupancy),
            (0.8, Differences::Logit),
            (2.0, Differences::Logit),
        ] {
            let cfg = NormalConsistency {
                p,
                delta,
                epsilon,
                max_anchors: 0,
                weight: 0.5,
                differences,
                every: 1,
            };
            let got = scalar(cfg.loss(&field, &a).expect("anchors pass"));
            let want = (0..b)
                .map(|o| {
                    let level = model_level(model.as_ref(), row(o), &dev, differences);
                    reference_loss(&cfg, level, &anchors[o])
                })
                .sum::<f64>()
                / b as f64;
            assert!(
                rel(got, want) < 1e-4,
                "p = {p}, Δd = {delta}, ε = {epsilon}, {differences:?}: tensor {got} vs reference {want}"
            );
        }
    }
}

#[test]
fn tensor_loss_matches_the_reference_on_a_per_object_field_model() {
    check_model(
        &PerObjectConfig {
            decoder: DecoderConfig {
                hidden: vec![32, 32],
                frequencies: 2,
            },
        },
        0,
    );
}

#[test]
fn tensor_loss_matches_the_reference_on_a_latent_conditioned_field_model() {
    // Each object's stencil must be decoded with its own latent.
    check_model(
        &SingleViewConfig {
            latent: 8,
            encoder: EncoderConfig {
                channels: vec![4],
                blocks: vec![1],
                in_channels: 4,
                ..EncoderConfig::default()
            },
            decoder: DecoderConfig {
                hidden: vec![32, 32],
                frequencies: 1,
            },
        },
        8,
    );
}

#[test]
fn the_loss_scales_as_the_normal_angle_to_the_p() {
    // On a ball, neighbours' normals differ by ≈ Δd/r in angle, so L ∝ (Δd/r)^p.
    let (a, r) = (1.0f32, 0.4f32);
    let objs = vec![on_sphere(r as f64)];
    for p in [2.0f32, 0.8] {
        let l = |d: f32| tensor_loss(&with(p, d), quadric_t(a, r), &objs).unwrap();
        let ratio = l(0.01) / l(0.03);
        let want = (1.0f64 / 3.0).powf(p as f64);
        assert!(
            rel(ratio, want) < 0.01,
            "p = {p}: L(0.01)/L(0.03) = {ratio}, (1/3)^p = {want}"
        );
        let reference = reference_loss(&with(p, 0.03), quadric_f(a as f64, r as f64), &objs[0]);
        assert!(rel(l(0.03), reference) < 1e-4);
    }
}

#[test]
fn a_smaller_p_weighs_small_normal_differences_more() {
    let objs = vec![on_sphere(0.4)];
    let losses: Vec<f64> = [0.5f32, 0.8, 1.0, 2.0]
        .iter()
        .map(|&p| tensor_loss(&with(p, 0.03), quadric_t(1.0, 0.4), &objs).unwrap())
        .collect();
    assert!(
        losses.windows(2).all(|w| w[0] > w[1]) && losses[3] > 0.0,
        "L should fall with p (components < 1): {losses:?}"
    );
}

#[test]
fn anchors_off_the_surface_contribute_nothing() {
    let cfg = occ();
    // |φ − 0.5| ≥ ε at every anchor: nothing is evaluated.
    let far: Vec<Vec3> = on_sphere(0.05).into_iter().chain(on_sphere(0.5)).collect();
    let phi = ball_f(30.0, 0.3);
    assert!(far.iter().all(|&x| (phi(x) - 0.5).abs() >= 0.25));
    assert_eq!(
        tensor_loss(&cfg, ball_t(30.0, 0.3), std::slice::from_ref(&far)),
        None
    );
    // Mixed in, they only dilute the mean (1/N over all anchors).
    let near = on_sphere(0.3);
    let alone = tensor_loss(&cfg, ball_t(30.0, 0.3), std::slice::from_ref(&near)).unwrap();
    let mixed: Vec<Vec3> = near.iter().chain(&far).copied().collect();
    let diluted = tensor_loss(&cfg, ball_t(30.0, 0.3), &[mixed]).unwrap();
    assert!(
        alone > 0.0 && rel(diluted, alone / 3.0) < 1e-5,
        "{alone} {diluted}"
    );
    // Passing anchors whose neighbours all fail W contribute 0 (a steep quadric).
    let steep = tensor_loss(&cfg, quadric_t(100.0, 0.4), &[on_sphere(0.4)]).unwrap();
    assert_eq!(steep, 0.0);
}

#[test]
fn the_weight_scales_the_term_linearly() {
    let objs = vec![on_sphere(0.3)];
    let l = |w: f32| {
        let cfg = NormalConsistency { weight: w, ..occ() };
        tensor_loss(&cfg, ball_t(10.0, 0.3), &objs)
    };
    let (a, b) = (l(0.01).unwrap(), l(0.05).unwrap());
    assert!(a > 0.0 && rel(b, 5.0 * a) < 1e-5, "{a} {b}");
    assert_eq!(l(0.0), None, "weight 0 evaluates nothing");
}

#[test]
fn the_capped_term_is_the_reweighted_subset() {
    let mut rng = Lcg(5);
    let (k, r) = (10.0, 0.3);
    let anchors: Vec<Vec<Vec3>> = (0..2)
        .map(|_| {
            (0..24)
                .map(|_| unit_vec(rng.point(1.0)).map(|c| c * rng.next(0.1, 0.5)))
                .collect()
        })
        .collect();
    let cfg = NormalConsistency {
        max_anchors: 6,
        ..occ()
    };
    let f = ball_f(k, r);
    let got = tensor_loss(&cfg, ball_t(k as f32, r as f32), &anchors).unwrap();
    let uncapped = tensor_loss(
        &NormalConsistency {
            max_anchors: 0,
            ..cfg
        },
        ball_t(k as f32, r as f32),
        &anchors,
    )
    .unwrap();
    // The gate reads 4·3 = 12 of each object's 24 anchors (every second one), keeps 3 evenly
    // spaced passing ones and weighs each by (passing / kept) / (B · 12).
    assert_eq!(cfg.gated_per_object(2, 24), 12);
    let mut want = 0.0;
    for (o, objs) in anchors.iter().enumerate() {
        let passing: Vec<Vec3> = objs
            .iter()
            .step_by(2)
            .copied()
            .filter(|&x| (f(x) - 0.5).abs() < 0.25)
            .collect();
        assert!(passing.len() > 3, "object {o}: {} pass", passing.len());
        let kept: Vec<Vec3> = (0..3).map(|i| passing[i * passing.len() / 3]).collect();
        want += reference_loss(&cfg, &f, &kept) * passing.len() as f64 / (2.0 * 12.0);
    }
    assert!(rel(got, want) < 1e-4, "capped {got} vs reference {want}");
    assert!(got != uncapped, "the cap should take a subset");
}

struct GradStats<'a> {
    grads: &'a Gradients,
    /// (elements, Σ|g|, all finite) per parameter.
    params: Vec<(usize, f64, bool)>,
}

impl ModuleVisitor for GradStats<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let g: Vec<f32> = param
            .val()
            .grad(self.grads)
            .map(|g| g.try_into_vec_as::<f32>().unwrap())
            .unwrap_or_default();
        self.params.push((
            g.len(),
            g.iter().map(|v| v.abs() as f64).sum(),
            g.iter().all(|v| v.is_finite()),
        ));
    }
}

/// A small per-object field (32-32, two frequencies) for tests that need any trainable field.
fn small_per_object() -> PerObjectConfig {
    PerObjectConfig {
        decoder: DecoderConfig {
            hidden: vec![32, 32],
            frequencies: 2,
        },
    }
}

#[test]
fn gradients_reach_every_parameter_and_are_finite() {
    let dev = Device::flex().autodiff();
    let config = small_per_object();
    let model = {
        let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
        dev.seed(3);
        // The concrete module, whose parameters the test visits.
        fieldprobe_models::PerObject {
            decoder: config.decoder.init(0, &dev),
        }
    };
    let mut rng = Lcg(2);
    let anchors: Vec<Vec3> = (0..256).map(|_| rng.point(0.45)).collect();
    let a = points(&[anchors], &dev);
    let field = FieldQuery {
        model: &model,
        latent: None,
        step: 0,
    };
    // ε = 0.5 lets every anchor pass (a fresh model is near 0.5 everywhere anyway).
    for (p, differences) in [(0.8f32, Differences::Logit), (2.0, Differences::Occupancy)] {
        let cfg = NormalConsistency {
            p,
            epsilon: 0.5,
            differences,
            ..Default::default()
        };
        let loss = cfg.loss(&field, &a).unwrap();
        let grads = loss.backward();
        let mut stats = GradStats {
            grads: &grads,
            params: Vec::new(),
        };
        model.visit(&mut stats);
        assert!(!stats.params.is_empty());
        for (i, &(len, sum, finite)) in stats.params.iter().enumerate() {
            assert!(len > 0, "p = {p}: parameter {i} has no gradient");
            assert!(finite, "p = {p}: parameter {i} has a non-finite gradient");
            assert!(sum > 0.0, "p = {p}: parameter {i} has a zero gradient");
        }
    }
}

/// Rough cost against a silhouette step: `cargo test --release --workspace cost_of_ -- --ignored
/// --nocapture`.
#[test]
#[ignore = "timing, prints numbers"]
fn cost_of_the_regularizer_against_a_silhouette_step() {
    let dev = Device::flex().autodiff();
    let config = PerObjectConfig {
        decoder: DecoderConfig {
            hidden: vec![256, 256, 128],
            frequencies: 5,
        },
    };
    let model = {
        let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
        dev.seed(1);
        config.init(&dev)
    };
    let mut rng = Lcg(9);
    // fit-one's probe: 8192 anchors, 24 views × 512 rays; 32 anchors per ray (synthetic indices).
    let (n, rays, width) = (8192usize, 24 * 512usize, 32usize);
    let anchors: Vec<Vec3> = (0..n).map(|_| rng.point(0.5)).collect();
    let index: Vec<i32> = (0..rays * width)
        .map(|_| rng.next(0.0, n as f64) as i32)
        .collect();
    let labels: Vec<f32> = (0..rays)
        .map(|_| rng.next(0.0, 1.0).round() as f32)
        .collect();
    let a = points(&[anchors], &dev);
    let field = FieldQuery {
        model: model.as_ref(),
        latent: None,
        step: 0,
    };
    let silhouette_step = || {
        let phi = field.eval(a.clone());
        let idx = Tensor::<1, Int>::from_data(TensorData::new(index.clone(), [rays * width]), &dev);
        let values: Tensor<2> = phi.reshape([n]).select(0, idx).reshape([rays, width]);
        let valid = Tensor::<2, Bool>::from_data(
            TensorData::new(vec![true; rays * width], [rays, width]),
            &dev,
        );
        let pred = MaxPool {}.aggregate(fieldprobe_core::probe::RayValues::new(values, valid));
        let y = Tensor::<1>::from_data(TensorData::new(labels.clone(), [rays]), &dev);
        let loss = (pred - y).powi_scalar(2).mean();
        let _ = loss.backward();
        let _ = dev.sync();
    };
    let cfg = NormalConsistency {
        epsilon: 0.5,
        ..Default::default()
    };
    let regularizer_step = || {
        let loss = cfg.loss(&field, &a).unwrap();
        let _ = loss.backward();
        let _ = dev.sync();
    };
    let time = |f: &dyn Fn()| {
        f();
        let t = Instant::now();
        for _ in 0..3 {
            f();
        }
        t.elapsed().as_secs_f64() / 3.0
    };
    let sil = time(&silhouette_step);
    let reg = time(&regularizer_step)
        - time(&|| {
            let _ = field.eval(a.clone()).sum().backward();
            let _ = dev.sync();
        });
    println!(
        "flex, decoder [256, 256, 128] F=5: silhouette step (8192 anchors, {rays} rays × {width}) \
         {sil:.3} s forward+backward; normal consistency with 2048 anchors (24 extra points each) \
         {reg:.3} s forward+backward ({:.1}× the silhouette step)",
        reg / sil
    );
}

/// `every = k`: the term acts at steps `0, k, 2k, …` only, with `k ×` the weight, so over any k
/// consecutive steps it sums to k times the plain term (the same field and anchors).
#[test]
fn a_term_every_k_steps_sums_to_the_plain_term_over_k_steps() {
    let dev = Device::flex();
    let config = small_per_object();
    let model = {
        let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
        dev.seed(5);
        config.init(&dev)
    };
    let mut rng = Lcg(4);
    let anchors: Vec<Vec3> = (0..300).map(|_| rng.point(0.45)).collect();
    let a = points(&[anchors], &dev);
    let plain = NormalConsistency {
        epsilon: 0.5,
        ..Default::default()
    };
    let at = |cfg: &NormalConsistency, step: usize| {
        let field = FieldQuery {
            model: model.as_ref(),
            latent: None,
            step,
        };
        cfg.loss(&field, &a).map(scalar)
    };
    let once = at(&plain, 7).expect("every anchor passes");
    for k in [2usize, 3, 5] {
        let sparse = NormalConsistency { every: k, ..plain };
        let mut sum = 0.0;
        for step in 0..3 * k {
            let term = at(&sparse, step);
            assert_eq!(
                term.is_some(),
                step.is_multiple_of(k),
                "k = {k}, step {step}"
            );
            sum += term.unwrap_or(0.0);
        }
        let expected = 3.0 * k as f64 * once;
        assert!(
            (sum - expected).abs() <= 1e-5 * expected.abs(),
            "k = {k}: {sum} vs {expected}"
        );
    }
    assert!(NormalConsistency { every: 0, ..plain }.validate().is_err());
}
