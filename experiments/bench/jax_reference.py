"""The JAX/XLA reference step that issue 14 compares `experiments bench experiments/bench/step.toml`
against: the same sizes written the way a JAX user would write them, jit-compiled on the CPU.

    pip install jax            # CPU wheels; not needed by FieldProbe itself
    python3 experiments/bench/jax_reference.py --steps 20

- Decoder: the per-object MLP of step.toml, on a Fourier encoding of the point (3 + 6·5 inputs),
  with hidden widths 256-256-128, ReLU and a logit output.
- Probing: 2048 uniform anchors and 2048 rays (256 × 8 views). The assignment tests all pairs in
  chunks: a point-to-ray distance below τ = 0.03. Each ray's value is the masked max of φ over its
  anchors, and the loss is L2 against the labels.
- Regularizer: the paper's p-norm normal consistency (p = 0.8, Δd = 0.03, λ = 1e-2, W with
  ε = 0.1) on every anchor. Differences are taken of the logit. `--stencil 25` evaluates the
  deduplicated 25-point lattice FieldProbe uses. `--stencil 49` evaluates each of the 7 normals
  from its own 6 points, plus φ at the 7 points: how a vmap over a `normal(q)` function comes out.
- Adam with lr = 1e-3.

Rays and labels are synthetic: cameras on the NMR sphere (distance 2.732) looking at the origin,
pixels uniform on a 30° field of view, and labels from a ball of radius 0.3. The cost depends on
the sizes only, not on which pixels are drawn.

The script prints the median step time with and without the regularizer.
"""

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

HIDDEN = [256, 256, 128]
FREQS = 5
ANCHORS = 2048
RAYS = 256 * 8
TAU = 0.03
P, DELTA, LAM, EPS = 0.8, 0.03, 1e-2, 0.1
S_SMOOTH, ETA = 1e-5, 1e-3
CHUNK = 512


def init(key):
    dims = [3 + 6 * FREQS] + HIDDEN + [1]
    params = []
    for a, b in zip(dims[:-1], dims[1:]):
        key, k = jax.random.split(key)
        params.append((jax.random.normal(k, (a, b)) * np.sqrt(2.0 / a), jnp.zeros(b)))
    return params


def encode(p):
    parts = [p]
    for k in range(FREQS):
        s = p * (np.pi * 2**k)
        parts += [jnp.sin(s), jnp.cos(s)]
    return jnp.concatenate(parts, -1)


def logits(params, p):
    x = encode(p)
    for w, b in params[:-1]:
        x = jax.nn.relu(x @ w + b)
    w, b = params[-1]
    return (x @ w + b)[..., 0]


def assign(anchors, origins, dirs):
    """[R, N] mask of anchors within τ of each ray, all pairs, in chunks of rays."""
    masks = []
    for c in range(0, RAYS, CHUNK):
        o, d = origins[c : c + CHUNK, None, :], dirs[c : c + CHUNK, None, :]
        v = anchors[None, :, :] - o
        t = jnp.sum(v * d, -1, keepdims=True)
        dist = jnp.linalg.norm(v - t * d, axis=-1)
        masks.append(dist < TAU)
    return jnp.concatenate(masks, 0)


def lattice(stencil):
    """Offsets (in Δd) and, for the 7 normal points × 3 axes, the columns of q ± e_a."""
    unit = [np.eye(3, dtype=int)[a] * s for a in range(3) for s in (1, -1)]
    points = [np.zeros(3, int)] + unit
    cols, plus, minus = [], [], []

    def col(o):
        if stencil == 25:
            for i, c in enumerate(cols):
                if (c == o).all():
                    return i
        cols.append(o)
        return len(cols) - 1

    for q in points:
        col(q)
    for q in points:
        for a in range(3):
            plus.append(col(q + np.eye(3, dtype=int)[a]))
            minus.append(col(q - np.eye(3, dtype=int)[a]))
    return np.array(cols, np.float32), np.array(plus), np.array(minus)


