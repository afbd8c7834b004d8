//! The paper's p-norm normal-consistency regularizer (§3.2, eq. 6–8).
//!
//! For every anchor `x_j` near the surface, the finite-difference normal `n(x_j)` should agree with
//! the normals of its six lattice neighbours `y_j^l = x_j ± Δd·e_axis`:
//!
//! ```text
//! L_geo = 1/N Σ_j W(φ(x_j)) · Σ_l W(φ(y_j^l)) ‖n(x_j) − n(y_j^l)‖_p^p / Σ_l W(φ(y_j^l))
//! W(v)  = 1[|v − 0.5| < ε]
//! n(q)  = g/|g|,  g_a = (φ(q + Δd·e_a) − φ(q − Δd·e_a)) / (2Δd)      (eq. 6, n = 1)
//! ```
//!
//! and the term added to the loss is `λ·L_geo` (eq. 8).
//!
//! # Rules this implementation fixes (the paper leaves them open)
//!
//! * **Normals** are `∇φ/|∇φ|` as in the paper. φ is an occupancy (1 inside), so they point
//!   *inwards* (for a ball, `n(q) = −q/|q|`); the sign does not change the loss.
//! * **Differences of the logit** (`differences = "logit"`, the default): `φ = sigmoid(ℓ)` is
//!   monotone in the logit `ℓ`, so `∇ℓ/|∇ℓ|` is the same normal as `∇φ/|∇φ|`, but the central
//!   differences of a trained, saturated φ (≈ 0 or 1 at `±Δd` once the field is sharper than
//!   Δd) are nearly constant and carry almost no gradient, while those of `ℓ` stay linear in the
//!   parameters. `differences = "occupancy"` takes them of φ, the paper's literal formula. `W`
//!   is always decided on φ. `η` below is in the units of the differenced function: φ per unit
//!   length, or logits per unit length (a surface has `|∇ℓ| ≫ 1`, so it is as negligible).
//! * **Which anchors**: every anchor the samplers drew for the step (`Regularizer::loss` gets
//!   them all, not only those some ray meets): the inside of a silhouette, which no ray can
//!   constrain, is exactly where the prior is needed. The gate needs φ there: one forward pass
//!   over the step's anchors, detached (no backward).
//! * **ε** (the width of `W`) defaults to **0.25**: `W` passes `φ ∈ (0.25, 0.75)`, logits within
//!   `±ln 3 ≈ ±1.1`. The paper does not state ε. A narrow band (0.1 → logits within ±0.41) leaves
//!   few anchors once the field has sharpened, and its neighbours across the band (`Δd = 0.03`
//!   away) fail `W`, so the term would mostly vanish; 0.25 still only looks at near-surface level
//!   sets while keeping enough anchors per step for a stable estimate.
//! * **Normalizer**: `1/N` over **all** anchors of the batch (`B·N`), as in eq. 7 — not over the
//!   anchors that pass `W`. The term therefore also shrinks when fewer anchors lie near the surface.
//!   A batch mixes objects with the same `N` each, so this is also the mean of the per-object terms.
//! * **No passing neighbour** (`Σ_l W(y) = 0`): that anchor's term is 0 (the denominator is clamped
//!   to 1; the numerator is 0).
//! * **Nothing passes**: if no anchor of the batch passes `W` (or `weight = 0`), [`loss`] returns
//!   `None` and nothing is evaluated.
//! * **`p < 1`**: `|v|^p` has an infinite derivative at `v = 0`, so each component uses
//!   `(v² + s²)^{p/2} − s^p` with `s =` [`PNORM_SMOOTHING`] `= 1e-5` (exactly 0 at `v = 0`,
//!   within `(s/|v|)^p` of `|v|^p` relatively — about 1 % at `|v| = 3·10⁻³` for `p = 0.8`, while
//!   Δd = 0.03 on a radius-0.3 surface gives `|v| ≈ 0.1` — and, for `p < 1`, a derivative bounded
//!   by `p·s^{p−1}` (≈ 8 at `p = 0.8`)). It also hides f32 noise in the normals (≈10⁻⁶). The
//!   smoothing is used for every `p` (for `p ≥ 1` its effect is below `s^p`).
//! * **Normalization**: `n = g / sqrt(|g|² + η²)` with `η =` [`GRADIENT_EPS`] `= 1e-3` (φ per unit
//!   length; a surface has `|∇φ| ≳ 1`), so flat spots give a finite normal and a bounded gradient.
//! * **`W` has no gradient** (an indicator): it is decided on detached values — the anchors on the
//!   host (one device→host read of `[B, N]` floats per step), the neighbours on the device. The
//!   gradient flows through the normals only, to the model's parameters.
//! * **Gate subset**: with a cap (below), the gate reads φ at `4·max(1, max_anchors / B)` of each
//!   object's anchors, evenly spaced in their sampled order (the samplers draw in random order, so
//!   this is a uniform random subset), instead of all `N`: the term is a mean over anchors, so a
//!   uniform subset estimates it without bias, and the gate pass (forward only, over `B·N`
//!   points) no longer costs as much as the silhouette step. Without a cap the gate reads all.
//! * **Anchor cap** (`max_anchors`, default 2048, 0 = no cap): the stencils of at most
//!   `max(1, max_anchors / B)` passing anchors per object are evaluated, chosen evenly spaced over
//!   that object's passing anchors in their sampled order (the samplers draw them in random order,
//!   so this is a deterministic random subset, needing no RNG). Each kept anchor of object `b`
//!   stands for `P_b/M_b` anchors (`P_b` passing, `M_b` kept), so the capped term is an unbiased
//!   estimate of the uncapped one. Objects are padded to the same count with weight-0 slots, so the
//!   cost is that of `B·max_b M_b ≤ max(B, max_anchors)` anchors.
//!
//! # Cost
//!
//! An anchor needs φ at 25 lattice points `x + Δd·o` (itself; its normal: `±e_a`; its neighbours:
//! `±e_l`; their normals: `±e_l ± e_a`, i.e. `0`, `±2e_a` and the 12 `±e_l ± e_a`, `l ≠ a`), all
//! through **one** field evaluation of shape `[B, 25·M, 3]`, plus the detached gate pass over
//! the step's `B·N` anchors. So 2048 stencils cost about as much as decoding 51 k points forward
//! and backward: on a 2-core
//! CPU (flex, decoder `[256, 256, 128]`, F = 5) 0.6–1.1 s, 5–8× a `fit-one`-sized silhouette step
//! (8192 anchors), while 49 k points are ≈ 0.4× the paper's 8 × 16000 anchors. Lower
//! `max_anchors` for small per-object fits; the capped term stays unbiased.
//!
//! **Evaluated every k steps** (`every = k`, default 1): the term is computed at steps
//! `0, k, 2k, …` only, with weight `k·λ`, and is absent from the other steps. Over any `k`
//! consecutive steps its gradient sums to `k` times the every-step gradient at (nearly) the same
//! parameters, so Adam sees the same expected prior at `1/k` of its cost; what changes is the
//! step-to-step variance (one large push every k steps instead of k small ones). The finite
//! differences, Δd and the gate are unchanged. `experiments bench` reports the regularizer's
//! share of a step, to choose k.
//!
//! [`loss`]: Regularizer::loss

