//! `experiments FILE.toml`: runs an experiment file through the library
//! (`fieldprobe::run_file`), with this crate's reports and pictures as its outputs, and
//! prints the report.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Result, bail};
use fieldprobe::ablation::entry::Status;
use fieldprobe::launch::run_file;
use fieldprobe::loader::CategoryData;
use fieldprobe::outputs::{FinishedRun, Outputs};
use fieldprobe::overrides::Overrides;
use fieldprobe::run::RunOptions;
use fieldprobe::variants::AblationFile;

use crate::ablation::{SamplesInfo, write_report, write_samples};
use crate::charts;

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
    /// Change a key of the file without editing it: a dotted key and a TOML value, e.g.
    /// `--set train.steps=10 --set probe.ray_sampler.type=normal` (repeatable; merged like an
    /// ablation variant; recorded in the run's config.toml).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

pub fn run(args: RunArgs) -> Result<()> {
    let opts = RunOptions {
        out: args.out,
        resume: args.resume,
        variant: args.variant,
        seed: args.seed,
        overrides: Overrides::parse(&args.set)?,
    };
    let done = run_file(&args.file, &opts, &ReportOutputs::default())?;
    println!("{}", done.report);
    let what = match done.metrics {
        Some(_) => "run directory",
        None => "ablation directory",
    };
    println!("{what}: {}", done.dir.display());
    if !done.failed.is_empty() {
        bail!(
            "{}: variant(s) {} failed (see above and {}); fix and rerun with --resume",
            args.file.display(),
            done.failed.join(", "),
            done.dir.join("report.md").display()
        );
    }
    Ok(())
}

/// The CLI's outputs: `report.md`, `gallery.png` and `training_curves.png` per run; per
/// ablation `samples.png`, `training_curves.png` and `report.md`.
#[derive(Debug, Default)]
pub struct ReportOutputs {
    /// What `samples.png` shows, once the ablation has drawn it.
    samples: Mutex<SamplesInfo>,
}

impl Outputs for ReportOutputs {
    fn run(&self, run: &FinishedRun<'_>) -> Result<String> {
        write_run_report(run)
    }

    fn ablation_started(
        &self,
        root: &Path,
        file: &AblationFile,
        base_data: &[CategoryData],
    ) -> Result<()> {
        let info = write_samples(&root.join("samples.png"), file, base_data)?;
        *self.samples.lock().expect("samples lock") = info;
        Ok(())
    }

    fn ablation(&self, root: &Path, file: &AblationFile, status: &[Status]) -> Result<String> {
        let samples = self.samples.lock().expect("samples lock").clone();
        write_report(root, file, status, &samples)
    }
}

/// A run's pictures and `report.md` (written last, linking them); returns the report.
pub fn write_run_report(run: &FinishedRun<'_>) -> Result<String> {
    let gallery = crate::gallery::write(
        run.dir,
        run.model,
        run.aggregator,
        run.data,
        run.meshes,
        &run.exp.eval,
        run.device,
    )?;
    let curves = !run.training.history.is_empty();
    if curves {
        charts::loss_terms(&run.training.history, &run.training.terms)
            .write(&run.dir.join("training_curves.png"))?;
    }
    let report = crate::report::render(run.exp, run.metrics, &gallery, curves);
    fieldprobe::data::dataset::write_atomic(&run.dir.join("report.md"), |w| {
        std::io::Write::write_all(w, report.as_bytes())
    })?;
    Ok(report)
}
