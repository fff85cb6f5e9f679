//! Gyro pre-processing (seed section 4.4.1, App. D.2-D.3): counts to rad/s, linear
//! interpolation over dropped samples (thruster word by nearest), and the two-pole 50 Hz
//! low-pass `wc^2/(s+wc)^2` discretised with Tustin (bilinear, no pre-warp, as `c2d`),
//! run zero-phase forward-backward offline and causally online.
use crate::recording::{Recording, Sample};
use crate::satellite::Satellite;

/// Corner frequency of the seed's gyro low-pass, Hz (`gyrofiltvar(rate, time, 50, 2)`).
pub const GYRO_FILTER_HZ: f64 = 50.0;

/// Uniformly sampled rates: the output of pre-processing and the input of every
/// angular-acceleration estimator.
#[derive(Clone, Debug, Default)]
pub struct Rates {
    /// Sample times, s, uniform: `t_s[k] = t_s[0] + k * dt`.
    pub t_s: Vec<f64>,
    /// Body rates, rad/s (filtered or not, as the producing function says).
    pub omega: Vec<[f64; 3]>,
    /// Commanded thruster word at each sample.
    pub words: Vec<u16>,
    /// True where the sample was filled in over a telemetry gap.
    pub interpolated: Vec<bool>,
    /// Sample period, s.
    pub dt: f64,
}

impl Rates {
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// One axis as a plain series.
    pub fn axis(&self, a: usize) -> Vec<f64> {
        self.omega.iter().map(|w| w[a]).collect()
    }

    /// Replaces one axis (e.g. after filtering).
    pub fn set_axis(&mut self, a: usize, v: &[f64]) {
        for (w, x) in self.omega.iter_mut().zip(v) {
            w[a] = *x;
        }
    }
}

/// Counts to rad/s for one sample with the satellite's bias and scale.
pub fn sample_rate_rad_s(sat: &Satellite, s: &Sample) -> [f64; 3] {
    [0, 1, 2].map(|a| sat.gyro_counts_to_rad_s(a, s.gyro[a] as f64))
}

/// Points of the uniform grid a recording spans (first to last sample at the nominal
/// period), None if it overflows.
pub fn grid_len(rec: &Recording) -> Option<usize> {
    let (first, last) = (rec.samples.first()?, rec.samples.last()?);
    let n = (last.time_ms - first.time_ms) / rec.sample_period_ms();
    usize::try_from(n).ok()?.checked_add(1)
}

/// Whether interpolation would mostly invent data: the grid is more than 16 times the
/// samples (plus 1000 points of slack). Such recordings are refused, not interpolated.
pub fn too_sparse(rec: &Recording) -> bool {
    match grid_len(rec) {
        Some(n) => n > rec.samples.len().saturating_mul(16).saturating_add(1000),
        None => !rec.samples.is_empty(),
    }
}

/// Counts to rad/s, then onto a uniform grid of the recording's nominal period starting
/// at the first sample: missing grid points are linearly interpolated between their
/// neighbours (seed `int.m`), the thruster word taken from the nearest real sample
/// (a tie goes to the earlier one, which keeps a pulse from being lengthened).
/// A [`too_sparse`] recording gives empty rates.
pub fn uniform_rates(rec: &Recording, sat: &Satellite) -> Rates {
    let period_ms = rec.sample_period_ms();
    let dt = period_ms as f64 / 1000.0;
    let mut out = Rates {
        dt,
        ..Rates::default()
    };
    let Some(first) = rec.samples.first() else {
        return out;
    };
    if too_sparse(rec) {
        return out;
    }
    let t0 = first.time_ms;
    let n = grid_len(rec).unwrap_or(0);
    out.t_s.reserve(n);
    out.omega.reserve(n);
    out.words.reserve(n);
    out.interpolated.reserve(n);
    let mut j = 0; // index of the last real sample at or before the grid time
    for k in 0..n {
        let t = t0 + k as u64 * period_ms;
        while j + 1 < rec.samples.len() && rec.samples[j + 1].time_ms <= t {
            j += 1;
        }
        let a = &rec.samples[j];
        let (omega, word, interp) = if a.time_ms == t || j + 1 >= rec.samples.len() {
            (sample_rate_rad_s(sat, a), a.thrusters, a.time_ms != t)
        } else {
            let b = &rec.samples[j + 1];
            let f = (t - a.time_ms) as f64 / (b.time_ms - a.time_ms) as f64;
            let (wa, wb) = (sample_rate_rad_s(sat, a), sample_rate_rad_s(sat, b));
            let omega = [0, 1, 2].map(|i| wa[i] + f * (wb[i] - wa[i]));
            let word = if t - a.time_ms <= b.time_ms - t {
                a.thrusters
            } else {
                b.thrusters
            };
            (omega, word, true)
        };
        out.t_s.push(t as f64 / 1000.0);
        out.omega.push(omega);
        out.words.push(word);
        out.interpolated.push(interp);
    }
    out
}

