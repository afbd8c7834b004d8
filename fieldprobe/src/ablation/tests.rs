//! Tests of the ordering comparison and the report.

use super::fixtures::{HISTORY, four_entries, run};
use super::*;

fn row(name: &str, paper: f32, objects: &[f32]) -> Row {
    Row {
        name: name.into(),
        ours: objects.iter().sum::<f32>() / objects.len() as f32,
        paper,
        per_object: objects
            .iter()
            .enumerate()
            .map(|(i, v)| (format!("chair/{i}"), *v))
            .collect(),
    }
}

#[test]
fn pairs_agree_disagree_or_stay_within_noise() {
    let rows = [
        // Clearly best in both.
        row("a", 0.548, &[0.60, 0.62, 0.61, 0.63]),
        // Clearly below a; the paper puts it second, but it is clearly below c too.
        row("b", 0.524, &[0.40, 0.42, 0.41, 0.43]),
        // Above b everywhere (resolved, against the paper), far below a.
        row("c", 0.502, &[0.50, 0.52, 0.51, 0.53]),
        // Noisy: mean just above c's but the per-object differences scatter widely.
        row("d", 0.502, &[0.70, 0.30, 0.66, 0.42]),
    ];
    let c = compare(&rows);
    let v = |a: usize, b: usize| {
        c.pairs
            .iter()
            .find(|p| p.a == a && p.b == b)
            .unwrap()
            .verdict
    };
    assert_eq!(v(0, 1), Verdict::Agrees);
    assert_eq!(v(0, 2), Verdict::Agrees);
    assert_eq!(v(1, 2), Verdict::Disagrees);
    assert_eq!(v(2, 3), Verdict::PaperTie);
    // d − b = +0.105, paper says b > d: opposite sign, but 2·SE ≈ 0.21.
    assert_eq!(v(1, 3), Verdict::Unresolved { sign_agrees: false });
    assert_eq!(v(0, 3), Verdict::Unresolved { sign_agrees: true });
    assert_eq!(c.pairs.len(), 6);
    assert_eq!(c.ours_rank, [1, 4, 3, 2]);
    assert_eq!(c.paper_rank, [1, 2, 3, 3]);
    let s = summary(&rows, &c);
    assert!(
        s.contains("disagrees with the paper's** on 1 of 5")
            && s.contains("2 agree, 1 disagree, 2 within noise (1 of them with the paper's sign)")
            && s.contains("1 tied in the paper")
            && s.contains("Our best: a; the paper's best: a — matches"),
        "{s}"
    );
}

#[test]
fn agreement_needs_every_pair_resolved() {
    let clean = [
        row("x", 0.5, &[0.6, 0.61, 0.62]),
        row("y", 0.4, &[0.5, 0.51, 0.52]),
    ];
    let c = compare(&clean);
    assert_eq!(c.pairs[0].verdict, Verdict::Agrees);
    assert!(summary(&clean, &c).contains("**Our ordering agrees with the paper's** on all 1"));
    // Tiny but perfectly consistent differences are not an ordering.
    let close = [
        row("x", 0.5, &[0.600, 0.610, 0.620]),
        row("y", 0.4, &[0.598, 0.608, 0.618]),
    ];
    let c = compare(&close);
    assert!(c.pairs[0].se.unwrap() < 1e-4);
    assert_eq!(
        c.pairs[0].verdict,
        Verdict::Unresolved { sign_agrees: true }
    );
    // One evaluation object: no noise estimate, so nothing is resolved.
    let single = [row("x", 0.5, &[0.7]), row("y", 0.4, &[0.2])];
    let c = compare(&single);
    assert_eq!(c.pairs[0].se, None);
    assert_eq!(
        c.pairs[0].verdict,
        Verdict::Unresolved { sign_agrees: true }
    );
    let s = summary(&single, &c);
    assert!(
        s.contains("No resolved pair contradicts") && s.contains("do not confirm"),
        "{s}"
    );
    // Best variants differ.
    let flipped = [row("x", 0.5, &[0.2, 0.21]), row("y", 0.4, &[0.7, 0.71])];
    let s = summary(&flipped, &compare(&flipped));
    assert!(
        s.contains("Our best: y; the paper's best: x — does not match"),
        "{s}"
    );
    assert!(summary(&flipped[..1], &compare(&flipped[..1])).contains("nothing to compare"));
}

