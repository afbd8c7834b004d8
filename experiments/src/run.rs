//! `experiments FILE.toml`: train, evaluate, and write the run directory
//! (`config.toml`, `checkpoints/`, `metrics.json`, `report.md`). A file with `[[variants]]` is an
//! ablation and goes to [`crate::ablation`], which runs [`run_one`] per variant.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use fieldprobe_backends::Selected;
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::eval::occupancy::MaxPoolPath;
use fieldprobe_core::field::Field;
use fieldprobe_core::object::ObjectViews;
use fieldprobe_core::train::{Components, Trainer, checkpoint, prepare_step};
use serde::{Deserialize, Serialize};
use tracing::info;

use crate::data::{CategoryData, ensure_dataset, load};
use crate::evaluate::{CategoryMetrics, evaluate};
use crate::experiment::{Experiment, load_experiment};
use crate::plot;
use crate::progress::Progress;

/// Arguments of a run.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// The experiment file.
    pub file: PathBuf,
    /// Run directory (default: `runs/<name>`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Continue from the run directory's latest checkpoint (a directory without one starts
    /// from step 0, so scripts can always pass it).
    #[arg(long)]
    pub resume: bool,
    /// Ablation files: run only this entry (its name or directory name); finished entries are
    /// still read into the report. Several processes can share one ablation directory this
    /// way, one entry or seed each; a last `--resume` without filters writes the full report.
    #[arg(long)]
    pub variant: Option<String>,
    /// Train with this seed instead of the file's (ablation files: run only this one of
    /// `seeds`).
    #[arg(long)]
    pub seed: Option<u64>,
}

/// What `metrics.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Metrics {
    pub experiment: String,
    /// Mean over categories of the model's max-pool IoU (the NMR protocol; see
    /// `evaluate::CategoryMetrics`).
    pub mean_iou: f32,
    /// The same predictions read at the voxel centres only (secondary).
    #[serde(default)]
    pub centre_iou: f32,
    /// Mean share of the predicted voxels outside the 24-view visual hull.
    #[serde(default)]
    pub outside_hull: f32,
    pub visual_hull_iou: f32,
    pub mean_shape_iou: Option<f32>,
    pub mean_gt_shape_iou: Option<f32>,
    /// Per-object fits: mean IoU of the field's rendered silhouettes vs the input ones.
    pub silhouette_iou: Option<f32>,
    pub per_category: BTreeMap<String, CategoryMetrics>,
    pub split: String,
    pub resolution: usize,
    /// Lattice cells per voxel and axis of the max-pool protocol.
    #[serde(default)]
    pub subsamples: usize,
    /// How fields were converted to voxels (`eval.maxpool`).
    #[serde(default)]
    pub maxpool: MaxPoolPath,
    pub steps: usize,
    pub train_seconds: f64,
    pub eval_seconds: f64,
    pub final_loss: Option<f32>,
    /// The silhouette and regularizer terms of the last logged interval (means).
    #[serde(default)]
    pub final_silhouette_loss: Option<f32>,
    #[serde(default)]
    pub final_regularizer_loss: Option<f32>,
    pub backend: String,
    pub device: String,
}

fn mean_of(
    m: &BTreeMap<String, CategoryMetrics>,
    f: impl Fn(&CategoryMetrics) -> Option<f32>,
) -> Option<f32> {
    let v: Vec<f32> = m.values().filter_map(f).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f32>() / v.len() as f32)
}

/// All training objects of all categories, in one pool.
fn pool(data: &[CategoryData]) -> Vec<ObjectViews> {
    data.iter().flat_map(|c| c.train.iter().cloned()).collect()
}

pub fn run(args: RunArgs) -> Result<()> {
    if crate::variants::has_variants(&args.file) {
        return crate::ablation::run(&args);
    }
    if args.variant.is_some() {
        bail!(
            "{}: --variant applies to ablation files (with [[variants]]) only",
            args.file.display()
        );
    }
    let mut exp = load_experiment(&args.file)?;
    if let Some(seed) = args.seed {
        exp.seed = seed;
    }
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&exp.name));
    check_can_start(&dir, args.resume)?;
    prepare_dir(&exp, &dir)?;

    ensure_dataset(&exp)?;
    let data = load(&exp)?;
    let outcome = run_one(&exp, &args.file, &data, &dir, args.resume)?;
    println!("{}", outcome.report);
    println!("run directory: {}", dir.display());
    Ok(())
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

