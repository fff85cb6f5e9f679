//! A delay on the measurement side (contract `measurement_delay`): the recorded rate is the
//! body rate `delay_ms` ago. Sensor filtering, a motion-capture pipeline or late telemetry
//! time stamps do this, and such delays may be far longer than a valve's.
//!
//! On rates alone it is exactly an equal `thruster_latency` on every edge (the body's answer
//! to every command is shifted by the same time), so the model applies it as a shift of the
//! valve timing on top of any latency, and of the body's own events (a mass-property change,
//! a blowdown start: `model::predict`), which a latency leaves in place. Without such an
//! event the two are one equivalence class: the diagnosis
//! never fits them together (`select::combinable`) and names the valve latency while the
//! delay fits inside the valves' range, the delay beyond it (valves cannot be that late),
//! listing the other under `equivalent_to` (`equivalence.rs`).
//!
//! The search starts on a grid over the whole range, a few points per command step: once
//! the delay exceeds the command step the error is no longer a smooth function of the delay
//! near zero (a shift by one step matches the next command), so a local fit from a single
//! start finds the wrong step.

use super::thruster_latency::MAX_LATENCY_MS;
use super::{all_at, contract, timing_starts, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct MeasurementDelay;

/// The longest delay searched, ms: a motion-capture pipeline plus telemetry stays well under
/// a second (the real air-bearing flight answers about 120 ms late).
pub const MAX_DELAY_MS: f64 = 1000.0;

impl Effect for MeasurementDelay {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        1
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.delay_ms = th[0];
    }
    fn spec(&self, cx: &Context) -> Spec {
        let hi = MAX_DELAY_MS
            .min(cx.duration_s * 1e3 / 4.0)
            .max(MAX_LATENCY_MS * 2.0);
        Spec {
            lo: vec![0.0],
            hi: vec![hi],
            step: vec![0.05],
            starts: timing_starts(MAX_LATENCY_MS, hi, cx, 80)
                .into_iter()
                .map(|d| vec![d])
                .collect(),
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // Inside the valves' range the delay is the valve latency's equal: named as that.
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        if at_bound(0) && th[0] > 0.0 {
            Some("delay at the search bound".into())
        } else if th[0] < MAX_LATENCY_MS {
            Some(format!(
                "a delay under {MAX_LATENCY_MS} ms is an equal valve latency on every edge \
                 (the same rates): named thruster_latency"
            ))
        } else {
            None
        }
    }
    fn signature(&self) -> &'static str {
        "the measured rate answers every command the same time late, longer than a valve can be"
    }
    fn window_ms(&self) -> i64 {
        200
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at =
            |delay_ms| contract::Effect::MeasurementDelay(contract::MeasurementDelay { delay_ms });
        Reported::new(at(th[0]), at(se(0)))
    }
}
