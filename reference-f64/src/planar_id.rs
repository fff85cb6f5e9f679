//! Mass-property identification for a planar craft (air-bearing testbed: yaw only, thrusters
//! in the x-y plane, yaw rate measured, e.g. differentiated motion capture at 10-100 Hz with
//! commands held between samples): yaw inertia `Izz`, centre-of-mass offset `(cx, cy)`, rate
//! damping `b` and a constant disturbance torque `d`, with standard errors that account for
//! time-correlated noise, and an explicit verdict on which terms the data do not determine.
//!
//! Physics (body axes, exact for the planar rigid body): thruster `i` at `p_i` from the
//! geometric centre, unit direction `d_i`, force `F_i` when open. With the CoM at the model's
//! `c_model + (dcx, dcy)`,
//! `torque = tau_nom - dcx Fy_net + dcy Fx_net` (`tau_nom` about the model's CoM) and
//! `Izz omega' = torque - b omega + d`. Divided by `Izz` this is linear in
//! `theta = (1/Izz, dcx/Izz, dcy/Izz, b/Izz, d/Izz)`; integrated between consecutive valid
//! rate samples,
//! `omega(t_k+1) - omega(t_k) = theta . integral [tau_nom, -Fy_net, Fx_net, -omega, 1] dt`,
//! the command integrals exact (held words, optional delay and first-order rise), the
//! `omega` integral the trapezoid of the measured rate.
//!
//! **Covariance.** Increments of measured rate carry noise that is correlated in time
//! (motion-capture differentiation and filtering; increments of white noise are MA(1));
//! unmodelled torques (table tilt under translation, thrust scatter) are correlated too. The
//! plain LS covariance assumes neither, so the covariance is HAC:
//! `V = (X'X)^-1 S (X'X)^-1 n/(n-p)`, `S = sum_|l|<=L w(l) G_l` over the scores
//! `g_k = x_k u_k` of the column-normalised problem. Default kernel Parzen, bandwidth
//! `L = max(floor(sqrt n), 2.6614 (alpha2 n)^(1/5))`; Newey-West (Bartlett) is available with
//! `L = max(floor(4 (n/100)^(2/9)), 1.1447 (alpha1 n)^(1/3))` (both Andrews' 1991 AR(1)
//! plug-ins, at most `n/4`). Why Parzen: the rate-noise part of the error is a first
//! difference, so the damping's score sum nearly telescopes; Bartlett's weight `1 - 1/(L+1)`
//! at lag 1 leaves most of that negative correlation uncounted and made the damping's
//! stderr 5x too large on the synthetic craft (Parzen: 2.2x with measurement noise alone,
//! 1.1x with a disturbance torque added; Izz and CoM within 10 % either way; the tests
//! print the figures). Lags count intervals of the original sample sequence (a missing
//! sample leaves a zero score).
//!
//! **Errors in variables.** The `omega` regressor is the trapezoid of the *measured* rate.
//! Its noise `dt (e_k + e_k+1)/2` is uncorrelated with the increment noise `e_k+1 - e_k`
//! when the measurement noise is stationary (`cov = dt (var e_k+1 - var e_k)/2 = 0`), so it
//! adds no first-order bias; what remains is the classical attenuation of `b` by about
//! `var(noise)/var(rate)` (0.25 % for 3 mrad/s of noise on 60 mrad/s of rate), which is not
//! corrected. In closed loop the command of a sample depends on that sample's noise, which
//! the increment also contains; that endogeneity is not corrected either (see the crate
//! README).
//!
//! **Observability.** A term is unobservable when (a) its column is zero, (b) the
//! column-normalised information matrix has a condition number above
//! [`PlanarOptions::max_condition`] (the term with the largest weight in the weakest
//! singular direction goes), or (c) its standard error exceeds its physical scale:
//! CoM `0.25 x` the largest thruster radius, damping `Izz_model / T` (the damping whose time
//! constant is the record length `T`), disturbance `0.1 x` the smallest single-thruster
//! torque. Such terms are held at the model's value (zero offset, no damping, no
//! disturbance), removed and the rest refitted; they are listed in
//! [`PlanarEstimate::unobservable`] and their fields are `None`. `Izz` itself is never held:
//! if it is not determined (standard error above half its value, or a zero / ill-conditioned
//! column) the result is [`PlanarIdError::InsufficientExcitation`]; if it comes out negative,
//! [`PlanarIdError::NegativeInertia`].
use nalgebra::{DMatrix, DVector};

/// Term names, in `theta` order.
pub const PLANAR_TERMS: [&str; 5] = ["Izz", "cm_x", "cm_y", "damping", "disturbance"];

