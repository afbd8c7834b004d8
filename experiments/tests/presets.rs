//! The main command and `paper.toml` run the paper's full method: importance sampling of rays and
//! anchors, boundary-aware assignment and the p-norm normal consistency with p = 0.8, Δd = 0.03.
//! Read from each file's resolved configuration (what a run records in `config.toml`); the
//! ablation files' bases are pinned in `tests/ablation.rs`.

use std::path::{Path, PathBuf};

use fieldprobe::experiment::{Experiment, load_experiment};
use toml::{Table, Value};

fn resolved(exp: &Experiment) -> Table {
    toml::from_str(&exp.to_toml().unwrap()).unwrap()
}

fn get<'a>(t: &'a Table, path: &[&str]) -> &'a Value {
    let mut v = t.get(path[0]).unwrap_or_else(|| panic!("no {}", path[0]));
    for k in &path[1..] {
        v = v
            .get(*k)
            .unwrap_or_else(|| panic!("no {} in {}", k, path.join(".")));
    }
    v
}

fn assert_full_method(name: &str, exp: &Experiment) {
    let t = resolved(exp);
    let s = |p: &[&str]| get(&t, p).as_str().unwrap().to_string();
    let f = |p: &[&str]| get(&t, p).as_float().unwrap();
    assert_eq!(s(&["probe", "ray_sampler", "type"]), "importance", "{name}");
    assert_eq!(
        s(&["probe", "anchor_sampler", "type"]),
        "importance",
        "{name}"
    );
    assert_eq!(s(&["probe", "assignment"]), "boundary_aware", "{name}");
    assert_eq!(
        s(&["regularizers", "normals", "type"]),
        "normal_consistency",
        "{name}"
    );
    assert!(
        (f(&["regularizers", "normals", "p"]) - 0.8).abs() < 1e-6,
        "{name}"
    );
    assert!(
        (f(&["regularizers", "normals", "delta"]) - 0.03).abs() < 1e-6,
        "{name}"
    );
    assert!(f(&["regularizers", "normals", "weight"]) > 0.0, "{name}");
}

/// The package folder as cargo sets it when running the test (see `fieldprobe_tests::data_dir`).
fn root() -> PathBuf {
    PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"))
}

#[test]
fn the_main_command_and_paper_toml_run_the_full_method() {
    for file in ["quickstart.toml", "paper.toml"] {
        let exp = load_experiment(&root().join(file)).unwrap();
        assert_full_method(file, &exp);
    }
    let paper = load_experiment(&root().join("paper.toml")).unwrap();
    assert_eq!((paper.eval.resolution, paper.eval.views), (32, 24));
    assert_eq!(
        paper.eval.subsamples, 4,
        "paper.toml evaluates in the max-pool protocol"
    );
}

/// `fit-one.toml` is the per-object λ sweep's row "λ = 3" (the λ that sweep chose, README "The
/// regularizer's weight"), so the sweep's finished runs are the preset's measured numbers: the
/// same training table (seed included), hence the same weights.
#[test]
fn fit_one_trains_as_the_chosen_row_of_its_lambda_sweep() {
    let fit_one = load_experiment(&root().join("fit-one.toml")).unwrap();
    let sweep =
        fieldprobe::variants::AblationFile::load(&root().join("sweeps/lambda-fit-one.toml"))
            .unwrap();
    let row = |name: &str| {
        let e = sweep.entries.iter().find(|e| e.name == name);
        e.unwrap_or_else(|| panic!("sweep has no row {name}"))
            .experiment
            .training_table()
            .unwrap()
    };
    let preset = fit_one.training_table().unwrap();
    assert_eq!(preset, row("λ=3"));
    assert_ne!(preset, row("none"), "the preset has a regularizer");
    let t = resolved(&fit_one);
    let w = get(&t, &["regularizers", "normals", "weight"]).as_float();
    assert_eq!(w, Some(3.0));
}

/// Every experiment file shipped under `experiments/` loads and validates (a plain file, or every
/// variant of an ablation file), so a renamed key or component breaks a test, not a user's run.
#[test]
fn every_shipped_experiment_file_loads() {
    use fieldprobe::variants::{AblationFile, has_variants};
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() && !p.ends_with("src") && !p.ends_with("tests") {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "toml") && !p.ends_with("Cargo.toml") {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    walk(&root(), &mut files);
    assert!(files.len() >= 10, "{files:?}");
    for f in &files {
        if has_variants(f) {
            let a = AblationFile::load(f).unwrap_or_else(|e| panic!("{e:#}"));
            assert!(a.entries.len() > 1, "{}", f.display());
        } else {
            load_experiment(f).unwrap_or_else(|e| panic!("{e:#}"));
        }
    }
    // The SDF presets pair the signed-distance representation with the eikonal term.
    let sdf = load_experiment(&root().join("sdf/single-view.toml")).unwrap();
    let t = resolved(&sdf);
    assert_eq!(get(&t, &["model", "type"]).as_str(), Some("sdf"));
    assert_eq!(
        get(&t, &["regularizers", "eikonal", "type"]).as_str(),
        Some("eikonal")
    );
}

/// The eikonal term on an occupancy network is a config error that says what it needs.
#[test]
fn eikonal_without_a_signed_distance_is_rejected_on_load() {
    let text = std::fs::read_to_string(root().join("sdf/single-view.toml"))
        .unwrap()
        .replace("type = \"sdf\"", "type = \"single_view\"")
        .replace("beta = 0.02\n", "")
        .replace("sphere = 0.3\n", "");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("occupancy-eikonal.toml");
    std::fs::write(&path, text).unwrap();
    let e = format!("{:#}", load_experiment(&path).unwrap_err());
    assert!(
        e.contains("occupancy-eikonal.toml")
            && e.contains("regularizers.eikonal")
            && e.contains("signed distance"),
        "{e}"
    );
}
