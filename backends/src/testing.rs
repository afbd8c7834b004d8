//! Helpers for tests that drive a device: a clear skip line where wgpu has no Vulkan driver, and
//! a watchdog so that a stalled device fails its test with a message instead of hanging the run.
//!
//! Autotune: tests check results, not speed, so [`wgpu_or_skip`] sets cubecl's autotune to
//! `minimal` (unless the process configured cubecl first). On a software device autotune times
//! kernels on an emulated GPU, which costs seconds per shape and is the code path seen to stall.

use std::io::Write as _;
use std::sync::mpsc;
use std::time::Duration;

use cubecl::config::autotune::AutotuneLevel;
use cubecl::config::{CubeClRuntimeConfig, RuntimeConfig};

use crate::{BackendChoice, Device};

/// How long one device test may run before the watchdog fails it.
pub const DEVICE_TEST_DEADLINE: Duration = Duration::from_secs(300);

/// The wgpu device for a test, or `None` after printing one line saying why the test is skipped
/// and what to install. The line is written to stderr directly, not through `eprintln!`, which
/// the test harness captures and hides for a test that passes.
pub fn wgpu_or_skip(test: &str) -> Option<Device> {
    if let Some(reason) = crate::wgpu_unavailable() {
        let _ = writeln!(
            std::io::stderr(),
            "skipped {test}: {reason}; install a Vulkan driver (e.g. `{}`) to run it",
            crate::vulkan::VULKAN_INSTALL
        );
        return None;
    }
    let mut config = CubeClRuntimeConfig::default();
    config.autotune.level = AutotuneLevel::Minimal;
    let _ = CubeClRuntimeConfig::try_set(config);
    match BackendChoice::Wgpu.select() {
        Ok(s) => Some(s.device),
        Err(e) => panic!("{test}: {e}"),
    }
}

/// Runs `body` on its own thread and fails the calling test with a message if it has not
/// finished within `deadline` (the stalled thread is left behind; the test binary exits at the
/// end of the run). A panic inside `body` is re-raised.
pub fn with_deadline<T: Send + 'static>(
    test: &str,
    deadline: Duration,
    body: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::Builder::new()
        .name(format!("{test} (watchdog)"))
        .spawn(move || {
            let out = body();
            let _ = tx.send(());
            out
        })
        .expect("spawn test thread");
    match rx.recv_timeout(deadline) {
        Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => match handle.join() {
            Ok(v) => v,
            Err(p) => std::panic::resume_unwind(p),
        },
        Err(mpsc::RecvTimeoutError::Timeout) => panic!(
            "{test}: no result after {} s; the device stalled (see backends/src/testing.rs)",
            deadline.as_secs()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_watchdog_fails_a_stalled_body_and_passes_a_quick_one() {
        assert_eq!(with_deadline("quick", Duration::from_secs(5), || 7), 7);
        let stalled = std::panic::catch_unwind(|| {
            with_deadline("stalled", Duration::from_millis(50), || {
                std::thread::sleep(Duration::from_secs(3600))
            })
        });
        let message = stalled.unwrap_err();
        let text = message
            .downcast_ref::<String>()
            .cloned()
            .unwrap_or_default();
        assert!(text.contains("stalled: no result after"), "{text}");
    }

    #[test]
    fn a_panic_inside_the_body_reaches_the_test() {
        let r = std::panic::catch_unwind(|| {
            with_deadline("panics", Duration::from_secs(5), || panic!("inner failure"))
        });
        assert!(r.is_err());
    }
}