/// Several seeds: the entry is their mean, its per-object IoUs are keyed by seed, and two
/// entries pair the same (seed, object).
#[test]
fn seeds_average_and_pair_by_seed_and_object() {
    let text = "name = \"abl\"\nseeds = [3, 5]\n[data]\ndir = \"d\"\ncategories = [\"chair\"]\n\
                [probe]\nanchors = 8\nrays_per_view = 4\nray_sampler = { type = \"uniform\" }\n\
                anchor_sampler = { type = \"uniform\" }\n[train]\nsteps = 10\n\
                [[variants]]\nname = \"naive\"\npaper_iou = 0.524\nprobe = { assignment = \"naive\" }\n";
    let file = AblationFile::parse(text, Path::new("abl.toml")).unwrap();
    assert_eq!(file.run_seeds(), [3, 5]);
    let root = Path::new("r");
    assert_eq!(
        file.run_dir(root, &file.entries[1], 5),
        Path::new("r/naive/seed-5")
    );
    let e = AblationEntry::new(
        &file.entries[0],
        &[run(3, &[0.5, 0.7], &[]), run(5, &[0.3, 0.5], &[])],
    );
    assert!((e.mean_iou - 0.5).abs() < 1e-6);
    assert!((e.seed_ious[0] - 0.6).abs() < 1e-6 && (e.seed_ious[1] - 0.4).abs() < 1e-6);
    let keys: Vec<String> = e.per_object().into_keys().collect();
    assert_eq!(
        keys,
        ["s3/chair/o0", "s3/chair/o1", "s5/chair/o0", "s5/chair/o1"]
    );
    assert_eq!(e.train_seconds, 10.0, "summed over seeds");
    assert!(with_seed(&file.entries[1].experiment, 9).unwrap().seed == 9);
    let bad = "name = \"a\"\nseeds = [1, 1]\n[data]\ndir = \"d\"\ncategories = [\"chair\"]\n[probe]\nanchors = 8\nrays_per_view = 4\nray_sampler = { type = \"uniform\" }\nanchor_sampler = { type = \"uniform\" }\n[train]\nsteps = 10\n[[variants]]\nname = \"x\"\nseed = 2\n";
    let err = AblationFile::parse(bad, Path::new("abl.toml")).unwrap_err();
    assert!(format!("{err}").contains("seeds"), "{err}");
}

#[test]
fn ablation_json_lists_finished_entries_base_first() {
    let (_, status) = four_entries();
    let dir = tempfile::tempdir().unwrap();
    write_ablation_json(dir.path(), &status).unwrap();
    let json = std::fs::read_to_string(dir.path().join("ablation.json")).unwrap();
    let entries: Vec<AblationEntry> = serde_json::from_str(&json).unwrap();
    let names: Vec<&str> = entries.iter().map(|e| e.variant.as_str()).collect();
    assert_eq!(names, ["full", "normal"]);
    assert_eq!(entries[0].paper_iou, Some(0.548));
    assert_eq!(entries[0].dir, "full");
    assert!(entries[0].overrides.is_empty());
    assert_eq!(
        entries[1].overrides,
        ["probe = { ray_sampler = { type = \"normal\" } }"]
    );
    assert!((entries[1].mean_iou - 0.41).abs() < 1e-6);
    assert_eq!(entries[1].per_category["chair"].per_object.len(), 3);
    assert_eq!(entries[1].loss_history, HISTORY);
    assert_eq!((entries[1].steps, entries[1].train_seconds), (10, 5.0));
    for key in [
        "\"visual_hull_iou\"",
        "\"mean_shape_iou\"",
        "\"per_category\"",
    ] {
        assert!(json.contains(key), "{key}");
    }
}

#[test]
fn paired_differences_are_means_over_shared_keys_with_their_standard_error() {
    use std::collections::BTreeMap;
    let map = |v: &[(&str, f32)]| -> BTreeMap<String, f32> {
        v.iter().map(|(k, x)| (k.to_string(), *x)).collect()
    };
    let a = map(&[("a", 0.5), ("b", 0.7), ("c", 0.9), ("only-a", 5.0)]);
    let b = map(&[("a", 0.4), ("b", 0.4), ("c", 0.9), ("only-b", -5.0)]);
    // Differences 0.1, 0.3, 0.0: mean 0.1333, sample SD 0.1528, SE 0.0882.
    let (d, se) = paired_difference(&a, &b).unwrap();
    assert!((d - 0.4 / 3.0).abs() < 1e-6, "{d}");
    assert!((se - 0.088_19).abs() < 1e-4, "{se}");
    assert_eq!(paired_difference(&a, &map(&[("a", 0.0)])), None);
}
