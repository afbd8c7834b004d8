//! `experiments export --run RUN_DIR --out model.safetensors`: a run's latest weights as
//! safetensors, for PyTorch, JAX or another FieldProbe run (`train.init_from`).

use std::path::PathBuf;

use anyhow::Result;
use fieldprobe::run_dir::RunDir;

/// Arguments of `export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The run directory (holds `config.toml` and `checkpoints/`).
    #[arg(long)]
    run: PathBuf,
    /// The `.safetensors` file to write (replaced atomically if it exists).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let rd = RunDir::open(&args.run)?;
    let parameters = rd.export_safetensors(&args.out)?;
    println!(
        "{}: {parameters} parameters of {} at step {}",
        args.out.display(),
        rd.dir.display(),
        rd.state.step
    );
    Ok(())
}
