//! Error budgets: how far each kernel output may be from `reference_f64`, in one table.

use massid_kernel::Scalar;

/// The absolute resolution of `S` measured through the trait: the smallest `2^-k` that is
/// not zero (fixed: the format step; f32: below 2^-64, reported as 0 scale).
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
