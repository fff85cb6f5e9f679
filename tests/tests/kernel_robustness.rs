//! No panic on any input: random and adversarial tick sequences (every thruster word incl.
//! the unused high bits, saturated and wildly jumping gyro counts, gaps, very long and very
//! short firings), extreme mixer commands and garbage matrices, in f32 and fixed point. The
//! test profile keeps debug assertions on, so an integer overflow would panic here too.
use massid_kernel::lu::solve;
use massid_kernel::mixer::{Mixer, MixerConfig};
use massid_kernel::model::{SPH2, SPH2_GYRO_BIAS_COUNTS};
use massid_kernel::rls::DetectorConfig;
use massid_kernel::{Pipeline, PipelineConfig, PipelineStatus, Scalar, Q8_24};
use rand::{Rng, SeedableRng};

fn configs<S: Scalar>() -> Vec<PipelineConfig<S>> {
    let mut tracking = PipelineConfig::<S>::with_gyroscopic(1, SPH2_GYRO_BIAS_COUNTS);
    tracking.rls.forgetting = Some(S::from_f32(0.999));
    tracking.rls.detector = Some(DetectorConfig::standard());
    vec![
        PipelineConfig::seed(1),
        PipelineConfig::with_gyroscopic(10, SPH2_GYRO_BIAS_COUNTS),
        tracking,
    ]
}

fn hammer<S: Scalar>(seed: u64) -> (usize, usize) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut solved = 0;
    let mut ok = 0;
    for cfg in configs::<S>() {
        let mut p = Pipeline::<S>::new(&SPH2, cfg).expect("model");
        let mut word: u16 = 0;
        let mut gyro = [2077u16, 2070, 2058];
        for _ in 0..30_000 {
            // word changes: mostly held (firings of 1..2000 ticks), any 16-bit value
            if rng.gen_ratio(1, 300) {
                word = if rng.gen_bool(0.3) { 0 } else { rng.gen() };
            }
            match rng.gen_range(0..100) {
                0 => gyro = [0, 4095, 0],                                    // saturated
                1 => gyro = std::array::from_fn(|_| rng.gen_range(0..4096)), // jump
                2..=40 => {
                    for g in gyro.iter_mut() {
                        *g = (*g as i32 + rng.gen_range(-3..=3)).clamp(0, 4095) as u16;
                    }
                }
                _ => {}
            }
            let r = if rng.gen_ratio(1, 200) {
                p.tick_gap()
            } else {
                p.tick(gyro, word)
            };
            if r.event == massid_kernel::TickEvent::Solved {
                solved += 1;
            }
        }
        p.finish();
        let e = p.estimates();
        if matches!(
            e.status,
            PipelineStatus::Ok | PipelineStatus::PartlyUnobservable
        ) {
            ok += 1;
            assert!(e
                .theta_inertia
                .iter()
                .chain(e.delta_com_m.iter())
                .all(|v| v.is_valid()));
        }
        let _ = p.mass_id().variances();
    }
    (solved, ok)
}

#[test]
fn random_tick_sequences_never_panic() {
    for seed in 0..3 {
        let (sf, _) = hammer::<f32>(seed);
        let (sq, _) = hammer::<Q8_24>(seed);
        // the sequences do reach the solves (not vacuous)
        assert!(sf > 10 && sq > 10, "solves reached: f32 {sf}, fixed {sq}");
    }
}

#[test]
fn one_endless_firing_is_frozen_not_overflowed() {
    for cfg in configs::<Q8_24>() {
        let mut p = Pipeline::<Q8_24>::new(&SPH2, cfg).expect("model");
        let mut last = None;
        for k in 0..300_000u32 {
            let c = (2077 + (k / 200) % 1500) as u16; // a rate ramp that saturates the axis range
            last = Some(p.tick([c, 2070, 2058], 0x810));
        }
        assert_eq!(
            last.map(|r| r.event),
            Some(massid_kernel::TickEvent::FiringTooLong)
        );
        p.finish();
    }
}

