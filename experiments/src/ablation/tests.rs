//! The ablation report and its training curves, on made-up entries.

use fieldprobe::ablation::fixtures::four_entries;

use super::*;
use crate::plot;

#[test]
fn the_report_has_every_row_and_the_curves_every_finished_entry() {
    let (file, status) = four_entries();
    let dir = tempfile::tempdir().unwrap();
    let samples = SamplesInfo {
        object: "the first training chair".into(),
        left: "L".into(),
        right: "R".into(),
        rays: 4,
        anchors: 8,
    };
    write_report(dir.path(), &file, &status, &samples).unwrap();

    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    for needle in [
        "| 1 | full (base) | – | 10 | 5 | **0.610** ± 0.006 | 0.610 | 0.610 | 0.0 % | – | – | – | 0.0900 / 0.01000 | 1 | 0.548 | 1 | 1 agree, 0 disagree, 0 within noise |",
        "| 2 | normal | `probe = { ray_sampler = { type = \"normal\" } }` |",
        "| 3 | naive |",
        "failed: the loss became NaN \\| at step 3",
        "| 4 | extra | `seed = 4` | | | not run yet |",
        "**Our ordering agrees with the paper's** on all 1 pair(s)",
        "| full vs normal | 0.548 > 0.482 | +0.200 (",
        "![training curves](training_curves.png)",
        "![samples](samples.png)",
        "* **2** — orange (`#ff7f0e`): normal",
        "* **3** — green (`#2ca02c`): naive (not drawn: not finished)",
        "Table 4, chair",
        // Paired on the same objects: every difference is exactly the same, so each is resolved.
        "## Against the base",
        "| 2 | normal | **-0.200 (0.000)** | **+0.200 (0.000)** | **-0.080 (0.000)** |",
    ] {
        assert!(report.contains(needle), "missing {needle:?} in\n{report}");
    }
    let curves = image::open(dir.path().join("training_curves.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(curves.dimensions(), (800, 480));
    // Both finished entries have the same history, so the second curve covers the first; each
    // still has its legend swatch (22 × 3 pixels), and the top curve its line.
    let pixels = |i: usize| curves.pixels().filter(|p| **p == plot::color(i).1).count();
    assert!(pixels(0) >= 60, "series 0: {}", pixels(0));
    assert!(pixels(1) > 200, "series 1: {}", pixels(1));
    assert!(
        dir.path().join("training_curves.svg").is_file(),
        "the SVG beside the PNG"
    );
    assert_eq!(
        curves.pixels().filter(|p| **p == plot::color(2).1).count(),
        0,
        "a failed entry draws no curve"
    );
}

/// With `against` naming a variant, the paired differences are taken from that row (the base is
/// then one of the rows subtracted from it), and a row that has not finished gives no section.
#[test]
fn the_paired_differences_are_taken_against_the_row_the_file_names() {
    let (mut file, status) = four_entries();
    file.against = 1;
    let samples = SamplesInfo {
        object: "o".into(),
        left: "L".into(),
        right: "R".into(),
        rays: 4,
        anchors: 8,
    };
    let report = render_report(&file, &status, &samples);
    assert!(!report.contains("## Against the base"), "{report}");
    for needle in [
        "## Against 'normal'",
        "Each row minus the row (normal)",
        "| 1 | full | **+0.200 (0.000)** | **-0.200 (0.000)** | **+0.080 (0.000)** |",
    ] {
        assert!(report.contains(needle), "missing {needle:?} in\n{report}");
    }
    assert!(!report.contains("| 2 | normal | **"), "{report}");
    file.against = 2; // 'naive' failed
    let report = render_report(&file, &status, &samples);
    assert!(!report.contains("## Against"), "{report}");
}
