//! An ablation's report and pictures (the runner is `fieldprobe::ablation`):
//!
//! ```text
//! runs/<name>/
//!   report.md              the comparison table, ordering vs the paper, pictures
//!   training_curves.png    the loss history of every finished entry (and .svg)
//!   cost_time.png          IoU against training time, one curve per method (and .svg)
//!   cost_points.png        IoU against decoder evaluations (and .svg)
//!   samples.png            rays and anchors of the base's samplers vs a comparison sampler
//! ```

pub mod cost;
mod figures;
mod report;
#[cfg(test)]
mod tests;

pub use figures::*;
pub use report::*;

use std::path::Path;

use anyhow::Result;
use fieldprobe::ablation::entry::Status;
use fieldprobe::data::dataset::write_atomic;
use fieldprobe::variants::AblationFile;

/// Writes `training_curves.png`, the cost charts and `report.md` (last) for the current state; returns the
/// report's text.
pub fn write_report(
    root: &Path,
    file: &AblationFile,
    status: &[Status],
    samples: &SamplesInfo,
) -> Result<String> {
    training_curves(status).write(&root.join("training_curves.png"))?;
    let [time, points] = cost::cost_charts(file, status);
    time.write(&root.join("cost_time.png"))?;
    points.write(&root.join("cost_points.png"))?;
    let report = render_report(file, status, samples);
    write_atomic(&root.join("report.md"), |w| {
        std::io::Write::write_all(w, report.as_bytes())
    })?;
    Ok(report)
}
