//! Angular-acceleration estimators (seed section 4.4.2): line fits (centred
//! non-overlapping, centred sliding, causal backward) and the constant-state Kalman filter
//! of seed Fig. 4.6 / eq. 3.12. Each returns its variance.
//!
//! Variances are the formal ones for white measurement noise of variance `r` per sample:
//! a least-squares line fit over `n` points spaced `dt` has slope variance
//! `r / sum((t_i - t_mean)^2) = 12 r / (dt^2 n (n^2 - 1))`, whether windows overlap or not;
//! the Kalman filter carries its own `P`.
use crate::preprocess::Rates;
use crate::satellite::Satellite;
use nalgebra::{Matrix3, Vector3};

/// Seed Fig. 4.5: variance of the 50 Hz-filtered gyro signal per axis, (rad/s)^2,
/// the Kalman filter's measurement covariance `R` (`R = 1e-7 * diag(9.5661, 2.7365, 2.3044)`).
pub const SEED_R0: [f64; 3] = [9.5661e-7, 2.7365e-7, 2.3044e-7];
/// The Kalman filter's covariance at every reset (seed `P_inv_minus = 2*eye(3)`), rad^2/s^4.
pub const SEED_KF_P0: f64 = 0.5;
/// Valve transient skipped after every thruster-word change, s (seed: 10 updates at 1 kHz).
pub const VALVE_TRANSIENT_S: f64 = 0.010;
/// The seed skips the transient only when sampling faster than this period, s.
pub const SKIP_ONLY_BELOW_DT_S: f64 = 0.005;
/// The seed's printed Kalman-filter variance "at the end of this data set", rad^2/s^4.
pub const SEED_KF_FINAL_VARIANCE: f64 = 5.4508e-5;

/// Slope variance of a least-squares line fit over `n` equally spaced points.
pub fn line_fit_variance(r: f64, dt: f64, n: usize) -> f64 {
    let n = n as f64;
    12.0 * r / (dt * dt * n * (n * n - 1.0))
}

/// Least-squares slope of `y` over equally spaced points `dt` apart.
pub fn line_fit_slope(y: &[f64], dt: f64) -> f64 {
    let n = y.len() as f64;
    let c = (n - 1.0) / 2.0;
    let mut num = 0.0;
    let mut den = 0.0;
    for (i, v) in y.iter().enumerate() {
        let d = i as f64 - c;
        num += d * v;
        den += d * d;
    }
    num / (den * dt)
}

/// One line-fit estimate: the slope, the sample index it belongs to, and its variance for
/// white rate noise of the variance `r` the fit was given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFitEstimate {
    /// Sample the estimate is attributed to (window centre, or its last sample when causal).
    pub index: usize,
    pub omega_dot: f64,
    /// `12 r / (dt^2 n (n^2 - 1))`, rad^2/s^4.
    pub variance: f64,
}

/// Centred non-overlapping line fit: windows of odd length `n` laid end to end, one
/// estimate per window at its centre. Acausal (offline only).
pub fn line_fit_non_overlapping(y: &[f64], dt: f64, n: usize, r: f64) -> Vec<LineFitEstimate> {
    assert!(n >= 2, "a line fit needs at least 2 points");
    let variance = line_fit_variance(r, dt, n);
    y.chunks_exact(n)
        .enumerate()
        .map(|(w, chunk)| LineFitEstimate {
            index: w * n + n / 2,
            omega_dot: line_fit_slope(chunk, dt),
            variance,
        })
        .collect()
}

/// Centred sliding ("overlapping") line fit: a window of odd length `n` centred on every
/// sample that has `n/2` neighbours on both sides. Acausal (offline only).
pub fn line_fit_sliding(y: &[f64], dt: f64, n: usize, r: f64) -> Vec<LineFitEstimate> {
    assert!(n >= 2, "a line fit needs at least 2 points");
    let variance = line_fit_variance(r, dt, n);
    y.windows(n)
        .enumerate()
        .map(|(s, w)| LineFitEstimate {
            index: s + n / 2,
            omega_dot: line_fit_slope(w, dt),
            variance,
        })
        .collect()
}

/// Causal backward line fit: at every sample, the slope of the last `n` samples
/// (usable online; it estimates the acceleration `(n-1)/2` samples in the past).
pub fn line_fit_backward(y: &[f64], dt: f64, n: usize, r: f64) -> Vec<LineFitEstimate> {
    assert!(n >= 2, "a line fit needs at least 2 points");
    let variance = line_fit_variance(r, dt, n);
    y.windows(n)
        .enumerate()
        .map(|(s, w)| LineFitEstimate {
            index: s + n - 1,
            omega_dot: line_fit_slope(w, dt),
            variance,
        })
        .collect()
}

