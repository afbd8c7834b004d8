//! Rendering, voxelizations and the visual hull agree with each other and with analytic shapes.

use fieldprobe_core::data::hull::{HullTest, visual_hull};
use fieldprobe_core::data::procedural::primitives::MeshBuilder;
use fieldprobe_core::data::procedural::{generate, object_rng};
use fieldprobe_core::data::render::{RenderOptions, render_nmr_views};
use fieldprobe_core::data::voxelize::{voxelize_nmr, voxelize_winding};
use fieldprobe_core::data::{Category, Silhouette, TriMesh, VoxelGrid};
use fieldprobe_core::geometry::Camera;
use glam::Vec3;

const R: usize = 32;

fn sphere(r: f32) -> TriMesh {
    let mut b = MeshBuilder::default();
    b.add_ellipsoid(Vec3::ZERO, Vec3::splat(r), 96);
    b.build()
}

fn cube(h: f32) -> TriMesh {
    let mut b = MeshBuilder::default();
    b.add_box(Vec3::ZERO, Vec3::splat(h));
    b.build()
}

fn silhouettes(mesh: &TriMesh) -> Vec<Silhouette> {
    render_nmr_views(mesh, &RenderOptions::default())
        .into_iter()
        .map(|v| v.alpha)
        .collect()
}

/// Every voxel centre the winding number puts inside projects onto the silhouette in all views.
fn assert_inside_voxels_project_inside(mesh: &TriMesh, sils: &[Silhouette], wind: &VoxelGrid) {
    let cams = Camera::nmr_views();
    let mut n = 0;
    for i in 0..R {
        for j in 0..R {
            for k in 0..R {
                if !wind.get(i, j, k) {
                    continue;
                }
                n += 1;
                let c = wind.frame.centre(i, j, k);
                for (v, cam) in cams.iter().enumerate() {
                    let (px, _) = cam.project(c);
                    // Bilinear > 0: one of the four pixels around the projection is covered.
                    assert!(
                        sils[v].bilinear(px) > 0.0,
                        "voxel {i},{j},{k} at {c:?} off the silhouette in view {v}"
                    );
                }
            }
        }
    }
    assert!(
        n > 0,
        "mesh {} faces has no inside voxels",
        mesh.faces.len()
    );
}

fn check_solid(name: &str, mesh: &TriMesh, analytic: impl Fn(Vec3) -> bool) {
    let exact = VoxelGrid::from_fn(R, |_, _, _, c| analytic(c));
    let wind = voxelize_winding(mesh, R);
    let nmr = voxelize_nmr(mesh, R);
    let sils = silhouettes(mesh);
    let hull = visual_hull(&sils, &Camera::nmr_views(), R, HullTest::Footprint);

    let iou = wind.iou(&exact);
    assert!(iou >= 0.95, "{name}: winding vs analytic IoU {iou}");
    assert_eq!(nmr.fraction_inside(&nmr), 1.0);
    assert_eq!(
        wind.fraction_inside(&nmr),
        1.0,
        "{name}: NMR voxels contain the winding voxels"
    );
    assert_eq!(
        exact.fraction_inside(&nmr),
        1.0,
        "{name}: NMR voxels contain the analytic voxels"
    );
    assert!(nmr.count() > wind.count(), "{name}: NMR voxels are dilated");
    // ... by about one voxel, not more: containment is not the trivial kind.
    let nmr_iou = nmr.iou(&exact);
    assert!(nmr_iou > 0.7, "{name}: NMR vs analytic IoU {nmr_iou}");
    let hull_iou = hull.iou(&exact);
    // A full grid would score about 0.35 here; 24 views all at 30° elevation leave the cube's hull
    // loose (0.56), the sphere's tighter (0.77).
    assert!(
        hull_iou > 0.5,
        "{name}: a convex shape's conservative hull is fairly tight, IoU {hull_iou}"
    );
    eprintln!(
        "{name}: winding IoU {iou:.3}, NMR IoU {nmr_iou:.3}, footprint hull IoU {hull_iou:.3}"
    );
    assert_eq!(
        wind.fraction_inside(&hull),
        1.0,
        "{name}: hull contains winding voxels"
    );
    assert_eq!(
        nmr.fraction_inside(&hull),
        1.0,
        "{name}: hull contains NMR voxels"
    );
    assert_inside_voxels_project_inside(mesh, &sils, &wind);
}

#[test]
fn sphere_voxelizations_and_hull() {
    check_solid("sphere", &sphere(0.45), |c| c.length() <= 0.45);
}

#[test]
fn cube_voxelizations_and_hull() {
    check_solid("cube", &cube(0.37), |c| c.abs().max_element() <= 0.37);
}