/// The seed's gyro filter: two real poles at `fc` (H(s) = wc^2/(s+wc)^2), Tustin at `dt`.
/// Coefficients in `y[n] = b0 x[n] + b1 x[n-1] + b2 x[n-2] - a1 y[n-1] - a2 y[n-2]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowPass2 {
    pub b: [f64; 3],
    pub a: [f64; 3],
}

impl LowPass2 {
    /// Tustin (bilinear, `s = (2/dt)(z-1)/(z+1)`) of `wc^2/(s+wc)^2`, wc = 2 pi fc.
    /// Each factor `wc/(s+wc)` maps to `g (z+1)/(z - p)` with `p = (K-wc)/(K+wc)`,
    /// `g = wc/(K+wc)`, `K = 2/dt`; the filter is the square of that factor.
    pub fn design(fc_hz: f64, dt: f64) -> LowPass2 {
        let wc = 2.0 * std::f64::consts::PI * fc_hz;
        let k = 2.0 / dt;
        let g = wc / (k + wc);
        let p = (k - wc) / (k + wc);
        LowPass2 {
            b: [g * g, 2.0 * g * g, g * g],
            a: [1.0, -2.0 * p, p * p],
        }
    }

    /// The seed's 50 Hz design at `dt`.
    pub fn seed(dt: f64) -> LowPass2 {
        Self::design(GYRO_FILTER_HZ, dt)
    }

    /// Gain at DC (1 for this design up to rounding).
    pub fn dc_gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / self.a.iter().sum::<f64>()
    }

    /// Group delay at DC, s: how far the causal output lags a ramp (`2/wc` for this design).
    pub fn dc_delay_s(&self, dt: f64) -> f64 {
        let moment = |c: &[f64; 3]| (c[1] + 2.0 * c[2]) / c.iter().sum::<f64>();
        (moment(&self.b) - moment(&self.a)) * dt
    }

    /// How far the zero-phase output at a kink (slope 0 -> 1 per s) sits above the kink,
    /// s: the forward-backward kernel is symmetric, so it reaches half a kernel into the
    /// coming ramp. A Kalman filter that measures rate changes from the filtered rate at a
    /// thruster-word change must subtract `slope change x this` from that rate.
    pub fn zero_phase_kink_offset_s(&self, dt: f64) -> f64 {
        let n = 4 * self.settling_samples().max(50);
        let x: Vec<f64> = (0..2 * n)
            .map(|k| if k > n { (k - n) as f64 * dt } else { 0.0 })
            .collect();
        self.filtfilt(&x)[n]
    }

    /// Causal filtering of a whole series, state started at rest on the first value
    /// (so a constant input passes unchanged from the first sample).
    pub fn filter(&self, x: &[f64]) -> Vec<f64> {
        let mut f = CausalLowPass::new(*self);
        if let Some(&x0) = x.first() {
            f.settle(x0);
        }
        x.iter().map(|&v| f.step(v)).collect()
    }

    /// Zero-phase forward-backward filtering (as MATLAB `filtfilt`): the series is padded
    /// at both ends by odd reflection (so edges do not ring), filtered forward, reversed,
    /// filtered again, reversed and trimmed. The result has no phase lag, so rate steps
    /// keep their timing; its magnitude response is the filter's squared.
    pub fn filtfilt(&self, x: &[f64]) -> Vec<f64> {
        let n = x.len();
        if n < 2 {
            return x.to_vec();
        }
        // pad long enough for the transient of the slower pole to die out
        let pad = self.settling_samples().min(n - 1);
        let mut ext = Vec::with_capacity(n + 2 * pad);
        for i in (1..=pad).rev() {
            ext.push(2.0 * x[0] - x[i]);
        }
        ext.extend_from_slice(x);
        for i in 1..=pad {
            ext.push(2.0 * x[n - 1] - x[n - 1 - i]);
        }
        let mut y = self.filter(&ext);
        y.reverse();
        let mut y = self.filter(&y);
        y.reverse();
        y[pad..pad + n].to_vec()
    }

    /// Samples for the pole's transient to fall below 1e-9 (at least 9, MATLAB's 3x order).
    fn settling_samples(&self) -> usize {
        // double pole p = sqrt(a2) (sign from a1)
        let p = self.a[2].sqrt();
        if p <= 1e-12 {
            return 9;
        }
        let n = (1e-9f64.ln() / p.ln()).ceil() as usize;
        n.clamp(9, 100_000)
    }
}