/// The Kalman filter of seed Fig. 4.6 with eq. 3.12: the state is the angular
/// acceleration, constant during a firing (`phi = 1`, `Q = 0`); the measurement is the
/// rate change since the firing began, `z_k = omega_k - omega_0 = H_k x + v`,
/// `H_k = k dt I` (here `k dt` is the time since the thruster word changed), `R = R0`.
/// Written in the seed's information form:
/// `P_k^-1 = P_k^-^-1 + H' R^-1 H`, `K = P_k H' R^-1`, `x_k = x_k^- + K (z_k - H x_k^-)`.
#[derive(Clone, Debug)]
pub struct OmegaDotKalman {
    /// Current estimate, rad/s^2.
    pub x: Vector3<f64>,
    /// Current information (inverse covariance).
    pub p_inv: Matrix3<f64>,
    /// Measurement covariance (rad/s)^2.
    pub r: Matrix3<f64>,
    /// Rate at the reset, the zero of the measurement.
    pub omega0: Vector3<f64>,
    /// Updates since the last reset.
    pub updates: usize,
}

impl OmegaDotKalman {
    pub fn new(r0: [f64; 3]) -> Self {
        OmegaDotKalman {
            x: Vector3::zeros(),
            p_inv: Matrix3::identity() / SEED_KF_P0,
            r: Matrix3::from_diagonal(&Vector3::from(r0)),
            omega0: Vector3::zeros(),
            updates: 0,
        }
    }

    /// Reset at a thruster-word change: the prior is the nominal model's prediction with a
    /// conservative covariance `p0 I`; `omega0` is the rate at the change.
    pub fn reset(&mut self, prior: Vector3<f64>, p0: f64, omega0: Vector3<f64>) {
        self.x = prior;
        self.p_inv = Matrix3::identity() / p0;
        self.omega0 = omega0;
        self.updates = 0;
    }

    /// One measurement update with rate `omega` taken `t_since_reset` seconds after the
    /// change (`H = t I`). Propagation is the identity (`phi = 1`, `Q = 0`).
    pub fn update(&mut self, omega: Vector3<f64>, t_since_reset: f64) {
        let h = Matrix3::identity() * t_since_reset;
        let r_inv = Matrix3::from_diagonal(&self.r.diagonal().map(|v| 1.0 / v));
        self.p_inv += h.transpose() * r_inv * h;
        let p = self.covariance();
        let k = p * h.transpose() * r_inv;
        let z = omega - self.omega0;
        self.x += k * (z - h * self.x);
        self.updates += 1;
    }

    /// Estimate covariance `P = (P^-1)^-1`.
    pub fn covariance(&self) -> Matrix3<f64> {
        // P^-1 is diagonal-dominant and positive definite by construction
        self.p_inv
            .try_inverse()
            .unwrap_or_else(|| Matrix3::from_diagonal_element(f64::INFINITY))
    }

    /// Per-axis variance of the estimate, rad^2/s^4.
    pub fn variance(&self) -> [f64; 3] {
        let p = self.covariance();
        [p[(0, 0)], p[(1, 1)], p[(2, 2)]]
    }
}

/// Closed form of the filter's variance after `n` updates at spacing `dt` from a reset
/// with covariance `p0`: `1 / (1/p0 + dt^2 n(n+1)(2n+1) / (6 r))` (sum of `(k dt)^2 / r`).
pub fn kalman_variance_after(r: f64, p0: f64, dt: f64, n: usize) -> f64 {
    let n = n as f64;
    1.0 / (1.0 / p0 + dt * dt * n * (n + 1.0) * (2.0 * n + 1.0) / (6.0 * r))
}

/// Options of the per-firing Kalman run.
#[derive(Clone, Copy, Debug)]
pub struct KalmanConfig {
    /// Measurement variance per axis, (rad/s)^2.
    pub r0: [f64; 3],
    /// Covariance at every reset.
    pub p0: f64,
    /// Samples this long after a word change are not used (valve transient), s.
    pub transient_s: f64,
    /// The transient is skipped only when the sample period is below this, s.
    pub skip_only_below_dt_s: f64,
    /// Lag of the rates behind the body (a causal filter's group delay), s: the
    /// measurement model becomes `H = (t - t_change - delay)`. 0 for zero-phase rates.
    pub measurement_delay_s: f64,
    /// For zero-phase filtered rates: how far the filtered rate at a kink overshoots
    /// ([`crate::preprocess::LowPass2::zero_phase_kink_offset_s`]); the reference rate at a
    /// word change is corrected by `(new - old acceleration) x this`. 0 = no correction.
    pub kink_offset_s: f64,
}

