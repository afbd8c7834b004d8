//! Silhouettes (alpha masks) and their sub-pixel lookup.

use crate::geometry::PixelPos;

/// A square single-channel image with values in `[0, 1]`, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Silhouette {
    pub size: usize,
    pub data: Vec<f32>,
}

impl Silhouette {
    /// An all-background silhouette.
    pub fn empty(size: usize) -> Self {
        Self {
            size,
            data: vec![0.0; size * size],
        }
    }

    /// From 8-bit alpha values (`0..=255`).
    pub fn from_u8(size: usize, alpha: &[u8]) -> Self {
        assert_eq!(alpha.len(), size * size);
        Self {
            size,
            data: alpha.iter().map(|&a| a as f32 / 255.0).collect(),
        }
    }

    /// Value of pixel `(row, col)`; zero outside the image (everything off-image is background).
    pub fn pixel(&self, row: isize, col: isize) -> f32 {
        let n = self.size as isize;
        if row < 0 || col < 0 || row >= n || col >= n {
            0.0
        } else {
            self.data[row as usize * self.size + col as usize]
        }
    }

    /// Bilinear interpolation at a continuous pixel position (pixel centres at integer
    /// coordinates), with zero padding outside the image.
    pub fn bilinear(&self, p: PixelPos) -> f32 {
        let (c0, r0) = (p.col.floor(), p.row.floor());
        let (fc, fr) = (p.col - c0, p.row - r0);
        let (c0, r0) = (c0 as isize, r0 as isize);
        let top = self.pixel(r0, c0) * (1.0 - fc) + self.pixel(r0, c0 + 1) * fc;
        let bottom = self.pixel(r0 + 1, c0) * (1.0 - fc) + self.pixel(r0 + 1, c0 + 1) * fc;
        top * (1.0 - fr) + bottom * fr
    }

    /// Value of the pixel whose square contains `p` (nearest pixel centre).
    pub fn nearest(&self, p: PixelPos) -> f32 {
        self.pixel(p.row.round() as isize, p.col.round() as isize)
    }

    /// Intersection over union of the two masks thresholded at 0.5.
    pub fn iou(&self, other: &Silhouette) -> f32 {
        let (mut i, mut u) = (0usize, 0usize);
        for (&a, &b) in self.data.iter().zip(&other.data) {
            let (a, b) = (a >= 0.5, b >= 0.5);
            i += (a && b) as usize;
            u += (a || b) as usize;
        }
        if u == 0 { 1.0 } else { i as f32 / u as f32 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_interpolates_between_centres() {
        let mut s = Silhouette::empty(4);
        s.data[4 + 1] = 1.0; // row 1, col 1
        let at = |col, row| s.bilinear(PixelPos { col, row });
        assert_eq!(at(1.0, 1.0), 1.0);
        assert!((at(1.5, 1.0) - 0.5).abs() < 1e-6);
        assert!((at(1.5, 1.5) - 0.25).abs() < 1e-6);
        assert!((at(0.75, 1.0) - 0.75).abs() < 1e-6);
        assert_eq!(at(3.0, 3.0), 0.0);
        // Off the image it fades to background.
        assert_eq!(at(-2.0, 1.0), 0.0);
        assert_eq!(s.nearest(PixelPos { col: 1.4, row: 0.6 }), 1.0);
    }
}
