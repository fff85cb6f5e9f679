//! A delay on the measurement side: the recorded rate is the body rate `delay_ms` ago
//! (contract `measurement_delay`). Sensor filtering, a motion-capture pipeline or telemetry
//! time stamps taken late all do this, and such delays may be far longer than a valve's
//! (the real air-bearing flight answers its commands about 120 ms late).
//!
//! The delay acts on what the rate sensor reports, so a closed-loop controller that reads
//! the same sensor sees the late rate too; the accelerometer and the thruster words are not
//! delayed. On rates alone it equals a `thruster_latency` of `delay_ms` on every edge (the
//! contract says so): the diagnosis names one and lists the other as equivalent.
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// The recorded rate at time t is the body rate at t - `delay_ms` (ms, >= 0; 0 = no effect).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct MeasurementDelay {
    pub delay_ms: f64,
}

impl Component for MeasurementDelay {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.measurement_delay_ms += self.delay_ms;
    }
}

/// The body rate some time ago, from a bounded history of one entry per ms (the simulator
/// steps its command loop on a 1 ms grid). Before the first entry the rate is the first one
/// (the craft's state at t = 0 held back in time).
pub struct DelayLine {
    delay_ms: f64,
    /// Rates at the last `len` whole ms, oldest first.
    hist: std::collections::VecDeque<[f64; 3]>,
    len: usize,
}

impl DelayLine {
    /// A line for `delay_ms` (finite, >= 0; the model-file check bounds it).
    pub fn new(delay_ms: f64) -> Self {
        let delay_ms = if delay_ms.is_finite() {
            delay_ms.max(0.0)
        } else {
            0.0
        };
        let len = delay_ms.ceil() as usize + 2;
        DelayLine {
            delay_ms,
            hist: std::collections::VecDeque::with_capacity(len),
            len,
        }
    }

    /// Records the body rate at the next whole ms and returns the rate `delay_ms` before it
    /// (linear between the whole ms around it).
    pub fn push(&mut self, w: [f64; 3]) -> [f64; 3] {
        if self.hist.is_empty() {
            self.hist.extend(std::iter::repeat_n(w, self.len));
        } else {
            self.hist.pop_front();
            self.hist.push_back(w);
        }
        if self.delay_ms == 0.0 {
            return w;
        }
        let back = self.delay_ms.floor() as usize;
        let frac = self.delay_ms - back as f64;
        let newest = self.hist.len() - 1;
        let a = self.hist[newest - back];
        let b = self.hist[newest - back - 1];
        std::array::from_fn(|i| a[i] + (b[i] - a[i]) * frac)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::{Effect, ThrusterLatency};
    use crate::simulate::{simulate, Maneuver, SimSpec};
    use reference_f64::satellite::Satellite;

    #[test]
    fn the_line_returns_the_rate_delay_ago_and_holds_the_start() {
        let mut d = DelayLine::new(2.5);
        let out: Vec<f64> = (0..6).map(|k| d.push([k as f64, 0.0, 0.0])[0]).collect();
        // t=0,1,2 look back before the start (held at 0); t=3 -> 0.5, t=4 -> 1.5, t=5 -> 2.5
        assert_eq!(out, vec![0.0, 0.0, 0.0, 0.5, 1.5, 2.5]);
        let mut none = DelayLine::new(0.0);
        assert_eq!(none.push([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0]);
    }

    /// The recorded rate is the undelayed recording's rate `delay_ms` later in an open-loop
    /// flight (the commands do not depend on the sensor), and the truth's body rate is not
    /// delayed. A planted fault (a delay line that ignores the delay) fails it.
    #[test]
    fn recorded_rates_lag_the_body_by_the_delay() {
        let sat = Satellite::builtin("sph2").unwrap();
        let spec = |effects: Vec<Effect>| {
            let mut s = SimSpec::new(sat.clone(), effects, Maneuver::Combo);
            s.seconds = Some(3.0);
            s.seed = 3;
            s.sensors.noiseless = true;
            s
        };
        let plain = simulate(&spec(vec![])).unwrap();
        let delayed = simulate(&spec(vec![Effect::MeasurementDelay(MeasurementDelay {
            delay_ms: 40.0,
        })]))
        .unwrap();
        assert_eq!(
            plain.body_rate, delayed.body_rate,
            "the body is not delayed"
        );
        let g = |o: &crate::SimOutput, k: usize| o.recording.samples[k].gyro;
        let n = plain.recording.samples.len();
        assert!(n > 2000);
        let moving = (0..n - 40)
            .filter(|&k| g(&plain, k) != g(&plain, k + 1))
            .count();
        assert!(moving > 1000, "the flight turns");
        for k in 0..n - 40 {
            assert_eq!(g(&delayed, k + 40), g(&plain, k), "sample {k}");
        }
        // And the same flight with an equal valve latency on every edge gives the same
        // recorded rates (the contract's equivalence), to a count.
        let latency = simulate(&spec(vec![Effect::ThrusterLatency(ThrusterLatency {
            open_ms: 40.0,
            close_ms: 40.0,
        })]))
        .unwrap();
        for k in 0..n {
            for a in 0..3 {
                let d = g(&delayed, k)[a] as i32 - g(&latency, k)[a] as i32;
                assert!(d.abs() <= 1, "sample {k} axis {a}: {d} counts");
            }
        }
    }

    #[test]
    fn ignoring_the_delay_is_caught() {
        // planted fault: a zero delay line where 40 ms was asked for
        let mut right = DelayLine::new(40.0);
        let mut wrong = DelayLine::new(0.0);
        let mut differ = 0;
        for k in 0..100 {
            let w = [(k as f64 * 0.1).sin(), 0.0, 0.0];
            if right.push(w) != wrong.push(w) {
                differ += 1;
            }
        }
        assert!(differ > 90);
    }
}
