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

    /// Parameters where the ray enters and leaves the axis-aligned box `[min, max]` (slab
    /// method), clipped to `t ≥ 0`; `None` when it misses the box or the box lies behind.
    pub fn box_interval(&self, min: Vec3, max: Vec3) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
        for a in 0..3 {
            let (o, d) = (self.origin[a], self.direction[a]);
            if d.abs() < 1e-12 {
                if o < min[a] || o > max[a] {
                    return None;
                }
                continue;
            }
            let (ta, tb) = ((min[a] - o) / d, (max[a] - o) / d);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1).then_some((t0, t1))
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

    #[test]
    fn box_interval_hits_misses_and_starts_inside() {
        let (lo, hi) = (Vec3::splat(-0.5), Vec3::splat(0.5));
        let r = Ray {
            origin: Vec3::new(0.2, 0.1, -5.0),
            direction: Vec3::Z,
        };
        let (t0, t1) = r.box_interval(lo, hi).unwrap();
        assert!((t0 - 4.5).abs() < 1e-6 && (t1 - 5.5).abs() < 1e-6);
        // A diagonal through opposite corners has length √3.
        let d = Vec3::ONE.normalize();
        let diag = Ray {
            origin: -d * 3.0,
            direction: d,
        };
        let (t0, t1) = diag.box_interval(lo, hi).unwrap();
        assert!((t1 - t0 - 3f32.sqrt()).abs() < 1e-5);
        let miss = Ray {
            origin: Vec3::new(0.6, 0.0, -5.0),
            direction: Vec3::Z,
        };
        assert!(miss.box_interval(lo, hi).is_none());
        let behind = Ray {
            origin: Vec3::new(0.0, 0.0, 2.0),
            direction: Vec3::Z,
        };
        assert!(behind.box_interval(lo, hi).is_none());
        let inside = Ray {
            origin: Vec3::ZERO,
            direction: Vec3::X,
        };
        assert_eq!(inside.box_interval(lo, hi), Some((0.0, 0.5)));
    }
}
