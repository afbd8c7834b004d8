//! Pixel helpers with the `image` crate: the series palette, atomic PNG writing, rectangles and
//! lines, silhouettes with dots on them, and grids of panels (galleries, contact sheets,
//! `samples.png`). Charts with axes and words are `crate::charts` (plotters).

use std::path::Path;

use anyhow::Result;
use fieldprobe_core::data::Silhouette;
use fieldprobe_core::data::dataset::write_atomic;
use image::{Rgb, RgbImage};

/// Series colours (Tableau 10) with their names, for legends written next to a picture.
pub const PALETTE: [(&str, [u8; 3]); 10] = [
    ("blue", [31, 119, 180]),
    ("orange", [255, 127, 14]),
    ("green", [44, 160, 44]),
    ("red", [214, 39, 40]),
    ("purple", [148, 103, 189]),
    ("brown", [140, 86, 75]),
    ("pink", [227, 119, 194]),
    ("grey", [127, 127, 127]),
    ("olive", [188, 189, 34]),
    ("cyan", [23, 190, 207]),
];

/// The colour of series `i` and its name.
pub fn color(i: usize) -> (&'static str, Rgb<u8>) {
    let (name, c) = PALETTE[i % PALETTE.len()];
    (name, Rgb(c))
}

/// `#rrggbb` of a colour.
pub fn hex(c: Rgb<u8>) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0[0], c.0[1], c.0[2])
}

pub const WHITE: Rgb<u8> = Rgb([255, 255, 255]);

/// Writes `img` as a PNG, atomically.
pub fn write_png(path: &Path, img: &RgbImage) -> Result<()> {
    write_atomic(path, |w| {
        img.write_to(w, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Primitives
// ---------------------------------------------------------------------------------------------

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A filled axis-aligned rectangle `[x, x + w) × [y, y + h)`.
pub fn fill_rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, c: Rgb<u8>) {
    for yy in y..y + h {
        for xx in x..x + w {
            put(img, xx, yy, c);
        }
    }
}

/// A line from `a` to `b` of `thickness` pixels (a square brush stepped along it).
pub fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), thickness: i64, c: Rgb<u8>) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as i64).max(1);
    let lo = -(thickness - 1) / 2;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let x = (a.0 + t * (b.0 - a.0)).round() as i64;
        let y = (a.1 + t * (b.1 - a.1)).round() as i64;
        fill_rect(img, x + lo, y + lo, thickness, thickness, c);
    }
}

// ---------------------------------------------------------------------------------------------
// Silhouettes with dots
// ---------------------------------------------------------------------------------------------

/// A silhouette at `zoom`× as a light grey shape on white.
pub fn silhouette_panel(sil: &Silhouette, zoom: u32) -> RgbImage {
    let s = sil.size as u32;
    RgbImage::from_fn(s * zoom, s * zoom, |x, y| {
        let a = sil
            .get(((y / zoom) * s + x / zoom) as usize)
            .clamp(0.0, 1.0);
        let v = (255.0 - a * 90.0).round() as u8;
        Rgb([v, v, v])
    })
}

/// Draws a `size × size` dot at each continuous pixel position `(col, row)` (pixel centres at
/// integers, as `PixelPos`) of a panel made at `zoom`×. Off-panel dots are clipped.
pub fn dots(img: &mut RgbImage, positions: &[(f32, f32)], zoom: u32, size: i64, c: Rgb<u8>) {
    let z = zoom as f32;
    for &(col, row) in positions {
        if !(col.is_finite() && row.is_finite()) {
            continue;
        }
        let x = ((col + 0.5) * z).floor() as i64;
        let y = ((row + 0.5) * z).floor() as i64;
        fill_rect(img, x - size / 2, y - size / 2, size, size, c);
    }
}

/// Panels laid out in rows (all panels the same size), `gap` pixels apart and around, on a
/// `background`.
pub fn grid(rows: &[Vec<RgbImage>], gap: u32, background: Rgb<u8>) -> RgbImage {
    let (pw, ph) = rows
        .first()
        .and_then(|r| r.first())
        .map_or((1, 1), |p| p.dimensions());
    let cols = rows.iter().map(Vec::len).max().unwrap_or(1).max(1) as u32;
    let n = rows.len().max(1) as u32;
    let mut img = RgbImage::from_pixel(cols * (pw + gap) + gap, n * (ph + gap) + gap, background);
    for (r, row) in rows.iter().enumerate() {
        for (c, p) in row.iter().enumerate() {
            let (x0, y0) = (gap + c as u32 * (pw + gap), gap + r as u32 * (ph + gap));
            for (x, y, px) in p.enumerate_pixels() {
                if x < pw && y < ph {
                    img.put_pixel(x0 + x, y0 + y, *px);
                }
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(img: &RgbImage, c: Rgb<u8>) -> usize {
        img.pixels().filter(|p| **p == c).count()
    }

    #[test]
    fn dots_land_on_their_pixels_over_the_silhouette() {
        let mut sil = Silhouette::empty(8);
        sil.values_mut()[2 * 8 + 3] = 1.0; // row 2, col 3
        let mut img = silhouette_panel(&sil, 4);
        assert_eq!(img.dimensions(), (32, 32));
        assert_eq!(*img.get_pixel(0, 0), WHITE);
        assert_ne!(
            *img.get_pixel(3 * 4 + 1, 2 * 4 + 1),
            WHITE,
            "silhouette pixel"
        );
        let red = Rgb([200, 0, 0]);
        dots(&mut img, &[(5.0, 6.0), (-9.0, 100.0)], 4, 2, red);
        assert_eq!(*img.get_pixel(5 * 4 + 2, 6 * 4 + 2), red);
        assert_eq!(count(&img, red), 4);
        let sheet = grid(
            &[vec![img.clone(), img.clone()], vec![img]],
            3,
            Rgb([0, 0, 0]),
        );
        assert_eq!(sheet.dimensions(), (2 * 35 + 3, 2 * 35 + 3));
        assert_eq!(count(&sheet, red), 12);
    }
}
