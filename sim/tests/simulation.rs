//! The full simulation: determinism, formats users know, sensors, artefacts, closed loop,
//! model files.
use massid_sim::maneuvers::{self, RGA_ROTATIONS, RGA_TRANSLATIONS};
use massid_sim::model_file::ModelFile;
use massid_sim::sensors::{Artefacts, SensorConfig};
use massid_sim::{predict, simulate, Maneuver, PredictOptions, SimSpec, Truth};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;
use std::path::PathBuf;

fn sph2() -> Satellite {
    Satellite::builtin("sph2").unwrap()
}

fn open(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/open")
        .join(name)
}

fn bytes(spec: &SimSpec) -> Vec<u8> {
    let mut v = Vec::new();
    simulate(spec).unwrap().recording.write_to(&mut v).unwrap();
    v
}

#[test]
fn same_seed_same_bytes_other_seed_other_bytes() {
    let truth = Truth::from_json_str(
        r#"{"satellite":"sph2","effects":[{"effect":"gyro_ringing","params":{"freq_hz":338.0,"decay_ms":30.0,"apparent_hz":38.0}}]}"#,
        "t",
    )
    .unwrap();
    let mut spec = SimSpec::new(sph2(), truth.effects, Maneuver::Combo);
    spec.seconds = Some(3.0);
    spec.seed = 11;
    spec.artefacts = Artefacts {
        gaps: 2,
        max_gap: 5,
        duplicates: 2,
    };
    let a = bytes(&spec);
    assert_eq!(a, bytes(&spec));
    spec.seed = 12;
    assert_ne!(a, bytes(&spec));
}

#[test]
fn rga12_commands_are_the_open_datas() {
    let rec = Recording::read(&open("o01_nominal_rga12.csv")).unwrap();
    let ours = maneuvers::rga12();
    assert_eq!(ours.len(), rec.samples.len());
    for s in &rec.samples {
        assert_eq!(ours[s.time_ms as usize], s.thrusters, "at {} ms", s.time_ms);
    }
}

#[test]
fn rga_pairs_are_pure_rotations_and_translations() {
    let sat = sph2();
    for (k, &(i, j)) in RGA_ROTATIONS.iter().enumerate() {
        let torque = sat.lever_arm_m(i).cross(&sat.dir(i)) + sat.lever_arm_m(j).cross(&sat.dir(j));
        let force = sat.dir(i) + sat.dir(j);
        let (axis, sign) = (k / 2, if k % 2 == 0 { 1.0 } else { -1.0 });
        assert!(
            torque[axis] * sign > 0.19,
            "rotation {k}: torque {torque:?}"
        );
        assert!(force.norm() < 0.1, "rotation {k}: force {force:?}");
    }
    for (k, &(i, j)) in RGA_TRANSLATIONS.iter().enumerate() {
        let force = sat.dir(i) + sat.dir(j);
        let torque = sat.pos_m(i).cross(&sat.dir(i)) + sat.pos_m(j).cross(&sat.dir(j));
        let (axis, sign) = (k / 2, if k % 2 == 0 { 1.0 } else { -1.0 });
        assert!(
            force[axis] * sign > 1.99,
            "translation {k}: force {force:?}"
        );
        assert!(torque.norm() < 0.01, "translation {k}: torque {torque:?}");
    }
}

#[test]
fn combo_fires_1_to_4_centred_pulses_per_period() {
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
    let w = maneuvers::combo(10.0, &mut rng);
    assert_eq!(w.len(), 1000 + 10_000 + 1500);
    for period in w[1000..11_000].chunks(maneuvers::PERIOD_MS) {
        let fired = period.iter().fold(0u16, |a, &b| a | b);
        assert!((1..=4).contains(&fired.count_ones()), "{fired:b}");
        for th in 0..12 {
            let on: Vec<usize> = (0..period.len())
                .filter(|&t| period[t] & (1 << th) != 0)
                .collect();
            if let (Some(&first), Some(&last)) = (on.first(), on.last()) {
                let width = last - first + 1;
                assert_eq!(on.len(), width, "one contiguous pulse");
                assert!(width >= 10, "minimum pulse");
                assert_eq!(first, (maneuvers::PERIOD_MS - width) / 2, "centred");
            }
        }
    }
}

