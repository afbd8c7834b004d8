//! The shipped `film.toml`, which uses this crate's representation, trains, checkpoints and
//! evaluates end to end through FieldProbe's unchanged pipeline.

use std::path::Path;

// Link this crate so its representation is registered (exactly what its `main` does).
use custom_model as _;
use experiments::run::{RunArgs, run};

#[test]
fn film_toml_trains_and_writes_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("film.toml");
    let mut doc: toml::Table = std::fs::read_to_string(shipped).unwrap().parse().unwrap();
    // Keep the representation as shipped; make the data and the run small and private.
    doc["data"]["dir"] =
        toml::Value::String(dir.path().join("data").to_string_lossy().into_owned());
    doc["data"]["generate"]["train"] = toml::Value::Integer(4);
    doc["train"]["steps"] = toml::Value::Integer(6);
    doc["train"]["checkpoint_every"] = toml::Value::Integer(3);
    doc["eval"]["views"] = toml::Value::Integer(1);
    let file = dir.path().join("film.toml");
    std::fs::write(&file, toml::to_string(&doc).unwrap()).unwrap();

    let out = dir.path().join("run");
    run(RunArgs {
        file,
        out: Some(out.clone()),
        resume: false,
        variant: None,
        seed: None,
    })
    .unwrap();
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    assert_eq!(metrics["steps"], 6);
    assert!(metrics["final_loss"].as_f64().unwrap().is_finite());
    assert!(metrics["mean_iou"].as_f64().unwrap() >= 0.0);
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        config.contains("type = \"film\""),
        "the resolved config records the plugin: {config}"
    );
}
