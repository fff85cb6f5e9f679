//! Error budgets: how far each kernel output may be from `reference_f64`, in one table
//! (in the manner of libm's test crate, which keeps every function's ULP allowance in one
//! place). The differential tests (`proofs/tests/differential_*.rs`), the divergence run and
//! C1's kernel tests all call [`check`]; the README prints [`TABLE`].
//!
//! Every allowance is derived from the kernel's arithmetic (how many rounded operations feed
//! the output and by what they are multiplied), in units of the format's step `s`
//! (Q8.24: absolute 2^-24) or unit roundoff `u` (f32: relative 2^-24). The derivation is in
//! each row's `why`.

use massid_kernel::Scalar;

/// A number format the kernel is instantiated with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fmt {
    F32,
    Q8_24,
}

/// One output's allowance: `|kernel - reference| <= abs + rel * |reference| + per_ctx * (1 + |reference|) * ctx`,
/// where `ctx` is an output-specific conditioning figure the caller passes (Kalman estimate:
/// the cancellation ratio of its sums; 0 elsewhere).
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    pub output: &'static str,
    pub unit: &'static str,
    pub fmt: Fmt,
    pub abs: f64,
    pub rel: f64,
    /// Coefficient of `(1 + |x|) * ctx` (see the struct doc).
    pub per_ctx: f64,
    pub why: &'static str,
}

const S: f64 = 1.0 / 16_777_216.0; // 2^-24: Q8.24 step and f32 unit roundoff alike

