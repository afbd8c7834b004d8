//! Exact inside tests for closed meshes at millions of points: signed crossings of a `+z` ray.
//!
//! The generalized winding number ([`super::voxelize::winding_number`]) is the reference: it costs
//! a solid angle (an `atan2` and three square roots) per face and point. For a closed mesh it is
//! an integer, and that integer is also the signed count of the faces that a ray from the point
//! crosses (`+1` leaving through a face whose normal points along the ray, `−1` entering). A ray
//! along `+z` only meets faces whose `xy` footprint contains the point, so faces are bucketed by
//! their footprint on an `xy` grid and each query tests a few dozen faces instead of all of them.
//!
//! Crossings on shared edges and vertices are counted once through the top-left rule of
//! rasterizers (a point on an edge belongs to exactly one of the two triangles sharing it), and
//! faces seen edge-on (zero `xy` area) are never crossed, so the count is exact for any point
//! that is not on the surface itself. A union of overlapping closed parts counts `k` inside `k`
//! parts; [`InsideTest::contains`] asks for a non-zero count, the orientation-agnostic solid the
//! winding-number voxelizer also uses.

use glam::{DVec2, Vec3};

use super::mesh::TriMesh;

/// Buckets per axis of the `xy` grid (faces are short next to the unit cube, so a few dozen
/// faces share a bucket at most).
const BUCKETS: usize = 64;

/// A mesh prepared for inside tests.
#[derive(Clone, Debug)]
pub struct InsideTest {
    /// Per face: the three vertices in f64.
    faces: Vec<[[f64; 3]; 3]>,
    lo: DVec2,
    cell: DVec2,
    /// Bucket `b` holds the faces `order[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl InsideTest {
    /// Buckets the faces of `mesh` (faces with no `xy` area are dropped: a vertical ray never
    /// crosses them).
    pub fn new(mesh: &TriMesh) -> Self {
        let faces: Vec<[[f64; 3]; 3]> = mesh
            .faces
            .iter()
            .map(|f| f.map(|i| mesh.vertices[i as usize].as_dvec3().to_array()))
            .filter(|t| signed_area(t) != 0.0)
            .collect();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for t in &faces {
            for v in t {
                lo = lo.min(DVec2::new(v[0], v[1]));
                hi = hi.max(DVec2::new(v[0], v[1]));
            }
        }
        if faces.is_empty() {
            (lo, hi) = (DVec2::ZERO, DVec2::ONE);
        }
        let cell = ((hi - lo) / BUCKETS as f64).max(DVec2::splat(1e-9));
        let range = |t: &[[f64; 3]; 3], a: usize| {
            let (mn, mx) = t
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(mn, mx), v| {
                    (mn.min(v[a]), mx.max(v[a]))
                });
            let c = |x: f64| (((x - lo[a]) / cell[a]).floor().max(0.0) as usize).min(BUCKETS - 1);
            c(mn)..=c(mx)
        };
        let mut lists = vec![Vec::new(); BUCKETS * BUCKETS];
        for (f, t) in faces.iter().enumerate() {
            for i in range(t, 0) {
                for j in range(t, 1) {
                    lists[i * BUCKETS + j].push(f as u32);
                }
            }
        }
        let mut starts = vec![0u32];
        let mut order = Vec::new();
        for l in lists {
            order.extend(l);
            starts.push(order.len() as u32);
        }
        Self {
            faces,
            lo,
            cell,
            starts,
            order,
        }
    }

    /// The winding number at `p`: the signed count of faces crossed by the ray `p + t·e_z`,
    /// `t > 0` (0 outside a closed mesh; its sign follows the mesh's orientation).
    pub fn winding(&self, p: Vec3) -> i32 {
        let q = p.as_dvec3();
        let g = (DVec2::new(q.x, q.y) - self.lo) / self.cell;
        if g.x < 0.0 || g.y < 0.0 || g.x >= BUCKETS as f64 || g.y >= BUCKETS as f64 {
            // Outside the footprint of every face (the last bucket's far edge is on the hull of
            // the footprints, where no face can be crossed either).
            return 0;
        }
        let b = g.x as usize * BUCKETS + g.y as usize;
        let mut w = 0;
        for &f in &self.order[self.starts[b] as usize..self.starts[b + 1] as usize] {
            w += crossing(&self.faces[f as usize], [q.x, q.y, q.z]);
        }
        w
    }

    /// Whether `p` is inside the solid (a non-zero winding number).
    pub fn contains(&self, p: Vec3) -> bool {
        self.winding(p) != 0
    }
}

