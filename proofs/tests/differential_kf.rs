//! Differential: the kernel's angular-acceleration Kalman filter (`OmegaDotKf`, integer sums,
//! f32 and Q8.24) against `reference_f64::omega_dot::OmegaDotKalman` (the seed's recursive
//! information-form filter) on the same filtered samples, with the kernel's timing (anchor
//! at the word change, transient skipped, `H = (k - kappa) dt`), on random and adversarial count sequences: single-axis
//! maneuvers, saturated gyros (0 / 4095), telemetry gaps, the longest firing of the envelope.
//! Budget: `budget::TABLE` row `kf.omega_dot`.

use massid_kernel::omega_dot::{KfConfig, KfStatus, OmegaDotKf};
use massid_kernel::Q8_24;
use massid_proofs::budget::{fmt_of, Exact, Worst};
use massid_proofs::harness::omega_dot::closed_form;
use nalgebra::Vector3;
use proptest::prelude::*;
use reference_f64::omega_dot::OmegaDotKalman;

/// Runs both filters over `counts` (filtered Q12 counts; None = gap) from `prior`; checks
/// every estimate the kernel gives against the reference within the budget (the context
/// figure is the sums' cancellation ratio, see `budget`). Returns (estimates compared,
/// estimates the kernel declined (None)).
fn run<S: Exact>(
    prior: [f64; 3],
    counts: &[Option<[i32; 3]>],
    worst: &mut Worst,
) -> Result<(u64, u64), String> {
    let cfg = KfConfig::seed(1);
    let mut kf = OmegaDotKf::<S>::new(&cfg);
    kf.reset(prior.map(|v| S::from_f32(v as f32)));
    // The reference sees the prior and the delay the kernel holds (rounded into S).
    let prior_s = prior.map(|v| S::from_f32(v as f32).exact());
    let kappa = S::from_f32(cfg.delay_ticks.clamp(0.0, 60.0) as f32).exact();
    let mut rf = OmegaDotKalman::new(cfg.r_rad2_s2);
    let g = cfg.counts_per_rad_s;
    let rate = |c: [i32; 3]| {
        Vector3::new(
            c[0] as f64 / (g[0] * 4096.0),
            c[1] as f64 / (g[1] * 4096.0),
            c[2] as f64 / (g[2] * 4096.0),
        )
    };
    let (mut compared, mut declined) = (0, 0);
    let mut anchor_tick = 0usize;
    for (t, c) in counts.iter().enumerate() {
        match kf.update(*c) {
            KfStatus::Anchored => {
                anchor_tick = t;
                rf.reset(
                    Vector3::from(prior_s),
                    cfg.p0,
                    rate(c.expect("anchored on a sample")),
                );
            }
            KfStatus::Updated => {
                let k = (t - anchor_tick) as f64;
                rf.update(
                    rate(c.expect("updated on a sample")),
                    (k - kappa) * cfg.dt_s,
                );
                let (_, ratio) = closed_form(&cfg, kappa, prior_s, &kf.sums());
                match kf.estimate() {
                    None => declined += 1,
                    Some(e) => {
                        compared += 1;
                        for i in 0..3 {
                            worst
                                .record(fmt_of::<S>(), e.omega_dot[i].exact(), rf.x[i], ratio)
                                .map_err(|m| format!("tick {t} axis {i}: {m}"))?;
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok((compared, declined))
}

/// A firing's filtered counts (Q12): bias + ramp (slope counts/sample per axis) + noise,
/// optional gaps.
fn sequence(
    bias: [u16; 3],
    slope: [f64; 3],
    noise: u16,
    gaps: bool,
    n: usize,
    seed: u64,
) -> Vec<Option<[i32; 3]>> {
    let mut x = seed | 1;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    (0..n)
        .map(|k| {
            if gaps && k > 12 && rnd() % 17 == 0 {
                return None;
            }
            Some([0, 1, 2].map(|i| {
                let n = if noise > 0 {
                    (rnd() % (2 * noise as u64 * 4096 + 1)) as f64 / 4096.0 - noise as f64
                } else {
                    0.0
                };
                ((bias[i] as f64 + slope[i] * k as f64 + n).clamp(0.0, 4095.0) * 4096.0).round()
                    as i32
            }))
        })
        .collect()
}

fn both(
    prior: [f64; 3],
    seq: &[Option<[i32; 3]>],
    wq: &mut Worst,
    wf: &mut Worst,
) -> Result<(u64, u64), String> {
    let q = run::<Q8_24>(prior, seq, wq)?;
    run::<f32>(prior, seq, wf)?;
    Ok(q)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_0001), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_firings(prior in prop::array::uniform3(-20.0f64..20.0), slope in prop::array::uniform3(-2.0f64..2.0),
                      noise in 0u16..4, gaps: bool, n in 15usize..600, seed: u64) {
        let seq = sequence([2048, 2070, 2058], slope, noise, gaps, n, seed);
        let (mut wq, mut wf) = (Worst::new("kf.omega_dot"), Worst::new("kf.omega_dot"));
        both(prior, &seq, &mut wq, &mut wf).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn single_axis_maneuvers(axis in 0usize..3, slope in -3.0f64..3.0, noise in 0u16..3, n in 15usize..1000, seed: u64) {
        let mut s = [0.0; 3];
        s[axis] = slope;
        let seq = sequence([2077, 2070, 2058], s, noise, false, n, seed);
        let (mut wq, mut wf) = (Worst::new("kf.omega_dot"), Worst::new("kf.omega_dot"));
        both([0.0; 3], &seq, &mut wq, &mut wf).map_err(TestCaseError::fail)?;
    }
}

#[test]
fn saturated_gyros_and_the_longest_firing() {
    let (mut wq, mut wf) = (Worst::new("kf.omega_dot"), Worst::new("kf.omega_dot"));
    // Saturated: pinned at 0 or 4095 (a rate beyond the gyro's range), and a step between them.
    for (a, b) in [(0u16, 0u16), (4095, 4095), (0, 4095), (4095, 0)] {
        let seq: Vec<_> = (0..300)
            .map(|k| {
                Some(if k < 40 {
                    [a as i32 * 4096; 3]
                } else {
                    [b as i32 * 4096; 3]
                })
            })
            .collect();
        let (c, d) = both([5.0, -5.0, 0.0], &seq, &mut wq, &mut wf).unwrap();
        println!("saturated {a}->{b}: {c} compared, {d} declined (quotient beyond Q8.24)");
    }
    // The longest firing of the envelope (2000 samples) at the largest slope that stays in
    // range: 1 count/sample per axis.
    let seq = sequence([100, 100, 100], [1.9, -0.04, 1.0], 2, true, 2000, 7);
    let (c, d) = both([0.0; 3], &seq, &mut wq, &mut wf).unwrap();
    println!("2000-sample firing: {c} compared, {d} declined");
    println!("Q8_24 {wq}");
    println!("F32 {wf}");
}

#[test]
fn figures_for_the_readme() {
    // A fixed sample of random firings, printing the worst error/budget ratios.
    let (mut wq, mut wf) = (Worst::new("kf.omega_dot"), Worst::new("kf.omega_dot"));
    let (mut compared, mut declined) = (0, 0);
    for seed in 1..=40u64 {
        let slope = [
            (seed % 7) as f64 * 0.3 - 0.9,
            (seed % 5) as f64 * 0.2 - 0.4,
            (seed % 3) as f64 * 0.5 - 0.5,
        ];
        let seq = sequence(
            [2055, 2079, 2051],
            slope,
            (seed % 3) as u16,
            seed % 2 == 0,
            1000,
            seed,
        );
        let (c, d) = both([0.3, -0.2, 0.1], &seq, &mut wq, &mut wf).unwrap();
        compared += c;
        declined += d;
    }
    println!(
        "40 firings x 1000 samples: Q8_24 {wq}; {declined} of {} estimates declined",
        compared + declined
    );
    println!("40 firings x 1000 samples: F32 {wf}");
    assert!(wq.count > 0 && wf.count > 0);
}
