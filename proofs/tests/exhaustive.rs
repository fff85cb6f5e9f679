//! Exhaustive checks where the domain allows:
//! * Q8.24 primitives (`kernel/src/scalar.rs`): every unary operation on every i16 bit
//!   pattern and on every i16 pattern shifted to the top of the word (so saturation is in
//!   the domain); every binary operation on every pair of a 768-value operand set (i8 at the
//!   bottom, middle and top of the word: 589,824 pairs); the same property functions as the
//!   Kani harnesses in `harness::primitives`.
//! * The mixer's stage-10 bookkeeping: every thruster word 0..4095 at every boundary
//!   duration (0, m-1/2, m, P/2, P-m, P-m+1/2, P) for several periods, and every half
//!   millisecond of every period 20..1000 ms at both minimum pulses.

use massid_kernel::mixer::{quantise_duration, Mixer, MixerConfig};
use massid_kernel::model::SPH2;
use massid_kernel::{Scalar, Q8_24};
use massid_proofs::harness::mixer::expected_duration;
use massid_proofs::harness::primitives::{
    check_add_sub, check_div, check_mul, check_order, check_pow2,
};

fn operand_set() -> Vec<i32> {
    let mut v = Vec::new();
    for b in i8::MIN..=i8::MAX {
        let b = b as i32;
        v.push(b);
        v.push(b << 12);
        v.push(b.wrapping_shl(24) | if b < 0 { 0x00ff_ffff } else { 0 });
    }
    v.push(i32::MAX);
    v.push(i32::MIN);
    v.sort();
    v.dedup();
    v
}

#[test]
fn q8_24_unary_operations_on_every_i16_pattern() {
    let mut n = 0u64;
    for a in i16::MIN..=i16::MAX {
        for bits in [a as i32, (a as i32) << 16] {
            check_add_sub(bits, 0);
            check_order(bits, 0);
            for e in -40..=40 {
                check_pow2(bits, e);
            }
            n += 1;
        }
    }
    println!("unary: {n} operands x (neg, abs, order, 81 shifts each way)");
    assert_eq!(n, 2 * 65536);
}

#[test]
fn q8_24_binary_operations_on_every_pair_of_the_operand_set() {
    let set = operand_set();
    let mut n = 0u64;
    for &a in &set {
        for &b in &set {
            check_add_sub(a, b);
            check_mul(a, b);
            check_div(a, b);
            check_order(a, b);
            n += 1;
        }
    }
    println!(
        "binary: {} operands, {n} pairs x (add, sub, mul, div, order)",
        set.len()
    );
    assert!(n > 500_000);
}

#[test]
fn every_thruster_word_at_every_boundary_duration() {
    let mut n = 0u64;
    for (period, min) in [(20u32, 10u32), (40, 20), (200, 10), (200, 20), (1000, 10)] {
        let cfg = MixerConfig {
            period_ms: period,
            min_pulse_ms: min,
            pressure_drop_n: Q8_24::ZERO,
        };
        let mixer = Mixer::<Q8_24>::new(&SPH2, [Q8_24::ZERO; 3], cfg).expect("SPH2");
        let half = [
            0,
            2 * min - 2,
            2 * min - 1,
            2 * min,
            period,
            2 * (period - min),
            2 * (period - min) + 1,
            2 * period,
        ];
        for h in half {
            let frac = Q8_24::from_int_pow2(h as i32, 0)
                .checked_div(Q8_24::from_int_pow2(2 * period as i32, 0))
                .expect("nonzero");
            let fexact = frac.0.to_num::<f64>();
            let d = expected_duration(fexact, period, min);
            for word in 0u16..=0x0fff {
                let fr: [Q8_24; 12] = core::array::from_fn(|i| {
                    if word & (1 << i) != 0 {
                        frac
                    } else {
                        Q8_24::ZERO
                    }
                });
                let f = mixer.quantise(&fr).expect("fractions in [0, 1]");
                for i in 0..12 {
                    let want = if word & (1 << i) != 0 { d } else { 0 };
                    assert_eq!(
                        f.off_ms[i] - f.on_ms[i],
                        want,
                        "P {period} m {min} word {word:#05x} thruster {i}"
                    );
                    assert!(f.on_ms[i] <= f.off_ms[i] && f.off_ms[i] <= period);
                    if want > 0 {
                        assert_eq!(f.on_ms[i], (period - want) / 2);
                    } else {
                        assert_eq!((f.on_ms[i], f.off_ms[i]), (0, 0));
                    }
                }
                n += 1;
            }
        }
    }
    println!("{n} (period, duration, word) cases");
    assert_eq!(n, 5 * 8 * 4096);
}

#[test]
fn quantise_duration_on_every_half_millisecond_of_every_period() {
    let mut n = 0u64;
    for period in 20u32..=1000 {
        for min in [10u32, 20] {
            if period < 2 * min {
                continue;
            }
            for h in 0..=2 * period {
                // The fraction the kernel holds for h/2 ms, and its neighbours one step away.
                let base = Q8_24::from_int_pow2(h as i32, 0)
                    .checked_div(Q8_24::from_int_pow2(2 * period as i32, 0))
                    .expect("nonzero");
                for bits in [base.0.to_bits() - 1, base.0.to_bits(), base.0.to_bits() + 1] {
                    let f = massid_kernel::Fx(fixed::types::extra::U24::default_fixed(bits));
                    let got = quantise_duration(f, period, min).expect("fits");
                    let want = expected_duration(f.0.to_num::<f64>(), period, min);
                    assert_eq!(got, want, "P {period} m {min} frac bits {bits}");
                    n += 1;
                }
            }
        }
    }
    println!("quantise_duration: {n} (period, min pulse, fraction) cases");
}

trait FromBits {
    fn default_fixed(bits: i32) -> fixed::FixedI32<fixed::types::extra::U24>;
}
impl FromBits for fixed::types::extra::U24 {
    fn default_fixed(bits: i32) -> fixed::FixedI32<fixed::types::extra::U24> {
        fixed::FixedI32::from_bits(bits)
    }
}
