//! Differential: the kernel's per-word regressors (`ModelTerms::firing_terms`) in f32 and
//! Q8.24 against `reference_f64` (force/torque, nominal angular acceleration, CoM rows) for
//! EVERY thruster word on every built-in satellite, and on random satellites of the
//! envelope (proptest). Budgets from `massid_proofs::budget`.

use massid_kernel::model::SatelliteParams;
use massid_kernel::Q8_24;
use massid_proofs::budget::{fmt_of, Exact, Worst};
use nalgebra::Vector3;
use proptest::prelude::*;
use reference_f64::mass_id::com_row;
use reference_f64::omega_dot::nominal_omega_dot;
use reference_f64::satellite::Satellite;

/// The same satellite on both sides: the reference's fields rounded to the kernel's f32
/// parameter type (so only the kernel's own arithmetic differs).
fn pair(mut sat: Satellite) -> (Satellite, SatelliteParams) {
    let r = |v: f64| v as f32;
    let p = SatelliteParams {
        thruster_pos_m: std::array::from_fn(|i| sat.thruster_pos_m[i].map(r)),
        thrust_dir: std::array::from_fn(|i| sat.thrust_dir[i].map(r)),
        thrust_n: std::array::from_fn(|i| r(sat.thrust_n[i])),
        inertia_kgm2: sat.inertia_kgm2.map(r),
        com_offset_mm: sat.com_offset_mm.map(r),
        gyro_counts_per_rad_s: sat.gyro_counts_per_rad_s.map(r),
        pressure_drop_n_per_extra: r(sat.pressure_drop_n_per_extra),
    };
    let b = |v: f32| v as f64;
    sat.thruster_pos_m = p.thruster_pos_m.map(|a| a.map(b)).to_vec();
    sat.thrust_dir = p.thrust_dir.map(|a| a.map(b)).to_vec();
    sat.thrust_n = p.thrust_n.map(b).to_vec();
    sat.inertia_kgm2 = p.inertia_kgm2.map(b);
    sat.com_offset_mm = p.com_offset_mm.map(b);
    sat.pressure_drop_n_per_extra = b(p.pressure_drop_n_per_extra);
    (sat, p)
}

struct Worsts([Worst; 4]);
impl Worsts {
    fn new() -> Self {
        Worsts(
            [
                "firing.force_n",
                "firing.torque_cnm",
                "firing.omega_dot_nominal",
                "firing.a_com",
            ]
            .map(Worst::new),
        )
    }
}

/// True when the pressure drop would make an open thruster's thrust negative: the
/// reference clamps it at zero, the kernel (so far) does not (reported to the kernel owner;
/// the comparison of these words is the separate, currently ignored, test below).
fn drop_exceeds_thrust(sat: &Satellite, word: u16) -> bool {
    let open = (word & 0x0fff).count_ones() as f64;
    (0..12).any(|i| {
        word & (1 << i) != 0 && sat.thrust_n[i] - (open - 1.0) * sat.pressure_drop_n_per_extra < 0.0
    })
}

fn compare_word<S: Exact>(
    sat: &Satellite,
    p: &SatelliteParams,
    word: u16,
    w: &mut Worsts,
) -> Result<(), String> {
    let fmt = fmt_of::<S>();
    let terms = p.terms::<S>().map_err(|e| format!("{e:?}"))?;
    let ft = terms.firing_terms(word);
    let (c, tau) = sat.force_torque_for_word(word);
    let od = nominal_omega_dot(sat, word, Vector3::zeros());
    let (a1, _) = com_row(sat, word, &Vector3::zeros(), &Vector3::zeros());
    for i in 0..3 {
        w.0[0].record(fmt, ft.force_n[i].exact(), c[i], 0.0)?;
        w.0[1].record(fmt, ft.torque_cnm[i].exact(), tau[i] * 100.0, 0.0)?;
        w.0[2].record(fmt, ft.omega_dot_nominal[i].exact(), od[i], 0.0)?;
        for j in 0..3 {
            w.0[3].record(fmt, ft.a_com[i][j].exact(), a1[(i, j)], 0.0)?;
        }
    }
    Ok(())
}

