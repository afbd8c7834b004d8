//! `report.md`: the run's numbers as Markdown tables, with their context.

use std::fmt::Write;

use crate::gallery::GalleryRow;
use fieldprobe::experiment::Experiment;
use fieldprobe::metrics::Metrics;

fn opt(v: Option<f32>) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.3}"))
}

/// Renders the report of a finished run; `gallery` lists the rows of `gallery.png` (none: no
/// gallery), `curves` says whether `training_curves.png` was written.
pub fn render(exp: &Experiment, m: &Metrics, gallery: &[GalleryRow], curves: bool) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {}\n", exp.name);
    let views = m.per_category.values().next().map_or(0, |c| c.views);
    let _ = writeln!(
        s,
        "3D IoU at {r}³ in the NMR protocol on the **{split}** split, {views} input view(s) per object; \
         {steps} training steps in {t:.0} s on {dev}; evaluation {e:.0} s ({g:.2} M field points \
         for the predictions' voxels).\n",
        r = m.resolution,
        split = m.split,
        steps = m.steps,
        t = m.train_seconds,
        dev = m.device,
        e = m.eval_seconds,
        g = m.eval_grid_points as f64 / 1e6
    );
    let _ = writeln!(
        s,
        "| category | objects | model IoU | centre IoU | outside hull | visual hull (24 views) | category mean shape | mean GT shape (3D prior) | silhouette IoU |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for (name, c) in &m.per_category {
        let _ = writeln!(
            s,
            "| {name} | {} | {:.3} | {:.3} | {:.1} % | {:.3} | {} | {} | {} |",
            c.objects,
            c.iou,
            c.centre_iou,
            100.0 * c.outside_hull,
            c.visual_hull_iou,
            opt(c.mean_shape_iou),
            opt(c.mean_gt_shape_iou),
            opt(c.silhouette_iou)
        );
    }
    let _ = writeln!(
        s,
        "| **mean** | | **{:.3}** | {:.3} | {:.1} % | {:.3} | {} | {} | {} |\n",
        m.mean_iou,
        m.centre_iou,
        100.0 * m.outside_hull,
        m.visual_hull_iou,
        opt(m.mean_shape_iou),
        opt(m.mean_gt_shape_iou),
        opt(m.silhouette_iou)
    );
    let _ = writeln!(
        s,
        "Model IoU is the max-pool protocol: a voxel is occupied when φ reaches ½ anywhere in its \
         closed cell (max over its ({sub}+1)³ lattice points, {sub}³ cells per voxel, by the {path} \
         path), the way NMR's ground truth marks every voxel whose edges the surface crosses; the \
         references are converted the same way. Centre IoU reads φ at voxel centres only (not \
         dilated like the ground truth; secondary). Outside hull is the share of predicted voxels \
         outside the object's 24-view visual hull. The visual hull is what the 24 silhouettes alone \
         determine; the category mean shape is the mean of the training objects' visual hulls (the \
         prior silhouettes give), so a model that beats it reads the image. The mean GT shape needs \
         3D data and is shown for context only.",
        sub = m.subsamples,
        path = match m.maxpool {
            fieldprobe_core::eval::occupancy::MaxPoolPath::Refined => "refined",
            fieldprobe_core::eval::occupancy::MaxPoolPath::Dense => "dense",
        }
    );
    mesh_table(&mut s, exp, m);
    if !gallery.is_empty() {
        let _ = writeln!(s, "\n## Gallery\n");
        let _ = writeln!(
            s,
            "One row per test object: the input image | the field's silhouette vs the true one at \
             the input view and a quarter and half turn away (grey: both, red: predicted only, \
             blue: true only) | a turntable of the mesh extracted from the field.\n"
        );
        let _ = writeln!(s, "![gallery](gallery.png)\n");
        let _ = writeln!(
            s,
            "| row | category | object | input (RGBA PNG) | mesh faces |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|");
        for (i, r) in gallery.iter().enumerate() {
            let _ = writeln!(
                s,
                "| {} | {} | {} | [view {}]({}) | {} |",
                i + 1,
                r.category,
                r.id,
                r.view,
                r.input,
                r.faces
            );
        }
    }
    if curves {
        let _ = writeln!(s, "\n## Training curve\n");
        let _ = writeln!(
            s,
            "Mean loss per logged interval (log scale) against the step: the total, the \
             silhouette term and the regularizers (when there are any); the numbers are in \
             `history.csv`, the chart also as `training_curves.svg`.\n"
        );
        let _ = writeln!(s, "![training curve](training_curves.png)");
    }
    if let Some(l) = m.final_loss {
        let _ = writeln!(
            s,
            "\nFinal training loss (mean of the last logged interval): {l:.5} (silhouette {}, \
             regularizers {}).",
            m.final_silhouette_loss
                .map_or_else(|| "–".into(), |v| format!("{v:.5}")),
            m.final_regularizer_loss
                .map_or_else(|| "–".into(), |v| format!("{v:.6}"))
        );
    }
    s
}

/// The mesh-metrics table, when the run computed them.
fn mesh_table(s: &mut String, exp: &Experiment, m: &Metrics) {
    let rows: Vec<_> = m
        .per_category
        .iter()
        .filter_map(|(name, c)| c.mesh.as_ref().map(|mm| (name, c, mm)))
        .collect();
    let Some((_, c0, first)) = rows.first() else {
        return;
    };
    let x = &exp.eval.extract;
    let _ = writeln!(s, "\n## Meshes\n");
    let _ = writeln!(
        s,
        "Meshes extracted at φ = {th} (MISE from {r}³ with {k} refinement(s), marching cubes) from \
         {v} of the {views} input views per object on the **{split}** split. Mesh IoU voxelizes \
         each mesh as NMR does (surface marking + fill, {res}³) against the ground-truth voxels; \
         the max-pool IoU of the same predictions is beside it. Chamfer-L1 is shown ×10 as in \
         Occupancy Networks and DVR, with F-score at τ = {tau} and normal consistency, from \
         {pts} points per surface against the dataset's meshes (their outer surface).\n",
        th = x
            .threshold
            .map_or("the representation's level".to_string(), |t| t.to_string()),
        r = x.resolution,
        k = x.refinements,
        v = first.views,
        views = c0.views,
        split = m.split,
        res = m.resolution,
        tau = first.fscore_threshold,
        pts = first.surface_points,
    );
    let _ = writeln!(
        s,
        "| category | meshes | empty | mesh IoU | max-pool IoU (same views) | Chamfer-L1 ×10 | F-score | normal consistency |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for (name, _, mm) in &rows {
        let _ = writeln!(
            s,
            "| {name} | {} | {} | {:.3} | {:.3} | {} | {} | {} |",
            mm.meshes,
            mm.empty,
            mm.iou,
            mm.grid_iou,
            opt(mm.chamfer_l1.map(|c| c * 10.0)),
            opt(mm.fscore),
            opt(mm.normal_consistency)
        );
    }
    if rows.iter().any(|(_, _, mm)| mm.chamfer_l1.is_none()) {
        let _ = writeln!(
            s,
            "\n–: no ground-truth mesh for every object (`{}/meshes/<synset>/<id>.obj`), so no \
             surface metrics.",
            exp.data.dir.display()
        );
    }
}
