//! Procedural shapes in the paper's six categories, with variation in proportions and topology.
//!
//! ShapeNet cannot be downloaded here, so the project makes its own objects. Each shape is a
//! union of closed primitives ([`primitives::MeshBuilder`]); overlapping parts are fine for every
//! consumer (the rasterizer draws the union, NMR's surface voxelization + fill and the winding
//! number both give the union's solid). Shapes use ShapeNet's orientation: up is `+y`, the front
//! of an object faces `−z` (towards the camera of view 0), and are normalized to the unit cube by
//! [`generate`].
//!
//! Variation is structural, not only metric: chairs with and without arms, solid / slatted /
//! framed backs (holes), four legs or a swivel base; tables with four legs, a pedestal, trestles,
//! cross-bars and shelves; benches with slatted seats and optional backs; airplanes with or without
//! engines, different sweep and tails; cars with different cabins and wheels; boats with hulls,
//! cabins, masts and sails. Everything is drawn from a seeded ChaCha RNG, so an object is a pure
//! function of `(seed, category, split, index)`.

pub mod primitives;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use self::primitives::MeshBuilder;
use super::category::Category;
use super::mesh::TriMesh;

/// Segments used for round parts: enough to read as round at 64×64, few enough to stay fast.
const ROUND: usize = 16;

/// The RNG for object `index` of `category` in the split numbered `split` (0 train, 1 val,
/// 2 test) under `seed`. Objects are independent of how many others are generated.
pub fn object_rng(seed: u64, category: Category, split: u64, index: u64) -> ChaCha8Rng {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for x in [category as u64 + 1, split + 1, index + 1] {
        h = splitmix(h ^ x.wrapping_mul(0xD1B5_4A32_D192_ED03));
    }
    ChaCha8Rng::seed_from_u64(h)
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A random object of `category`, normalized to the unit cube.
pub fn generate(category: Category, rng: &mut impl Rng) -> TriMesh {
    let mut b = MeshBuilder::default();
    match category {
        Category::Airplane => airplane(&mut b, rng),
        Category::Bench => bench(&mut b, rng),
        Category::Car => car(&mut b, rng),
        Category::Chair => chair(&mut b, rng),
        Category::Table => table(&mut b, rng),
        Category::Watercraft => watercraft(&mut b, rng),
    }
    let mut mesh = b.build();
    mesh.normalize_unit_cube();
    mesh
}

fn u(rng: &mut impl Rng, lo: f32, hi: f32) -> f32 {
    rng.random_range(lo..hi)
}

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

fn chair(b: &mut MeshBuilder, rng: &mut impl Rng) {
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

fn table(b: &mut MeshBuilder, rng: &mut impl Rng) {
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

fn bench(b: &mut MeshBuilder, rng: &mut impl Rng) {
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

fn airplane(b: &mut MeshBuilder, rng: &mut impl Rng) {
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

fn car(b: &mut MeshBuilder, rng: &mut impl Rng) {
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

fn watercraft(b: &mut MeshBuilder, rng: &mut impl Rng) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxelize::voxelize_nmr;

    #[test]
    fn every_category_generates_valid_normalized_distinct_shapes() {
        for c in Category::ALL {
            let mut counts = Vec::new();
            for i in 0..6 {
                let m = generate(c, &mut object_rng(0, c, 0, i));
                m.validate().unwrap();
                let (lo, hi) = m.bounds();
                assert!(((hi - lo).max_element() - 1.0).abs() < 1e-5, "{c}");
                assert!(lo.min_element() >= -0.5 - 1e-5 && hi.max_element() <= 0.5 + 1e-5);
                counts.push(voxelize_nmr(&m, 32).count());
            }
            counts.sort();
            counts.dedup();
            assert!(
                counts.len() >= 5,
                "{c}: shapes should differ, voxel counts {counts:?}"
            );
        }
    }

    #[test]
    fn objects_are_reproducible_and_independent_of_each_other() {
        let a = generate(Category::Chair, &mut object_rng(7, Category::Chair, 2, 3));
        let b = generate(Category::Chair, &mut object_rng(7, Category::Chair, 2, 3));
        let c = generate(Category::Chair, &mut object_rng(7, Category::Chair, 2, 4));
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