def regularizer(params, anchors, stencil):
    offsets, plus, minus = lattice(stencil)
    pts = anchors[:, None, :] + DELTA * offsets[None]
    ell = logits(params, pts.reshape(-1, 3)).reshape(ANCHORS, -1)
    g = ((ell[:, plus] - ell[:, minus]) / (2 * DELTA)).reshape(ANCHORS, 7, 3)
    n = g / jnp.sqrt(jnp.sum(g * g, -1, keepdims=True) + ETA * ETA)
    phi = jax.lax.stop_gradient(jax.nn.sigmoid(ell[:, :7]))
    w = (jnp.abs(phi - 0.5) < EPS).astype(jnp.float32)
    d = jnp.sum((((n[:, 1:] - n[:, :1]) ** 2 + S_SMOOTH**2) ** (P / 2)) - S_SMOOTH**P, -1)
    term = jnp.sum(w[:, 1:] * d, -1) / jnp.maximum(jnp.sum(w[:, 1:], -1), 1.0)
    return LAM * jnp.sum(w[:, 0] * term) / ANCHORS


def make_step(with_reg, stencil):
    def loss(params, anchors, origins, dirs, labels):
        mask = assign(anchors, origins, dirs)
        phi = jax.nn.sigmoid(logits(params, anchors))
        pred = jnp.max(jnp.where(mask, phi[None, :], 0.0), axis=1)
        sil = jnp.mean((pred - labels) ** 2) * 8
        return sil + (regularizer(params, anchors, stencil) if with_reg else 0.0)

    @jax.jit
    def step(params, m, v, t, anchors, origins, dirs, labels):
        grads = jax.grad(loss)(params, anchors, origins, dirs, labels)
        b1, b2, lr = 0.9, 0.999, 1e-3
        m = jax.tree_util.tree_map(lambda m, g: b1 * m + (1 - b1) * g, m, grads)
        v = jax.tree_util.tree_map(lambda v, g: b2 * v + (1 - b2) * g * g, v, grads)
        mh = jax.tree_util.tree_map(lambda m: m / (1 - b1**t), m)
        vh = jax.tree_util.tree_map(lambda v: v / (1 - b2**t), v)
        params = jax.tree_util.tree_map(
            lambda p, a, b: p - lr * a / (jnp.sqrt(b) + 1e-8), params, mh, vh
        )
        return params, m, v

    return step


def batch(rng):
    anchors = rng.uniform(-0.5, 0.5, (ANCHORS, 3)).astype(np.float32)
    views = rng.uniform(0, 2 * np.pi, RAYS)
    origins = np.stack([2.732 * np.sin(views), 0.5 * np.ones(RAYS), 2.732 * np.cos(views)], 1)
    fov = np.tan(np.radians(15))
    target = rng.uniform(-fov, fov, (RAYS, 3)) * 2.732
    dirs = target - origins
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t = -np.sum(origins * dirs, 1, keepdims=True)
    labels = (np.linalg.norm(origins + t * dirs, axis=1) < 0.3).astype(np.float32)
    return [jnp.asarray(x, jnp.float32) for x in (anchors, origins, dirs, labels)]


def median_step(with_reg, stencil, steps, warmup):
    rng = np.random.default_rng(0)
    params = init(jax.random.PRNGKey(0))
    m = jax.tree_util.tree_map(jnp.zeros_like, params)
    v = jax.tree_util.tree_map(jnp.zeros_like, params)
    step = make_step(with_reg, stencil)
    times = []
    for i in range(warmup + steps):
        data = batch(rng)
        t0 = time.perf_counter()
        params, m, v = step(params, m, v, float(i + 1), *data)
        jax.block_until_ready(params)
        if i >= warmup:
            times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--stencil", type=int, choices=[25, 49], default=49)
    a = ap.parse_args()
    without = median_step(False, a.stencil, a.steps, a.warmup)
    with_reg = median_step(True, a.stencil, a.steps, a.warmup)
    print(f"| JAX {jax.__version__} ({jax.devices()[0].platform}) | stencil | without regularizer (s) | with (s) |")
    print("|---|---|---|---|")
    print(f"| reference step | {a.stencil} points | {without:.4f} | {with_reg:.4f} |")


if __name__ == "__main__":
    main()