/// The table. One row per (output, format).
pub const TABLE: &[Budget] = &[
    Budget { output: "firing.force_n", unit: "N", fmt: Fmt::Q8_24, abs: 64.0 * S, rel: 0.0, per_ctx: 0.0,
        why: "<= 12 terms d*f, each 2 rounded inputs + product + sum: 48 s, rounded up to 64 s" },
    Budget { output: "firing.force_n", unit: "N", fmt: Fmt::F32, abs: 64.0 * S * 2.4, rel: 0.0, per_ctx: 0.0,
        why: "same 48 operations, each within u of sum|d f| <= 12 x 0.2 N" },
    Budget { output: "firing.torque_cnm", unit: "cN m", fmt: Fmt::Q8_24, abs: 100.0 * 64.0 * S, rel: 0.0, per_ctx: 0.0,
        why: "the N m sum as force_n (64 s), times 100 for cN m" },
    Budget { output: "firing.torque_cnm", unit: "cN m", fmt: Fmt::F32, abs: 100.0 * 64.0 * S * 0.5, rel: 0.0, per_ctx: 0.0,
        why: "48 operations within u of sum|lxd f| <= 12 x 0.2 x 0.19 N m, x100" },
    Budget { output: "firing.omega_dot_nominal", unit: "rad/s^2", fmt: Fmt::Q8_24, abs: 16384.0 * S, rel: 16384.0 * S, per_ctx: 0.0,
        why: "I^-1 (<= 91 per entry, rounded 1 s) times a (64 s) over 3 terms: 91 x 64 x 3 = 17472 s; 2^14 s (1+|x|)" },
    Budget { output: "firing.omega_dot_nominal", unit: "rad/s^2", fmt: Fmt::F32, abs: 1024.0 * S, rel: 1024.0 * S, per_ctx: 0.0,
        why: "3 products + sums of relative u each over 12-term torques: < 2^10 u (1+|x|)" },
    Budget { output: "firing.a_com", unit: "rad/s^2/m", fmt: Fmt::Q8_24, abs: 16384.0 * S, rel: 16384.0 * S, per_ctx: 0.0,
        why: "I^-1 (<= 91) times [c]x (64 s) over 3 terms: < 2^14 s (1+|x|)" },
    Budget { output: "firing.a_com", unit: "rad/s^2/m", fmt: Fmt::F32, abs: 1024.0 * S, rel: 1024.0 * S, per_ctx: 0.0,
        why: "as omega_dot_nominal" },
    Budget { output: "kf.omega_dot", unit: "rad/s^2", fmt: Fmt::Q8_24, abs: 2.0 * S, rel: 0.0, per_ctx: 64.0 * S,
        why: "block floating point: every sum and product is a mantissa in [1, 2) with step s (relative <= s); S2 and Sz subtract kappa terms, so their relative error is <= 16 s times the cancellation ratio c = (sum k^2 + 2 kappa sum k + kappa^2 n) / S2; num/den/value add 4 roundings: |dx| <= 64 s c (1 + |x|) + 2 s" },
    Budget { output: "kf.omega_dot", unit: "rad/s^2", fmt: Fmt::F32, abs: 2.0 * S, rel: 0.0, per_ctx: 64.0 * S,
        why: "as Q8.24 with the f32 mantissa's relative u = 2^-24 in place of s" },
    Budget { output: "lu.solution", unit: "1", fmt: Fmt::Q8_24, abs: 4096.0 * S, rel: 0.0, per_ctx: 0.0,
        why: "test systems diagonally dominant with margin >= 1/16 (|A^-1|_inf <= 16, no pivot growth), |x| <= 4, n <= 6: each entry of U, y, x carries <= n roundings of one step, so |dx| <= |A^-1|_inf n s (1 + |x|_1) <= 16 x 6 x 25 s = 2400 s < 2^12 s" },
    Budget { output: "lu.solution", unit: "1", fmt: Fmt::F32, abs: 0.0, rel: 1024.0 * S, per_ctx: 0.0,
        why: "same systems (cond_inf <= 16 x 1.5 = 24): relative backward error <= 2 n u (growth <= 2), forward <= 24 x 12 u = 288 u < 2^10 u relative to |x|_inf" },
    Budget { output: "rls.estimate", unit: "1 (norm-wise, x cond (1 + |x|_1))", fmt: Fmt::Q8_24, abs: 0.0, rel: 0.0, per_ctx: 264.0 * S,
        why: "Lambda and eta are mantissas (max diagonal in [4, 16)) with absolute step s: each product and each down-shift rounds to nearest (<= s/2, unbiased), so over a run of <= 10^6 adds their errors stay < 2^8 s (random walk, sqrt(10^6) x s/4). eta's error does not scale with x: |dx| <= |Lambda^-1| (|dLambda| |x| + |deta|) <= (cond / max diag) 2^8 s max diag (1 + |x|_1) = 2^8 s ctx. The solve adds its own absolute rounding (a fixed-point x cannot be closer than its step): each entry of U, y, x carries <= n = 6 roundings, growth <= 2 (SPD), residual <= 12 s (1 + |x|_1), |dx| <= sqrt(n) cond / (max diag >= 4) x that < 8 s ctx. ctx = cond(Lambda) (1 + |x|_1). (Until the kernel's products and shifts rounded to nearest, a truncation drift of half a step per product failed this by 13x: proofs finding 7.)" },
    Budget { output: "rls.estimate", unit: "1 (norm-wise, x cond)", fmt: Fmt::F32, abs: 0.0, rel: 256.0 * S, per_ctx: 0.0,
        why: "f32: relative u per accumulation, the information sums are renormalised (no growth of the absolute error): < 2^8 u backward, times cond" },
];

/// The budget row for `output` in `fmt`.
pub fn budget(output: &str, fmt: Fmt) -> &'static Budget {
    TABLE
        .iter()
        .find(|b| b.output == output && b.fmt == fmt)
        .unwrap_or_else(|| panic!("no budget for {output} in {fmt:?}"))
}

/// The allowance for one value (`ctx`: see [`Budget`]; 0 for outputs without one).
pub fn allowance(output: &str, fmt: Fmt, reference: f64, ctx: f64) -> f64 {
    let b = budget(output, fmt);
    let c = if b.per_ctx > 0.0 {
        b.per_ctx * (1.0 + reference.abs()) * ctx
    } else {
        0.0
    };
    b.abs + b.rel * reference.abs() + c
}

/// `Ok` when `got` is within the budget of `reference`; the error names the output.
pub fn check(output: &str, fmt: Fmt, got: f64, reference: f64, ctx: f64) -> Result<(), String> {
    let a = allowance(output, fmt, reference, ctx);
    let e = (got - reference).abs();
    if e <= a && got.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "{output} ({fmt:?}): kernel {got} vs reference {reference}: error {e:e} > budget {a:e}"
        ))
    }
}

