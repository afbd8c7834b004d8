//! Vehicles: airplanes (engines or not, sweep, tails), cars (cabins, wheels) and boats (hulls,
//! cabins, masts, sails).

use glam::Vec3;
use rand::Rng;

use super::primitives::MeshBuilder;
use super::{ROUND, u};

/// A swept, tapered flat surface (wing, stabilizer): root at `root` (leading edge), spanning
/// `span` along `dir_span`, chords along +z.
fn wing(
    b: &mut MeshBuilder,
    root: Vec3,
    span: Vec3,
    root_chord: f32,
    tip_chord: f32,
    sweep: f32,
    t: f32,
) {
    let tip = root + span + Vec3::Z * sweep;
    // Thickness along the axis perpendicular to span and chord.
    let n = span.cross(Vec3::Z).normalize_or_zero() * t;
    let n = if n.y < 0.0 { -n } else { n };
    let (rl, rt) = (root, root + Vec3::Z * root_chord);
    let (tl, tt) = (tip, tip + Vec3::Z * tip_chord);
    // Order as a box: bottom (−n) face [rl, tl?]... corners: (−x,−z) (+x,−z) (+x,+z) (−x,+z).
    let (a, c) = if span.x >= 0.0 {
        ((rl, rt), (tl, tt))
    } else {
        ((tl, tt), (rl, rt))
    };
    b.add_hexahedron([
        a.0 - n,
        c.0 - n,
        c.1 - n,
        a.1 - n,
        a.0 + n,
        c.0 + n,
        c.1 + n,
        a.1 + n,
    ]);
}

pub(super) fn airplane(b: &mut MeshBuilder, rng: &mut impl Rng) {
    let len = 1.0;
    let r = u(rng, 0.035, 0.07);
    let nose = u(rng, 0.08, 0.18);
    let tail = u(rng, 0.15, 0.3);
    let (z0, z1) = (-len * 0.5, len * 0.5);
    b.add_cylinder(
        Vec3::new(0.0, 0.0, z0 + nose),
        Vec3::new(0.0, 0.0, z1 - tail),
        r,
        r,
        ROUND,
    );
    b.add_cylinder(
        Vec3::new(0.0, 0.0, z0 + nose),
        Vec3::new(0.0, 0.0, z0),
        r,
        r * 0.15,
        ROUND,
    );
    let tail_lift = u(rng, 0.0, r * 0.8);
    b.add_cylinder(
        Vec3::new(0.0, 0.0, z1 - tail),
        Vec3::new(0.0, tail_lift, z1),
        r,
        r * 0.3,
        ROUND,
    );
    // Main wings.
    let span = u(rng, 0.35, 0.55);
    let root_chord = u(rng, 0.15, 0.3);
    let tip_chord = root_chord * u(rng, 0.25, 0.7);
    let sweep = u(rng, -0.02, 0.3);
    let dihedral = u(rng, -0.02, 0.08);
    let wz = u(rng, -0.15, 0.05);
    let wy = if rng.random_bool(0.3) {
        r * 0.7
    } else {
        -r * 0.4
    };
    let t = 0.012;
    for sx in [-1., 1.] {
        wing(
            b,
            Vec3::new(0.0, wy, wz),
            Vec3::new(sx * span, dihedral, 0.0),
            root_chord,
            tip_chord,
            sweep,
            t,
        );
    }
    // Engines under the wings: none, two or four.
    let engines = [0, 2, 2, 4][rng.random_range(0..4)];
    let er = u(rng, 0.025, 0.045);
    for e in 0..engines / 2 {
        let f = if engines == 2 {
            0.4
        } else {
            0.3 + 0.3 * e as f32
        };
        for sx in [-1., 1.] {
            let x = sx * span * f;
            let z = wz + sweep * f - 0.05;
            let y = wy + dihedral * f - er - 0.01;
            b.add_cylinder(
                Vec3::new(x, y, z),
                Vec3::new(x, y, z + 0.16),
                er,
                er * 0.85,
                12,
            );
        }
    }
    // Tail: conventional or T-tail, fin height and sweep vary.
    let fin_h = u(rng, 0.1, 0.2);
    let fin_chord = u(rng, 0.1, 0.18);
    let fin_sweep = u(rng, 0.02, 0.1);
    let fz = z1 - fin_chord - 0.02;
    b.add_hexahedron([
        Vec3::new(-0.008, 0.0, fz),
        Vec3::new(0.008, 0.0, fz),
        Vec3::new(0.008, 0.0, fz + fin_chord),
        Vec3::new(-0.008, 0.0, fz + fin_chord),
        Vec3::new(-0.008, fin_h, fz + fin_sweep),
        Vec3::new(0.008, fin_h, fz + fin_sweep),
        Vec3::new(0.008, fin_h, fz + fin_chord * 0.6 + fin_sweep),
        Vec3::new(-0.008, fin_h, fz + fin_chord * 0.6 + fin_sweep),
    ]);
    let t_tail = rng.random_bool(0.3);
    let (sy, sz) = if t_tail {
        (fin_h, fz + fin_sweep)
    } else {
        (tail_lift * 0.5, fz)
    };
    let stab = u(rng, 0.1, 0.2);
    for sx in [-1., 1.] {
        wing(
            b,
            Vec3::new(0.0, sy, sz),
            Vec3::new(sx * stab, 0.0, 0.0),
            fin_chord * 0.8,
            fin_chord * 0.4,
            0.04,
            0.008,
        );
    }
}

