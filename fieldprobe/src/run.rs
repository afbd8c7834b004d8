//! One run: train, evaluate, and write the run directory (`config.toml`, `input.json`,
//! `checkpoints/`, `history.csv` (as training goes), `metrics.json`, `objects.csv` (every
//! prediction's scores), `meshes/` (the test meshes, unless `eval.save_meshes = false`), and
//! whatever the [`Outputs`] add: the CLI's `report.md` and pictures).
//! [`crate::launch::run_file`] runs a file through [`run_one`]; an ablation runs it per entry and
//! seed.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use fieldprobe_backends::Selected;
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::field::{Field, FieldModel};
use fieldprobe_core::object::ObjectViews;
use fieldprobe_core::train::{Components, StepStats, TrainRun, Trainer, checkpoint};
use fieldprobe_core::weights::Import;
use serde::{Deserialize, Serialize};
use tracing::{info, warn};

use crate::evaluate::{evaluate, write_predictions_csv};
use crate::experiment::Experiment;
use crate::history::{self, HistoryLog};
use crate::loader::CategoryData;
use crate::metrics::{Metrics, Training, mean_of};
use crate::outputs::{FinishedRun, Outputs};
use crate::overrides::Overrides;
use crate::progress;

/// How to run an experiment file (the CLI's flags).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Run directory (default: `runs/<name>`).
    pub out: Option<PathBuf>,
    /// Continue from the run directory's latest checkpoint (a directory without one starts
    /// from step 0, so scripts can always pass it).
    pub resume: bool,
    /// Ablation files: run only this entry (its name or directory name); finished entries are
    /// still read into the report.
    pub variant: Option<String>,
    /// Train with this seed instead of the file's (ablation files: run only this one of
    /// `seeds`).
    pub seed: Option<u64>,
    /// `--set key=value` changes to the file's keys (every entry of an ablation).
    pub overrides: Overrides,
}

/// All training objects of all categories, in one pool.
fn pool(data: &[CategoryData]) -> Vec<ObjectViews> {
    data.iter().flat_map(|c| c.train.iter().cloned()).collect()
}

/// Where a file's results went and the text of its report.
#[derive(Debug)]
pub struct FileOutcome {
    /// The run directory (an ablation: its root).
    pub dir: PathBuf,
    /// `report.md`'s text, if the [`Outputs`] wrote one.
    pub report: String,
    /// Ablation entries that failed (the others ran; rerun with `resume`).
    pub failed: Vec<String>,
    /// A single run's metrics (what `metrics.json` holds); `None` for an ablation.
    pub metrics: Option<Metrics>,
}

/// A finished run.
#[derive(Debug)]
pub struct RunOutcome {
    pub metrics: Metrics,
    /// The trainer's loss history: `(step, mean loss of the interval)`.
    pub history: Vec<(usize, f32)>,
    /// What `report.md` holds.
    pub report: String,
}

/// Refuses to start over a run directory that holds a checkpoint, unless resuming.
pub fn check_can_start(dir: &Path, resume: bool) -> Result<()> {
    let ckpt = dir.join("checkpoints");
    let existing = checkpoint::latest(&ckpt)?;
    if existing.is_some() && !resume {
        bail!(
            "{} already holds a checkpoint (step {}); pass --resume to continue it or --out DIR to start a new run",
            ckpt.display(),
            existing.map_or(0, |s| s.step)
        );
    }
    Ok(())
}

/// Creates the run directory and writes the resolved `config.toml`.
pub fn prepare_dir(exp: &Experiment, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let resolved = exp.to_toml()?;
    write_atomic(&dir.join("config.toml"), |w| {
        std::io::Write::write_all(w, resolved.as_bytes())
    })?;
    Ok(())
}

