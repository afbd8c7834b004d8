//! A CPU rasterizer for silhouettes and simply shaded colour images.
//!
//! Rendering is exact-coverage-by-supersampling: each output pixel is split into `s × s`
//! sub-pixels whose centres are tested against every triangle (with a depth buffer), so the alpha
//! of a pixel is the fraction of its area the shape covers (up to `1/s²`), which is how an
//! anti-aliased renderer such as Kato's produces the published silhouettes. Colour is flat
//! Lambertian shading under a head light, enough to make shapes readable; the method only uses
//! the silhouettes.

use glam::Vec3;

use super::image::Silhouette;
use super::mesh::TriMesh;
use crate::geometry::Camera;

/// Rendering options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Sub-pixels per pixel side (alpha resolution is `1/s²`). 4 by default.
    pub supersample: usize,
    /// Surface colour in `[0, 1]³`.
    pub albedo: Vec3,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            supersample: 4,
            albedo: Vec3::new(0.78, 0.74, 0.70),
        }
    }
}

/// One rendered view: coverage (alpha) and the shaded colour of the covered part.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedView {
    /// Coverage in `[0, 1]`: the silhouette.
    pub alpha: Silhouette,
    /// Mean shaded colour over the covered sub-pixels, `[0, 1]³`, row-major; black where empty.
    pub color: Vec<Vec3>,
}

impl RenderedView {
    /// The colour composited over a white background, `[0, 1]³` per pixel.
    pub fn over_white(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.color
            .iter()
            .zip(self.alpha.values())
            .map(|(&c, a)| c * a + Vec3::ONE * (1.0 - a))
    }
}

/// Renders `mesh` as seen by `camera` (at `camera.image_size`).
pub fn render(mesh: &TriMesh, camera: &Camera, opts: &RenderOptions) -> RenderedView {
    let size = camera.image_size;
    let s = opts.supersample.max(1);
    let hi = size * s;
    let hi_cam = Camera {
        image_size: hi,
        ..*camera
    };
    let face_ids = rasterize_face_ids(mesh, &hi_cam);
    let shade = face_shades(mesh, camera, opts.albedo);

    let mut alpha = Silhouette::empty(size);
    let mut color = vec![Vec3::ZERO; size * size];
    let inv = 1.0 / (s * s) as f32;
    for row in 0..size {
        for col in 0..size {
            let (mut n, mut sum) = (0usize, Vec3::ZERO);
            for sr in 0..s {
                let base = (row * s + sr) * hi + col * s;
                for &f in &face_ids[base..base + s] {
                    if f != u32::MAX {
                        n += 1;
                        sum += shade[f as usize];
                    }
                }
            }
            alpha.values_mut()[row * size + col] = n as f32 * inv;
            if n > 0 {
                color[row * size + col] = sum / n as f32;
            }
        }
    }
    RenderedView { alpha, color }
}

/// The 24 NMR views of `mesh`.
pub fn render_nmr_views(mesh: &TriMesh, opts: &RenderOptions) -> Vec<RenderedView> {
    Camera::nmr_views()
        .iter()
        .map(|c| render(mesh, c, opts))
        .collect()
}

