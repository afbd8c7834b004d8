//! `report.md` of an ablation: the comparison table beside the paper's numbers, the orderings,
//! the loss terms and the pictures.

use std::fmt::Write as _;

use fieldprobe::ablation::compare::{
    MIN_RESOLVED_DIFF, Row, compare, paired_difference, se_of, summary, tally, verdict_text,
};
use fieldprobe::ablation::entry::{AblationEntry, Status};
use fieldprobe::variants::AblationFile;

use super::figures::SamplesInfo;
use crate::plot;

/// "Against the base" (or against the row the file's `against` names): each other finished row's
/// paired difference from it in max-pool IoU, Chamfer-L1 and normal consistency, and whether it
/// is resolved. This is how a row without the paper's number (a sweep's) is read: does the
/// change move what is learned beyond noise?
fn render_against(done: &[(usize, &AblationEntry)], against: usize) -> String {
    let mut s = String::new();
    let Some(&(_, reference)) = done.iter().find(|(i, _)| *i == against) else {
        return s;
    };
    if done.len() < 2 {
        return s;
    }
    let title = if against == 0 {
        "the base".to_string()
    } else {
        format!("'{}'", reference.variant)
    };
    let _ = writeln!(s, "\n## Against {title}\n");
    let _ = writeln!(
        s,
        "Each row minus {} ({}), paired on the same training seed and evaluation object: \
         the mean difference and, in brackets, twice its standard error. A difference is \
         **resolved** (bold) when it exceeds 2·SE (and, for IoU, {MIN_RESOLVED_DIFF}). Chamfer-L1 \
         (×10; lower is better) and normal consistency are per object means over its meshed \
         views.\n",
        if against == 0 { "the base" } else { "the row" },
        reference.variant
    );
    let _ = writeln!(
        s,
        "| # | variant | Δ max-pool IoU (2·SE) | Δ Chamfer-L1 ×10 (2·SE) | Δ normal consistency (2·SE) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|");
    let cell = |a: &std::collections::BTreeMap<String, f32>,
                b: &std::collections::BTreeMap<String, f32>,
                scale: f32,
                floor: f32| {
        match paired_difference(a, b) {
            Some((d, se)) => {
                let txt = format!("{:+.3} ({:.3})", d * scale, 2.0 * se * scale);
                if d.abs() > 2.0 * se && d.abs() >= floor {
                    format!("**{txt}**")
                } else {
                    txt
                }
            }
            None => "–".into(),
        }
    };
    for &(i, e) in done.iter().filter(|(i, _)| *i != against) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            i + 1,
            e.variant,
            cell(
                &e.per_object(),
                &reference.per_object(),
                1.0,
                MIN_RESOLVED_DIFF
            ),
            cell(
                &e.per_seed_object_chamfer,
                &reference.per_seed_object_chamfer,
                10.0,
                0.0
            ),
            cell(
                &e.per_seed_object_normals,
                &reference.per_seed_object_normals,
                1.0,
                0.0
            ),
        );
    }
    s
}

