//! Line charts with words: a title, axis titles with units, tick labels and a legend of the
//! series' names, drawn by `plotters` as a PNG (its bitmap backend, text from the embedded
//! DejaVu Sans, so the picture reads the same on every machine) and an SVG beside it (vector,
//! for papers and slides). A chart shared without its Markdown still says what it shows.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{Result, anyhow};
use image::Rgb;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use crate::plot;

/// The embedded font (DejaVu Sans 2.37; license in `experiments/assets/`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// The family name charts ask for.
const FAMILY: &str = "sans-serif";

/// Registers [`FONT`] with plotters once.
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
            .unwrap_or_else(|_| panic!("the embedded font parses"));
    });
}

/// One named polyline.
#[derive(Clone, Debug)]
pub struct Series {
    /// Shown in the legend (any text: a variant's name, "silhouette term").
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub color: Rgb<u8>,
}

/// A line chart: what it shows, in words, and its data.
#[derive(Clone, Debug)]
pub struct LineChart {
    pub title: String,
    /// The x axis' title with its unit, e.g. "training step".
    pub x_label: String,
    /// The y axis' title with its unit, e.g. "loss (mean per logged interval)"; " (log scale)"
    /// is added when the axis is logarithmic.
    pub y_label: String,
    /// Logarithmic y, used when every value is positive and they span more than a decade.
    pub log_y: bool,
    /// A dot at every point (for short series: a budget sweep's few runs, where the points are
    /// the data and the lines only join them).
    pub markers: bool,
    pub series: Vec<Series>,
}

/// Pixel size of the PNG (and of the SVG's view box).
pub const SIZE: (u32, u32) = (800, 480);

impl LineChart {
    /// The finite points of every series (positive ones only on a log axis) and the axis ranges.
    fn ranges(&self) -> (bool, Range<f64>, Range<f64>) {
        let all: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        // A log axis only where it helps: positive data spanning more than a decade (plotters
        // labels a log axis at powers of ten, so a narrower one would have no y labels).
        let positive = !all.is_empty() && all.iter().all(|p| p.1 > 0.0);
        let (lo, hi) = all.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
        let log = self.log_y && positive && hi / lo > 10.0;
        let span = |v: &mut dyn Iterator<Item = f64>| {
            v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
        };
        let (mut x0, mut x1) = span(&mut all.iter().map(|p| p.0));
        let (mut y0, mut y1) = span(&mut all.iter().map(|p| p.1));
        if all.is_empty() {
            (x0, x1, y0, y1) = (0.0, 1.0, if log { 0.1 } else { 0.0 }, 1.0);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if log {
            (y0, y1) = (y0 / 1.25, y1 * 1.25);
        } else {
            let pad = ((y1 - y0) * 0.05).max(1e-6);
            (y0, y1) = (y0 - pad, y1 + pad);
        }
        (log, x0..x1, y0..y1)
    }

    /// Draws the chart on any plotters backend.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let (log, x, y) = self.ranges();
        if log {
            let label = format!("{} (log scale)", self.y_label);
            self.draw_on(root, x, y.log_scale(), &label)
        } else {
            self.draw_on(root, x, y, &self.y_label)
        }
    }

    fn draw_on<DB: DrawingBackend, Y>(
        &self,
        root: &DrawingArea<DB, Shift>,
        x: Range<f64>,
        y: Y,
        y_label: &str,
    ) -> Result<()>
    where
        Y: AsRangedCoord<Value = f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("cannot draw the chart: {e}");
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FAMILY, 20))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x, y)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(y_label)
            .x_label_formatter(&|x| {
                if x.fract() == 0.0 {
                    format!("{x:.0}")
                } else {
                    format!("{x}")
                }
            })
            .label_style((FAMILY, 13))
            .axis_desc_style((FAMILY, 15))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(err)?;
        for s in &self.series {
            let color = RGBColor(s.color[0], s.color[1], s.color[2]);
            let points = s
                .points
                .iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite());
            chart
                .draw_series(
                    LineSeries::new(points, color.stroke_width(2)).point_size(if self.markers {
                        4
                    } else {
                        0
                    }),
                )
                .map_err(err)?
                .label(&s.label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(3))
                });
        }
        if !self.series.is_empty() {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .label_font((FAMILY, 14))
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
        Ok(())
    }

    /// The chart as an RGB picture of [`SIZE`].
    pub fn to_image(&self) -> Result<image::RgbImage> {
        register_font();
        let (w, h) = SIZE;
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            self.draw(&root)?;
        }
        image::RgbImage::from_raw(w, h, buf).ok_or_else(|| anyhow!("chart buffer size"))
    }

    /// The chart as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
            self.draw(&root)?;
        }
        Ok(svg)
    }

    /// Writes `png` and the SVG beside it (same stem), both atomically; returns the SVG's path.
    pub fn write(&self, png: &Path) -> Result<PathBuf> {
        plot::write_png(png, &self.to_image()?)?;
        let svg_path = png.with_extension("svg");
        let svg = self.to_svg()?;
        fieldprobe::data::dataset::write_atomic(&svg_path, |w| {
            std::io::Write::write_all(w, svg.as_bytes())
        })?;
        Ok(svg_path)
    }
}

