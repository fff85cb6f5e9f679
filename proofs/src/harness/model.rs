//! `SatelliteParams::terms` and `ModelTerms::firing_terms` (the regressors of every thruster
//! word): no panic, every derived value a valid number of the format, and the nominal
//! angular acceleration inside the envelope bound, for every word and parameters in the
//! envelope.

use super::{draw, Harness};
use crate::budget::Exact;
use crate::cover;
use crate::envelope as env;
use massid_kernel::Q8_24;

fn firing_terms<S: Exact>() {
    let p = draw::params_or_sph2();
    let word = draw::word();
    firing_terms_for::<S>(p, word);
}

/// Every thruster word on SPH2 (the exhaustive engine enumerates all 4096).
fn firing_terms_sph2<S: Exact>() {
    let word = crate::engine::any_in(0u16, 0x0fff);
    firing_terms_for::<S>(massid_kernel::model::SPH2, word);
}

fn firing_terms_for<S: Exact>(p: massid_kernel::model::SatelliteParams, word: u16) {
    let terms = p.terms::<S>();
    cover!(terms.is_ok(), "terms derived");
    let Ok(terms) = terms else {
        // The envelope's inertia box is positive definite (Gershgorin), so this is a failure.
        panic!("terms rejected inside the envelope: {:?}", terms.err());
    };
    for v in terms
        .inertia_inv
        .iter()
        .flatten()
        .chain(terms.lever_x_dir.iter().flatten())
        .chain(terms.theta_inertia_nominal.iter())
    {
        assert!(v.is_valid(), "a model term saturated the format");
    }
    let ft = terms.firing_terms(word);
    cover!(word & 0x0fff == 0x0fff, "all twelve open");
    cover!(word & 0x0fff == 0, "all closed");
    for v in all_outputs(&ft) {
        assert!(v.is_valid(), "invalid regressor for word {word:#x}");
    }
    for v in ft.omega_dot_nominal {
        let v = v.exact();
        assert!(
            env::within(v, env::OMEGA_DOT_RAD_S2),
            "omega_dot nominal {v} outside the envelope"
        );
    }
    // Each output equals the f64 computation from the same parameters within the rounding
    // allowance: <= 12 terms of 3 rounded factors (36 steps), x100 for cN m, x91 (largest
    // |inv(I)| entry) x 3 terms for the I^-1 products: < 2^14 steps of the format.
    let exact = exact_firing_terms(&p, word);
    let step = crate::budget::fixed_step::<S>();
    let u = if step == 0.0 {
        f32::EPSILON as f64 / 2.0
    } else {
        step
    };
    let got: Vec<f64> = all_outputs(&ft).map(|v| v.exact()).collect();
    for (k, (g, e)) in got.iter().zip(exact.iter()).enumerate() {
        let tol = 16384.0 * u * (1.0 + e.abs());
        assert!(
            (g - e).abs() <= tol,
            "word {word:#x} output {k}: {g} vs exact {e}"
        );
    }
}

fn all_outputs<S: Exact>(
    ft: &massid_kernel::model::FiringTerms<S>,
) -> impl Iterator<Item = S> + '_ {
    ft.force_n
        .iter()
        .chain(ft.torque_cnm.iter())
        .chain(ft.omega_dot_nominal.iter())
        .chain(ft.a_com.iter().flatten())
        .copied()
}

/// The firing terms in f64 straight from the parameters (force, torque in cN m, I^-1 a,
/// I^-1 \[c\]x), in the order of `all_outputs`.
pub fn exact_firing_terms(p: &massid_kernel::model::SatelliteParams, word: u16) -> Vec<f64> {
    let inv = p.inertia_inverse().expect("envelope inertia is invertible");
    let open = (word & 0x0fff).count_ones() as f64;
    let drop = p.pressure_drop_n_per_extra as f64 * (open - 1.0).max(0.0);
    let (mut c, mut a) = ([0.0f64; 3], [0.0f64; 3]);
    for i in 0..12 {
        if word & (1 << i) == 0 {
            continue;
        }
        // Clamped at zero as reference_f64 does (kernel finding 4).
        let f = (p.thrust_n[i] as f64 - drop).max(0.0);
        let d = p.thrust_dir[i].map(|v| v as f64);
        let l = [0, 1, 2].map(|k| p.thruster_pos_m[i][k] as f64 - p.com_offset_mm[k] as f64 * 1e-3);
        let lxd = [
            l[1] * d[2] - l[2] * d[1],
            l[2] * d[0] - l[0] * d[2],
            l[0] * d[1] - l[1] * d[0],
        ];
        for k in 0..3 {
            c[k] += d[k] * f;
            a[k] += lxd[k] * f;
        }
    }
    let mut out: Vec<f64> = c.to_vec();
    out.extend(a.iter().map(|v| v * 100.0));
    out.extend((0..3).map(|i| (0..3).map(|j| inv[i][j] * a[j]).sum::<f64>()));
    let cx = [[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            out.push((0..3).map(|k| inv[i][k] * cx[k][j]).sum());
        }
    }
    out
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn firing_terms_q8_24() {
    firing_terms::<Q8_24>()
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn firing_terms_f32() {
    firing_terms::<f32>()
}

/// The same harness with a deliberately too narrow format (Q4.28, range +-8): it must fail
/// (used by the test that shows the checks can fail; not in [`super::ALL`]).
pub fn firing_terms_q4_28() {
    firing_terms::<massid_kernel::Fx<fixed::types::extra::U28>>()
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn firing_terms_every_word_q8_24() {
    firing_terms_sph2::<Q8_24>()
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn firing_terms_every_word_f32() {
    firing_terms_sph2::<f32>()
}

const COVERS: &[&str] = &["terms derived", "all twelve open", "all closed"];
pub const HARNESSES: [Harness; 4] = [
    Harness {
        name: "firing_terms_every_word_q8_24",
        body: firing_terms_every_word_q8_24,
        covers: COVERS,
        random_runs: 1_000,
        exhaustive_limit: Some(4096),
    },
    Harness {
        name: "firing_terms_every_word_f32",
        body: firing_terms_every_word_f32,
        covers: COVERS,
        random_runs: 1_000,
        exhaustive_limit: Some(4096),
    },
    Harness {
        name: "firing_terms_q8_24",
        body: firing_terms_q8_24,
        covers: COVERS,
        random_runs: 20_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "firing_terms_f32",
        body: firing_terms_f32,
        covers: COVERS,
        random_runs: 20_000,
        exhaustive_limit: None,
    },
];
