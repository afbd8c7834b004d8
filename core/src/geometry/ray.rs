//! A ray in world space.

use glam::Vec3;

/// A half-line `origin + t·direction`, `t ≥ 0`, with a unit `direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
}

impl Ray {
    /// The point at parameter `t` (world units, since `direction` is unit length).
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }

    /// Parameters where the ray enters and leaves the sphere `(centre, radius)`, if it meets it
    /// in front of the origin. `None` when the line misses the sphere or the sphere lies behind.
    pub fn sphere_interval(&self, centre: Vec3, radius: f32) -> Option<(f32, f32)> {
        let oc = self.origin - centre;
        let b = oc.dot(self.direction);
        let c = oc.length_squared() - radius * radius;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        let (t0, t1) = (-b - s, -b + s);
        (t1 >= 0.0).then_some((t0.max(0.0), t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_interval_hits_and_misses() {
        let r = Ray {
            origin: Vec3::new(0.0, 0.0, -5.0),
            direction: Vec3::Z,
        };
        let (t0, t1) = r.sphere_interval(Vec3::ZERO, 1.0).unwrap();
        assert!((t0 - 4.0).abs() < 1e-6 && (t1 - 6.0).abs() < 1e-6);
        assert!(r.sphere_interval(Vec3::new(2.0, 0.0, 0.0), 1.0).is_none());
        assert!(r.sphere_interval(Vec3::new(0.0, 0.0, -9.0), 1.0).is_none());
        assert!((r.at(2.0) - Vec3::new(0.0, 0.0, -3.0)).length() < 1e-6);
    }
}
