//! The kernel's O(1) fast paths against the defining slow forms they replace: any difference
//! would change the kernel's results (and the QEMU-vs-host equality rests on one code path).

use massid_kernel::scalar::{
    fixed_div_by_digits, fixed_div_by_i64, fixed_div_by_words, split_pow2_by_steps, Fx, Scalar,
    Q16_16, Q8_24,
};
use proptest::prelude::*;

type Q4_28 = Fx<fixed::types::extra::U28>;
type Q20_12 = Fx<fixed::types::extra::U12>;

fn fx_bits<F: fixed::types::extra::LeEqU32>(b: i32) -> Fx<F> {
    Fx(fixed::FixedI32::from_bits(b))
}

fn same_fx<F: fixed::types::extra::LeEqU32>(b: i32) -> Result<(), TestCaseError> {
    let v: Fx<F> = fx_bits(b);
    let (m_fast, k_fast) = v.split_pow2();
    let (m_loop, k_loop) = split_pow2_by_steps(v);
    prop_assert_eq!(
        (m_fast.0.to_bits(), k_fast),
        (m_loop.0.to_bits(), k_loop),
        "bits {:#x}",
        b
    );
    Ok(())
}

/// Bit patterns where the shift count changes: powers of two and their neighbours, both signs.
fn edge_patterns() -> Vec<i32> {
    let mut v = vec![0, 1, -1, i32::MIN, i32::MAX, i32::MIN + 1];
    for s in 0..31 {
        let p = 1i32 << s;
        for d in [-1, 0, 1] {
            v.push(p.wrapping_add(d));
            v.push(p.wrapping_add(d).wrapping_neg());
        }
    }
    v
}

#[test]
fn fixed_split_pow2_equals_the_loop_at_every_edge() {
    for b in edge_patterns() {
        same_fx::<fixed::types::extra::U24>(b).unwrap();
        same_fx::<fixed::types::extra::U16>(b).unwrap();
        same_fx::<fixed::types::extra::U28>(b).unwrap();
        same_fx::<fixed::types::extra::U12>(b).unwrap();
    }
    // Non-vacuity: both directions and the negative extra step are exercised.
    let q = |b: i32| Q8_24::split_pow2(fx_bits(b)).1;
    assert!(q(1 << 30) > 0 && q(1) < 0 && q(1 << 24) == 0);
    // -(2^26 - 1): the floor shift by 1 gives -2^25 (magnitude 2.0), so the loop takes k = 2.
    assert_eq!(q(-(1 << 26) + 1), 2);
    assert_eq!(q((1 << 26) - 1), 1);
    let _ = (Q16_16::ZERO, Q4_28::ZERO, Q20_12::ZERO);
}

#[test]
fn f32_split_pow2_equals_the_loop_on_special_values() {
    let specials = [
        0.0f32,
        -0.0,
        1.0,
        -1.0,
        2.0,
        1.999_999_9,
        f32::MIN_POSITIVE,
        f32::MIN_POSITIVE / 3.0,
        -1e-45,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1e30,
        -3e-30,
        2f32.powi(64),
        2f32.powi(65),
        2f32.powi(-64),
        2f32.powi(-65),
    ];
    for v in specials {
        let (mf, kf) = v.split_pow2();
        let (ml, kl) = split_pow2_by_steps(v);
        assert_eq!((mf.to_bits(), kf), (ml.to_bits(), kl), "{v:e}");
    }
}

/// The `fixed` crate's own quotient: the definition both division paths must equal.
fn crate_div(a: i32, b: i32, frac: u32) -> Option<i32> {
    use fixed::types::extra::{U0, U12, U16, U24, U28, U31};
    use fixed::FixedI32;
    macro_rules! q {
        ($f:ty) => {
            FixedI32::<$f>::from_bits(a)
                .checked_div(FixedI32::<$f>::from_bits(b))
                .map(|v| v.to_bits())
        };
    }
    match frac {
        0 => q!(U0),
        12 => q!(U12),
        16 => q!(U16),
        24 => q!(U24),
        28 => q!(U28),
        31 => q!(U31),
        _ => unreachable!("format not listed"),
    }
}

const FRACS: [u32; 6] = [0, 12, 16, 24, 28, 31];

fn same_div(a: i32, b: i32) -> Result<(), TestCaseError> {
    for f in FRACS {
        let want = crate_div(a, b, f);
        prop_assert_eq!(
            fixed_div_by_words(a, b, f),
            want,
            "words {} / {} frac {}",
            a,
            b,
            f
        );
        prop_assert_eq!(
            fixed_div_by_i64(a, b, f),
            want,
            "i64 {} / {} frac {}",
            a,
            b,
            f
        );
        prop_assert_eq!(
            fixed_div_by_digits(a, b, f),
            want,
            "digits {} / {} frac {}",
            a,
            b,
            f
        );
    }
    Ok(())
}

