//! Logs through `tracing-subscriber`'s `fmt` layer on stderr, with the `log` bridge on, so that
//! the warnings burn, cubecl and wgpu emit through the `log` crate are shown too.
//!
//! `tracing-subscriber` is already built with `fmt`, `env-filter`, `ansi` and `tracing-log` for
//! burn's own dependencies (`cargo tree -e features -i tracing-subscriber`), so using it here
//! compiles nothing of burn again.
//!
//! Lines go to stderr through [`crate::progress::LogWriter`], which lifts the progress bars for
//! the line and redraws them under it, so a log line never tears a bar.
//!
//! `-v` (debug), `-vv` (trace) and `-q` (warnings only, no bars) set a bare level; otherwise
//! `FIELDPROBE_LOG` sets the filter. A bare level (`error`, `warn`, `info` — the default —,
//! `debug`, `trace`) applies to FieldProbe's own crates, while other crates (burn, cubecl, wgpu)
//! log only warnings and errors; anything else is read as an `EnvFilter` directive list
//! (`warn,fieldprobe_core=trace,wgpu_core=info`).

use tracing::Level;
use tracing_subscriber::EnvFilter;
use tracing_subscriber::fmt::MakeWriter;
use tracing_subscriber::fmt::time::Uptime;
use tracing_subscriber::util::SubscriberInitExt;

/// Crate-name prefixes whose `info`/`debug` events a bare level applies to.
const OWN: [&str; 4] = [
    "experiments",
    "fieldprobe",
    "custom_sampler",
    "custom_model",
];

/// The filter `FIELDPROBE_LOG`'s value (`None`: unset) asks for; an unparsable value is reported
/// and the default used.
pub fn filter(spec: Option<&str>) -> EnvFilter {
    let spec = spec.map(str::trim).filter(|s| !s.is_empty());
    let directives = match spec {
        None => own_at(Level::INFO),
        Some(s) => match s.parse::<Level>() {
            Ok(level) => own_at(level),
            Err(_) => s.to_string(),
        },
    };
    EnvFilter::try_new(&directives).unwrap_or_else(|e| {
        eprintln!("FIELDPROBE_LOG='{directives}' is not a level or filter ({e}); using info");
        EnvFilter::new(own_at(Level::INFO))
    })
}

/// `warn` for everything, `level` for FieldProbe's crates.
fn own_at(level: Level) -> String {
    let level = level.as_str().to_ascii_lowercase();
    let own: Vec<String> = OWN.iter().map(|c| format!("{c}={level}")).collect();
    format!("warn,{}", own.join(","))
}

/// Installs the logger on `writer` as the global default, with the `log` bridge (once; later
/// calls do nothing).
pub fn init_with<W>(writer: W, spec: Option<&str>)
where
    W: for<'a> MakeWriter<'a> + Send + Sync + 'static,
{
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter(spec))
        .with_timer(Uptime::default())
        .with_target(false)
        .with_ansi(false)
        .with_writer(writer)
        .finish()
        .try_init();
}

/// Installs the logger on stderr (above the progress bars) with `level` (from `-v`/`-q`) or,
/// without one, `FIELDPROBE_LOG`'s filter.
pub fn init(level: Option<Level>) {
    let spec = match level {
        Some(l) => Some(l.as_str().to_string()),
        None => std::env::var("FIELDPROBE_LOG").ok(),
    };
    init_with(crate::progress::LogWriter::default, spec.as_deref());
}

/// The level `-v` (counted) and `-q` ask for; `None` when neither is given.
pub fn level_of(verbose: u8, quiet: bool) -> Option<Level> {
    match (quiet, verbose) {
        (true, _) => Some(Level::WARN),
        (false, 0) => None,
        (false, 1) => Some(Level::DEBUG),
        (false, _) => Some(Level::TRACE),
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;
    use std::sync::{Arc, Mutex};

    use super::*;

    #[derive(Clone, Default)]
    struct Captured(Arc<Mutex<Vec<u8>>>);

    impl Write for Captured {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl<'a> MakeWriter<'a> for Captured {
        type Writer = Captured;
        fn make_writer(&'a self) -> Self::Writer {
            self.clone()
        }
    }

    /// The whole path as the binary has it: a `log::warn!` from wgpu reaches the output, a
    /// `log::info!` from it does not, and FieldProbe's own `info` does.
    #[test]
    fn warnings_through_log_are_shown_and_own_crates_log_at_the_level() {
        let out = Captured::default();
        init_with(out.clone(), Some("info"));
        log::warn!(target: "wgpu_core::device", "adapter lost");
        log::info!(target: "wgpu_core::device", "adapter details");
        tracing::info!("training started");
        tracing::debug!("too verbose");
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        assert!(
            text.contains("WARN") && text.contains("adapter lost"),
            "{text}"
        );
        assert!(!text.contains("adapter details"), "{text}");
        assert!(text.contains("training started"), "{text}");
        assert!(!text.contains("too verbose"), "{text}");
    }

    #[test]
    fn verbosity_flags_pick_a_bare_level() {
        assert_eq!(level_of(0, false), None);
        assert_eq!(level_of(1, false), Some(Level::DEBUG));
        assert_eq!(level_of(3, false), Some(Level::TRACE));
        assert_eq!(level_of(0, true), Some(Level::WARN));
    }

    #[test]
    fn a_bare_level_applies_to_own_crates_and_a_directive_list_is_taken_as_is() {
        assert_eq!(
            own_at(Level::DEBUG),
            "warn,experiments=debug,fieldprobe=debug,custom_sampler=debug,custom_model=debug"
        );
        let f = filter(Some("warn,fieldprobe_core=trace")).to_string();
        assert!(
            f.contains("fieldprobe_core=trace") && f.contains("warn"),
            "{f}"
        );
        // Not a filter at all: the default, not a panic.
        let _ = filter(Some("=="));
    }
}