fn every_word<S: Exact>(include_negative_thrust: bool) -> usize {
    let mut w = Worsts::new();
    let mut skipped = 0;
    for name in ["sph1", "sph2", "sph3", "sph4", "sph5"] {
        let mut sat = Satellite::builtin(name).expect("built-in");
        for drop in [0.0, 0.0106] {
            sat.pressure_drop_n_per_extra = drop;
            let (sat, p) = pair(sat.clone());
            for word in 0u16..=0x0fff {
                if drop_exceeds_thrust(&sat, word) && !include_negative_thrust {
                    skipped += 1;
                    continue;
                }
                compare_word::<S>(&sat, &p, word, &mut w)
                    .unwrap_or_else(|e| panic!("{name} word {word:#05x}: {e}"));
            }
        }
    }
    for x in &w.0 {
        println!(
            "{:?} every word x 5 satellites x 2 drops: {x}",
            fmt_of::<S>()
        );
    }
    println!("skipped {skipped} (satellite, word) pairs where the drop exceeds a thrust");
    skipped
}

#[test]
fn every_word_every_builtin_satellite_q8_24() {
    every_word::<Q8_24>(false);
}

#[test]
fn every_word_every_builtin_satellite_f32() {
    every_word::<f32>(false);
}

/// Words whose pressure drop would make a thrust negative: the kernel clamps it at zero as
/// the reference does (kernel finding 4, fixed).
#[test]
fn words_where_the_drop_exceeds_a_thrust_match_the_reference() {
    every_word::<Q8_24>(true);
    every_word::<f32>(true);
}

fn envelope_satellite() -> impl Strategy<Value = Satellite> {
    use massid_proofs::envelope as env;
    (
        prop::array::uniform12(env::THRUST_N.0..=env::THRUST_N.1),
        prop::array::uniform3(env::INERTIA_PRINCIPAL.0..=env::INERTIA_PRINCIPAL.1),
        prop::array::uniform3(env::INERTIA_PRODUCT.0..=env::INERTIA_PRODUCT.1),
        prop::array::uniform3(env::COM_OFFSET_M.0..=env::COM_OFFSET_M.1),
        env::PRESSURE_DROP_N.0..=env::PRESSURE_DROP_N.1,
        prop::array::uniform12(prop::array::uniform3(
            env::DIRECTION_OFF_AXIS.0..=env::DIRECTION_OFF_AXIS.1,
        )),
    )
        .prop_map(|(thrust, pr, prod, com, drop, tilt)| {
            let mut s = Satellite::builtin("sph2").expect("built-in");
            s.thrust_n = thrust.to_vec();
            s.inertia_kgm2 = [pr[0], pr[1], pr[2], prod[0], prod[1], prod[2]];
            s.com_offset_mm = com.map(|v| v * 1e3);
            s.pressure_drop_n_per_extra = drop;
            for i in 0..12 {
                for k in 0..3 {
                    if s.thrust_dir[i][k].abs() < 0.5 {
                        s.thrust_dir[i][k] = tilt[i][k];
                    }
                }
            }
            s
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_0001), failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn random_envelope_satellites_any_word(sat in envelope_satellite(), words in prop::collection::vec(0u16..=0x0fff, 16)) {
        let (sat, p) = pair(sat);
        let (mut wq, mut wf) = (Worsts::new(), Worsts::new());
        for word in words {
            if drop_exceeds_thrust(&sat, word) {
                continue;
            }
            compare_word::<Q8_24>(&sat, &p, word, &mut wq).map_err(TestCaseError::fail)?;
            compare_word::<f32>(&sat, &p, word, &mut wf).map_err(TestCaseError::fail)?;
        }
    }
}