/// The same filter run one sample at a time (online, causal; direct form II transposed).
#[derive(Clone, Copy, Debug)]
pub struct CausalLowPass {
    pub filter: LowPass2,
    z: [f64; 2],
}

impl CausalLowPass {
    pub fn new(filter: LowPass2) -> Self {
        CausalLowPass {
            filter,
            z: [0.0; 2],
        }
    }

    /// Sets the state to the steady state for a constant input `x0`.
    pub fn settle(&mut self, x0: f64) {
        let LowPass2 { b, a } = self.filter;
        let y0 = x0 * self.filter.dc_gain();
        self.z[1] = b[2] * x0 - a[2] * y0;
        self.z[0] = b[1] * x0 - a[1] * y0 + self.z[1];
    }

    /// Filters one sample.
    pub fn step(&mut self, x: f64) -> f64 {
        let LowPass2 { b, a } = self.filter;
        let y = b[0] * x + self.z[0];
        self.z[0] = b[1] * x - a[1] * y + self.z[1];
        self.z[1] = b[2] * x - a[2] * y;
        y
    }
}

/// Offline pre-processing of seed `massid_kc1.m`: counts to rad/s, interpolation over gaps,
/// then the 50 Hz two-pole filter forward-backward on each axis.
pub fn preprocess_offline(rec: &Recording, sat: &Satellite) -> Rates {
    let mut r = uniform_rates(rec, sat);
    if r.len() < 2 {
        return r;
    }
    let lp = LowPass2::seed(r.dt);
    for a in 0..3 {
        let y = lp.filtfilt(&r.axis(a));
        r.set_axis(a, &y);
    }
    r
}

