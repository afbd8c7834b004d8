//! Closed, outward-oriented primitive meshes from which procedural shapes are assembled.
//!
//! Every primitive is a closed surface with counter-clockwise faces seen from outside, so its
//! generalized winding number is +1 inside. Shapes are unions of (possibly overlapping)
//! primitives; see [`super`] for why that is enough.

use glam::Vec3;

use crate::mesh::TriMesh;

/// Accumulates primitives into one mesh.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    mesh: TriMesh,
}

impl MeshBuilder {
    /// The mesh assembled so far.
    pub fn build(self) -> TriMesh {
        self.mesh
    }

    fn push(&mut self, vertices: &[Vec3], faces: &[[u32; 3]]) {
        self.mesh.append(&TriMesh {
            vertices: vertices.to_vec(),
            faces: faces.to_vec(),
        });
    }

    /// An axis-aligned box.
    pub fn add_box(&mut self, centre: Vec3, half: Vec3) -> &mut Self {
        let c = |sx: f32, sy: f32, sz: f32| centre + half * Vec3::new(sx, sy, sz);
        self.add_hexahedron([
            c(-1., -1., -1.),
            c(1., -1., -1.),
            c(1., -1., 1.),
            c(-1., -1., 1.),
            c(-1., 1., -1.),
            c(1., 1., -1.),
            c(1., 1., 1.),
            c(-1., 1., 1.),
        ])
    }

    /// An axis-aligned box given by its min and max corners.
    pub fn add_box_between(&mut self, lo: Vec3, hi: Vec3) -> &mut Self {
        self.add_box((lo + hi) * 0.5, (hi - lo).abs() * 0.5)
    }

    /// A convex hexahedron. Corners are ordered like an axis-aligned box's: bottom face
    /// `(−x,−z), (+x,−z), (+x,+z), (−x,+z)` then the top face in the same order. Tapered, sheared
    /// and swept boxes (wings, hulls, cabins) are hexahedra.
    pub fn add_hexahedron(&mut self, c: [Vec3; 8]) -> &mut Self {
        const FACES: [[u32; 3]; 12] = [
            [0, 1, 2],
            [0, 2, 3], // bottom (−y)
            [4, 6, 5],
            [4, 7, 6], // top (+y)
            [0, 4, 5],
            [0, 5, 1], // front (−z)
            [3, 2, 6],
            [3, 6, 7], // back (+z)
            [0, 3, 7],
            [0, 7, 4], // left (−x)
            [1, 5, 6],
            [1, 6, 2], // right (+x)
        ];
        self.push(&c, &FACES);
        self
    }

    /// A (possibly tapered) cylinder from `a` (radius `ra`) to `b` (radius `rb`), with caps.
    pub fn add_cylinder(
        &mut self,
        a: Vec3,
        b: Vec3,
        ra: f32,
        rb: f32,
        segments: usize,
    ) -> &mut Self {
        let n = segments.max(3);
        let d = (b - a).normalize();
        let (u, v) = d.any_orthonormal_pair();
        // (u, v, d) right-handed so that increasing angle turns counter-clockwise about d.
        let (u, v) = if u.cross(v).dot(d) > 0.0 {
            (u, v)
        } else {
            (v, u)
        };
        let ring = |centre: Vec3, r: f32, i: usize| {
            let t = std::f32::consts::TAU * i as f32 / n as f32;
            centre + (u * t.cos() + v * t.sin()) * r
        };
        let mut verts: Vec<Vec3> = (0..n).map(|i| ring(a, ra, i)).collect();
        verts.extend((0..n).map(|i| ring(b, rb, i)));
        verts.push(a);
        verts.push(b);
        let (ca, cb) = (2 * n as u32, 2 * n as u32 + 1);
        let mut faces = Vec::with_capacity(4 * n);
        for i in 0..n as u32 {
            let j = (i + 1) % n as u32;
            let (ai, aj, bi, bj) = (i, j, i + n as u32, j + n as u32);
            faces.push([ai, aj, bj]);
            faces.push([ai, bj, bi]);
            faces.push([ca, aj, ai]);
            faces.push([cb, bi, bj]);
        }
        self.push(&verts, &faces);
        self
    }

    /// An ellipsoid with semi-axes `radii`, `segments` around and `segments/2` from pole to pole.
    pub fn add_ellipsoid(&mut self, centre: Vec3, radii: Vec3, segments: usize) -> &mut Self {
        let slices = segments.max(4);
        let stacks = (segments / 2).max(2);
        let mut verts = vec![centre + Vec3::Y * radii.y];
        for s in 1..stacks {
            let th = std::f32::consts::PI * s as f32 / stacks as f32;
            for k in 0..slices {
                let ph = std::f32::consts::TAU * k as f32 / slices as f32;
                let dir = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
                verts.push(centre + dir * radii);
            }
        }
        verts.push(centre - Vec3::Y * radii.y);
        let bottom = verts.len() as u32 - 1;
        let at = |s: usize, k: usize| 1 + ((s - 1) * slices + k % slices) as u32;
        let mut faces = Vec::new();
        for k in 0..slices {
            faces.push([0, at(1, k + 1), at(1, k)]);
            faces.push([bottom, at(stacks - 1, k), at(stacks - 1, k + 1)]);
        }
        for s in 1..stacks - 1 {
            for k in 0..slices {
                faces.push([at(s, k), at(s, k + 1), at(s + 1, k + 1)]);
                faces.push([at(s, k), at(s + 1, k + 1), at(s + 1, k)]);
            }
        }
        self.push(&verts, &faces);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxelize::winding_number;

    /// Signed volume by the divergence theorem: positive iff faces point outwards.
    fn volume(m: &TriMesh) -> f32 {
        (0..m.faces.len())
            .map(|f| {
                let [a, b, c] = m.triangle(f);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn primitives_are_closed_outward_and_have_the_right_volume() {
        let pi = std::f32::consts::PI;
        let mut b = MeshBuilder::default();
        b.add_box(Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.1, 0.2, 0.3));
        let m = b.build();
        assert!((volume(&m) - 0.2 * 0.4 * 0.6).abs() < 1e-5);
        assert!((winding_number(&m, Vec3::new(0.1, 0.0, 0.0)) - 1.0).abs() < 1e-6);

        let mut b = MeshBuilder::default();
        b.add_cylinder(
            Vec3::new(0.0, -0.2, 0.1),
            Vec3::new(0.1, 0.3, 0.0),
            0.1,
            0.1,
            64,
        );
        let m = b.build();
        let len = Vec3::new(0.1, 0.5, -0.1).length();
        assert!((volume(&m) - pi * 0.01 * len).abs() / (pi * 0.01 * len) < 0.01);
        assert!((winding_number(&m, Vec3::new(0.05, 0.05, 0.05)) - 1.0).abs() < 1e-6);

        let mut b = MeshBuilder::default();
        b.add_ellipsoid(Vec3::ZERO, Vec3::new(0.3, 0.2, 0.1), 64);
        let m = b.build();
        let exact = 4.0 / 3.0 * pi * 0.3 * 0.2 * 0.1;
        assert!(
            (volume(&m) - exact).abs() / exact < 0.02,
            "{} vs {exact}",
            volume(&m)
        );
        assert!((winding_number(&m, Vec3::ZERO) - 1.0).abs() < 1e-6);
    }
}
