//! Valve opening and closing delays: torque arrives later than commanded.

use super::{all_at, contract, timing_starts, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct ThrusterLatency;

/// The longest valve delay searched, ms: a solenoid valve opens in a few ms (seed ch. 2:
/// ~6 ms); a long feed line or a slow pilot stage adds tens of ms. Beyond this a delay is
/// not the valves' (see `measurement_delay.rs`, its equal on rates).
pub const MAX_LATENCY_MS: f64 = 100.0;

impl Effect for ThrusterLatency {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        2
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.open_ms = th[0];
        p.close_ms = th[1];
    }
    fn spec(&self, cx: &Context) -> Spec {
        // from 2 ms (the seed's valves), then along open = close over the whole range: a
        // latency longer than the command step is not found from a start near zero
        let mut starts = vec![vec![2.0, 2.0]];
        starts.extend(
            timing_starts(6.0, MAX_LATENCY_MS, cx, 24)
                .into_iter()
                .skip(1)
                .map(|d| vec![d, d]),
        );
        Spec {
            lo: vec![0.0, 0.0],
            hi: vec![MAX_LATENCY_MS, MAX_LATENCY_MS],
            step: vec![0.05, 0.05],
            starts,
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // valves open/close within 0..MAX_LATENCY_MS (seed ch. 2 measures ~6 ms)
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        (at_bound(0) && th[0] > 0.0 || at_bound(1) && th[1] > 0.0)
            .then(|| format!("latency at the {MAX_LATENCY_MS} ms search bound"))
    }
    fn signature(&self) -> &'static str {
        "residual concentrates at valve edges: torque arrives later than commanded"
    }
    // A pulse no longer than `open - close` never opens: where that difference reaches a
    // commanded width the rates have a kink, and a forward difference in `close` takes the
    // swallowed pulses' slope into the (smooth) direction `open + close` as well. On random
    // planar craft at 100 Hz with 40/20 ms (a 20 ms difference, 10 ms command steps) the fit
    // stopped with both latencies off by the same 0.5-3.8 ms at 6-37 errors (seeds 88105,
    // 88118); with central differences the two one-sided slopes cancel in that direction.
    fn kinked(&self) -> bool {
        true
    }
    fn window_ms(&self) -> i64 {
        20
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |open_ms, close_ms| {
            contract::Effect::ThrusterLatency(contract::ThrusterLatency { open_ms, close_ms })
        };
        Reported::new(at(th[0], th[1]), at(se(0), se(1)))
    }
}
