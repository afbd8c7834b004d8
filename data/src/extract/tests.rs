use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;
use std::time::Instant;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// Smooth sphere of radius `r` (φ = ½ on it).
fn sphere(r: f32) -> impl Fn(Vec3) -> f32 {
    move |p| sigmoid(40.0 * (r - p.length()))
}

/// Smooth torus around z: major radius `big`, minor `small`.
fn torus(big: f32, small: f32) -> impl Fn(Vec3) -> f32 {
    move |p| {
        let q = Vec3::new(p.truncate().length() - big, p.z, 0.0);
        sigmoid(40.0 * (small - q.length()))
    }
}

/// Runs `extract_mesh` on a pointwise field, counting the points and calls.
fn run(f: impl Fn(Vec3) -> f32, opts: &ExtractOptions) -> (TriMesh, usize, usize) {
    let (mut points, mut calls) = (0, 0);
    let mut field = |p: &[f32]| {
        calls += 1;
        points += p.len() / 3;
        p.chunks_exact(3).map(|c| f(Vec3::from_slice(c))).collect()
    };
    let mesh = extract_mesh(&mut field, opts);
    (mesh, points, calls)
}

fn dense(resolution: usize) -> ExtractOptions {
    ExtractOptions {
        resolution,
        refinements: 0,
        ..ExtractOptions::default()
    }
}

