//! The NMR/SoftRas perspective camera used by Kato's renderings, SoftRas, DVR's NMR data and the
//! paper (`DESIGN.md` §4).
//!
//! Conventions, fixed because the published data depend on them:
//!
//! * view `v ∈ 0..24`: distance 2.732, elevation 30°, azimuth `θ = −15°·v`,
//!   eye `= (d·cosφ·sinθ, d·sinφ, −d·cosφ·cosθ)`, looking at the origin with up `+y`;
//! * camera axes `z_c = normalize(at − eye)`, `x_c = normalize(up × z_c)`, `y_c = z_c × x_c`;
//! * normalized device coordinates `x' = x_c/(z_c·tan15°)`, `y' = y_c/(z_c·tan15°)`, in `[−1, 1]`,
//!   `+y'` up;
//! * continuous pixel coordinates `(col, row)` put the centre of pixel `(row i, column j)` at
//!   `(j, i)`, row 0 at the top (`y' = +1`): `col = (x'+1)·W/2 − ½`, `row = (1−y')·H/2 − ½`.

use glam::{Vec2, Vec3};

use super::Ray;

/// Number of views per object in the NMR layout.
pub const NUM_VIEWS: usize = 24;
/// Camera distance from the origin.
pub const NMR_DISTANCE: f32 = 2.732;
/// Camera elevation in degrees.
pub const NMR_ELEVATION_DEG: f32 = 30.0;
/// Half of the field of view, in degrees.
pub const NMR_HALF_ANGLE_DEG: f32 = 15.0;
/// Azimuth step between consecutive views, in degrees (views turn clockwise seen from above).
pub const NMR_AZIMUTH_STEP_DEG: f32 = -15.0;
/// Image side in pixels.
pub const NMR_IMAGE_SIZE: usize = 64;

/// A continuous pixel position: `col` grows to the right, `row` downwards, and the centre of pixel
/// `(row i, column j)` is at `(col, row) = (j, i)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelPos {
    pub col: f32,
    pub row: f32,
}

/// A pinhole camera looking at the origin, in the NMR conventions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Camera centre in world coordinates.
    pub eye: Vec3,
    /// `x_c`: image right, in world coordinates.
    pub right: Vec3,
    /// `y_c`: image up, in world coordinates.
    pub up: Vec3,
    /// `z_c`: viewing direction, in world coordinates.
    pub forward: Vec3,
    /// `tan` of the half field of view.
    pub tan_half_fov: f32,
    /// Image side in pixels (images are square).
    pub image_size: usize,
}

impl Camera {
    /// A camera at `eye` looking at `at`, with the world `up` hint, half field of view in degrees.
    pub fn look_at(eye: Vec3, at: Vec3, up: Vec3, half_angle_deg: f32, image_size: usize) -> Self {
        let forward = (at - eye).normalize();
        let right = up.cross(forward).normalize();
        let up = forward.cross(right);
        Self {
            eye,
            right,
            up,
            forward,
            tan_half_fov: half_angle_deg.to_radians().tan(),
            image_size,
        }
    }

    /// The camera at `azimuth_deg`, `elevation_deg` and `distance` around the origin, NMR formula.
    pub fn orbit(distance: f32, elevation_deg: f32, azimuth_deg: f32, image_size: usize) -> Self {
        let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
        let eye = Vec3::new(
            distance * el.cos() * az.sin(),
            distance * el.sin(),
            -distance * el.cos() * az.cos(),
        );
        Self::look_at(eye, Vec3::ZERO, Vec3::Y, NMR_HALF_ANGLE_DEG, image_size)
    }

    /// View `view` (`0..24`) of the published NMR renderings, 64×64 pixels.
    ///
    /// # Panics
    /// If `view >= 24`.
    pub fn nmr(view: usize) -> Self {
        assert!(
            view < NUM_VIEWS,
            "NMR view index {view} out of 0..{NUM_VIEWS}"
        );
        Self::orbit(
            NMR_DISTANCE,
            NMR_ELEVATION_DEG,
            NMR_AZIMUTH_STEP_DEG * view as f32,
            NMR_IMAGE_SIZE,
        )
    }

    /// All 24 NMR views, in file order.
    pub fn nmr_views() -> Vec<Self> {
        (0..NUM_VIEWS).map(Self::nmr).collect()
    }