use burn::prelude::*;
use fieldprobe_core::register_component;
use fieldprobe_core::regularize::{FieldQuery, Regularizer, RegularizerConfig};
use serde::{Deserialize, Serialize};

/// `s` of the smoothed p-norm `Σ_a (v_a² + s²)^{p/2} − s^p`.
pub const PNORM_SMOOTHING: f32 = 1e-5;

/// `η` of the normalization `n = g / sqrt(|g|² + η²)`.
pub const GRADIENT_EPS: f32 = 1e-3;

/// What the finite differences are taken of (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Differences {
    /// The logit of φ: the same normals, with a gradient where φ saturates.
    #[default]
    Logit,
    /// φ itself, the paper's literal formula.
    Occupancy,
}

impl Differences {
    /// φ from values of the differenced function.
    fn phi(self, level: Tensor<3>) -> Tensor<3> {
        match self {
            Differences::Logit => burn::tensor::activation::sigmoid(level),
            Differences::Occupancy => level,
        }
    }

    /// φ from one value of the differenced function (host side).
    pub fn phi_of(self, level: f64) -> f64 {
        match self {
            Differences::Logit => 1.0 / (1.0 + (-level).exp()),
            Differences::Occupancy => level,
        }
    }
}

/// The p-norm normal-consistency regularizer (config and runtime).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormalConsistency {
    /// λ, the factor of the term in the total loss (paper: 1e-2).
    #[serde(default = "NormalConsistency::default_weight")]
    pub weight: f32,
    /// The norm's p (paper: 0.8; its ablation also uses 1 and 2).
    #[serde(default = "NormalConsistency::default_p")]
    pub p: f32,
    /// Δd, the finite-difference step and the distance to the neighbours (paper: 0.03).
    #[serde(default = "NormalConsistency::default_delta")]
    pub delta: f32,
    /// ε of `W(v) = 1[|v − 0.5| < ε]` (not given in the paper; see the module docs).
    #[serde(default = "NormalConsistency::default_epsilon")]
    pub epsilon: f32,
    /// At most this many passing anchors per step (split evenly over the objects) have their
    /// stencils evaluated; 0 = all.
    #[serde(default = "NormalConsistency::default_max_anchors")]
    pub max_anchors: usize,
    /// `logit` (default) or `occupancy`: what the finite differences are taken of.
    #[serde(default)]
    pub differences: Differences,
    /// Evaluate the term at every `every`-th step only (steps `0, k, 2k, …`), with its weight
    /// multiplied by `k` (default 1: every step). See "Evaluated every k steps" in the module docs.
    #[serde(default = "NormalConsistency::default_every")]
    pub every: usize,
}

