//! Progress of long work (rendering a dataset, training, evaluating), shown the way the
//! application wants it.
//!
//! The library only says how far it is; the application installs one [`Display`] at start-up
//! (the CLI: indicatif bars with rate and ETA, or log lines where stderr is not a terminal), the
//! way `tracing` leaves output to the subscriber the binary installs. Without one, progress is
//! not shown: a library user embedding a run sees nothing it did not ask for.

use std::sync::OnceLock;

/// Makes a [`Bar`] for each piece of long work.
pub trait Display: Send + Sync {
    /// Work labelled `label` of `len` units, starting at `position` (resumed work counts as done
    /// before this process, not towards the rate).
    fn bar(&self, label: &str, len: usize, position: usize) -> Box<dyn Bar>;
}

/// Progress through one piece of work; shared between worker threads.
pub trait Bar: Send + Sync {
    /// Moves to `position`, with a message (e.g. the loss).
    fn set(&self, position: usize, message: String);
    /// Sets the message only.
    fn message(&self, message: String);
    /// One more unit done.
    fn inc(&self);
    /// The work is done.
    fn finish(&self);
    /// The work stopped on an error; leave what is shown as it is.
    fn abandon(&self);
}

static DISPLAY: OnceLock<Box<dyn Display>> = OnceLock::new();

/// Installs the process's display; `false` (and nothing changes) if one is installed already.
pub fn set_display(display: Box<dyn Display>) -> bool {
    DISPLAY.set(display).is_ok()
}

/// A bar from the installed display, or one that shows nothing.
pub fn bar(label: &str, len: usize, position: usize) -> Box<dyn Bar> {
    match DISPLAY.get() {
        Some(d) => d.bar(label, len, position),
        None => Box::new(Hidden),
    }
}

/// A bar that shows nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hidden;

impl Bar for Hidden {
    fn set(&self, _: usize, _: String) {}
    fn message(&self, _: String) {}
    fn inc(&self) {}
    fn finish(&self) {}
    fn abandon(&self) {}
}
