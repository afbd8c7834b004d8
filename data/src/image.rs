//! Silhouettes (alpha masks) and their sub-pixel lookup.

use std::sync::Arc;

use crate::geometry::PixelPos;

/// A square single-channel image with values in `[0, 1]`, row-major, row 0 at the top.
///
/// A silhouette read from a dataset is the alpha plane of its RGBA picture: it can view that
/// plane in place ([`Silhouette::shared_alpha`]), so a training object holds its pictures once
/// instead of a second, four-times-larger f32 copy of every alpha plane (issue 13: bounded memory
/// at Kato's scale). The value of an 8-bit alpha `a` is `a / 255` either way, so both storages
/// give bit-identical lookups. Writing ([`Silhouette::values_mut`]) turns a view into an owned
/// f32 image.
#[derive(Clone, Debug)]
pub struct Silhouette {
    pub size: usize,
    values: Values,
}

#[derive(Clone, Debug)]
enum Values {
    /// Owned values (rendered coverage, predictions, test images).
    Float(Vec<f32>),
    /// `size²` alpha bytes starting at `start` inside a shared buffer.
    Alpha { bytes: Arc<[u8]>, start: usize },
}

impl PartialEq for Silhouette {
    fn eq(&self, other: &Self) -> bool {
        self.size == other.size && self.values().eq(other.values())
    }
}

impl Silhouette {
    /// An all-background silhouette.
    pub fn empty(size: usize) -> Self {
        Self::from_values(size, vec![0.0; size * size])
    }

    /// From `size²` row-major values.
    pub fn from_values(size: usize, values: Vec<f32>) -> Self {
        assert_eq!(values.len(), size * size, "a silhouette of side {size}");
        Self {
            size,
            values: Values::Float(values),
        }
    }

    /// From 8-bit alpha values (`0..=255`), copied.
    pub fn from_u8(size: usize, alpha: &[u8]) -> Self {
        assert_eq!(alpha.len(), size * size, "a silhouette of side {size}");
        Self::shared_alpha(size, alpha.into(), 0)
    }

    /// A view of the `size²` alpha bytes at `bytes[start..]`, shared rather than copied.
    pub fn shared_alpha(size: usize, bytes: Arc<[u8]>, start: usize) -> Self {
        assert!(
            start + size * size <= bytes.len(),
            "alpha plane {start}..{} outside a buffer of {} bytes",
            start + size * size,
            bytes.len()
        );
        Self {
            size,
            values: Values::Alpha { bytes, start },
        }
    }

    /// Number of pixels (`size²`).
    pub fn len(&self) -> usize {
        self.size * self.size
    }

    /// Whether the image has no pixels.
    pub fn is_empty(&self) -> bool {
        self.size == 0
    }

    /// Value of the pixel at row-major index `i`.
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        match &self.values {
            Values::Float(v) => v[i],
            Values::Alpha { bytes, start } => {
                assert!(
                    i < self.len(),
                    "pixel {i} of a {0}×{0} silhouette",
                    self.size
                );
                bytes[start + i] as f32 / 255.0
            }
        }
    }

    /// Every value, row-major.
    pub fn values(&self) -> impl Iterator<Item = f32> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    /// The values for writing; a shared alpha view becomes an owned copy first.
    pub fn values_mut(&mut self) -> &mut [f32] {
        if let Values::Alpha { .. } = self.values {
            self.values = Values::Float(self.values().collect());
        }
        match &mut self.values {
            Values::Float(v) => v,
            Values::Alpha { .. } => unreachable!("converted above"),
        }
    }

    /// Value of pixel `(row, col)`; zero outside the image (everything off-image is background).
    pub fn pixel(&self, row: isize, col: isize) -> f32 {
        let n = self.size as isize;
        if row < 0 || col < 0 || row >= n || col >= n {
            0.0
        } else {
            self.get(row as usize * self.size + col as usize)
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
        for (a, b) in self.values().zip(other.values()) {
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
        s.values_mut()[4 + 1] = 1.0; // row 1, col 1
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

    #[test]
    fn a_shared_alpha_plane_reads_like_its_owned_copy() {
        let bytes: Arc<[u8]> = (0..=255u8).chain(0..=255).collect();
        let view = Silhouette::shared_alpha(4, bytes.clone(), 300);
        let owned =
            Silhouette::from_values(4, (300..316).map(|i| bytes[i] as f32 / 255.0).collect());
        assert_eq!(view, owned);
        for i in 0..16 {
            assert_eq!(view.get(i).to_bits(), owned.get(i).to_bits());
        }
        let p = PixelPos { col: 1.3, row: 2.6 };
        assert_eq!(view.bilinear(p).to_bits(), owned.bilinear(p).to_bits());
        let mut written = view.clone();
        written.values_mut()[0] = 1.0;
        assert_eq!(written.get(0), 1.0);
        assert_eq!(
            view.get(0),
            bytes[300] as f32 / 255.0,
            "the shared bytes are untouched"
        );
    }
}
