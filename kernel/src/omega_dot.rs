//! The angular-acceleration Kalman filter of seed Fig. 4.6 / eq. 3.12, per sample.
//!
//! The state is a constant `omega_dot` per axis during one thruster configuration
//! (`phi = 1`, `Q = 0`). The measurement is the (low-pass filtered, see
//! [`crate::gyro_filter`]) rate change since the word change, `z_k = omega_k - omega_0`,
//! with `H_k = (k - kappa) dt`: `k` samples since the change, `kappa` the filter's group
//! delay in samples (the filtered rate lags a ramp by `kappa dt`). With a constant state and
//! `Q = 0` the filter's information form is exact and closed:
//!
//! ```text
//! P_k^-1 = P0^-1 + sum h_k^2 / R,               h_k = (k - kappa) dt
//! x_k    = P_k (x0 / P0 + sum h_k z_k / (g R))   z in counts, g counts per rad/s
//! ```
//!
//! The filtered counts are integers (Q12), so the filter keeps **exact integer
//! accumulators** `n, sum k, sum k^2, sum z, sum k z` (adds and one integer multiply per
//! sample, no rounding at all); `kappa` enters only when an estimate is formed:
//!
//! ```text
//! S2 = sum k^2 - 2 kappa sum k + kappa^2 n,   Sz = sum k z - kappa sum z
//! x  = (x0 alpha + gamma Sz) / (alpha + S2),  alpha = R / (P0 dt^2),  gamma = 1 / (g dt)
//! P  = (R / dt^2) / (alpha + S2)
//! ```
//!
//! Each sum is converted to block floating point (an O(1) mantissa and a power of two), so
//! the information (~3e9 after a 1 s firing at 1 kHz) and the covariance (~3e-10) never sit
//! in a fixed-point number: this is what keeps a 32-bit format at full accuracy where a naive
//! Q16.16 filter overflows one way and underflows the other (numbers in `kernel/README.md`).
//!
//! Per firing, [`OmegaDotKf::reset`] restarts the filter at the nominal-model prediction
//! with a conservative covariance `P0`; the sample at the word change is the zero of the
//! measurement, and the samples of the valve transient (10 ms, seed sec. 3.4) are not used.

use crate::gyro_filter::{LowPassCoefs, COUNT_FRAC_BITS};
use crate::scalar::{Scalar, Scaled};

/// Longest firing the filter accumulates, in samples (2^18 = 262 s at 1 kHz). Beyond it the
/// estimate is frozen and [`KfStatus::Saturated`] is reported, so the integer sums can never overflow.
pub const MAX_FIRING_TICKS: u32 = (1 << 18) - 1;

/// The seed's gyro filter cut-off, Hz (sec. 4.4.1).
pub const GYRO_FILTER_HZ: f64 = 50.0;

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
    /// Samples after a change of thruster word that are not used (the 10 ms valve transient;
    /// the seed skips it only when sampling faster than 5 ms).
    pub transient_ticks: u32,
    /// Lag of the filtered rate behind the body rate, samples (`H = (k - delay) dt`).
    pub delay_ticks: f64,
}

impl KfConfig {
    /// The seed's values at sample period `dt_ms`: R0 = diag(9.5661, 2.7365, 2.3044)e-7,
    /// P0 = 0.5, 1412.79 counts per rad/s, 10 ms transient (below 5 ms sampling), and the
    /// delay of the seed's 50 Hz two-pole filter.
    pub fn seed(dt_ms: u32) -> Self {
        let dt_ms = dt_ms.max(1);
        let dt_s = f64::from(dt_ms) * 1e-3;
        KfConfig {
            dt_s,
            r_rad2_s2: [9.5661e-7, 2.7365e-7, 2.3044e-7],
            p0: 0.5,
            counts_per_rad_s: [1412.79; 3],
            transient_ticks: if dt_ms < 5 {
                10u32
                    .saturating_add(dt_ms / 2)
                    .checked_div(dt_ms)
                    .unwrap_or(0)
            } else {
                0
            },
            delay_ticks: LowPassCoefs::delay_samples(GYRO_FILTER_HZ, dt_s),
        }
    }
}

