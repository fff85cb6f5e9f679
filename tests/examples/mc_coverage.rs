//! Monte Carlo coverage of the estimators' standard errors (issue 12 item 3): `N` simulated
//! rga12 flights of the nominal SPH2 that differ only in the noise seed, through the f64
//! reference (online form) and the f32 and fixed kernels; for every principal inertia and CoM
//! term, the share of flights whose error is within 1 and 2 reported standard errors, and the
//! mean error in sigma (bias). `cargo run --release -p massid-tests --example mc_coverage -- [N] [SEED0]`
use massid_tests::coverage::{run_flights, Table};

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap_or(200);
    let seed0: u64 = std::env::args()
        .nth(2)
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let t: Table = run_flights(n, seed0);
    print!("{}", t.markdown());
}