#[test]
fn noise_matches_the_open_datas_generator() {
    // Rest period of o01 vs a simulated rest period: std of the counts per axis.
    let rec = Recording::read(&open("o01_nominal_rga12.csv")).unwrap();
    let mut spec = SimSpec::new(sph2(), vec![], Maneuver::Rga12);
    spec.seed = 5;
    let sim = simulate(&spec).unwrap().recording;
    let std = |r: &Recording, ch: usize| {
        let x: Vec<f64> = r.samples[..1000]
            .iter()
            .map(|s| {
                if ch < 3 {
                    s.gyro[ch] as f64
                } else {
                    s.accel[ch - 3] as f64
                }
            })
            .collect();
        let m = x.iter().sum::<f64>() / x.len() as f64;
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
    };
    for ch in 0..6 {
        let (a, b) = (std(&rec, ch), std(&sim, ch));
        // 1000 samples: the std estimate's own spread is about 2-3%.
        assert!(
            (a / b - 1.0).abs() < 0.1,
            "channel {ch}: open {a:.3} counts, simulated {b:.3}"
        );
    }
}

#[test]
fn noiseless_simulation_equals_the_prediction() {
    let mut spec = SimSpec::new(sph2(), vec![], Maneuver::Combo);
    spec.seconds = Some(5.0);
    spec.sensors = SensorConfig {
        noiseless: true,
        ..SensorConfig::default()
    };
    let out = simulate(&spec).unwrap();
    let t: Vec<u64> = (0..out.commands.len() as u64).collect();
    let p = predict(
        &spec.satellite,
        &[],
        &t,
        &out.commands,
        [0.0; 3],
        PredictOptions::default(),
    );
    for (k, s) in out.recording.samples.iter().enumerate() {
        for a in 0..3 {
            assert!((out.body_rate[k][a] - p.body_rate[k][a]).abs() < 1e-12);
            // The gyro counts are the true rate quantised: within half a count.
            let counts = spec.satellite.rad_s_to_gyro_counts(a, p.body_rate[k][a]);
            assert!((s.gyro[a] as f64 - counts).abs() <= 0.5 + 1e-9);
        }
    }
}

#[test]
fn accelerometer_reads_thrust_over_mass() {
    let sat = sph2();
    let mut spec = SimSpec::new(sat.clone(), vec![], Maneuver::Rga12);
    spec.sensors = SensorConfig {
        noiseless: true,
        ..SensorConfig::default()
    };
    let out = simulate(&spec).unwrap();
    // +x translation pair (thrusters 1 and 2) fires 13000..14000 ms.
    let s = &out.recording.samples[13_500];
    assert_eq!(s.thrusters, 0b11);
    let (force, _) = sat.force_torque_for_word(0b11);
    for a in 0..3 {
        let expected = sat.accel_bias_counts[a] + force[a] / sat.mass_kg / sat.accel_m_s2_per_count;
        assert!(
            (s.accel[a] as f64 - expected).abs() <= 0.5 + 1e-9,
            "axis {a}: {} vs {expected}",
            s.accel[a]
        );
    }
    // The satellite moves along +x: 2 x 0.11 N for 1 s on 3.5 kg gives ~0.06 m/s.
    assert!(out.final_state.pos.norm() > 0.0);
}

#[test]
fn artefacts_are_what_a_reader_counts() {
    let mut spec = SimSpec::new(sph2(), vec![], Maneuver::Combo);
    spec.seconds = Some(5.0);
    spec.artefacts = Artefacts {
        gaps: 4,
        max_gap: 20,
        duplicates: 3,
    };
    let mut text = Vec::new();
    simulate(&spec)
        .unwrap()
        .recording
        .write_to(&mut text)
        .unwrap();
    let back = Recording::from_reader(std::io::Cursor::new(text), "sim").unwrap();
    assert_eq!(back.issues.duplicates, 3);
    assert!(
        back.issues.gaps >= 1 && back.issues.gaps <= 4,
        "{:?}",
        back.issues
    );
    assert!(back.issues.missing_samples >= back.issues.gaps);
}