impl NormalConsistency {
    fn default_weight() -> f32 {
        1e-2
    }
    fn default_p() -> f32 {
        0.8
    }
    fn default_delta() -> f32 {
        0.03
    }
    fn default_epsilon() -> f32 {
        0.25
    }
    fn default_max_anchors() -> usize {
        2048
    }
    fn default_every() -> usize {
        1
    }

    /// Checks the ranges; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        crate::common::check_weight(self.weight)?;
        if !(self.p > 0.0 && self.p.is_finite()) {
            return Err(format!("p must be positive, got {}", self.p));
        }
        if !(self.delta > 0.0 && self.delta.is_finite()) {
            return Err(format!("delta must be positive, got {}", self.delta));
        }
        if !(self.epsilon > 0.0 && self.epsilon <= 0.5) {
            return Err(format!("epsilon must be in (0, 0.5], got {}", self.epsilon));
        }
        if self.every == 0 {
            return Err("every must be at least 1 (1 = every step)".into());
        }
        Ok(())
    }

    /// How many of an object's `n` sampled anchors the gate reads φ at, in a batch of `b`
    /// objects: all without a cap, else `4·max(1, max_anchors / b)` (see the module docs).
    pub fn gated_per_object(&self, b: usize, n: usize) -> usize {
        if self.max_anchors == 0 {
            n
        } else {
            n.min(4 * (self.max_anchors / b.max(1)).max(1))
        }
    }

    /// The configuration that acts at 0-based step `step`: `None` between evaluations, else this
    /// one with its weight multiplied by `every` (so that the term's sum over any `every`
    /// consecutive steps is `every ×` the term once: the same expected total as every step).
    pub fn at_step(&self, step: usize) -> Option<Self> {
        let every = self.every.max(1);
        step.is_multiple_of(every).then_some(Self {
            weight: self.weight * every as f32,
            every: 1,
            ..*self
        })
    }

    /// `W(v)`.
    pub fn passes(&self, v: f32) -> bool {
        (v - 0.5).abs() < self.epsilon
    }

    /// The term for anchors `[B, N, 3]` under any evaluator of the differenced function (`[B, M,
    /// 3]` → `[B, M]`, object `b` of the points evaluated with object `b`'s field; logits or φ
    /// according to [`differences`](Self::differences)): [`Regularizer::loss`] with
    /// `level = |p| field.logits(p)`. Analytic fields can be passed directly.
    pub fn loss_with<F>(&self, level: F, anchors: &Tensor<3>) -> Option<Tensor<1>>
    where
        F: Fn(Tensor<3>) -> Tensor<2>,
    {
        if self.weight == 0.0 {
            return None;
        }
        let [b, all, _] = anchors.dims();
        let n = self.gated_per_object(b, all);
        let anchors = &crate::common::strided_subset(anchors, n);
        let gate = self
            .differences
            .phi(level(anchors.clone()).detach().unsqueeze_dim::<3>(2));
        let host: Vec<f32> = gate.try_into_vec_as::<f32>().expect("f32 field values");
        let sel = select_anchors(&host, b, n, self.epsilon, self.max_anchors)?;
        let device = anchors.device();
        let m = sel.per_object;
        let index = Tensor::<1, Int>::from_data(TensorData::new(sel.index, [b * m]), &device);
        let centres = anchors
            .clone()
            .reshape([b * n, 3])
            .select(0, index)
            .reshape([b, m, 3]);
        let stencil = eval_stencil(&level, centres, self.delta, self.differences);
        let terms = anchor_terms(&stencil, self.p, self.epsilon);
        let weights = Tensor::<2>::from_data(TensorData::new(sel.weight, [b, m]), &device);
        Some((terms * weights).sum().mul_scalar(self.weight))
    }
}

