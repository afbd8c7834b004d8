//! `experiments eval --run RUN_DIR [--data DIR]`: recomputes a run's metrics and pictures from its
//! latest checkpoint — after changing the evaluation code, or on another dataset.

use std::path::PathBuf;

use anyhow::Result;
use fieldprobe::loader::{ensure_dataset, load};
use fieldprobe::run_dir::RunDir;

/// Arguments of `eval`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The run directory (holds `config.toml` and `checkpoints/`).
    #[arg(long)]
    run: PathBuf,
    /// Evaluate on this dataset instead of the run's (same layouts as `[data] dir`); the outputs
    /// then go to `RUN_DIR/eval-<name of DIR>/`, so the run's own are kept.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Write the outputs here instead.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let mut rd = RunDir::open(&args.run)?;
    let out = match (&args.out, &args.data) {
        (Some(o), _) => o.clone(),
        (None, Some(d)) => {
            let name = d
                .file_name()
                .map_or("data".into(), |n| n.to_string_lossy().into_owned());
            rd.dir.join(format!("eval-{name}"))
        }
        (None, None) => rd.dir.clone(),
    };
    if let Some(d) = &args.data {
        anyhow::ensure!(d.is_dir(), "--data {}: no such directory", d.display());
        rd.exp.data.dir = d.clone();
        rd.exp.data.generate = None;
    }
    std::fs::create_dir_all(&out)?;
    ensure_dataset(&rd.exp)?;
    let data = load(&rd.exp)?;
    let outputs = crate::run::ReportOutputs::default();
    let outcome = rd.evaluate(&data, &out, &outputs)?;
    println!("{}", outcome.report);
    println!("outputs: {}", out.display());
    Ok(())
}
