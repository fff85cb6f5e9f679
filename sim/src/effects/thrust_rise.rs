//! First-order valve thrust rise (contract `thrust_rise`; it began here as an extra effect
//! the diagnosis could not name, to check that it then reported a mismatch instead of
//! forcing the residual onto latency, its nearest neighbour).
//!
//! A solenoid valve does not deliver its full thrust the instant it opens: the plenum
//! between valve and nozzle fills (and empties) with a time constant. Each thruster's force
//! therefore follows its steady value (scale, pressure drop of the actual valve set) through
//! a first-order lag, `tau dF_i/dt = F_ss_i(valves) - F_i`: after the (possibly delayed,
//! see `thruster_latency`) opening it rises as `1 - exp(-t/tau)`, after the closing it decays
//! as `exp(-t/tau)`; the blowdown factor multiplies the lagged force. The lag acts on the
//! actual valve edges, so it composes with any latency; `tau_ms = 0` is the nominal
//! instantaneous valve (bit for bit). Two rise effects add their time constants (the mean
//! delay of the cascade). The propagation (`propagate.rs`) re-references every thruster's
//! force at each valve edge and the equations of motion (`dynamics.rs`) evaluate the
//! exponential at every RK4 stage; steps are shortened to tau/8 while a transient is young.
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// Every thruster's force lags its valve by a first-order rise/decay of time constant
/// `tau_ms` (ms, >= 0; 0 = no effect).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ThrustRise {
    pub tau_ms: f64,
}

impl Component for ThrustRise {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.thrust_rise_tau_ms += self.tau_ms;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::{Effect, ThrusterLatency};
    use crate::predict::{predict, PredictOptions, Prediction};
    use crate::simulate::{simulate, Maneuver, SimSpec};
    use reference_f64::satellite::{Satellite, GYRO_COUNTS_PER_RAD_S};

    fn sph2() -> Satellite {
        Satellite::builtin("sph2").unwrap()
    }

    fn rise(tau_ms: f64) -> Effect {
        Effect::ThrustRise(ThrustRise { tau_ms })
    }

    /// Thrusters 5 and 12 (indices 4, 11): the RGA's pure rotation pair about x.
    const PAIR: u16 = (1 << 4) | (1 << 11);
    /// Commanded open on [OPEN_MS, CLOSE_MS), then off until END_MS, 1 kHz samples.
    const OPEN_MS: u64 = 100;
    const CLOSE_MS: u64 = 500;
    const END_MS: u64 = 800;

    fn pulse(effects: &[Effect], max_step_ms: f64) -> Prediction {
        let t: Vec<u64> = (0..END_MS).collect();
        let w: Vec<u16> = t
            .iter()
            .map(|&t| {
                if (OPEN_MS..CLOSE_MS).contains(&t) {
                    PAIR
                } else {
                    0
                }
            })
            .collect();
        predict(
            &sph2(),
            effects,
            &t,
            &w,
            [0.0; 3],
            PredictOptions { max_step_ms },
        )
    }

    fn norm(v: [f64; 3]) -> f64 {
        v.iter().map(|x| x * x).sum::<f64>().sqrt()
    }

