//! Statistical tests of both importance samplers against their densities, and of the cache.

use std::sync::Arc;

use fieldprobe_core::data::Silhouette;
use fieldprobe_core::data::grid::VoxelGrid;
use fieldprobe_core::data::hull::{HullTest, visual_hull};
use fieldprobe_core::geometry::PixelPos;
use fieldprobe_core::probe::sampler::on_image;
use fieldprobe_core::probe::{
    AnchorSampler, AnchorSamplerConfig, RaySampler, RaySamplerConfig, Supervision,
};
use glam::Vec3;

use super::anchors::object_key;
use super::*;
use crate::test_support::{assert_even_quadrants, blank};
use crate::{UniformAnchors, UniformRays};
use fieldprobe_core::geometry::Camera;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// A disc of radius `radius` pixels centred at `(col, row)` with value `value`, anti-aliased by
/// 8×8 supersampling, added onto `s`.
fn add_disc(s: &mut Silhouette, col: f32, row: f32, radius: f32, value: f32) {
    let n = s.size;
    for r in 0..n {
        for c in 0..n {
            let mut hits = 0;
            for k in 0..64 {
                let x = c as f32 - 0.5 + ((k % 8) as f32 + 0.5) / 8.0;
                let y = r as f32 - 0.5 + ((k / 8) as f32 + 0.5) / 8.0;
                hits += ((x - col).hypot(y - row) < radius) as u32;
            }
            s.values_mut()[r * n + c] += value * hits as f32 / 64.0;
        }
    }
}

fn disc_object(col: f32, row: f32, radius: f32) -> Supervision {
    let mut s = Silhouette::empty(64);
    add_disc(&mut s, col, row, radius, 1.0);
    Supervision::nmr(vec![s; 24])
}

/// The 24 NMR silhouettes of a sphere, by exact ray–sphere tests at 4×4 points per pixel.
fn sphere_object(centre: Vec3, radius: f32) -> Supervision {
    let sils = Camera::nmr_views()
        .iter()
        .map(|cam| {
            let n = cam.image_size;
            let mut s = Silhouette::empty(n);
            for r in 0..n {
                for c in 0..n {
                    let mut hits = 0;
                    for k in 0..16 {
                        let px = PixelPos {
                            col: c as f32 - 0.375 + (k % 4) as f32 * 0.25,
                            row: r as f32 - 0.375 + (k / 4) as f32 * 0.25,
                        };
                        hits += cam.ray(px).sphere_interval(centre, radius).is_some() as u32;
                    }
                    s.values_mut()[r * n + c] = hits as f32 / 16.0;
                }
            }
            s
        })
        .collect();
    Supervision::nmr(sils)
}

/// Upper `z`-quantile of χ²(dof) by Wilson–Hilferty (`z = 3.72`: p ≈ 1e-4).
fn chi2_bound(dof: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// `χ²` of observed counts against expected probabilities (which sum to 1).
fn chi2(counts: &[usize], probs: &[f64]) -> f64 {
    let n: usize = counts.iter().sum();
    counts
        .iter()
        .zip(probs)
        .map(|(&c, &p)| {
            let e = p * n as f64;
            (c as f64 - e).powi(2) / e
        })
        .sum()
}

fn anchors(config: ImportanceAnchors) -> ImportanceAnchorSampler {
    ImportanceAnchorSampler::new(config).unwrap()
}

/// `k` successes of `n` draws are within 4 standard deviations of a Binomial(n, p).
fn assert_binomial(k: f64, n: usize, p: f64) {
    let sd = (n as f64 * p * (1.0 - p)).sqrt();
    assert!(
        (k - n as f64 * p).abs() < 4.0 * sd,
        "{k} vs {}",
        n as f64 * p
    );
}

#[test]
fn normal_pair_is_two_independent_standard_normals() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let n = 200_000;
    let xy: Vec<(f32, f32)> = (0..n).map(|_| normal_pair(&mut rng)).collect();
    let m = |f: &dyn Fn(&(f32, f32)) -> f32| xy.iter().map(f).sum::<f32>() / n as f32;
    assert!(m(&|p| p.0).abs() < 0.01 && m(&|p| p.1).abs() < 0.01);
    assert!((m(&|p| p.0 * p.0) - 1.0).abs() < 0.02);
    assert!((m(&|p| p.1 * p.1) - 1.0).abs() < 0.02);
    assert!(m(&|p| p.0 * p.1).abs() < 0.01);
    // Independence: P(|x| < 1, |y| < 1) = 0.6827².
    let both = m(&|p| (p.0.abs() < 1.0 && p.1.abs() < 1.0) as u8 as f32);
    assert!((both - 0.4661).abs() < 0.005, "{both}");
}

