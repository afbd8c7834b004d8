//! Progress of long work with a rate and an ETA: an indicatif bar on a terminal, and — where
//! stderr is not a terminal (CI, `2> log`), where the bar would stay hidden — a `tracing` line
//! every [`LOG_EVERY`], so that logs show progress too. [`CliDisplay`] is how the library's
//! progress (`fieldprobe::progress`) is shown by this binary.

use std::io::Write;
use std::sync::{LazyLock, Mutex};
use std::time::{Duration, Instant};

use fieldprobe::progress::{Bar, Display};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use tracing::info;

/// Every bar of this process (on stderr; hidden where stderr is not a terminal).
static BARS: LazyLock<MultiProgress> = LazyLock::new(MultiProgress::new);

/// stderr for log lines: each write clears the bars, writes, and lets them redraw below, so a log
/// line printed during training does not tear the bar (indicatif's `suspend`). The logger
/// formats a whole line before writing it, so a line is one write.
#[derive(Clone, Copy, Debug, Default)]
pub struct LogWriter;

impl Write for LogWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        BARS.suspend(|| std::io::stderr().write(buf))
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        BARS.suspend(|| std::io::stderr().write_all(buf))
    }

    fn flush(&mut self) -> std::io::Result<()> {
        std::io::stderr().flush()
    }
}

/// Shows the library's progress as [`Progress`] bars; installed by `cli_main`.
#[derive(Clone, Copy, Debug, Default)]
pub struct CliDisplay;

impl Display for CliDisplay {
    fn bar(&self, label: &str, len: usize, position: usize) -> Box<dyn Bar> {
        Box::new(Progress::new(label, len, position))
    }
}

/// How often a hidden bar logs a line.
pub const LOG_EVERY: Duration = Duration::from_secs(30);

/// A bar labelled `label` showing position, rate and ETA.
fn style(label: &str) -> ProgressStyle {
    ProgressStyle::with_template(&format!(
        "{label:<6} [{{bar:30}}] {{pos}}/{{len}} {{msg}} {{per_sec}} eta {{eta}}"
    ))
    .expect("valid template")
    .progress_chars("=> ")
}

/// Progress through `len` units of work (thread-safe).
#[derive(Debug)]
pub struct Progress {
    bar: ProgressBar,
    label: String,
    /// Position when this process started (resumed work does not count towards the rate).
    first: u64,
    start: Instant,
    last_log: Mutex<Instant>,
}

impl Progress {
    /// Starts at `position` of `len`.
    pub fn new(label: &str, len: usize, position: usize) -> Self {
        let bar = BARS.add(ProgressBar::new(len as u64).with_style(style(label)));
        bar.set_position(position as u64);
        // The resumed position is work done before this process: without this the rate counts
        // it as done instantly and the ETA starts far too short.
        bar.reset_eta();
        let now = Instant::now();
        Self {
            bar,
            label: label.into(),
            first: position as u64,
            start: now,
            last_log: Mutex::new(now),
        }
    }

    fn maybe_log(&self) {
        if !self.bar.is_hidden() {
            return;
        }
        let mut last = self.last_log.lock().expect("progress lock");
        if last.elapsed() >= LOG_EVERY {
            *last = Instant::now();
            info!("{}", self.line());
        }
    }

    /// `label pos/len (pct%) msg, rate/s, eta …`.
    fn line(&self) -> String {
        line(
            &self.label,
            self.bar.position(),
            self.bar.length().unwrap_or(0),
            self.first,
            self.start.elapsed(),
            &self.bar.message(),
        )
    }
}

impl Bar for Progress {
    /// Moves to `position` with a message (e.g. the loss).
    fn set(&self, position: usize, message: String) {
        self.bar.set_message(message);
        self.bar.set_position(position as u64);
        self.maybe_log();
    }

    /// Sets the message only.
    fn message(&self, message: String) {
        self.bar.set_message(message);
    }

    /// One more unit done.
    fn inc(&self) {
        self.bar.inc(1);
        self.maybe_log();
    }

    /// Clears the bar and logs the total.
    fn finish(&self) {
        self.bar.finish_and_clear();
        let done = self.bar.position().saturating_sub(self.first);
        info!(
            "{}: {done} done in {:.1} s",
            self.label,
            self.start.elapsed().as_secs_f64()
        );
    }

    /// Leaves the bar as it is (on an error).
    fn abandon(&self) {
        self.bar.abandon();
    }
}

/// The log line of a hidden bar: position, percentage, message, rate since `first`, ETA.
pub fn line(
    label: &str,
    pos: u64,
    len: u64,
    first: u64,
    elapsed: Duration,
    message: &str,
) -> String {
    let rate = pos.saturating_sub(first) as f64 / elapsed.as_secs_f64().max(1e-9);
    let pct = if len > 0 {
        100.0 * pos as f64 / len as f64
    } else {
        100.0
    };
    let eta = if rate > 0.0 {
        let s = (len.saturating_sub(pos) as f64 / rate).round() as u64;
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        "?".into()
    };
    let msg = if message.is_empty() {
        String::new()
    } else {
        format!(" {message}")
    };
    format!("{label} {pos}/{len} ({pct:.0}%){msg}, {rate:.2}/s, eta {eta}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_give_rate_and_eta_from_work_done_here() {
        // Resumed at 100 of 1000; 50 more in 10 s: 5/s, 850 left → 170 s.
        let l = line("train", 150, 1000, 100, Duration::from_secs(10), "loss 0.2");
        assert_eq!(l, "train 150/1000 (15%) loss 0.2, 5.00/s, eta 2m50s");
        assert!(line("eval", 0, 10, 0, Duration::from_secs(1), "").ends_with("eta ?"));
    }
}
