use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::data::procedural::primitives::MeshBuilder;

fn rng() -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(7)
}

fn brute_nearest(points: &[Vec3], q: Vec3) -> f32 {
    points
        .iter()
        .map(|p| p.distance(q))
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn samples_lie_on_the_surface_and_follow_face_areas() {
    // A box with faces of areas 2·(1·2), 2·(1·4), 2·(2·4): 4, 8, 16 out of 28.
    let half = Vec3::new(0.5, 1.0, 2.0);
    let mesh = MeshBuilder::default()
        .add_box(Vec3::ZERO, half)
        .clone()
        .build();
    let n = 28_000;
    let s = sample_surface(&mesh, n, &mut rng());
    assert_eq!(s.points.len(), n);
    let mut per_axis = [0usize; 3];
    for (p, nrm) in s.points.iter().zip(&s.normals) {
        // On the surface: one coordinate at ±half, the others inside.
        let on = (0..3)
            .filter(|&a| (p[a].abs() - half[a]).abs() < 1e-5)
            .collect::<Vec<_>>();
        assert!(!on.is_empty(), "{p} is not on the box");
        assert!((0..3).all(|a| p[a].abs() <= half[a] + 1e-5));
        // The normal is the face's axis.
        let axis = (0..3)
            .max_by(|&a, &b| nrm[a].abs().total_cmp(&nrm[b].abs()))
            .unwrap();
        assert!((nrm[axis].abs() - 1.0).abs() < 1e-5);
        per_axis[axis] += 1;
    }
    // Faces normal to x have area 2·(2·4) = 16, to y 2·(1·4) = 8, to z 2·(1·2) = 4.
    for (axis, area) in [(0, 16.0), (1, 8.0), (2, 4.0)] {
        let expected = n as f64 * area / 28.0;
        let sd = (expected * (1.0 - area / 28.0)).sqrt();
        let got = per_axis[axis] as f64;
        assert!(
            (got - expected).abs() < 4.0 * sd,
            "axis {axis}: {got} samples, expected {expected:.0} ± {sd:.0}"
        );
    }
    // Within a face the density is uniform: the x = +0.5 face's quadrants are equally hit.
    let face: Vec<&Vec3> = s
        .points
        .iter()
        .filter(|p| (p.x - 0.5).abs() < 1e-5)
        .collect();
    let q = face.iter().filter(|p| p.y > 0.0 && p.z > 0.0).count() as f64;
    let expected = face.len() as f64 / 4.0;
    assert!(
        (q - expected).abs() < 4.0 * (expected * 0.75).sqrt(),
        "{q} vs {expected}"
    );
}

#[test]
fn a_mesh_without_area_gives_no_samples() {
    let flat = TriMesh {
        vertices: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
        faces: vec![[0, 1, 2]],
    };
    assert!(sample_surface(&flat, 10, &mut rng()).points.is_empty());
    assert!(
        sample_surface(&TriMesh::default(), 10, &mut rng())
            .points
            .is_empty()
    );
}

#[test]
fn outer_surface_drops_walls_inside_other_parts() {
    // Two unit cubes overlapping by half along x: each loses the face that lies inside the
    // other; the four side faces stay (where they overlap, coplanar, both copies stay), so 10 of
    // the 12 unit faces are kept.
    let mesh = MeshBuilder::default()
        .add_box(Vec3::ZERO, Vec3::splat(0.5))
        .add_box(Vec3::new(0.5, 0.0, 0.0), Vec3::splat(0.5))
        .clone()
        .build();
    let all = sample_surface(&mesh, 6000, &mut rng());
    let n = all.points.len() as f64;
    let outer = outer_surface(&mesh, all);
    for p in &outer.points {
        let inside_a = p.abs().max_element() < 0.5 - 1e-4;
        let inside_b = (*p - Vec3::new(0.5, 0.0, 0.0)).abs().max_element() < 0.5 - 1e-4;
        assert!(!inside_a && !inside_b, "{p} is inside a part");
    }
    let kept = outer.points.len() as f64 / n;
    assert!((kept - 10.0 / 12.0).abs() < 0.03, "kept {kept}");
}

#[test]
fn nearest_index_matches_brute_force() {
    let mut r = rng();
    // Clustered data (most points in a small ball, a few far away) stresses the ring search.
    let mut points: Vec<Vec3> = (0..2000)
        .map(|_| Vec3::new(r.random(), r.random(), r.random()) * 0.05)
        .collect();
    points.extend((0..50).map(|_| Vec3::new(r.random(), r.random(), r.random()) * 2.0 - 1.0));
    let index = NearestIndex::new(&points);
    for _ in 0..2000 {
        // Queries inside and well outside the points' bounding box.
        let q = (Vec3::new(r.random(), r.random(), r.random()) * 2.0 - 1.0) * 1.5;
        let (i, d) = index.nearest(q).unwrap();
        let exact = brute_nearest(&points, q);
        assert!((d - exact).abs() < 1e-6, "{q}: {d} vs {exact}");
        assert!((points[i].distance(q) - d).abs() < 1e-6);
        // The bounded query agrees with the distance, on both sides of it.
        for radius in [0.01, 0.1, 0.5] {
            if (exact - radius).abs() > 1e-5 {
                assert_eq!(index.within(q, radius), exact <= radius, "{q} r={radius}");
            }
        }
    }
    assert!(NearestIndex::new(&[]).nearest(Vec3::ZERO).is_none());
    assert!(!NearestIndex::new(&[]).within(Vec3::ZERO, 1.0));
    let one = NearestIndex::new(&[Vec3::ONE]);
    assert_eq!(one.nearest(Vec3::ZERO).unwrap().0, 0);
}

/// Points and outward normals of a sphere of radius `r`, fine enough that sampling gaps are
/// small against the distances tested.
fn sphere(r: f32, n: usize, seed: u64) -> SurfaceSample {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut s = SurfaceSample::default();
    while s.points.len() < n {
        let v = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
        if v.length() > 0.1 && v.length() <= 1.0 {
            s.points.push(v.normalize() * r);
            s.normals.push(v.normalize());
        }
    }
    s
}

#[test]
fn identical_surfaces_score_perfectly() {
    let s = sphere(0.4, 3000, 1);
    let m = surface_metrics(&s, &s, 0.01);
    assert_eq!(m.chamfer_l1, 0.0);
    assert_eq!(m.fscore, 1.0);
    assert!((m.normal_consistency - 1.0).abs() < 1e-6);
}

#[test]
fn concentric_spheres_are_their_gap_apart() {
    let (r, gap) = (0.3, 0.05);
    let pred = sphere(r + gap, 20_000, 2);
    let gt = sphere(r, 20_000, 3);
    let m = surface_metrics(&pred, &gt, 0.01);
    // Every nearest distance is at least the gap, and sampling adds little at this density.
    assert!(
        m.accuracy >= gap - 1e-5 && m.accuracy < gap + 0.006,
        "{m:?}"
    );
    assert!(
        m.completeness >= gap - 1e-5 && m.completeness < gap + 0.006,
        "{m:?}"
    );
    assert_eq!(
        m.fscore, 0.0,
        "no point is within τ = 0.01 of a surface 0.05 away"
    );
    assert!(m.normal_consistency > 0.99, "{m:?}");
    // With τ beyond the gap, almost every point counts.
    assert!(surface_metrics(&pred, &gt, 0.07).fscore > 0.99);
    // A sphere against itself rotated by 90° about z: normals stay consistent, distances small.
    let turned = SurfaceSample {
        points: gt
            .points
            .iter()
            .map(|p| Vec3::new(-p.y, p.x, p.z))
            .collect(),
        normals: gt
            .normals
            .iter()
            .map(|p| Vec3::new(-p.y, p.x, p.z))
            .collect(),
    };
    let m = surface_metrics(&turned, &gt, 0.01);
    assert!(m.chamfer_l1 < 0.005 && m.fscore > 0.9, "{m:?}");
}

#[test]
fn crossed_planes_have_zero_normal_consistency() {
    // A plane sampled with normal z against the same points claiming normal x.
    let mut rng = rng();
    let pts: Vec<Vec3> = (0..500)
        .map(|_| Vec3::new(rng.random(), rng.random(), 0.0))
        .collect();
    let a = SurfaceSample {
        points: pts.clone(),
        normals: vec![Vec3::Z; pts.len()],
    };
    let b = SurfaceSample {
        points: pts,
        normals: vec![Vec3::X; a.points.len()],
    };
    let m = surface_metrics(&a, &b, 0.01);
    assert_eq!(m.normal_consistency, 0.0);
    assert_eq!(m.chamfer_l1, 0.0);
}

#[test]
fn an_empty_prediction_scores_worst() {
    let gt = sphere(0.3, 100, 4);
    let m = surface_metrics(&SurfaceSample::default(), &gt, 0.01);
    assert_eq!(m.chamfer_l1, EMPTY_CHAMFER);
    assert_eq!(m.fscore, 0.0);
    assert_eq!(m.normal_consistency, 0.0);
}
