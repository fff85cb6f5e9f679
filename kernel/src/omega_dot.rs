//! The angular-acceleration Kalman filter of seed Fig. 4.6 / eq. 3.12, per sample.
//!
//! The state is a constant `omega_dot` per axis during one thruster configuration
//! (`phi = 1`, `Q = 0`), the measurement is the rate change since the end of the valve
//! transient, `z_k = omega_k - omega_0 = omega_dot * (k dt) + noise`, so `H_k = k dt`. With a
//! constant state and `Q = 0` the filter's information form is exact and closed:
//!
//! ```text
//! P_k^-1   = P0^-1 + dt^2 S2 / R,          S2 = sum k^2
//! x_k      = P_k (x0 / P0 + dt Sz / (g R)), Sz = sum k (c_k - c_0)   (gyro counts)
//! ```
//!
//! Gyro samples are integer counts, so `S2` and `Sz` are kept as **exact integer
//! accumulators** (no rounding at all per sample, adds only): this is the formulation that
//! avoids the naive Q16.16 filter's overflow (information ~3e9) and underflow (covariance
//! ~3e-10). The estimate is formed on demand by normalising both sums by a common power of
//! two (block floating point) so that every scalar operand is O(1):
//!
//! ```text
//! x = (x0 alpha + gamma Sz) / (alpha + S2),  alpha = R / (P0 dt^2),  gamma = 1 / (g dt)
//! P = (R / dt^2) / (alpha + S2)
//! ```
//!
//! Per firing, [`OmegaDotKf::reset`] restarts the filter at the nominal-model prediction
//! with a conservative covariance `P0`, and the first `transient_ticks` samples (10 ms, the
//! valve opening transient of seed sec. 3.4) are skipped; the sample after them anchors
//! `c_0`.

use crate::scalar::{Scalar, Scaled};

/// Longest firing the filter accumulates, in ticks (2^18 = 262 s at 1 kHz). Beyond it the
/// estimate is frozen and [`KfStatus::Saturated`] is reported, so the integer sums can never overflow.
pub const MAX_FIRING_TICKS: u32 = (1 << 18) - 1;

/// Kalman-filter constants (f64 at initialisation only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KfConfig {
    /// Sample period, s.
    pub dt_s: f64,
    /// Measurement noise variance per axis, (rad/s)^2 (seed Fig. 4.5: R0).
    pub r_rad2_s2: [f64; 3],
    /// Conservative initial variance at each reset, (rad/s^2)^2 (seed App. D: P^-1 = 2 I).
    pub p0: f64,
    /// Gyro scale, counts per rad/s.
    pub counts_per_rad_s: [f64; 3],
    /// Samples skipped after every change of thruster word (10 ms / dt).
    pub transient_ticks: u32,
}

impl KfConfig {
    /// The seed's values at sample period `dt_ms`: R0 = diag(9.5661, 2.7365, 2.3044)e-7,
    /// P0 = 0.5, 1412.79 counts per rad/s, 10 ms transient.
    pub fn seed(dt_ms: u32) -> Self {
        let dt_ms = dt_ms.max(1);
        KfConfig {
            dt_s: f64::from(dt_ms) * 1e-3,
            r_rad2_s2: [9.5661e-7, 2.7365e-7, 2.3044e-7],
            p0: 0.5,
            counts_per_rad_s: [1412.79; 3],
            transient_ticks: 10u32.div_ceil(dt_ms),
        }
    }
}

/// What one call to [`OmegaDotKf::update`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KfStatus {
    /// Inside the valve transient: sample ignored.
    Skipping,
    /// The sample became the anchor `c_0`.
    Anchored,
    /// A measurement update was folded in.
    Updated,
    /// No sample this tick (telemetry gap): time advanced only.
    Missing,
    /// The firing exceeded [`MAX_FIRING_TICKS`]: the estimate is frozen.
    Saturated,
}

/// The filter's current output.
#[derive(Clone, Copy, Debug)]
pub struct OmegaDotEstimate<S> {
    /// Angular acceleration estimate, rad/s^2.
    pub omega_dot: [S; 3],
    /// Its variance per axis, (rad/s^2)^2, block floating point.
    pub variance: [Scaled<S>; 3],
    /// The information `1 / variance` per axis (the RLS weight), block floating point.
    pub information: [Scaled<S>; 3],
    /// Measurement updates since the reset.
    pub updates: u32,
}

/// Per-axis constants in block-floating-point form.
#[derive(Clone, Copy, Debug)]
struct AxisConst<S> {
    alpha: Scaled<S>,
    gamma: Scaled<S>,
    r_over_dt2: Scaled<S>,
}

/// The per-sample angular-acceleration Kalman filter (integer accumulators).
#[derive(Clone, Copy, Debug)]
pub struct OmegaDotKf<S> {
    axes: [AxisConst<S>; 3],
    p0: Scaled<S>,
    transient_ticks: u32,
    prior: [S; 3],
    ticks: u32,
    anchor_tick: u32,
    anchor: [i32; 3],
    anchored: bool,
    k_sq: u64,
    s2: u64,
    sz: [i64; 3],
    updates: u32,
}

