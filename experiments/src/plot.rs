//! Minimal PNG plotting with the `image` crate: line charts (axes, grid, tick labels, a legend of
//! coloured numbered boxes) and dot overlays on silhouettes. Text is limited to a built-in 3×5
//! bitmap font of digits and `. - + e`; names go into the Markdown that shows the picture.

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
const BLACK: Rgb<u8> = Rgb([0, 0, 0]);
const GRID: Rgb<u8> = Rgb([225, 225, 225]);

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

/// 3×5 glyphs, one row per entry top to bottom, bit 2 = left column.
fn glyph(ch: char) -> Option<[u8; 5]> {
    Some(match ch {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        'e' => [2, 5, 7, 4, 3],
        ' ' => [0; 5],
        _ => return None,
    })
}

/// Width in pixels of `text` drawn at `scale`.
pub fn text_width(text: &str, scale: i64) -> i64 {
    (text.chars().count() as i64 * 4 - 1).max(0) * scale
}

/// Draws `text` (digits, `. - + e` and space; other characters are skipped) with its top-left
/// corner at `(x, y)`; each font pixel is a `scale × scale` block, glyphs are 3 wide + 1 apart.
pub fn text(img: &mut RgbImage, x: i64, y: i64, text: &str, scale: i64, c: Rgb<u8>) {
    for (i, ch) in text.chars().enumerate() {
        let Some(rows) = glyph(ch) else { continue };
        let gx = x + i as i64 * 4 * scale;
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    fill_rect(img, gx + col * scale, y + r as i64 * scale, scale, scale, c);
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Line charts
// ---------------------------------------------------------------------------------------------

/// One polyline of a chart.
#[derive(Clone, Debug)]
pub struct Series {
    pub points: Vec<(f64, f64)>,
    pub color: Rgb<u8>,
    /// The series' legend label (digits and `. - + e` only, e.g. its number).
    pub label: String,
}

/// The chart's layout, so that tests can locate data in the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartFrame {
    /// Plot area in pixels: left, top, right, bottom.
    pub left: f64,
    pub top: f64,
    pub right: f64,
    pub bottom: f64,
    pub x_range: (f64, f64),
    /// In log10 units when `log_y`.
    pub y_range: (f64, f64),
    pub log_y: bool,
}

impl ChartFrame {
    /// Pixel position of a data point.
    pub fn to_pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let y = if self.log_y { y.log10() } else { y };
        let tx = (x - self.x_range.0) / (self.x_range.1 - self.x_range.0);
        let ty = (y - self.y_range.0) / (self.y_range.1 - self.y_range.0);
        (
            self.left + tx * (self.right - self.left),
            self.bottom - ty * (self.bottom - self.top),
        )
    }
}

/// "Nice" linear ticks covering `[lo, hi]` (steps 1, 2 or 5 × 10^k, at most about 6).
pub fn linear_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).abs().max(f64::MIN_POSITIVE);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// Log ticks (1, 2, 5 × 10^k) inside `[lo, hi]` (both positive).
pub fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for k in lo.log10().floor() as i32 - 1..=hi.log10().ceil() as i32 {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(k);
            if v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9) {
                out.push(v);
            }
        }
    }
    out
}

/// The y ticks of `[lo, hi]` (data units): [`log_ticks`] on a log axis unless that gives fewer
/// than 3 (a range under a factor of about 2.5), then nice linear values; else [`linear_ticks`].
pub fn y_ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if !log {
        return linear_ticks(lo, hi);
    }
    let t = log_ticks(lo, hi);
    if t.len() >= 3 {
        t
    } else {
        linear_ticks(lo, hi)
            .into_iter()
            .filter(|v| *v > 0.0)
            .collect()
    }
}

