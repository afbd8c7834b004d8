//! The FieldProbe command line. The pipeline (experiment files, data, training, evaluation,
//! run directories, ablations) is the `fieldprobe` library; this crate parses commands, shows
//! progress, and renders reports and pictures (`report`, `gallery`, `charts`, `plot`, `pictures`,
//! `ablation`, `contact_sheet`) through the library's `Outputs` and `progress` hooks.
//!
//! ```text
//! experiments FILE.toml [--out DIR] [--resume]     train and evaluate an experiment (with
//!                                                  [[variants]]: an ablation, see `ablation`)
//! experiments bench FILE.toml [--steps N]          time training steps
//! experiments list                                 registered components with example TOML
//! experiments make-dataset --out DIR [...]         procedural or .obj meshes → published layout
//! experiments check-dataset --data DIR             do silhouettes, cameras and voxels agree?
//! experiments eval --run DIR [--data DIR]          recompute a run's metrics and pictures
//! experiments reconstruct --run DIR --image IMG.png --out mesh.obj   a mesh from a picture
//! experiments export --run DIR --out model.safetensors                the weights as safetensors
//! ```
//!
//! Logs go through `tracing` (see [`logging`]; `-v`, `-q` or `FIELDPROBE_LOG=debug`).

pub mod ablation;
pub mod bench;
pub mod charts;
pub mod check_dataset;
pub mod contact_sheet;
pub mod eval;
pub mod export;
pub mod gallery;
pub mod list;
pub mod logging;
pub mod make_dataset;
pub mod pictures;
pub mod plot;
pub mod progress;
pub mod reconstruct;
pub mod report;
pub mod run;

use clap::{Parser, Subcommand};

// The shipped plugins are linked through the library (typetag and the component registry only
// see crates that are linked).
use fieldprobe as _;

/// The command line.
#[derive(Parser, Debug)]
#[command(
    name = "experiments",
    version,
    about = "FieldProbe: implicit surfaces from silhouettes"
)]
#[command(args_conflicts_with_subcommands = true, arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: Option<run::RunArgs>,
    /// More log lines: -v debug, -vv trace (FieldProbe's crates; burn and wgpu stay at warn).
    /// With a subcommand, put it after the subcommand's name (`experiments list -q`).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    /// Warnings and errors only, and no progress bars.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Train and evaluate an experiment file (the same as `experiments FILE.toml`).
    Run(run::RunArgs),
    /// Time training steps of an experiment on its backend.
    Bench(bench::BenchArgs),
    /// List the registered representations, samplers, aggregators and regularizers with example
    /// TOML.
    List,
    /// Render meshes (procedural or .obj) into a dataset in Kato's npz layout (or DVR's).
    MakeDataset(make_dataset::Args),
    /// Load a dataset (ours or the published files) and report per category how its silhouettes,
    /// cameras and voxels agree (visual hull vs voxels).
    CheckDataset(check_dataset::Args),
    /// Recompute a finished run's metrics, gallery and report from its latest checkpoint
    /// (optionally on another dataset with --data).
    Eval(eval::Args),
    /// Reconstruct a mesh (and a turntable PNG) from a picture with a trained run's model.
    Reconstruct(reconstruct::Args),
    /// Write a run's latest weights as safetensors (tensor names are module paths; the header
    /// holds the run's [model] table). `train.init_from` reads such a file back.
    Export(export::Args),
}

/// Runs the command line on the process arguments. Call it first thing in `main`.
#[allow(unsafe_code)]
pub fn cli_main() -> anyhow::Result<()> {
    // burn materializes a loaded optimizer state on its default device before moving it to the
    // parameters' device; without this the default is wgpu, which would start a GPU runtime just
    // to resume a CPU run. SAFETY: called first in `main`, before any other thread exists.
    if std::env::var_os("BURN_DEVICE").is_none() {
        unsafe { std::env::set_var("BURN_DEVICE", "flex") };
    }
    // Mesa's Vulkan device_select layer prints a Wayland error at every adapter probe on a
    // headless machine; it has no display to match there (see the function's docs).
    // SAFETY: as above.
    if fieldprobe_backends::device_select_is_noise(|v| std::env::var(v).ok()) {
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    let cli = Cli::parse();
    logging::init(logging::level_of(cli.verbose, cli.quiet));
    if !cli.quiet {
        fieldprobe::progress::set_display(Box::new(progress::CliDisplay));
    }
    match (cli.command, cli.run) {
        (Some(Command::Run(args)), _) | (None, Some(args)) => run::run(args),
        (Some(Command::Bench(args)), _) => bench::run(args),
        (Some(Command::List), _) => {
            list::run();
            Ok(())
        }
        (Some(Command::MakeDataset(args)), _) => make_dataset::run(args),
        (Some(Command::CheckDataset(args)), _) => check_dataset::run(args),
        (Some(Command::Eval(args)), _) => eval::run(args),
        (Some(Command::Reconstruct(args)), _) => reconstruct::run(args),
        (Some(Command::Export(args)), _) => export::run(args),
        (None, None) => {
            use clap::CommandFactory;
            Cli::command().print_help()?;
            Ok(())
        }
    }
}