/// Per pixel of `camera`'s image, the index of the nearest face whose interior contains the pixel
/// centre, or `u32::MAX`. Depth is interpolated perspective-correctly (linear in `1/z`).
fn rasterize_face_ids(mesh: &TriMesh, camera: &Camera) -> Vec<u32> {
    let n = camera.image_size;
    let mut ids = vec![u32::MAX; n * n];
    let mut inv_depth = vec![0.0f32; n * n];
    const NEAR: f32 = 1e-3;
    for f in 0..mesh.faces.len() {
        let tri = mesh.triangle(f);
        let p = tri.map(|v| camera.project(v));
        if p.iter().any(|(_, z)| !z.is_finite() || *z <= NEAR) {
            continue;
        }
        let (x, y, w) = (
            p.map(|(q, _)| q.col),
            p.map(|(q, _)| q.row),
            p.map(|(_, z)| 1.0 / z),
        );
        let area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
        if area.abs() < 1e-12 {
            continue;
        }
        let (lo_c, hi_c) = (x[0].min(x[1]).min(x[2]), x[0].max(x[1]).max(x[2]));
        let (lo_r, hi_r) = (y[0].min(y[1]).min(y[2]), y[0].max(y[1]).max(y[2]));
        if hi_c < 0.0 || hi_r < 0.0 || lo_c > (n - 1) as f32 || lo_r > (n - 1) as f32 {
            continue;
        }
        let c0 = lo_c.ceil().max(0.0) as usize;
        let c1 = hi_c.floor().min((n - 1) as f32) as usize;
        let r0 = lo_r.ceil().max(0.0) as usize;
        let r1 = hi_r.floor().min((n - 1) as f32) as usize;
        let inv_area = 1.0 / area;
        for row in r0..=r1 {
            let py = row as f32;
            for col in c0..=c1 {
                let px = col as f32;
                // Barycentric weights from edge functions; the sign of `area` makes both windings
                // work (meshes from the wild are not consistently oriented).
                let b0 = ((x[1] - px) * (y[2] - py) - (x[2] - px) * (y[1] - py)) * inv_area;
                let b1 = ((x[2] - px) * (y[0] - py) - (x[0] - px) * (y[2] - py)) * inv_area;
                let b2 = 1.0 - b0 - b1;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let iz = b0 * w[0] + b1 * w[1] + b2 * w[2];
                let idx = row * n + col;
                if iz > inv_depth[idx] {
                    inv_depth[idx] = iz;
                    ids[idx] = f as u32;
                }
            }
        }
    }
    ids
}

/// Flat two-sided Lambertian shade of every face under a light from above-left of the camera.
fn face_shades(mesh: &TriMesh, camera: &Camera, albedo: Vec3) -> Vec<Vec3> {
    let light = (-camera.forward + camera.up * 0.6 - camera.right * 0.4).normalize();
    (0..mesh.faces.len())
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            let mut nrm = (b - a).cross(c - a).normalize_or_zero();
            if nrm.dot(camera.eye - a) < 0.0 {
                nrm = -nrm;
            }
            albedo * (0.35 + 0.65 * nrm.dot(light).max(0.0))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of side `2h` in the plane z = 0 facing the camera of view 0 from below is awkward;
    /// instead use a camera looking down +z at a quad in the z = 0 plane.
    fn quad(h: f32) -> TriMesh {
        TriMesh {
            vertices: vec![
                Vec3::new(-h, -h, 0.0),
                Vec3::new(h, -h, 0.0),
                Vec3::new(h, h, 0.0),
                Vec3::new(-h, h, 0.0),
            ],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn coverage_matches_projected_area() {
        // Camera on −z looking at the origin: the quad's projected side is 2h·focal/d pixels.
        let cam = Camera::look_at(Vec3::new(0.0, 0.0, -2.0), Vec3::ZERO, Vec3::Y, 15.0, 64);
        let h = 0.21; // edges fall mid-pixel, so edge pixels are partly covered
        let v = render(&quad(h), &cam, &RenderOptions::default());
        let side = 2.0 * h * cam.focal_px() / 2.0;
        let area: f32 = v.alpha.values().sum();
        assert!(
            (area - side * side).abs() / (side * side) < 0.02,
            "{area} vs {}",
            side * side
        );
        // Centre fully covered, corners empty, edges partially covered.
        assert_eq!(v.alpha.get(32 * 64 + 32), 1.0);
        assert_eq!(v.alpha.get(0), 0.0);
        let partial: Vec<f32> = v.alpha.values().filter(|&a| a > 0.0 && a < 1.0).collect();
        assert!(!partial.is_empty(), "side {side}, area {area}");
    }

    #[test]
    fn nearer_face_wins_the_depth_test() {
        let cam = Camera::look_at(Vec3::new(0.0, 0.0, -2.0), Vec3::ZERO, Vec3::Y, 15.0, 16);
        let mut m = quad(0.3);
        let mut near = quad(0.1);
        near.map_vertices(|v| v - Vec3::Z * 0.5);
        m.append(&near);
        let ids = rasterize_face_ids(&m, &cam);
        let centre = ids[8 * 16 + 8];
        assert!(
            centre == 2 || centre == 3,
            "near quad's faces are 2 and 3, got {centre}"
        );
    }
}