#[test]
fn contour_map_is_the_absolute_laplacian_with_edge_replication() {
    let mut s = Silhouette::empty(5);
    s.values_mut()[2 * 5 + 2] = 1.0;
    let w = contour_map(&s);
    assert_eq!(w[2 * 5 + 2], 4.0);
    for i in [5 + 2, 3 * 5 + 2, 2 * 5 + 1, 2 * 5 + 3] {
        assert_eq!(w[i], 1.0);
    }
    assert_eq!(w.iter().sum::<f32>(), 8.0);
    // A half-covered image has its contour only along the step, not at the frame.
    let mut half = Silhouette::empty(6);
    for r in 0..6 {
        for c in 0..3 {
            half.values_mut()[r * 6 + c] = 0.5;
        }
    }
    let w = contour_map(&half);
    for r in 0..6 {
        assert_eq!(&w[r * 6..r * 6 + 6], &[0.0, 0.0, 0.5, 0.5, 0.0, 0.0]);
    }
    let full = Silhouette::from_values(6, vec![1.0; 36]);
    assert!(contour_map(&full).iter().all(|&v| v == 0.0));
}

#[test]
fn importance_rays_stay_near_the_contour() {
    // Disc of radius 16 px at the image centre; the paper's σ = 0.007 (0.224 px). Kernels sit
    // on pixels next to the contour (centres within ~1.7 px of it), plus ≤ 0.71 px of jitter.
    let (c0, radius) = (31.5f32, 16.0f32);
    let sup = disc_object(c0, c0, radius);
    let sigma_px = 0.007 * 32.0;
    let within = |pts: &[PixelPos], px: f32| {
        let d = |p: &&PixelPos| ((p.col - c0).hypot(p.row - c0) - radius).abs();
        pts.iter().filter(|p| d(p) < 3.0 * sigma_px + px).count() as f32 / pts.len() as f32
    };
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let px = ImportanceRays::default().sample_pixels(&sup, 3, 20_000, &mut rng);
    assert_eq!(px.len(), 20_000);
    assert!(px.iter().all(|p| on_image(*p, 64)));
    let (one, two) = (within(&px, 1.0), within(&px, 2.0));
    assert!(one >= 0.95 && two >= 0.999, "{one} {two}");
    // Uniform rays: the annulus 2·(3σ + 1 px) wide is ≈ 8.2% of the image.
    let uni = UniformRays {}.sample_pixels(&sup, 3, 20_000, &mut rng);
    let uni = within(&uni, 1.0);
    assert!((0.07..0.095).contains(&uni), "uniform {uni}");
    // Symmetric about the contour: as many samples inside the disc as outside.
    let inside = px
        .iter()
        .filter(|p| (p.col - c0).hypot(p.row - c0) < radius)
        .count() as f32;
    assert!((inside / 20_000.0 - 0.5).abs() < 0.05, "{inside}");
}

#[test]
fn importance_rays_bandwidth_is_in_ndc_units() {
    // One bright pixel: weights 4 (centre) and 1 on each 4-neighbour. Per axis the offset
    // from the centre has variance 2/8 (neighbours) + 1/12 (pixel jitter) + σ_px², with
    // σ_px = σ·S/2 = 0.1·32 = 3.2 pixels.
    let mut s = Silhouette::empty(64);
    s.values_mut()[32 * 64 + 32] = 1.0;
    let sup = Supervision::nmr(vec![s; 24]);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let rays = ImportanceRays {
        bandwidth: 0.1,
        uniform_fraction: 0.0,
    };
    let px = rays.sample_pixels(&sup, 0, 40_000, &mut rng);
    let n = px.len() as f32;
    let expected = 0.25 + 1.0 / 12.0 + 3.2 * 3.2;
    for coord in [
        px.iter().map(|p| p.col - 32.0).collect::<Vec<_>>(),
        px.iter().map(|p| p.row - 32.0).collect(),
    ] {
        let mean = coord.iter().sum::<f32>() / n;
        let var = coord.iter().map(|d| d * d).sum::<f32>() / n;
        assert!(mean.abs() < 0.07, "{mean}");
        assert!((var - expected).abs() < 0.35, "{var} vs {expected}");
    }
}

