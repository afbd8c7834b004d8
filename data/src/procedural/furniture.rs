//! Furniture: chairs (arms or not; solid, slatted or framed backs; four legs or a swivel base),
//! tables (four legs, pedestal or trestles; cross-bars, shelves) and benches (slatted seats,
//! optional backs).

use glam::Vec3;
use rand::Rng;

use super::primitives::MeshBuilder;
use super::{ROUND, u};

/// Four legs under a rectangle `[-w, w] × [-d, d]` from `y = 0` to `top`, inset by `inset`,
/// square or round.
fn four_legs(b: &mut MeshBuilder, w: f32, d: f32, top: f32, thick: f32, round: bool) {
    for (sx, sz) in [(-1., -1.), (1., -1.), (1., 1.), (-1., 1.)] {
        let x = sx * (w - thick);
        let z = sz * (d - thick);
        if round {
            b.add_cylinder(
                Vec3::new(x, 0.0, z),
                Vec3::new(x, top, z),
                thick,
                thick,
                ROUND,
            );
        } else {
            b.add_box_between(
                Vec3::new(x - thick, 0.0, z - thick),
                Vec3::new(x + thick, top, z + thick),
            );
        }
    }
}

/// Cross-bars (stretchers) between four legs at height `y`.
fn stretchers(b: &mut MeshBuilder, w: f32, d: f32, y: f32, thick: f32, around: bool) {
    let t = thick * 0.6;
    let (xi, zi) = (w - thick, d - thick);
    // Side bars along z on both sides; front/back bars along x when `around`.
    for sx in [-1., 1.] {
        b.add_box_between(
            Vec3::new(sx * xi - t, y - t, -zi),
            Vec3::new(sx * xi + t, y + t, zi),
        );
    }
    if around {
        for sz in [-1., 1.] {
            b.add_box_between(
                Vec3::new(-xi, y - t, sz * zi - t),
                Vec3::new(xi, y + t, sz * zi + t),
            );
        }
    } else {
        b.add_box_between(Vec3::new(-xi, y - t, -t), Vec3::new(xi, y + t, t));
    }
}