impl Default for KalmanConfig {
    fn default() -> Self {
        KalmanConfig {
            r0: SEED_R0,
            p0: SEED_KF_P0,
            transient_s: VALVE_TRANSIENT_S,
            skip_only_below_dt_s: SKIP_ONLY_BELOW_DT_S,
            measurement_delay_s: 0.0,
            kink_offset_s: 0.0,
        }
    }
}

impl KalmanConfig {
    /// Number of samples after a change that are skipped at sample period `dt`.
    pub fn skip_samples(&self, dt: f64) -> usize {
        if dt < self.skip_only_below_dt_s {
            (self.transient_s / dt).round() as usize
        } else {
            0
        }
    }
}

/// One angular-acceleration estimate of the Kalman filter, at one sample of a firing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OmegaDotEstimate {
    /// Sample index in the `Rates` it came from.
    pub index: usize,
    pub t_s: f64,
    /// Thruster word during this firing.
    pub word: u16,
    /// Index of the firing (run of constant non-zero word) this estimate belongs to.
    pub firing: usize,
    /// Filtered body rate at this sample, rad/s.
    pub omega: [f64; 3],
    /// Thrust-induced angular acceleration estimate `I^-1 tau`, rad/s^2 (the total is this
    /// plus [`gyroscopic_omega_dot`] at `omega`).
    pub omega_dot: [f64; 3],
    /// Its variance per axis (diagonal of P), rad^2/s^4.
    pub variance: [f64; 3],
}

/// The nominal model's prediction of the angular acceleration for a thruster word at
/// rate `omega` (seed: `x_minus = inv(I_nom) * cross(L, D) * Fk'`, plus the gyroscopic
/// term of eq. 3.1): `I^-1 (tau - omega x I omega)`.
pub fn nominal_omega_dot(sat: &Satellite, word: u16, omega: Vector3<f64>) -> Vector3<f64> {
    let i = sat.inertia_matrix();
    let (_, tau) = sat.force_torque_for_word(word);
    let rhs = tau - omega.cross(&(i * omega));
    i.lu().solve(&rhs).unwrap_or_else(Vector3::zeros)
}

/// The gyroscopic part of the angular acceleration at rate `omega` with the nominal
/// inertia, `-I^-1 (omega x I omega)` (seed eq. 3.1).
pub fn gyroscopic_omega_dot(sat: &Satellite, omega: &Vector3<f64>) -> Vector3<f64> {
    let i = sat.inertia_matrix();
    i.lu()
        .solve(&(-omega.cross(&(i * omega))))
        .unwrap_or_else(Vector3::zeros)
}

