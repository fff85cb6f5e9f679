//! Drawing kernel inputs from the envelope through the engine (shared by the harnesses).

use crate::engine::{any_bool, any_f64_in, any_in};
use crate::envelope as env;
use massid_kernel::model::{SatelliteParams, SPH2};

/// Satellite parameters anywhere in the envelope: thrusts, directions (main axis of SPH2's
/// thruster kept, components inside the Table C.4 spread), inertia box, CoM offset box.
pub fn params() -> SatelliteParams {
    let mut p = SPH2;
    for i in 0..12 {
        p.thrust_n[i] = any_f64_in(env::THRUST_N.0, env::THRUST_N.1) as f32;
        let main = (0..3).fold(0, |m, k| {
            if SPH2.thrust_dir[i][k].abs() > SPH2.thrust_dir[i][m].abs() {
                k
            } else {
                m
            }
        });
        for k in 0..3 {
            p.thrust_dir[i][k] = if k == main {
                SPH2.thrust_dir[i][k].signum()
                    * any_f64_in(env::DIRECTION_MAIN.0, env::DIRECTION_MAIN.1) as f32
            } else {
                any_f64_in(env::DIRECTION_OFF_AXIS.0, env::DIRECTION_OFF_AXIS.1) as f32
            };
        }
    }
    for k in 0..3 {
        p.inertia_kgm2[k] = any_f64_in(env::INERTIA_PRINCIPAL.0, env::INERTIA_PRINCIPAL.1) as f32;
        p.inertia_kgm2[3 + k] = any_f64_in(env::INERTIA_PRODUCT.0, env::INERTIA_PRODUCT.1) as f32;
        p.com_offset_mm[k] = (any_f64_in(env::COM_OFFSET_M.0, env::COM_OFFSET_M.1) * 1e3) as f32;
    }
    p.pressure_drop_n_per_extra = any_f64_in(env::PRESSURE_DROP_N.0, env::PRESSURE_DROP_N.1) as f32;
    p
}

/// Either SPH2 as compiled in, or parameters drawn from the envelope.
pub fn params_or_sph2() -> SatelliteParams {
    if any_bool() {
        SPH2
    } else {
        params()
    }
}

/// A thruster word (every 12-bit word is in the envelope; the kernel masks higher bits, so
/// those are drawn too).
pub fn word() -> u16 {
    any_in(0u16, u16::MAX)
}

/// Three gyro counts off the rails (a sample at a rail cuts the firing, so runs that should
/// reach a solve draw these most of the time).
pub fn counts_off_rail() -> [u16; 3] {
    [0; 3].map(|_| {
        any_in(
            env::GYRO_COUNTS.0.saturating_add(1),
            env::GYRO_COUNTS.1.saturating_sub(1),
        )
    })
}

/// Three gyro counts.
pub fn counts() -> [u16; 3] {
    [0; 3].map(|_| any_in(env::GYRO_COUNTS.0, env::GYRO_COUNTS.1))
}