impl Default for NormalConsistency {
    fn default() -> Self {
        Self {
            weight: Self::default_weight(),
            p: Self::default_p(),
            delta: Self::default_delta(),
            epsilon: Self::default_epsilon(),
            max_anchors: Self::default_max_anchors(),
            differences: Differences::default(),
            every: Self::default_every(),
        }
    }
}

impl Regularizer for NormalConsistency {
    fn loss(&self, field: &FieldQuery<'_>, anchors: &Tensor<3>) -> Option<Tensor<1>> {
        let this = self.at_step(field.step)?;
        match self.differences {
            Differences::Logit => this.loss_with(|p| field.logits(p), anchors),
            Differences::Occupancy => this.loss_with(|p| field.eval(p), anchors),
        }
    }
}

#[typetag::serde(name = "normal_consistency")]
impl RegularizerConfig for NormalConsistency {
    fn build(&self) -> Result<Box<dyn Regularizer>, String> {
        self.validate()?;
        Ok(Box::new(*self))
    }
}

register_component!(
    Regularizer,
    "normal_consistency",
    "the paper's p-norm normal consistency of near-surface anchors and their 6 neighbours (eq. 7)",
    "type = \"normal_consistency\"\nweight = 0.01\np = 0.8\ndelta = 0.03\nepsilon = 0.25\nmax_anchors = 2048\ndifferences = \"logit\"\nevery = 1"
);

/// The anchors whose stencils are evaluated: `per_object` slots per object.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Selection {
    /// Slots per object (`M`).
    pub per_object: usize,
    /// `[B·M]` indices into the flat `[B·N]` anchors; padding repeats a real index of the batch.
    pub index: Vec<i32>,
    /// `[B·M]` the weight of each slot: `(P_b/M_b) / (B·N)` for kept anchors, 0 for padding.
    pub weight: Vec<f32>,
}