#[test]
fn extreme_mixer_commands_give_statuses() {
    let cfg = MixerConfig {
        period_ms: 200,
        min_pulse_ms: 10,
        pressure_drop_n: 0.0106f32,
    };
    let m = Mixer::<f32>::new(&SPH2, [0.0; 3], cfg).expect("mixer");
    let cfgq = MixerConfig {
        period_ms: 200,
        min_pulse_ms: 10,
        pressure_drop_n: Q8_24::from_f32(0.0106),
    };
    let mq = Mixer::<Q8_24>::new(&SPH2, [Q8_24::ZERO; 3], cfgq).expect("mixer");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let specials = [
        f32::NAN,
        f32::INFINITY,
        -f32::INFINITY,
        1e30,
        -1e30,
        0.0,
        1e-30,
        5.0,
        -5.0,
    ];
    for _ in 0..3000 {
        let pick = |rng: &mut rand_chacha::ChaCha8Rng| {
            if rng.gen_bool(0.2) {
                specials[rng.gen_range(0..specials.len())]
            } else {
                rng.gen_range(-2.0f32..2.0)
            }
        };
        let f: [f32; 3] = std::array::from_fn(|_| pick(&mut rng));
        let t: [f32; 3] = std::array::from_fn(|_| pick(&mut rng) * 0.1);
        if let Ok(firing) = m.mix(f, t) {
            for i in 0..12 {
                assert!(firing.on_ms[i] <= firing.off_ms[i] && firing.off_ms[i] <= 200);
                let d = firing.off_ms[i] - firing.on_ms[i];
                assert!(d == 0 || d >= 10, "pulse shorter than the minimum");
            }
        }
        if let Ok(firing) = mq.mix(f.map(Q8_24::from_f32), t.map(Q8_24::from_f32)) {
            for i in 0..12 {
                assert!(firing.on_ms[i] <= firing.off_ms[i] && firing.off_ms[i] <= 200);
            }
        }
    }
    // Bad configurations are statuses.
    assert!(Mixer::<f32>::new(
        &SPH2,
        [0.0; 3],
        MixerConfig {
            period_ms: 15,
            min_pulse_ms: 10,
            pressure_drop_n: 0.0
        }
    )
    .is_err());
    let mut bad = SPH2;
    bad.thrust_n[3] = 0.0;
    assert!(Mixer::<f32>::new(&bad, [0.0; 3], cfg).is_err());
    bad.thrust_n[3] = f32::NAN;
    assert!(Mixer::<f32>::new(&bad, [0.0; 3], cfg).is_err());
}

#[test]
fn garbage_matrices_give_statuses_or_finite_solutions() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    for _ in 0..5000 {
        let scale = 10f32.powi(rng.gen_range(-12..12));
        let a: [[f32; 6]; 6] =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.gen_range(-1.0f32..1.0) * scale));
        let b: [f32; 6] = std::array::from_fn(|_| rng.gen_range(-1.0f32..1.0));
        if let Ok(x) = solve::<f32, 6>(&a, &b, 2f32.powi(-20)) {
            assert!(x.iter().all(|v| v.is_finite()));
        }
        let aq = a.map(|r| r.map(Q8_24::from_f32));
        let bq = b.map(Q8_24::from_f32);
        if let Ok(x) = solve::<Q8_24, 6>(&aq, &bq, Q8_24::from_int_pow2(1, -20)) {
            assert!(x.iter().all(|v| v.is_valid()));
        }
    }
}

/// The Cortex-M0 multiply path (16-bit halves) is the exact 64-bit product.
#[test]
fn multiply_by_halves_is_exact() {
    use massid_kernel::scalar::mul_32x32_by_halves;
    let edges = [
        0,
        1,
        -1,
        0xffff,
        -0xffff,
        0x10000,
        -0x10000,
        i32::MAX,
        i32::MIN,
        i32::MIN + 1,
        0x7fff_0000,
        -0x7fff_ffff,
    ];
    for &a in &edges {
        for &b in &edges {
            assert_eq!(
                mul_32x32_by_halves(a, b),
                i64::from(a) * i64::from(b),
                "{a} * {b}"
            );
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    for _ in 0..1_000_000 {
        let (a, b): (i32, i32) = (rng.gen(), rng.gen());
        assert_eq!(
            mul_32x32_by_halves(a, b),
            i64::from(a) * i64::from(b),
            "{a} * {b}"
        );
    }
}
