//! Running an experiment file from start to end: [`run_file`] (one run, or an ablation for a
//! file with `[[variants]]`), [`run_shrunk`] (a shipped file shrunk to seconds, for plugin
//! tests) and [`main_with_linked_plugins`] (a `main` for binaries that link their own plugins).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::experiment::load_experiment_with;
use crate::loader::{ensure_dataset, load};
use crate::lock::RunLock;
use crate::outputs::{NoOutputs, Outputs};
use crate::overrides::Overrides;
use crate::run::{FileOutcome, RunOptions, check_can_start, prepare_dir, run_one};
use crate::variants::has_variants;

/// Runs an experiment file: one run, or an ablation if it has `[[variants]]`.
pub fn run_file(file: &Path, opts: &RunOptions, outputs: &dyn Outputs) -> Result<FileOutcome> {
    if has_variants(file) {
        return crate::ablation::run(file, opts, outputs);
    }
    if opts.variant.is_some() {
        bail!(
            "{}: --variant applies to ablation files (with [[variants]]) only",
            file.display()
        );
    }
    let mut exp = load_experiment_with(file, &opts.overrides)?;
    if let Some(seed) = opts.seed {
        exp.seed = seed;
    }
    let dir = opts
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&exp.name));
    let _lock = RunLock::acquire(&dir)?;
    check_can_start(&dir, opts.resume)?;
    prepare_dir(&exp, &dir)?;

    ensure_dataset(&exp)?;
    let data = load(&exp)?;
    let outcome = run_one(&exp, file, &data, &dir, opts.resume, outputs)?;
    Ok(FileOutcome {
        dir,
        report: outcome.report,
        failed: Vec::new(),
        metrics: Some(outcome.metrics),
    })
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
    let opts = RunOptions {
        out: Some(out.clone()),
        ..RunOptions::default()
    };
    run_file(&file, &opts, &NoOutputs)?;
    Ok(out)
}

/// The arguments [`main_with_linked_plugins`] takes.
const USAGE: &str = "FILE.toml [--out DIR] [--resume] [--set KEY=VALUE]...";

/// A minimal `main` for a binary that links its own plugins: `BIN FILE.toml [--out DIR]
/// [--resume] [--set KEY=VALUE]` runs the file with [`NoOutputs`] (numbers and checkpoints, no report or
/// pictures: those are the `experiments` CLI's) and prints where `metrics.json` went and the
/// mean IoU; `BIN list` prints the linked components. Link the plugin crate
/// (`use my_plugin as _;`) in that binary first.
pub fn main_with_linked_plugins() -> Result<()> {
    if std::env::args().nth(1).as_deref() == Some("list") {
        print!("{}", fieldprobe_core::registry::catalogue());
        return Ok(());
    }
    let mut args = std::env::args().skip(1);
    let mut file = None;
    let mut opts = RunOptions::default();
    let mut sets = Vec::new();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--resume" => opts.resume = true,
            "--out" => {
                let dir = args.next().context("--out needs a directory")?;
                opts.out = Some(dir.into());
            }
            "--set" => sets.push(args.next().context("--set needs KEY=VALUE")?),
            _ if file.is_none() && !a.starts_with("--") => file = Some(PathBuf::from(a)),
            _ => bail!("unexpected argument '{a}'; usage: {USAGE}"),
        }
    }
    opts.overrides = Overrides::parse(&sets)?;
    let file = file.with_context(|| format!("usage: {USAGE}"))?;
    let done = run_file(&file, &opts, &NoOutputs)?;
    if let Some(m) = &done.metrics {
        println!("mean IoU {:.3} (max-pool protocol)", m.mean_iou);
    }
    println!("run directory: {}", done.dir.display());
    Ok(())
}
