//! The gyro low-pass state stays bounded, with no operation that could wrap, for every
//! sequence of 12-bit counts and every sample period of the envelope (1 to 20 ms): an
//! inductive invariant of the kernel's own `section`, on the interval machine.

use massid_kernel::gyro_filter::COUNT_FRAC_BITS;
use massid_proofs_solver::gyro::{filter_invariant, MAX_INPUT};

/// 64 pieces, geometric in the period, covering 1..20 ms at the kernel's 50 Hz cut-off.
#[test]
fn the_filter_state_is_bounded_over_the_envelope() {
    let fc = massid_kernel::omega_dot::GYRO_FILTER_HZ;
    let pieces = 64;
    let ratio: f64 = 20.0;
    let mut worst = 0i128;
    for i in 0..pieces {
        let lo = 1e-3 * ratio.powf(i as f64 / pieces as f64);
        let hi = 1e-3 * ratio.powf((i + 1) as f64 / pieces as f64);
        let inv = filter_invariant(lo, hi, fc, MAX_INPUT)
            .unwrap_or_else(|e| panic!("{lo:.5}..{hi:.5} s: {e}"));
        worst = worst.max(inv.second).max(inv.first);
        if i % 16 == 0 || i == pieces - 1 {
            println!(
                "dt {:.4}..{:.4} s: p {:?}, first section |u| <= {} ({:.2} counts), output |y| <= {} ({:.2} counts)",
                lo,
                hi,
                inv.p,
                inv.first,
                inv.first as f64 / f64::from(1u32 << COUNT_FRAC_BITS),
                inv.second,
                inv.second as f64 / f64::from(1u32 << COUNT_FRAC_BITS),
            );
        }
    }
    // The state comment's claim: below 2^30.
    assert!(worst < 1 << 30, "state bound {worst}");
    println!("worst state bound {worst} (2^{:.2})", (worst as f64).log2());
}

/// The Kalman filter's exact sums over one firing (`omega_dot::KfSums`: `sum z` and
/// `sum k z` with `z` the difference of two filter outputs, `k <= MAX_FIRING_TICKS`) fit
/// `i64` without saturating, from the proved output bound: `|sum k z| <= |z|max K (K+1) / 2`.
/// This is a closed-form bound on the sums, not a run of the update code. Where it does
/// not cover the whole cap, the longest firing it covers is printed.
#[test]
fn the_kalman_sums_fit_over_the_capped_firing() {
    let fc = massid_kernel::omega_dot::GYRO_FILTER_HZ;
    let cap = i128::from(massid_kernel::omega_dot::MAX_FIRING_TICKS);
    let fits = |z: i128, k: i128| {
        z * k * (k + 1) / 2 <= i128::from(i64::MAX) && z * k <= i128::from(i64::MAX)
    };
    let mut covered_to = 0.0;
    for (lo, hi) in [
        (1e-3, 2e-3),
        (2e-3, 5e-3),
        (5e-3, 1e-2),
        (1e-2, 1.5e-2),
        (1.5e-2, 2e-2),
    ] {
        let inv = filter_invariant(lo, hi, fc, MAX_INPUT).expect("invariant");
        let z = 2 * inv.second;
        // sum k and sum k^2 do not depend on the data
        assert!(cap * (cap + 1) * (2 * cap + 1) / 6 <= i128::from(u64::MAX));
        if fits(z, cap) {
            covered_to = hi;
            println!("dt {lo:.3}..{hi:.3} s: |z| <= {z}: every sum fits over {cap} ticks");
        } else {
            let mut k = cap;
            while !fits(z, k) {
                k = k * 15 / 16;
            }
            println!(
                "dt {lo:.3}..{hi:.3} s: |z| <= {z}: sums proved to fit for firings up to {k} ticks ({:.0} s); the cap is {cap}",
                k as f64 * hi
            );
        }
    }
    assert!(
        covered_to >= 1e-2,
        "the sums are proved over the whole cap only to {covered_to} s"
    );
}

/// The check can fail: at a 1 s period the pole is close to -1 and the bound leaves the
/// format; with 20-bit counts the products may wrap.
#[test]
fn the_invariant_check_fails_where_it_should() {
    let fc = massid_kernel::omega_dot::GYRO_FILTER_HZ;
    let slow = filter_invariant(0.9, 1.0, fc, MAX_INPUT);
    assert!(slow.is_err(), "{slow:?}");
    println!("1 s period: {}", slow.unwrap_err());
    let wide = filter_invariant(1e-3, 1.1e-3, fc, 1i128 << 40);
    assert!(wide.is_err(), "{wide:?}");
    println!("2^40 inputs: {}", wide.unwrap_err());
}
