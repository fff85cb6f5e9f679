//! Tilted thrusters (contract `thruster_misalignment`): a thruster's force points a few
//! degrees off the model's direction (seed Table 3.3 measures the directions), so its torque
//! changes direction, not only size. Without this effect a tilt is named as a thrust scale
//! on every thruster (the nearest thing the vocabulary had).
//!
//! One tilted thruster: which one (a discrete choice the search makes, one start per fired
//! thruster) and its two tilt angles about the axes of `Plant::tilt_axes`; the magnitude
//! stays (that is `thrust_scale`). Tilts of every thruster at once (two angles each) were
//! tried first: with 22 free angles on SPHERES (11 fired thrusters) they stood in for a CoM offset plus a gyro
//! scale error (open recording p06), so the effect is the parsimonious one-thruster form.
//! The index is parameter 0, held by the fit (its Jacobian column is zero, so it is a dead
//! parameter and costs no BIC penalty).
//!
//! On a planar craft only the yaw torque is seen, and a tilt in the plane changes it exactly
//! as that thruster's scale does: there the effect is not tried (`applies`) and a tilt is
//! named as a thrust scale.

use super::{contract, Context, Effect, Reported, Spec};
use crate::json_number::nums;
use crate::model::{Params, NT};
use serde_json::Value;

pub struct ThrusterMisalignment;

/// The thruster a parameter vector tilts (parameter 0, rounded into range).
fn thruster_of(th: &[f64]) -> usize {
    th.first()
        .map(|v| v.round().clamp(0.0, (NT - 1) as f64) as usize)
        .unwrap_or(0)
}

/// The largest tilt searched, rad (20 degrees): beyond it the thruster is mounted
/// elsewhere, not misaligned.
const MAX_TILT_RAD: f64 = 0.35;

impl Effect for ThrusterMisalignment {
    fn n_params(&self, fired: &[bool; NT]) -> usize {
        // no thruster fired: nothing to tilt (and no start to search from)
        if fired.iter().any(|&f| f) {
            3
        } else {
            0
        }
    }
    fn apply(&self, th: &[f64], fired: &[bool; NT], p: &mut Params) {
        let k = thruster_of(th);
        if fired[k] {
            p.tilt[k] = [th[1], th[2]];
        }
    }
    fn applies(&self, cx: &Context) -> bool {
        !cx.plant.planar
    }
    fn spec(&self, cx: &Context) -> Spec {
        Spec {
            lo: vec![0.0, -MAX_TILT_RAD, -MAX_TILT_RAD],
            hi: vec![(NT - 1) as f64, MAX_TILT_RAD, MAX_TILT_RAD],
            step: vec![1e-3, 1e-4, 1e-4],
            starts: (0..NT)
                .filter(|&i| cx.fired[i])
                .map(|i| vec![i as f64, 0.0, 0.0])
                .collect(),
        }
    }
    fn no_effect(&self, _: &[f64], _: &Context) -> Vec<(usize, f64)> {
        vec![(1, 0.0), (2, 0.0)]
    }
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        (1..3).any(|i| at_bound(i) && th[i] != 0.0).then(|| {
            format!(
                "a tilt at the {:.0} degree search bound",
                MAX_TILT_RAD.to_degrees()
            )
        })
    }
    fn signature(&self) -> &'static str {
        "a thruster's torque points off the model's direction, not just off its size"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, cx: &Context) -> Reported {
        let plant = cx.plant;
        let n = cx.n_thrusters.min(NT);
        let mut dir = vec![];
        let mut dir_se = vec![];
        let mut tilt = vec![];
        let mut tilt_se = vec![];
        let mut tilted = vec![];
        let k = thruster_of(th);
        let unit = |v: nalgebra::Vector3<f64>| v / v.norm().max(1e-300);
        for i in 0..n {
            let nominal = unit(plant.tilted_force(i, [0.0; 2]));
            if i == k && cx.fired[i] {
                let (a, b) = (th[1], th[2]);
                // an unidentifiable angle (NaN error) stays at 0: it adds no uncertainty
                let finite = |e: f64| if e.is_finite() { e } else { 0.0 };
                let (sa, sb) = (finite(se(1)), finite(se(2)));
                let d = unit(plant.tilted_force(i, [a, b]));
                let [u1, u2] = plant.tilt_axes[i];
                dir.push(d);
                dir_se.push(std::array::from_fn::<f64, 3, _>(|c| {
                    (u1[c] * sa).hypot(u2[c] * sb)
                }));
                let angle = nominal.dot(&d).clamp(-1.0, 1.0).acos();
                // the angle's error: along the tilt's own direction
                let e = if a.hypot(b) > 0.0 {
                    ((a * sa).powi(2) + (b * sb).powi(2)).sqrt() / a.hypot(b)
                } else {
                    sa.max(sb)
                };
                tilted.push(i + 1);
                tilt.push(angle.to_degrees());
                tilt_se.push(e.to_degrees());
            } else {
                dir.push(nominal);
                dir_se.push([0.0; 3]);
                tilt.push(0.0);
                tilt_se.push(0.0);
            }
        }
        let at =
            |dir| contract::Effect::ThrusterMisalignment(contract::ThrusterMisalignment { dir });
        let dir: Vec<[f64; 3]> = dir.iter().map(|d| [d.x, d.y, d.z]).collect();
        Reported::new(at(dir), at(dir_se))
            .with("tilt_deg", nums(&tilt), Some(nums(&tilt_se)))
            .with(
                "thrusters",
                Value::Array(tilted.into_iter().map(Value::from).collect()),
                None,
            )
    }
}