#[test]
fn centre_hull_of_a_sphere_is_tight() {
    // The centre-sampled hull of a convex shape from 24 views is close to the shape itself.
    let m = sphere(0.45);
    let hull = visual_hull(&silhouettes(&m), &Camera::nmr_views(), R, HullTest::Centre);
    let exact = VoxelGrid::from_fn(R, |_, _, _, c| c.length() <= 0.45);
    assert!(hull.iou(&exact) > 0.85, "{}", hull.iou(&exact));
    assert!(exact.fraction_inside(&hull) > 0.97);
}

#[test]
fn procedural_chair_voxels_project_inside_and_hull_cannot_carve_under_the_seat() {
    let mesh = generate(Category::Chair, &mut object_rng(0, Category::Chair, 2, 0));
    let sils = silhouettes(&mesh);
    let wind = voxelize_winding(&mesh, R);
    assert_inside_voxels_project_inside(&mesh, &sils, &wind);
    let nmr = voxelize_nmr(&mesh, R);
    let hull = visual_hull(&sils, &Camera::nmr_views(), R, HullTest::Footprint);
    assert!(
        nmr.fraction_inside(&hull) > 0.99,
        "{}",
        nmr.fraction_inside(&hull)
    );
    // All cameras look down at 30°: the hull keeps much empty space (under the seat).
    let iou = hull.iou(&nmr);
    assert!(
        iou < 0.9,
        "a chair's hull should be far from its voxels, IoU {iou}"
    );
}

#[test]
fn silhouettes_are_antialiased_and_symmetric_for_a_centred_sphere() {
    let sils = silhouettes(&sphere(0.4));
    for s in &sils {
        assert!(
            s.data.iter().any(|&a| a > 0.0 && a < 1.0),
            "edge pixels are fractional"
        );
        let area: f32 = s.data.iter().sum();
        let area0: f32 = sils[0].data.iter().sum();
        assert!(
            (area - area0).abs() / area0 < 0.01,
            "a centred sphere looks the same from every azimuth"
        );
    }
    // Projected disc area: the sphere's silhouette from distance d subtends asin(r/d).
    let cam = Camera::nmr(0);
    let half = (0.4f32 / 2.732).asin().tan() * cam.focal_px();
    let area0: f32 = sils[0].data.iter().sum();
    let disc = std::f32::consts::PI * half * half;
    assert!((area0 - disc).abs() / disc < 0.03, "{area0} vs {disc}");
}

/// The mesh metrics of a perfect prediction: a field that is exactly a procedural object's
/// occupancy, meshed as the evaluation meshes a model's field, scores mesh IoU ≈ 1 against the
/// object's NMR voxels (both are NMR voxelizations of nearly the same surface), while the grid
/// IoU (centre test) of the same field is far lower, since NMR's ground truth is dilated
/// (measured: 0.83 for this table, 0.58 for this chair, mesh IoU 1.000 for both); and at
/// 100 000 points its Chamfer-L1 is a fraction of a voxel and its F-score ≈ 1.
#[test]
fn a_perfect_field_scores_near_one_on_meshes_and_lower_on_the_centre_grid() {
    use fieldprobe_core::data::GridFrame;
    use fieldprobe_core::data::voxelize::winding_number;
    use fieldprobe_core::eval::surface::{outer_surface, sample_surface, surface_metrics};
    use fieldprobe_core::eval::{grid_points, in_domain, occupancy_grid};
    use fieldprobe_core::extract::{ExtractOptions, extract_mesh};
    use rand::SeedableRng;

    for category in [Category::Table, Category::Chair] {
        let gt = generate(category, &mut object_rng(0, category, 2, 0));
        let occupancy = |p: &[f32]| -> Vec<f32> {
            p.chunks_exact(3)
                .map(|q| (winding_number(&gt, Vec3::from_slice(q)).abs() >= 0.5) as u8 as f32)
                .collect()
        };
        let mesh = extract_mesh(&mut |p| in_domain(p, occupancy), &ExtractOptions::default());
        let truth = voxelize_nmr(&gt, R);
        let mesh_iou = voxelize_nmr(&mesh, R).iou(&truth);
        let grid_iou = occupancy_grid(&occupancy(&grid_points(R)), R).iou(&truth);
        assert!(mesh_iou > 0.9, "{category}: mesh IoU {mesh_iou}");
        assert!(
            grid_iou < mesh_iou,
            "{category}: grid {grid_iou} vs mesh {mesh_iou}"
        );
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let gt_s = outer_surface(&gt, sample_surface(&gt, 100_000, &mut rng));
        let pred_s = sample_surface(&mesh, 100_000, &mut rng);
        let m = surface_metrics(&pred_s, &gt_s, 0.01);
        let voxel = GridFrame::new(R).voxel_size();
        assert!(m.chamfer_l1 < 0.25 * voxel, "{category}: {m:?}");
        assert!(
            m.fscore > 0.8 && m.normal_consistency > 0.8,
            "{category}: {m:?}"
        );
    }
}
