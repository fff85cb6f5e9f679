//! Every effect does what the contract's table says, checked against the satellite's
//! geometry from first principles (angular acceleration at rest = I^-1 sum L_i x F_i).
use massid_sim::effects::*;
use massid_sim::{predict, PredictOptions, Truth};
use nalgebra::{Matrix3, Vector3};
use reference_f64::satellite::Satellite;

fn sph2() -> Satellite {
    Satellite::builtin("sph2").unwrap()
}

fn inertia(m: [f64; 6]) -> Matrix3<f64> {
    let [xx, yy, zz, xy, xz, yz] = m;
    Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
}

/// Angular acceleration right after `word` is commanded at t_ms (from rest).
fn alpha(effects: &[Effect], word: u16, t_ms: u64) -> Vector3<f64> {
    let t: Vec<u64> = vec![0, t_ms, t_ms + 1];
    let w = vec![0, word, word];
    Vector3::from(
        predict(
            &sph2(),
            effects,
            &t,
            &w,
            [0.0; 3],
            PredictOptions::default(),
        )
        .angular_accel[1],
    )
}

/// I^-1 sum over `word`'s thrusters of (pos - com) x dir * force, force per thruster given.
fn expected(
    sat: &Satellite,
    i_true: Matrix3<f64>,
    com: Vector3<f64>,
    word: u16,
    force: impl Fn(usize) -> f64,
) -> Vector3<f64> {
    let tau = (0..12)
        .filter(|i| word & (1 << i) != 0)
        .map(|i| (sat.pos_m(i) - com).cross(&sat.dir(i)) * force(i))
        .fold(Vector3::zeros(), |a, b| a + b);
    i_true.try_inverse().unwrap() * tau
}

fn close(a: Vector3<f64>, b: Vector3<f64>) -> bool {
    (a - b).norm() <= 1e-12 + 1e-9 * b.norm()
}

const WORD: u16 = 0b0000_0010_0101; // thrusters 1, 3, 6

#[test]
fn nominal_is_the_rigid_body_of_the_model() {
    let sat = sph2();
    let e = expected(&sat, sat.inertia_matrix(), sat.com_m(), WORD, |i| {
        sat.thrust_n[i]
    });
    assert!(close(alpha(&[], WORD, 10), e));
}

#[test]
fn blowdown_scales_all_thrust_by_the_exponential_after_start() {
    let sat = sph2();
    let b = Effect::Blowdown(Blowdown {
        start_s: 2.0,
        tau_s: 30.0,
    });
    let nominal = alpha(&[], WORD, 10);
    assert!(close(alpha(std::slice::from_ref(&b), WORD, 1000), nominal));
    let a = alpha(&[b], WORD, 12_000);
    assert!(close(a, nominal * (-(12.0 - 2.0) / 30.0f64).exp()), "{a:?}");
    let _ = sat;
}

#[test]
fn thrust_scale_multiplies_each_thruster_and_zero_is_dead() {
    let sat = sph2();
    let mut scale = [1.0; 12];
    scale[5] = 0.7;
    scale[0] = 0.0;
    let e = Effect::ThrustScale(ThrustScale {
        scale: scale.to_vec(),
    });
    let want = expected(&sat, sat.inertia_matrix(), sat.com_m(), WORD, |i| {
        sat.thrust_n[i] * scale[i]
    });
    assert!(close(alpha(std::slice::from_ref(&e), WORD, 10), want));
    assert_eq!(alpha(&[e], 1, 10).norm(), 0.0, "thruster 1 is dead");
}

#[test]
fn com_offset_moves_the_lever_arms() {
    let sat = sph2();
    let off = [1.5, -2.0, 3.0];
    let e = Effect::ComOffset(ComOffset { offset_mm: off });
    let com = sat.com_m() + Vector3::from(off) * 1e-3;
    // A pure +x translation pair turns when the CoM is off its line of action.
    let want = expected(&sat, sat.inertia_matrix(), com, 0b11, |i| sat.thrust_n[i]);
    assert!(close(alpha(&[e], 0b11, 10), want));
}

#[test]
fn inertia_replaces_the_inertia_matrix() {
    let sat = sph2();
    let m = [0.03, 0.025, 0.02, 0.0002, -0.0001, 0.00005];
    let want = expected(&sat, inertia(m), sat.com_m(), WORD, |i| sat.thrust_n[i]);
    assert!(close(
        alpha(&[Effect::Inertia(Inertia { inertia_kgm2: m })], WORD, 10),
        want
    ));
}