/// Trains (or, with `resume`, continues from `dir/checkpoints`) and evaluates `exp` on its loaded
/// `data`, writing `metrics.json` and `report.md` into `dir` (made by [`prepare_dir`]); `file`
/// names the experiment file in errors.
pub fn run_one(
    exp: &Experiment,
    file: &Path,
    data: &[CategoryData],
    dir: &Path,
    resume: bool,
    outputs: &dyn Outputs,
) -> Result<RunOutcome> {
    let ckpt = dir.join("checkpoints");
    let selected = exp.backend.select()?;
    info!("backend: {}", selected.description);
    let comps = exp
        .components_on(&selected.device)
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;

    write_input_spec(dir, data)?;
    let devices = selected.devices(exp.train.devices)?;
    if devices.len() > 1 {
        info!(
            "data-parallel training over {} devices: {devices:?}",
            devices.len()
        );
    }
    let (trainer, train_seconds, decoder_points) =
        train(exp, data, &comps, &devices, &ckpt, resume)?;
    let training = Training {
        steps: trainer.step,
        seconds: train_seconds,
        decoder_points,
        history: trainer.history.clone(),
        terms: trainer.terms.clone(),
    };
    let model = trainer.model.valid_model();
    evaluate_run(
        exp,
        model.as_ref(),
        data,
        dir,
        &selected,
        &training,
        outputs,
    )
}

/// `input.json`: what the model reads, so that `reconstruct` can bring any image to it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Side of the square input images in pixels.
    pub image_size: usize,
}

