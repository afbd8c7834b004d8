//! The training loop: the one that `experiments` runs, `bench` times and the tests drive.
//!
//! [`Trainer::fit`] takes steps until the schedule's end, logs the loss and its terms per interval
//! into the trainer (what checkpoints, curves and reports read), writes checkpoints when asked,
//! and calls a [`TrainHooks`] after every step for what the caller wants to see (a progress bar,
//! timings, the losses of a test).

use std::path::Path;
use std::time::Instant;

use super::{
    Components, StepStats, TrainError, TrainSpec, Trainer, UploadedStep, checkpoint, prepare_step,
};
use crate::object::ObjectViews;
use crate::probe::ProbeSpec;

/// What a training run reads besides the trainer.
#[derive(Clone, Copy, Debug)]
pub struct TrainRun<'a> {
    /// The training pool (all categories).
    pub objects: &'a [ObjectViews],
    pub comps: &'a Components,
    pub probe: &'a ProbeSpec,
    /// Steps, batch, learning-rate schedule and checkpoint interval.
    pub schedule: &'a TrainSpec,
    /// Whether the model reads input images (single-view) or not (per-object fits).
    pub uses_image: bool,
    /// Seeds every step's sampling (with the step index), so a resumed run continues exactly.
    pub seed: u64,
}

/// Called by [`Trainer::fit`] after every step. Any `FnMut(&Trainer, &StepStats)` is one.
pub trait TrainHooks {
    fn after_step(&mut self, trainer: &Trainer, stats: &StepStats);
}

impl<F: FnMut(&Trainer, &StepStats)> TrainHooks for F {
    fn after_step(&mut self, trainer: &Trainer, stats: &StepStats) {
        self(trainer, stats)
    }
}

/// How many steps one logged interval spans: a hundred points per run.
fn log_interval(steps: usize) -> usize {
    (steps / 100).max(1)
}

impl Trainer {
    /// Trains from the current step to `run.schedule.steps`.
    ///
    /// Every [`log_interval`] steps (and at the last) the interval's mean loss goes to
    /// `history` and its silhouette and regularizer terms to `terms`. With `checkpoints`, a
    /// checkpoint is written there every `checkpoint_every` steps and at the end. A non-finite
    /// loss stops training before the optimizer touches the weights, the last checkpoint kept.
    ///
    /// With `schedule.prefetch = k > 0`, a worker thread prepares the probes of the next steps
    /// and uploads them to the device(s) (`k` waiting in a bounded channel, one more in
    /// preparation) while this thread runs the device work, so the device waits for the CPU only
    /// when probing is slower than a step. A step's probes depend only on `(seed, step)`, so the
    /// batches, and with them the weights, are the ones the serial loop makes. When training stops early, the worker's next send
    /// fails and it ends.
    pub fn fit(
        &mut self,
        run: &TrainRun<'_>,
        checkpoints: Option<&Path>,
        hooks: &mut dyn TrainHooks,
    ) -> Result<(), TrainError> {
        let (first, steps) = (self.step, run.schedule.steps);
        let prepare = |step: usize| {
            prepare_step(
                run.objects,
                run.comps,
                run.probe,
                run.schedule.batch,
                run.uses_image,
                run.seed,
                step,
            )
        };
        let devices = self.step_devices();
        if run.schedule.prefetch == 0 {
            return self.fit_with(run, checkpoints, hooks, |step| {
                prepare(step).upload(run.comps, &devices)
            });
        }
        std::thread::scope(|scope| {
            let (tx, rx) = std::sync::mpsc::sync_channel(run.schedule.prefetch);
            let devices = &devices;
            scope.spawn(move || {
                for step in first..steps {
                    if tx.send(prepare(step).upload(run.comps, devices)).is_err() {
                        break;
                    }
                }
            });
            self.fit_with(run, checkpoints, hooks, move |step| {
                let uploaded: UploadedStep = rx
                    .recv()
                    .expect("the prefetch worker prepares every step, in order");
                assert_eq!(uploaded.step, step, "prefetched steps arrive in order");
                uploaded
            })
        })
    }

    /// The loop of [`fit`](Self::fit), its batches from `next(step)`.
    fn fit_with(
        &mut self,
        run: &TrainRun<'_>,
        checkpoints: Option<&Path>,
        hooks: &mut dyn TrainHooks,
        mut next: impl FnMut(usize) -> UploadedStep,
    ) -> Result<(), TrainError> {
        let steps = run.schedule.steps;
        let log_every = log_interval(steps);
        // Sums over the logged interval: total, silhouette, regularizers, steps.
        let mut acc = (0.0f32, 0.0f32, 0.0f32, 0usize);
        while self.step < steps {
            let waiting = Instant::now();
            let uploaded = next(self.step);
            let wait_seconds = waiting.elapsed().as_secs_f64();
            let stats = StepStats {
                wait_seconds,
                ..self.step_uploaded(&uploaded, run.comps, run.schedule.lr_at(self.step))?
            };
            acc = (
                acc.0 + stats.loss,
                acc.1 + stats.silhouette_loss,
                acc.2 + stats.regularizer_loss,
                acc.3 + 1,
            );
            if self.step.is_multiple_of(log_every) || self.step == steps {
                let n = acc.3 as f32;
                self.history.push((self.step, acc.0 / n));
                self.terms.push((self.step, acc.1 / n, acc.2 / n));
                acc = (0.0, 0.0, 0.0, 0);
            }
            hooks.after_step(self, &stats);
            let every = run.schedule.checkpoint_every;
            if let Some(dir) = checkpoints
                && ((every > 0 && self.step.is_multiple_of(every)) || self.step == steps)
            {
                checkpoint::save(self, dir)?;
            }
        }
        Ok(())
    }
}
