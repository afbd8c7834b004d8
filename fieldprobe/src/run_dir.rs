//! An existing run directory (`config.toml`, `checkpoints/`, `input.json`), opened to evaluate
//! it again or to reconstruct meshes with its model.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use burn::prelude::*;
use fieldprobe_core::field::FieldModel;
use fieldprobe_core::geometry::camera::NMR_IMAGE_SIZE;
use fieldprobe_core::train::checkpoint::{self, CheckpointState};

use crate::experiment::{Experiment, load_experiment};
use crate::loader::CategoryData;
use crate::metrics::{Metrics, Training};
use crate::outputs::Outputs;
use crate::run::{InputSpec, RunOutcome, evaluate_run};

/// A run directory with its resolved experiment and latest checkpoint.
#[derive(Debug)]
pub struct RunDir {
    pub dir: PathBuf,
    /// The resolved experiment the run was made with (`config.toml`).
    pub exp: Experiment,
    /// The latest complete checkpoint.
    pub state: CheckpointState,
}

impl RunDir {
    /// Opens `dir`; the errors say what is missing (not a directory, not a run, no checkpoint).
    pub fn open(dir: &Path) -> Result<Self> {
        if !dir.is_dir() {
            bail!("{}: no such run directory", dir.display());
        }
        let config = dir.join("config.toml");
        if !config.is_file() {
            bail!(
                "{}: not a run directory (no config.toml; an ablation keeps one run per variant in its sub-directories)",
                dir.display()
            );
        }
        let exp = load_experiment(&config)?;
        let ckpt = dir.join("checkpoints");
        let state = checkpoint::latest(&ckpt)?.ok_or_else(|| {
            anyhow!(
                "{}: no checkpoint yet ({} is missing); train the run first",
                dir.display(),
                ckpt.join("latest.json").display()
            )
        })?;
        Ok(Self {
            dir: dir.to_path_buf(),
            exp,
            state,
        })
    }

    /// The model of the latest checkpoint, on `device`, in evaluation mode.
    pub fn model(&self, device: &Device) -> Result<Box<dyn FieldModel>> {
        Ok(checkpoint::load_model(
            self.exp.model.as_ref(),
            device,
            &self.dir.join("checkpoints"),
        )?)
    }

    /// Evaluates the latest checkpoint with `self.exp`'s `[eval]` settings on `data` (loaded for
    /// `self.exp`) and writes `metrics.json`, `objects.csv` and, through `outputs`, the report
    /// into `out`. The training time and decoder points are carried over from the run's own
    /// `metrics.json` when it has one (an evaluation does not retrain, and 0 s would misreport).
    pub fn evaluate(
        &self,
        data: &[CategoryData],
        out: &Path,
        outputs: &dyn Outputs,
    ) -> Result<RunOutcome> {
        let selected = self.exp.backend.select()?;
        tracing::info!("backend: {}", selected.description);
        let model = self.model(&selected.device)?;
        let (seconds, decoder_points) = std::fs::read_to_string(self.dir.join("metrics.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<Metrics>(&t).ok())
            .map_or((0.0, 0), |m| (m.train_seconds, m.train_decoder_points));
        let training = Training {
            steps: self.state.step,
            seconds,
            decoder_points,
            history: self.state.history.clone(),
            terms: self.state.terms.clone(),
        };
        tracing::info!(
            "evaluating {} at step {} → {}",
            self.dir.display(),
            self.state.step,
            out.display()
        );
        evaluate_run(
            &self.exp,
            model.as_ref(),
            data,
            out,
            &selected,
            &training,
            outputs,
        )
    }

    /// Writes the latest checkpoint's weights to `out` as safetensors (tensor names are module
    /// paths, `decoder.layers.0.weight`); the header holds the run's `[model]` table
    /// (`fieldprobe.model`) and step (`fieldprobe.step`), so the file says what it fits. A run
    /// with the same `[model]` and `train.init_from = "<out>"` starts from it. Returns the number
    /// of scalar parameters written.
    pub fn export_safetensors(&self, out: &Path) -> Result<usize> {
        #[derive(serde::Serialize)]
        struct ModelTable<'a> {
            model: &'a dyn fieldprobe_core::field::FieldModelConfig,
        }
        if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("cannot create {}", parent.display()))?;
        }
        let model = self.model(&Device::flex())?;
        let table = toml::to_string(&ModelTable {
            model: self.exp.model.as_ref(),
        })?;
        let metadata = [
            ("fieldprobe.model".to_string(), table),
            ("fieldprobe.step".to_string(), self.state.step.to_string()),
        ];
        model
            .export_safetensors(out, &metadata)
            .map_err(|e| anyhow!(e))?;
        Ok(model.parameters())
    }

    /// The side of the images the model was trained on (`input.json`; runs made before it was
    /// written used NMR's 64).
    pub fn input_size(&self) -> Result<usize> {
        let path = self.dir.join("input.json");
        if !path.is_file() {
            return Ok(NMR_IMAGE_SIZE);
        }
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let spec: InputSpec =
            serde_json::from_str(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
        Ok(spec.image_size)
    }
}