/// Picks the anchors that pass `W` (at most `max(1, cap / B)` per object, evenly spaced; `cap = 0`
/// keeps all); `None` if none passes.
pub(crate) fn select_anchors(
    phi: &[f32],
    b: usize,
    n: usize,
    epsilon: f32,
    cap: usize,
) -> Option<Selection> {
    assert_eq!(phi.len(), b * n, "phi is [B, N]");
    let quota = if cap == 0 {
        usize::MAX
    } else {
        (cap / b.max(1)).max(1)
    };
    let kept: Vec<(Vec<usize>, usize)> = (0..b)
        .map(|o| {
            let passing: Vec<usize> = (0..n)
                .filter(|&i| (phi[o * n + i] - 0.5).abs() < epsilon)
                .map(|i| o * n + i)
                .collect();
            let p = passing.len();
            let kept = if p <= quota {
                passing
            } else {
                (0..quota).map(|i| passing[i * p / quota]).collect()
            };
            (kept, p)
        })
        .collect();
    let m = kept.iter().map(|(k, _)| k.len()).max().unwrap_or(0);
    let pad = kept.iter().find_map(|(k, _)| k.first().copied())?;
    let total = (b * n) as f32;
    let mut index = Vec::with_capacity(b * m);
    let mut weight = Vec::with_capacity(b * m);
    for (k, p) in &kept {
        let w = if k.is_empty() {
            0.0
        } else {
            *p as f32 / k.len() as f32 / total
        };
        for s in 0..m {
            match k.get(s) {
                Some(&i) => {
                    index.push(i as i32);
                    weight.push(w);
                }
                None => {
                    index.push(pad as i32);
                    weight.push(0.0);
                }
            }
        }
    }
    Some(Selection {
        per_object: m,
        index,
        weight,
    })
}

/// The lattice of one anchor's stencil, in units of Δd.
struct Lattice {
    /// The offsets evaluated by the field, the centre first: column `c` of the values.
    offsets: Vec<[i32; 3]>,
    /// `[7·3]` for each normal point (the anchor, then `+x, −x, +y, −y, +z, −z`) and axis: the
    /// value columns of `q + e_a` and `q − e_a` (column 0 is the centre).
    plus: Vec<i32>,
    minus: Vec<i32>,
    /// `[6]` the value columns of the neighbours.
    neighbours: Vec<i32>,
}

fn unit(axis: usize, sign: i32) -> [i32; 3] {
    let mut o = [0; 3];
    o[axis] = sign;
    o
}