/// Online pre-processing: the same, but the filter causal (what flight code can run).
/// Over a gap the online form has nothing to interpolate towards; it holds the last value
/// (flight code sees no gaps: they happen in telemetry, after the estimator).
pub fn preprocess_causal(rec: &Recording, sat: &Satellite) -> Rates {
    let mut r = uniform_rates(rec, sat);
    if r.is_empty() {
        return r;
    }
    let lp = LowPass2::seed(r.dt);
    for a in 0..3 {
        let y = lp.filter(&r.axis(a));
        r.set_axis(a, &y);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::Sample;

    #[test]
    fn design_matches_continuous_response() {
        // The Tustin map sends analog w_a to digital w_d = (2/dt) atan(w_a dt / 2): check
        // the digital gain at w_d equals the analog gain at w_a, and DC gain 1.
        let dt = 0.001;
        let lp = LowPass2::seed(dt);
        assert!((lp.dc_gain() - 1.0).abs() < 1e-12);
        for f_a in [10.0, 50.0, 120.0] {
            let w_a: f64 = 2.0 * std::f64::consts::PI * f_a;
            let w_d = (2.0 / dt) * (w_a * dt / 2.0).atan();
            let z = nalgebra::Complex::from_polar(1.0, w_d * dt);
            let num = lp.b[0] * z * z + lp.b[1] * z + lp.b[2];
            let den = lp.a[0] * z * z + lp.a[1] * z + lp.a[2];
            let g_d = (num / den).norm();
            let wc = 2.0 * std::f64::consts::PI * 50.0;
            let g_a = wc * wc / (w_a * w_a + wc * wc);
            assert!((g_d - g_a).abs() < 1e-9, "f={f_a}: {g_d} vs {g_a}");
        }
    }

    #[test]
    fn filtfilt_keeps_constants_and_ramps_and_has_no_lag() {
        let lp = LowPass2::seed(0.001);
        let c = vec![0.7; 200];
        for v in lp.filtfilt(&c) {
            assert!((v - 0.7).abs() < 1e-12);
        }
        // a ramp passes through a zero-phase, unit-DC filter unchanged (symmetric kernel)
        let ramp: Vec<f64> = (0..500).map(|k| 0.3 + 0.002 * k as f64).collect();
        let y = lp.filtfilt(&ramp);
        for k in 20..480 {
            assert!((y[k] - ramp[k]).abs() < 1e-9, "k={k}");
        }
        // the causal filter lags a ramp by 2/wc seconds (two poles, each 1/wc)
        let yc = lp.filter(&ramp);
        let lag_s = (ramp[400] - yc[400]) / 2.0; // slope 2 rad/s per s
        let wc = 2.0 * std::f64::consts::PI * 50.0;
        assert!((lag_s - 2.0 / wc).abs() < 1e-4, "lag {lag_s}");
    }

    #[test]
    fn delay_and_kink_offset_of_the_seed_filter() {
        // each real pole wc/(s+wc) delays a ramp by 1/wc, and Tustin keeps the DC delay
        let wc = 2.0 * std::f64::consts::PI * 50.0;
        for dt in [0.001, 0.01] {
            let lp = LowPass2::seed(dt);
            assert!((lp.dc_delay_s(dt) - 2.0 / wc).abs() < 1e-12);
        }
        // The zero-phase output at a kink is the one-sided first moment of the symmetric
        // kernel k(tau) = e^(-wc|tau|) (wc + wc^2 |tau|) / 4 (the autocorrelation of
        // h(t) = wc^2 t e^(-wc t)): int_0^inf tau k(tau) dtau = 3 / (4 wc) = 2.39 ms.
        let k = LowPass2::seed(0.001).zero_phase_kink_offset_s(0.001);
        assert!((k / (3.0 / (4.0 * wc)) - 1.0).abs() < 1e-3, "{k}");
    }

    #[test]
    fn causal_step_by_step_equals_batch() {
        let lp = LowPass2::seed(0.01);
        let x: Vec<f64> = (0..50).map(|k| ((k * 7) % 11) as f64).collect();
        let batch = lp.filter(&x);
        let mut f = CausalLowPass::new(lp);
        f.settle(x[0]);
        for (k, &v) in x.iter().enumerate() {
            assert_eq!(f.step(v), batch[k]);
        }
    }

    #[test]
    fn gaps_are_interpolated_and_words_nearest() {
        let s = |t: u64, g: u16, w: u16| Sample {
            time_ms: t,
            gyro: [g, 2070, 2058],
            accel: [2048; 3],
            thrusters: w,
        };
        let rec = Recording::new(
            "g.csv",
            Some("sph2"),
            Some(1000.0),
            vec![s(0, 2077, 0), s(1, 2077, 0), s(5, 2081, 8), s(6, 2081, 8)],
        );
        let sat = Satellite::builtin("sph2").unwrap();
        let r = uniform_rates(&rec, &sat);
        assert_eq!(r.len(), 7);
        assert_eq!(
            r.interpolated,
            vec![false, false, true, true, true, false, false]
        );
        let scale = 1412.79;
        for (k, expect_counts) in [(2, 1.0), (3, 2.0), (4, 3.0)] {
            assert!((r.omega[k][0] - expect_counts / scale).abs() < 1e-12);
        }
        assert_eq!(r.words, vec![0, 0, 0, 0, 8, 8, 8]);
        assert!((r.dt - 0.001).abs() < 1e-15);
    }
}
