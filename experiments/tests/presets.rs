//! The main command and `paper.toml` run the paper's full method: importance sampling of rays and
//! anchors, boundary-aware assignment and the p-norm normal consistency with p = 0.8, Δd = 0.03.
//! Read from each file's resolved configuration (what a run records in `config.toml`); the
//! ablation files' bases are pinned in `tests/ablation.rs`.

use std::path::Path;

use experiments::experiment::{Experiment, load_experiment};
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
    assert_eq!(s(&["regularizer", "type"]), "normal_consistency", "{name}");
    assert!((f(&["regularizer", "p"]) - 0.8).abs() < 1e-6, "{name}");
    assert!((f(&["regularizer", "delta"]) - 0.03).abs() < 1e-6, "{name}");
    assert!(f(&["regularizer", "weight"]) > 0.0, "{name}");
}

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/"))
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
