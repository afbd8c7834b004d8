//! `experiments bench FILE.toml [--steps N] [--variant NAME]`: times training steps of an
//! experiment (or of one entry of an ablation file, the base by default) on its configured
//! backend and prints a table.
//!
//! Each step is timed in two parts, both synchronized: the CPU probe (sampling + binned
//! assignment) and the device work (forward, backward, Adam; `device.sync()` before the clock is
//! read). Reported: median step time, decoder points evaluated per second (anchors per step /
//! device time), ray–anchor pairs decided per second (rays × anchors per step / probe time: the
//! pairs the all-pairs reference would test) and pairs assigned per step.

use std::path::PathBuf;

use anyhow::{Result, bail};
use fieldprobe_core::train::{StepStats, TrainRun, TrainSpec, Trainer};

use fieldprobe::experiment::load_experiment_with;
use fieldprobe::loader::{ensure_dataset, load};
use fieldprobe::overrides::Overrides;

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    pub file: PathBuf,
    /// Timed steps.
    #[arg(long, default_value_t = 10)]
    pub steps: usize,
    /// Untimed warm-up steps (compilation, autotuning, allocation).
    #[arg(long, default_value_t = 2)]
    pub warmup: usize,
    /// For a file with `[[variants]]`: the variant to time (default: the base).
    #[arg(long)]
    pub variant: Option<String>,
    /// Change a key of the file, e.g. `--set probe.anchors=4096` (repeatable; as for runs).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

pub fn run(args: BenchArgs) -> Result<()> {
    if args.steps == 0 {
        bail!("--steps must be positive");
    }
    let overrides = Overrides::parse(&args.set)?;
    let exp = if fieldprobe::variants::has_variants(&args.file) {
        let file = fieldprobe::variants::AblationFile::load_with(&args.file, &overrides)?;
        let names: Vec<String> = file.entries.iter().map(|e| e.name.clone()).collect();
        let i = match &args.variant {
            None => 0,
            Some(v) => names.iter().position(|n| n == v).ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: no variant '{v}' (have: {})",
                    args.file.display(),
                    names.join(", ")
                )
            })?,
        };
        file.entries
            .into_iter()
            .nth(i)
            .expect("index checked")
            .experiment
    } else {
        if args.variant.is_some() {
            bail!(
                "{}: --variant needs a file with [[variants]]",
                args.file.display()
            );
        }
        load_experiment_with(&args.file, &overrides)?
    };
    ensure_dataset(&exp)?;
    let data = load(&exp)?;
    let objects: Vec<_> = data.iter().flat_map(|c| c.train.iter().cloned()).collect();
    let selected = exp.backend.select()?;
    let comps = exp
        .components()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.file.display()))?;
    let spec = exp.probe.spec;
    let mut trainer = Trainer::new(exp.model.as_ref(), &selected.device, exp.seed);
    // The run's own loop, untimed warm-up steps first; the hook reads each step's timings.
    let schedule = TrainSpec {
        steps: args.warmup + args.steps,
        checkpoint_every: 0,
        ..exp.train.clone()
    };
    let run = TrainRun {
        objects: &objects,
        comps: &comps,
        probe: &spec,
        schedule: &schedule,
        uses_image: exp.model.uses_image(),
        seed: exp.seed,
    };
    let (mut step_s, mut probe_s, mut device_s) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = StepStats::default();
    let mut time = |_: &Trainer, s: &StepStats| {
        if s.step > args.warmup {
            probe_s.push(s.probe_seconds);
            device_s.push(s.device_seconds);
            step_s.push(s.probe_seconds + s.device_seconds);
            last = *s;
        }
    };
    trainer.fit(&run, None, &mut time)?;
    let (points, pairs) = (last.points, last.pairs);
    let decided = last.rays as u64 * spec.anchors as u64;
    let (st, pr, dv) = (median(step_s), median(probe_s), median(device_s));
    println!(
        "| experiment | backend | batch | anchors/object | rays/step | median step (s) | probe (s) | device (s) | decoder points/s | pairs decided/s | pairs assigned/step |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    println!(
        "| {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.4} | {:.3e} | {:.3e} | {} |",
        exp.name,
        selected.description,
        exp.train.batch,
        spec.anchors,
        decided / spec.anchors as u64,
        st,
        pr,
        dv,
        points as f64 / dv,
        decided as f64 / pr,
        pairs
    );
    Ok(())
}