#[test]
fn importance_rays_follow_the_contour_weights_per_pixel() {
    // With a negligible σ every sample stays in the pixel of its kernel, so the counts per
    // pixel are multinomial with probabilities W_r / ΣW_r: a χ² test over the contour pixels.
    let sup = disc_object(30.2, 33.7, 11.3);
    let w = contour_map(&sup.silhouettes[0]);
    let total: f64 = w.iter().map(|&v| v as f64).sum();
    let rays = ImportanceRays {
        bandwidth: 1e-9,
        uniform_fraction: 0.0,
    };
    let n = 200_000;
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut counts = vec![0usize; 64 * 64];
    for p in rays.sample_pixels(&sup, 0, n, &mut rng) {
        counts[p.row.round() as usize * 64 + p.col.round() as usize] += 1;
    }
    // Only f32 rounding onto a pixel edge (about one in 10⁵ samples here) can put a sample
    // in a neighbouring pixel, possibly one without weight.
    let stray: usize = counts
        .iter()
        .zip(&w)
        .filter(|(_, w)| **w == 0.0)
        .map(|(c, _)| c)
        .sum();
    assert!(stray <= 4, "{stray} samples in pixels without weight");
    // Bins with at least 5 expected samples, the rest pooled.
    let (mut obs, mut probs, mut rest) = (Vec::new(), Vec::new(), (0usize, 0.0f64));
    for (&c, &wi) in counts.iter().zip(&w) {
        let p = wi as f64 / total;
        if p * n as f64 >= 5.0 {
            obs.push(c);
            probs.push(p);
        } else if wi > 0.0 {
            rest.0 += c;
            rest.1 += p;
        }
    }
    if rest.1 > 0.0 {
        obs.push(rest.0);
        probs.push(rest.1);
    }
    let dof = (obs.len() - 1) as f64;
    assert!(dof > 150.0, "{dof}");
    let x2 = chi2(&obs, &probs);
    assert!(x2 < chi2_bound(dof, 3.72), "χ² = {x2} with {dof} dof");
}

#[test]
fn importance_rays_split_between_regions_as_their_summed_weights() {
    // Two identical discs, one of value 1 and one of value 0.5, whole pixels apart: the
    // second's |Laplacian| is exactly half the first's, so P(left) = 2/3.
    let mut s = Silhouette::empty(64);
    add_disc(&mut s, 16.0, 31.5, 10.0, 1.0);
    add_disc(&mut s, 47.0, 31.5, 10.0, 0.5);
    let w = contour_map(&s);
    let (mut left, mut right) = (0.0f64, 0.0f64);
    for (i, &v) in w.iter().enumerate() {
        if i % 64 < 32 {
            left += v as f64;
        } else {
            right += v as f64;
        }
    }
    assert!((left / right - 2.0).abs() < 1e-4, "{left} {right}");
    let sup = Supervision::nmr(vec![s; 24]);
    let n = 30_000;
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let px = ImportanceRays::default().sample_pixels(&sup, 5, n, &mut rng);
    let k = px.iter().filter(|p| p.col < 31.5).count() as f64;
    let (p, nf) = (2.0 / 3.0, n as f64);
    let sd = (nf * p * (1.0 - p)).sqrt();
    assert!((k - nf * p).abs() < 4.0 * sd, "{k} vs {}", nf * p);
}

#[test]
fn importance_rays_fall_back_to_uniform_without_contour() {
    let full = Supervision::nmr(vec![Silhouette::from_values(64, vec![1.0; 64 * 64]); 24]);
    for (seed, sup) in [(14, blank()), (15, full)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let px = ImportanceRays::default().sample_pixels(&sup, 0, 64_000, &mut rng);
        assert!(px.iter().all(|p| on_image(*p, 64)));
        assert_even_quadrants(&px);
    }
}