/// Writes `input.json` (the training images' size).
fn write_input_spec(dir: &Path, data: &[CategoryData]) -> Result<()> {
    let Some(size) = data
        .iter()
        .flat_map(|c| c.eval.first())
        .map(|o| o.image_size)
        .next()
    else {
        return Ok(());
    };
    let json = serde_json::to_string_pretty(&InputSpec { image_size: size })?;
    write_atomic(&dir.join("input.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    Ok(())
}

/// Evaluates `model` (evaluation mode) on `data` and writes `metrics.json` into `dir`
/// (atomically), then hands the finished run to `outputs` (the CLI's report and pictures).
pub fn evaluate_run(
    exp: &Experiment,
    model: &dyn Field,
    data: &[CategoryData],
    dir: &Path,
    selected: &Selected,
    training: &Training,
    outputs: &dyn Outputs,
) -> Result<RunOutcome> {
    let t0 = Instant::now();
    let per_object_fit = !exp.model.uses_image();
    let mesh_dir = exp.data.dir.join("meshes");
    let mesh_dir = mesh_dir.is_dir().then_some(mesh_dir.as_path());
    info!("evaluating on the {} split", exp.data.eval_split.name());
    // Field silhouettes are rendered through the run's aggregator, as training saw them.
    let comps = exp
        .components()
        .map_err(|e| anyhow::anyhow!("{}: {e}", exp.name))?;
    let aggregator = comps.aggregator.as_ref();
    let evaluation = evaluate(
        model,
        aggregator,
        data,
        &exp.eval,
        per_object_fit,
        mesh_dir,
        exp.eval.save_meshes.then_some(dir),
        &selected.device,
    )?;
    write_predictions_csv(&dir.join("objects.csv"), &evaluation.predictions)?;
    let eval_seconds = t0.elapsed().as_secs_f64();
    let eval_grid_points = evaluation.grid_points;
    let per_category = evaluation.per_category;
    let metrics = Metrics {
        experiment: exp.name.clone(),
        mean_iou: mean_of(&per_category, |c| Some(c.iou)).unwrap_or(0.0),
        centre_iou: mean_of(&per_category, |c| Some(c.centre_iou)).unwrap_or(0.0),
        outside_hull: mean_of(&per_category, |c| Some(c.outside_hull)).unwrap_or(0.0),
        visual_hull_iou: mean_of(&per_category, |c| Some(c.visual_hull_iou)).unwrap_or(0.0),
        mean_shape_iou: mean_of(&per_category, |c| c.mean_shape_iou),
        mean_gt_shape_iou: mean_of(&per_category, |c| c.mean_gt_shape_iou),
        silhouette_iou: mean_of(&per_category, |c| c.silhouette_iou),
        per_category,
        split: exp.data.eval_split.name().into(),
        resolution: exp.eval.resolution,
        subsamples: exp.eval.subsamples,
        maxpool: exp.eval.maxpool,
        steps: training.steps,
        train_seconds: training.seconds,
        train_decoder_points: training.decoder_points,
        eval_seconds,
        eval_grid_points,
        final_loss: training.history.last().map(|h| h.1),
        final_silhouette_loss: training.terms.last().map(|t| t.1),
        final_regularizer_loss: training.terms.last().map(|t| t.2),
        backend: selected.backend.into(),
        device: selected.description.clone(),
    };
    let json = serde_json::to_string_pretty(&metrics)?;
    write_atomic(&dir.join("metrics.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    let report = outputs.run(&FinishedRun {
        exp,
        model,
        aggregator,
        data,
        dir,
        metrics: &metrics,
        meshes: &evaluation.gallery_meshes,
        training,
        device: &selected.device,
    })?;
    Ok(RunOutcome {
        metrics,
        history: training.history.clone(),
        report,
    })
}

/// The weights a fresh run starts from, over the random ones: the representation's own
/// (`model.encoder.pretrained`), then every tensor from `train.init_from`.
pub fn start_weights(exp: &Experiment, model: &mut dyn FieldModel) -> Result<()> {
    exp.model
        .load_pretrained(model)
        .map_err(anyhow::Error::msg)?;
    if let Some(path) = &exp.train.init_from {
        let report = model
            .import_safetensors(path, &Import::default())
            .map_err(|e| anyhow::anyhow!("train.init_from: {e}"))?;
        info!(
            "started from {} ({} tensors; {} in the file not used)",
            path.display(),
            report.loaded,
            report.unused.len()
        );
    }
    Ok(())
}

/// Trains (or resumes) to `exp.train.steps` on `devices` (data-parallel when there are several;
/// the model lives on the first), checkpointing atomically; returns the trainer, the
/// seconds spent in this process and the decoder evaluations of its steps' silhouette terms.
fn train(
    exp: &Experiment,
    data: &[CategoryData],
    comps: &Components,
    devices: &[burn::prelude::Device],
    ckpt: &Path,
    resume: bool,
) -> Result<(Trainer, f64, u64)> {
    let device = &devices[0];
    let resume = resume && {
        let found = checkpoint::latest(ckpt)?.is_some();
        if !found {
            info!(
                "--resume: no checkpoint in {} yet; starting at step 0",
                ckpt.display()
            );
        }
        found
    };
    let trainer = if resume {
        let t = checkpoint::load(exp.model.as_ref(), device, ckpt)?;
        info!("resumed from {} at step {}", ckpt.display(), t.step);
        t
    } else {
        let mut t = Trainer::new(exp.model.as_ref(), device, exp.seed);
        start_weights(exp, t.model.as_mut())?;
        t
    };
    let mut trainer = trainer.data_parallel(devices);
    let objects = pool(data);
    let run = TrainRun {
        objects: &objects,
        comps,
        probe: &exp.probe.spec,
        schedule: &exp.train,
        uses_image: exp.model.uses_image(),
        seed: exp.seed,
    };
    let dir = ckpt.parent().unwrap_or(Path::new("."));
    let mut history = HistoryLog::open(dir, &trainer)?;
    // A history that cannot be written (a full disk) is reported once; training goes on, and
    // the checkpoints say whether the disk is usable.
    let mut history_error = None;
    let bar = progress::bar("train", exp.train.steps, trainer.step);
    let t0 = Instant::now();
    let mut points = 0u64;
    let mut show = |t: &Trainer, s: &StepStats| {
        points += s.points as u64;
        bar.set(t.step, format!("loss {:.4}", s.loss));
        if history_error.is_none()
            && let Err(e) = history.record(t, exp.train.lr_at(t.step.saturating_sub(1)))
        {
            warn!("{e:#}; {} is not updated any more", history::FILE);
            history_error = Some(e);
        }
    };
    trainer.fit(&run, Some(ckpt), &mut show).map_err(|e| {
        bar.abandon();
        anyhow::anyhow!("{e} (checkpoints: {})", ckpt.display())
    })?;
    bar.finish();
    Ok((trainer, t0.elapsed().as_secs_f64(), points))
}
