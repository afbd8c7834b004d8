//! What each entry of an ablation cost against what it reached: max-pool IoU against training
//! time and against decoder evaluations (the paper's efficiency claim: probing against dense
//! ray marching, `experiments/efficiency/`). Entries that read the field the same way and differ
//! only in their budget (`train.steps`) form one curve.

use std::fmt::Write as _;

use fieldprobe::ablation::entry::{AblationEntry, Status};
use fieldprobe::experiment::Experiment;
use fieldprobe::variants::{AblationFile, inline_of};

use crate::charts::{LineChart, Series};
use crate::plot;

/// How an entry reads the field: its curve in the cost charts.
pub fn method_label(e: &Experiment) -> String {
    let p = &e.probe;
    let agg = inline_of(p.aggregator.as_ref());
    match &p.march {
        None => format!(
            "probing: {} anchors, τ {}, {} rays/view, {agg}",
            p.spec.anchors, p.spec.radius, p.spec.rays_per_view
        ),
        Some(m) => format!(
            "marching: {}, {} rays/view, {agg}",
            inline_of(m.as_ref()),
            p.spec.rays_per_view
        ),
    }
}

/// One finished entry's cost and result, per training seed.
#[derive(Clone, Debug, PartialEq)]
pub struct CostPoint {
    pub entry: usize,
    pub steps: usize,
    pub seconds: f64,
    pub points: f64,
    pub iou: f32,
}

impl CostPoint {
    fn of(entry: usize, e: &AblationEntry) -> Self {
        let seeds = e.seeds.len().max(1) as f64;
        Self {
            entry,
            steps: e.steps,
            seconds: e.train_seconds / seeds,
            points: e.train_decoder_points as f64 / seeds,
            iou: e.mean_iou,
        }
    }
}

/// The finished entries grouped by [`method_label`] in order of first appearance, each curve
/// sorted by training time.
pub fn curves(file: &AblationFile, status: &[Status]) -> Vec<(String, Vec<CostPoint>)> {
    let mut out: Vec<(String, Vec<CostPoint>)> = Vec::new();
    for (i, (v, st)) in file.entries.iter().zip(status).enumerate() {
        let Status::Finished(e) = st else { continue };
        let label = method_label(&v.experiment);
        let point = CostPoint::of(i, e);
        match out.iter_mut().find(|(l, _)| *l == label) {
            Some((_, pts)) => pts.push(point),
            None => out.push((label, vec![point])),
        }
    }
    for (_, pts) in &mut out {
        pts.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    }
    out
}

/// What reaching `iou` costs on `curve` (sorted by `cost`), joining its points by straight
/// lines: the cost where the curve first reaches it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// Interpolated between two budgets (or exactly at one).
    At(f64),
    /// The smallest budget run is already at or above it: it costs at most this.
    AtMost(f64),
    /// No budget run reaches it.
    Never,
}

pub fn cost_to_reach(curve: &[(f64, f32)], iou: f32) -> Reach {
    match curve.first() {
        None => return Reach::Never,
        Some(&(c, y)) if y >= iou => return Reach::AtMost(c),
        _ => {}
    }
    for w in curve.windows(2) {
        let ((c0, y0), (c1, y1)) = (w[0], w[1]);
        if y1 >= iou && y0 < iou {
            let t = f64::from((iou - y0) / (y1 - y0));
            return Reach::At(c0 + t * (c1 - c0));
        }
    }
    Reach::Never
}

/// IoU against training seconds (first) and against decoder evaluations (second), one curve per
/// method.
pub fn cost_charts(file: &AblationFile, status: &[Status]) -> [LineChart; 2] {
    let groups = curves(file, status);
    let chart = |title: &str, x: &str, f: &dyn Fn(&CostPoint) -> f64| LineChart {
        title: title.into(),
        x_label: x.into(),
        y_label: "max-pool IoU (NMR protocol)".into(),
        log_y: false,
        markers: true,
        series: groups
            .iter()
            .enumerate()
            .map(|(i, (label, pts))| Series {
                label: label.clone(),
                points: pts.iter().map(|p| (f(p), f64::from(p.iou))).collect(),
                color: plot::color(i).1,
            })
            .collect(),
    };
    [
        chart(
            "IoU against training time",
            "training time per seed (s)",
            &|p| p.seconds,
        ),
        chart(
            "IoU against decoder evaluations",
            "decoder evaluations in training, millions (silhouette term)",
            &|p| p.points / 1e6,
        ),
    ]
}

