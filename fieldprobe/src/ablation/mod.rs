//! Running an ablation file (an experiment with `[[variants]]`, see [`crate::variants`]): the base
//! and then each variant is trained and evaluated into its own run directory, and one comparison
//! is written beside them:
//!
//! ```text
//! runs/<name>/
//!   ablation.toml          the file as run
//!   <slug>/                one ordinary run directory per entry (config.toml, checkpoints/,
//!                          metrics.json, report.md), the base first
//!   ablation.json          the finished entries, base first (rewritten after each one)
//!   report.md              (the CLI's, through `Outputs`) the comparison table, ordering vs
//!   training_curves.png    the paper, the loss history of every finished entry, and the rays
//!   samples.png            and anchors of the base's samplers vs a comparison sampler
//! ```
//!
//! All entries share the dataset (generated once, loaded once per distinct `[data]`). With
//! `--resume` an entry whose `metrics.json` exists is skipped, the one with a checkpoint continues,
//! and the rest start; without it, a directory already holding any entry is refused. What
//! `--resume` compares with the entry's recorded `config.toml` is the *training* configuration
//! ([`Experiment::training_table`]): a different one is refused; a finished run whose `[eval]`
//! alone changed is evaluated again from its checkpoint, not retrained; a different `name` does
//! not matter, so an entry that trains exactly as another file's entry (an ablation's base and a
//! sweep's row) can take over that run directory, copied into place, instead of training it
//! twice. An entry that fails (e.g. a non-finite loss) is reported, the others still run, and the
//! command exits with an error at the end.
//!
//! # Ordering vs the paper
//!
//! The paper's numbers are ShapeNet IoUs at full scale; ours are CPU-scale runs on procedural
//! data, so only orderings are compared ([`compare`]). For each pair of finished entries with
//! paper numbers: the paper orders them by its IoUs (equal numbers: a paper tie, not counted); our
//! order is the sign of the difference of mean IoUs, and it counts as *resolved* only if that
//! difference exceeds twice the standard error of the paired per-object IoU differences (the
//! same evaluation objects under both entries) and at least [`MIN_RESOLVED_DIFF`]. A resolved
//! pair agrees or disagrees with the paper; an unresolved one is within noise and is reported as
//! such, with its sign. The noise bar covers the choice of evaluation objects only, not training
//! noise (another seed could reorder close rows), which the report says.

pub mod compare;
pub mod entry;
pub mod fixtures;
#[cfg(test)]
mod tests;

pub use compare::*;
pub use entry::*;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::train::checkpoint;
use tracing::{error, info};

use crate::evaluate::{PredictionScores, read_predictions_csv};
use crate::experiment::{DataConfig, Experiment, load_experiment};
use crate::history::read_history;
use crate::loader::{CategoryData, ensure_dataset, load};
use crate::lock::RunLock;
use crate::metrics::Metrics;
use crate::outputs::Outputs;
use crate::run::{FileOutcome, RunOptions, RunOutcome, prepare_dir, run_one};
use crate::run_dir::RunDir;
use crate::variants::{AblationFile, Variant, entry_names};

