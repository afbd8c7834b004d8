//! FieldProbe as one library: implicit surfaces learned from silhouettes by ray-based field
//! probing (Liu et al., NeurIPS 2019).
//!
//! The framework's crates, re-exported under one name (as `burn` does for its own):
//!
//! * [`data`] — the NMR world without burn: camera, meshes, rendering, voxelization, visual hull,
//!   procedural shapes, dataset formats, mesh extraction (`fieldprobe-data`).
//! * the method (`fieldprobe-core`, its modules at this crate's root): [`field`]
//!   (representations), [`probe`] (samplers, assignment, aggregation), [`regularize`], [`train`]
//!   (the training loop), [`eval`] (the NMR protocol), [`registry`] (plugins), [`geometry`],
//!   [`extract`].
//! * [`models`], [`samplers`], [`regularizers`] — the shipped plugins; [`backends`] — the device.
//!
//! and the pipeline that turns an experiment file into results, which the `experiments` CLI only
//! drives:
//!
//! * [`experiment`] — the TOML experiment file; [`variants`] — ablation files (`[[variants]]`);
//!   [`overrides`] — `--set key=value` on top of either; [`layers`] — how those layers merge.
//! * [`make`] — datasets in the published layout; [`loader`] — an experiment's objects;
//!   [`lock`] — one process per run directory.
//! * [`launch`] — an experiment file from start to end ([`run_file`]); [`run`] — train + evaluate
//!   one experiment into a run directory; [`metrics`] — what it measured; [`history`] — its
//!   `history.csv`; [`run_dir`] — open one.
//! * [`evaluate`] — the NMR protocol with its references and mesh metrics, per category.
//! * [`ablation`] — every entry × seed of an ablation, and orderings vs the paper.
//! * [`outputs`] — hooks for reports and pictures; [`progress`] — hooks for progress display.
//!
//! ```no_run
//! use fieldprobe::outputs::NoOutputs;
//! use fieldprobe::{RunOptions, run_file};
//!
//! let done = run_file("experiments/smoke.toml".as_ref(), &RunOptions::default(), &NoOutputs)?;
//! println!("metrics in {}", done.dir.join("metrics.json").display());
//! # anyhow::Ok(())
//! ```
//!
//! A crate adding a plugin depends on this library (or on `fieldprobe-core` alone) and links
//! itself into the binary that runs it; linking this library links every shipped plugin.

pub mod ablation;
pub mod evaluate;
pub mod experiment;
pub mod history;
pub mod launch;
pub mod layers;
pub mod loader;
pub mod lock;
pub mod make;
pub mod metrics;
pub mod outputs;
pub mod overrides;
pub mod progress;
pub mod run;
pub mod run_dir;
pub mod variants;

pub use fieldprobe_backends as backends;
pub use fieldprobe_core::{
    Error, data, eval, extract, field, geometry, object, probe, register_component, registry,
    regularize, train,
};
pub use fieldprobe_models as models;
pub use fieldprobe_regularizers as regularizers;
pub use fieldprobe_samplers as samplers;

pub use experiment::Experiment;
pub use launch::run_file;
pub use run::RunOptions;