#[test]
fn mass_property_change_applies_from_at_s() {
    let sat = sph2();
    let m = [0.03, 0.03, 0.025, 0.0, 0.0, 0.0];
    let e = Effect::MassPropertyChange(MassPropertyChange {
        at_s: 5.0,
        offset_mm: [0.0, 0.0, 5.0],
        inertia_kgm2: m,
    });
    assert!(close(
        alpha(std::slice::from_ref(&e), WORD, 4000),
        alpha(&[], WORD, 4000)
    ));
    let com = sat.com_m() + Vector3::new(0.0, 0.0, 5e-3);
    let want = expected(&sat, inertia(m), com, WORD, |i| sat.thrust_n[i]);
    assert!(close(alpha(&[e], WORD, 6000), want));
}

#[test]
fn disturbance_torque_accelerates_without_thrust() {
    let sat = sph2();
    let tau = [1e-5, 0.0, -2e-5];
    let d = [Effect::DisturbanceTorque(DisturbanceTorque {
        torque_nm: tau,
    })];
    // At the first instant, still at rest (no gyroscopic term yet).
    let a = Vector3::from(
        predict(
            &sat,
            &d,
            &[0, 1],
            &[0, 0],
            [0.0; 3],
            PredictOptions::default(),
        )
        .angular_accel[0],
    );
    assert!(close(
        a,
        sat.inertia_matrix().try_inverse().unwrap() * Vector3::from(tau)
    ));
}

#[test]
fn gyro_bias_and_scale_change_what_the_gyro_reads_not_the_body() {
    let sat = sph2();
    let effects = [
        Effect::GyroBias(GyroBias {
            counts: [3.0, -2.0, 1.0],
        }),
        Effect::GyroScale(GyroScale {
            scale: [1.01, 0.99, 1.0],
        }),
    ];
    let t: Vec<u64> = (0..600).collect();
    let w: Vec<u16> = t.iter().map(|&k| if k >= 100 { WORD } else { 0 }).collect();
    let p = predict(&sat, &effects, &t, &w, [0.0; 3], PredictOptions::default());
    let q = predict(&sat, &[], &t, &w, [0.0; 3], PredictOptions::default());
    for k in [0usize, 599] {
        for a in 0..3 {
            assert_eq!(p.body_rate[k][a], q.body_rate[k][a]);
            let want = [1.01, 0.99, 1.0][a] * q.body_rate[k][a]
                + [3.0, -2.0, 1.0][a] / sat.gyro_counts_per_rad_s[a];
            assert!((p.gyro_rad_s[k][a] - want).abs() < 1e-15);
        }
    }
}

#[test]
fn effects_compose_in_list_order_independently() {
    // Delays add, scales multiply: two half-latencies are one latency.
    let half = Effect::ThrusterLatency(ThrusterLatency {
        open_ms: 3.0,
        close_ms: 2.5,
    });
    let full = Effect::ThrusterLatency(ThrusterLatency {
        open_ms: 6.0,
        close_ms: 5.0,
    });
    let sat = sph2();
    let t: Vec<u64> = (0..100).collect();
    let w: Vec<u16> = t
        .iter()
        .map(|&k| if (10..50).contains(&k) { WORD } else { 0 })
        .collect();
    let a = predict(
        &sat,
        &[half.clone(), half],
        &t,
        &w,
        [0.0; 3],
        PredictOptions::default(),
    );
    let b = predict(&sat, &[full], &t, &w, [0.0; 3], PredictOptions::default());
    assert_eq!(a.body_rate, b.body_rate);
}

#[test]
fn one_millisecond_steps_agree_with_tenth_of_a_millisecond_steps() {
    // Thrust is constant inside every step (steps are cut at valve edges), so RK4's error
    // is that of the smooth rotation only: far below the gyro's 0.0007 rad/s count.
    let text = r#"{"satellite": "sph2", "effects": [
     {"effect": "thruster_latency", "params": {"open_ms": 6.3, "close_ms": 5.6}},
     {"effect": "blowdown", "params": {"start_s": 2.0, "tau_s": 30.0}},
     {"effect": "fuel_slosh", "params": {"freq_hz": 0.39, "damping_ratio": 0.004}},
     {"effect": "mass_property_change", "params": {"at_s": 3.0, "offset_mm": [0, 0, 5], "inertia_kgm2": [0.03, 0.03, 0.025, 0, 0, 0]}}
    ]}"#;
    let effects = Truth::from_json_str(text, "t").unwrap().effects;
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(9);
    let w = massid_sim::maneuvers::combo(5.0, &mut rng);
    let t: Vec<u64> = (0..w.len() as u64).collect();
    let coarse = predict(
        &sph2(),
        &effects,
        &t,
        &w,
        [0.0; 3],
        PredictOptions { max_step_ms: 1.0 },
    );
    let fine = predict(
        &sph2(),
        &effects,
        &t,
        &w,
        [0.0; 3],
        PredictOptions { max_step_ms: 0.1 },
    );
    let worst = coarse
        .body_rate
        .iter()
        .zip(&fine.body_rate)
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "max difference {worst} rad/s");
}
