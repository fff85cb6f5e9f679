//! Shared helpers for the workspace's cross-crate tests (in `tests/tests/`).
use std::path::PathBuf;

/// The open recordings shipped beside the repository (`../shared/data/open/`).
pub fn open_data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open")
}
