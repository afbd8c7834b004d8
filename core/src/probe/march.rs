//! Dense ray marching: the baseline that field probing replaces.
//!
//! Methods that supervise a field with silhouettes by rendering (DVR, NeRF-style volume
//! rendering, SoftRas-like soft silhouettes of implicit fields) read φ at many depths along every
//! ray: `S` samples inside the object's cube per ray, aggregated by a max or by compositing
//! ([`Composite`](super::Composite)). The paper's argument is that its sparse anchors with spherical
//! support give the same supervision for far fewer decoder evaluations; this module is the other
//! side of that comparison.
//!
//! Selected in TOML by `[probe] march = { type = "fixed" | "stratified", samples = S }` instead of
//! the τ-sphere assignment. Every ray then owns its own `S` points: the batch format is the
//! probing one (an `[R, K]` index into the flat field values, `K = S`), each point on exactly one
//! ray, its depth along the ray recorded (so order-aware aggregators work), its distance from the
//! ray 0. A ray that misses the cube gets no points and predicts 0, as an anchor-less ray does.
//! The anchor sampler still draws `probe.anchors` points per object: they are what regularizers
//! see, the same points a probing run of the same seed would give them.

use std::fmt::Debug;

use glam::Vec3;
use rand::RngCore;

use super::assign::{Assignment, RaySet};
use super::sampler::Supervision;

/// Half the side of the cube rays are marched through: the unit cube `[-½, ½]³` that objects are
/// normalized into, where evaluation reads the field.
pub const MARCH_EXTENT: f32 = 0.5;

/// Places the samples along one ray.
pub trait RayMarcher: Send + Sync + Debug {
    /// Samples per ray.
    fn samples(&self) -> usize;

    /// [`samples`](Self::samples) increasing depths in `[near, far]` (the ray's interval inside
    /// the cube).
    fn depths(&self, near: f32, far: f32, rng: &mut dyn RngCore) -> Vec<f32>;
}

/// The TOML/serde side of a ray marcher.
#[typetag::serde(tag = "type")]
pub trait RayMarcherConfig: Send + Sync + Debug {
    /// Validates the configuration and builds the marcher; the error says which field is wrong.
    fn build(&self) -> Result<Box<dyn RayMarcher>, String>;
}

/// One object's rays marched: the points, in ray order (`S` per ray that meets the cube), and
/// the ray → points assignment with each point's depth.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Marched {
    pub points: Vec<Vec3>,
    pub assignment: Assignment,
    pub depth: Vec<f32>,
}

/// Marches every ray of `rays` through the cube `[-MARCH_EXTENT, MARCH_EXTENT]³`.
pub fn march_rays(
    object: &Supervision,
    rays: &RaySet,
    marcher: &dyn RayMarcher,
    rng: &mut dyn RngCore,
) -> Marched {
    let (lo, hi) = (Vec3::splat(-MARCH_EXTENT), Vec3::splat(MARCH_EXTENT));
    let mut out = Marched {
        points: Vec::with_capacity(rays.len() * marcher.samples()),
        assignment: Assignment {
            offsets: Vec::with_capacity(rays.len() + 1),
            anchors: Vec::with_capacity(rays.len() * marcher.samples()),
        },
        depth: Vec::with_capacity(rays.len() * marcher.samples()),
    };
    out.assignment.offsets.push(0);
    for r in 0..rays.len() {
        let ray = object.cameras[rays.views[r] as usize].ray(rays.pixels[r]);
        if let Some((near, far)) = ray.box_interval(lo, hi) {
            for t in marcher.depths(near, far, rng) {
                out.assignment.anchors.push(out.points.len() as u32);
                out.points.push(ray.at(t));
                out.depth.push(t);
            }
        }
        out.assignment.offsets.push(out.points.len() as u32);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Silhouette;
    use crate::geometry::PixelPos;
    use rand::SeedableRng;

    /// Evenly spaced, for the test only (the shipped marchers live in `fieldprobe-samplers`).
    #[derive(Debug)]
    struct Even(usize);

    impl RayMarcher for Even {
        fn samples(&self) -> usize {
            self.0
        }
        fn depths(&self, near: f32, far: f32, _rng: &mut dyn RngCore) -> Vec<f32> {
            let step = (far - near) / self.0 as f32;
            (0..self.0)
                .map(|i| near + (i as f32 + 0.5) * step)
                .collect()
        }
    }

    #[test]
    fn marched_points_lie_on_their_rays_inside_the_cube() {
        let object = Supervision::nmr(vec![Silhouette::empty(64); 24]);
        let mut rays = RaySet::default();
        // The image centre (meets the cube), a corner (misses it), a point in between.
        for (v, col, row) in [(0u16, 31.5f32, 31.5f32), (3, -0.5, -0.5), (7, 20.0, 40.0)] {
            rays.views.push(v);
            rays.pixels.push(PixelPos { col, row });
            rays.labels.push(0.0);
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let m = march_rays(&object, &rays, &Even(8), &mut rng);
        assert_eq!(m.assignment.rays(), 3);
        assert_eq!(
            (m.assignment.of(0).len(), m.assignment.of(1).len()),
            (8, 0),
            "the centre ray meets the cube, the corner ray misses it"
        );
        assert_eq!(m.assignment.of(2).len(), 8);
        for r in [0, 2] {
            let ray = object.cameras[rays.views[r] as usize].ray(rays.pixels[r]);
            for &p in m.assignment.of(r) {
                let q = m.points[p as usize];
                assert!(q.abs().max_element() <= MARCH_EXTENT + 1e-5, "{q:?}");
                let t = m.depth[p as usize];
                assert!((ray.at(t) - q).length() < 1e-5);
            }
            let d: Vec<f32> = m
                .assignment
                .of(r)
                .iter()
                .map(|&p| m.depth[p as usize])
                .collect();
            assert!(d.windows(2).all(|w| w[0] < w[1]), "increasing depths {d:?}");
        }
        // The centre ray of view 0 (elevation 30°) passes through the origin and crosses the
        // front and back faces z = ∓½: it spends ½/cos 30° on each side of the centre, and the
        // even samples sit at their bin centres.
        let half = 0.5 / 30f32.to_radians().cos();
        let d0 = m.depth[m.assignment.of(0)[0] as usize];
        assert!(
            (d0 - (2.732 - half + 2.0 * half / 16.0)).abs() < 1e-3,
            "{d0}"
        );
    }
}