/// Runs the Kalman filter over every firing of `rates` (seed `wdotkalman.m`): reset at
/// each change of the thruster word to the nominal prediction, skip the valve transient,
/// one update per remaining sample with a non-zero word.
///
/// The state is the thrust-induced acceleration `I^-1 tau`, constant during a firing as
/// eq. 3.12 assumes. The gyroscopic part `-I^-1 (omega x I omega)` is not constant (it grows
/// with `omega^2`, 0.6 % of the torque cross-axis at the RGA maneuvers' 0.9 rad/s), so its
/// integral since the change (nominal inertia, trapezoid) is subtracted from the
/// measurement; the prior is the nominal `I^-1 tau` (seed `x_minus = inv(I_nom)*cross(L,D)*Fk'`).
/// Fitting the total rate instead makes the constant-state filter average a growing term
/// that the LS rows take at its current value, which biased the products of inertia by
/// about their own size on `o01`.
///
/// Timing convention (as the recordings are made: the word of sample `k` acts over
/// `[t_k, t_k+1)`, measured on `o01`: the extrapolated rate ramps start within 0.5 ms of the
/// word's first sample): the zero of the measurement is the rate at the change sample,
/// and `H = (k - k_change) dt`. The seed's listing takes the sample before the change and
/// restarts `H` after the skipped transient; both bias the estimate by ~1 % on a 1 s firing.
pub fn kalman_per_firing(
    rates: &Rates,
    sat: &Satellite,
    cfg: &KalmanConfig,
) -> Vec<OmegaDotEstimate> {
    let mut out = Vec::new();
    let mut kf = OmegaDotKalman::new(cfg.r0);
    let skip = cfg.skip_samples(rates.dt);
    let mut current: Option<(u16, usize)> = None; // (word, index of the change)
    let mut last_omega_dot = Vector3::zeros(); // thrust acceleration just before the change
    let mut gyro_integral = Vector3::zeros(); // rate change due to omega x I omega since the change
    let mut gyro_prev = Vector3::zeros();
    for k in 0..rates.len() {
        let word = rates.words[k] & 0x0fff;
        let omega = Vector3::from(rates.omega[k]);
        if word == 0 {
            current = None;
            last_omega_dot = Vector3::zeros();
            continue;
        }
        let gyro = gyroscopic_omega_dot(sat, &omega);
        let start = match current {
            Some((w, s)) if w == word => {
                gyro_integral += (gyro_prev + gyro) * (0.5 * rates.dt);
                s
            }
            _ => {
                let prior = nominal_omega_dot(sat, word, Vector3::zeros());
                let omega0 = omega - (prior - last_omega_dot) * cfg.kink_offset_s;
                kf.reset(prior, cfg.p0, omega0);
                gyro_integral = Vector3::zeros();
                current = Some((word, k));
                k
            }
        };
        gyro_prev = gyro;
        // samples since the change; the change's own sample (H = 0) carries no information
        let since = k - start;
        if since == 0 || since <= skip {
            continue;
        }
        let h = since as f64 * rates.dt - cfg.measurement_delay_s;
        if h <= 0.0 {
            continue;
        }
        // the known, time-varying gyroscopic part is taken out so the state is constant
        kf.update(omega - gyro_integral, h);
        last_omega_dot = kf.x;
        out.push(OmegaDotEstimate {
            index: k,
            t_s: rates.t_s[k],
            word,
            firing: 0,
            omega: rates.omega[k],
            omega_dot: kf.x.into(),
            variance: kf.variance(),
        });
    }
    renumber_firings(&mut out);
    out
}

/// Numbers firings 0, 1, 2, ... by (word, start) runs of consecutive estimates.
fn renumber_firings(est: &mut [OmegaDotEstimate]) {
    let mut n = 0;
    for i in 0..est.len() {
        if i > 0 {
            let (a, b) = (est[i - 1], est[i]);
            if a.word != b.word || b.index != a.index + 1 {
                n += 1;
            }
        }
        est[i].firing = n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fits_are_exact_on_a_line() {
        let dt = 0.01;
        let y: Vec<f64> = (0..40).map(|k| 1.0 + 0.37 * k as f64 * dt).collect();
        for n in [3, 5, 15] {
            for e in line_fit_sliding(&y, dt, n, 1e-7)
                .iter()
                .chain(&line_fit_non_overlapping(&y, dt, n, 1e-7))
                .chain(&line_fit_backward(&y, dt, n, 1e-7))
            {
                assert!((e.omega_dot - 0.37).abs() < 1e-10);
            }
        }
        let s = line_fit_sliding(&y, dt, 5, 1e-7);
        assert_eq!(s[0].variance, line_fit_variance(1e-7, dt, 5));
        assert_eq!(s[0].index, 2);
        let b = line_fit_backward(&y, dt, 5, 1e-7);
        assert_eq!(b[0].index, 4);
        let no = line_fit_non_overlapping(&y, dt, 5, 1e-7);
        assert_eq!(no.len(), 8);
        assert_eq!(no[1].index, 7);
    }

    #[test]
    fn kalman_variance_matches_closed_form_and_converges() {
        let dt = 0.001;
        let mut kf = OmegaDotKalman::new(SEED_R0);
        let truth = Vector3::new(0.8, -0.2, 0.05);
        kf.reset(Vector3::zeros(), SEED_KF_P0, Vector3::new(0.1, 0.2, 0.3));
        for k in 1..=1000 {
            let t = k as f64 * dt;
            kf.update(Vector3::new(0.1, 0.2, 0.3) + truth * t, t);
            let v = kf.variance();
            for a in 0..3 {
                let c = kalman_variance_after(SEED_R0[a], SEED_KF_P0, dt, k);
                assert!((v[a] - c).abs() <= 1e-9 * c, "k={k} a={a}");
            }
        }
        // noise-free data: the prior's weight (1/p0 = 2) against ~3e8 of data information
        assert!((kf.x - truth).norm() < 1e-6);
    }
}
