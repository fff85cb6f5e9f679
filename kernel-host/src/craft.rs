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

/// Budgets for the kernel mixer's pulse fractions against the f64 reference, as fractions of
/// the period: twice the worst deviation measured on the example craft over 300 reachable
/// commands each (`tests/tests/kernel_mixer_any_craft.rs`: f32 3.2e-6, Q8.24 2.4e-5).
pub const MIXER_BUDGET_F32: f64 = 1e-5;
/// See [`MIXER_BUDGET_F32`].
pub const MIXER_BUDGET_Q8_24: f64 = 5e-5;

/// The largest |kernel - reference| pulse fraction (of the period) over `commands` (force N,
/// torque N m), with the command it occurred on; `Err` when the kernel refuses a command
/// the reference mixes (or the craft altogether). Commands the reference refuses are skipped.
pub fn mixer_deviation<S: Scalar>(
    sat: &Satellite,
    commands: &[([f64; 3], [f64; 3])],
    period_ms: u32,
) -> Result<(f64, usize), HostError> {
    use nalgebra::Vector3;
    let r = reference_f64::mixer::Mixer::from_satellite(sat, None, period_ms)
        .map_err(|e| model_error(sat, format!("the reference mixer: {e}")))?;
    let k = mixer::<S>(sat, None, period_ms)?;
    let p = f64::from(period_ms);
    let mut worst = (0.0, 0);
    for (j, (f, t)) in commands.iter().enumerate() {
        let Ok(tr) = r.mix_traced(Vector3::from(*f), Vector3::from(*t)) else {
            continue;
        };
        let frac = k
            .pulse_fractions(
                f.map(|v| S::from_f32(v as f32)),
                t.map(|v| S::from_f32(v as f32)),
            )
            .map_err(|e| {
                model_error(
                    sat,
                    format!("the kernel's mixer refuses force {f:?} torque {t:?}: {e:?}"),
                )
            })?;
        for (i, (kf, rd)) in frac.iter().zip(tr.corrected_ms.iter()).enumerate() {
            if i < sat.n_thrusters() {
                let dev = (f64::from(kf.to_f32()) - rd / p).abs();
                if dev > worst.0 {
                    worst = (dev, j);
                }
            }
        }
    }
    Ok(worst)
}

/// Pure-axis commands (both signs of every axis the craft controls) at half the largest the
/// reference mixer delivers unscaled: the probes of `massid model check`.
pub fn axis_probes(sat: &Satellite, period_ms: u32) -> Vec<([f64; 3], [f64; 3])> {
    use nalgebra::Vector3;
    let Ok(r) = reference_f64::mixer::Mixer::from_satellite(sat, None, period_ms) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for &axis in r.geometry().axes() {
        for sign in [1.0, -1.0] {
            let mut c = [0.0; 6];
            c[axis] = sign * 1e3;
            let (f, t) = ([c[0], c[1], c[2]], [c[3], c[4], c[5]]);
            if let Ok(tr) = r.mix_traced(Vector3::from(f), Vector3::from(t)) {
                let s = 0.5 * tr.scale;
                out.push((f.map(|v| v * s), t.map(|v| v * s)));
            }
        }
    }
    out
}