/// The report's "Cost" section: the table, the charts and, for every curve after the first, what
/// the first curve (the base's method) needs to reach the same IoU.
pub fn render_cost(file: &AblationFile, status: &[Status]) -> String {
    let mut s = String::new();
    let groups = curves(file, status);
    if groups.is_empty() {
        return s;
    }
    let _ = writeln!(s, "\n## Cost\n");
    let _ = writeln!(
        s,
        "What each finished entry spent in training (per seed) and what it reached. Decoder \
         evaluations are the points the rays read, summed over the steps (regularizer stencils \
         not counted); entries that read the field the same way and differ in budget form one \
         curve of `cost_time.png` and `cost_points.png` (also as SVG).\n"
    );
    let _ = writeln!(
        s,
        "| # | entry | method | steps | train (s) | decoder evaluations | per step | IoU |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for (label, pts) in &groups {
        for p in pts {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {:.0} | {:.3e} | {:.0} | {:.3} |",
                p.entry + 1,
                file.entries[p.entry].name,
                label.replace('|', "\\|"),
                p.steps,
                p.seconds,
                p.points,
                p.points / p.steps.max(1) as f64,
                p.iou
            );
        }
    }
    let _ = writeln!(s, "\n![IoU against time](cost_time.png)\n");
    let _ = writeln!(s, "![IoU against decoder evaluations](cost_points.png)\n");
    let (base_label, base) = &groups[0];
    if groups.len() > 1 {
        let _ = writeln!(
            s,
            "At equal IoU: for each entry of another method, the training time and decoder \
             evaluations that `{base_label}` needs to reach the same IoU (its budgets joined by \
             straight lines), and the ratio of the entry's cost to that.\n"
        );
        let _ = writeln!(
            s,
            "| entry | IoU | its time (s) | base method's time (s) | time ratio | its evaluations | base method's | evaluation ratio |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
        let by = |f: &dyn Fn(&CostPoint) -> f64| -> Vec<(f64, f32)> {
            let mut c: Vec<(f64, f32)> = base.iter().map(|p| (f(p), p.iou)).collect();
            c.sort_by(|a, b| a.0.total_cmp(&b.0));
            c
        };
        let (time_curve, point_curve) = (by(&|p| p.seconds), by(&|p| p.points));
        let cell = |r: Reach, own: f64, fmt: &dyn Fn(f64) -> String| match r {
            Reach::At(c) => (fmt(c), format!("{:.2}", own / c)),
            Reach::AtMost(c) => (format!("≤ {}", fmt(c)), format!("≥ {:.2}", own / c)),
            Reach::Never => ("not reached".into(), "–".into()),
        };
        for (_, pts) in &groups[1..] {
            for p in pts {
                let (t, tr) = cell(cost_to_reach(&time_curve, p.iou), p.seconds, &|c| {
                    format!("{c:.0}")
                });
                let (e, er) = cell(cost_to_reach(&point_curve, p.iou), p.points, &|c| {
                    format!("{c:.3e}")
                });
                let _ = writeln!(
                    s,
                    "| {} | {:.3} | {:.0} | {t} | {tr} | {:.3e} | {e} | {er} |",
                    file.entries[p.entry].name, p.iou, p.seconds, p.points
                );
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(r: Reach) -> f64 {
        match r {
            Reach::At(c) => c,
            other => panic!("expected an interpolated cost, got {other:?}"),
        }
    }

    #[test]
    fn cost_to_reach_interpolates_between_budgets() {
        let curve = [(10.0, 0.4f32), (30.0, 0.6), (90.0, 0.7)];
        assert!((at(cost_to_reach(&curve, 0.5)) - 20.0).abs() < 1e-4);
        assert!((at(cost_to_reach(&curve, 0.7)) - 90.0).abs() < 1e-4);
        assert_eq!(cost_to_reach(&curve, 0.3), Reach::AtMost(10.0));
        assert_eq!(cost_to_reach(&curve, 0.75), Reach::Never);
        assert_eq!(cost_to_reach(&[], 0.1), Reach::Never);
        // A curve that dips: the first crossing counts.
        let dip = [(1.0, 0.2f32), (2.0, 0.5), (3.0, 0.3), (4.0, 0.6)];
        assert!((at(cost_to_reach(&dip, 0.4)) - (1.0 + 2.0 / 3.0)).abs() < 1e-4);
    }
}
