//! The range analysis in CI: prints each variable's worst-case range against the format's
//! limit and fails when one does not fit; and shows the analysis (and a harness) flag a
//! deliberately too narrow format.

// Drives the executing engine, which does not exist under Kani.
#![cfg(not(kani))]

use massid_proofs::interval::Format;
use massid_proofs::range;

#[test]
fn firing_terms_fit_q8_24_for_every_word_over_the_envelope() {
    let r = range::firing_terms(Format::Q8_24);
    println!("{}", r.table());
    assert!(r.fits(), "{}", r.table());
}

#[test]
fn firing_terms_fit_f32() {
    let r = range::firing_terms(Format::F32);
    println!("{}", r.table());
    assert!(r.fits(), "{}", r.table());
}

#[test]
fn a_too_narrow_format_is_flagged_by_the_range_analysis_and_a_harness() {
    // Q4.28 (range +-8) where the torque regressor reaches tens of cN m.
    let r = range::firing_terms(Format::Q4_28);
    println!("{}", r.table());
    assert!(!r.fits(), "the range analysis must flag Q4.28");
    assert!(r
        .overflows()
        .iter()
        .any(|v| v.name.starts_with("torque_cnm")));
    // The same kernel code instantiated with the too narrow fixed type: the harness fails.
    let e = massid_proofs::engine::check(
        "firing_terms_q4_28",
        massid_proofs::engine::Mode::Random {
            runs: 2000,
            seed: 9,
        },
        &[],
        massid_proofs::harness::model::firing_terms_q4_28,
    )
    .expect_err("the firing-terms harness must fail for Q4.28");
    println!("harness flagged Q4.28: {e}");
}

/// A simulated trajectory: SPH2 firing each single thruster and each torque couple in turn
/// (300 ticks each, 30 coasting), gyro counts from the rigid-body rate with the seed's noise.
fn trajectory(ticks: usize) -> Vec<([u16; 3], u16)> {
    use massid_kernel::model::SPH2;
    let p = SPH2;
    let inv = p.inertia_inverse().expect("invertible");
    let mut words: Vec<u16> = (0..12).map(|i| 1 << i).collect();
    for (a, b) in [(0, 7), (1, 6), (2, 9), (3, 8), (4, 11), (5, 10)] {
        words.push((1 << a) | (1 << b));
    }
    let mut omega = [0.0f64; 3];
    let mut out = Vec::with_capacity(ticks);
    let mut x = 0x1234_5678u64;
    let mut noise = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % 5) as f64 - 2.0
    };
    let mut t = 0;
    while out.len() < ticks {
        let word = if t % 330 < 300 {
            words[(t / 330) % words.len()]
        } else {
            0
        };
        t += 1;
        let mut tau = [0.0; 3];
        for i in 0..12 {
            if word & (1 << i) != 0 {
                let f = p.thrust_dir[i].map(|v| v as f64 * p.thrust_n[i] as f64);
                let r = [0, 1, 2]
                    .map(|k| p.thruster_pos_m[i][k] as f64 - p.com_offset_mm[k] as f64 * 1e-3);
                tau[0] += r[1] * f[2] - r[2] * f[1];
                tau[1] += r[2] * f[0] - r[0] * f[2];
                tau[2] += r[0] * f[1] - r[1] * f[0];
            }
        }
        for a in 0..3 {
            let od: f64 = (0..3).map(|b| inv[a][b] * tau[b]).sum();
            omega[a] = if word == 0 {
                omega[a] * 0.9
            } else {
                omega[a] + od * 1e-3
            };
        }
        let counts = [0, 1, 2].map(|a| {
            (2070.0 + omega[a] * 1412.79 + noise())
                .round()
                .clamp(0.0, 4095.0) as u16
        });
        out.push((counts, word));
    }
    out
}

#[test]
fn pipeline_trajectory_ranges_fit_q8_24() {
    use massid_proofs::engine::{check, Mode};
    let samples = trajectory(6 * 330);
    // Undecided comparisons are explored along random paths (3 runs); each run's watch is
    // checked, so every explored path fits.
    thread_local!(static SAMPLES: std::cell::RefCell<Vec<([u16; 3], u16)>> = const { std::cell::RefCell::new(Vec::new()) });
    SAMPLES.with(|s| *s.borrow_mut() = samples);
    fn body() {
        let samples = SAMPLES.with(|s| s.borrow().clone());
        let r = range::pipeline_trajectory(Format::Q8_24, &massid_kernel::model::SPH2, &samples);
        println!("{}", r.table());
        assert!(r.overflows().is_empty(), "{}", r.table());
        assert!(r.watch.max_abs < Format::Q8_24.max, "{}", r.table());
    }
    let rep = check(
        "pipeline_trajectory_q8_24",
        Mode::Random { runs: 3, seed: 5 },
        &[],
        body,
    )
    .unwrap();
    println!("{rep}");
}