impl<S: Scalar> OmegaDotKf<S> {
    /// A filter with the given constants, in the reset state with a zero prior.
    pub fn new(cfg: &KfConfig) -> Self {
        let dt = if cfg.dt_s > 0.0 { cfg.dt_s } else { 1e-3 };
        let p0 = if cfg.p0 > 0.0 { cfg.p0 } else { 0.5 };
        let axes = core::array::from_fn(|i| {
            let r = cfg.r_rad2_s2.get(i).copied().unwrap_or(1e-7);
            let g = cfg.counts_per_rad_s.get(i).copied().unwrap_or(1412.79);
            AxisConst {
                alpha: Scaled::from_f64(r / (p0 * dt * dt)),
                gamma: Scaled::from_f64(1.0 / (g * dt)),
                r_over_dt2: Scaled::from_f64(r / (dt * dt)),
            }
        });
        OmegaDotKf {
            axes,
            p0: Scaled::from_f64(p0),
            transient_ticks: cfg.transient_ticks,
            prior: [S::ZERO; 3],
            ticks: 0,
            anchor_tick: 0,
            anchor: [0; 3],
            anchored: false,
            k_sq: 0,
            s2: 0,
            sz: [0; 3],
            updates: 0,
        }
    }

    /// Restarts the filter for a new thruster configuration at the nominal prediction
    /// `prior` (rad/s^2) with the conservative covariance `P0`.
    pub fn reset(&mut self, prior: [S; 3]) {
        self.prior = prior;
        self.ticks = 0;
        self.anchor_tick = 0;
        self.anchored = false;
        self.k_sq = 0;
        self.s2 = 0;
        self.sz = [0; 3];
        self.updates = 0;
    }

    /// One sample period. `counts` is `None` for a telemetry gap (time still advances).
    pub fn update(&mut self, counts: Option<[u16; 3]>) -> KfStatus {
        let tick = self.ticks;
        self.ticks = self.ticks.saturating_add(1);
        if tick < self.transient_ticks {
            return KfStatus::Skipping;
        }
        if !self.anchored {
            return match counts {
                Some(c) => {
                    self.anchor = c.map(i32::from);
                    self.anchor_tick = tick;
                    self.anchored = true;
                    KfStatus::Anchored
                }
                None => KfStatus::Missing,
            };
        }
        let k = tick.saturating_sub(self.anchor_tick);
        if k > MAX_FIRING_TICKS {
            return KfStatus::Saturated;
        }
        // k^2 kept incrementally with adds only: k^2 = (k-1)^2 + 2k - 1 (k advances by 1 per tick).
        let step = u64::from(k).saturating_add(u64::from(k)).saturating_sub(1);
        self.k_sq = self.k_sq.saturating_add(step);
        let Some(c) = counts else {
            return KfStatus::Missing;
        };
        self.s2 = self.s2.saturating_add(self.k_sq);
        let k_i = k as i32; // k <= 2^18, fits
        for ((acc, ci), ai) in self.sz.iter_mut().zip(c.iter()).zip(self.anchor.iter()) {
            let z = i32::from(*ci).saturating_sub(*ai); // |z| <= 4095
            *acc = acc.saturating_add(i64::from(k_i.saturating_mul(z))); // |k z| < 2^30
        }
        self.updates = self.updates.saturating_add(1);
        KfStatus::Updated
    }

    /// Measurement updates since the last reset.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// The exact integer sums `(S2, Sz)` (for tests and the range analysis).
    pub fn sums(&self) -> (u64, [i64; 3]) {
        (self.s2, self.sz)
    }

    /// The current estimate, or `None` if a quotient does not fit the scalar type.
    pub fn estimate(&self) -> Option<OmegaDotEstimate<S>> {
        if self.updates == 0 || self.s2 == 0 {
            let p0 = self.p0;
            let info = Scaled { m: S::ONE.checked_div(p0.m)?, e: p0.e.saturating_neg() };
            return Some(OmegaDotEstimate {
                omega_dot: self.prior,
                variance: [p0; 3],
                information: [info; 3],
                updates: 0,
            });
        }
        // Common power-of-two normalisation of S2 and every Sz: the largest becomes a
        // value in [8, 16) (integers of up to 30 significant bits keep full precision).
        let s2 = i64::try_from(self.s2).unwrap_or(i64::MAX);
        let biggest = self.sz.iter().fold(s2, |m, v| m.max(v.saturating_abs()));
        let len = 64i32.saturating_sub(biggest.unsigned_abs().leading_zeros() as i32);
        let sh = len.saturating_sub(30).clamp(0, 63);
        let e_norm = len.saturating_sub(4); // true value = scaled value * 2^e_norm
        let to_s = |v: i64| -> S {
            let m = (v >> sh) as i32; // |v >> sh| < 2^30 by construction
            S::from_int_pow2(m, sh.saturating_sub(e_norm))
        };
        let s2_s = to_s(s2);
        let mut omega_dot = [S::ZERO; 3];
        let mut variance = [Scaled::zero(); 3];
        let mut information = [Scaled::zero(); 3];
        for i in 0..3 {
            let (Some(ax), Some(sz), Some(x0)) = (self.axes.get(i), self.sz.get(i), self.prior.get(i)) else {
                return None;
            };
            let alpha = ax.alpha.mantissa_at(e_norm);
            let num = x0.times(alpha).mul_add(ax.gamma.m, to_s(*sz).mul_pow2(ax.gamma.e));
            let den = alpha.plus(s2_s);
            let x = num.checked_div(den)?;
            let den_n = Scaled { m: den, e: e_norm }.normalized();
            let var = Scaled {
                m: ax.r_over_dt2.m.checked_div(den_n.m)?,
                e: ax.r_over_dt2.e.saturating_sub(den_n.e),
            };
            let info = Scaled {
                m: den_n.m.checked_div(ax.r_over_dt2.m)?,
                e: den_n.e.saturating_sub(ax.r_over_dt2.e),
            };
            if let (Some(o), Some(v), Some(j)) = (omega_dot.get_mut(i), variance.get_mut(i), information.get_mut(i)) {
                *o = x;
                *v = var;
                *j = info;
            }
        }
        Some(OmegaDotEstimate { omega_dot, variance, information, updates: self.updates })
    }
}