/// What one call to [`OmegaDotKf::update`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KfStatus {
    /// The sample became the zero of the measurement (`omega_0`).
    Anchored,
    /// Inside the valve transient (or before the filter delay): sample not used.
    Skipping,
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

/// The exact integer sums of one firing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KfSums {
    /// Updates.
    pub n: u32,
    /// `sum k`.
    pub sk: u64,
    /// `sum k^2`.
    pub sk2: u64,
    /// `sum z` per axis (Q12 counts).
    pub sz: [i64; 3],
    /// `sum k z` per axis (Q12 counts).
    pub skz: [i64; 3],
}

/// A 128-bit accumulator stored as two 64-bit words (so the state keeps 8-byte alignment,
/// which the C ABI's opaque blocks rely on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Acc128 {
    lo: u64,
    hi: i64,
}

impl Acc128 {
    /// The value.
    pub fn get(self) -> i128 {
        (i128::from(self.hi) << 64) | i128::from(self.lo)
    }
    /// Adds `v` (saturating).
    pub fn add(&mut self, v: i128) {
        let s = self.get().saturating_add(v);
        self.lo = s as u64; // low 64 bits
        self.hi = (s >> 64) as i64; // |s| < 2^127
    }
}

/// Sums over the updates of a firing of the running sums of [`KfSums`] (exact integers):
/// they give the firing's per-sample RLS measurements in aggregate
/// ([`OmegaDotKf::aggregate`]) without forming an estimate per sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KfSumsOfSums {
    /// `sum n_k`.
    pub tn: u64,
    /// `sum (sum k)_k`.
    pub tsk: Acc128,
    /// `sum (sum k^2)_k`.
    pub tsk2: Acc128,
    /// `sum (sum z)_k` per axis.
    pub tsz: [Acc128; 3],
    /// `sum (sum k z)_k` per axis.
    pub tskz: [Acc128; 3],
}

/// What an estimate is formed from: the prior and the exact sums of one firing (so the
/// estimate of a firing can be formed after the filter has been reset for the next one).
#[derive(Clone, Copy, Debug)]
pub struct KfSnapshot<S> {
    /// The reset value `x0`.
    pub prior: [S; 3],
    /// First-order sums.
    pub sums: KfSums,
    /// Second-order sums.
    pub second: KfSumsOfSums,
}

/// The per-sample angular-acceleration Kalman filter (integer accumulators).
#[derive(Clone, Copy, Debug)]
pub struct OmegaDotKf<S> {
    axes: [AxisConst<S>; 3],
    p0: Scaled<S>,
    transient_ticks: u32,
    kappa: S,
    kappa_ceil: u32,
    prior: [S; 3],
    ticks: u32,
    anchor_tick: u32,
    anchor: [i32; 3],
    anchor_offset: [i32; 3],
    anchored: bool,
    k_sq: u64,
    sums: KfSums,
    second: KfSumsOfSums,
}