#[test]
fn closed_loop_follows_rate_commands_then_holds_attitude() {
    let mut spec = SimSpec::new(sph2(), vec![], Maneuver::ClosedLoop);
    spec.seconds = Some(30.0);
    let out = simulate(&spec).unwrap();
    // Legs of 3 s: +x, -x, +y, -y, +z, -z; check the end of each leg.
    for leg in 0..6 {
        let k = (leg + 1) * 3000 - 100;
        let want = if leg % 2 == 0 { 0.15 } else { -0.15 };
        let got = out.body_rate[k][leg / 2];
        // The 10 ms minimum pulse leaves a dead band of about 0.01 rad/s.
        assert!(
            (got - want).abs() < 0.02,
            "leg {leg}: rate {got}, commanded {want}"
        );
    }
    let w_end = out.body_rate.last().unwrap();
    assert!(
        w_end.iter().all(|w| w.abs() < 0.02),
        "attitude hold ends at rest: {w_end:?}"
    );
    assert!(
        out.commands[18_000..].iter().any(|&w| w != 0),
        "the hold fires thrusters"
    );
}

#[test]
fn model_file_parses_and_errors_name_file_and_line() {
    let m = ModelFile::parse(
        "satellite = \"sph2\"\n[[effects]]\neffect = \"pressure_drop\"\nparams = { newton_per_extra_thruster = 0.0106 }\n[artefacts]\ngaps = 2\nmax_gap = 3\n",
        "m.toml",
    )
    .unwrap();
    assert_eq!(m.satellite.name, "sph2");
    assert_eq!(m.effects[0].name(), "pressure_drop");
    assert_eq!(m.artefacts.gaps, 2);
    let e = ModelFile::parse(
        "satellite = \"sph2\"\n\n[[effects]]\neffect = \"warp\"\nparams = {}\n",
        "m.toml",
    )
    .unwrap_err();
    assert_eq!((e.file.as_str(), e.line), ("m.toml", 4), "{e}");
    let e = ModelFile::parse("satellite = \"sph2\"\n[[effects]]\neffect = \"blowdown\"\nparams = { start_s = 1.0, tau_s = 0.0 }\n", "m.toml")
        .unwrap_err();
    assert_eq!(e.line, 2, "{e}");
    assert!(e.reason.contains("tau_s"), "{e}");
    let e = ModelFile::parse("satellite = \"sph7\"\n", "m.toml").unwrap_err();
    assert!(
        e.to_string().starts_with("m.toml:1: unknown satellite"),
        "{e}"
    );
    let e = ModelFile::parse("satelite = \"sph2\"\n", "m.toml").unwrap_err();
    assert_eq!(e.line, 1, "{e}");
}

#[test]
fn bad_specs_are_errors_not_panics() {
    let mut spec = SimSpec::new(sph2(), vec![], Maneuver::Rga12);
    spec.rate_hz = 300.0;
    assert!(simulate(&spec).unwrap_err().to_string().contains("300"));
    spec.rate_hz = 1000.0;
    spec.seconds = Some(-1.0);
    assert!(simulate(&spec).is_err());
    spec.seconds = Some(f64::NAN);
    assert!(simulate(&spec).is_err());
}

#[test]
fn model_file_takes_an_inline_satellite() {
    let mut sat = sph2();
    sat.name = "proto".to_string();
    sat.pressure_drop_n_per_extra = 0.0106;
    let text = format!("[satellite]\n{}\n", sat.to_toml_string());
    let m = ModelFile::parse(&text, "inline.toml").unwrap();
    assert_eq!(m.satellite, sat);
    // Its pressure drop is part of the plant: a 2-thruster firing is weaker than nominal.
    let t: Vec<u64> = (0..20).collect();
    let w: Vec<u16> = t
        .iter()
        .map(|&k| if k >= 10 { (1 << 4) | (1 << 11) } else { 0 })
        .collect();
    let a = predict(
        &m.satellite,
        &[],
        &t,
        &w,
        [0.0; 3],
        PredictOptions::default(),
    )
    .angular_accel[10];
    let b = predict(&sph2(), &[], &t, &w, [0.0; 3], PredictOptions::default()).angular_accel[10];
    assert!(a[0].abs() < b[0].abs(), "{a:?} vs {b:?}");
}
