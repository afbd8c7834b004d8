//! `experiments bench FILE.toml [--steps N] [--variant NAME]`: times training steps of an
//! experiment (or of one entry of an ablation file, the base by default) on its configured
//! backend and prints a table.
//!
//! Each step is timed in parts, all synchronized: the CPU probe (sampling + binned assignment,
//! on the prefetch worker unless `train.prefetch = 0`), the time the training loop waited for it,
//! and the device work (forward, backward, Adam; `device.sync()` before the clock is read). A
//! step is the wait plus the device work. Reported: median step time, the share of it spent
//! waiting for probes, decoder points evaluated per second (points the rays read per step /
//! device time), ray–anchor pairs decided per second (rays × anchors per step / probe time: the
//! pairs the all-pairs reference would test) and pairs assigned per step.
//!
//! With regularizers, the same steps (same seed, same batches) are timed a second time without
//! them, in the same process, and a second table gives the regularizers' share of the mean step
//! (`1 − without/with`; the mean, since a term evaluated every k steps is in only some steps).
//! It also gives the decoder's achieved GFLOP/s on the steps without
//! regularizers, `6 · MACs per point · anchors / device time`. The factor 6 counts the forward
//! pass (2 FLOPs per multiply-add) and the backward pass (twice that). The device time also
//! holds the aggregation, the optimizer and, for image models, the encoder, so this is a lower
//! bound. Beside it is a ceiling: the GFLOP/s of a plain `[4096, 256] × [256, 256]` matrix
//! product on the same device, timed in the same run.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use burn::prelude::*;
use fieldprobe_core::object::ObjectViews;
use fieldprobe_core::train::{Components, StepStats, TrainRun, TrainSpec, Trainer};

use fieldprobe::experiment::{Experiment, load_experiment_with};
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
    let comps = || {
        exp.components_on(&selected.device)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.file.display()))
    };
    let spec = exp.probe.spec;
    let devices = selected.devices(exp.train.devices)?;
    let with = time_steps(&exp, &comps()?, &objects, &devices, &args)?;
    let (points, pairs) = (with.last.points, with.last.pairs);
    let decided = with.last.rays as u64 * spec.anchors as u64;
    let (st, pr, dv) = (with.step, with.probe, with.device);
    println!(
        "| experiment | backend | batch | points read/object | rays/step | prefetch | median step (s) | probe (s) | waiting for probes | device (s) | decoder points/s | pairs decided/s | pairs assigned/step |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    println!(
        "| {} | {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.1} % | {:.4} | {:.3e} | {} | {} |",
        exp.name,
        selected.description,
        exp.train.batch,
        points / exp.train.batch.max(1),
        with.last.rays,
        exp.train.prefetch,
        st,
        pr,
        100.0 * with.wait / with.mean,
        dv,
        points as f64 / dv,
        // Dense marching decides no ray–anchor pairs: every point is on its ray.
        if exp.probe.march.is_some() {
            "–".to_string()
        } else {
            format!("{:.3e}", decided as f64 / pr)
        },
        pairs
    );
    let plain = if exp.regularizers.is_empty() {
        with
    } else {
        let mut bare = comps()?;
        bare.regularizers.clear();
        time_steps(&exp, &bare, &objects, &devices, &args)?
    };
    let gflops = exp
        .model
        .decoder_macs_per_point()
        .map(|macs| 6.0 * macs as f64 * plain.last.points as f64 / plain.device / 1e9);
    let ceiling = matmul_gflops(&selected.device);
    println!();
    println!(
        "| median step (s) | mean step (s) | mean without regularizers (s) | regularizers' share | decoder GFLOP/s (≥) | matmul GFLOP/s |"
    );
    println!("|---|---|---|---|---|---|");
    println!(
        "| {:.4} | {:.4} | {:.4} | {:.0} % | {} | {:.1} |",
        with.step,
        with.mean,
        plain.mean,
        100.0 * (1.0 - plain.mean / with.mean).max(0.0),
        gflops.map_or("–".to_string(), |g| format!("{g:.1}")),
        ceiling
    );
    Ok(())
}

/// The timed steps: median and mean step, mean wait for probes, median probe and device time,
/// and the last step's counts.
#[derive(Clone, Copy)]
struct Timings {
    step: f64,
    /// Mean step: a term evaluated every k steps makes the median misleading.
    mean: f64,
    /// Mean time the loop waited for a step's probes.
    wait: f64,
    probe: f64,
    device: f64,
    last: StepStats,
}

/// Times `args.steps` training steps (after `args.warmup` untimed ones) of a fresh model with
/// the experiment's seed, through the run's own loop (on `train.devices` devices).
fn time_steps(
    exp: &Experiment,
    comps: &Components,
    objects: &[ObjectViews],
    devices: &[Device],
    args: &BenchArgs,
) -> Result<Timings> {
    let mut trainer =
        Trainer::new(exp.model.as_ref(), &devices[0], exp.seed).data_parallel(devices);
    let schedule = TrainSpec {
        steps: args.warmup + args.steps,
        checkpoint_every: 0,
        ..exp.train.clone()
    };
    let run = TrainRun {
        objects,
        comps,
        probe: &exp.probe.spec,
        schedule: &schedule,
        uses_image: exp.model.uses_image(),
        seed: exp.seed,
    };
    let (mut step_s, mut probe_s, mut device_s) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = StepStats::default();
    let mut wait = 0.0;
    let mut time = |_: &Trainer, s: &StepStats| {
        if s.step > args.warmup {
            probe_s.push(s.probe_seconds);
            device_s.push(s.device_seconds);
            step_s.push(s.wait_seconds + s.device_seconds);
            wait += s.wait_seconds;
            last = *s;
        }
    };
    trainer.fit(&run, None, &mut time)?;
    Ok(Timings {
        wait: wait / step_s.len() as f64,
        mean: step_s.iter().sum::<f64>() / step_s.len() as f64,
        step: median(step_s),
        probe: median(probe_s),
        device: median(device_s),
        last,
    })
}

/// GFLOP/s of a `[4096, 256] × [256, 256]` product on `device` (median of 9 after a warm-up).
fn matmul_gflops(device: &Device) -> f64 {
    let (m, k, n) = (4096, 256, 256);
    let a = Tensor::<2>::random([m, k], burn::tensor::Distribution::Default, device);
    let b = Tensor::<2>::random([k, n], burn::tensor::Distribution::Default, device);
    let mut times = Vec::new();
    for i in 0..10 {
        let t0 = Instant::now();
        let c = a.clone().matmul(b.clone());
        let _ = c.into_data();
        if i > 0 {
            times.push(t0.elapsed().as_secs_f64());
        }
    }
    2.0 * (m * k * n) as f64 / median(times) / 1e9
}