/// Runs an ablation file (one with `[[variants]]`): every entry and seed, or only those that
/// `opts.variant` and `opts.seed` name. `outputs` writes the comparison after each entry.
pub fn run(path: &Path, opts: &RunOptions, outputs: &dyn Outputs) -> Result<FileOutcome> {
    let file = AblationFile::load_with(path, &opts.overrides)?;
    let args = opts;
    let root = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&file.name));
    let seeds = file.run_seeds();
    if let Some(v) = &args.variant
        && !file.entries.iter().any(|e| &e.name == v || &e.slug == v)
    {
        bail!(
            "{}: no entry named '{v}' (entries: {})",
            path.display(),
            entry_names(&file.entries)
        );
    }
    if let Some(s) = args.seed
        && !seeds.contains(&s)
    {
        bail!(
            "{}: --seed {s} is not one of the file's seeds {seeds:?}",
            path.display()
        );
    }
    // Every (entry, seed) run, with its experiment and directory.
    let mut runs: Vec<Vec<(u64, Experiment, PathBuf, Prior)>> = Vec::new();
    for e in &file.entries {
        let mut per = Vec::new();
        for &seed in &seeds {
            let exp = with_seed(&e.experiment, seed)
                .with_context(|| format!("{}: variant '{}'", path.display(), e.name))?;
            let dir = file.run_dir(&root, e, seed);
            per.push((seed, exp, dir, Prior::Nothing));
        }
        runs.push(per);
    }

    // Check everything before writing anything.
    for (e, per) in file.entries.iter().zip(&mut runs) {
        for (seed, exp, dir, prior) in per {
            *prior = check_run_dir(path, args, e, *seed, exp, dir, &root)?;
        }
    }
    std::fs::create_dir_all(&root).with_context(|| format!("cannot create {}", root.display()))?;
    let source = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    write_atomic(&root.join("ablation.toml"), |w| {
        std::io::Write::write_all(w, &source)
    })?;

    let mut cache = DataCache::default();
    let base = &file.base().experiment;
    outputs.ablation_started(&root, &file, cache.get(base)?)?;

    let mut status = vec![Status::Pending; file.entries.len()];
    let mut report = String::new();
    let total = file.entries.len() * seeds.len();
    let mut k = 0;
    for (i, (e, per)) in file.entries.iter().zip(&runs).enumerate() {
        let mut done = Vec::new();
        let mut failure = None;
        let chosen = args
            .variant
            .as_ref()
            .is_none_or(|v| v == &e.name || v == &e.slug);
        let mut skipped = false;
        for (seed, exp, dir, prior) in per {
            k += 1;
            let finished = *prior == Prior::Finished;
            let wanted = chosen && args.seed.is_none_or(|s| s == *seed);
            if !finished && !wanted {
                skipped = true;
                continue;
            }
            let outcome = match prior {
                Prior::Finished => {
                    info!(
                        "run {k}/{total} '{}' seed {seed}: finished, skipping ({})",
                        e.name,
                        dir.display()
                    );
                    read_finished(*seed, dir)
                }
                Prior::Trained => {
                    info!(
                        "run {k}/{total} '{}' seed {seed}: trained under another [eval]; evaluating its checkpoint again ({})",
                        e.name,
                        dir.display()
                    );
                    (|| {
                        let data = cache.get(exp)?;
                        let _lock = RunLock::acquire(dir)?;
                        let o = evaluate_again(exp, dir, data, outputs)?;
                        Ok(SeedRun {
                            seed: *seed,
                            metrics: o.metrics,
                            history: o.history,
                            predictions: read_predictions(dir)?,
                        })
                    })()
                }
                Prior::Nothing | Prior::Checkpoint => {
                    info!(
                        "run {k}/{total} '{}' seed {seed} → {}",
                        e.name,
                        dir.display()
                    );
                    let resume = *prior == Prior::Checkpoint;
                    (|| {
                        let data = cache.get(exp)?;
                        let _lock = RunLock::acquire(dir)?;
                        prepare_dir(exp, dir)?;
                        let o = run_one(exp, path, data, dir, resume, outputs)?;
                        info!(
                            "'{}' seed {seed}: mean IoU {:.3}",
                            e.name, o.metrics.mean_iou
                        );
                        Ok(SeedRun {
                            seed: *seed,
                            metrics: o.metrics,
                            history: o.history,
                            predictions: read_predictions(dir)?,
                        })
                    })()
                }
            };
            match outcome {
                Ok(r) => done.push(r),
                Err(err) => {
                    let msg = format!("seed {seed}: {err:#}");
                    error!("variant '{}' failed: {msg}", e.name);
                    failure = Some(msg);
                    break;
                }
            }
        }
        status[i] = match failure {
            Some(msg) => Status::Failed(msg),
            None if skipped => Status::Pending,
            None => Status::Finished(Box::new(AblationEntry::new(e, &done))),
        };
        write_ablation_json(&root, &status)?;
        report = outputs.ablation(&root, &file, &status)?;
    }
    let failed = file
        .entries
        .iter()
        .zip(&status)
        .filter(|(_, s)| matches!(s, Status::Failed(_)))
        .map(|(e, _)| e.name.clone())
        .collect();
    Ok(FileOutcome {
        dir: root,
        report,
        failed,
        metrics: None,
    })
}

/// Datasets loaded so far, one per distinct `[data]`.
#[derive(Default)]
struct DataCache {
    sets: Vec<(DataConfig, Vec<CategoryData>)>,
}

impl DataCache {
    fn get(&mut self, exp: &Experiment) -> Result<&[CategoryData]> {
        let i = match self.sets.iter().position(|(d, _)| *d == exp.data) {
            Some(i) => i,
            None => {
                ensure_dataset(exp)?;
                self.sets.push((exp.data.clone(), load(exp)?));
                self.sets.len() - 1
            }
        };
        Ok(&self.sets[i].1)
    }
}