#[test]
fn importance_rays_uniform_fraction_mixes_in_uniform_pixels() {
    // Far from a small disc (> 10 px from its contour) only uniform draws land: a fraction
    // f·P_uniform(far) of all rays.
    let sup = disc_object(31.5, 31.5, 8.0);
    let far = |p: &PixelPos| ((p.col - 31.5).hypot(p.row - 31.5) - 8.0).abs() > 10.0;
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    let uni = UniformRays {}.sample_pixels(&sup, 0, 100_000, &mut rng);
    let p_far = uni.iter().filter(|p| far(p)).count() as f64 / 100_000.0;
    let rays = ImportanceRays {
        bandwidth: 0.007,
        uniform_fraction: 0.25,
    };
    let n = 40_000;
    let k = rays
        .sample_pixels(&sup, 0, n, &mut rng)
        .iter()
        .filter(|p| far(p))
        .count() as f64;
    assert_binomial(k, n, 0.25 * p_far);
}

#[test]
fn importance_anchors_concentrate_on_the_hull_boundary() {
    // Sphere of radius 0.3: near its equator the 24-view hull is the sphere to within 1%,
    // so anchors there must lie within a few voxels of |p| = 0.3, unlike uniform anchors.
    let (r, sup) = (0.3f32, sphere_object(Vec3::ZERO, 0.3));
    let sampler = anchors(ImportanceAnchors::default());
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    let a = sampler.sample_anchors(&sup, 16_000, &mut rng);
    assert_eq!(a.len(), 16_000);
    let voxel = 1.0 / 31.0;
    // Within one voxel (+3σ) of the sphere; the shell's kernels are within ~1.7 voxels of
    // the hull boundary, so the rest lies within ~2.
    let tol = voxel + 3.0 * 0.007;
    let band = |p: &&Vec3| p.y.abs() < 0.1;
    let near_frac = |pts: &[Vec3]| {
        let eq: Vec<&Vec3> = pts.iter().filter(band).collect();
        let near = eq.iter().filter(|p| (p.length() - r).abs() < tol).count();
        (near as f32 / eq.len() as f32, eq.len())
    };
    let (imp, n_eq) = near_frac(&a);
    assert!(n_eq > 2_000, "{n_eq}");
    assert!(imp >= 0.95, "importance {imp}");
    let all = a
        .iter()
        .filter(band)
        .filter(|p| (p.length() - r).abs() < 2.0 * voxel + 0.021);
    assert_eq!(all.count(), n_eq);
    let uni = UniformAnchors { extent: 0.5 }.sample_anchors(&sup, 16_000, &mut rng);
    let (uni, _) = near_frac(&uni);
    assert!(uni < 0.25, "uniform {uni}");
    // The radial offset is centred on the surface and about a voxel wide.
    let d: Vec<f32> = a.iter().filter(band).map(|p| p.length() - r).collect();
    let mean = d.iter().sum::<f32>() / d.len() as f32;
    let rms = (d.iter().map(|x| x * x).sum::<f32>() / d.len() as f32).sqrt();

    assert!(mean.abs() < 0.3 * voxel, "mean {mean}");
    assert!(rms < 1.2 * voxel, "rms {rms}");
    // A finer hull gives a thinner shell.
    let fine = anchors(ImportanceAnchors {
        resolution: 64,
        ..Default::default()
    });
    let a64 = fine.sample_anchors(&sup, 16_000, &mut rng);
    let d64: Vec<f32> = a64.iter().filter(band).map(|p| p.length() - r).collect();
    let rms64 = (d64.iter().map(|x| x * x).sum::<f32>() / d64.len() as f32).sqrt();
    assert!(rms64 < 0.7 * rms, "{rms64} vs {rms}");
}

