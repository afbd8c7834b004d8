//! `history.csv`: the training curve as numbers, written as training goes, so that it can be
//! re-plotted with any tool (pandas, gnuplot, a spreadsheet) while a run is still going and
//! after it was killed.
//!
//! One row per logged interval (the trainer's `history`, a hundred per run): the step at its end,
//! the interval's mean loss and its terms, the learning rate, the interval's speed and the wall
//! time since the run started (across resumes). Rows are appended and flushed one at a time;
//! resuming keeps the rows up to the checkpoint's step (those after it are trained again) and
//! drops a row that a kill cut short.

use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::train::Trainer;
use serde::{Deserialize, Serialize};

/// The file name in a run directory.
pub const FILE: &str = "history.csv";

/// One row of `history.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HistoryRow {
    /// The last step of the interval (1-based: steps done).
    pub step: usize,
    /// Mean total loss over the interval.
    pub loss: f32,
    /// Mean silhouette term.
    pub silhouette_loss: f32,
    /// Mean sum of the regularizer terms (0 without regularizers).
    pub regularizer_loss: f32,
    /// Learning rate of the interval's last step.
    pub lr: f64,
    /// Steps per second over the interval (this process's wall clock).
    pub steps_per_second: f64,
    /// Seconds since the run first started, summed over resumed processes.
    pub wall_seconds: f64,
}

/// Appends [`HistoryRow`]s to a run's `history.csv` as the trainer logs intervals.
#[derive(Debug)]
pub struct HistoryLog {
    path: PathBuf,
    writer: csv::Writer<File>,
    /// How many of the trainer's logged intervals are already written.
    written: usize,
    /// The step and time of the last written row (this process).
    last: (usize, Instant),
    /// Wall seconds of earlier processes of this run.
    offset: f64,
    started: Instant,
}

impl HistoryLog {
    /// Opens `dir/history.csv` for a trainer at `trainer.step`: a new file at step 0, else the
    /// existing rows up to that step kept (rewritten atomically) and new ones appended.
    pub fn open(dir: &Path, trainer: &Trainer) -> Result<Self> {
        let path = dir.join(FILE);
        let kept = if trainer.step == 0 {
            Vec::new()
        } else {
            read_history(&path)?
                .into_iter()
                .filter(|r| r.step <= trainer.step)
                .collect()
        };
        write_atomic(&path, |w| {
            let mut csv = csv::WriterBuilder::new().has_headers(false).from_writer(w);
            csv.write_record(HEADER)?;
            for r in &kept {
                csv.serialize(r)?;
            }
            csv.flush()
        })
        .with_context(|| format!("cannot write {}", path.display()))?;
        let file = OpenOptions::new()
            .append(true)
            .open(&path)
            .with_context(|| format!("cannot append to {}", path.display()))?;
        let now = Instant::now();
        Ok(Self {
            path,
            writer: csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(file),
            written: trainer.history.len(),
            last: (trainer.step, now),
            offset: kept.last().map_or(0.0, |r| r.wall_seconds),
            started: now,
        })
    }

    /// Writes the intervals the trainer logged since the last call; `lr` is the learning rate
    /// of its last step.
    pub fn record(&mut self, trainer: &Trainer, lr: f64) -> Result<()> {
        while self.written < trainer.history.len() {
            let (step, loss) = trainer.history[self.written];
            let (_, sil, reg) = trainer
                .terms
                .get(self.written)
                .copied()
                .unwrap_or((step, loss, 0.0));
            let now = Instant::now();
            let secs = now.duration_since(self.last.1).as_secs_f64();
            let row = HistoryRow {
                step,
                loss,
                silhouette_loss: sil,
                regularizer_loss: reg,
                lr,
                steps_per_second: if secs > 0.0 {
                    (step - self.last.0) as f64 / secs
                } else {
                    0.0
                },
                wall_seconds: self.offset + now.duration_since(self.started).as_secs_f64(),
            };
            self.writer
                .serialize(&row)
                .and_then(|()| self.writer.flush().map_err(csv::Error::from))
                .with_context(|| format!("cannot append to {}", self.path.display()))?;
            self.written += 1;
            self.last = (step, now);
        }
        Ok(())
    }
}

/// The column names, in [`HistoryRow`]'s field order.
const HEADER: [&str; 7] = [
    "step",
    "loss",
    "silhouette_loss",
    "regularizer_loss",
    "lr",
    "steps_per_second",
    "wall_seconds",
];

/// The rows of a `history.csv`, skipping any that do not parse (a row a kill cut short); no file
/// is no rows.
pub fn read_history(path: &Path) -> Result<Vec<HistoryRow>> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    Ok(reader.deserialize().filter_map(|r| r.ok()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::prelude::Device;
    use fieldprobe_models::PerObjectConfig;

    fn trainer_at(step: usize) -> Trainer {
        let mut t = Trainer::new(&PerObjectConfig::default(), &Device::flex(), 0);
        t.step = step;
        for s in 1..=step {
            t.history.push((s, 1.0 / s as f32));
            t.terms.push((s, 0.9 / s as f32, 0.1 / s as f32));
        }
        t
    }

    #[test]
    fn rows_are_appended_as_training_goes_and_a_resume_keeps_those_up_to_its_step() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE);
        let mut log = HistoryLog::open(dir.path(), &trainer_at(0)).unwrap();
        for s in 1..=4 {
            log.record(&trainer_at(s), 1e-3).unwrap();
            // Each row is on disk as soon as it is logged.
            assert_eq!(read_history(&path).unwrap().len(), s);
        }
        let rows = read_history(&path).unwrap();
        assert_eq!(
            rows.iter().map(|r| r.step).collect::<Vec<_>>(),
            [1, 2, 3, 4]
        );
        assert_eq!((rows[1].loss, rows[1].silhouette_loss), (0.5, 0.45));
        assert!((rows[1].regularizer_loss - 0.05).abs() < 1e-7);
        assert!(
            rows.windows(2)
                .all(|w| w[0].wall_seconds <= w[1].wall_seconds)
        );
        drop(log);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("step,loss,silhouette_loss,regularizer_loss,lr,"),
            "{text}"
        );
        // A kill mid-row, then a resume from the checkpoint of step 2: rows 3, 4 and the torn
        // one go, new rows follow.
        std::fs::write(&path, format!("{text}5,0.2,0.1")).unwrap();
        let resumed = trainer_at(2);
        let mut log = HistoryLog::open(dir.path(), &resumed).unwrap();
        assert_eq!(read_history(&path).unwrap().len(), 2);
        log.record(&trainer_at(3), 1e-3).unwrap();
        let rows = read_history(&path).unwrap();
        assert_eq!(rows.iter().map(|r| r.step).collect::<Vec<_>>(), [1, 2, 3]);
        assert!(
            rows[2].wall_seconds >= rows[1].wall_seconds,
            "wall time goes on"
        );
        // A fresh run (step 0) starts a new file.
        HistoryLog::open(dir.path(), &trainer_at(0)).unwrap();
        assert!(read_history(&path).unwrap().is_empty());
    }
}
