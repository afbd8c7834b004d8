//! The shipped `film.toml`, which uses this crate's representation, trains, checkpoints and
//! evaluates end to end through FieldProbe's unchanged pipeline.

use std::path::PathBuf;

// Link this crate so its representation is registered (exactly what its `main` does).
use custom_model as _;

#[test]
fn film_toml_trains_and_writes_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let shipped = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"))
        .join("film.toml");
    let out = fieldprobe::launch::run_shrunk(&shipped, dir.path(), 6).unwrap();
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    assert_eq!(metrics["steps"], 6);
    assert!(metrics["final_loss"].as_f64().unwrap().is_finite());
    let iou = metrics["mean_iou"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&iou), "{iou}");
    assert!(out.join("checkpoints/latest.json").is_file());
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        config.contains("type = \"film\""),
        "the resolved config records the plugin: {config}"
    );
}