pub(super) fn car(b: &mut MeshBuilder, rng: &mut impl Rng) {
    let w = u(rng, 0.19, 0.25); // half width (x)
    let l = 0.5; // half length (z)
    let clearance = u(rng, 0.04, 0.08);
    let bh = u(rng, 0.12, 0.2);
    let y0 = clearance;
    let y1 = y0 + bh;
    // Body: slightly tapered at the front (hood slope).
    let nose_drop = u(rng, 0.0, 0.05);
    b.add_hexahedron([
        Vec3::new(-w, y0, -l),
        Vec3::new(w, y0, -l),
        Vec3::new(w, y0, l),
        Vec3::new(-w, y0, l),
        Vec3::new(-w, y1 - nose_drop, -l),
        Vec3::new(w, y1 - nose_drop, -l),
        Vec3::new(w, y1, l),
        Vec3::new(-w, y1, l),
    ]);
    // Cabin: sedan, hatchback, van or pickup.
    let kind = rng.random_range(0..4);
    let ch = u(rng, 0.1, 0.17) * if kind == 2 { 1.5 } else { 1.0 };
    let (front, back) = match kind {
        0 => (u(rng, -0.2, -0.05), u(rng, 0.2, 0.32)), // sedan: boot behind
        1 => (u(rng, -0.2, -0.05), l - 0.02),          // hatchback
        2 => (-l + 0.12, l - 0.02),                    // van
        _ => (u(rng, -0.2, -0.1), u(rng, 0.05, 0.12)), // pickup: open bed behind
    };
    let rake = u(rng, 0.05, 0.14);
    let cw = w * u(rng, 0.8, 0.95);
    b.add_hexahedron([
        Vec3::new(-w * 0.97, y1 - 0.01, front),
        Vec3::new(w * 0.97, y1 - 0.01, front),
        Vec3::new(w * 0.97, y1 - 0.01, back),
        Vec3::new(-w * 0.97, y1 - 0.01, back),
        Vec3::new(-cw, y1 + ch, front + rake),
        Vec3::new(cw, y1 + ch, front + rake),
        Vec3::new(cw, y1 + ch, back - rake * 0.5),
        Vec3::new(-cw, y1 + ch, back - rake * 0.5),
    ]);
    if kind == 0 && rng.random_bool(0.3) {
        // Spoiler on the boot.
        b.add_box_between(
            Vec3::new(-w * 0.9, y1 + 0.04, l - 0.06),
            Vec3::new(w * 0.9, y1 + 0.055, l - 0.01),
        );
        for sx in [-0.6, 0.6] {
            b.add_box_between(
                Vec3::new(sx * w - 0.01, y1, l - 0.04),
                Vec3::new(sx * w + 0.01, y1 + 0.045, l - 0.03),
            );
        }
    }
    // Wheels.
    let wr = u(rng, 0.07, 0.1).max(clearance + 0.02);
    let ww = u(rng, 0.03, 0.05);
    let wheelbase = u(rng, 0.28, 0.36);
    for sz in [-1., 1.] {
        for sx in [-1., 1.] {
            let x = sx * (w - ww * 0.5);
            let c = Vec3::new(x, wr, sz * wheelbase);
            b.add_cylinder(c - Vec3::X * ww, c + Vec3::X * ww, wr, wr, ROUND);
        }
    }
}