#[test]
fn hull_contour_weights_are_4m_1_minus_m_of_the_box_mean() {
    // One occupied voxel: its 27-neighbourhood has m = 1/27 everywhere, the rest m = 0.
    let mut g = VoxelGrid::empty(6);
    g.set(2, 3, 4, true);
    let w = hull_contour_weights(&g);
    let expected = 4.0 * (1.0 / 27.0) * (26.0 / 27.0);
    for i in 0..6usize {
        for j in 0..6usize {
            for k in 0..6usize {
                let inside = i.abs_diff(2) <= 1 && j.abs_diff(3) <= 1 && k.abs_diff(4) <= 1;
                let v = w[g.index(i, j, k)];
                assert!((v - if inside { expected } else { 0.0 }).abs() < 1e-6);
            }
        }
    }
    // A half-space x < 3: m = 1/3 at x = 3 (w = 8/9), 2/3 at x = 2 (w = 8/9). The outside of
    // the grid counts as empty, so the grid's face x = 0 is a contour too (m = 2/3).
    let g = VoxelGrid::from_fn(6, |i, _, _, _| i < 3);
    let w = hull_contour_weights(&g);
    for i in 0..6 {
        let v = w[g.index(i, 2, 2)];
        let e = if i == 0 || i == 2 || i == 3 {
            8.0 / 9.0
        } else {
            0.0
        };
        assert!((v - e).abs() < 1e-6, "x = {i}: {v}");
    }
}

#[test]
fn importance_anchors_follow_the_contour_weights() {
    // Negligible σ keeps each anchor in its kernel's voxel: the counts per weight level
    // (voxels with the same m, pooled) match the summed weights (χ²), and no anchor falls
    // in a voxel without weight.
    let sup = sphere_object(Vec3::new(0.05, -0.02, 0.03), 0.27);
    let hull = visual_hull(&sup.silhouettes, &sup.cameras, 32, HullTest::Centre);
    let w = hull_contour_weights(&hull);
    let sampler = anchors(ImportanceAnchors {
        bandwidth: 1e-7,
        ..Default::default()
    });
    let n = 100_000;
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let pts = sampler.sample_anchors(&sup, n, &mut rng);
    // Level of a voxel: its weight, as one of the 13 values 4c(27 − c)/27², c = 1..=13.
    let level = |v: f32| {
        (1..=13)
            .find(|&c| (v - 4.0 * (c * (27 - c)) as f32 / 729.0).abs() < 1e-5)
            .map(|c| c - 1)
    };
    let (mut probs, mut counts) = (vec![0.0f64; 13], vec![0usize; 13]);
    let total: f64 = w.iter().map(|&v| v as f64).sum();
    for &v in &w {
        if v > 0.0 {
            probs[level(v).expect("a weight off the levels")] += v as f64 / total;
        }
    }
    for p in &pts {
        let g = hull.frame.to_grid(*p).floor();
        let (i, j, k) = (g.x as usize, g.y as usize, g.z as usize);
        let v = w[hull.index(i, j, k)];
        assert!(v > 0.0, "anchor {p:?} in a voxel without weight");
        counts[level(v).unwrap()] += 1;
    }
    let (obs, probs): (Vec<usize>, Vec<f64>) = counts
        .into_iter()
        .zip(probs)
        .filter(|&(_, p)| p > 0.0)
        .unzip();
    let dof = (obs.len() - 1) as f64;
    assert!(dof >= 8.0, "{dof}");
    let x2 = chi2(&obs, &probs);
    assert!(x2 < chi2_bound(dof, 3.72), "χ² = {x2} with {dof} dof");
    // And between the two halves x < centre / x ≥ centre: binomial.
    // Voxels i < 16 span x < 0 (voxel 16's centre is at 0.5/31).
    let cx = 0.0;
    let p_left: f64 = (0..32 * 32 * 32)
        .filter(|i| i / (32 * 32) < 16)
        .map(|i| w[i] as f64 / total)
        .sum();
    let k = pts.iter().filter(|p| p.x < cx).count() as f64;
    let sd = (n as f64 * p_left * (1.0 - p_left)).sqrt();
    assert!((k - n as f64 * p_left).abs() < 4.0 * sd, "{k} vs {p_left}");
}