    /// World point → camera coordinates `(x_c, y_c, z_c)`; `z_c` is the depth along the axis.
    pub fn to_camera(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// World point → normalized device coordinates `(x', y')` and depth `z_c`.
    /// Points at or behind the camera plane give non-finite or sign-flipped coordinates; check
    /// the depth.
    pub fn project_ndc(&self, p: Vec3) -> (Vec2, f32) {
        let c = self.to_camera(p);
        let s = 1.0 / (c.z * self.tan_half_fov);
        (Vec2::new(c.x * s, c.y * s), c.z)
    }

    /// World point → continuous pixel position and depth.
    pub fn project(&self, p: Vec3) -> (PixelPos, f32) {
        let (ndc, depth) = self.project_ndc(p);
        (self.ndc_to_pixel(ndc), depth)
    }

    /// NDC → continuous pixel position.
    pub fn ndc_to_pixel(&self, ndc: Vec2) -> PixelPos {
        let half = self.image_size as f32 * 0.5;
        PixelPos {
            col: (ndc.x + 1.0) * half - 0.5,
            row: (1.0 - ndc.y) * half - 0.5,
        }
    }

    /// Continuous pixel position → NDC.
    pub fn pixel_to_ndc(&self, px: PixelPos) -> Vec2 {
        let half = self.image_size as f32 * 0.5;
        Vec2::new((px.col + 0.5) / half - 1.0, 1.0 - (px.row + 0.5) / half)
    }

    /// The ray from the eye through a continuous pixel position (unit direction).
    pub fn ray(&self, px: PixelPos) -> Ray {
        let ndc = self.pixel_to_ndc(px);
        let t = self.tan_half_fov;
        let dir = self.forward + self.right * (ndc.x * t) + self.up * (ndc.y * t);
        Ray {
            origin: self.eye,
            direction: dir.normalize(),
        }
    }

    /// Focal length in pixels: a length `l` at depth `z` spans `l · focal_px / z` pixels.
    pub fn focal_px(&self) -> f32 {
        self.image_size as f32 * 0.5 / self.tan_half_fov
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn origin_lands_on_image_centre_in_every_view() {
        for cam in Camera::nmr_views() {
            let (px, depth) = cam.project(Vec3::ZERO);
            assert!(
                close(px.col, 31.5, 1e-4) && close(px.row, 31.5, 1e-4),
                "{px:?}"
            );
            assert!(close(depth, NMR_DISTANCE, 1e-5));
        }
    }

    #[test]
    fn point_above_origin_lands_above_centre() {
        // By hand for view 0: eye = (0, 1.366, −2.366), y_c = (0, cos30, sin30), z_c = (0, −sin30,
        // cos30). p = (0, 0.25, 0): y_c·(p−eye) = 0.866·(−1.116) + 0.5·2.366 = 0.2165,
        // z_c·(p−eye) = 0.558 + 2.049 = 2.607, y' = 0.2165/(2.607·tan15°) = 0.30994,
        // row = (1 − 0.30994)·32 − 0.5 = 21.582 (above the centre row 31.5).
        let cam = Camera::nmr(0);
        let (px, depth) = cam.project(Vec3::new(0.0, 0.25, 0.0));
        assert!(close(px.row, 21.582, 2e-3), "{px:?}");
        assert!(close(px.col, 31.5, 1e-4));
        assert!(close(depth, 2.607, 1e-3));
        for cam in Camera::nmr_views() {
            assert!(cam.project(Vec3::new(0.0, 0.25, 0.0)).0.row < 31.5);
        }
    }

    #[test]
    fn view_six_looks_along_the_formula_direction() {
        // θ = −90°: eye = (d·cos30·sin(−90°), d·sin30, −d·cos30·cos(−90°)) = (−2.366, 1.366, 0),
        // so the camera looks along (+cos30, −sin30, 0) = (0.866, −0.5, 0), and image right is
        // up × z_c = (0, 0, −1)·… = (0, 0, −0.866)/0.866 = −z.
        let cam = Camera::nmr(6);
        assert!(
            (cam.eye - Vec3::new(-2.366, 1.366, 0.0)).length() < 1e-3,
            "{:?}",
            cam.eye
        );
        assert!((cam.forward - Vec3::new(0.8660254, -0.5, 0.0)).length() < 1e-5);
        assert!((cam.right - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-5);
        // A point at −z lands right of the centre.
        assert!(cam.project(Vec3::new(0.0, 0.0, -0.25)).0.col > 31.5);
    }

    #[test]
    fn row_zero_is_the_top_and_pixel_centres_are_half_integers_in_ndc() {
        let cam = Camera::nmr(0);
        let top = cam.pixel_to_ndc(PixelPos { col: 0.0, row: 0.0 });
        assert!(close(top.y, 63.0 / 64.0, 1e-6) && close(top.x, -63.0 / 64.0, 1e-6));
        // column i centre is x' = (2i + 1 − 64)/64
        for i in [0usize, 10, 31, 63] {
            let ndc = cam.pixel_to_ndc(PixelPos {
                col: i as f32,
                row: 5.0,
            });
            assert!(close(ndc.x, (2.0 * i as f32 + 1.0 - 64.0) / 64.0, 1e-6));
        }
    }

    #[test]
    fn ray_through_a_projection_passes_through_the_point() {
        let p = Vec3::new(0.3, -0.2, 0.1);
        for cam in Camera::nmr_views() {
            let (px, _) = cam.project(p);
            let ray = cam.ray(px);
            let t = (p - ray.origin).dot(ray.direction);
            assert!((ray.at(t) - p).length() < 1e-5);
        }
    }
}