/// Runs a shipped experiment file shrunk to seconds, inside `dir`: its data generated privately
/// there (4 training objects), `steps` training steps checkpointed halfway, one evaluation view;
/// everything else (the model, probes, plugins) as shipped. What plugin crates use to test that
/// their TOML file trains end to end. Returns the run directory.
pub fn run_shrunk(shipped: &Path, dir: &Path, steps: usize) -> Result<PathBuf> {
    let text = std::fs::read_to_string(shipped)
        .with_context(|| format!("cannot read {}", shipped.display()))?;
    let mut doc: toml::Table = text
        .parse()
        .map_err(|e| anyhow::anyhow!("{}: {e}", shipped.display()))?;
    let table = |doc: &mut toml::Table, key: &str| -> Result<toml::Table> {
        match doc.get(key) {
            Some(toml::Value::Table(t)) => Ok(t.clone()),
            _ => bail!("{}: no [{key}] table", shipped.display()),
        }
    };
    let mut data = table(&mut doc, "data")?;
    data.insert(
        "dir".into(),
        toml::Value::String(dir.join("data").to_string_lossy().into_owned()),
    );
    if let Some(toml::Value::Table(g)) = data.get_mut("generate") {
        g.insert("train".into(), toml::Value::Integer(4));
    }
    doc.insert("data".into(), toml::Value::Table(data));
    let mut train = table(&mut doc, "train")?;
    train.insert("steps".into(), toml::Value::Integer(steps as i64));
    train.insert(
        "checkpoint_every".into(),
        toml::Value::Integer((steps / 2).max(1) as i64),
    );
    doc.insert("train".into(), toml::Value::Table(train));
    let mut eval = table(&mut doc, "eval").unwrap_or_default();
    eval.insert("views".into(), toml::Value::Integer(1));
    doc.insert("eval".into(), toml::Value::Table(eval));
    let name = shipped.file_name().unwrap_or_default();
    let file = dir.join(name);
    std::fs::write(&file, toml::to_string(&doc)?)
        .with_context(|| format!("cannot write {}", file.display()))?;
    let out = dir.join("run");
    run(RunArgs {
        file,
        out: Some(out.clone()),
        resume: false,
        variant: None,
        seed: None,
    })?;
    Ok(out)
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
) -> Result<RunOutcome> {
    let ckpt = dir.join("checkpoints");
    let selected = exp.backend.select();
    info!("backend: {}", selected.description);
    let comps = exp
        .components()
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;

    write_input_spec(dir, data)?;
    let (trainer, train_seconds) = train(exp, data, &comps, &selected.device, &ckpt, resume)?;
    let training = Training {
        steps: trainer.step,
        seconds: train_seconds,
        history: trainer.history.clone(),
        terms: trainer.terms.clone(),
    };
    let model = trainer.model.valid_model();
    evaluate_run(exp, model.as_ref(), data, dir, &selected, &training)
}

/// What training left for the report.
#[derive(Clone, Debug, Default)]
pub struct Training {
    pub steps: usize,
    pub seconds: f64,
    /// `(step, mean loss of the interval)`.
    pub history: Vec<(usize, f32)>,
    /// `(step, mean silhouette term, mean regularizer term)` of the same intervals.
    pub terms: Vec<(usize, f32, f32)>,
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

/// Evaluates `model` (evaluation mode) on `data` and writes the run's outputs into `dir`:
/// `metrics.json`, `gallery.png`, `training_curves.png` and `report.md` linking them (each
/// atomically, the report last).
pub fn evaluate_run(
    exp: &Experiment,
    model: &dyn Field,
    data: &[CategoryData],
    dir: &Path,
    selected: &Selected,
    training: &Training,
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
    let per_category = evaluate(
        model,
        aggregator,
        data,
        &exp.eval,
        per_object_fit,
        mesh_dir,
        &selected.device,
    )?;
    let eval_seconds = t0.elapsed().as_secs_f64();
    let gallery = crate::gallery::write(dir, model, aggregator, data, &exp.eval, &selected.device)?;
    if !training.history.is_empty() {
        let curve = plot::loss_terms_chart(&training.history, &training.terms);
        plot::write_png(&dir.join("training_curves.png"), &curve)?;
    }
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
        eval_seconds,
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
    let report = crate::report::render(exp, &metrics, &gallery, !training.history.is_empty());
    write_atomic(&dir.join("report.md"), |w| {
        std::io::Write::write_all(w, report.as_bytes())
    })?;
    Ok(RunOutcome {
        metrics,
        history: training.history.clone(),
        report,
    })
}

/// Trains (or resumes) to `exp.train.steps`, checkpointing atomically; returns the trainer and the
/// seconds spent in this process.
fn train(
    exp: &Experiment,
    data: &[CategoryData],
    comps: &Components,
    device: &burn::prelude::Device,
    ckpt: &Path,
    resume: bool,
) -> Result<(Trainer, f64)> {
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
    let mut trainer = if resume {
        let t = checkpoint::load(exp.model.as_ref(), device, ckpt)?;
        info!("resumed from {} at step {}", ckpt.display(), t.step);
        t
    } else {
        Trainer::new(exp.model.as_ref(), device, exp.seed)
    };
    let objects = pool(data);
    let spec = exp.probe_spec();
    let steps = exp.train.steps;
    let log_every = (steps / 100).max(1);
    let bar = Progress::new("train", steps, trainer.step);
    let t0 = Instant::now();
    // Sums over the logged interval: total, silhouette, regularizers, steps.
    let mut acc = (0.0f32, 0.0f32, 0.0f32, 0usize);
    while trainer.step < steps {
        let prepared = prepare_step(
            &objects,
            comps,
            &spec,
            exp.train.batch,
            exp.model.uses_image(),
            exp.seed,
            trainer.step,
        );
        let stats = trainer
            .step(&prepared, comps, exp.train.lr_at(trainer.step))
            .map_err(|e| {
                bar.abandon();
                anyhow::anyhow!("{e} (checkpoints: {})", ckpt.display())
            })?;
        acc = (
            acc.0 + stats.loss,
            acc.1 + stats.silhouette_loss,
            acc.2 + stats.regularizer_loss,
            acc.3 + 1,
        );
        if trainer.step % log_every == 0 || trainer.step == steps {
            let n = acc.3 as f32;
            trainer.history.push((trainer.step, acc.0 / n));
            trainer.terms.push((trainer.step, acc.1 / n, acc.2 / n));
            acc = (0.0, 0.0, 0.0, 0);
        }
        bar.set(trainer.step, format!("loss {:.4}", stats.loss));
        let every = exp.train.checkpoint_every;
        if (every > 0 && trainer.step % every == 0) || trainer.step == steps {
            checkpoint::save(&trainer, ckpt)?;
        }
    }
    bar.finish();
    Ok((trainer, t0.elapsed().as_secs_f64()))
}