impl<S: Scalar> OmegaDotKf<S> {
    /// A filter with the given constants, in the reset state with a zero prior.
    pub fn new(cfg: &KfConfig) -> Self {
        let dt = if cfg.dt_s > 0.0 { cfg.dt_s } else { 1e-3 };
        let p0 = if cfg.p0 > 0.0 { cfg.p0 } else { 0.5 };
        let q12 = f64::from(1u32 << COUNT_FRAC_BITS);
        let axes = core::array::from_fn(|i| {
            let r = cfg.r_rad2_s2.get(i).copied().unwrap_or(1e-7);
            let g = cfg.counts_per_rad_s.get(i).copied().unwrap_or(1412.79);
            AxisConst {
                alpha: Scaled::from_f64(r / (p0 * dt * dt)),
                gamma: Scaled::from_f64(1.0 / (g * dt * q12)),
                r_over_dt2: Scaled::from_f64(r / (dt * dt)),
            }
        });
        let delay = if cfg.delay_ticks.is_finite() {
            cfg.delay_ticks.clamp(0.0, 60.0)
        } else {
            0.0
        };
        OmegaDotKf {
            axes,
            p0: Scaled::from_f64(p0),
            transient_ticks: cfg.transient_ticks,
            kappa: S::from_f32(delay as f32),
            kappa_ceil: (delay as u32).saturating_add(1),
            prior: [S::ZERO; 3],
            ticks: 0,
            anchor_tick: 0,
            anchor: [0; 3],
            anchor_offset: [0; 3],
            anchored: false,
            k_sq: 0,
            sums: KfSums::default(),
            second: KfSumsOfSums::default(),
        }
    }

    /// Restarts the filter for a new thruster configuration at the nominal prediction
    /// `prior` (rad/s^2) with the conservative covariance `P0`.
    pub fn reset(&mut self, prior: [S; 3]) {
        self.reset_with_offset(prior, [0; 3]);
    }

    /// [`OmegaDotKf::reset`] with `offset_q12` added to the zero of the measurement: the
    /// filtered rate at the change still lags the body by the filter delay, so after a firing
    /// the reference rate is extrapolated by that firing's acceleration times the delay.
    pub fn reset_with_offset(&mut self, prior: [S; 3], offset_q12: [i32; 3]) {
        self.anchor_offset = offset_q12;
        self.prior = prior;
        self.ticks = 0;
        self.anchor_tick = 0;
        self.anchored = false;
        self.k_sq = 0;
        self.sums = KfSums::default();
        self.second = KfSumsOfSums::default();
    }

