//! A ground model as the kernel's craft: its thruster list, the identification's wrench
//! table and the craft's mixer (the one place where `Satellite` becomes kernel tables).
use crate::HostError;
use massid_kernel::craft::{Craft, Thruster, MAX_THRUSTERS};
use massid_kernel::craft_mixer::CraftMixer;
use massid_kernel::mixer::MixerConfig;
use massid_kernel::Scalar;
use reference_f64::mixer::MIN_PULSE_MS;
use reference_f64::satellite::Satellite;

pub(crate) fn model_error(sat: &Satellite, why: String) -> HostError {
    HostError::Model {
        name: sat.name.clone(),
        why,
    }
}

/// The thrusters of `sat` (1 to 16).
pub fn thrusters(sat: &Satellite) -> Result<Vec<Thruster>, HostError> {
    let n = sat.n_thrusters();
    if n == 0 || n > MAX_THRUSTERS {
        return Err(model_error(
            sat,
            format!("{n} thrusters: the kernel takes 1-{MAX_THRUSTERS}"),
        ));
    }
    Ok((0..n)
        .map(|i| Thruster {
            pos_m: sat.thruster_pos_m[i].map(|v| v as f32),
            dir: sat.dir(i).map(|v| v as f32).into(),
            thrust_n: sat.thrust_n[i] as f32,
        })
        .collect())
}

/// The kernel's thruster table for `sat`.
pub fn craft<S: Scalar>(sat: &Satellite) -> Result<Craft<S>, HostError> {
    let com = sat.com_m();
    Craft::new(
        &thrusters(sat)?,
        [com.x as f32, com.y as f32, com.z as f32],
        sat.pressure_drop_n_per_extra as f32,
    )
    .map_err(|e| model_error(sat, format!("{e:?}")))
}

/// The kernel's mixer for `sat` with lever arms about `com_m` (m from the geometric centre;
/// `None`: the model's CoM), the seed's 10 ms minimum pulse and the model's pressure drop.
pub fn mixer<S: Scalar>(
    sat: &Satellite,
    com_m: Option<[f64; 3]>,
    period_ms: u32,
) -> Result<CraftMixer<S>, HostError> {
    let c = sat.com_m();
    let com = com_m
        .unwrap_or([c.x, c.y, c.z])
        .map(|v| S::from_f32(v as f32));
    let cfg = MixerConfig {
        period_ms,
        min_pulse_ms: MIN_PULSE_MS,
        pressure_drop_n: S::from_f32(sat.pressure_drop_n_per_extra as f32),
    };
    CraftMixer::new(&thrusters(sat)?, com, sat.planar, cfg)
        .map_err(|e| model_error(sat, format!("the kernel's mixer: {e:?}")))
}