pub(super) fn chair(b: &mut MeshBuilder, rng: &mut impl Rng) {
    let w = u(rng, 0.20, 0.30); // half width
    let d = u(rng, 0.19, 0.28); // half depth
    let h = u(rng, 0.38, 0.50); // seat height
    let t = u(rng, 0.03, 0.07); // seat thickness
    let leg = u(rng, 0.015, 0.03);
    b.add_box_between(Vec3::new(-w, h - t, -d), Vec3::new(w, h, d));
    // Base: four legs (square or round, maybe with stretchers) or a swivel base.
    if rng.random_bool(0.2) {
        let r = u(rng, 0.025, 0.04);
        b.add_cylinder(
            Vec3::new(0.0, 0.06, 0.0),
            Vec3::new(0.0, h - t, 0.0),
            r,
            r,
            ROUND,
        );
        let spokes = rng.random_range(4..=5);
        let reach = u(rng, 0.22, 0.3);
        for i in 0..spokes {
            let a = std::f32::consts::TAU * i as f32 / spokes as f32;
            let tip = Vec3::new(a.cos() * reach, 0.03, a.sin() * reach);
            b.add_cylinder(Vec3::new(0.0, 0.06, 0.0), tip, 0.02, 0.015, 8);
            b.add_ellipsoid(tip - Vec3::Y * 0.01, Vec3::splat(0.025), 8);
        }
    } else {
        let round = rng.random_bool(0.4);
        four_legs(b, w, d, h - t, leg, round);
        if rng.random_bool(0.35) {
            stretchers(b, w, d, u(rng, 0.08, 0.2), leg, rng.random_bool(0.5));
        }
    }
    // Back: solid panel, vertical slats, horizontal slats, or a frame with a hole.
    let bh = u(rng, 0.32, 0.55);
    let bt = u(rng, 0.025, 0.05);
    let tilt = u(rng, 0.0, 0.12);
    let (z0, y0, y1) = (d - bt, h, h + bh);
    let back = |b: &mut MeshBuilder, x0: f32, x1: f32, ya: f32, yb: f32| {
        let (za, zb) = (z0 + tilt * (ya - y0) / bh, z0 + tilt * (yb - y0) / bh);
        b.add_hexahedron([
            Vec3::new(x0, ya, za - bt),
            Vec3::new(x1, ya, za - bt),
            Vec3::new(x1, ya, za + bt),
            Vec3::new(x0, ya, za + bt),
            Vec3::new(x0, yb, zb - bt),
            Vec3::new(x1, yb, zb - bt),
            Vec3::new(x1, yb, zb + bt),
            Vec3::new(x0, yb, zb + bt),
        ]);
    };
    let post = u(rng, 0.025, 0.045);
    match rng.random_range(0..4) {
        0 => back(b, -w, w, y0 - t, y1),
        1 => {
            // Posts, a top rail and vertical slats with gaps between them.
            back(b, -w, -w + post, y0 - t, y1);
            back(b, w - post, w, y0 - t, y1);
            let rail = u(rng, 0.05, 0.1);
            back(b, -w, w, y1 - rail, y1);
            let n = rng.random_range(2..=5);
            let inner = 2.0 * (w - post);
            let slat = inner / (2 * n + 1) as f32;
            for i in 0..n {
                let x = -w + post + slat * (2 * i + 1) as f32;
                back(b, x, x + slat, y0, y1 - rail);
            }
        }
        2 => {
            // Posts and horizontal slats.
            back(b, -w, -w + post, y0 - t, y1);
            back(b, w - post, w, y0 - t, y1);
            let n = rng.random_range(2..=4);
            let gap = bh / (2 * n) as f32;
            for i in 0..n {
                let ya = y1 - gap * (2 * i + 1) as f32;
                back(b, -w, w, ya, ya + gap);
            }
        }
        _ => {
            // A frame with one big hole.
            let rail = u(rng, 0.06, 0.1);
            back(b, -w, -w + post, y0 - t, y1);
            back(b, w - post, w, y0 - t, y1);
            back(b, -w, w, y1 - rail, y1);
            back(b, -w, w, y0, y0 + rail * 0.8);
        }
    }
    // Arms.
    if rng.random_bool(0.4) {
        let ah = u(rng, 0.18, 0.26);
        let aw = u(rng, 0.025, 0.045);
        let solid = rng.random_bool(0.3);
        for sx in [-1., 1.] {
            let x = sx * (w - aw);
            b.add_box_between(
                Vec3::new(x - aw, h + ah - 0.03, -d),
                Vec3::new(x + aw, h + ah, d),
            );
            if solid {
                b.add_box_between(
                    Vec3::new(x - aw * 0.6, h, -d),
                    Vec3::new(x + aw * 0.6, h + ah, d * 0.9),
                );
            } else {
                b.add_box_between(
                    Vec3::new(x - aw * 0.6, h, -d),
                    Vec3::new(x + aw * 0.6, h + ah, -d + 2.0 * aw),
                );
            }
        }
    }
}

pub(super) fn table(b: &mut MeshBuilder, rng: &mut impl Rng) {
    let w = u(rng, 0.45, 0.8);
    let round_top = rng.random_bool(0.25);
    let d = if round_top { w } else { u(rng, 0.28, 0.5) };
    let h = u(rng, 0.5, 0.75);
    let t = u(rng, 0.025, 0.06);
    if round_top {
        b.add_cylinder(Vec3::new(0.0, h - t, 0.0), Vec3::new(0.0, h, 0.0), w, w, 32);
    } else {
        b.add_box_between(Vec3::new(-w, h - t, -d), Vec3::new(w, h, d));
    }
    let leg = u(rng, 0.02, 0.045);
    let base = if round_top {
        rng.random_range(0..2)
    } else {
        rng.random_range(0..4)
    };
    match base {
        0 => {
            // Pedestal: column and a foot (disc or cross).
            let r = u(rng, 0.04, 0.09);
            b.add_cylinder(
                Vec3::ZERO,
                Vec3::new(0.0, h - t, 0.0),
                r,
                r * u(rng, 0.7, 1.0),
                ROUND,
            );
            if rng.random_bool(0.5) {
                let fr = u(rng, 0.25, 0.45) * w.min(d).max(0.4);
                b.add_cylinder(Vec3::ZERO, Vec3::new(0.0, 0.04, 0.0), fr, fr * 0.8, 24);
            } else {
                let reach = w.min(d) * 0.8;
                b.add_box_between(Vec3::new(-reach, 0.0, -0.03), Vec3::new(reach, 0.05, 0.03));
                b.add_box_between(Vec3::new(-0.03, 0.0, -reach), Vec3::new(0.03, 0.05, reach));
            }
        }
        1 => {
            // Four legs, perhaps with cross-bars and a lower shelf.
            let (lw, ld) = if round_top {
                (w * 0.65, w * 0.65)
            } else {
                (w, d)
            };
            four_legs(b, lw, ld, h - t, leg, rng.random_bool(0.4));
            if rng.random_bool(0.5) {
                stretchers(b, lw, ld, u(rng, 0.08, 0.3), leg, rng.random_bool(0.5));
            }
            if rng.random_bool(0.25) {
                let y = u(rng, 0.1, 0.25);
                b.add_box_between(Vec3::new(-lw, y, -ld), Vec3::new(lw, y + 0.025, ld));
            }
        }
        2 => {
            // Trestles: two end panels joined by a bar.
            let inset = u(rng, 0.03, 0.12);
            for sx in [-1., 1.] {
                let x = sx * (w - inset);
                b.add_box_between(
                    Vec3::new(x - leg, 0.0, -d * 0.85),
                    Vec3::new(x + leg, h - t, d * 0.85),
                );
            }
            let y = u(rng, 0.1, 0.35);
            b.add_box_between(
                Vec3::new(-w + inset, y, -0.03),
                Vec3::new(w - inset, y + 0.05, 0.03),
            );
        }
        _ => {
            // Four legs with an apron under the top.
            four_legs(b, w, d, h - t, leg, false);
            let ah = u(rng, 0.05, 0.1);
            b.add_box_between(
                Vec3::new(-w + leg, h - t - ah, -d + leg),
                Vec3::new(w - leg, h - t, d - leg),
            );
        }
    }
}