pub(super) fn watercraft(b: &mut MeshBuilder, rng: &mut impl Rng) {
    let l = 0.5;
    let w = u(rng, 0.08, 0.16);
    let depth = u(rng, 0.06, 0.12);
    let bow = u(rng, 0.12, 0.25);
    let keel = u(rng, 0.3, 0.7); // bottom width relative to deck
    let deck = depth;
    // Hull: a tapered box for the stern part and a wedge converging to the bow.
    let zb = -l + bow;
    b.add_hexahedron([
        Vec3::new(-w * keel, 0.0, zb),
        Vec3::new(w * keel, 0.0, zb),
        Vec3::new(w * keel, 0.0, l - 0.02),
        Vec3::new(-w * keel, 0.0, l - 0.02),
        Vec3::new(-w, deck, zb),
        Vec3::new(w, deck, zb),
        Vec3::new(w, deck, l),
        Vec3::new(-w, deck, l),
    ]);
    let tip = 0.004;
    b.add_hexahedron([
        Vec3::new(-tip, deck * 0.4, -l + bow * 0.3),
        Vec3::new(tip, deck * 0.4, -l + bow * 0.3),
        Vec3::new(w * keel, 0.0, zb),
        Vec3::new(-w * keel, 0.0, zb),
        Vec3::new(-tip, deck + 0.02, -l),
        Vec3::new(tip, deck + 0.02, -l),
        Vec3::new(w, deck, zb),
        Vec3::new(-w, deck, zb),
    ]);
    match rng.random_range(0..3) {
        0 => {
            // Sailing boat: mast(s) and sails, a small cabin.
            let masts = rng.random_range(1..=2);
            for m in 0..masts {
                let z = -0.1 + 0.25 * m as f32;
                let mh = u(rng, 0.35, 0.6) * if m == 0 { 1.0 } else { 0.75 };
                b.add_cylinder(
                    Vec3::new(0.0, deck, z),
                    Vec3::new(0.0, deck + mh, z),
                    0.008,
                    0.005,
                    8,
                );
                let foot = u(rng, 0.15, 0.25);
                b.add_hexahedron([
                    Vec3::new(-0.003, deck + 0.05, z + 0.01),
                    Vec3::new(0.003, deck + 0.05, z + 0.01),
                    Vec3::new(0.003, deck + 0.05, z + foot),
                    Vec3::new(-0.003, deck + 0.05, z + foot),
                    Vec3::new(-0.003, deck + mh * 0.95, z + 0.01),
                    Vec3::new(0.003, deck + mh * 0.95, z + 0.01),
                    Vec3::new(0.003, deck + mh * 0.95, z + 0.02),
                    Vec3::new(-0.003, deck + mh * 0.95, z + 0.02),
                ]);
            }
            if rng.random_bool(0.6) {
                b.add_box_between(
                    Vec3::new(-w * 0.5, deck, 0.1),
                    Vec3::new(w * 0.5, deck + 0.05, 0.3),
                );
            }
        }
        1 => {
            // Motor yacht: stacked cabins.
            let levels = rng.random_range(1..=3);
            let (mut z0, mut z1, mut y) = (u(rng, -0.25, -0.1), u(rng, 0.3, 0.45), deck);
            let mut cw = w * 0.8;
            for _ in 0..levels {
                let hgt = u(rng, 0.05, 0.08);
                b.add_box_between(Vec3::new(-cw, y, z0), Vec3::new(cw, y + hgt, z1));
                y += hgt;
                z0 += u(rng, 0.04, 0.1);
                z1 -= u(rng, 0.02, 0.08);
                cw *= 0.85;
            }
            if rng.random_bool(0.5) {
                b.add_cylinder(
                    Vec3::new(0.0, y, (z0 + z1) * 0.5),
                    Vec3::new(0.0, y + 0.1, (z0 + z1) * 0.5),
                    0.006,
                    0.004,
                    6,
                );
            }
        }
        _ => {
            // Ship: a long superstructure and funnels.
            let z0 = u(rng, -0.1, 0.1);
            let hgt = u(rng, 0.06, 0.1);
            b.add_box_between(
                Vec3::new(-w * 0.7, deck, z0),
                Vec3::new(w * 0.7, deck + hgt, z0 + 0.25),
            );
            let funnels = rng.random_range(1..=3);
            for f in 0..funnels {
                let z = z0 + 0.05 + 0.07 * f as f32;
                let fr = u(rng, 0.02, 0.035);
                b.add_cylinder(
                    Vec3::new(0.0, deck + hgt, z),
                    Vec3::new(0.0, deck + hgt + u(rng, 0.06, 0.12), z),
                    fr,
                    fr,
                    12,
                );
            }
        }
    }
}
