//! Ablation files: the shipped ones parse, and a tiny ablation runs end to end through the CLI
//! (base first, every variant, report and pictures, `--resume` skipping finished variants).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fieldprobe::ablation::AblationEntry;
use fieldprobe::variants::AblationFile;

fn experiments(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_experiments"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn ok(out: &Output) -> String {
    let t = text(out);
    assert!(out.status.success(), "{t}");
    t
}

/// `experiments/ablations/`, from the folder cargo names when it runs the test (see
/// `fieldprobe_tests::data_dir` for why not `env!`).
fn ablations_dir() -> PathBuf {
    PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"))
        .join("ablations")
}

fn ablation_files() -> Vec<PathBuf> {
    let root = ablations_dir();
    let mut files = Vec::new();
    for dir in [root.clone(), root.join("paper")] {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

fn json(v: &impl serde::Serialize) -> String {
    serde_json::to_string(v).unwrap()
}

#[test]
fn every_ablation_file_parses_and_every_variant_deserializes() {
    let files = ablation_files();
    let root = ablations_dir();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.strip_prefix(&root).unwrap().display().to_string())
        .collect();
    assert_eq!(
        names,
        [
            "delta.toml",
            "paper/delta.toml",
            "paper/regularizer.toml",
            "paper/sampling.toml",
            "regularizer.toml",
            "sampling.toml"
        ]
    );
    for path in &files {
        assert!(fieldprobe::variants::has_variants(path));
        let f = AblationFile::load(path).unwrap_or_else(|e| panic!("{e:#}"));
        let stem = path.file_stem().unwrap().to_str().unwrap();
        let paper_scale = path.parent().unwrap().ends_with("paper");
        let rows: Vec<(&str, Option<f32>)> = f
            .entries
            .iter()
            .map(|e| (e.name.as_str(), e.paper_iou))
            .collect();
        // The paper's numbers, base first (Tables 2–4).
        let want: Vec<(&str, Option<f32>)> = match stem {
            "regularizer" => vec![
                ("p=0.8", Some(0.548)),
                ("p=2.0", Some(0.502)),
                ("p=1.0", Some(0.524)),
                ("no regularizer", Some(0.503)),
            ],
            "delta" => vec![
                ("Δd=0.03", Some(0.515)),
                ("Δd=0.01", Some(0.482)),
                ("Δd=0.1", Some(0.507)),
            ],
            "sampling" => vec![
                ("full model", Some(0.548)),
                ("no importance sampling", Some(0.482)),
                ("no boundary-aware", Some(0.524)),
                ("boundary-aware (hull reading)", None),
            ],
            other => panic!("unexpected ablation file {other}"),
        };
        assert_eq!(rows, want, "{}", path.display());
        let base = &f.base().experiment;
        let category = if stem == "delta" { "table" } else { "chair" };
        assert_eq!(
            json(&base.data.categories),
            format!("[\"{category}\"]"),
            "{}",
            path.display()
        );
        // The full model: importance sampling, boundary-aware, p = 0.8, Δd = 0.03.
        assert_eq!(json(&base.probe.spec.assignment), "\"boundary_aware\"");
        assert!(json(&base.probe.ray_sampler).contains("\"importance\""));
        assert!(json(&base.probe.anchor_sampler).contains("\"importance\""));
        let reg = json(&base.regularizers);
        assert!(
            reg.starts_with("{\"normals\":{\"type\":\"normal_consistency\"")
                && reg.contains("\"p\":0.8")
                && reg.contains("\"delta\":0.03"),
            "{reg}"
        );
        if paper_scale {
            assert_eq!(
                (
                    base.probe.spec.anchors,
                    base.probe.spec.rays_per_view,
                    base.probe.spec.views
                ),
                (16000, 4096, 24)
            );
            assert_eq!((base.train.batch, base.train.lr), (8, 1e-4));
            assert_eq!(base.data.dir, Path::new("datasets/nmr"));
        } else {
            assert_eq!(
                base.data.dir,
                Path::new(&format!("datasets/ablation-{category}"))
            );
            let g = base.data.generate.expect("CPU presets generate their data");
            assert_eq!((g.train, g.test), (64, 8));
        }
        for v in &f.entries[1..] {
            let x = &v.experiment;
            // Everything a variant does not override is the base's.
            assert_eq!(x.data, base.data);
            assert_eq!(json(&x.model), json(&base.model));
            assert_eq!(x.train, base.train);
            assert_eq!(x.eval, base.eval);
            assert_eq!(x.seed, base.seed);
            let changed = [
                json(&x.probe.ray_sampler) != json(&base.probe.ray_sampler),
                json(&x.probe.anchor_sampler) != json(&base.probe.anchor_sampler),
                x.probe.spec.assignment != base.probe.spec.assignment,
                json(&x.regularizers) != json(&base.regularizers),
            ];
            assert_eq!(
                changed.iter().filter(|c| **c).count(),
                if v.name == "no importance sampling" {
                    2
                } else {
                    1
                },
                "{}: {}",
                path.display(),
                v.name
            );
            let reg = json(&x.regularizers);
            match v.name.as_str() {
                "no importance sampling" => {
                    for s in [json(&x.probe.ray_sampler), json(&x.probe.anchor_sampler)] {
                        assert_eq!(s, r#"{"type":"normal","sigma":0.4}"#);
                    }
                }
                "no boundary-aware" => assert_eq!(json(&x.probe.spec.assignment), "\"naive\""),
                "boundary-aware (hull reading)" => {
                    assert_eq!(json(&x.probe.spec.assignment), "\"boundary_aware_hull\"")
                }
                "no regularizer" => assert_eq!(reg, "{}"),
                "p=2.0" | "p=1.0" => {
                    let p = &v.name[2..];
                    assert!(
                        reg.contains(&format!("\"p\":{p}")) && reg.contains("\"delta\":0.03"),
                        "{reg}"
                    );
                }
                "Δd=0.01" | "Δd=0.1" => {
                    let d = &v.name["Δd=".len()..];
                    assert!(
                        reg.contains(&format!("\"delta\":{d}")) && reg.contains("\"p\":0.8"),
                        "{reg}"
                    );
                }
                other => panic!("unexpected variant {other}"),
            }
        }
    }
}

/// The CPU ablations' bases train exactly as the λ sweep's λ = 0.01 row, and the regularizer
/// ablation's "no regularizer" as the sweep's "none" row, so that a run can be copied across
/// instead of trained twice (each file's BUDGET comment says how; `--resume` compares training
/// tables). The Δd ablation is on tables: it differs in `[data]` only. All are evaluated alike.
#[test]
fn the_cpu_ablation_bases_train_as_the_lambda_sweep_rows() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"));
    let load =
        |rel: &str| AblationFile::load(&root.join(rel)).unwrap_or_else(|e| panic!("{rel}: {e:#}"));
    let entry = |f: &AblationFile, name: &str| {
        let e = f.entries.iter().find(|e| e.name == name);
        let exp = &e
            .unwrap_or_else(|| panic!("{}: no entry {name}", f.name))
            .experiment;
        (exp.training_table().unwrap(), exp.eval_table().unwrap())
    };
    let sweep = load("sweeps/lambda-single-view.toml");
    let (full, eval) = entry(&sweep, "λ=0.01");
    let (none, _) = entry(&sweep, "none");
    let without_data = |mut t: toml::Table| {
        t.remove("data").expect("a [data] table");
        t
    };
    for (rel, base, same_data) in [
        ("ablations/sampling.toml", "full model", true),
        ("ablations/regularizer.toml", "p=0.8", true),
        ("ablations/delta.toml", "Δd=0.03", false),
    ] {
        let f = load(rel);
        assert_eq!(f.run_seeds(), sweep.run_seeds(), "{rel}");
        let (train, e) = entry(&f, base);
        assert_eq!(e, eval, "{rel}");
        if same_data {
            assert_eq!(train, full, "{rel}");
        } else {
            assert_ne!(train, full, "{rel}");
            assert_eq!(without_data(train), without_data(full.clone()), "{rel}");
        }
    }
    let regularizer = load("ablations/regularizer.toml");
    assert_eq!(entry(&regularizer, "no regularizer").0, none);
}

const TINY: &str = r#"
name = "tiny-ablation"
base_name = "full"
base_paper_iou = 0.548
paper_table = "Table 4, chair"
seed = 1
backend = "flex"

[data]
dir = "DATA"
categories = ["chair"]
generate = { train = 2, val = 0, test = 1, seed = 0 }

[model]
type = "single_view"
latent = 8
encoder = { channels = [4, 8], blocks = [1, 1] }
decoder = { hidden = [16] }

[probe]
anchors = 256
rays_per_view = 32
views = 2
assignment = "boundary_aware"
ray_sampler = { type = "importance" }
anchor_sampler = { type = "importance", resolution = 16 }

[regularizers.normals]
type = "normal_consistency"
max_anchors = 32

[train]
steps = 3
batch = 2
lr = 1e-3
checkpoint_every = 0

[eval]
views = 2

[[variants]]
name = "-Imp. sampling"
paper_iou = 0.482
probe = { ray_sampler = { type = "normal" }, anchor_sampler = { type = "normal" } }

[[variants]]
name = "naive"
paper_iou = 0.524
probe = { assignment = "naive" }
"#;

#[test]
fn a_tiny_ablation_runs_every_variant_and_resumes_by_skipping_finished_ones() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let file = dir.path().join("tiny.toml");
    std::fs::write(&file, TINY.replace("DATA", data.to_str().unwrap())).unwrap();
    let out = dir.path().join("run");
    let (f, o) = (file.to_str().unwrap(), out.to_str().unwrap());

    let log = ok(&experiments(&[f, "--out", o]));
    assert!(log.contains("ablation directory"), "{log}");
    let slugs = ["full", "imp.-sampling", "naive"];
    for s in slugs {
        for name in ["config.toml", "metrics.json", "report.md"] {
            assert!(out.join(s).join(name).is_file(), "{s}/{name}");
        }
    }
    let entries: Vec<AblationEntry> =
        serde_json::from_str(&std::fs::read_to_string(out.join("ablation.json")).unwrap()).unwrap();
    let names: Vec<&str> = entries.iter().map(|e| e.variant.as_str()).collect();
    assert_eq!(names, ["full", "-Imp. sampling", "naive"]);
    let dirs: Vec<&str> = entries.iter().map(|e| e.dir.as_str()).collect();
    assert_eq!(dirs, slugs);
    for e in &entries {
        assert_eq!(e.steps, 3);
        assert!((0.0..=1.0).contains(&e.mean_iou), "{}", e.mean_iou);
        assert!(e.per_category.contains_key("chair"));
        assert!(!e.loss_history.is_empty());
        assert!(e.train_seconds > 0.0);
    }
    assert_eq!(
        entries.iter().map(|e| e.paper_iou).collect::<Vec<_>>(),
        [Some(0.548), Some(0.482), Some(0.524)]
    );
    // The variant's resolved config is the base's with the override.
    let cfg = std::fs::read_to_string(out.join("imp.-sampling/config.toml")).unwrap();
    assert!(
        cfg.contains("type = \"normal\"") && !cfg.contains("importance"),
        "{cfg}"
    );
    assert!(
        cfg.contains("boundary_aware") && cfg.contains("max_anchors = 32"),
        "{cfg}"
    );

    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for needle in [
        "# Ablation: tiny-ablation",
        "| 1 | full (base) |",
        "| 2 | -Imp. sampling |",
        "| 3 | naive |",
        "![training curves](training_curves.png)",
        "![samples](samples.png)",
        "## Ordering vs the paper",
        // One evaluation object: no noise estimate, nothing is resolved, and the report says so.
        "do not confirm",
        "variant '-Imp. sampling'",
    ] {
        assert!(report.contains(needle), "missing {needle:?} in\n{report}");
    }
    let curves = image::open(out.join("training_curves.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(curves.dimensions(), (800, 480));
    let samples = image::open(out.join("samples.png")).unwrap().to_rgb8();
    assert_eq!(samples.dimensions(), (2 * (256 + 8) + 8, 2 * (256 + 8) + 8));
    let red = experiments::plot::color(3).1;
    let blue = experiments::plot::color(0).1;
    let count = |c: image::Rgb<u8>, x0: u32, x1: u32| {
        (x0..x1)
            .flat_map(|x| (0..samples.height()).map(move |y| (x, y)))
            .filter(|&(x, y)| *samples.get_pixel(x, y) == c)
            .count()
    };
    let mid = samples.width() / 2;
    assert!(count(red, 0, mid) > 100 && count(red, mid, samples.width()) == 0);
    assert!(count(blue, mid, samples.width()) > 100 && count(blue, 0, mid) == 0);

    // Without --resume a finished ablation is refused, and nothing changes.
    let before: Vec<String> = slugs
        .iter()
        .map(|s| std::fs::read_to_string(out.join(s).join("metrics.json")).unwrap())
        .collect();
    let again = experiments(&[f, "--out", o]);
    assert!(!again.status.success());
    assert!(text(&again).contains("--resume"), "{}", text(&again));

    // --resume skips every finished variant (their metrics stay as they were).
    let log = ok(&experiments(&[f, "--out", o, "--resume"]));
    assert_eq!(log.matches("finished, skipping").count(), 3, "{log}");
    let after: Vec<String> = slugs
        .iter()
        .map(|s| std::fs::read_to_string(out.join(s).join("metrics.json")).unwrap())
        .collect();
    assert_eq!(before, after);

    // A variant with a checkpoint but no metrics (killed after training) is resumed, the others
    // skipped.
    std::fs::remove_file(out.join("naive/metrics.json")).unwrap();
    let log = ok(&experiments(&[f, "--out", o, "--resume"]));
    assert_eq!(log.matches("finished, skipping").count(), 2, "{log}");
    assert!(
        log.contains("resumed from") && log.contains("at step 3"),
        "{log}"
    );
    assert!(out.join("naive/metrics.json").is_file());
    let entries: Vec<AblationEntry> =
        serde_json::from_str(&std::fs::read_to_string(out.join("ablation.json")).unwrap()).unwrap();
    assert_eq!(entries.len(), 3);
    assert_eq!(entries[0].variant, "full");

    // Another `[eval]` and another name: every finished variant is evaluated again from its
    // checkpoint, not retrained (its training time is kept), and its config.toml follows.
    let metrics = |s: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join(s).join("metrics.json")).unwrap())
            .unwrap()
    };
    let trained: Vec<serde_json::Value> = slugs
        .iter()
        .map(|s| metrics(s)["train_seconds"].clone())
        .collect();
    let tiny = TINY.replace("DATA", data.to_str().unwrap());
    let renamed = tiny
        .replace("name = \"tiny-ablation\"", "name = \"renamed\"")
        .replace("[eval]\nviews = 2", "[eval]\nviews = 1");
    assert_ne!(renamed, tiny);
    std::fs::write(&file, &renamed).unwrap();
    let log = ok(&experiments(&[f, "--out", o, "--resume"]));
    assert_eq!(
        log.matches("evaluating its checkpoint again").count(),
        3,
        "{log}"
    );
    assert!(!log.contains("resumed from"), "{log}");
    for (s, seconds) in slugs.iter().zip(&trained) {
        let m = metrics(s);
        assert_eq!(m["per_category"]["chair"]["views"], 1, "{s}: {m}");
        assert_eq!(&m["train_seconds"], seconds, "{s}");
        let cfg = std::fs::read_to_string(out.join(s).join("config.toml")).unwrap();
        assert!(cfg.contains("name = \"renamed-"), "{s}: {cfg}");
    }
    let log = ok(&experiments(&[f, "--out", o, "--resume"]));
    assert_eq!(log.matches("finished, skipping").count(), 3, "{log}");

    // A light copy of a finished run (no checkpoints, meshes or pictures: what `results/` keeps
    // in git) is taken as finished, its loss history read from its history.csv.
    let light = dir.path().join("light");
    copy_dir(&out.join("full"), &light.join("full"));
    std::fs::remove_dir_all(light.join("full/checkpoints")).unwrap();
    let log = ok(&experiments(&[
        f,
        "--out",
        light.to_str().unwrap(),
        "--resume",
        "--variant",
        "full",
    ]));
    assert_eq!(log.matches("finished, skipping").count(), 1, "{log}");
    let entries: Vec<AblationEntry> =
        serde_json::from_str(&std::fs::read_to_string(light.join("ablation.json")).unwrap())
            .unwrap();
    assert_eq!(entries.len(), 1);
    assert!(!entries[0].loss_history.is_empty());

    // A run directory copied from another file's entry that trains the same way is taken over.
    let other = dir.path().join("other");
    copy_dir(&out.join("full"), &other.join("full"));
    std::fs::write(&file, &tiny).unwrap();
    let log = ok(&experiments(&[
        f,
        "--out",
        other.to_str().unwrap(),
        "--resume",
        "--variant",
        "full",
    ]));
    assert!(
        log.contains("'full' seed 1: trained under another [eval]"),
        "{log}"
    );
    assert!(!log.contains("resumed from"), "{log}");

    // A changed training configuration of a finished variant is refused on resume.
    std::fs::write(
        &file,
        renamed.replace(
            "assignment = \"naive\"",
            "assignment = \"naive\", views = 1",
        ),
    )
    .unwrap();
    let changed = experiments(&[f, "--out", o, "--resume"]);
    assert!(!changed.status.success());
    assert!(
        text(&changed).contains("variant 'naive' was trained with a different configuration"),
        "{}",
        text(&changed)
    );
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn a_misspelled_key_in_a_variant_names_the_file_the_variant_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.toml");
    std::fs::write(
        &file,
        TINY.replace("DATA", dir.path().join("data").to_str().unwrap())
            .replace("assignment = \"naive\"", "assignmnet = \"naive\""),
    )
    .unwrap();
    let run = dir.path().join("run");
    let out = experiments(&[file.to_str().unwrap(), "--out", run.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.toml") && err.contains("variant 'naive'") && err.contains("assignmnet"),
        "{err}"
    );
    assert!(
        !run.exists() && !dir.path().join("data").exists(),
        "nothing is written"
    );
}