pub(super) fn bench(b: &mut MeshBuilder, rng: &mut impl Rng) {
    let w = u(rng, 0.6, 1.0);
    let d = u(rng, 0.14, 0.25);
    let h = u(rng, 0.32, 0.45);
    let t = u(rng, 0.025, 0.05);
    if rng.random_bool(0.6) {
        // Slatted seat with gaps.
        let n = rng.random_range(3..=5);
        let slat = 2.0 * d / (n as f32 * 1.4 - 0.4);
        for i in 0..n {
            let z = -d + i as f32 * slat * 1.4;
            b.add_box_between(Vec3::new(-w, h - t, z), Vec3::new(w, h, z + slat));
        }
        // Cross supports under the slats.
        for sx in [-1., 0., 1.] {
            let x = sx * (w * 0.8);
            b.add_box_between(
                Vec3::new(x - 0.02, h - t - 0.04, -d),
                Vec3::new(x + 0.02, h - t, d),
            );
        }
    } else {
        b.add_box_between(Vec3::new(-w, h - t, -d), Vec3::new(w, h, d));
    }
    let leg = u(rng, 0.02, 0.04);
    if rng.random_bool(0.5) {
        four_legs(
            b,
            w * u(rng, 0.85, 1.0),
            d,
            h - t,
            leg,
            rng.random_bool(0.3),
        );
    } else {
        // Side panels.
        for sx in [-1., 1.] {
            let x = sx * (w * 0.9);
            b.add_box_between(Vec3::new(x - leg, 0.0, -d), Vec3::new(x + leg, h - t, d));
        }
    }
    if rng.random_bool(0.5) {
        // Backrest: posts and one to three rails.
        let bh = u(rng, 0.2, 0.4);
        let z = d - 0.02;
        for sx in [-1., 1.] {
            let x = sx * (w * 0.9);
            b.add_box_between(
                Vec3::new(x - leg, h, z - 0.02),
                Vec3::new(x + leg, h + bh, z + 0.02),
            );
        }
        let n = rng.random_range(1..=3);
        let rail = bh / (2 * n) as f32;
        for i in 0..n {
            let y = h + bh - rail * (2 * i + 1) as f32;
            b.add_box_between(Vec3::new(-w, y, z - 0.02), Vec3::new(w, y + rail, z + 0.02));
        }
        if rng.random_bool(0.4) {
            for sx in [-1., 1.] {
                let x = sx * w;
                b.add_box_between(
                    Vec3::new(x - 0.03, h + 0.15, -d),
                    Vec3::new(x + 0.03, h + 0.18, d),
                );
                b.add_box_between(
                    Vec3::new(x - 0.02, h, -d),
                    Vec3::new(x + 0.02, h + 0.15, -d + 0.04),
                );
            }
        }
    }
}