/// One thruster in the plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarThruster {
    /// Position from the geometric centre, m.
    pub pos_m: [f64; 2],
    /// Direction of the force on the craft (used as given; unit length expected).
    pub dir: [f64; 2],
    /// Force when open, N.
    pub force_n: f64,
}

/// The nominal planar model. Thruster `i` is bit `i` of a command word.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarModel {
    pub thrusters: Vec<PlanarThruster>,
    /// Yaw inertia about the CoM, kg m^2.
    pub izz_kgm2: f64,
    /// CoM from the geometric centre, m.
    pub com_m: [f64; 2],
}

/// How the covariance of `theta` is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CovarianceKind {
    /// HAC, Parzen kernel (default).
    Parzen,
    /// Newey-West: HAC, Bartlett kernel.
    NeweyWest,
    /// Plain LS, `s^2 (X'X)^-1`: wrong for correlated noise; for comparison only.
    Ols,
}

/// Options of [`identify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarOptions {
    /// Known command delay: the word of a sample acts from `delay_ms` after its time, ms.
    pub delay_ms: f64,
    /// Known first-order thrust rise (and decay) time constant, ms (0: instantaneous).
    pub rise_ms: f64,
    /// Fit the rate damping `b` (else held at 0).
    pub fit_damping: bool,
    /// Fit a constant disturbance torque `d` (else held at 0).
    pub fit_disturbance: bool,
    /// Covariance estimator.
    pub covariance: CovarianceKind,
    /// Largest condition number of the column-normalised information matrix accepted.
    pub max_condition: f64,
}

impl Default for PlanarOptions {
    fn default() -> Self {
        Self {
            delay_ms: 0.0,
            rise_ms: 0.0,
            fit_damping: true,
            fit_disturbance: true,
            covariance: CovarianceKind::Parzen,
            max_condition: 1e6,
        }
    }
}

/// Result status when an estimate is returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanarStatus {
    /// Every requested term identified.
    Ok,
    /// `Izz` identified; the terms in `unobservable` are held at the model's values.
    UnobservableTerms,
}

/// An identification. Terms that were not fitted (options) or are unobservable are `None`.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarEstimate {
    pub izz_kgm2: f64,
    pub izz_stderr: f64,
    /// Estimated CoM minus the model's, m.
    pub com_offset_m: [Option<f64>; 2],
    pub com_stderr_m: [Option<f64>; 2],
    /// Rate damping `b`, N m s/rad.
    pub damping_nms: Option<f64>,
    pub damping_stderr: Option<f64>,
    /// Constant disturbance torque, N m.
    pub disturbance_nm: Option<f64>,
    pub disturbance_stderr: Option<f64>,
    /// Names (of [`PLANAR_TERMS`]) of the terms the data do not determine.
    pub unobservable: Vec<&'static str>,
    /// RMS of the fitted rate-increment residuals, rad/s.
    pub residual_rms_rad_s: f64,
    pub intervals_used: usize,
    /// Newey-West bandwidth used (0 for plain LS).
    pub hac_bandwidth: usize,
    /// Condition number of the final column-normalised information matrix.
    pub condition_number: f64,
    pub status: PlanarStatus,
}

/// Physical parameters for [`predict`] and [`interval_residuals`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarParams {
    pub izz_kgm2: f64,
    /// CoM minus the model's, m.
    pub com_offset_m: [f64; 2],
    pub damping_nms: f64,
    pub disturbance_nm: f64,
}

impl PlanarParams {
    /// The model as given: no offset, no damping, no disturbance.
    pub fn nominal(model: &PlanarModel) -> Self {
        Self {
            izz_kgm2: model.izz_kgm2,
            com_offset_m: [0.0; 2],
            damping_nms: 0.0,
            disturbance_nm: 0.0,
        }
    }

    fn theta(&self) -> [f64; 5] {
        let a = 1.0 / self.izz_kgm2;
        [
            a,
            self.com_offset_m[0] * a,
            self.com_offset_m[1] * a,
            self.damping_nms * a,
            self.disturbance_nm * a,
        ]
    }
}

impl PlanarEstimate {
    /// The estimate with unfitted / unobservable terms at the model's values.
    pub fn params(&self) -> PlanarParams {
        PlanarParams {
            izz_kgm2: self.izz_kgm2,
            com_offset_m: [
                self.com_offset_m[0].unwrap_or(0.0),
                self.com_offset_m[1].unwrap_or(0.0),
            ],
            damping_nms: self.damping_nms.unwrap_or(0.0),
            disturbance_nm: self.disturbance_nm.unwrap_or(0.0),
        }
    }
}