/// A loss history `(step, loss)` as chart points.
pub fn points(history: &[(usize, f32)]) -> Vec<(f64, f64)> {
    history
        .iter()
        .map(|&(s, l)| (s as f64, f64::from(l)))
        .collect()
}

/// One run's training curve: the total loss, the silhouette term and (when they contributed) the
/// regularizers, per logged interval, log y.
pub fn loss_terms(history: &[(usize, f32)], terms: &[(usize, f32, f32)]) -> LineChart {
    let mut series = vec![Series {
        label: "total loss".into(),
        points: points(history),
        color: plot::color(0).1,
    }];
    if !terms.is_empty() {
        let sil: Vec<(usize, f32)> = terms.iter().map(|&(s, l, _)| (s, l)).collect();
        series.push(Series {
            label: "silhouette term (L_sil)".into(),
            points: points(&sil),
            color: plot::color(1).1,
        });
        let reg: Vec<(usize, f32)> = terms.iter().map(|&(s, _, r)| (s, r)).collect();
        if reg.iter().any(|&(_, r)| r > 0.0) {
            series.push(Series {
                label: "regularizers (λ·L_geo, summed)".into(),
                points: points(&reg),
                color: plot::color(2).1,
            });
        }
    }
    LineChart {
        title: "Training loss".into(),
        x_label: "training step".into(),
        y_label: "loss, mean per logged interval".into(),
        log_y: true,
        markers: false,
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart() -> LineChart {
        let h: Vec<(usize, f32)> = (1..=50).map(|s| (s * 10, 1.0 / s as f32)).collect();
        let t: Vec<(usize, f32, f32)> = h.iter().map(|&(s, l)| (s, 0.9 * l, 0.1 * l)).collect();
        loss_terms(&h, &t)
    }

    #[test]
    fn a_chart_is_drawn_with_its_series_colours_and_words() {
        let img = chart().to_image().unwrap();
        assert_eq!(img.dimensions(), SIZE);
        for i in 0..3 {
            let c = plot::color(i).1;
            let n = img.pixels().filter(|p| **p == c).count();
            assert!(n > 100, "series {i}: {n} pixels");
        }
        // Text was rendered (dark anti-aliased glyphs, not only the black axis lines).
        let grey = img
            .pixels()
            .filter(|p| p[0] == p[1] && p[1] == p[2] && (30..200).contains(&p[0]))
            .count();
        assert!(grey > 200, "{grey} grey pixels of text");
        let svg = chart().to_svg().unwrap();
        for words in [
            "Training loss",
            "training step",
            "(log scale)",
            "total loss",
            "silhouette term",
            "regularizers",
        ] {
            assert!(svg.contains(words), "{words} not in the SVG");
        }
    }

    #[test]
    fn empty_and_non_positive_data_still_draw() {
        let mut c = chart();
        c.series[0].points = vec![(0.0, 0.0), (1.0, -1.0)];
        c.to_image().unwrap();
        c.series.clear();
        c.to_image().unwrap();
        c.to_svg().unwrap();
    }

    #[test]
    fn both_files_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("curves.png");
        let svg = chart().write(&png).unwrap();
        assert!(png.is_file() && svg.is_file());
        assert_eq!(svg, dir.path().join("curves.svg"));
    }
}