/// The ablation's `report.md`.
pub fn render_report(file: &AblationFile, status: &[Status], samples: &SamplesInfo) -> String {
    let mut s = String::new();
    let base = &file.base().experiment;
    let _ = writeln!(s, "# Ablation: {}\n", file.name);
    let cats: Vec<&str> = base.data.categories.iter().map(|c| c.name()).collect();
    let _ = writeln!(
        s,
        "Each row is the base with the overrides shown, trained and evaluated into its own run \
         directory; all share the data (`{}`, {}, evaluated on the {} split), the training \
         seed(s) {} and the evaluation (3D IoU at {}³ in the NMR max-pool protocol, {}³ points per \
         voxel, {} input view(s) per object).",
        base.data.dir.display(),
        cats.join(", "),
        base.data.eval_split.name(),
        file.run_seeds()
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        base.eval.resolution,
        base.eval.subsamples,
        base.eval.views
    );
    let paper_src = file
        .paper_table
        .as_deref()
        .unwrap_or("the paper's ablation tables");
    let _ = writeln!(
        s,
        "The paper's column is its 3D IoU on ShapeNet at full scale ({paper_src}); ours come from \
         a different scale and data, so compare orderings, not values.\n"
    );

    // Rows with the paper's numbers, for the ordering.
    let done: Vec<(usize, &AblationEntry)> = status
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s {
            Status::Finished(e) => Some((i, e.as_ref())),
            _ => None,
        })
        .collect();
    let compared: Vec<(usize, Row)> = done
        .iter()
        .filter_map(|&(i, e)| {
            e.paper_iou.map(|p| {
                (
                    i,
                    Row {
                        name: e.variant.clone(),
                        ours: e.mean_iou,
                        paper: p,
                        per_object: e.per_object(),
                    },
                )
            })
        })
        .collect();
    let rows: Vec<Row> = compared.iter().map(|(_, r)| r.clone()).collect();
    let cmp = compare(&rows);
    let pos = |i: usize| compared.iter().position(|(j, _)| *j == i);

    let _ = writeln!(
        s,
        "| # | variant | overrides | steps | train (s) | our mean IoU ± SE | per seed | centre IoU | outside hull | mesh IoU | Chamfer-L1 ×10 | normal consistency | final L_sil / L_reg | our rank | paper IoU | paper rank | pairs vs the paper |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for (i, (v, st)) in file.entries.iter().zip(status).enumerate() {
        let name = if i == 0 {
            format!("{} (base)", v.name)
        } else {
            v.name.clone()
        };
        let overrides = if v.overrides.is_empty() {
            "–".to_string()
        } else {
            v.overrides
                .iter()
                .map(|o| format!("`{}`", o.replace('|', "\\|")))
                .collect::<Vec<_>>()
                .join("<br>")
        };
        let paper = v.paper_iou.map_or("–".into(), |p| format!("{p:.3}"));
        match st {
            Status::Finished(e) => {
                let objs: Vec<f32> = e.per_object().into_values().collect();
                let se = se_of(&objs).map_or(String::new(), |x| format!(" ± {x:.3}"));
                let (our_rank, paper_rank, pairs) = match pos(i) {
                    Some(k) => {
                        let (a, d, u, _, t) =
                            tally(cmp.pairs.iter().filter(|p| p.a == k || p.b == k));
                        let mut txt = format!("{a} agree, {d} disagree, {u} within noise");
                        if t > 0 {
                            let _ = write!(txt, ", {t} paper tie(s)");
                        }
                        (
                            cmp.ours_rank[k].to_string(),
                            cmp.paper_rank[k].to_string(),
                            txt,
                        )
                    }
                    None => ("–".into(), "–".into(), "–".into()),
                };
                let o = |v: Option<f32>, scale: f32| {
                    v.map_or_else(|| "–".to_string(), |v| format!("{:.3}", v * scale))
                };
                let per_seed = e
                    .seed_ious
                    .iter()
                    .map(|v| format!("{v:.3}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                let losses = format!(
                    "{} / {}",
                    e.final_silhouette_loss
                        .map_or_else(|| "–".into(), |v| format!("{v:.4}")),
                    e.final_regularizer_loss
                        .map_or_else(|| "–".into(), |v| format!("{v:.5}"))
                );
                let _ = writeln!(
                    s,
                    "| {} | {name} | {overrides} | {} | {:.0} | **{:.3}**{se} | {per_seed} | {:.3} | {:.1} % | {} | {} | {} | {losses} | {our_rank} | {paper} | {paper_rank} | {pairs} |",
                    i + 1,
                    e.steps,
                    e.train_seconds,
                    e.mean_iou,
                    e.centre_iou,
                    100.0 * e.outside_hull,
                    o(e.mesh_iou, 1.0),
                    o(e.chamfer_l1, 10.0),
                    o(e.normal_consistency, 1.0),
                );
            }
            Status::Pending => {
                let _ = writeln!(
                    s,
                    "| {} | {name} | {overrides} | | | not run yet | | | | | | | | | {paper} | | |",
                    i + 1
                );
            }
            Status::Failed(msg) => {
                let _ = writeln!(
                    s,
                    "| {} | {name} | {overrides} | | | failed: {} | | | | | | | | | {paper} | | |",
                    i + 1,
                    msg.replace('|', "\\|").replace('\n', " ")
                );
            }
        }
    }
    if let Some((_, e)) = done.first() {
        let _ = writeln!(
            s,
            "\nReferences on the same evaluation objects: visual hull (24 views) {:.3}, category mean \
             shape {}. SE: standard error of the mean over seeds × evaluation objects. Train (s) \
             is summed over seeds; centre IoU reads φ at voxel centres only (secondary); outside \
             hull is the share of predicted voxels outside the 24-view visual hull; mesh metrics \
             are means over the meshed views and seeds.",
            e.visual_hull_iou,
            e.mean_shape_iou.map_or("–".into(), |v| format!("{v:.3}"))
        );
    }

    s.push_str(&render_against(&done, file.against));

    let _ = writeln!(s, "\n## Ordering vs the paper\n");
    let _ = writeln!(
        s,
        "Rule: every pair of finished rows with the paper's numbers is compared. The paper orders \
         a pair by its two IoUs (equal numbers are a tie and not counted). Our order is the sign of \
         the difference Δ of our mean IoUs; it is *resolved* only when |Δ| exceeds twice the \
         standard error of the paired differences (the same evaluation object under the same \
         training seed in both rows) and is at least {MIN_RESOLVED_DIFF}. A resolved pair agrees \
         or disagrees with the paper; an unresolved one is reported as within noise, and its 2·SE \
         is the smallest difference this run could have resolved. The noise bar is rough (not a \
         significance test); it covers the choice of evaluation objects and, with several seeds, \
         training noise (with one seed, close rows could swap under another).\n"
    );
    let _ = writeln!(s, "{}\n", summary(&rows, &cmp));
    if !cmp.pairs.is_empty() {
        let _ = writeln!(s, "| pair | paper | ours: Δ (2·SE) | verdict |");
        let _ = writeln!(s, "|---|---|---|---|");
        for p in &cmp.pairs {
            let (a, b) = (&rows[p.a], &rows[p.b]);
            let rel = |d: f32| {
                if d > 0.0 {
                    ">"
                } else if d < 0.0 {
                    "<"
                } else {
                    "="
                }
            };
            let _ = writeln!(
                s,
                "| {} vs {} | {:.3} {} {:.3} | {:+.3} ({}) | {} |",
                a.name,
                b.name,
                a.paper,
                rel(a.paper - b.paper),
                b.paper,
                p.diff,
                p.se.map_or("n/a".into(), |se| format!("{:.3}", 2.0 * se)),
                verdict_text(p.verdict)
            );
        }
    }

    s.push_str(&super::cost::render_cost(file, status));

    let _ = writeln!(s, "\n## Training curves\n");
    let _ = writeln!(s, "![training curves](training_curves.png)\n");
    let _ = writeln!(
        s,
        "Mean training loss per logged interval (silhouette MSE plus the regularizer's term, so \
         rows with different regularizers differ in what the loss includes) against the step, log \
         scale (also as `training_curves.svg`). Entries in the chart's legend, by colour:\n"
    );
    for (i, (v, st)) in file.entries.iter().zip(status).enumerate() {
        let (cname, c) = plot::color(i);
        let note = match st {
            Status::Finished(_) => "",
            _ => " (not drawn: not finished)",
        };
        let _ = writeln!(
            s,
            "* **{}** — {cname} (`{}`): {}{note}",
            i + 1,
            plot::hex(c),
            v.name
        );
    }

    let _ = writeln!(s, "\n## Samples\n");
    let _ = writeln!(s, "![samples](samples.png)\n");
    let _ = writeln!(
        s,
        "{}, silhouette in grey. Top row: the pixels of one view's {} rays; bottom row: one \
         object's {} anchors projected into the same view — what one training step draws for one \
         object. Left column (red): {}. Right column (blue): {}.",
        upper_first(&samples.object),
        samples.rays,
        samples.anchors,
        samples.left,
        samples.right
    );

    let _ = writeln!(s, "\n## Run directories\n");
    for v in &file.entries {
        let _ = writeln!(
            s,
            "* `{}/` — {} (config.toml, metrics.json, report.md, checkpoints/)",
            v.slug, v.name
        );
    }
    s
}

pub(super) fn upper_first(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}
