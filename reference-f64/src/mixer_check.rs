//! What a mixed firing really delivers, against what was commanded: the average force and
//! torque of the integer-millisecond firing over the control period, side by side with the
//! command, and a warning for every way the two differ (the mixer's job is a command, and a
//! user acts on the assumption that it was met).

use crate::mixer::{MixTrace, Mixer};
use crate::satellite::Satellite;
use nalgebra::Vector3;

/// A delivered error on any axis above this fraction of the (scaled) command's magnitude is
/// reported: the seed's 1 ms resolution and 10 ms minimum pulse make a few per cent normal.
pub const CROSS_AXIS_WARN: f64 = 0.05;

/// Why a delivery differs from its command.
#[derive(Clone, Debug, PartialEq)]
pub enum MixWarning {
    /// The command was beyond the thrusters' reach and scaled down (direction kept).
    Scaled { scale: f64 },
    /// Thrusters whose pulse was shorter than the minimum and not fired (1-based).
    BelowMinimumPulse {
        thrusters: Vec<usize>,
        min_pulse_ms: u32,
    },
    /// A non-zero command fired nothing at all.
    NothingFired,
    /// The delivered force or torque misses the (scaled) command by more than
    /// [`CROSS_AXIS_WARN`] of its magnitude on some axis (of the fired thrusters' total
    /// output when that command is zero).
    AxisError {
        what: &'static str,
        axis: usize,
        error: f64,
        of_command: f64,
    },
}

impl std::fmt::Display for MixWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MixWarning::Scaled { scale } => write!(f, "command beyond the thrusters' reach: scaled to {:.4} % of it (direction kept)", scale * 100.0),
            MixWarning::BelowMinimumPulse { thrusters, min_pulse_ms } => {
                write!(f, "thruster(s) {thrusters:?} needed less than the {min_pulse_ms} ms minimum pulse and were not fired")
            }
            MixWarning::NothingFired => write!(f, "nothing fired: every pulse was below the minimum"),
            MixWarning::AxisError { what, axis, error, of_command } => write!(
                f,
                "{what} {} delivered {error:+.3e} off the command ({:.0} % of its size; warned above {:.0} %)",
                ["x", "y", "z"][*axis],
                of_command * 100.0,
                CROSS_AXIS_WARN * 100.0
            ),
        }
    }
}

/// A firing's delivery against its command.
#[derive(Clone, Debug)]
pub struct Delivery {
    /// Commanded force (N) and torque about the CoM (N m).
    pub commanded_force_n: Vector3<f64>,
    pub commanded_torque_nm: Vector3<f64>,
    /// Average over the control period of what the firing delivers (no pressure drop).
    pub delivered_force_n: Vector3<f64>,
    pub delivered_torque_nm: Vector3<f64>,
    pub warnings: Vec<MixWarning>,
}

/// Compares the firing of `trace` (from `mixer.mix_traced(force, torque)`) with its command.
pub fn check(
    mixer: &Mixer,
    trace: &MixTrace,
    force: Vector3<f64>,
    torque: Vector3<f64>,
) -> Delivery {
    let firing = &trace.firing;
    let period_s = f64::from(firing.period_ms.max(1)) * 1e-3;
    let (jf, jt) = firing.impulse(mixer.geometry());
    let (df, dt) = (jf / period_s, jt / period_s);
    let mut warnings = Vec::new();
    if firing.scale < 1.0 {
        warnings.push(MixWarning::Scaled {
            scale: firing.scale,
        });
    }
    let dropped: Vec<usize> = (0..mixer.geometry().described)
        .filter(|&i| trace.corrected_ms[i] > 0.0 && firing.duration_ms(i) == 0)
        .map(|i| i + 1)
        .collect();
    let fired = (0..mixer.geometry().described).any(|i| firing.duration_ms(i) > 0);
    let commanded = force.norm() > 0.0 || torque.norm() > 0.0;
    if commanded && !fired {
        warnings.push(MixWarning::NothingFired);
    }
    if !dropped.is_empty() {
        warnings.push(MixWarning::BelowMinimumPulse {
            thrusters: dropped,
            min_pulse_ms: firing.min_pulse_ms,
        });
    }
    if fired {
        // What the fired thrusters produce in total, each at its own duty: the scale of an
        // error against a zero command (a pure torque must not push the craft).
        let g = mixer.geometry();
        let duty = |i: usize| f64::from(firing.duration_ms(i)) * 1e-3 / period_s;
        let gross_force: f64 = (0..mixer.geometry().described)
            .map(|i| g.force_n[i].norm() * duty(i))
            .sum();
        let gross_torque: f64 = (0..mixer.geometry().described)
            .map(|i| g.torque_nm(i).norm() * duty(i))
            .sum();
        for (what, cmd, got, gross) in [
            ("force", force * firing.scale, df, gross_force),
            ("torque", torque * firing.scale, dt, gross_torque),
        ] {
            let size = cmd.norm();
            for axis in 0..3 {
                let error = got[axis] - cmd[axis];
                let reference = if size > 0.0 { size } else { gross };
                if error.abs() > CROSS_AXIS_WARN * reference {
                    warnings.push(MixWarning::AxisError {
                        what,
                        axis,
                        error,
                        of_command: error.abs() / reference,
                    });
                }
            }
        }
    }
    Delivery {
        commanded_force_n: force,
        commanded_torque_nm: torque,
        delivered_force_n: df,
        delivered_torque_nm: dt,
        warnings,
    }
}