#[test]
fn importance_anchor_bandwidth_is_in_world_units() {
    // A single occupied voxel: 27 equal kernels on the voxel offsets {-1, 0, 1}³, so per axis
    // the variance is (2/3)·v² + v²/12 (voxel jitter) + σ².
    let mut g = VoxelGrid::empty(32);
    g.set(16, 16, 16, true);
    let m = HullContour::from_hull(&g);
    assert_eq!(m.len(), 27);
    let c = g.frame.centre(16, 16, 16);
    let (v, sigma) = (1.0f32 / 31.0, 0.05f32);
    let expected = (2.0 / 3.0 + 1.0 / 12.0) * v * v + sigma * sigma;
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let n = 50_000;
    let pts: Vec<Vec3> = (0..n).map(|_| m.sample(sigma, &mut rng) - c).collect();
    let mean = pts.iter().copied().sum::<Vec3>() / n as f32;
    let var = pts.iter().map(|p| *p * *p).sum::<Vec3>() / n as f32;
    assert!(mean.abs().max_element() < 0.002, "{mean:?}");
    assert!(
        (var - Vec3::splat(expected)).abs().max_element() < 0.04 * expected,
        "{var:?} vs {expected}"
    );
}

#[test]
fn importance_anchors_fall_back_to_uniform_on_an_empty_hull() {
    let sampler = anchors(ImportanceAnchors::default());
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let a = sampler.sample_anchors(&blank(), 50_000, &mut rng);
    assert!(a.iter().all(|p| p.abs().max_element() <= 0.5));
    let n = a.len() as f32;
    let mean = a.iter().copied().sum::<Vec3>() / n;
    let var = a.iter().map(|p| (*p - mean) * (*p - mean)).sum::<Vec3>() / n;
    assert!(mean.abs().max_element() < 0.01, "{mean:?}");
    assert!(
        (var - Vec3::splat(1.0 / 12.0)).abs().max_element() < 0.003,
        "{var:?}"
    );
}

#[test]
fn importance_anchors_uniform_fraction_mixes_in_uniform_points() {
    // Far from the sphere's hull (|p| < 0.1 or a corner region) only uniform draws land.
    let sup = sphere_object(Vec3::ZERO, 0.3);
    let far = |p: &Vec3| p.length() < 0.12 || p.length() > 0.55;
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    let p_far = (0..200_000)
        .filter(|_| far(&UniformAnchors::default().point(&mut rng)))
        .count() as f64
        / 200_000.0;
    let sampler = anchors(ImportanceAnchors {
        uniform_fraction: 0.3,
        ..Default::default()
    });
    let n = 40_000;
    let k = sampler
        .sample_anchors(&sup, n, &mut rng)
        .iter()
        .filter(|p| far(p))
        .count() as f64;
    assert_binomial(k, n, 0.3 * p_far);
}

#[test]
fn importance_samplers_are_deterministic_and_the_cache_changes_nothing() {
    let sup = sphere_object(Vec3::new(0.0, 0.05, 0.0), 0.25);
    let cached = anchors(ImportanceAnchors::default());
    let uncached = anchors(ImportanceAnchors {
        cache_objects: 0,
        ..Default::default()
    });
    let run = |s: &dyn AnchorSampler, seed| {
        s.sample_anchors(&sup, 2_000, &mut ChaCha8Rng::seed_from_u64(seed))
    };
    let cold = run(&cached, 30);
    assert_eq!(cached.cached_objects(), 1);
    assert_eq!(run(&cached, 30), cold, "warm cache");
    assert_eq!(run(&uncached, 30), cold, "no cache");
    assert_eq!(uncached.cached_objects(), 0);
    assert_ne!(run(&cached, 31), cold);
    let rays = ImportanceRays::default();
    let px = |seed| rays.sample_pixels(&sup, 7, 2_000, &mut ChaCha8Rng::seed_from_u64(seed));
    assert_eq!(px(32), px(32));
    assert_ne!(px(32), px(33));
}

#[test]
fn importance_anchor_cache_is_bounded_first_in_first_out() {
    let sampler = anchors(ImportanceAnchors {
        resolution: 8,
        cache_objects: 2,
        ..Default::default()
    });
    let objects: Vec<Supervision> = [0.2f32, 0.25, 0.3]
        .iter()
        .map(|&r| sphere_object(Vec3::ZERO, r))
        .collect();
    let first = sampler.contour(&objects[0]);
    assert!(Arc::ptr_eq(&first, &sampler.contour(&objects[0])));
    sampler.contour(&objects[1]);
    sampler.contour(&objects[2]);
    assert_eq!(sampler.cached_objects(), 2);
    // The oldest was evicted: recomputed, equal but not the same allocation.
    let again = sampler.contour(&objects[0]);
    assert!(!Arc::ptr_eq(&first, &again));
    assert_eq!(*first, *again);
}