    fn diff(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| a[i] - b[i])
    }

    /// 1 gyro count in rad/s (the recorded noise is 2-3 counts rms).
    const COUNT_RAD_S: f64 = 1.0 / GYRO_COUNTS_PER_RAD_S;

    /// The physics check of a first-order rise of `tau_ms` starting at the valve opening
    /// `t_open_ms` (after any latency; `nominal` has the same latency, no rise):
    /// - once risen (from 6 tau after the opening to the commanded close) the body rate lags
    ///   the nominal one by alpha * tau (alpha = the nominal angular acceleration), within 3 %;
    /// - the rise is smooth: at tau after the opening the angular acceleration is
    ///   (1 - 1/e) of its final value within 5 % (a pure delay would give 0 or 1).
    fn rise_check(
        nominal: &Prediction,
        rising: &Prediction,
        tau_ms: f64,
        t_open_ms: f64,
    ) -> Result<(), String> {
        let tau_s = tau_ms * 1e-3;
        let alpha = nominal.angular_accel[(CLOSE_MS - 50) as usize];
        let want = norm(alpha) * tau_s;
        let from = (t_open_ms + 6.0 * tau_ms).ceil() as usize;
        for k in from..CLOSE_MS as usize {
            let deficit = norm(diff(nominal.body_rate[k], rising.body_rate[k]));
            if (deficit - want).abs() > 0.03 * want {
                return Err(format!(
                    "t {k} ms: rate deficit {deficit:.6} rad/s, alpha*tau {want:.6}"
                ));
            }
        }
        // Sample at (or just after) t_open + tau; the expected fraction at that sample.
        let k = (t_open_ms + tau_ms).ceil() as usize;
        let expected = 1.0 - (-(k as f64 - t_open_ms) / tau_ms).exp();
        let final_ = rising.angular_accel[(CLOSE_MS - 50) as usize];
        let got = rising.angular_accel[k][0] / final_[0];
        if (got - expected).abs() > 0.05 * expected {
            return Err(format!(
                "accel at t_open + tau is {got:.4} of final, want {expected:.4} (1 - 1/e = 0.632)"
            ));
        }
        Ok(())
    }

    #[test]
    fn serialises_as_an_effect_and_validates() {
        let e = rise(20.0);
        assert_eq!(
            serde_json::to_string(&e).unwrap(),
            r#"{"effect":"thrust_rise","params":{"tau_ms":20.0}}"#
        );
        let back: Effect =
            serde_json::from_str(r#"{"effect": "thrust_rise", "params": {"tau_ms": 20.0}}"#)
                .unwrap();
        assert_eq!(back, e);
        assert_eq!(e.name(), "thrust_rise");
        assert_eq!(e.params(), vec![("tau_ms".to_string(), 20.0)]);
        assert!(crate::effects::EFFECT_NAMES.contains(&"thrust_rise"));
        assert!(rise(0.0).validate().is_ok());
        assert!(rise(-1.0).validate().unwrap_err().contains("tau_ms"));
        assert!(rise(f64::NAN).validate().is_err());
    }

    #[test]
    fn zero_tau_is_bit_identical_to_nominal() {
        let spec = |effects: Vec<Effect>| {
            let mut s = SimSpec::new(sph2(), effects, Maneuver::Combo);
            s.seconds = Some(4.0);
            s.seed = 7;
            s
        };
        let nominal = simulate(&spec(vec![])).unwrap();
        let zero = simulate(&spec(vec![rise(0.0)])).unwrap();
        let bytes = |o: &crate::SimOutput| {
            let mut v = Vec::new();
            o.recording.write_to(&mut v).unwrap();
            v
        };
        assert!(nominal.recording.samples.len() > 3000);
        assert!(bytes(&nominal) == bytes(&zero), "recordings differ");
        let bits = |o: &crate::SimOutput| {
            o.body_rate
                .iter()
                .flatten()
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&nominal), bits(&zero));
        // And the same recording differs once tau is set (so the comparison can fail).
        let on = simulate(&spec(vec![rise(20.0)])).unwrap();
        assert!(bytes(&nominal) != bytes(&on));
        // The fast prediction too, with latency.
        let lat = Effect::ThrusterLatency(ThrusterLatency {
            open_ms: 6.4,
            close_ms: 3.7,
        });
        let a = pulse(std::slice::from_ref(&lat), 1.0);
        let b = pulse(&[lat, rise(0.0)], 1.0);
        assert_eq!(a, b);
    }

    #[test]
    fn long_pulse_lags_by_alpha_tau_and_rises_smoothly() {
        let nominal = pulse(&[], 1.0);
        let rising = pulse(&[rise(20.0)], 1.0);
        rise_check(&nominal, &rising, 20.0, OPEN_MS as f64).unwrap();
        // Right at the opening no torque yet; the final acceleration equals the nominal one
        // (to 1e-3: the gyroscopic term differs a little, the rates differ by alpha * tau).
        let k = OPEN_MS as usize;
        assert!(norm(nominal.angular_accel[k]) > 0.1);
        assert!(norm(rising.angular_accel[k]) < 1e-9 * norm(nominal.angular_accel[k]));
        let (a, b) = (
            rising.angular_accel[CLOSE_MS as usize - 1],
            nominal.angular_accel[CLOSE_MS as usize - 1],
        );
        assert!(norm(diff(a, b)) < 1e-3 * norm(b), "{a:?} vs {b:?}");
        // After the close the force decays as exp(-t/tau): at tau, 1/e of the steady value.
        let at = rising.angular_accel[(CLOSE_MS + 20) as usize][0] / b[0];
        assert!(
            (at - (-1.0f64).exp()).abs() < 0.02 * (-1.0f64).exp(),
            "{at}"
        );
        // The impulse is only shifted, not lost: long after the close the rates agree.
        let last = END_MS as usize - 1;
        let d = norm(diff(nominal.body_rate[last], rising.body_rate[last]));
        assert!(d < 1e-4 * norm(nominal.body_rate[last]), "end deficit {d}");
    }

    #[test]
    fn composes_with_latency_off_the_grid() {
        let lat = Effect::ThrusterLatency(ThrusterLatency {
            open_ms: 6.4,
            close_ms: 3.7,
        });
        let nominal = pulse(std::slice::from_ref(&lat), 1.0);
        let rising = pulse(&[lat, rise(20.0)], 1.0);
        rise_check(&nominal, &rising, 20.0, OPEN_MS as f64 + 6.4).unwrap();
        // The valve edges themselves are those of the latency alone.
        assert_eq!(rising.edges, nominal.edges);
    }

    #[test]
    fn ignoring_tau_is_caught() {
        // Planted fault: a "rise" prediction that ignores tau (= nominal) must fail the check,
        // and the rate it misses is far above the gyro noise (2-3 counts rms).
        let nominal = pulse(&[], 1.0);
        let rising = pulse(&[rise(20.0)], 1.0);
        let ignored = pulse(&[rise(0.0)], 1.0);
        let err = rise_check(&nominal, &ignored, 20.0, OPEN_MS as f64).unwrap_err();
        assert!(err.contains("rate deficit"), "{err}");
        let worst = (0..END_MS as usize)
            .map(|k| norm(diff(rising.body_rate[k], nominal.body_rate[k])))
            .fold(0.0, f64::max);
        assert!(
            worst > 10.0 * COUNT_RAD_S,
            "tau = 20 ms moves the rate by only {worst} rad/s"
        );
        // A wrong tau fails too.
        let other = pulse(&[rise(15.0)], 1.0);
        assert!(rise_check(&nominal, &other, 20.0, OPEN_MS as f64).is_err());
    }

    #[test]
    fn any_tau_is_integrated_accurately() {
        // 1 ms steps against 0.1 ms steps, for slow and very fast rises (the steps are cut
        // to tau/8 while a transient is young), also with latency and pressure drop.
        let lat = Effect::ThrusterLatency(ThrusterLatency {
            open_ms: 0.37,
            close_ms: 2.2,
        });
        let drop = Effect::PressureDrop(crate::effects::PressureDrop {
            newton_per_extra_thruster: 0.0106,
        });
        for tau in [20.0, 3.0, 0.05] {
            let fx = [lat.clone(), drop.clone(), rise(tau)];
            let coarse = pulse(&fx, 1.0);
            let fine = pulse(&fx, 0.1);
            for k in 0..END_MS as usize {
                let d = norm(diff(coarse.body_rate[k], fine.body_rate[k]));
                assert!(d < 1e-9, "tau {tau}: t {k}: {d}");
            }
            // Deficit while firing = alpha * tau also for the fast rise.
            let nominal = pulse(&[lat.clone(), drop.clone()], 1.0);
            let k = CLOSE_MS as usize - 10;
            let want = norm(nominal.angular_accel[k]) * tau * 1e-3;
            let got = norm(diff(nominal.body_rate[k], coarse.body_rate[k]));
            assert!(
                (got - want).abs() < 0.03 * want,
                "tau {tau}: deficit {got} vs {want}"
            );
        }
    }
}