/// The mixer built onboard from a CoM estimate in 1 mm cells of the envelope box (+-30 mm), then
/// mixing commands from boxes of the envelope: ranges of every intermediate (the mixing
/// matrix sits near the top of the format by design, so this is where range matters).
/// Undecided comparisons (pivoting, the opposing/negative resolution, scaling) are explored
/// along random paths, so this is sound for the explored paths.
#[test]
fn mixer_ranges_fit_q8_24_over_the_com_box_and_command_boxes() {
    use massid_kernel::mixer::{Mixer, MixerConfig};
    use massid_kernel::Scalar;
    use massid_proofs::engine::{any_in, check, Mode};
    use massid_proofs::interval::{self, Interval};
    fn body() {
        interval::set_format(Format::Q8_24);
        interval::reset_watch();
        // The CoM estimate: a 1 mm cell of the +-30 mm envelope box (the whole box at once
        // is too wide for an interval LU of M M': every pivot becomes uncertain).
        let com = [0; 3].map(|_| {
            let k = any_in(-30i32, 29);
            Interval::new(k as f64 * 1e-3, (k + 1) as f64 * 1e-3).expect("ordered")
        });
        let cfg = MixerConfig {
            period_ms: 200,
            min_pulse_ms: 10,
            pressure_drop_n: Interval::ZERO,
        };
        let built = Mixer::<Interval>::new(&massid_kernel::model::SPH2, com, cfg);
        let build_watch = interval::watch();
        let Ok(mixer) = built else {
            // The interval LU could not certify the pivots for the whole box: a status path.
            println!(
                "mixer build over the box: {:?}, watch {:?}",
                built.err(),
                build_watch
            );
            massid_proofs::cover!(true, "mixer build: status");
            interval::set_format(Format::REAL);
            return;
        };
        massid_proofs::cover!(true, "mixer built");
        // A command cell of 1 mN x 0.1 mN m anywhere in +-0.4 N x +-0.04 N m (wider cells
        // make the interval duties divide by uncertain maxima: overestimation, not range).
        let cell =
            |k: i32, w: f64| Interval::new(k as f64 * w, (k + 1) as f64 * w).expect("ordered");
        let f = [0; 3].map(|_| cell(any_in(-400, 399), 1e-3));
        let t = [0; 3].map(|_| cell(any_in(-400, 399), 1e-4));
        let _ = mixer.mix(f, t);
        let w = interval::reset_watch();
        interval::set_format(Format::REAL);
        println!("mixer: build max |x| {:.4} ({} ops, {} undecided); build + mix max |x| {:.4} ({} undecided, {} divisions by 0-containing intervals)",
            build_watch.max_abs, build_watch.ops, build_watch.undecided, w.max_abs, w.undecided, w.div_by_zero);
        assert!(
            w.max_abs < Format::Q8_24.max,
            "an intermediate reaches {} >= 128",
            w.max_abs
        );
        WORST.with(|c| c.set((c.get().0.max(build_watch.max_abs), c.get().1.max(w.max_abs))));
    }
    thread_local!(static WORST: std::cell::Cell<(f64, f64)> = const { std::cell::Cell::new((0.0, 0.0)) });
    let r = check(
        "mixer_ranges_q8_24",
        Mode::Random { runs: 40, seed: 3 },
        &["mixer built"],
        body,
    )
    .unwrap();
    let (b, m) = WORST.with(|c| c.get());
    println!("{r}; worst over the runs: build max |x| {b:.4}, build + mix max |x| {m:.4} (Q8.24 limit 128)");
}

/// The same analysis on a rail-to-rail trajectory (counts alternating 0 / 4095 every 3 ticks
/// during the firings): whatever range the intervals reach, a value at the format's limit
/// must come with a status (the kernel's `is_valid` checks), never an Ok estimate beyond it.
#[test]
fn pipeline_rail_trajectory_reports_what_does_not_fit() {
    use massid_proofs::engine::{check, Mode};
    fn body() {
        let mut samples = trajectory(4 * 330);
        for (k, s) in samples.iter_mut().enumerate() {
            if s.1 != 0 {
                s.0 = [if (k / 3) % 2 == 0 { 0 } else { 4095 }; 3];
            }
        }
        let r = range::pipeline_trajectory(Format::Q8_24, &massid_kernel::model::SPH2, &samples);
        println!("{}", r.table());
        // Estimates the pipeline reports are inside the format (what does not fit is caught
        // by its status checks before it becomes an estimate).
        assert!(
            r.vars
                .iter()
                .filter(|v| v.name.starts_with("delta_com") || v.name.starts_with("theta"))
                .all(|v| v.range.mag() < Format::Q8_24.max),
            "{}",
            r.table()
        );
    }
    let rep = check(
        "pipeline_rails_q8_24",
        Mode::Random { runs: 2, seed: 9 },
        &[],
        body,
    )
    .unwrap();
    println!("{rep}");
}
