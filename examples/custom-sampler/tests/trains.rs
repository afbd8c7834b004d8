//! The shipped `stratified.toml`, which uses this crate's sampler, trains end to end.

use std::path::PathBuf;

// Link this crate so its sampler is registered (exactly what its `main` does).
use custom_sampler as _;

#[test]
fn stratified_toml_trains_and_writes_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let shipped = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"))
        .join("stratified.toml");
    let out = fieldprobe::launch::run_shrunk(&shipped, dir.path(), 6).unwrap();
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
