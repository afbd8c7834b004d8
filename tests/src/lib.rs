//! Shared helpers for FieldProbe's cross-crate integration tests (the tests live in `tests/`).

use std::path::PathBuf;

/// `tests/data/` of this crate: golden files copied from `shared/testdata`.
pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data")
}
