//! Tilted thrusters (contract `thruster_misalignment`): a thruster's force points along a
//! direction other than the model's (a nozzle mounted a few degrees off, a bent bracket; seed
//! Table 3.3 measures the directions). The force keeps its magnitude (that is
//! `thrust_scale`); only its direction, and so its torque about the CoM, changes.
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// The true unit direction of each thruster's force, body axes, thruster 1 first (all N of
/// the model's thrusters; the model's own direction where nothing is tilted). Directions
/// are normalised when applied.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ThrusterMisalignment {
    pub dir: Vec<[f64; 3]>,
}

impl Component for ThrusterMisalignment {
    fn apply(&self, plant: &mut PlantConfig) {
        for (slot, d) in plant.thrust_dir.iter_mut().zip(&self.dir) {
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if n > 0.0 && n.is_finite() {
                *slot = Some([d[0] / n, d[1] / n, d[2] / n]);
            }
        }
    }
}

/// The largest tilt from the model's direction a model may state, degrees: beyond it the
/// thruster is mounted elsewhere, not misaligned.
pub const MAX_TILT_DEG: f64 = 45.0;

/// Angle between two directions, degrees.
pub fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::Effect;
    use crate::simulate::{simulate, Maneuver, SimSpec};
    use reference_f64::satellite::Satellite;

    fn tilted(sat: &Satellite, i: usize, deg: f64) -> Effect {
        let mut dir: Vec<[f64; 3]> = (0..sat.n_thrusters()).map(|k| sat.thrust_dir[k]).collect();
        let d = sat.thrust_dir[i];
        // tilt about an axis perpendicular to the direction
        let axis = if d[2].abs() < 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let v = nalgebra::Vector3::from(d);
        let r = nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(v.cross(&nalgebra::Vector3::from(axis))),
            deg.to_radians(),
        );
        dir[i] = (r * v).into();
        Effect::ThrusterMisalignment(ThrusterMisalignment { dir })
    }

    #[test]
    fn serialises_as_the_contract_and_checks_its_shape() {
        let sat = Satellite::builtin("sph2").unwrap();
        let e = tilted(&sat, 4, 5.0);
        let json = serde_json::to_string(&e).unwrap();
        assert!(json.starts_with(r#"{"effect":"thruster_misalignment","params":{"dir":[["#));
        let back: Effect = serde_json::from_str(&json).unwrap();
        assert_eq!(back, e);
        assert!(e.check_plausible(&sat).is_ok());
        let Effect::ThrusterMisalignment(m) = &e else {
            unreachable!()
        };
        assert!((angle_deg(m.dir[4], sat.thrust_dir[4]) - 5.0).abs() < 1e-9);
        // planted faults: a short list, a zero direction, a thruster turned around
        let mut short = m.clone();
        short.dir.pop();
        let err = Effect::ThrusterMisalignment(short)
            .check_plausible(&sat)
            .unwrap_err();
        assert!(err.contains("entries"), "{err}");
        let mut zero = m.clone();
        zero.dir[0] = [0.0; 3];
        assert!(Effect::ThrusterMisalignment(zero)
            .check_plausible(&sat)
            .is_err());
        let far = tilted(&sat, 2, 90.0);
        assert!(far.check_plausible(&sat).unwrap_err().contains("degrees"));
    }

    /// Matrix parameters flatten as `dir[i][j]` and can be set back by that name.
    #[test]
    fn direction_entries_are_named_parameters() {
        let sat = Satellite::builtin("sph2").unwrap();
        let e = tilted(&sat, 4, 5.0);
        let p = e.params();
        assert_eq!(p.len(), 3 * sat.n_thrusters());
        assert_eq!(p[3 * 4 + 1].0, "dir[4][1]");
        let moved = e.with_params(&[("dir[4][1]", 0.25)]).unwrap();
        assert_eq!(moved.params()[3 * 4 + 1].1, 0.25);
        assert_eq!(moved.params()[0], p[0]);
        // planted faults: a row past the end, a malformed index
        assert!(e.with_params(&[("dir[99][0]", 1.0)]).is_err());
        assert!(e.with_params(&[("dir[4][x]", 1.0)]).is_err());
    }

    /// A tilted thruster turns the body differently (the torque changes), the model's own
    /// directions change nothing (bit for bit).
    #[test]
    fn a_tilt_changes_the_torque_and_the_model_directions_change_nothing() {
        let sat = Satellite::builtin("sph2").unwrap();
        let run = |effects: Vec<Effect>| {
            let mut s = SimSpec::new(sat.clone(), effects, Maneuver::Combo);
            s.seconds = Some(3.0);
            s.sensors.noiseless = true;
            simulate(&s).unwrap().body_rate
        };
        let nominal = run(vec![]);
        assert_eq!(nominal, run(vec![tilted(&sat, 4, 0.0)]));
        let off = run(vec![tilted(&sat, 4, 8.0)]);
        let worst = nominal
            .iter()
            .zip(&off)
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        assert!(
            worst > 1e-3,
            "an 8 degree tilt moves the rate by only {worst}"
        );
    }
}
