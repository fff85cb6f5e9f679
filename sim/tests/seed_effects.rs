//! Each effect pinned to the seed's numbers.
use massid_sim::effects::{Effect, FuelSlosh, GyroRinging, PressureDrop, ThrusterLatency};
use massid_sim::sensors::SensorConfig;
use massid_sim::{predict, simulate, Maneuver, PredictOptions, SimSpec};
use nalgebra::Vector3;
use reference_f64::satellite::{Satellite, SEED_PRESSURE_DROP_N_PER_EXTRA};

fn sph2() -> Satellite {
    Satellite::builtin("sph2").unwrap()
}

/// |DFT|^2 of `x` (sampled at `rate_hz`) at frequency `f`, mean removed.
fn power_at(x: &[f64], rate_hz: f64, f: f64) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let w = 2.0 * std::f64::consts::PI * f / rate_hz;
    let (mut re, mut im) = (0.0, 0.0);
    for (n, &v) in x.iter().enumerate() {
        re += (v - mean) * (w * n as f64).cos();
        im -= (v - mean) * (w * n as f64).sin();
    }
    re * re + im * im
}

/// Frequency (Hz) of the largest peak of the summed power spectra of `segments`, searched
/// in [lo, hi] with `step` Hz resolution (a direct DFT at arbitrary frequencies).
fn dft_peak(segments: &[Vec<f64>], rate_hz: f64, lo: f64, hi: f64, step: f64) -> f64 {
    let mut best = (0.0, lo);
    let n = ((hi - lo) / step).round() as usize;
    for i in 0..=n {
        let f = lo + i as f64 * step;
        let p: f64 = segments.iter().map(|x| power_at(x, rate_hz, f)).sum();
        if p > best.0 {
            best = (p, f);
        }
    }
    best.1
}

/// Where a tone of `f` shows when point-sampled at `fs`: folded into [0, fs/2].
fn folded(f: f64, fs: f64) -> f64 {
    let r = f - (f / fs).round() * fs;
    r.abs()
}

/// The simulated gyro minus the true body rate (rad/s), i.e. what the sensor adds, in
/// windows of `window_ms` after each valve shock of the RGA set, every axis (each shock
/// rings with its own phase, so the windows' power spectra are summed).
fn ringing_windows(freq_hz: f64, rate_hz: f64, window_ms: u64) -> Vec<Vec<f64>> {
    let sat = sph2();
    let ringing = Effect::GyroRinging(GyroRinging {
        freq_hz,
        decay_ms: 100.0,
        apparent_hz: GyroRinging::aliased_hz(freq_hz, rate_hz),
        amplitude_rad_s: [0.01; 3],
    });
    let mut spec = SimSpec::new(sat.clone(), vec![ringing], Maneuver::Rga12);
    spec.sensors = SensorConfig {
        noiseless: true,
        ..SensorConfig::default()
    };
    spec.rate_hz = rate_hz;
    spec.seed = 7;
    let out = simulate(&spec).unwrap();
    let s = &out.recording.samples;
    let mut windows = Vec::new();
    for k in 1..s.len() {
        if s[k].thrusters != s[k - 1].thrusters {
            for a in 0..3 {
                let w: Vec<f64> = (k..s.len())
                    .take_while(|&j| s[j].time_ms < s[k].time_ms + window_ms)
                    .map(|j| sat.gyro_counts_to_rad_s(a, s[j].gyro[a] as f64) - out.body_rate[j][a])
                    .collect();
                windows.push(w);
            }
        }
    }
    assert_eq!(windows.len(), 24 * 3, "the RGA set has 24 valve shocks");
    windows
}

#[test]
fn ringing_338_33_hz_shows_at_38_33_hz_sampled_at_100_hz() {
    let expected = folded(338.33, 100.0);
    assert!((expected - 38.33).abs() < 1e-9);
    let peak = dft_peak(&ringing_windows(338.33, 100.0, 500), 100.0, 1.0, 49.0, 0.01);
    assert!(
        (peak - expected).abs() < 0.05,
        "peak at {peak} Hz, expected {expected}"
    );
}

#[test]
fn ringing_338_55_hz_shows_at_11_45_hz_sampled_at_50_hz() {
    let expected = folded(338.55, 50.0);
    assert!((expected - 11.45).abs() < 1e-9);
    let peak = dft_peak(&ringing_windows(338.55, 50.0, 500), 50.0, 1.0, 24.0, 0.01);
    assert!(
        (peak - expected).abs() < 0.05,
        "peak at {peak} Hz, expected {expected}"
    );
}

#[test]
fn ringing_is_not_aliased_at_1_khz() {
    let peak = dft_peak(
        &ringing_windows(338.33, 1000.0, 500),
        1000.0,
        300.0,
        380.0,
        0.05,
    );
    assert!((peak - 338.33).abs() < 0.1, "peak at {peak} Hz");
}

/// One 1 s rotation about x (the RGA's first leg), then `coast_ms` of coasting.
fn x_spin_commands(coast_ms: u64) -> (Vec<u64>, Vec<u16>) {
    let n = 2000 + coast_ms;
    let t: Vec<u64> = (0..n).collect();
    let w: Vec<u16> = t
        .iter()
        .map(|&k| {
            if (1000..2000).contains(&k) {
                (1 << 4) | (1 << 11)
            } else {
                0
            }
        })
        .collect();
    (t, w)
}

