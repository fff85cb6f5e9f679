//! Tilted thrusters (contract `thruster_misalignment`): a thruster's force points a few
//! degrees off the model's direction (seed Table 3.3 measures the directions), so its torque
//! changes direction, not only size. Without this effect a tilt is named as a thrust scale
//! on every thruster (the nearest thing the vocabulary had).
//!
//! Two tilt angles per fired thruster, about the axes of `Plant::tilt_axes`; the magnitude
//! stays (that is `thrust_scale`). On a planar craft only the yaw torque is seen, and a tilt
//! in the plane changes it exactly as that thruster's scale does: there the effect is not
//! tried (`applies`) and a tilt is named as a thrust scale.

use super::{Context, Effect, Reported, Spec};
use crate::json_number::num;
use crate::model::{Params, NT};
use serde_json::Value;

pub struct ThrusterMisalignment;

/// The largest tilt searched, rad (20 degrees): beyond it the thruster is mounted
/// elsewhere, not misaligned.
const MAX_TILT_RAD: f64 = 0.35;

impl Effect for ThrusterMisalignment {
    fn name(&self) -> &'static str {
        "thruster_misalignment"
    }
    fn n_params(&self, fired: &[bool; NT]) -> usize {
        2 * fired.iter().filter(|&&f| f).count()
    }
    fn apply(&self, th: &[f64], fired: &[bool; NT], p: &mut Params) {
        let mut j = 0;
        for i in 0..NT {
            if fired[i] && j + 1 < th.len() {
                p.tilt[i] = [th[j], th[j + 1]];
                j += 2;
            }
        }
    }
    fn applies(&self, cx: &Context) -> bool {
        !cx.plant.planar
    }
    fn spec(&self, cx: &Context) -> Spec {
        let n = self.n_params(cx.fired);
        Spec {
            lo: vec![-MAX_TILT_RAD; n],
            hi: vec![MAX_TILT_RAD; n],
            step: vec![1e-4; n],
            starts: vec![vec![0.0; n]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        (0..theta.len()).map(|i| (i, 0.0)).collect()
    }
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        (0..th.len()).any(|i| at_bound(i) && th[i] != 0.0).then(|| {
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
        let mut j = 0;
        for i in 0..n {
            let nominal = plant.tilted_force(i, [0.0; 2]);
            let unit = |v: nalgebra::Vector3<f64>| v / v.norm().max(1e-300);
            if cx.fired[i] && j + 1 < th.len() {
                let (a, b) = (th[j], th[j + 1]);
                let (sa, sb) = (se(j), se(j + 1));
                let d = unit(plant.tilted_force(i, [a, b]));
                let [u1, u2] = plant.tilt_axes[i];
                dir.push(d);
                dir_se.push(std::array::from_fn::<f64, 3, _>(|k| {
                    (u1[k] * sa).hypot(u2[k] * sb)
                }));
                let angle = unit(nominal).dot(&d).clamp(-1.0, 1.0).acos();
                // the angle's error: the tilt's own direction's component
                let e = if angle > 0.0 {
                    ((a * sa).powi(2) + (b * sb).powi(2)).sqrt() / a.hypot(b)
                } else {
                    sa.max(sb)
                };
                if angle > 3.0 * e {
                    tilted.push(i + 1);
                }
                tilt.push(angle.to_degrees());
                tilt_se.push(e.to_degrees());
                j += 2;
            } else {
                dir.push(unit(nominal));
                dir_se.push([0.0; 3]);
                tilt.push(0.0);
                tilt_se.push(0.0);
            }
        }
        let rows = |v: &[nalgebra::Vector3<f64>]| {
            Value::Array(
                v.iter()
                    .map(|d| Value::Array(d.iter().map(|x| num(*x)).collect()))
                    .collect(),
            )
        };
        let rows3 = |v: &[[f64; 3]]| {
            Value::Array(
                v.iter()
                    .map(|d| Value::Array(d.iter().map(|x| num(*x)).collect()))
                    .collect(),
            )
        };
        let mut r = Reported::default();
        r.0.insert("dir".into(), rows(&dir));
        r.1.insert("dir".into(), rows3(&dir_se));
        r.0.insert("tilt_deg".into(), crate::json_number::nums(&tilt));
        r.1.insert("tilt_deg".into(), crate::json_number::nums(&tilt_se));
        r.0.insert(
            "thrusters".into(),
            Value::Array(tilted.into_iter().map(Value::from).collect()),
        );
        r
    }
}