/// Twice the signed area of a face's `xy` projection.
fn signed_area(t: &[[f64; 3]; 3]) -> f64 {
    edge(t[0], t[1], [t[2][0], t[2][1]])
}

/// `(b − a) × (p − a)` in `xy`.
fn edge(a: [f64; 3], b: [f64; 3], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Whether a point exactly on the edge `a → b` of a counter-clockwise (in `xy`) triangle belongs
/// to it: the top-left rule, so that of two triangles sharing the edge exactly one owns it.
fn owns_edge(a: [f64; 3], b: [f64; 3]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    dy < 0.0 || (dy == 0.0 && dx > 0.0)
}

/// The signed crossing of face `t` by the ray from `p` along `+z`: `+1` when the face is above `p`
/// with its normal pointing up, `−1` pointing down, 0 when the ray misses it.
fn crossing(t: &[[f64; 3]; 3], p: [f64; 3]) -> i32 {
    let area = signed_area(t);
    // Counter-clockwise order in xy, remembering the orientation.
    let (v, sign) = if area > 0.0 {
        ([t[0], t[1], t[2]], 1)
    } else {
        ([t[0], t[2], t[1]], -1)
    };
    let xy = [p[0], p[1]];
    let mut bary = [0.0; 3];
    for i in 0..3 {
        let (a, b) = (v[(i + 1) % 3], v[(i + 2) % 3]);
        let e = edge(a, b, xy);
        if e < 0.0 || (e == 0.0 && !owns_edge(a, b)) {
            return 0;
        }
        bary[i] = e;
    }
    let total = bary[0] + bary[1] + bary[2];
    let z = (bary[0] * v[0][2] + bary[1] * v[1][2] + bary[2] * v[2][2]) / total;
    if z > p[2] { sign } else { 0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Category;
    use crate::procedural::primitives::MeshBuilder;
    use crate::procedural::{generate, object_rng};
    use crate::voxelize::winding_number;
    use rand::{Rng, SeedableRng};

    /// The fast count equals the generalized winding number (the reference) at random points,
    /// inside and outside, for procedural unions of overlapping parts.
    #[test]
    fn crossing_count_equals_the_winding_number() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for category in [Category::Chair, Category::Airplane, Category::Watercraft] {
            let mesh = generate(category, &mut object_rng(0, category, 2, 1));
            let fast = InsideTest::new(&mesh);
            let mut inside = 0;
            for _ in 0..3000 {
                let p = Vec3::new(
                    rng.random_range(-0.55..0.55),
                    rng.random_range(-0.55..0.55),
                    rng.random_range(-0.55..0.55),
                );
                let reference = winding_number(&mesh, p);
                let w = fast.winding(p);
                assert!(
                    (reference - w as f64).abs() < 1e-6,
                    "{category} at {p}: winding {reference}, crossings {w}"
                );
                inside += fast.contains(p) as usize;
            }
            // Thin airplanes fill about 0.5 % of the box.
            assert!(inside > 5, "{category}: only {inside} points inside");
        }
    }

    /// Points exactly above shared edges and vertices of a box (on the lattice of its
    /// tessellation) are counted once.
    #[test]
    fn shared_edges_and_vertices_count_once() {
        let mut b = MeshBuilder::default();
        b.add_box(Vec3::ZERO, Vec3::splat(0.25));
        let t = InsideTest::new(&b.build());
        for p in [
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, -0.2),
            Vec3::new(0.25, 0.0, 0.0),
            Vec3::new(0.1, 0.1, 0.1),
            Vec3::new(-0.25, -0.25, 0.0),
        ] {
            let w = t.winding(p).abs();
            assert!(w <= 1, "{p}: {w}");
        }
        assert_eq!(t.winding(Vec3::new(0.1, 0.1, 0.1)).abs(), 1);
        assert_eq!(t.winding(Vec3::new(0.1, 0.1, 0.3)), 0);
        assert_eq!(t.winding(Vec3::new(0.4, 0.1, 0.0)), 0);
    }
}
