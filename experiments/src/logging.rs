//! Logs through `tracing`: a small subscriber that prints events as
//! `elapsed LEVEL message key=value…` on stderr.
//!
//! Why not `tracing-subscriber`'s `fmt`: burn already links `tracing-subscriber` with only its
//! `std` feature, and turning on `fmt` changes that crate's features and with them the build hash
//! of all of burn beneath it — a 25-minute rebuild for a log formatter. This one is enough for a
//! command line.
//!
//! The level comes from `FIELDPROBE_LOG` (`error`, `warn`, `info` — the default —, `debug`,
//! `trace`) and applies to FieldProbe's own crates; other crates (burn, cubecl, wgpu) log only
//! warnings and errors.

use std::fmt::Write as _;
use std::io::Write as _;
use std::time::Instant;

use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Level, Metadata, Subscriber};

/// The subscriber (see the module docs).
#[derive(Debug)]
pub struct Logger {
    level: Level,
    start: Instant,
}

/// Crates whose `info`/`debug` events are shown.
const OWN: [&str; 3] = ["experiments", "fieldprobe", "custom_sampler"];

impl Logger {
    /// A logger at `level` for FieldProbe's crates.
    pub fn new(level: Level) -> Self {
        Self {
            level,
            start: Instant::now(),
        }
    }

    /// The level `FIELDPROBE_LOG` names, else `info`; an unknown name is reported and ignored.
    pub fn level_from_env() -> Level {
        match std::env::var("FIELDPROBE_LOG") {
            Ok(v) => v.trim().parse().unwrap_or_else(|_| {
                eprintln!("FIELDPROBE_LOG='{v}' is not a level (error, warn, info, debug, trace); using info");
                Level::INFO
            }),
            Err(_) => Level::INFO,
        }
    }
}

/// Installs the logger as the global default (once; later calls do nothing).
pub fn init() {
    let _ = tracing::subscriber::set_global_default(Logger::new(Logger::level_from_env()));
}

/// Collects an event's fields: `message` first, then `key=value`.
#[derive(Default)]
struct Line {
    message: String,
    fields: String,
}

impl Visit for Line {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.message.push_str(value);
        } else {
            let _ = write!(self.fields, " {}={}", field.name(), value);
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.message, "{value:?}");
        } else {
            let _ = write!(self.fields, " {}={:?}", field.name(), value);
        }
    }
}

impl Subscriber for Logger {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        let own = OWN.iter().any(|c| metadata.target().starts_with(c));
        let max = if own { self.level } else { Level::WARN };
        // In tracing, "more verbose" compares greater.
        *metadata.level() <= max
    }

    fn new_span(&self, _span: &Attributes<'_>) -> Id {
        Id::from_u64(1)
    }

    fn record(&self, _span: &Id, _values: &Record<'_>) {}

    fn record_follows_from(&self, _span: &Id, _follows: &Id) {}

    fn event(&self, event: &Event<'_>) {
        let mut line = Line::default();
        event.record(&mut line);
        let meta = event.metadata();
        let level = match *meta.level() {
            Level::INFO => String::new(),
            l => format!("{l} "),
        };
        let t = self.start.elapsed().as_secs_f64();
        let _ = writeln!(
            std::io::stderr().lock(),
            "[{t:7.1}s] {level}{}{}",
            line.message,
            line.fields
        );
    }

    fn enter(&self, _span: &Id) {}

    fn exit(&self, _span: &Id) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_crates_log_at_the_level_others_only_warn() {
        let logger = Logger::new(Level::INFO);
        let dispatch = tracing::Dispatch::new(logger);
        tracing::dispatcher::with_default(&dispatch, || {
            // This test's target is `experiments::logging::tests`: an own crate.
            assert!(tracing::enabled!(Level::INFO));
            assert!(!tracing::enabled!(Level::DEBUG));
            assert!(tracing::enabled!(target: "wgpu_core", Level::WARN));
            assert!(!tracing::enabled!(target: "wgpu_core", Level::INFO));
        });
    }
}
