//! What a run writes besides its numbers.
//!
//! The library writes what every user of a run needs: `config.toml`, `input.json`, checkpoints,
//! `metrics.json`, and for an ablation `ablation.toml` and `ablation.json`. Reports and pictures
//! are the application's: the CLI renders `report.md`, `gallery.png`, `training_curves.png` and
//! `samples.png` through an [`Outputs`] it passes in; [`NoOutputs`] writes nothing more.

use std::path::Path;

use anyhow::Result;
use burn::prelude::Device;
use fieldprobe_core::field::Field;
use fieldprobe_core::probe::Aggregator;

use crate::ablation::entry::Status;
use crate::evaluate::GalleryMeshes;
use crate::experiment::Experiment;
use crate::loader::CategoryData;
use crate::metrics::{Metrics, Training};
use crate::variants::AblationFile;

/// A run that has just been evaluated (its `metrics.json` is written).
#[derive(Clone, Copy)]
pub struct FinishedRun<'a> {
    pub exp: &'a Experiment,
    /// The trained model, in evaluation mode.
    pub model: &'a dyn Field,
    /// The run's aggregator (field silhouettes are rendered through it).
    pub aggregator: &'a dyn Aggregator,
    pub data: &'a [CategoryData],
    /// The run directory.
    pub dir: &'a Path,
    pub metrics: &'a Metrics,
    /// Meshes evaluation extracted for the gallery (see `evaluate::Evaluation`).
    pub meshes: &'a GalleryMeshes,
    pub training: &'a Training,
    /// The plain (non-autodiff) device the model is on.
    pub device: &'a Device,
}

/// Hooks for the application's reports and pictures. Every method has a default that writes
/// nothing.
pub trait Outputs: Sync {
    /// After a run is evaluated: write its pictures and report into `run.dir` and return the
    /// report's text (printed by the CLI).
    fn run(&self, run: &FinishedRun<'_>) -> Result<String> {
        let _ = run;
        Ok(String::new())
    }

    /// When an ablation starts, once its directory exists and the base's data are loaded.
    fn ablation_started(
        &self,
        root: &Path,
        file: &AblationFile,
        base_data: &[CategoryData],
    ) -> Result<()> {
        let _ = (root, file, base_data);
        Ok(())
    }

    /// After each entry of an ablation (`ablation.json` is written already): write the
    /// comparison and return its text.
    fn ablation(&self, root: &Path, file: &AblationFile, status: &[Status]) -> Result<String> {
        let _ = (root, file, status);
        Ok(String::new())
    }
}

/// Writes nothing beyond the library's files.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoOutputs;

impl Outputs for NoOutputs {}
