//! Voxel grids over the NMR unit cube, with NMR's voxel placement.
//!
//! NMR's evaluation maps a vertex `v ∈ [-0.5, 0.5]³` to grid coordinates
//! `g = (v·(R−1)/R + 0.5)·R` and voxel `i` spans `g ∈ [i, i+1)`. So the centre of voxel `i` is
//! the world coordinate `(i + ½ − R/2)/(R − 1)`: at `R = 32`, `(i − 15.5)/31`, and the grid spans
//! `[-16/31, 16/31]`, slightly more than the unit cube. All our grids (ground-truth voxels, the
//! visual hull, predictions) share this frame, indexed `[x][y][z]` in world axes; the file layout
//! of Kato's voxels is a permutation of it handled by [`crate::dataset::kato`].

use glam::Vec3;

/// The placement of an `R³` grid in world space (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridFrame {
    pub resolution: usize,
}

impl GridFrame {
    /// The frame of NMR's evaluation grid at resolution `resolution` (32 in the paper).
    pub fn new(resolution: usize) -> Self {
        assert!(resolution >= 2, "grid resolution must be at least 2");
        Self { resolution }
    }

    /// Edge length of one voxel in world units, `1/(R−1)`.
    pub fn voxel_size(&self) -> f32 {
        1.0 / (self.resolution as f32 - 1.0)
    }

    /// World position → continuous grid coordinate (voxel `i` spans `[i, i+1)`).
    pub fn to_grid(&self, p: Vec3) -> Vec3 {
        let r = self.resolution as f32;
        (p * ((r - 1.0) / r) + Vec3::splat(0.5)) * r
    }

    /// Centre of voxel `(i, j, k)` in world coordinates.
    pub fn centre(&self, i: usize, j: usize, k: usize) -> Vec3 {
        let r = self.resolution as f32;
        let s = self.voxel_size();
        Vec3::new(
            (i as f32 + 0.5 - r * 0.5) * s,
            (j as f32 + 0.5 - r * 0.5) * s,
            (k as f32 + 0.5 - r * 0.5) * s,
        )
    }
}

/// A boolean occupancy grid indexed `[x][y][z]` (world axes), `z` fastest in memory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VoxelGrid {
    pub frame: GridFrame,
    pub data: Vec<bool>,
}

impl VoxelGrid {
    /// An empty grid at `resolution`.
    pub fn empty(resolution: usize) -> Self {
        Self {
            frame: GridFrame::new(resolution),
            data: vec![false; resolution.pow(3)],
        }
    }

    /// A grid whose voxel `(i, j, k)` is `f(i, j, k, centre)`.
    pub fn from_fn(resolution: usize, f: impl Fn(usize, usize, usize, Vec3) -> bool) -> Self {
        let mut g = Self::empty(resolution);
        for i in 0..resolution {
            for j in 0..resolution {
                for k in 0..resolution {
                    let c = g.frame.centre(i, j, k);
                    let idx = g.index(i, j, k);
                    g.data[idx] = f(i, j, k, c);
                }
            }
        }
        g
    }

    pub fn resolution(&self) -> usize {
        self.frame.resolution
    }

    /// Flat index of `(i, j, k)`.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        let r = self.resolution();
        (i * r + j) * r + k
    }

    pub fn get(&self, i: usize, j: usize, k: usize) -> bool {
        self.data[self.index(i, j, k)]
    }

    pub fn set(&mut self, i: usize, j: usize, k: usize, v: bool) {
        let idx = self.index(i, j, k);
        self.data[idx] = v;
    }

    /// Number of occupied voxels.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }

    /// Intersection over union with `other` (1 when both are empty).
    pub fn iou(&self, other: &VoxelGrid) -> f32 {
        assert_eq!(self.frame, other.frame, "IoU of grids in different frames");
        let (mut inter, mut union) = (0usize, 0usize);
        for (&a, &b) in self.data.iter().zip(&other.data) {
            inter += (a && b) as usize;
            union += (a || b) as usize;
        }
        if union == 0 {
            1.0
        } else {
            inter as f32 / union as f32
        }
    }

    /// Fraction of `self`'s occupied voxels that are also occupied in `other`
    /// (1 when `self` is empty): 1 means `other` contains `self`.
    pub fn fraction_inside(&self, other: &VoxelGrid) -> f32 {
        assert_eq!(self.frame, other.frame);
        let (mut n, mut inside) = (0usize, 0usize);
        for (&a, &b) in self.data.iter().zip(&other.data) {
            n += a as usize;
            inside += (a && b) as usize;
        }
        if n == 0 {
            1.0
        } else {
            inside as f32 / n as f32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nmr_voxel_centres() {
        let f = GridFrame::new(32);
        assert!((f.centre(0, 0, 0) - Vec3::splat(-15.5 / 31.0)).length() < 1e-6);
        assert!((f.centre(31, 31, 31) - Vec3::splat(15.5 / 31.0)).length() < 1e-6);
        // NMR's mapping sends a voxel centre to the middle of its cell.
        let g = f.to_grid(f.centre(3, 17, 30));
        assert!((g - Vec3::new(3.5, 17.5, 30.5)).length() < 1e-4, "{g:?}");
    }

    #[test]
    fn iou_and_containment() {
        let a = VoxelGrid::from_fn(4, |i, _, _, _| i < 2);
        let b = VoxelGrid::from_fn(4, |i, _, _, _| i < 3);
        assert!((a.iou(&b) - 2.0 / 3.0).abs() < 1e-6);
        assert_eq!(a.fraction_inside(&b), 1.0);
        assert!((b.fraction_inside(&a) - 2.0 / 3.0).abs() < 1e-6);
    }
}
