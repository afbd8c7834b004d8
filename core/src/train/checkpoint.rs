//! Atomic checkpoints: `DIR/step-NNNNNNN/{model,optim}.bpk` plus `DIR/latest.json`, which is
//! written (atomically) last and names the complete checkpoint to resume from. A kill at any
//! moment leaves either the previous or the new checkpoint valid; the two most recent are kept.

use std::path::{Path, PathBuf};

use burn::optim::AdamConfig;
use burn::prelude::*;
use serde::{Deserialize, Serialize};

use super::Trainer;
use crate::data::dataset::write_atomic;
use crate::field::{FieldModel, FieldModelConfig};
use crate::{Error, Result};

/// What `latest.json` records.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointState {
    pub step: usize,
    /// Sub-directory holding `model.bpk` and `optim.bpk`.
    pub dir: String,
    pub history: Vec<(usize, f32)>,
    /// `(step, silhouette, regularizers)` per logged interval (absent in older checkpoints).
    #[serde(default)]
    pub terms: Vec<(usize, f32, f32)>,
}

const LATEST: &str = "latest.json";

fn record_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::format(path, format!("checkpoint: {e}"))
}

/// Writes a checkpoint of `trainer` under `dir`.
pub fn save(trainer: &Trainer, dir: &Path) -> Result<()> {
    let name = format!("step-{:07}", trainer.step);
    let sub = dir.join(&name);
    std::fs::create_dir_all(&sub).map_err(|e| Error::io(&sub, e))?;
    let written = (|| {
        let model_path = sub.join("model.bpk");
        trainer
            .model
            .save_weights(&model_path)
            .map_err(|e| record_error(&model_path, e))?;
        let optim_path = sub.join("optim.bpk");
        trainer
            .optim
            .save(&optim_path)
            .map_err(|e| record_error(&optim_path, e))
    })();
    if let Err(e) = written {
        // A half-written checkpoint (a full disk) is never named by `latest.json`; removing it
        // gives its space back. Best effort: the error that matters is `e`.
        let _ = std::fs::remove_dir_all(&sub);
        return Err(e);
    }
    let state = CheckpointState {
        step: trainer.step,
        dir: name.clone(),
        history: trainer.history.clone(),
        terms: trainer.terms.clone(),
    };
    let text = serde_json::to_string_pretty(&state).expect("state serializes");
    // The checkpoint `latest.json` named until now: the one kept besides the new one.
    let previous = latest(dir).ok().flatten().map(|s| s.dir);
    write_atomic(&dir.join(LATEST), |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    // Keep this checkpoint and the previous complete one; anything else (older ones, and the
    // half-written directory a kill can leave) goes.
    let stale: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.is_dir()
                && p.file_name().is_some_and(|n| {
                    let n = n.to_string_lossy();
                    n.starts_with("step-") && n != name && Some(n.as_ref()) != previous.as_deref()
                })
        })
        .collect();
    for p in stale {
        let _ = std::fs::remove_dir_all(p);
    }
    Ok(())
}

/// The state of the latest complete checkpoint under `dir`, if any.
pub fn latest(dir: &Path) -> Result<Option<CheckpointState>> {
    let path = dir.join(LATEST);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| Error::format(&path, e.to_string()))
}

/// Restores a trainer from the latest checkpoint under `dir`.
pub fn load(config: &dyn FieldModelConfig, device: &Device, dir: &Path) -> Result<Trainer> {
    let state = latest(dir)?.ok_or_else(|| {
        Error::io(
            dir.join(LATEST),
            std::io::Error::new(std::io::ErrorKind::NotFound, "no checkpoint to resume from"),
        )
    })?;
    let device = device.clone().autodiff();
    let sub = dir.join(&state.dir);
    let model_path = sub.join("model.bpk");
    let mut model = config.init(&device);
    model
        .load_weights(&model_path)
        .map_err(|e| record_error(&model_path, e))?;
    let optim_path = sub.join("optim.bpk");
    let optim = AdamConfig::new()
        .init()
        .load(&optim_path)
        .map_err(|e| record_error(&optim_path, e))?;
    Ok(Trainer {
        model,
        optim,
        device,
        replicas: Vec::new(),
        step: state.step,
        history: state.history,
        terms: state.terms,
    })
}

/// Loads just the model weights of the latest checkpoint (for evaluation), on `device`.
pub fn load_model(
    config: &dyn FieldModelConfig,
    device: &Device,
    dir: &Path,
) -> Result<Box<dyn FieldModel>> {
    let state = latest(dir)?.ok_or_else(|| {
        Error::io(
            dir.join(LATEST),
            std::io::Error::new(std::io::ErrorKind::NotFound, "no checkpoint"),
        )
    })?;
    let model_path = dir.join(&state.dir).join("model.bpk");
    let mut model = config.init(device);
    model
        .load_weights(&model_path)
        .map_err(|e| record_error(&model_path, e))?;
    Ok(model)
}
