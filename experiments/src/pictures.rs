//! Pictures of a model's predictions: turntables of extracted meshes, predicted-vs-true
//! silhouette overlays, input images, and the per-run gallery that puts them side by side.

use glam::Vec3;
use image::{Rgb, RgbImage};

use fieldprobe_core::data::Silhouette;
use fieldprobe_core::data::TriMesh;
use fieldprobe_core::data::render::{RenderOptions, render};
use fieldprobe_core::geometry::Camera;
use fieldprobe_core::geometry::camera::{NMR_DISTANCE, NMR_ELEVATION_DEG};

use crate::plot;

/// Overlay colours: both (true positive), predicted only, ground truth only.
pub const BOTH: Rgb<u8> = Rgb([90, 90, 90]);
pub const PREDICTED_ONLY: Rgb<u8> = Rgb([220, 60, 50]);
pub const TRUTH_ONLY: Rgb<u8> = Rgb([60, 110, 220]);

/// `frames` views of `mesh` at `size` pixels, the camera orbiting at NMR's distance and
/// elevation in equal azimuth steps starting at view 0's, shaded, over white. An empty mesh gives
/// white frames crossed out, so that "nothing predicted" is visible.
pub fn turntable(mesh: &TriMesh, frames: usize, size: usize) -> Vec<RgbImage> {
    (0..frames)
        .map(|f| {
            let azimuth = 360.0 * f as f32 / frames as f32;
            let cam = Camera::orbit(NMR_DISTANCE, NMR_ELEVATION_DEG, azimuth, size);
            if mesh.faces.is_empty() {
                let mut img = RgbImage::from_pixel(size as u32, size as u32, plot::WHITE);
                let s = size as f64;
                plot::line(&mut img, (0.0, 0.0), (s, s), 1, PREDICTED_ONLY);
                plot::line(&mut img, (0.0, s), (s, 0.0), 1, PREDICTED_ONLY);
                return img;
            }
            let view = render(mesh, &cam, &RenderOptions::default());
            let px: Vec<Vec3> = view.over_white().collect();
            RgbImage::from_fn(size as u32, size as u32, |x, y| {
                let c = px[y as usize * size + x as usize];
                Rgb(c
                    .to_array()
                    .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
            })
        })
        .collect()
}

/// The turntable frames side by side in one strip.
pub fn turntable_strip(mesh: &TriMesh, frames: usize, size: usize) -> RgbImage {
    plot::grid(&[turntable(mesh, frames, size)], 2, plot::WHITE)
}

/// A predicted silhouette against the true one at `zoom`×: grey where both cover a pixel, red
/// where only the prediction does, blue where only the truth does (coverage ≥ ½).
pub fn silhouette_overlay(pred: &Silhouette, truth: &Silhouette, zoom: u32) -> RgbImage {
    assert_eq!(pred.size, truth.size, "silhouette sizes");
    let s = pred.size as u32;
    RgbImage::from_fn(s * zoom, s * zoom, |x, y| {
        let i = ((y / zoom) * s + x / zoom) as usize;
        match (pred.get(i) >= 0.5, truth.get(i) >= 0.5) {
            (true, true) => BOTH,
            (true, false) => PREDICTED_ONLY,
            (false, true) => TRUTH_ONLY,
            (false, false) => plot::WHITE,
        }
    })
}

/// An input view stored in Kato's planes (`[4, S, S]`, RGB inverted) as a natural-colour image at
/// `zoom`×.
pub fn input_image(planes: &[u8], size: usize, zoom: u32) -> RgbImage {
    let plane = size * size;
    let s = size as u32;
    RgbImage::from_fn(s * zoom, s * zoom, |x, y| {
        let p = ((y / zoom) * s + x / zoom) as usize;
        Rgb([0, 1, 2].map(|ch| 255 - planes[ch * plane + p]))
    })
}

/// An input view stored in Kato's planes as an RGBA picture (straight alpha, colour un-composited
/// from white), the form `reconstruct` reads back: a test image users can feed to a model.
pub fn input_rgba(planes: &[u8], size: usize) -> image::RgbaImage {
    let plane = size * size;
    let s = size as u32;
    image::RgbaImage::from_fn(s, s, |x, y| {
        let p = (y * s + x) as usize;
        let a = f32::from(planes[3 * plane + p]) / 255.0;
        let c = [0, 1, 2].map(|ch| {
            let over_white = f32::from(255 - planes[ch * plane + p]) / 255.0;
            let straight = if a > 0.0 {
                (over_white - (1.0 - a)) / a
            } else {
                1.0
            };
            (straight.clamp(0.0, 1.0) * 255.0).round() as u8
        });
        image::Rgba([c[0], c[1], c[2], planes[3 * plane + p]])
    })
}

/// Scales `img` to `side × side` (nearest neighbour), so panels of different sources fit one
/// grid.
pub fn fit(img: &RgbImage, side: u32) -> RgbImage {
    image::imageops::resize(img, side, side, image::imageops::FilterType::Nearest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fieldprobe_core::data::procedural::primitives::MeshBuilder;

    #[test]
    fn overlay_colours_each_case() {
        let pred = Silhouette::from_values(2, vec![1.0, 1.0, 0.0, 0.0]);
        let truth = Silhouette::from_values(2, vec![1.0, 0.0, 1.0, 0.0]);
        let img = silhouette_overlay(&pred, &truth, 3);
        assert_eq!(img.dimensions(), (6, 6));
        assert_eq!(*img.get_pixel(0, 0), BOTH);
        assert_eq!(*img.get_pixel(5, 0), PREDICTED_ONLY);
        assert_eq!(*img.get_pixel(0, 5), TRUTH_ONLY);
        assert_eq!(*img.get_pixel(5, 5), plot::WHITE);
    }

    #[test]
    fn a_turntable_shows_the_mesh_from_every_side() {
        // A long box along x: seen along x it is small, seen from the side it is long, so the
        // frames differ in covered area the way the orbit turns.
        let mut b = MeshBuilder::default();
        b.add_box(Vec3::ZERO, Vec3::new(0.45, 0.08, 0.08));
        let frames = turntable(&b.build(), 4, 48);
        assert_eq!(frames.len(), 4);
        let covered: Vec<usize> = frames
            .iter()
            .map(|f| f.pixels().filter(|p| **p != plot::WHITE).count())
            .collect();
        assert!(covered.iter().all(|&c| c > 20), "{covered:?}");
        // Frames half a turn apart see the same outline; a quarter turn apart they differ.
        let (a, b) = (covered[0] as f64, covered[2] as f64);
        assert!((a - b).abs() / a < 0.1, "{covered:?}");
        let (lo, hi) = (
            covered[0].min(covered[1]) as f64,
            covered[0].max(covered[1]) as f64,
        );
        assert!(hi / lo > 1.5, "{covered:?}");
        // An empty mesh is crossed out, not blank.
        let empty = turntable(&TriMesh::default(), 1, 16);
        assert!(empty[0].pixels().any(|p| *p == PREDICTED_ONLY));
    }

    #[test]
    fn rgba_inputs_read_back_as_the_same_planes() {
        // A half-covered pixel of colour (200, 100, 50) over white, and an empty one.
        let size = 2;
        let mut planes = vec![0u8; 4 * 4];
        let over_white = [200.0f32, 100.0, 50.0].map(|c| c * 0.5 + 255.0 * 0.5);
        for ch in 0..3 {
            planes[ch * 4] = 255 - over_white[ch].round() as u8;
        }
        planes[3 * 4] = 128;
        let img = input_rgba(&planes, size);
        let p = img.get_pixel(0, 0);
        assert_eq!(p[3], 128);
        for (ch, want) in [200u8, 100, 50].into_iter().enumerate() {
            assert!((i32::from(p[ch]) - i32::from(want)).abs() <= 2, "{p:?}");
        }
        assert_eq!(img.get_pixel(1, 1)[3], 0);
    }

    #[test]
    fn input_images_undo_katos_inversion() {
        let size = 2;
        let mut planes = vec![0u8; 4 * 4];
        planes[0] = 255; // red channel inverted: the first pixel has no red
        let img = input_image(&planes, size, 1);
        assert_eq!(*img.get_pixel(0, 0), Rgb([0, 255, 255]));
        assert_eq!(*img.get_pixel(1, 1), Rgb([255, 255, 255]));
    }
}