/// Tracks the largest error seen relative to the budget, for the README figures.
#[derive(Clone, Debug, Default)]
pub struct Worst {
    pub output: String,
    pub max_err: f64,
    pub max_ratio: f64,
    pub count: u64,
}

impl Worst {
    pub fn new(output: &str) -> Self {
        Worst {
            output: output.into(),
            ..Default::default()
        }
    }
    /// Records one comparison; `Err` if it is over budget.
    pub fn record(&mut self, fmt: Fmt, got: f64, reference: f64, ctx: f64) -> Result<(), String> {
        let a = allowance(&self.output, fmt, reference, ctx);
        let e = (got - reference).abs();
        self.count += 1;
        self.max_err = self.max_err.max(e);
        self.max_ratio = self.max_ratio.max(e / a);
        check(&self.output, fmt, got, reference, ctx)
    }

    /// As [`Worst::record`] for a norm-wise budget: the relative part applies to `scale`
    /// (e.g. `cond |x|_inf` of the whole solution vector) instead of the entry itself, and
    /// the context part is `per_ctx * ctx` (the row says what `ctx` is).
    pub fn record_normwise(
        &mut self,
        fmt: Fmt,
        got: f64,
        reference: f64,
        scale: f64,
        ctx: f64,
    ) -> Result<(), String> {
        let b = budget(&self.output, fmt);
        let a = b.abs + b.rel * scale + b.per_ctx * ctx;
        let e = (got - reference).abs();
        self.count += 1;
        self.max_err = self.max_err.max(e);
        self.max_ratio = self.max_ratio.max(e / a);
        if e <= a && got.is_finite() {
            Ok(())
        } else {
            Err(format!("{} ({fmt:?}): kernel {got} vs reference {reference}: error {e:e} > budget {a:e} (norm-wise, scale {scale}, ctx {ctx})", self.output))
        }
    }
}

impl core::fmt::Display for Worst {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{}: {} comparisons, max error {:.3e}, max error/budget {:.3}",
            self.output, self.count, self.max_err, self.max_ratio
        )
    }
}

/// The exact value of a kernel scalar as f64 (`Scalar::to_f32` rounds a Q8.24 value above 1
/// to 24 significant bits, up to 16 steps of the format: too coarse to measure its errors).
pub trait Exact: Scalar {
    fn exact(self) -> f64;
}
impl Exact for f32 {
    fn exact(self) -> f64 {
        self as f64
    }
}
impl<Frac: fixed::types::extra::LeEqU32> Exact for massid_kernel::Fx<Frac> {
    fn exact(self) -> f64 {
        self.0.to_num::<f64>()
    }
}

/// The absolute resolution of `S` measured through the trait: the smallest `2^-k` that is
/// not zero (fixed: the format step; f32: 0, i.e. no absolute step above 2^-64).
pub fn fixed_step<S: Scalar>() -> f64 {
    let mut step = 1.0f64;
    for k in 1..=64 {
        if !S::ZERO.lt(S::from_int_pow2(1, -k)) {
            return step;
        }
        step *= 0.5;
    }
    0.0
}

/// The [`Fmt`] of a kernel scalar type (by its resolution).
pub fn fmt_of<S: Scalar>() -> Fmt {
    if fixed_step::<S>() == 0.0 {
        Fmt::F32
    } else {
        Fmt::Q8_24
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_output_has_both_formats() {
        for b in TABLE {
            budget(b.output, Fmt::F32);
            budget(b.output, Fmt::Q8_24);
        }
    }

    #[test]
    fn resolution_is_measured_through_the_trait() {
        assert_eq!(fixed_step::<massid_kernel::Q8_24>(), S);
        assert_eq!(fixed_step::<massid_kernel::Q16_16>(), 1.0 / 65536.0);
        assert_eq!(fixed_step::<f32>(), 0.0);
    }

    #[test]
    fn check_rejects_errors_over_budget() {
        let a = allowance("firing.force_n", Fmt::Q8_24, 0.3, 0.0);
        assert!(check("firing.force_n", Fmt::Q8_24, 0.3 + 0.9 * a, 0.3, 0.0).is_ok());
        assert!(check("firing.force_n", Fmt::Q8_24, 0.3 + 1.1 * a, 0.3, 0.0).is_err());
    }
}
