//! The shipped `stratified.toml`, which uses this crate's sampler, trains end to end.

use std::path::Path;

// Link this crate so its sampler is registered (exactly what its `main` does).
use custom_sampler as _;
use experiments::run::{RunArgs, run};

#[test]
fn stratified_toml_trains_and_writes_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("stratified.toml");
    let mut doc: toml::Table = std::fs::read_to_string(shipped).unwrap().parse().unwrap();
    // Keep the sampler and model as shipped; make the data and the run small and private.
    doc["data"]["dir"] =
        toml::Value::String(dir.path().join("data").to_string_lossy().into_owned());
    doc["data"]["generate"]["train"] = toml::Value::Integer(4);
    doc["train"]["steps"] = toml::Value::Integer(6);
    doc["train"]["checkpoint_every"] = toml::Value::Integer(3);
    doc["eval"]["views"] = toml::Value::Integer(1);
    let file = dir.path().join("stratified.toml");
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
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        config.contains("stratified"),
        "the resolved config records the plugin: {config}"
    );
}
