//! Issue 24 item 3: a noise model per rate sensor. Our simulator flies craft that are not
//! the README's air-bearing model alone (the 3-D 8-thruster cubesat of
//! `examples/models/cubesat8.toml`, and the planar air-bearing craft) with three rate
//! sensors: a white gyro, a band-limited gyro (first-order Gauss-Markov) and rates
//! differenced from motion-capture attitude (`[sensors] rate_sensor =
//! "differenced_attitude"`: attitude noise differenced over one sample plus white noise).
//! A nominal flight must report no effect and nothing `unexplained`; the same flight with a
//! residual 1.3x the noise that no effect of the vocabulary makes (a rate offset that
//! wanders with a 2 s time constant, where the vocabulary has only a constant gyro bias)
//! must be reported `unexplained`. The noise model's kind must be the sensor's.
//!
//! `noise_monte_carlo` (ignored; `--ignored --nocapture`) is the Monte Carlo of the README.

mod noise_flights;

use noise_flights::{diagnose, kind_of, noise_rms, summary, Flight, Sensor};

const CUBESAT_DIFF: Flight = Flight {
    model: "cubesat8.toml",
    rate_hz: 100.0,
    sensor: Sensor::Differenced,
    level: 1.0,
    seconds: 30.0,
    seed: 3,
    excess: 1.0,
};

const PLANAR_DIFF: Flight = Flight {
    model: "airbearing-mpc.toml",
    rate_hz: 50.0,
    sensor: Sensor::Differenced,
    level: 1.0,
    seconds: 60.0,
    seed: 3,
    excess: 1.0,
};

fn nominal_reports_nothing(f: &Flight) {
    let out = diagnose(f);
    eprintln!("{f:?}: {}", summary(&out));
    let noise = out.noise.as_ref().expect("the noise model is reported");
    assert_eq!(noise.kind, kind_of(f.sensor), "{}", summary(&out));
    assert!(out.effects.is_empty(), "{}", summary(&out));
    assert!(out.unexplained.is_none(), "{}", summary(&out));
}

fn excess_is_flagged(f: &Flight) {
    let f = Flight { excess: 1.3, ..*f };
    let out = diagnose(&f);
    eprintln!("{f:?}: {}", summary(&out));
    assert!(
        out.unexplained.is_some(),
        "a residual 1.3x the noise must be reported: {}",
        summary(&out)
    );
}

/// (a) A nominal 3-D flight with differenced-attitude rates: no effect, nothing unexplained.
#[test]
fn nominal_cubesat_with_differenced_attitude_rates_reports_nothing() {
    nominal_reports_nothing(&CUBESAT_DIFF);
}

/// (a) The same on the planar air-bearing craft.
#[test]
fn nominal_planar_flight_with_differenced_attitude_rates_reports_nothing() {
    nominal_reports_nothing(&PLANAR_DIFF);
}

/// (b) A residual 1.3x the noise that no effect makes is reported (3-D craft).
#[test]
fn a_residual_1_3x_the_noise_is_reported_on_the_cubesat() {
    excess_is_flagged(&CUBESAT_DIFF);
}

/// (b) The same on the planar craft.
#[test]
fn a_residual_1_3x_the_noise_is_reported_on_the_planar_craft() {
    excess_is_flagged(&PLANAR_DIFF);
}

/// A band-limited gyro whose correlation outlasts 12 ms (the lag the variance was read at
/// before): its level is read right, so an exactly explained flight is not flagged.
#[test]
fn slow_band_limited_gyro_is_not_flagged() {
    let f = Flight {
        sensor: Sensor::BandLimited,
        rate_hz: 250.0,
        seconds: 20.0,
        ..CUBESAT_DIFF
    };
    let out = diagnose(&f);
    eprintln!("{f:?}: {}", summary(&out));
    let n = out.noise.as_ref().expect("noise");
    let want = noise_rms(&f);
    // within three of its own standard errors (the old 12 ms rule reads such a gyro 10-15 %
    // low: noise.rs, a_slow_gyro_is_not_read_low)
    for a in 0..3 {
        assert!(
            (n.rms[a] / want - 1.0).abs() < 3.0 * n.rms_rel_se,
            "axis {a}: noise {} +- {:.1} % against {want}",
            n.rms[a],
            100.0 * n.rms_rel_se
        );
    }
    nominal_reports_nothing(&f);
}

/// Monte Carlo over conditions not tuned on (README, "A noise model per rate sensor").
#[test]
#[ignore]
fn noise_monte_carlo() {
    let crafts = [
        ("airbearing-mpc.toml", [25.0, 100.0]),
        ("cubesat8.toml", [50.0, 250.0]),
    ];
    let mut rows = vec![];
    for (model, rates) in crafts {
        for rate_hz in rates {
            for sensor in [Sensor::White, Sensor::BandLimited, Sensor::Differenced] {
                for level in [1.0, 3.0] {
                    for seed in [11u64, 12] {
                        for excess in [1.0, 1.3] {
                            if excess > 1.0 && level > 1.0 {
                                continue;
                            }
                            let f = Flight {
                                model,
                                rate_hz,
                                sensor,
                                level,
                                seconds: 30.0,
                                seed,
                                excess,
                            };
                            let t = std::time::Instant::now();
                            let out = diagnose(&f);
                            let named: Vec<String> =
                                out.effects.iter().map(|e| e.effect.clone()).collect();
                            let kind = out.noise.as_ref().map(|n| n.kind);
                            println!(
                                "{model} {rate_hz} Hz {sensor:?} x{level} seed {seed} excess {excess}: kind {kind:?} named {named:?} unexplained {} ({:.1} s)",
                                out.unexplained.is_some(),
                                t.elapsed().as_secs_f64()
                            );
                            rows.push((f, kind, named, out.unexplained.is_some()));
                        }
                    }
                }
            }
        }
    }
    let nominal: Vec<_> = rows.iter().filter(|r| r.0.excess == 1.0).collect();
    let excess: Vec<_> = rows.iter().filter(|r| r.0.excess > 1.0).collect();
    let fp_unexpl = nominal.iter().filter(|r| r.3).count();
    let fp_named = nominal.iter().filter(|r| !r.2.is_empty()).count();
    let kind_right = rows
        .iter()
        .filter(|r| r.1 == Some(kind_of(r.0.sensor)))
        .count();
    let detected = excess.iter().filter(|r| r.3).count();
    println!(
        "nominal {}: unexplained {fp_unexpl}, named effects {fp_named}; 1.3x: {}/{} reported; kind right {kind_right}/{}",
        nominal.len(),
        detected,
        excess.len(),
        rows.len()
    );
}