    /// One sample period with the filtered counts (Q12); `None` for a telemetry gap.
    pub fn update(&mut self, filtered_q12: Option<[i32; 3]>) -> KfStatus {
        let tick = self.ticks;
        self.ticks = self.ticks.saturating_add(1);
        if !self.anchored {
            return match filtered_q12 {
                Some(c) => {
                    self.anchor = [0, 1, 2].map(|a| {
                        let v = c.get(a).copied().unwrap_or(0);
                        v.saturating_add(self.anchor_offset.get(a).copied().unwrap_or(0))
                    });
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
        if tick <= self.transient_ticks || k < self.kappa_ceil {
            return KfStatus::Skipping;
        }
        let Some(c) = filtered_q12 else {
            return KfStatus::Missing;
        };
        let s = &mut self.sums;
        s.n = s.n.saturating_add(1);
        s.sk = s.sk.saturating_add(u64::from(k));
        s.sk2 = s.sk2.saturating_add(self.k_sq);
        for (((sz, skz), ci), ai) in
            s.sz.iter_mut()
                .zip(s.skz.iter_mut())
                .zip(c.iter())
                .zip(self.anchor.iter())
        {
            let z = i64::from(*ci).saturating_sub(i64::from(*ai)); // |z| < 2^25
            *sz = sz.saturating_add(z);
            *skz = skz.saturating_add(z.saturating_mul(i64::from(k))); // |k z| < 2^43
        }
        // Second-order sums (adds only): with k < 2^18 every term stays far inside 128 bits.
        let t = &mut self.second;
        t.tn = t.tn.saturating_add(u64::from(s.n));
        t.tsk.add(i128::from(s.sk));
        t.tsk2.add(i128::from(s.sk2));
        for (((tsz, tskz), sz), skz) in t
            .tsz
            .iter_mut()
            .zip(t.tskz.iter_mut())
            .zip(s.sz.iter())
            .zip(s.skz.iter())
        {
            tsz.add(i128::from(*sz));
            tskz.add(i128::from(*skz));
        }
        KfStatus::Updated
    }

    /// `periods` calls of [`OmegaDotKf::update`] without a sample, in O(1): the clock
    /// advances; once anchored, `k^2` is set to what the per-tick increments would give
    /// (they stop at [`MAX_FIRING_TICKS`]).
    pub fn skip(&mut self, periods: u64) {
        if periods == 0 {
            return;
        }
        let last = self
            .ticks
            .saturating_add(u32::try_from(periods.saturating_sub(1)).unwrap_or(u32::MAX));
        self.ticks = last.saturating_add(1);
        if self.anchored {
            let k = u64::from(last.saturating_sub(self.anchor_tick).min(MAX_FIRING_TICKS));
            self.k_sq = k.saturating_mul(k);
        }
    }

    /// Measurement updates since the last reset.
    pub fn updates(&self) -> u32 {
        self.sums.n
    }

    /// The exact integer sums (for tests and the range analysis).
    pub fn sums(&self) -> KfSums {
        self.sums
    }

    /// The firing's per-sample measurements in aggregate: every update `k` of the firing is
    /// an RLS measurement `x_k` with weight `J_k = 1/P_k` and the same regressor, so together
    /// they add `sum_k J_k` of information at the weighted mean `sum_k J_k x_k / sum_k J_k`.
    /// Both sums are closed forms of the exact second-order integer sums:
    /// `sum_k J_k = (n alpha + sum_k S2_k) / (R/dt^2)`,
    /// `sum_k J_k x_k = (n alpha x0 + gamma sum_k Sz_k) / (R/dt^2)`.
    /// Returns `(sum_k J_k, weighted mean)` per axis, `None` without updates or if a value
    /// does not fit.
    pub fn aggregate(&self) -> Option<([Scaled<S>; 3], [S; 3])> {
        self.aggregate_of(&self.snapshot())
    }

    /// The firing's state for a later [`OmegaDotKf::estimate_of`] / [`OmegaDotKf::aggregate_of`].
    pub fn snapshot(&self) -> KfSnapshot<S> {
        KfSnapshot {
            prior: self.prior,
            sums: self.sums,
            second: self.second,
        }
    }

    /// [`OmegaDotKf::aggregate`] of a snapshot (same filter constants).
    pub fn aggregate_of(&self, snap: &KfSnapshot<S>) -> Option<([Scaled<S>; 3], [S; 3])> {
        let s = &snap.sums;
        let t = &snap.second;
        if s.n == 0 {
            return None;
        }
        let kappa = self.kappa;
        let n = Scaled::from_i64(i64::from(s.n));
        let tn = Scaled::from_i128(i128::from(t.tn));
        let tsk = Scaled::from_i128(t.tsk.get());
        let tsk2 = Scaled::from_i128(t.tsk2.get());
        // sum_k S2_k = sum_k (sum k^2 - 2 kappa sum k + kappa^2 n)_k
        let s2_sum = tsk2
            .minus(tsk.scale(kappa.plus(kappa)))
            .plus(tn.scale(kappa.times(kappa)));
        let mut weight = [Scaled::zero(); 3];
        let mut mean = [S::ZERO; 3];
        for i in 0..3 {
            let (Some(ax), Some(tsz), Some(tskz), Some(x0)) = (
                self.axes.get(i),
                t.tsz.get(i),
                t.tskz.get(i),
                snap.prior.get(i),
            ) else {
                return None;
            };
            let szk_sum =
                Scaled::from_i128(tskz.get()).minus(Scaled::from_i128(tsz.get()).scale(kappa));
            let n_alpha = ax.alpha.times(n);
            let den = n_alpha.plus(s2_sum);
            let num = n_alpha.scale(*x0).plus(szk_sum.times(ax.gamma));
            let w = den.over(ax.r_over_dt2)?;
            let b = num.over(den)?.value();
            if let (Some(wo), Some(mo)) = (weight.get_mut(i), mean.get_mut(i)) {
                *wo = w;
                *mo = b;
            }
        }
        Some((weight, mean))
    }

    /// The current angular acceleration only (no variance), rad/s^2; the prior without updates.
    pub fn omega_dot(&self) -> Option<[S; 3]> {
        let s = &self.sums;
        if s.n == 0 {
            return Some(self.prior);
        }
        let kappa = self.kappa;
        let n = Scaled::from_i64(i64::from(s.n));
        let sk = Scaled::from_i64(i64::try_from(s.sk).unwrap_or(i64::MAX));
        let sk2 = Scaled::from_i64(i64::try_from(s.sk2).unwrap_or(i64::MAX));
        let s2 = sk2
            .minus(sk.scale(kappa.plus(kappa)))
            .plus(n.scale(kappa.times(kappa)));
        let mut out = [S::ZERO; 3];
        for (i, o) in out.iter_mut().enumerate() {
            let (Some(ax), Some(sz), Some(skz), Some(x0)) = (
                self.axes.get(i),
                s.sz.get(i),
                s.skz.get(i),
                self.prior.get(i),
            ) else {
                return None;
            };
            let szk = Scaled::from_i64(*skz).minus(Scaled::from_i64(*sz).scale(kappa));
            let num = ax.alpha.scale(*x0).plus(szk.times(ax.gamma));
            *o = num.over(ax.alpha.plus(s2))?.value();
        }
        Some(out)
    }

    /// The current estimate, or `None` if a quotient does not fit the scalar type.
    pub fn estimate(&self) -> Option<OmegaDotEstimate<S>> {
        self.estimate_of(&self.snapshot())
    }

    /// [`OmegaDotKf::estimate`] of a snapshot (same filter constants).
    pub fn estimate_of(&self, snap: &KfSnapshot<S>) -> Option<OmegaDotEstimate<S>> {
        let s = &snap.sums;
        if s.n == 0 {
            let p0 = self.p0;
            let info = Scaled {
                m: S::ONE.checked_div(p0.m)?,
                e: p0.e.saturating_neg(),
            };
            return Some(OmegaDotEstimate {
                omega_dot: snap.prior,
                variance: [p0; 3],
                information: [info; 3],
                updates: 0,
            });
        }
        let kappa = self.kappa;
        let n = Scaled::from_i64(i64::from(s.n));
        let sk = Scaled::from_i64(i64::try_from(s.sk).unwrap_or(i64::MAX));
        let sk2 = Scaled::from_i64(i64::try_from(s.sk2).unwrap_or(i64::MAX));
        // S2 = sum k^2 - 2 kappa sum k + kappa^2 n  (> 0 since every k > kappa)
        let s2 = sk2
            .minus(sk.scale(kappa.plus(kappa)))
            .plus(n.scale(kappa.times(kappa)));
        let mut omega_dot = [S::ZERO; 3];
        let mut variance = [Scaled::zero(); 3];
        let mut information = [Scaled::zero(); 3];
        for i in 0..3 {
            let (Some(ax), Some(sz), Some(skz), Some(x0)) = (
                self.axes.get(i),
                s.sz.get(i),
                s.skz.get(i),
                snap.prior.get(i),
            ) else {
                return None;
            };
            let szk = Scaled::from_i64(*skz).minus(Scaled::from_i64(*sz).scale(kappa));
            let num = ax.alpha.scale(*x0).plus(szk.times(ax.gamma));
            let den = ax.alpha.plus(s2);
            let x = num.over(den)?.value();
            // `value()` saturates: a value on a saturation limit is not an estimate (finding 6).
            if !x.is_valid() {
                return None;
            }
            let var = ax.r_over_dt2.over(den)?;
            let info = den.over(ax.r_over_dt2)?;
            if let (Some(o), Some(v), Some(j)) = (
                omega_dot.get_mut(i),
                variance.get_mut(i),
                information.get_mut(i),
            ) {
                *o = x;
                *v = var;
                *j = info;
            }
        }
        Some(OmegaDotEstimate {
            omega_dot,
            variance,
            information,
            updates: s.n,
        })
    }
}