/// `exp` with its training seed replaced (through its resolved TOML, so that the copy is
/// validated like a file).
fn with_seed(exp: &Experiment, seed: u64) -> Result<Experiment> {
    let mut table: toml::Table = toml::from_str(&exp.to_toml()?)?;
    table.insert("seed".into(), toml::Value::Integer(seed as i64));
    let copy: Experiment = toml::from_str(&toml::to_string(&table)?)?;
    copy.validate().map_err(|e| anyhow!(e))?;
    Ok(copy)
}

/// What an entry's run directory already holds, and so what this invocation does with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Prior {
    /// Nothing (or not resuming): train from step 0.
    Nothing,
    /// A checkpoint of this training configuration: continue training, then evaluate.
    Checkpoint,
    /// A finished run of this configuration: skip it.
    Finished,
    /// A finished run of this training configuration that was evaluated under other `[eval]`
    /// settings: evaluate its checkpoint again, without retraining.
    Trained,
}

/// Refuses to run over a run directory that holds results, unless resuming with the same
/// training configuration ([`Experiment::training_table`]); says what the directory holds.
fn check_run_dir(
    path: &Path,
    args: &RunOptions,
    e: &Variant,
    seed: u64,
    exp: &Experiment,
    dir: &Path,
    root: &Path,
) -> Result<Prior> {
    let done = dir.join("metrics.json").is_file();
    let ckpt = checkpoint::latest(&dir.join("checkpoints"))?;
    if !done && ckpt.is_none() {
        return Ok(Prior::Nothing);
    }
    if !args.resume {
        bail!(
            "{} already holds variant '{}' seed {seed} ({}); pass --resume to continue the ablation (finished runs are skipped) or --out DIR to start a new one",
            root.display(),
            e.name,
            if done {
                "finished".to_string()
            } else {
                format!("checkpoint at step {}", ckpt.as_ref().map_or(0, |c| c.step))
            }
        );
    }
    let config = dir.join("config.toml");
    let same_eval = if config.is_file() {
        let old = load_experiment(&config).with_context(|| {
            format!(
                "{}: variant '{}' seed {seed}: cannot read the recorded configuration",
                path.display(),
                e.name
            )
        })?;
        if old.training_table()? != exp.training_table()? {
            bail!(
                "{}: variant '{}' was trained with a different configuration ({}); restore the file, remove {} to rerun it, or pass --out DIR",
                path.display(),
                e.name,
                config.display(),
                dir.display()
            );
        }
        old.eval_table()? == exp.eval_table()?
    } else {
        true
    };
    Ok(match (done, same_eval) {
        (true, true) => Prior::Finished,
        (true, false) => Prior::Trained,
        (false, _) => Prior::Checkpoint,
    })
}

/// Evaluates the finished run in `dir` again under `exp`'s `[eval]` (its training configuration
/// is `exp`'s, checked by [`check_run_dir`]); `config.toml` is rewritten only after the new
/// `metrics.json` is, so that a run killed in between is evaluated again on the next resume.
fn evaluate_again(
    exp: &Experiment,
    dir: &Path,
    data: &[CategoryData],
    outputs: &dyn Outputs,
) -> Result<RunOutcome> {
    let mut rd = RunDir::open(dir)?;
    rd.exp = with_seed(exp, exp.seed)?;
    let outcome = rd.evaluate(data, dir, outputs)?;
    prepare_dir(exp, dir)?;
    Ok(outcome)
}

/// A run that finished in an earlier invocation. Its loss history comes from the latest
/// checkpoint or, for a run kept without checkpoints (the light copies under `results/`, see
/// `results/README.md`), from its `history.csv`.
fn read_finished(seed: u64, dir: &Path) -> Result<SeedRun> {
    let path = dir.join("metrics.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let metrics: Metrics =
        serde_json::from_str(&text).map_err(|err| anyhow!("{}: {err}", path.display()))?;
    let history = match checkpoint::latest(&dir.join("checkpoints"))? {
        Some(s) => s.history,
        None => read_history(&dir.join(crate::history::FILE))?
            .into_iter()
            .map(|r| (r.step, r.loss))
            .collect(),
    };
    Ok(SeedRun {
        seed,
        metrics,
        history,
        predictions: read_predictions(dir)?,
    })
}

/// The run's `objects.csv` (none: an empty list, as from runs made before it was written).
fn read_predictions(dir: &Path) -> Result<Vec<PredictionScores>> {
    let path = dir.join("objects.csv");
    if !path.is_file() {
        return Ok(Vec::new());
    }
    read_predictions_csv(&path)
}

/// Writes `ablation.json`: the finished entries, base first.
pub fn write_ablation_json(root: &Path, status: &[Status]) -> Result<()> {
    let json = serde_json::to_string_pretty(&finished(status))?;
    write_atomic(&root.join("ablation.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    Ok(())
}
