//! How good can it be (issue 12 item 5): the Monte Carlo variance of the offline batch, the
//! online reference and the kernels over `N` rga12 flights, against the Cramér–Rao bound of
//! the rate-output model. `cargo run --release -p massid-tests --example crlb -- [N] [SEED0]`
fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap_or(200);
    let seed0: u64 = std::env::args()
        .nth(2)
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let (mc, bound) = massid_tests::crlb::mc_against_crlb(n, seed0);
    print!("{}", massid_tests::crlb::markdown(&mc, &bound));
}
