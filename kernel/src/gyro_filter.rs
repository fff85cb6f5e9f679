//! The seed's gyro low-pass (sec. 4.4.1: two poles at 50 Hz, Tustin), causal, on integer
//! counts, as flight code runs it before the Kalman filter.
//!
//! The filter is the square of `g (z + 1) / (z - p)` with `K = 2/dt`, `wc = 2 pi 50`,
//! `p = (K - wc)/(K + wc)`, `g = wc/(K + wc)` (unit DC gain), run as two cascaded
//! first-order sections in integer arithmetic: counts carry 12 fractional bits (Q12, so a
//! 12-bit count is below 2^24) and the coefficients 30 (Q30). Rounding adds well under
//! 0.01 count; the output is an integer in Q12 counts, so the Kalman filter's sums of it stay
//! exact integers.

use crate::int::mul::widening_mul;
use crate::int::{Machine, MachineExt, Native};

/// Fractional bits of the filtered counts.
pub const COUNT_FRAC_BITS: u32 = 12;
/// Fractional bits of the filter coefficients.
pub const COEF_FRAC_BITS: u32 = 30;

/// Filter coefficients for one sample period (f64 at initialisation only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LowPassCoefs {
    /// Pole `p` in Q30.
    pub p_q30: i64,
    /// Gain `g` in Q30.
    pub g_q30: i64,
}

impl LowPassCoefs {
    /// The Tustin design of `wc^2 / (s + wc)^2` at cut-off `fc_hz` and period `dt_s`.
    pub fn design(fc_hz: f64, dt_s: f64) -> Self {
        let wc = 2.0 * core::f64::consts::PI * fc_hz;
        let k = 2.0 / dt_s;
        let g = wc / (k + wc);
        let p = (k - wc) / (k + wc);
        let q = f64::from(1u32 << COEF_FRAC_BITS);
        LowPassCoefs {
            p_q30: (p * q + 0.5) as i64,
            g_q30: (g * q + 0.5) as i64,
        }
    }

    /// The DC group delay of the two-pole filter in samples, `2 p / (1 - p)` summed over the
    /// two sections with the `(z + 1)` zeros' half sample taken off: the lag of the output
    /// behind a ramp (`2/wc` in the continuous limit). Used by the Kalman filter's `H`.
    pub fn delay_samples(fc_hz: f64, dt_s: f64) -> f64 {
        let wc = 2.0 * core::f64::consts::PI * fc_hz;
        let k = 2.0 / dt_s;
        let p = (k - wc) / (k + wc);
        // One section g (z + 1)/(z - p): delay = p/(1 - p) + 1/(1 + p)... evaluated as the
        // moment difference of numerator and denominator at z = 1.
        let section = (1.0 / 2.0) - (-p / (1.0 - p));
        2.0 * section
    }
}

/// Three-axis causal low-pass state.
///
/// State and output are `i32`: Q12 counts of a 16-bit gyro are below 2^28, and a section's
/// impulse response sums in magnitude to `g (1 + (1 + p) / (1 - |p|)) <= 2` (`p` turns
/// negative below about 2.6 sample periods per `1/wc`, e.g. at 100 Hz), so a state stays below
/// 2^30. Each coefficient product is one 32 x 32 -> 64 bit multiply (a single `SMULL` on the
/// M4F, four 16-bit multiplies on the M0): a tick calls no 64 x 64 multiply routine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GyroLowPass {
    p_q30: i32,
    g_q30: i32,
    x_prev: [i32; 3],
    u: [i32; 3],
    y: [i32; 3],
    started: bool,
}

impl GyroLowPass {
    /// A filter that settles on the first sample it sees.
    pub fn new(coefs: LowPassCoefs) -> Self {
        // A stable pole and its gain are in [-1, 1]: |Q30| <= 2^30.
        let one = 1i64 << COEF_FRAC_BITS;
        let q30 = |v: i64| i32::try_from(v.clamp(one.wrapping_neg(), one)).unwrap_or(0);
        GyroLowPass {
            p_q30: q30(coefs.p_q30),
            g_q30: q30(coefs.g_q30),
            x_prev: [0; 3],
            u: [0; 3],
            y: [0; 3],
            started: false,
        }
    }

    /// Filters one sample of raw counts; returns the filtered counts in Q12.
    pub fn step(&mut self, counts: [u16; 3]) -> [i32; 3] {
        // u16 << 12 < 2^28: fits i32.
        let x = counts.map(|c| i32::from(c) << COUNT_FRAC_BITS);
        if !self.started {
            self.x_prev = x;
            self.u = x;
            self.y = x;
            self.started = true;
        }
        let (p, g) = (self.p_q30, self.g_q30);
        let mut out = [0i32; 3];
        for a in 0..3 {
            let (Some(xa), Some(xp), Some(ua), Some(ya), Some(o)) = (
                x.get(a).copied(),
                self.x_prev.get_mut(a),
                self.u.get_mut(a),
                self.y.get_mut(a),
                out.get_mut(a),
            ) else {
                continue;
            };
            let w = |v: i32| v as u32;
            let u_new = section(&Native, &w(p), &w(g), &w(*ua), &w(xa), &w(*xp)) as i32;
            let y_new = section(&Native, &w(p), &w(g), &w(*ya), &w(u_new), &w(*ua)) as i32;
            *xp = xa;
            *ua = u_new;
            *ya = y_new;
            *o = y_new;
        }
        out
    }
}

/// One first-order section `round(p y + g (x0 + x1))` with Q30 coefficients, on the
/// machine word ([`crate::int`]), so that `proofs/` bounds the very code that runs.
#[inline(always)]
pub fn section<M: Machine>(m: &M, p: &M::W, g: &M::W, y: &M::W, x0: &M::W, x1: &M::W) -> M::W {
    // |y|, |x| < 2^30 and |p|, |g| <= 2^30: products below 2^60 in magnitude, their sum
    // below 2^62 (no wrap); the result is a state, < 2^30 (see `GyroLowPass`).
    let half = m.d(1 << (COEF_FRAC_BITS - 1));
    let acc = m.add_d(
        &m.add_d(
            &m.add_d(&widening_mul(m, p, y), &widening_mul(m, g, x0)),
            &widening_mul(m, g, x1),
        ),
        &half,
    );
    let r = m.ashr_dk(&acc, COEF_FRAC_BITS);
    m.select(&m.fits_w(&r), &m.lo(&r), &m.w(0))
}
