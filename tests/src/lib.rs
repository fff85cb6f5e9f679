//! Shared helpers for the workspace's cross-crate tests (in `tests/tests/`).
use std::path::PathBuf;

/// The open recordings shipped beside the repository (`../shared/data/open/`).
pub fn open_data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open")
}

/// The second open set (`../shared/data/open2/`): other rates, an effect on some axes only,
/// a stuck gyro, a dead thruster, more noise.
pub fn open2_data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open2")
}

pub mod allocation_check;
pub mod coverage;
pub mod crlb;
pub mod identification_mc;
pub mod mocap_flight;
pub mod planted_faults;
pub mod random_craft;
