//! The seed's gyro low-pass (sec. 4.4.1: two poles at 50 Hz, Tustin), causal, on integer
//! counts, as flight code runs it before the Kalman filter.
//!
//! The filter is the square of `g (z + 1) / (z - p)` with `K = 2/dt`, `wc = 2 pi 50`,
//! `p = (K - wc)/(K + wc)`, `g = wc/(K + wc)` (unit DC gain), run as two cascaded
//! first-order sections in integer arithmetic: counts carry 12 fractional bits (Q12, so a
//! 12-bit count is below 2^24) and the coefficients 30 (Q30). Rounding adds well under
//! 0.01 count; the output is an integer in Q12 counts, so the Kalman filter's sums of it stay
//! exact integers.

/// Fractional bits of the filtered counts.
pub const COUNT_FRAC_BITS: u32 = 12;
const COEF_FRAC_BITS: u32 = 30;

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
        LowPassCoefs { p_q30: (p * q + 0.5) as i64, g_q30: (g * q + 0.5) as i64 }
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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GyroLowPass {
    coefs: LowPassCoefs,
    x_prev: [i64; 3],
    u: [i64; 3],
    y: [i64; 3],
    started: bool,
}

impl GyroLowPass {
    /// A filter that settles on the first sample it sees.
    pub fn new(coefs: LowPassCoefs) -> Self {
        GyroLowPass { coefs, x_prev: [0; 3], u: [0; 3], y: [0; 3], started: false }
    }

    /// Filters one sample of raw counts; returns the filtered counts in Q12.
    pub fn step(&mut self, counts: [u16; 3]) -> [i32; 3] {
        let x = counts.map(|c| i64::from(c) << COUNT_FRAC_BITS);
        if !self.started {
            self.x_prev = x;
            self.u = x;
            self.y = x;
            self.started = true;
        }
        let LowPassCoefs { p_q30, g_q30 } = self.coefs;
        let half = 1i64 << (COEF_FRAC_BITS - 1);
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
            // |values| < 2^25 and coefficients < 2^30: every product is below 2^56.
            let u_new = p_q30
                .saturating_mul(*ua)
                .saturating_add(g_q30.saturating_mul(xa.saturating_add(*xp)))
                .saturating_add(half)
                >> COEF_FRAC_BITS;
            let y_new = p_q30
                .saturating_mul(*ya)
                .saturating_add(g_q30.saturating_mul(u_new.saturating_add(*ua)))
                .saturating_add(half)
                >> COEF_FRAC_BITS;
            *xp = xa;
            *ua = u_new;
            *ya = y_new;
            *o = i32::try_from(y_new).unwrap_or(0);
        }
        out
    }
}
