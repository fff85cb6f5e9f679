//! `SatelliteParams::terms` and `ModelTerms::firing_terms` (the regressors of every thruster
//! word): no panic, every derived value a valid number of the format, and the nominal
//! angular acceleration inside the envelope bound, for every word and parameters in the
//! envelope.

use super::{draw, Harness};
use crate::cover;
use crate::envelope as env;
use massid_kernel::{Scalar, Q8_24};

fn firing_terms<S: Scalar>() {
    let p = draw::params_or_sph2();
    let word = draw::word();
    let terms = p.terms::<S>();
    cover!(terms.is_ok(), "terms derived");
    let Ok(terms) = terms else {
        // The envelope's inertia box is positive definite (Gershgorin), so this is a failure.
        panic!("terms rejected inside the envelope: {:?}", terms.err());
    };
    let ft = terms.firing_terms(word);
    cover!(word & 0x0fff == 0x0fff, "all twelve open");
    cover!(word & 0x0fff == 0, "all closed");
    let all = ft.force_n.iter().chain(ft.torque_cnm.iter()).chain(ft.omega_dot_nominal.iter()).chain(ft.a_com.iter().flatten());
    for v in all {
        assert!(v.is_valid(), "invalid regressor for word {word:#x}");
    }
    for v in ft.omega_dot_nominal {
        let v = v.to_f32() as f64;
        assert!(env::within(v, env::OMEGA_DOT_RAD_S2), "omega_dot nominal {v} outside the envelope");
    }
}

#[cfg_attr(kani, kani::proof)]
pub fn firing_terms_q8_24() {
    firing_terms::<Q8_24>()
}

#[cfg_attr(kani, kani::proof)]
pub fn firing_terms_f32() {
    firing_terms::<f32>()
}

const COVERS: &[&str] = &["terms derived", "all twelve open", "all closed"];
pub const HARNESSES: [Harness; 2] = [
    Harness { name: "firing_terms_q8_24", body: firing_terms_q8_24, covers: COVERS, random_runs: 20_000, exhaustive_limit: None },
    Harness { name: "firing_terms_f32", body: firing_terms_f32, covers: COVERS, random_runs: 20_000, exhaustive_limit: None },
];