/// Why no estimate was returned.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanarIdError {
    #[error("invalid_input: {0}")]
    InvalidInput(String),
    #[error("too_few_samples: {used} valid intervals, need {needed}")]
    TooFewSamples { used: usize, needed: usize },
    #[error("insufficient_excitation: {0}")]
    InsufficientExcitation(String),
    #[error("negative_inertia: Izz {izz_kgm2} +- {stderr}")]
    NegativeInertia { izz_kgm2: f64, stderr: f64 },
}

impl PlanarIdError {
    /// The status word: `invalid_input`, `too_few_samples`, `insufficient_excitation`,
    /// `negative_inertia`.
    pub fn status(&self) -> &'static str {
        match self {
            Self::InvalidInput(_) => "invalid_input",
            Self::TooFewSamples { .. } => "too_few_samples",
            Self::InsufficientExcitation(_) => "insufficient_excitation",
            Self::NegativeInertia { .. } => "negative_inertia",
        }
    }
}

/// Per thruster: torque about the model's CoM, net force x, y when fully open.
fn thruster_effects(model: &PlanarModel) -> Vec<[f64; 3]> {
    model
        .thrusters
        .iter()
        .map(|t| {
            let (fx, fy) = (t.force_n * t.dir[0], t.force_n * t.dir[1]);
            let rx = t.pos_m[0] - model.com_m[0];
            let ry = t.pos_m[1] - model.com_m[1];
            [rx * fy - ry * fx, fx, fy]
        })
        .collect()
}

fn validate(
    model: &PlanarModel,
    time_ms: &[u64],
    words: &[u16],
    rate_len: Option<usize>,
    opts: &PlanarOptions,
) -> Result<(), PlanarIdError> {
    let bad = |s: &str| Err(PlanarIdError::InvalidInput(s.to_string()));
    if model.thrusters.is_empty() || model.thrusters.len() > 16 {
        return bad("the model needs 1 to 16 thrusters");
    }
    let finite = model.thrusters.iter().all(|t| {
        t.pos_m.iter().chain(t.dir.iter()).all(|v| v.is_finite()) && t.force_n.is_finite()
    });
    if !finite || !model.com_m.iter().all(|v| v.is_finite()) {
        return bad("non-finite model value");
    }
    if !(model.izz_kgm2.is_finite() && model.izz_kgm2 > 0.0) {
        return bad("the model's Izz must be positive");
    }
    if words.len() != time_ms.len() || rate_len.is_some_and(|n| n != time_ms.len()) {
        return bad("time, rate and word series differ in length");
    }
    if time_ms.windows(2).any(|w| w[1] < w[0]) {
        return bad("time goes backwards");
    }
    if !(opts.delay_ms.is_finite() && opts.delay_ms >= 0.0) {
        return bad("delay_ms must be finite and >= 0");
    }
    if !(opts.rise_ms.is_finite() && opts.rise_ms >= 0.0) {
        return bad("rise_ms must be finite and >= 0");
    }
    Ok(())
}

/// Effective open fraction `z_i` of each thruster: the held word (delayed), through the
/// first-order rise. Steps the state over `[t0, t1]` and returns per-thruster integrals.
struct CommandSweep<'a> {
    time_s: Vec<f64>,
    words: &'a [u16],
    delay_s: f64,
    rise_s: f64,
    z: Vec<f64>,
    word: u16,
    next_event: usize,
    t: f64,
}

impl<'a> CommandSweep<'a> {
    fn new(time_ms: &[u64], words: &'a [u16], n_thr: usize, opts: &PlanarOptions) -> Self {
        let time_s: Vec<f64> = time_ms.iter().map(|&t| t as f64 / 1000.0).collect();
        let t = time_s.first().copied().unwrap_or(0.0);
        Self {
            time_s,
            words,
            delay_s: opts.delay_ms / 1000.0,
            rise_s: opts.rise_ms / 1000.0,
            z: vec![0.0; n_thr],
            word: 0,
            next_event: 0,
            t,
        }
    }

    fn apply_events(&mut self) {
        while self.next_event < self.time_s.len()
            && self.time_s[self.next_event] + self.delay_s <= self.t
        {
            self.word = self.words[self.next_event];
            self.next_event += 1;
        }
    }

    /// End of the current constant-command segment, at most `end`.
    fn segment_end(&self, end: f64) -> f64 {
        match self.time_s.get(self.next_event) {
            Some(&te) => (te + self.delay_s).min(end),
            None => end,
        }
    }

