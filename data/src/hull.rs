//! The visual hull of a set of silhouettes: what silhouettes alone determine about a shape.
//!
//! Two tests of a voxel against a view, because they answer different questions:
//!
//! * [`HullTest::Centre`] — the voxel centre projects to where the (bilinear) silhouette is at
//!   least ½. This is the hull as a point set sampled at centres: the natural companion of a
//!   predicted occupancy field queried at the same centres.
//! * [`HullTest::Footprint`] — some pixel with non-zero coverage lies under the voxel's projected
//!   footprint (the square bounding the projection of the voxel's circumscribed sphere). This hull
//!   is conservative: it contains every voxel that touches the shape, so it contains both the
//!   winding-number voxels and NMR's dilated voxels, and it is the fair "silhouettes-only"
//!   reference next to NMR-protocol ground truth.
//!
//! Footprint queries use a summed-area table per view, so each is O(1).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::grid::{GridFrame, VoxelGrid};
use super::image::Silhouette;
use crate::geometry::Camera;

/// How a voxel is tested against a silhouette (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum HullTest {
    Centre,
    #[default]
    Footprint,
}

/// Summed-area table of `alpha > 0` of one silhouette, for footprint tests.
struct CoverageTable {
    size: usize,
    /// `(size+1)²` prefix sums.
    sums: Vec<u32>,
}

impl CoverageTable {
    fn new(s: &Silhouette) -> Self {
        let n = s.size;
        let mut sums = vec![0u32; (n + 1) * (n + 1)];
        for r in 0..n {
            for c in 0..n {
                let v = (s.get(r * n + c) > 0.0) as u32;
                sums[(r + 1) * (n + 1) + c + 1] =
                    v + sums[r * (n + 1) + c + 1] + sums[(r + 1) * (n + 1) + c]
                        - sums[r * (n + 1) + c];
            }
        }
        Self { size: n, sums }
    }

    /// Whether any covered pixel has its square overlapping `[c0, c1] × [r0, r1]` (continuous
    /// pixel coordinates; pixel `j` spans `[j − ½, j + ½]`).
    fn any(&self, c0: f32, c1: f32, r0: f32, r1: f32) -> bool {
        let n = self.size as i64;
        let lo = |x: f32| ((x + 0.5).floor() as i64).clamp(0, n);
        let hi = |x: f32| ((x + 0.5).ceil() as i64).clamp(0, n);
        let (ca, cb, ra, rb) = (lo(c0), hi(c1), lo(r0), hi(r1));
        if ca >= cb || ra >= rb {
            return false;
        }
        let w = (n + 1) as usize;
        let at = |r: i64, c: i64| self.sums[r as usize * w + c as usize] as i64;
        at(rb, cb) - at(ra, cb) - at(rb, ca) + at(ra, ca) > 0
    }
}

/// Whether point `p` lies inside the visual hull of `silhouettes` seen by `cameras` as a point
/// set: in front of every camera, projecting where every silhouette is at least ½ (bilinear).
pub fn projects_inside(silhouettes: &[Silhouette], cameras: &[Camera], p: Vec3) -> bool {
    cameras.iter().zip(silhouettes).all(|(cam, sil)| {
        let (px, depth) = cam.project(p);
        depth > 0.0 && sil.bilinear(px) >= 0.5
    })
}

/// The visual hull of `silhouettes` seen by `cameras` on the NMR grid at `resolution`.
pub fn visual_hull(
    silhouettes: &[Silhouette],
    cameras: &[Camera],
    resolution: usize,
    test: HullTest,
) -> VoxelGrid {
    assert_eq!(
        silhouettes.len(),
        cameras.len(),
        "one camera per silhouette"
    );
    let frame = GridFrame::new(resolution);
    let tables: Vec<CoverageTable> = match test {
        HullTest::Footprint => silhouettes.iter().map(CoverageTable::new).collect(),
        HullTest::Centre => Vec::new(),
    };
    let radius = frame.voxel_size() * 3f32.sqrt() * 0.5;
    VoxelGrid::from_fn(resolution, |_, _, _, centre| {
        cameras.iter().enumerate().all(|(v, cam)| {
            let (px, depth) = cam.project(centre);
            match test {
                HullTest::Centre => silhouettes[v].bilinear(px) >= 0.5,
                HullTest::Footprint => {
                    let r = radius * cam.focal_px() / (depth - radius).max(1e-3);
                    tables[v].any(px.col - r, px.col + r, px.row - r, px.row + r)
                }
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_table_counts_overlaps() {
        let mut s = Silhouette::empty(8);
        s.values_mut()[3 * 8 + 5] = 0.1;
        let t = CoverageTable::new(&s);
        assert!(t.any(4.6, 5.4, 2.6, 3.4));
        assert!(
            t.any(5.45, 6.0, 3.0, 3.0),
            "touches pixel 5's square [4.5, 5.5]"
        );
        assert!(!t.any(5.6, 7.0, 0.0, 7.0));
        assert!(!t.any(0.0, 7.0, 3.6, 7.0));
    }
}
