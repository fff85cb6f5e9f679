//! Benchmark fixtures and the baseline every speed figure is a ratio against.
//!
//! The baseline, [`naive::NaiveSeedPipeline`], is the seed's equations written the
//! straightforward way in nalgebra f64, the way the seed's flight C code does it: one RLS
//! update per Kalman-filter update, each inverting the full information matrix (LU).
pub mod naive;

use reference_f64::recording::{Recording, Sample};
use std::path::PathBuf;

/// The open recordings directory (`../shared/data/open/`, beside the repository).
pub fn open_data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open")
}

/// The samples of `o01_nominal_rga12.csv` (nominal SPH2, 28 s at 1 kHz), the workload of the
/// pipeline benchmarks.
pub fn rga12_samples() -> Vec<Sample> {
    let path = open_data_dir().join("o01_nominal_rga12.csv");
    match Recording::read(&path) {
        Ok(r) => r.samples,
        Err(e) => {
            eprintln!("benchmark fixture missing: {e}");
            std::process::exit(2);
        }
    }
}