#[test]
fn importance_configs_validate_their_fields() {
    let bad_rays = [
        (
            ImportanceRays {
                bandwidth: 0.0,
                ..Default::default()
            },
            "bandwidth",
        ),
        (
            ImportanceRays {
                bandwidth: f32::NAN,
                ..Default::default()
            },
            "bandwidth",
        ),
        (
            ImportanceRays {
                uniform_fraction: 1.5,
                ..Default::default()
            },
            "uniform_fraction",
        ),
    ];
    for (c, field) in bad_rays {
        let e = c.build().unwrap_err();
        assert!(e.contains(field), "{e}");
    }
    let bad_anchors = [
        (
            ImportanceAnchors {
                bandwidth: -1.0,
                ..Default::default()
            },
            "bandwidth",
        ),
        (
            ImportanceAnchors {
                resolution: 2,
                ..Default::default()
            },
            "resolution",
        ),
        (
            ImportanceAnchors {
                uniform_fraction: -0.1,
                ..Default::default()
            },
            "uniform_fraction",
        ),
    ];
    for (c, field) in bad_anchors {
        let e = c.build().unwrap_err();
        assert!(e.contains(field), "{e}");
    }
    assert!(ImportanceRays::default().build().is_ok());
    assert!(ImportanceAnchors::default().build().is_ok());
    // Omitted fields take the documented defaults; unknown fields are errors.
    let r: ImportanceRays = toml::from_str("").unwrap();
    assert_eq!((r.bandwidth, r.uniform_fraction), (0.007, 0.0));
    let a: ImportanceAnchors = toml::from_str("resolution = 64").unwrap();
    assert_eq!(
        a,
        ImportanceAnchors {
            bandwidth: 0.007,
            resolution: 64,
            uniform_fraction: 0.0,
            cache_objects: 4096
        }
    );
    let e = toml::from_str::<ImportanceAnchors>("sigma = 0.1").unwrap_err();
    assert!(e.to_string().contains("sigma"), "{e}");
}

/// Timings of the paper's workload (printed; run with `--nocapture`): 4096 rays in one view,
/// 24 such views, and 16000 anchors with a cold and a warm cache, next to the uniform
/// samplers.
#[test]
fn importance_sampling_timings() {
    let sup = sphere_object(Vec3::ZERO, 0.3);
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let rays = ImportanceRays::default();
    let t = Instant::now();
    let px = rays.sample_pixels(&sup, 0, 4096, &mut rng);
    let one_view = t.elapsed();
    let t = Instant::now();
    for v in 0..24 {
        rays.sample_pixels(&sup, v, 4096, &mut rng);
    }
    let all_views = t.elapsed();
    assert_eq!(px.len(), 4096);
    for resolution in [32, 64] {
        let sampler = anchors(ImportanceAnchors {
            resolution,
            ..Default::default()
        });
        let t = Instant::now();
        let a = sampler.sample_anchors(&sup, 16_000, &mut rng);
        let cold = t.elapsed();
        let t = Instant::now();
        sampler.sample_anchors(&sup, 16_000, &mut rng);
        let warm = t.elapsed();
        let t = Instant::now();
        object_key(&sup);
        let key = t.elapsed();
        let m = sampler.contour(&sup);
        eprintln!(
            "importance anchors {resolution}³: 16000 cold {cold:?}, warm {warm:?} \
             (of which key hash {key:?}); {} kernels, {} kB",
            m.len(),
            m.bytes() / 1024
        );
        // No timing assertion (a loaded machine makes any flaky); the warm call was a hit.
        assert_eq!(a.len(), 16_000);
        assert_eq!(sampler.cached_objects(), 1);
    }
    let t = Instant::now();
    UniformAnchors::default().sample_anchors(&sup, 16_000, &mut rng);
    let uniform_anchors = t.elapsed();
    let t = Instant::now();
    for v in 0..24 {
        UniformRays {}.sample_pixels(&sup, v, 4096, &mut rng);
    }
    let uniform_rays = t.elapsed();
    eprintln!(
        "importance rays: 4096 in one view {one_view:?}, 24 × 4096 {all_views:?}; \
         uniform: 16000 anchors {uniform_anchors:?}, 24 × 4096 rays {uniform_rays:?}"
    );
}