    /// Advance to `end`, calling `seg(t_start, h, word, z_start)` for each segment, and
    /// return the integral of each `z_i`.
    fn advance(&mut self, end: f64, mut seg: impl FnMut(f64, f64, u16, &[f64])) -> Vec<f64> {
        let mut acc = vec![0.0; self.z.len()];
        while self.t < end {
            self.apply_events();
            let next = self.segment_end(end);
            let h = next - self.t;
            if h > 0.0 {
                seg(self.t, h, self.word, &self.z);
                for (i, (zi, ai)) in self.z.iter_mut().zip(acc.iter_mut()).enumerate() {
                    let u = if self.word >> i & 1 == 1 { 1.0 } else { 0.0 };
                    if self.rise_s > 0.0 {
                        let decay = (-h / self.rise_s).exp();
                        *ai += u * h + (*zi - u) * self.rise_s * -(-h / self.rise_s).exp_m1();
                        *zi = u + (*zi - u) * decay;
                    } else {
                        *ai += u * h;
                        *zi = u;
                    }
                }
            }
            self.t = next;
        }
        self.apply_events();
        acc
    }
}

/// Per interval `k` (samples `k`, `k+1`): `(y, x)` when both rates are finite and `dt > 0`.
fn regressors(
    model: &PlanarModel,
    time_ms: &[u64],
    rate: &[f64],
    words: &[u16],
    opts: &PlanarOptions,
) -> Vec<Option<(f64, [f64; 5])>> {
    let eff = thruster_effects(model);
    let mut sweep = CommandSweep::new(time_ms, words, eff.len(), opts);
    let first_active = time_ms.first().map_or(0.0, |&t| t as f64 / 1000.0) + opts.delay_ms / 1000.0;
    let mut out = Vec::with_capacity(time_ms.len().saturating_sub(1));
    for k in 0..time_ms.len().saturating_sub(1) {
        let (t0, t1) = (sweep.time_s[k], sweep.time_s[k + 1]);
        let z = sweep.advance(t1, |_, _, _, _| {});
        let (w0, w1) = (rate[k], rate[k + 1]);
        // Before the first word acts (delay) the command is unknown: skipped.
        if !(w0.is_finite() && w1.is_finite()) || t1 <= t0 || t0 < first_active - 1e-12 {
            out.push(None);
            continue;
        }
        let dt = t1 - t0;
        let mut x = [0.0, 0.0, 0.0, -0.5 * (w0 + w1) * dt, dt];
        for (zi, e) in z.iter().zip(eff.iter()) {
            x[0] += zi * e[0];
            x[1] -= zi * e[2];
            x[2] += zi * e[1];
        }
        out.push(Some((w1 - w0, x)));
    }
    out
}

/// Lag-window weight of lag `l` for bandwidth `bw`: Bartlett `1 - l/(bw+1)`, Parzen
/// `k(l/(bw+1))` with `k(x) = 1 - 6x^2 + 6x^3` (x <= 1/2), `2 (1-x)^3` (x <= 1).
fn lag_weight(kind: CovarianceKind, l: usize, bw: usize) -> f64 {
    let x = l as f64 / (bw as f64 + 1.0);
    match kind {
        CovarianceKind::Parzen => {
            if x <= 0.5 {
                1.0 - 6.0 * x * x + 6.0 * x * x * x
            } else {
                2.0 * (1.0 - x).powi(3)
            }
        }
        _ => 1.0 - x,
    }
}

/// Long-run covariance of the scores `g` (rows = intervals) with the kernel of `kind`.
fn long_run(g: &DMatrix<f64>, bandwidth: usize, kind: CovarianceKind) -> DMatrix<f64> {
    let (n, p) = g.shape();
    let mut s = g.transpose() * g;
    for l in 1..=bandwidth.min(n.saturating_sub(1)) {
        let w = lag_weight(kind, l, bandwidth);
        let a = g.rows(l, n - l);
        let b = g.rows(0, n - l);
        let gl = a.transpose() * b;
        s += (&gl + gl.transpose()) * w;
    }
    debug_assert_eq!(s.shape(), (p, p));
    s
}

