//! Simulator speed: real-time factor of the prediction at 1 kHz output, and how the cost
//! grows with the integration step and the number of effects (ratios against the baseline
//! "nominal, 1 ms step" in the same run). `cargo bench -p massid-sim --bench speed`
//! (the crate README lists the figures and how they were measured).
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use massid_sim::effects::Truth;
use massid_sim::sensors::SensorConfig;
use massid_sim::{maneuvers, simulate, Maneuver, PredictOptions, Predictor, SimSpec};
use rand::SeedableRng;
use reference_f64::satellite::Satellite;

/// Every effect of the vocabulary at once (mass change half way).
const ALL_EFFECTS: &str = r#"{"satellite": "sph2", "effects": [
 {"effect": "thruster_latency", "params": {"open_ms": 6.3, "close_ms": 5.6}},
 {"effect": "pressure_drop", "params": {"newton_per_extra_thruster": 0.0106}},
 {"effect": "blowdown", "params": {"start_s": 4.0, "tau_s": 30.0}},
 {"effect": "thrust_scale", "params": {"scale": [1,1,1,1,1,0.7,1,1,1,1,1,1]}},
 {"effect": "com_offset", "params": {"offset_mm": [1.5, -2.0, 3.0]}},
 {"effect": "inertia", "params": {"inertia_kgm2": [0.025, 0.022, 0.02, 0.0001, 0.0002, 0.00001]}},
 {"effect": "mass_property_change", "params": {"at_s": 5.0, "offset_mm": [0, 0, 5], "inertia_kgm2": [0.03, 0.03, 0.025, 0, 0, 0]}},
 {"effect": "fuel_slosh", "params": {"freq_hz": 0.39, "damping_ratio": 0.004}},
 {"effect": "gyro_bias", "params": {"counts": [3, -2, 1]}},
 {"effect": "gyro_scale", "params": {"scale": [1.01, 0.99, 1.0]}},
 {"effect": "gyro_ringing", "params": {"freq_hz": 338.0, "decay_ms": 30.0, "apparent_hz": 38.0}},
 {"effect": "disturbance_torque", "params": {"torque_nm": [1e-5, 0, -2e-5]}}
]}"#;

fn bench(c: &mut Criterion) {
    let sat = Satellite::builtin("sph2").unwrap();
    let all = Truth::from_json_str(ALL_EFFECTS, "bench").unwrap().effects;
    // 10 s of random short-pulse combos (about 100 valve edges per second) at 1 kHz.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let words: Vec<u16> = maneuvers::combo(9.0, &mut rng)
        .into_iter()
        .take(10_000)
        .collect();
    let times: Vec<u64> = (0..words.len() as u64).collect();

    let mut g = c.benchmark_group("predict_10s_at_1kHz");
    g.sample_size(30);
    for (label, n_effects) in [
        ("nominal", 0usize),
        ("3_effects", 3),
        ("6_effects", 6),
        ("12_effects", 12),
    ] {
        let p = Predictor::new(&sat, &all[..n_effects]);
        g.bench_function(format!("{label}_step_1ms"), |b| {
            b.iter(|| {
                black_box(p.run(
                    &times,
                    &words,
                    [0.0; 3],
                    PredictOptions { max_step_ms: 1.0 },
                ))
            })
        });
    }
    let p = Predictor::new(&sat, &[]);
    for step in [0.5, 0.25, 0.1] {
        g.bench_function(format!("nominal_step_{step}ms"), |b| {
            b.iter(|| {
                black_box(p.run(
                    &times,
                    &words,
                    [0.0; 3],
                    PredictOptions { max_step_ms: step },
                ))
            })
        });
    }
    let p = Predictor::new(&sat, &all);
    g.bench_function("12_effects_step_0.1ms", |b| {
        b.iter(|| {
            black_box(p.run(
                &times,
                &words,
                [0.0; 3],
                PredictOptions { max_step_ms: 0.1 },
            ))
        })
    });
    // The baseline again: how much the machine drifted during the run.
    let p = Predictor::new(&sat, &[]);
    g.bench_function("nominal_step_1ms_repeat", |b| {
        b.iter(|| {
            black_box(p.run(
                &times,
                &words,
                [0.0; 3],
                PredictOptions { max_step_ms: 1.0 },
            ))
        })
    });
    g.finish();

    let mut g = c.benchmark_group("simulate_10s_at_1kHz");
    g.sample_size(20);
    let mut spec = SimSpec::new(sat.clone(), all.clone(), Maneuver::Combo);
    spec.seconds = Some(9.0);
    spec.sensors = SensorConfig::default();
    g.bench_function("full_6dof_sensors_12_effects", |b| {
        b.iter(|| black_box(simulate(&spec).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