/// A short label for a tick value: `1200`, `0.05`, `2e-4`.
pub fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.0e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// A line chart of `series` on a `width × height` white canvas: axes, light grid lines at the
/// ticks, tick labels, and a legend of boxes in the series colours with their labels in the top
/// right. With `log_y` (and all y positive) the y axis is logarithmic. Series with fewer than one
/// point are skipped; a single point is drawn as a dot.
pub fn line_chart(
    series: &[Series],
    width: u32,
    height: u32,
    log_y: bool,
) -> (RgbImage, ChartFrame) {
    let mut img = RgbImage::from_pixel(width, height, WHITE);
    let pts = series.iter().flat_map(|s| s.points.iter().copied());
    let finite: Vec<(f64, f64)> = pts.filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
    let log_y = log_y && !finite.is_empty() && finite.iter().all(|p| p.1 > 0.0);
    let fy = |y: f64| if log_y { y.log10() } else { y };
    let (mut x0, mut x1) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let (mut y0, mut y1) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(fy(p.1)), b.max(fy(p.1)))
        });
    if !x0.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    if !y0.is_finite() {
        (y0, y1) = (0.0, 1.0);
    }
    if x1 - x0 < 1e-12 {
        (x0, x1) = (x0 - 1.0, x1 + 1.0);
    }
    if y1 - y0 < 1e-12 {
        let d = if log_y { 0.1 } else { y0.abs().max(1.0) * 0.1 };
        (y0, y1) = (y0 - d, y1 + d);
    }
    let pad = 0.06 * (y1 - y0);
    (y0, y1) = (y0 - pad, y1 + pad);
    if !log_y && y0 < 0.0 && finite.iter().all(|p| p.1 >= 0.0) {
        y0 = 0.0;
    }

    let scale = 2;
    let frame = ChartFrame {
        left: 14.0 + text_width("0.0000", scale) as f64,
        top: 12.0,
        right: width as f64 - 16.0,
        bottom: height as f64 - 20.0 - 5.0 * scale as f64,
        x_range: (x0, x1),
        y_range: (y0, y1),
        log_y,
    };
    let yticks = if log_y {
        y_ticks(10f64.powf(y0), 10f64.powf(y1), true)
    } else {
        y_ticks(y0, y1, false)
    };
    for &t in &yticks {
        let (_, py) = frame.to_pixel(x0, t);
        line(&mut img, (frame.left, py), (frame.right, py), 1, GRID);
        let label = tick_label(t);
        let lx = frame.left as i64 - 6 - text_width(&label, scale);
        text(
            &mut img,
            lx,
            py as i64 - 5 * scale / 2,
            &label,
            scale,
            BLACK,
        );
    }
    for t in linear_ticks(x0, x1) {
        let (px, _) = frame.to_pixel(t, if log_y { 10f64.powf(y0) } else { y0 });
        line(&mut img, (px, frame.top), (px, frame.bottom), 1, GRID);
        let label = tick_label(t);
        let lx = px as i64 - text_width(&label, scale) / 2;
        text(&mut img, lx, frame.bottom as i64 + 6, &label, scale, BLACK);
    }
    line(
        &mut img,
        (frame.left, frame.bottom),
        (frame.right, frame.bottom),
        1,
        BLACK,
    );
    line(
        &mut img,
        (frame.left, frame.top),
        (frame.left, frame.bottom),
        1,
        BLACK,
    );
    for s in series {
        let p: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite() && (!log_y || p.1 > 0.0))
            .map(|&(x, y)| frame.to_pixel(x, y))
            .collect();
        match p.len() {
            0 => {}
            1 => fill_rect(
                &mut img,
                p[0].0 as i64 - 2,
                p[0].1 as i64 - 2,
                5,
                5,
                s.color,
            ),
            _ => {
                for w in p.windows(2) {
                    line(&mut img, w[0], w[1], 2, s.color);
                }
            }
        }
    }
    // Legend: labelled colour boxes, top right.
    let box_h = 5 * scale + 6;
    for (i, s) in series.iter().enumerate() {
        let label = &s.label;
        let w = text_width(label, scale) + 24;
        let x = frame.right as i64 - w - 6;
        let y = frame.top as i64 + 6 + i as i64 * (box_h + 4);
        fill_rect(&mut img, x, y, w, box_h, WHITE);
        fill_rect(&mut img, x + 3, y + 3, 14, box_h - 6, s.color);
        text(&mut img, x + 21, y + 3, label, scale, BLACK);
    }
    (img, frame)
}

/// Training-loss histories `(step, loss)` on a log-y chart (800 × 480): history `(i, h)` in
/// colour `i`, labelled `i + 1` in the legend.
pub fn loss_chart(histories: &[(usize, &[(usize, f32)])]) -> RgbImage {
    let series: Vec<Series> = histories
        .iter()
        .map(|&(i, h)| Series {
            points: h.iter().map(|&(s, l)| (s as f64, f64::from(l))).collect(),
            color: color(i).1,
            label: (i + 1).to_string(),
        })
        .collect();
    line_chart(&series, 800, 480, true).0
}