/// The CoM estimate must lie inside the craft: within [`Satellite::reach_m`], the envelope
/// `mass_id::physical_validity` checks too. `Err` says where it is and how far the craft
/// reaches.
pub fn com_inside(sat: &Satellite, com_m: &Vector3<f64>) -> Result<(), String> {
    let reach = sat.reach_m();
    if com_m.norm() <= reach {
        return Ok(());
    }
    Err(format!(
        "CoM ({:.1}, {:.1}, {:.1}) mm is {:.1} mm from the centre, outside the craft (its \
         farthest thruster is {:.1} mm out)",
        com_m[0] * 1e3,
        com_m[1] * 1e3,
        com_m[2] * 1e3,
        com_m.norm() * 1e3,
        reach * 1e3
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mixer::DEFAULT_PERIOD_MS;

    fn deliver(force: [f64; 3], torque: [f64; 3]) -> Delivery {
        let sat = Satellite::builtin("sph2").expect("sph2");
        let mixer = Mixer::from_satellite(&sat, None, DEFAULT_PERIOD_MS).expect("mixer");
        let (f, t) = (Vector3::from(force), Vector3::from(torque));
        let trace = mixer.mix_traced(f, t).expect("mix");
        check(&mixer, &trace, f, t)
    }

    fn has(d: &Delivery, p: impl Fn(&MixWarning) -> bool) -> bool {
        d.warnings.iter().any(p)
    }

    #[test]
    fn a_torque_below_every_minimum_pulse_says_nothing_fired() {
        let d = deliver([0.0; 3], [0.0, 0.0, 0.001]);
        assert!(
            has(&d, |w| *w == MixWarning::NothingFired),
            "{:?}",
            d.warnings
        );
        assert!(
            has(&d, |w| matches!(w, MixWarning::BelowMinimumPulse { .. })),
            "{:?}",
            d.warnings
        );
        assert_eq!(d.delivered_torque_nm, Vector3::zeros());
    }

    #[test]
    fn half_a_torque_and_a_cross_axis_force_are_reported() {
        let d = deliver([0.05, 0.0, 0.0], [0.0, 0.0, 0.001]);
        let axis = |what: &str, a: usize| {
            has(
                &d,
                |w| matches!(w, MixWarning::AxisError { what: q, axis, .. } if *q == what && *axis == a),
            )
        };
        assert!(axis("torque", 2), "z torque short: {:?}", d.warnings);
        assert!(axis("force", 1), "y force: {:?}", d.warnings);
        assert!(
            (d.delivered_torque_nm.z / 0.001 - 0.5).abs() < 0.1,
            "{}",
            d.delivered_torque_nm
        );
    }

    #[test]
    fn an_unreachable_command_is_scaled_and_says_so() {
        let d = deliver([1000.0; 3], [0.0; 3]);
        assert!(
            has(
                &d,
                |w| matches!(w, MixWarning::Scaled { scale } if *scale < 1e-3)
            ),
            "{:?}",
            d.warnings
        );
    }

    #[test]
    fn a_command_within_reach_is_delivered_without_axis_warnings() {
        // The control case: a torque the thrusters deliver in long pulses is met on every axis
        // (small direction-correction pulses below the minimum are still listed).
        let d = deliver([0.0; 3], [0.0, 0.0, 0.01]);
        assert!(
            d.warnings
                .iter()
                .all(|w| matches!(w, MixWarning::BelowMinimumPulse { .. })),
            "{:?}",
            d.warnings
        );
        assert!((d.delivered_torque_nm.z / 0.01 - 1.0).abs() < CROSS_AXIS_WARN);
    }

    #[test]
    fn a_com_outside_the_craft_is_refused() {
        let sat = Satellite::builtin("sph2").expect("sph2");
        assert!(com_inside(&sat, &Vector3::new(0.002, -0.001, 0.0)).is_ok());
        let e = com_inside(&sat, &Vector3::new(1e3, 0.0, 0.0)).expect_err("1 km off");
        assert!(
            e.contains("outside the craft") && e.contains("from the centre"),
            "{e}"
        );
    }
}
