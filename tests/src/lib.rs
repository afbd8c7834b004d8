//! Shared helpers for FieldProbe's cross-crate integration tests (the tests live in `tests/`).

use std::path::PathBuf;

/// `tests/data/` of this crate: golden files copied from `shared/testdata`.
///
/// The folder comes from `CARGO_MANIFEST_DIR` as cargo sets it when it runs the test, not as it
/// was at compile time (`env!`): cargo reuses a test binary built in another checkout of the
/// repository when the target dir is shared (`.ci/run` points it at a cache), and `env!` would
/// then name that checkout's folder, gone or stale. The same rule holds in every test that reads
/// a file of the repository.
pub fn data_dir() -> PathBuf {
    PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test")).join("data")
}