#[test]
fn fixed_division_paths_equal_the_crate_at_every_edge() {
    let e = edge_patterns();
    let mut some = 0;
    let mut none = 0;
    for &a in &e {
        for &b in &e {
            same_div(a, b).unwrap();
            match fixed_div_by_words(a, b, 24) {
                Some(_) => some += 1,
                None => none += 1,
            }
        }
    }
    // Non-vacuity: both results occur, including the exact i32::MIN quotient.
    assert!(some > 1000 && none > 1000, "{some} {none}");
    assert_eq!(fixed_div_by_words(i32::MIN, 1 << 24, 24), Some(i32::MIN));
    assert_eq!(fixed_div_by_words(i32::MIN, -(1 << 24), 24), None);
}

proptest! {
    #[test]
    fn fixed_division_paths_equal_the_crate(a in any::<i32>(), b in any::<i32>(), small in -(1i32 << 20)..(1i32 << 20)) {
        same_div(a, b)?;
        same_div(a, small)?;
        same_div(small, b)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn fixed_split_pow2_equals_the_loop(b in any::<i32>()) {
        same_fx::<fixed::types::extra::U24>(b)?;
        same_fx::<fixed::types::extra::U16>(b)?;
        same_fx::<fixed::types::extra::U28>(b)?;
    }

    #[test]
    fn f32_split_pow2_equals_the_loop(bits in any::<u32>()) {
        let v = f32::from_bits(bits);
        let (mf, kf) = v.split_pow2();
        let (ml, kl) = split_pow2_by_steps(v);
        prop_assert_eq!((mf.to_bits(), kf), (ml.to_bits(), kl), "{:e}", v);
    }
}

/// The gyro low-pass in i128 (no overflow possible): the definition the kernel's i32 state
/// with 32 x 32 -> 64 products must equal, including at slow sampling where the pole is negative.
fn low_pass_wide(
    coefs: massid_kernel::gyro_filter::LowPassCoefs,
    xs: &[[u16; 3]],
) -> Vec<[i32; 3]> {
    let (p, g) = (i128::from(coefs.p_q30), i128::from(coefs.g_q30));
    let half = 1i128 << 29;
    let first = xs[0].map(|c| i128::from(c) << 12);
    let (mut xp, mut u, mut y) = (first, first, first);
    xs.iter()
        .map(|c| {
            let x = c.map(|c| i128::from(c) << 12);
            let mut out = [0i32; 3];
            for a in 0..3 {
                let un = (p * u[a] + g * (x[a] + xp[a]) + half) >> 30;
                let yn = (p * y[a] + g * (un + u[a]) + half) >> 30;
                xp[a] = x[a];
                u[a] = un;
                y[a] = yn;
                out[a] = i32::try_from(yn).expect("fits i32");
            }
            out
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn gyro_low_pass_equals_the_wide_definition(
        dt_ms in prop::sample::select(vec![1u32, 2, 5, 10, 20, 50, 200]),
        // runs of constant counts (steps between the extremes are the worst case for the states)
        runs in prop::collection::vec((prop::sample::select(vec![0u16, 1, 2047, 30000, 65534, 65535]), any::<u16>(), 1usize..40), 1..30),
    ) {
        use massid_kernel::gyro_filter::{GyroLowPass, LowPassCoefs};
        let coefs = LowPassCoefs::design(50.0, f64::from(dt_ms) * 1e-3);
        let xs: Vec<[u16; 3]> = runs.iter().flat_map(|&(a, b, n)| std::iter::repeat_n([a, b, a ^ b], n)).collect();
        let want = low_pass_wide(coefs, &xs);
        let mut f = GyroLowPass::new(coefs);
        let got: Vec<[i32; 3]> = xs.iter().map(|c| f.step(*c)).collect();
        prop_assert_eq!(got, want);
    }
}

#[test]
fn gyro_low_pass_pole_is_negative_at_slow_sampling() {
    // Non-vacuity for the test above: the negative-pole branch is exercised.
    use massid_kernel::gyro_filter::LowPassCoefs;
    assert!(LowPassCoefs::design(50.0, 0.010).p_q30 < 0);
    assert!(LowPassCoefs::design(50.0, 0.001).p_q30 > 0);
}

/// `floor(v 2^e)` (or nearest, ties up) saturated to i32, in i128: the definition of the fixed
/// `mul_pow2` / `mul_pow2_nearest` shifts.
fn shift_wide(v: i32, e: i32, nearest: bool) -> i32 {
    let w = i128::from(v);
    let r = if e >= 0 {
        if e >= 64 {
            w.signum() * (1i128 << 100)
        } else {
            w << e
        }
    } else {
        let k = (-e).min(100) as u32;
        let w = if nearest { w + (1i128 << (k - 1)) } else { w };
        w >> k
    };
    r.clamp(i128::from(i32::MIN), i128::from(i32::MAX)) as i32
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn fixed_shifts_equal_the_wide_definition(v in any::<i32>(), small in -300i32..300, e in -70i32..70) {
        for v in [v, small, 0, -1, i32::MIN, i32::MAX] {
            let q: Q8_24 = fx_bits(v);
            prop_assert_eq!(q.mul_pow2(e).0.to_bits(), shift_wide(v, e, false), "{} * 2^{}", v, e);
            let expect_nearest = if e >= 0 { shift_wide(v, e, false) } else { shift_wide(v, e.max(-40), true) };
            prop_assert_eq!(q.mul_pow2_nearest(e).0.to_bits(), expect_nearest, "nearest {} * 2^{}", v, e);
        }
    }
}