/// One run's loss and its terms on a log-y chart (800 × 480): `1` the total, `2` the silhouette
/// term, `3` the regularizers (drawn only when they contributed).
pub fn loss_terms_chart(history: &[(usize, f32)], terms: &[(usize, f32, f32)]) -> RgbImage {
    let sil: Vec<(usize, f32)> = terms.iter().map(|&(s, l, _)| (s, l)).collect();
    let reg: Vec<(usize, f32)> = terms.iter().map(|&(s, _, r)| (s, r)).collect();
    let mut all = vec![(0, history)];
    if !sil.is_empty() {
        all.push((1, sil.as_slice()));
    }
    if reg.iter().any(|&(_, r)| r > 0.0) {
        all.push((2, reg.as_slice()));
    }
    loss_chart(&all)
}

// ---------------------------------------------------------------------------------------------
// Silhouettes with dots
// ---------------------------------------------------------------------------------------------

/// A silhouette at `zoom`× as a light grey shape on white.
pub fn silhouette_panel(sil: &Silhouette, zoom: u32) -> RgbImage {
    let s = sil.size as u32;
    RgbImage::from_fn(s * zoom, s * zoom, |x, y| {
        let a = sil.data[((y / zoom) * s + x / zoom) as usize].clamp(0.0, 1.0);
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
    fn a_chart_has_its_size_and_its_curves_where_the_data_are() {
        let falling = Series {
            points: (0..=10)
                .map(|i| (i as f64 * 100.0, 0.2 / (1.0 + i as f64)))
                .collect(),
            color: color(0).1,
            label: "1".into(),
        };
        let flat = Series {
            points: vec![(0.0, 0.05), (1000.0, 0.05)],
            color: color(1).1,
            label: "2".into(),
        };
        for log_y in [true, false] {
            let (img, frame) = line_chart(&[falling.clone(), flat.clone()], 640, 400, log_y);
            assert_eq!(img.dimensions(), (640, 400));
            assert_eq!(frame.log_y, log_y);
            // Each curve passes through its data points.
            for (s, (x, y)) in [
                (&falling, falling.points[4]),
                (&falling, falling.points[10]),
                (&flat, (500.0, 0.05)),
            ] {
                let (px, py) = frame.to_pixel(x, y);
                let near = (-2..=2).any(|dx| {
                    (-2..=2).any(|dy| {
                        *img.get_pixel((px as i64 + dx) as u32, (py as i64 + dy) as u32) == s.color
                    })
                });
                assert!(
                    near,
                    "no curve pixel near ({x}, {y}) → ({px}, {py}), log {log_y}"
                );
            }
            assert!(count(&img, falling.color) > 200 && count(&img, flat.color) > 200);
            // Nothing is drawn in the corner above the data, left of the legend.
            let (px, py) = frame.to_pixel(700.0, 0.13);
            assert_eq!(*img.get_pixel(px as u32, py as u32), WHITE);
            // Tick labels are drawn (black pixels left of the plot area).
            let labels = (0..frame.left as u32 - 4)
                .flat_map(|x| (0..400).map(move |y| (x, y)))
                .filter(|&(x, y)| *img.get_pixel(x, y) == BLACK)
                .count();
            assert!(labels > 20, "{labels}");
        }
        // Degenerate input still gives a picture.
        let (img, _) = line_chart(&[], 100, 80, true);
        assert_eq!(img.dimensions(), (100, 80));
    }

    #[test]
    fn ticks_are_nice_and_inside() {
        assert_eq!(
            linear_ticks(0.0, 1000.0),
            [0.0, 200.0, 400.0, 600.0, 800.0, 1000.0]
        );
        assert_eq!(log_ticks(0.03, 0.3), [0.05, 0.1, 0.2]);
        assert_eq!(y_ticks(0.03, 0.3, true), [0.05, 0.1, 0.2]);
        assert_eq!(
            y_ticks(0.19, 0.31, true).len(),
            3,
            "{:?}",
            y_ticks(0.19, 0.31, true)
        );
        assert_eq!(tick_label(0.05), "0.05");
        assert_eq!(tick_label(1200.0), "1200");
        assert_eq!(tick_label(2e-4), "2e-4");
    }

    #[test]
    fn dots_land_on_their_pixels_over_the_silhouette() {
        let mut sil = Silhouette::empty(8);
        sil.data[2 * 8 + 3] = 1.0; // row 2, col 3
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
        let sheet = grid(&[vec![img.clone(), img.clone()], vec![img]], 3, BLACK);
        assert_eq!(sheet.dimensions(), (2 * 35 + 3, 2 * 35 + 3));
        assert_eq!(count(&sheet, red), 12);
    }
}