/// Enclosed volume by the divergence theorem (positive for outward winding).
fn volume(m: &TriMesh) -> f64 {
    (0..m.faces.len())
        .map(|f| {
            let [a, b, c] = m.triangle(f).map(|v| v.as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn area(m: &TriMesh) -> f64 {
    (0..m.faces.len())
        .map(|f| {
            let [a, b, c] = m.triangle(f).map(|v| v.as_dvec3());
            (b - a).cross(c - a).length() / 2.0
        })
        .sum()
}

/// Asserts that `m` is a closed, consistently oriented 2-manifold without duplicate vertices or
/// zero-area triangles, and returns its Euler characteristic V − E + F.
fn check_closed(m: &TriMesh) -> i64 {
    let nv = m.vertices.len();
    let mut directed = HashSet::new();
    let mut link: Vec<HashMap<u32, u32>> = vec![HashMap::new(); nv];
    for (fi, f) in m.faces.iter().enumerate() {
        assert!(
            f.iter().all(|&i| (i as usize) < nv),
            "face {fi} out of range"
        );
        assert!(
            f[0] != f[1] && f[1] != f[2] && f[2] != f[0],
            "face {fi} repeats a vertex: {f:?}"
        );
        let [a, b, c] = m.triangle(fi).map(|v| v.as_dvec3());
        let twice_area = (b - a).cross(c - a).length();
        assert!(twice_area > 0.0, "face {fi} has zero area: {a} {b} {c}");
        for q in 0..3 {
            let (u, v, w) = (f[q], f[(q + 1) % 3], f[(q + 2) % 3]);
            assert!(
                directed.insert((u, v)),
                "directed edge {u}→{v} used twice (inconsistent orientation or non-manifold)"
            );
            assert!(link[u as usize].insert(v, w).is_none());
        }
    }
    for &(u, v) in &directed {
        assert!(
            directed.contains(&(v, u)),
            "edge {u}–{v} has one triangle: the mesh is open"
        );
    }
    // Each vertex is used and its link is one cycle (no pinched vertices).
    for (i, l) in link.iter().enumerate() {
        assert!(!l.is_empty(), "vertex {i} is unused");
        let start = *l.keys().next().unwrap();
        let (mut at, mut len) = (start, 0);
        loop {
            at = *l
                .get(&at)
                .unwrap_or_else(|| panic!("vertex {i}: open link"));
            len += 1;
            if at == start {
                break;
            }
        }
        assert_eq!(len, l.len(), "vertex {i}: the link is not one cycle");
    }
    let mut seen = HashSet::new();
    for (i, v) in m.vertices.iter().enumerate() {
        assert!(v.is_finite(), "vertex {i} not finite");
        assert!(
            seen.insert(v.to_array().map(f32::to_bits)),
            "vertex {i} duplicates the position {v}"
        );
    }
    nv as i64 - directed.len() as i64 / 2 + m.faces.len() as i64
}

fn rel(got: f64, want: f64) -> f64 {
    (got - want) / want
}

#[test]
fn smooth_sphere_area_and_volume_match_analytic() {
    let r = 0.35f64;
    let t0 = Instant::now();
    let (m, points, calls) = run(sphere(r as f32), &ExtractOptions::default());
    let secs = t0.elapsed().as_secs_f64();
    let (a, v) = (area(&m), volume(&m));
    let (ea, ev) = (rel(a, 4.0 * PI * r * r), rel(v, 4.0 / 3.0 * PI * r.powi(3)));
    eprintln!(
        "sphere 32→128: {} vertices, {} faces, area err {:+.4}%, volume err {:+.4}%, \
         {points} points in {calls} calls, {secs:.3} s",
        m.vertices.len(),
        m.faces.len(),
        ea * 100.0,
        ev * 100.0
    );
    assert!(v > 0.0, "negative volume {v}: inward winding");
    assert!(ea.abs() < 0.03, "area error {ea}");
    assert!(ev.abs() < 0.03, "volume error {ev}");
    assert_eq!(calls, 3, "one call per level");
    assert_eq!(check_closed(&m), 2, "a sphere has Euler characteristic 2");
    // Every vertex lies on the sphere to within the interpolation error (≪ a fine cell).
    let worst = m
        .vertices
        .iter()
        .map(|p| (f64::from(p.length()) - r).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.1 / 124.0, "vertex {worst} off the sphere");
}

#[test]
fn coarse_and_binary_spheres_are_still_close() {
    let r = 0.35f64;
    let (sa, sv) = (4.0 * PI * r * r, 4.0 / 3.0 * PI * r.powi(3));
    // Dense 32³, smooth field.
    let (m, ..) = run(sphere(r as f32), &dense(32));
    assert_eq!(check_closed(&m), 2);
    let (ea, ev) = (rel(area(&m), sa), rel(volume(&m), sv));
    eprintln!(
        "smooth sphere 32³: area err {:+.3}%, volume err {:+.3}%",
        ea * 100.0,
        ev * 100.0
    );
    assert!(ea.abs() < 0.03 && ev.abs() < 0.03, "{ea} {ev}");
    // Binary field (φ ∈ {0, 1}): vertices at edge midpoints, a chamfered staircase.
    let binary = |p: Vec3| f32::from(u8::from(f64::from(p.length()) < r));
    let (m, ..) = run(binary, &ExtractOptions::default());
    assert_eq!(check_closed(&m), 2);
    let (ea, ev) = (rel(area(&m), sa), rel(volume(&m), sv));
    eprintln!(
        "binary sphere 32→128: area err {:+.3}%, volume err {:+.3}%",
        ea * 100.0,
        ev * 100.0
    );
    assert!(ev.abs() < 0.03, "{ev}");
    assert!(ea.abs() < 0.10, "{ea}");
}

#[test]
fn torus_is_closed_with_euler_characteristic_zero() {
    let (big, small) = (0.25f64, 0.1f64);
    let (m, ..) = run(torus(big as f32, small as f32), &ExtractOptions::default());
    assert_eq!(check_closed(&m), 0, "a torus has Euler characteristic 0");
    let (ea, ev) = (
        rel(area(&m), 4.0 * PI * PI * big * small),
        rel(volume(&m), 2.0 * PI * PI * big * small * small),
    );
    eprintln!(
        "torus: area err {:+.3}%, volume err {:+.3}%",
        ea * 100.0,
        ev * 100.0
    );
    assert!(ea.abs() < 0.03 && ev.abs() < 0.03, "{ea} {ev}");
}

#[test]
fn mise_matches_dense_with_far_fewer_points() {
    let f = sphere(0.35);
    let (mise, mise_points, _) = run(&f, &ExtractOptions::default());
    let (full, full_points, _) = run(&f, &dense(128));
    let (dilated, dilated_points, _) = run(
        &f,
        &ExtractOptions {
            refine_neighbours: true,
            ..ExtractOptions::default()
        },
    );
    eprintln!(
        "points: MISE {mise_points}, MISE + neighbours {dilated_points}, dense {full_points}; \
         vertices {} / {} / {}; volumes {:.7} / {:.7} / {:.7}",
        mise.vertices.len(),
        dilated.vertices.len(),
        full.vertices.len(),
        volume(&mise),
        volume(&dilated),
        volume(&full)
    );
    eprintln!("MISE mesh identical to dense: {}", mise == full);
    assert_eq!(full_points, 129usize.pow(3));
    // The coarse 65³ alone is an eighth of the dense 129³; the refined band adds a little.
    assert!(
        mise_points * 5 < full_points,
        "MISE evaluated {mise_points} of {full_points}"
    );
    assert!(mise_points < dilated_points && dilated_points < full_points);
    for m in [&mise, &dilated] {
        let dv = (m.vertices.len() as f64 - full.vertices.len() as f64).abs();
        assert!(
            dv <= 0.001 * full.vertices.len() as f64,
            "vertex counts {} vs {}",
            m.vertices.len(),
            full.vertices.len()
        );
        assert!(rel(volume(m), volume(&full)).abs() < 0.005);
        assert_eq!(check_closed(m), 2);
    }
}

#[test]
fn batch_size_splits_calls_without_changing_the_mesh() {
    let f = sphere(0.3);
    let (whole, points, calls) = run(&f, &ExtractOptions::default());
    let (split, points_split, calls_split) = run(
        &f,
        &ExtractOptions {
            batch_size: 10_000,
            ..ExtractOptions::default()
        },
    );
    assert_eq!(calls, 3);
    assert_eq!(points, points_split);
    assert!(calls_split > points / 10_000, "{calls_split} calls");
    assert_eq!(whole, split);
}

#[test]
fn field_touching_the_unit_cube_gives_a_closed_box() {
    // φ = 1 on the closed unit cube: the samples at ±0.5 are inside, the next ones (±0.5 ± h)
    // outside, so the faces lie at ±(0.5 + h/2) — only because of the padding.
    let cube = |p: Vec3| f32::from(u8::from(p.abs().max_element() <= 0.5 + 1e-5));
    let opts = ExtractOptions::default();
    let (m, ..) = run(cube, &opts);
    assert_eq!(check_closed(&m), 2);
    let h = 1.0f64 / 124.0;
    let v = volume(&m);
    assert!(
        rel(v, (1.0 + h).powi(3)).abs() < 1e-4,
        "volume {v} vs {}",
        (1.0 + h).powi(3)
    );
    let (lo, hi) = m.bounds();
    assert!(
        (hi.max_element() - (0.5 + h as f32 / 2.0)).abs() < 1e-5,
        "{hi}"
    );
    assert!(
        (lo.min_element() + (0.5 + h as f32 / 2.0)).abs() < 1e-5,
        "{lo}"
    );

    // Without padding the samples at ±0.5 are the last ones and the box is capped there.
    let (m, ..) = run(
        cube,
        &ExtractOptions {
            padding: 0.0,
            ..ExtractOptions::default()
        },
    );
    assert_eq!(check_closed(&m), 2);
    assert!(rel(volume(&m), 1.0).abs() < 0.01);
}

#[test]
fn field_filling_everything_is_capped_at_the_sampled_cube() {
    let (m, points, _) = run(|_| 1.0, &ExtractOptions::default());
    assert_eq!(points, 65usize.pow(3), "nothing to refine");
    assert_eq!(check_closed(&m), 2);
    let side = 1.0 + 1.0 / 31.0;
    assert!(rel(volume(&m), side * side * side).abs() < 1e-3);
    // A cap on each face: 6 faces × 128² cells × 2 triangles... approximately.
    assert!(m.faces.len() >= 6 * 128 * 128 * 2);
}

#[test]
fn empty_field_gives_an_empty_mesh() {
    for f in [|_: Vec3| 0.0, |_: Vec3| f32::NAN] {
        let (m, points, calls) = run(f, &ExtractOptions::default());
        assert!(m.vertices.is_empty() && m.faces.is_empty());
        // Nothing straddles: the refinement level has no points and makes no calls (the coarse
        // 65³ takes two calls of at most 2^18 points).
        assert_eq!((points, calls), (65usize.pow(3), 2));
    }
    let m = marching_cubes(&[], [0, 0, 0], Vec3::ZERO, Vec3::ONE, 0.5);
    assert!(m.faces.is_empty());
}

#[test]
fn every_single_cell_configuration_is_closed_and_outward() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for mask in 1..256u32 {
        for _ in 0..8 {
            let values: Vec<f32> = (0..8)
                .map(|c| {
                    // Sample c = (i, j, k) sits at index (i·2 + j)·2 + k.
                    let (i, j, k) = (c >> 2 & 1, c >> 1 & 1, c & 1);
                    let corner = i | j << 1 | k << 2;
                    let inside = mask >> corner & 1 == 1;
                    let u: f32 = rng.random_range(0.0..0.5);
                    if inside { 0.5 + u } else { u }
                })
                .collect();
            let m = marching_cubes(&values, [2, 2, 2], Vec3::ZERO, Vec3::ONE, 0.5);
            let chi = check_closed(&m);
            assert!(chi % 2 == 0 && chi > 0, "mask {mask:#010b}: χ = {chi}");
            assert!(volume(&m) > 0.0, "mask {mask:#010b}");
        }
    }
}

#[test]
fn random_fields_give_closed_oriented_manifolds() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 7;
    let (mut faces, mut centroids) = (0, 0);
    for trial in 0..300 {
        // Half the trials draw from {0, ¼, ½, ¾, 1}: many samples exactly at the threshold.
        let values: Vec<f32> = (0..n * n * n)
            .map(|_| {
                if trial % 2 == 0 {
                    rng.random()
                } else {
                    rng.random_range(0..5) as f32 / 4.0
                }
            })
            .collect();
        let spacing = Vec3::new(0.1, 0.2, 0.15);
        let m = marching_cubes(&values, [n; 3], Vec3::splat(-0.3), spacing, 0.5);
        check_closed(&m);
        assert!(volume(&m) > 0.0, "trial {trial}");
        faces += m.faces.len();
        // Vertices off the grid lines (centroids of loops) are the only ones off every edge.
        centroids += m
            .vertices
            .iter()
            .filter(|v| {
                let g = (**v - Vec3::splat(-0.3)) / spacing;
                let off = g
                    .to_array()
                    .into_iter()
                    .filter(|x| (x - x.round()).abs() > 1e-4);
                off.count() > 1
            })
            .count();
    }
    eprintln!("random fields: {faces} faces, {centroids} loop-centroid vertices");
}

#[test]
fn options_are_validated() {
    let ok = ExtractOptions::default();
    assert!(ok.validate().is_ok());
    assert_eq!(ok.fine_resolution(), 128);
    for bad in [
        ExtractOptions {
            resolution: 0,
            ..ok.clone()
        },
        ExtractOptions {
            resolution: 64,
            refinements: 5,
            ..ok.clone()
        },
        ExtractOptions {
            threshold: Some(f32::NAN),
            ..ok.clone()
        },
        ExtractOptions {
            batch_size: 0,
            ..ok.clone()
        },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
}

/// Parses a binary little-endian PLY as written by `write_ply_to`.
fn read_ply(bytes: &[u8]) -> TriMesh {
    let end = b"end_header\n";
    let at = bytes
        .windows(end.len())
        .position(|w| w == end)
        .expect("end_header")
        + end.len();
    let header = std::str::from_utf8(&bytes[..at]).unwrap();
    let mut lines = header.lines();
    assert_eq!(lines.next(), Some("ply"));
    assert_eq!(lines.next(), Some("format binary_little_endian 1.0"));
    let count = |name: &str| -> usize {
        header
            .lines()
            .find_map(|l| l.strip_prefix(&format!("element {name} ")))
            .unwrap_or_else(|| panic!("no element {name}"))
            .parse()
            .unwrap()
    };
    let (nv, nf) = (count("vertex"), count("face"));
    assert!(header.contains("property list uchar int vertex_indices\n"));
    let mut body = &bytes[at..];
    let mut take = |n: usize| {
        let (a, b) = body.split_at(n);
        body = b;
        a
    };
    let mut m = TriMesh::default();
    for _ in 0..nv {
        let c: Vec<f32> = (0..3)
            .map(|_| f32::from_le_bytes(take(4).try_into().unwrap()))
            .collect();
        m.vertices.push(Vec3::from_slice(&c));
    }
    for _ in 0..nf {
        assert_eq!(take(1), [3]);
        let f: Vec<u32> = (0..3)
            .map(|_| i32::from_le_bytes(take(4).try_into().unwrap()) as u32)
            .collect();
        m.faces.push([f[0], f[1], f[2]]);
    }
    assert!(body.is_empty(), "trailing bytes");
    m
}

#[test]
fn ply_and_obj_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let (m, ..) = run(sphere(0.3), &dense(16));
    assert!(!m.faces.is_empty());

    let ply = dir.path().join("sub/sphere.ply");
    write_mesh(&m, &ply).unwrap();
    let bytes = std::fs::read(&ply).unwrap();
    let header = String::from_utf8_lossy(&bytes[..300]);
    assert!(header.contains(&format!("element vertex {}\n", m.vertices.len())));
    assert!(header.contains(&format!("element face {}\n", m.faces.len())));
    assert_eq!(read_ply(&bytes), m, "bit-exact round trip");
    // Atomic: no temporary left behind.
    assert_eq!(std::fs::read_dir(ply.parent().unwrap()).unwrap().count(), 1);

    let empty = dir.path().join("empty.ply");
    write_ply(&TriMesh::default(), &empty).unwrap();
    assert_eq!(
        read_ply(&std::fs::read(&empty).unwrap()),
        TriMesh::default()
    );

    let obj = dir.path().join("sphere.obj");
    write_mesh(&m, &obj).unwrap();
    let back = TriMesh::load_obj(&obj).unwrap();
    assert_eq!(back.faces.len(), m.faces.len());
    assert_eq!(back.triangle(0), m.triangle(0));

    let e = write_mesh(&m, &dir.path().join("sphere.stl")).unwrap_err();
    assert!(e.to_string().contains("sphere.stl"), "{e}");
}

#[test]
fn extracted_meshes_voxelize_solid_in_the_nmr_protocol() {
    // The default grid is aligned with NMR's lattice, so lattice lines meet the surface at mesh
    // vertices: the voxelizer's inclusive test must still close the shell, or the fill leaks and
    // only the shell remains.
    use crate::voxelize::voxelize_nmr;
    use crate::{GridFrame, VoxelGrid};
    let (mesh, _, _) = run(sphere(0.3), &ExtractOptions::default());
    let nmr = voxelize_nmr(&mesh, 32);
    let frame = GridFrame::new(32);
    let centres = VoxelGrid::from_fn(32, |i, j, k, _| frame.centre(i, j, k).length() < 0.29);
    assert!(centres.count() > 3000, "{} voxels inside", centres.count());
    // NMR's voxelization is the centre test dilated: it contains every inside centre.
    assert_eq!(centres.fraction_inside(&nmr), 1.0, "the fill leaked");
    assert!(
        nmr.count() < centres.count() * 3 / 2,
        "{} vs {}",
        nmr.count(),
        centres.count()
    );
}