#[test]
fn slosh_mode_rings_at_the_seeds_2_45_rad_s_and_decays_at_0_01_per_s() {
    // Seed App. B: H(s) = 1/(s^2 + 0.02 s + 6): poles -0.01 +/- 2.45i.
    let mode = FuelSlosh::seed_mode();
    let sat = sph2();
    let (t, w) = x_spin_commands(120_000);
    let slosh = predict(
        &sat,
        &[Effect::FuelSlosh(mode)],
        &t,
        &w,
        [0.0; 3],
        PredictOptions::default(),
    );
    let rigid = predict(&sat, &[], &t, &w, [0.0; 3], PredictOptions::default());
    // The slosh part of the body rate after the firing, decimated to 10 Hz.
    let x: Vec<f64> = (2000..t.len())
        .step_by(100)
        .map(|k| slosh.body_rate[k][0] - rigid.body_rate[k][0])
        .collect();
    let peak_hz = dft_peak(std::slice::from_ref(&x), 10.0, 0.3, 0.5, 0.0002);
    let wd = 2.0 * std::f64::consts::PI * peak_hz;
    let expected = (6.0f64 - 0.01 * 0.01).sqrt();
    assert!(
        (wd - expected).abs() < 0.01 * expected,
        "mode at {wd} rad/s, expected {expected}"
    );
    // Envelope decay: peak amplitude over the first and the last 10 s of the coast.
    let amp = |from: usize, to: usize| x[from..to].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (a1, a2) = (amp(0, 100), amp(1000, 1100));
    let sigma = (a1 / a2).ln() / 100.0;
    assert!(
        (sigma - 0.01).abs() < 0.001,
        "decay rate {sigma} 1/s, expected 0.01"
    );
}

#[test]
fn latency_shifts_rate_onsets_and_ends_by_the_set_delay() {
    let sat = sph2();
    let (t, w) = x_spin_commands(1000);
    for (open_ms, close_ms) in [(6.0, 6.0), (6.4, 3.7)] {
        let lat = Effect::ThrusterLatency(ThrusterLatency { open_ms, close_ms });
        let p = predict(&sat, &[lat], &t, &w, [0.0; 3], PredictOptions::default());
        // The first sample with thrust is the first at or after the valve opens; the rate
        // it has gained since then tells the sub-millisecond onset.
        let k_on = p.angular_accel.iter().position(|a| a[0] != 0.0).unwrap();
        let onset = k_on as f64 - p.body_rate[k_on][0] / p.angular_accel[k_on][0] * 1e3;
        assert!(
            (onset - (1000.0 + open_ms)).abs() < 1e-6,
            "onset {onset} ms for open_ms {open_ms}"
        );
        // The first sample without thrust after the firing: the rate gained during the last
        // interval tells when the valve closed.
        // (While spinning the gyroscopic term keeps a tiny acceleration after the close.)
        let k_off = k_on + p.valves_open[k_on..].iter().position(|&v| v == 0).unwrap();
        let gained = (p.body_rate[k_off][0] - p.body_rate[k_off - 1][0]) * 1e3;
        let (a_on, a_off) = (p.angular_accel[k_off - 1][0], p.angular_accel[k_off][0]);
        let end = (k_off - 1) as f64 + (gained - a_off) / (a_on - a_off);
        assert!(
            (end - (2000.0 + close_ms)).abs() < 1e-6,
            "end {end} ms for close_ms {close_ms}"
        );
        // Valves open exactly open_ms after the command.
        let first_open = p.valves_open.iter().position(|&v| v != 0).unwrap();
        assert_eq!(first_open as f64, (1000.0 + open_ms).ceil());
    }
}

#[test]
fn pressure_drop_lowers_angular_acceleration_by_the_seeds_linear_law() {
    let sat = sph2();
    let i_inv = sat.inertia_matrix().try_inverse().unwrap();
    let drop = Effect::PressureDrop(PressureDrop {
        newton_per_extra_thruster: SEED_PRESSURE_DROP_N_PER_EXTRA,
    });
    // n = 1..4 thrusters that never oppose each other.
    for thrusters in [vec![4usize], vec![4, 11], vec![4, 11, 0], vec![4, 11, 0, 2]] {
        let word: u16 = thrusters.iter().fold(0, |w, &i| w | (1 << i));
        let t: Vec<u64> = (0..20).collect();
        let w: Vec<u16> = t.iter().map(|&k| if k >= 10 { word } else { 0 }).collect();
        let nominal = predict(&sat, &[], &t, &w, [0.0; 3], PredictOptions::default());
        let dropped = predict(
            &sat,
            std::slice::from_ref(&drop),
            &t,
            &w,
            [0.0; 3],
            PredictOptions::default(),
        );
        let n = thrusters.len() as f64;
        // Each open thruster loses 0.0106 N per other open thruster: the torque loses
        // 0.0106 (n - 1) sum_i (L_i x D_i).
        let unit_torques: Vector3<f64> = thrusters
            .iter()
            .map(|&i| sat.lever_arm_m(i).cross(&sat.dir(i)))
            .fold(Vector3::zeros(), |a, b| a + b);
        let expected_loss = i_inv * unit_torques * (SEED_PRESSURE_DROP_N_PER_EXTRA * (n - 1.0));
        let a_nom = Vector3::from(nominal.angular_accel[10]);
        let a_drop = Vector3::from(dropped.angular_accel[10]);
        let loss = a_nom - a_drop;
        assert!(
            (loss - expected_loss).norm() <= 1e-12 + 1e-9 * expected_loss.norm(),
            "n = {n}: loss {loss:?} expected {expected_loss:?}"
        );
        if n == 1.0 {
            assert_eq!(loss.norm(), 0.0);
        } else {
            assert!(loss.norm() > 0.0);
        }
    }
}