/// Bandwidth: Bartlett `max(floor(4 (n/100)^(2/9)), 1.1447 (alpha1 n)^(1/3))`, Parzen
/// `max(floor(sqrt n), 2.6614 (alpha2 n)^(1/5))` (Andrews 1991, AR(1) plug-in on each
/// column of the normalised scores, unit weights); at most `n/4`.
fn bandwidth(g: &DMatrix<f64>, n_used: usize, kind: CovarianceKind) -> usize {
    let n = n_used as f64;
    let (rows, p) = g.shape();
    let (mut num1, mut num2, mut den) = (0.0, 0.0, 0.0);
    for j in 0..p {
        let c = g.column(j);
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for k in 1..rows {
            sxy += c[k] * c[k - 1];
            sxx += c[k - 1] * c[k - 1];
        }
        if sxx <= 0.0 {
            continue;
        }
        let rho = (sxy / sxx).clamp(-0.97, 0.97);
        let mut s2 = 0.0;
        for k in 1..rows {
            let e = c[k] - rho * c[k - 1];
            s2 += e * e;
        }
        let s4 = (s2 / n).powi(2);
        num1 += 4.0 * rho * rho * s4 / ((1.0 - rho).powi(6) * (1.0 + rho).powi(2));
        num2 += 4.0 * rho * rho * s4 / (1.0 - rho).powi(8);
        den += s4 / (1.0 - rho).powi(4);
    }
    let plug = |num: f64, c: f64, pow: f64| {
        let v = (c * (num / den * n).powf(pow)).floor();
        if den > 0.0 && v.is_finite() {
            v
        } else {
            0.0
        }
    };
    let l = match kind {
        CovarianceKind::Parzen => n.sqrt().floor().max(plug(num2, 2.6614, 0.2)),
        _ => (4.0 * (n / 100.0).powf(2.0 / 9.0))
            .floor()
            .max(plug(num1, 1.1447, 1.0 / 3.0)),
    };
    (l.min((n / 4.0).floor()).max(1.0)) as usize
}

struct Fit {
    theta: DVector<f64>,
    cov: DMatrix<f64>,
    resid_rms: f64,
    bandwidth: usize,
    condition: f64,
}

/// LS on the active columns. `Err(j)`: column `j` (index into `cols`) is unidentifiable.
fn fit(
    rows: &[Option<(f64, [f64; 5])>],
    cols: &[usize],
    kind: CovarianceKind,
    max_condition: f64,
) -> Result<Fit, usize> {
    let p = cols.len();
    let n_all = rows.len();
    let used: Vec<usize> = (0..n_all).filter(|&k| rows[k].is_some()).collect();
    let n = used.len();
    let mut x = DMatrix::<f64>::zeros(n_all, p);
    let mut y = DVector::<f64>::zeros(n_all);
    for &k in &used {
        if let Some((yk, xk)) = &rows[k] {
            y[k] = *yk;
            for (j, &c) in cols.iter().enumerate() {
                x[(k, j)] = xk[c];
            }
        }
    }
    // Column normalisation.
    let mut norms = vec![0.0; p];
    for j in 0..p {
        let nj = x.column(j).norm();
        if !(nj.is_finite() && nj > 0.0) {
            return Err(j);
        }
        norms[j] = nj;
        x.column_mut(j).scale_mut(1.0 / nj);
    }
    let svd = x.clone().svd(false, true);
    let sv = &svd.singular_values;
    let (mut imax, mut imin) = (0, 0);
    for i in 0..sv.len() {
        if sv[i] > sv[imax] {
            imax = i;
        }
        if sv[i] < sv[imin] {
            imin = i;
        }
    }
    let condition = sv[imax] / sv[imin];
    if !(condition.is_finite() && condition <= max_condition) {
        let Some(vt) = svd.v_t.as_ref() else {
            return Err(0);
        };
        let row = vt.row(imin);
        let mut worst = 0;
        for j in 0..p {
            if row[j].abs() > row[worst].abs() {
                worst = j;
            }
        }
        return Err(worst);
    }
    let info = x.transpose() * &x;
    let Some(info_inv) = info.clone().try_inverse() else {
        return Err(0);
    };
    let ths = &info_inv * (x.transpose() * &y);
    let u = &y - &x * &ths;
    let ssr = u.norm_squared();
    let dof = (n as f64 - p as f64).max(1.0);
    let (cov_s, l) = match kind {
        CovarianceKind::Ols => (&info_inv * (ssr / dof), 0),
        _ => {
            let mut g = x.clone();
            for k in 0..n_all {
                g.row_mut(k).scale_mut(u[k]);
            }
            let l = bandwidth(&g, n, kind);
            let s = long_run(&g, l, kind);
            (&info_inv * s * &info_inv * (n as f64 / dof), l)
        }
    };
    let d_inv = DVector::from_iterator(p, norms.iter().map(|v| 1.0 / v));
    let theta = ths.component_mul(&d_inv);
    let dm = DMatrix::from_diagonal(&d_inv);
    let cov = &dm * cov_s * &dm;
    Ok(Fit {
        theta,
        cov,
        resid_rms: (ssr / n as f64).sqrt(),
        bandwidth: l,
        condition,
    })
}

/// Physical values and standard errors (delta method) of the active terms.
fn physical(theta: &DVector<f64>, cov: &DMatrix<f64>) -> (Vec<f64>, Vec<f64>) {
    let p = theta.len();
    let a = theta[0];
    let mut val = vec![1.0 / a];
    let mut jac = DMatrix::<f64>::zeros(p, p);
    jac[(0, 0)] = -1.0 / (a * a);
    for j in 1..p {
        val.push(theta[j] / a);
        jac[(j, 0)] = -theta[j] / (a * a);
        jac[(j, j)] = 1.0 / a;
    }
    let c = &jac * cov * jac.transpose();
    let se = (0..p).map(|j| c[(j, j)].max(0.0).sqrt()).collect();
    (val, se)
}