fn add(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The anchor and its neighbours in the order of [`Lattice`]: `0, +x, −x, +y, −y, +z, −z`.
fn normal_points() -> Vec<[i32; 3]> {
    std::iter::once([0; 3])
        .chain((0..3).flat_map(|a| [unit(a, 1), unit(a, -1)]))
        .collect()
}

fn lattice() -> Lattice {
    let mut columns = vec![[0; 3]];
    let mut column = |o: [i32; 3]| -> i32 {
        let c = match columns.iter().position(|&x| x == o) {
            Some(c) => c,
            None => {
                columns.push(o);
                columns.len() - 1
            }
        };
        c as i32
    };
    let points = normal_points();
    let (mut plus, mut minus) = (Vec::new(), Vec::new());
    for &q in &points {
        for a in 0..3 {
            plus.push(column(add(q, unit(a, 1))));
            minus.push(column(add(q, unit(a, -1))));
        }
    }
    let neighbours = points[1..].iter().map(|&q| column(q)).collect();
    Lattice {
        offsets: columns,
        plus,
        minus,
        neighbours,
    }
}

/// φ and normals on the stencils of `M` points per object.
pub(crate) struct Stencil {
    /// `[B, M, 7, 3]` normals at each point (index 0) and its 6 neighbours (`+x, −x, …, −z`).
    pub normals: Tensor<4>,
    /// `[B, M, 6]` φ at the neighbours.
    pub neighbour_phi: Tensor<3>,
}

/// Evaluates the stencils of `centres` `[B, M, 3]` in one call of `level` (the differenced
/// function; φ is `differences.phi` of it).
pub(crate) fn eval_stencil<F>(
    level: &F,
    centres: Tensor<3>,
    delta: f32,
    differences: Differences,
) -> Stencil
where
    F: Fn(Tensor<3>) -> Tensor<2>,
{
    let [b, m, _] = centres.dims();
    let device = centres.device();
    let lat = lattice();
    let k = lat.offsets.len();
    let offsets: Vec<f32> = lat
        .offsets
        .iter()
        .flat_map(|o| o.map(|c| c as f32 * delta))
        .collect();
    let offsets = Tensor::<4>::from_data(TensorData::new(offsets, [1, 1, k, 3]), &device);
    let points: Tensor<4> = centres.unsqueeze_dim::<4>(2) + offsets;
    let values = level(points.reshape([b, m * k, 3])).reshape([b, m, k]);
    let columns =
        |c: &[i32]| Tensor::<1, Int>::from_data(TensorData::new(c.to_vec(), [c.len()]), &device);
    let plus = values.clone().select(2, columns(&lat.plus));
    let minus = values.clone().select(2, columns(&lat.minus));
    let g: Tensor<4> = (plus - minus).div_scalar(2.0 * delta).reshape([b, m, 7, 3]);
    let norm = g
        .clone()
        .powi_scalar(2)
        .sum_dim(3)
        .add_scalar(GRADIENT_EPS * GRADIENT_EPS)
        .sqrt();
    Stencil {
        normals: g / norm,
        neighbour_phi: differences.phi(values.select(2, columns(&lat.neighbours))),
    }
}

/// `[B, M]` the bracket of eq. 7 for each point (its own `W` is the caller's business).
pub(crate) fn anchor_terms(stencil: &Stencil, p: f32, epsilon: f32) -> Tensor<2> {
    let [b, m, _, _] = stencil.normals.dims();
    let own = stencil.normals.clone().narrow(2, 0, 1);
    let others = stencil.normals.clone().narrow(2, 1, 6);
    let s = PNORM_SMOOTHING;
    let dist: Tensor<3> = (others - own)
        .powi_scalar(2)
        .add_scalar(s * s)
        .powf_scalar(p / 2.0)
        .sub_scalar(s.powf(p))
        .sum_dim(3)
        .reshape([b, m, 6]);
    let w = stencil
        .neighbour_phi
        .clone()
        .detach()
        .sub_scalar(0.5)
        .abs()
        .lower_elem(epsilon)
        .float();
    let num = (w.clone() * dist).sum_dim(2);
    let den = w.sum_dim(2).clamp_min(1.0);
    (num / den).reshape([b, m])
}

/// A plain f64 implementation of `λ·L_geo` for one object (no cap: every anchor counts), the
/// reference the tensor implementation is tested against. `level` is the differenced function
/// (logits or φ, per `config.differences`); `1/N` is `1/anchors.len()`. A batch's term is the
/// mean of its objects' terms.
pub fn reference_loss(
    config: &NormalConsistency,
    level: impl Fn([f64; 3]) -> f64,
    anchors: &[[f64; 3]],
) -> f64 {
    let f = &level;
    let d = config.delta as f64;
    let eps = config.epsilon as f64;
    let p = config.p as f64;
    let s = PNORM_SMOOTHING as f64;
    let eta = GRADIENT_EPS as f64;
    let w = |v: f64| (config.differences.phi_of(v) - 0.5).abs() < eps;
    let at = |x: [f64; 3], o: [i32; 3]| {
        [
            x[0] + d * o[0] as f64,
            x[1] + d * o[1] as f64,
            x[2] + d * o[2] as f64,
        ]
    };
    let normal = |q: [f64; 3]| {
        let g: [f64; 3] =
            std::array::from_fn(|a| (f(at(q, unit(a, 1))) - f(at(q, unit(a, -1)))) / (2.0 * d));
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2] + eta * eta).sqrt();
        g.map(|c| c / len)
    };
    let mut sum = 0.0;
    for &x in anchors {
        if !w(f(x)) {
            continue;
        }
        let nx = normal(x);
        let (mut num, mut den) = (0.0, 0.0);
        for o in &normal_points()[1..] {
            let y = at(x, *o);
            if !w(f(y)) {
                continue;
            }
            let ny = normal(y);
            num += (0..3)
                .map(|a| ((nx[a] - ny[a]).powi(2) + s * s).powf(p / 2.0) - s.powf(p))
                .sum::<f64>();
            den += 1.0;
        }
        if den > 0.0 {
            sum += num / den;
        }
    }
    config.weight as f64 * sum / anchors.len() as f64
}

#[cfg(test)]
mod tests;
