//! `report.md`: the run's numbers as Markdown tables, with their context.

use std::fmt::Write;

use crate::experiment::Experiment;
use crate::run::Metrics;

fn opt(v: Option<f32>) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.3}"))
}

/// Renders the report of a finished run.
pub fn render(exp: &Experiment, m: &Metrics) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {}\n", exp.name);
    let views = m.per_category.values().next().map_or(0, |c| c.views);
    let _ = writeln!(
        s,
        "3D IoU at {r}³ in the NMR protocol on the **{split}** split, {views} input view(s) per object; \
         {steps} training steps in {t:.0} s on {dev}; evaluation {e:.0} s.\n",
        r = m.resolution,
        split = m.split,
        steps = m.steps,
        t = m.train_seconds,
        dev = m.device,
        e = m.eval_seconds
    );
    let _ = writeln!(
        s,
        "| category | objects | model IoU | visual hull (24 views) | category mean shape | mean GT shape (3D prior) | silhouette IoU |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for (name, c) in &m.per_category {
        let _ = writeln!(
            s,
            "| {name} | {} | {:.3} | {:.3} | {} | {} | {} |",
            c.objects,
            c.iou,
            c.visual_hull_iou,
            opt(c.mean_shape_iou),
            opt(c.mean_gt_shape_iou),
            opt(c.silhouette_iou)
        );
    }
    let _ = writeln!(
        s,
        "| **mean** | | **{:.3}** | {:.3} | {} | {} | {} |\n",
        m.mean_iou,
        m.visual_hull_iou,
        opt(m.mean_shape_iou),
        opt(m.mean_gt_shape_iou),
        opt(m.silhouette_iou)
    );
    let _ = writeln!(
        s,
        "The visual hull is what the 24 silhouettes alone determine; the category mean shape is the \
         mean of the training objects' visual hulls (the prior silhouettes give), so a model that beats \
         it reads the image. The mean GT shape needs 3D data and is shown for context only."
    );
    if let Some(l) = m.final_loss {
        let _ = writeln!(
            s,
            "\nFinal training loss (mean of the last logged interval): {l:.5}."
        );
    }
    s
}