/// Identify `Izz`, the CoM offset, damping and disturbance from a yaw-rate record.
///
/// `time_ms` sample times (non-decreasing), `rate_z` measured yaw rate (rad/s, NaN = missing:
/// the intervals touching it are skipped), `words` the command held from each sample (bit `i`
/// = thruster `i`) until the next, acting `opts.delay_ms` later.
pub fn identify(
    model: &PlanarModel,
    time_ms: &[u64],
    rate_z: &[f64],
    words: &[u16],
    opts: &PlanarOptions,
) -> Result<PlanarEstimate, PlanarIdError> {
    validate(model, time_ms, words, Some(rate_z.len()), opts)?;
    let rows = regressors(model, time_ms, rate_z, words, opts);
    let used = rows.iter().filter(|r| r.is_some()).count();
    let span_s: f64 = rows.iter().flatten().map(|(_, x)| x[4]).sum();
    let eff = thruster_effects(model);
    let radius = model
        .thrusters
        .iter()
        .map(|t| t.pos_m[0].hypot(t.pos_m[1]))
        .fold(0.0, f64::max);
    let min_torque = eff
        .iter()
        .map(|e| e[0].abs())
        .filter(|v| *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let scale = |term: usize| match term {
        1 | 2 => 0.25 * radius,
        3 => model.izz_kgm2 / span_s.max(1e-9),
        4 => {
            0.1 * if min_torque.is_finite() {
                min_torque
            } else {
                1.0
            }
        }
        _ => f64::INFINITY,
    };
    let mut cols: Vec<usize> = vec![0, 1, 2];
    if opts.fit_damping {
        cols.push(3);
    }
    if opts.fit_disturbance {
        cols.push(4);
    }
    let mut unobservable: Vec<&'static str> = Vec::new();
    loop {
        let needed = (10 * cols.len()).max(30);
        if used < needed {
            return Err(PlanarIdError::TooFewSamples { used, needed });
        }
        let f = match fit(&rows, &cols, opts.covariance, opts.max_condition) {
            Ok(f) => f,
            Err(0) => {
                return Err(PlanarIdError::InsufficientExcitation(
                    "the nominal-torque column is zero or collinear with the others".into(),
                ))
            }
            Err(j) => {
                unobservable.push(PLANAR_TERMS[cols[j]]);
                cols.remove(j);
                continue;
            }
        };
        let (a, se_a) = (f.theta[0], f.cov[(0, 0)].max(0.0).sqrt());
        let a_clear = a > 0.0 && a > 2.0 * se_a;
        let (val, se) = physical(&f.theta, &f.cov);
        // Standard error over physical scale, per non-Izz term; in theta units at the model's
        // Izz when 1/Izz is not clearly positive (the delta method is meaningless there).
        let mut worst: Option<(usize, f64)> = None;
        for j in 1..cols.len() {
            let s = if a_clear {
                se[j]
            } else {
                f.cov[(j, j)].max(0.0).sqrt() * model.izz_kgm2
            };
            let r = s / scale(cols[j]);
            let r = if r.is_nan() { f64::INFINITY } else { r };
            if r > 1.0 && worst.is_none_or(|(_, w)| r > w) {
                worst = Some((j, r));
            }
        }
        if let Some((j, _)) = worst {
            unobservable.push(PLANAR_TERMS[cols[j]]);
            cols.remove(j);
            continue;
        }
        if !(a.is_finite() && se_a.is_finite()) {
            return Err(PlanarIdError::InsufficientExcitation(
                "non-finite fit".into(),
            ));
        }
        if a <= 0.0 {
            if a + 2.0 * se_a < 0.0 {
                return Err(PlanarIdError::NegativeInertia {
                    izz_kgm2: val[0],
                    stderr: se[0],
                });
            }
            return Err(PlanarIdError::InsufficientExcitation(format!(
                "1/Izz = {a:.4} +- {se_a:.4} is not clearly positive"
            )));
        }
        if se_a > 0.5 * a {
            return Err(PlanarIdError::InsufficientExcitation(format!(
                "Izz {:.4} +- {:.4}: standard error above half the value",
                val[0], se[0]
            )));
        }
        let get = |term: usize| {
            cols.iter()
                .position(|&c| c == term)
                .map(|j| (val[j], se[j]))
        };
        let cx = get(1);
        let cy = get(2);
        let b = get(3);
        let d = get(4);
        let status = if unobservable.is_empty() {
            PlanarStatus::Ok
        } else {
            PlanarStatus::UnobservableTerms
        };
        unobservable.sort_by_key(|n| PLANAR_TERMS.iter().position(|t| t == n));
        return Ok(PlanarEstimate {
            izz_kgm2: val[0],
            izz_stderr: se[0],
            com_offset_m: [cx.map(|v| v.0), cy.map(|v| v.0)],
            com_stderr_m: [cx.map(|v| v.1), cy.map(|v| v.1)],
            damping_nms: b.map(|v| v.0),
            damping_stderr: b.map(|v| v.1),
            disturbance_nm: d.map(|v| v.0),
            disturbance_stderr: d.map(|v| v.1),
            unobservable,
            residual_rms_rad_s: f.resid_rms,
            intervals_used: used,
            hac_bandwidth: f.bandwidth,
            condition_number: f.condition,
            status,
        });
    }
}

/// One-interval-ahead residuals: measured rate increment minus the increment the parameters
/// predict from the same regressors (the identification's own equation). `NaN` for skipped
/// intervals; length `n - 1`.
pub fn interval_residuals(
    model: &PlanarModel,
    params: &PlanarParams,
    opts: &PlanarOptions,
    time_ms: &[u64],
    rate_z: &[f64],
    words: &[u16],
) -> Result<Vec<f64>, PlanarIdError> {
    validate(model, time_ms, words, Some(rate_z.len()), opts)?;
    let th = params.theta();
    Ok(regressors(model, time_ms, rate_z, words, opts)
        .into_iter()
        .map(|r| match r {
            Some((y, x)) => y - (0..5).map(|j| th[j] * x[j]).sum::<f64>(),
            None => f64::NAN,
        })
        .collect())
}

/// The yaw rate at each sample time from `omega0` at the first, integrating
/// `Izz omega' = torque - b omega + d` with the held (delayed, risen) commands (RK4, steps of
/// at most 1 ms inside each constant-command segment).
pub fn predict(
    model: &PlanarModel,
    params: &PlanarParams,
    opts: &PlanarOptions,
    time_ms: &[u64],
    words: &[u16],
    omega0: f64,
) -> Result<Vec<f64>, PlanarIdError> {
    validate(model, time_ms, words, None, opts)?;
    if !(params.izz_kgm2.is_finite() && params.izz_kgm2 > 0.0) {
        return Err(PlanarIdError::InvalidInput("Izz must be positive".into()));
    }
    let eff = thruster_effects(model);
    let [dcx, dcy] = params.com_offset_m;
    // Torque per unit open fraction, about the actual CoM.
    let k: Vec<f64> = eff.iter().map(|e| e[0] - dcx * e[2] + dcy * e[1]).collect();
    let (izz, b, d) = (params.izz_kgm2, params.damping_nms, params.disturbance_nm);
    let rise_s = opts.rise_ms / 1000.0;
    let mut sweep = CommandSweep::new(time_ms, words, eff.len(), opts);
    let mut out = Vec::with_capacity(time_ms.len());
    let mut w = omega0;
    if !time_ms.is_empty() {
        out.push(w);
    }
    for i in 1..time_ms.len() {
        let end = sweep.time_s[i];
        sweep.advance(end, |_, h, word, z0| {
            // Torque at time s into the segment.
            let torque = |s: f64| -> f64 {
                let decay = if rise_s > 0.0 {
                    (-s / rise_s).exp()
                } else {
                    0.0
                };
                k.iter()
                    .enumerate()
                    .map(|(j, kj)| {
                        let u = if word >> j & 1 == 1 { 1.0 } else { 0.0 };
                        kj * (u + (z0[j] - u) * decay)
                    })
                    .sum()
            };
            let f = |s: f64, om: f64| (torque(s) - b * om + d) / izz;
            let steps = (h / 1e-3).ceil().max(1.0) as usize;
            let dt = h / steps as f64;
            for n in 0..steps {
                let s = n as f64 * dt;
                let k1 = f(s, w);
                let k2 = f(s + dt / 2.0, w + dt / 2.0 * k1);
                let k3 = f(s + dt / 2.0, w + dt / 2.0 * k2);
                let k4 = f(s + dt, w + dt * k3);
                w += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            }
        });
        out.push(w);
    }
    Ok(out)
}

impl PlanarModel {
    /// The planar part of a ground model: thruster x/y positions, directions and forces,
    /// Izz and the CoM's x/y. None for a 3-D model (its other terms matter) or one whose
    /// thrusters leave the plane.
    pub fn from_satellite(sat: &crate::satellite::Satellite) -> Option<PlanarModel> {
        if !sat.planar {
            return None;
        }
        let thrusters = (0..sat.n_thrusters())
            .map(|i| PlanarThruster {
                pos_m: [sat.thruster_pos_m[i][0], sat.thruster_pos_m[i][1]],
                dir: [sat.thrust_dir[i][0], sat.thrust_dir[i][1]],
                force_n: sat.thrust_n[i],
            })
            .collect();
        let com = sat.com_m();
        Some(PlanarModel {
            thrusters,
            izz_kgm2: sat.inertia_kgm2[2],
            com_m: [com.x, com.y],
        })
    }
}

/// Terms of the 3-D estimate contract a planar craft cannot identify: reported
/// unobservable (held at the model), never estimated.
pub const NOT_PLANAR_TERMS: [&str; 6] = ["Ixx", "Iyy", "Ixy", "Ixz", "Iyz", "cm_z"];

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> PlanarModel {
        let t = |x: f64, y: f64, dx: f64, dy: f64| PlanarThruster {
            pos_m: [x, y],
            dir: [dx, dy],
            force_n: 0.45,
        };
        PlanarModel {
            thrusters: vec![
                t(0.145, 0.06, -1.0, 0.0),
                t(0.145, -0.06, -1.0, 0.0),
                t(0.06, -0.145, 0.0, 1.0),
                t(-0.06, -0.145, 0.0, 1.0),
                t(-0.145, -0.06, 1.0, 0.0),
                t(-0.145, 0.06, 1.0, 0.0),
                t(-0.06, 0.145, 0.0, -1.0),
                t(0.06, 0.145, 0.0, -1.0),
            ],
            izz_kgm2: 0.4,
            com_m: [0.0, 0.0],
        }
    }

    #[test]
    fn command_integrals_respect_delay_and_rise() {
        let m = model();
        let time = [0u64, 100, 200, 300];
        let words = [1u16, 0, 0, 0];
        let rate = [0.0; 4];
        let plain = regressors(&m, &time, &rate, &words, &PlanarOptions::default());
        let tau1 = thruster_effects(&m)[0][0];
        let x0 = plain[0].map(|r| r.1[0]).unwrap_or(f64::NAN);
        assert!((x0 - tau1 * 0.1).abs() < 1e-12);
        let opts = PlanarOptions {
            delay_ms: 40.0,
            ..PlanarOptions::default()
        };
        let del = regressors(&m, &time, &rate, &words, &opts);
        // The first interval starts before the first word acts: skipped.
        assert!(del[0].is_none());
        let x1 = del[1].map(|r| r.1[0]).unwrap_or(f64::NAN);
        assert!((x1 - tau1 * 0.04).abs() < 1e-12, "{x1}");
        let opts = PlanarOptions {
            rise_ms: 10.0,
            ..PlanarOptions::default()
        };
        let r = regressors(&m, &time, &rate, &words, &opts);
        let on = r[0].map(|r| r.1[0] / tau1).unwrap_or(f64::NAN);
        let want = 0.1 - 0.01 * (1.0 - (-10.0f64).exp());
        assert!((on - want).abs() < 1e-12, "{on} {want}");
        let off = r[1].map(|r| r.1[0] / tau1).unwrap_or(f64::NAN);
        assert!((on + off - 0.1).abs() < 1e-6, "{on} {off}");
    }

    #[test]
    fn predict_matches_closed_form_for_a_constant_torque() {
        let m = model();
        let p = PlanarParams {
            izz_kgm2: 0.5,
            com_offset_m: [0.0; 2],
            damping_nms: 0.05,
            disturbance_nm: 0.0,
        };
        let time: Vec<u64> = (0..11).map(|k| k * 100).collect();
        let words = vec![1u16; 11];
        let w = predict(&m, &p, &PlanarOptions::default(), &time, &words, 0.0).unwrap_or_default();
        let tau = thruster_effects(&m)[0][0];
        let t = 1.0;
        let want = tau / 0.05 * (1.0 - (-0.05 * t / 0.5f64).exp());
        assert!((w[10] - want).abs() < 1e-9, "{} {want}", w[10]);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let m = model();
        let o = PlanarOptions::default();
        assert!(identify(&m, &[0, 1], &[0.0], &[0, 0], &o).is_err());
        assert!(identify(&m, &[1, 0], &[0.0, 0.0], &[0, 0], &o).is_err());
        let e = identify(&m, &[], &[], &[], &o);
        assert_eq!(e.map_err(|e| e.status()), Err("too_few_samples"));
        let nan = vec![f64::NAN; 100];
        let t: Vec<u64> = (0..100).map(|k| k * 60).collect();
        let e = identify(&m, &t, &nan, &[1; 100], &o);
        assert_eq!(e.map_err(|e| e.status()), Err("too_few_samples"));
    }
}
