//! LU decomposition with partial pivoting and a pivot threshold relative to the matrix
//! scale, and its solve. A pivot that is not certainly above `rel_tol * max|a_ij|` gives
//! [`LuError::Singular`] naming the column: never a silently wrong answer (a plain LU, such
//! as nalgebra's over fixed types, divides by whatever tiny pivot it finds).

use crate::scalar::{max_abs, Scalar};

/// Why a factorisation or solve failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LuError {
    /// No pivot in this column exceeded the threshold: the matrix is (numerically) singular.
    Singular {
        /// Elimination step (0-based) at which it happened.
        column: usize,
    },
    /// The matrix is all zeros (or its scale is not a valid number).
    ZeroMatrix,
    /// A quotient did not fit the scalar type.
    Overflow,
}

/// An LU factorisation `P A = L U` (unit lower `L` and `U` stored in one matrix).
#[derive(Clone, Copy, Debug)]
pub struct Lu<S, const N: usize> {
    lu: [[S; N]; N],
    perm: [usize; N],
}

impl<S: Scalar, const N: usize> Lu<S, N> {
    /// Factors `a` with partial pivoting. `rel_tol` is the pivot threshold relative to
    /// `max |a_ij|`; 2^-20 is the kernel's default (see `kernel/README.md`).
    pub fn factor(a: &[[S; N]; N], rel_tol: S) -> Result<Self, LuError> {
        let mut lu = *a;
        let mut perm: [usize; N] = core::array::from_fn(|i| i);
        let scale = lu.iter().flatten().fold(S::ZERO, |m, v| max_abs(m, *v));
        if !scale.is_valid() || !S::ZERO.lt(scale) {
            return Err(LuError::ZeroMatrix);
        }
        let threshold = rel_tol.abs().times(scale);
        for col in 0..N {
            // Partial pivoting: largest |a_rc| for r >= col.
            let mut best = col;
            let mut best_abs = S::ZERO;
            for (r, row) in lu.iter().enumerate().skip(col) {
                let v = row.get(col).copied().unwrap_or(S::ZERO).abs();
                if best_abs.lt(v) {
                    best = r;
                    best_abs = v;
                }
            }
            // Safe branch: anything not certainly above the threshold is singular.
            if !threshold.lt(best_abs) {
                return Err(LuError::Singular { column: col });
            }
            if best != col {
                swap_checked(&mut lu, best, col);
                swap_checked(&mut perm, best, col);
            }
            let Some(pivot_row) = lu.get(col).copied() else {
                return Err(LuError::Singular { column: col });
            };
            let pivot = pivot_row.get(col).copied().unwrap_or(S::ZERO);
            for row in lu.iter_mut().skip(col.saturating_add(1)) {
                let Some(entry) = row.get_mut(col) else {
                    continue;
                };
                let factor = entry.checked_div(pivot).ok_or(LuError::Overflow)?;
                if !factor.is_valid() {
                    return Err(LuError::Overflow);
                }
                *entry = factor;
                for (dst, src) in row
                    .iter_mut()
                    .zip(pivot_row.iter())
                    .skip(col.saturating_add(1))
                {
                    *dst = minus_product(*dst, factor, *src)?;
                }
            }
        }
        Ok(Lu { lu, perm })
    }

    /// Solves `A x = b` with the factorisation.
    pub fn solve(&self, b: &[S; N]) -> Result<[S; N], LuError> {
        // Forward substitution with the permutation: L y = P b.
        let mut x: [S; N] = core::array::from_fn(|i| {
            self.perm
                .get(i)
                .and_then(|&p| b.get(p))
                .copied()
                .unwrap_or(S::ZERO)
        });
        for i in 0..N {
            let Some(row) = self.lu.get(i) else { continue };
            let mut acc = x.get(i).copied().unwrap_or(S::ZERO);
            for (l, xj) in row.iter().zip(x.iter()).take(i) {
                acc = minus_product(acc, *l, *xj)?;
            }
            if let Some(xi) = x.get_mut(i) {
                *xi = acc;
            }
        }
        // Back substitution: U x = y.
        for i in (0..N).rev() {
            let Some(row) = self.lu.get(i) else { continue };
            let mut acc = x.get(i).copied().unwrap_or(S::ZERO);
            for (u, xj) in row.iter().zip(x.iter()).skip(i.saturating_add(1)) {
                acc = minus_product(acc, *u, *xj)?;
            }
            let diag = row.get(i).copied().unwrap_or(S::ZERO);
            let xi_new = acc.checked_div(diag).ok_or(LuError::Overflow)?;
            if !xi_new.is_valid() {
                return Err(LuError::Overflow);
            }
            if let Some(xi) = x.get_mut(i) {
                *xi = xi_new;
            }
        }
        Ok(x)
    }
}

/// Factor and solve in one call.
pub fn solve<S: Scalar, const N: usize>(
    a: &[[S; N]; N],
    b: &[S; N],
    rel_tol: S,
) -> Result<[S; N], LuError> {
    Lu::factor(a, rel_tol)?.solve(b)
}

/// `acc - a * b`, or [`LuError::Overflow`] if the product or the difference saturated: a
/// saturated intermediate can be moved off the limit by a later step, so it must be caught
/// where it happens (proofs finding 1), not only in the final result.
fn minus_product<S: Scalar>(acc: S, a: S, b: S) -> Result<S, LuError> {
    let p = a.times(b);
    if !p.is_valid() {
        return Err(LuError::Overflow);
    }
    let r = acc.minus(p);
    if !r.is_valid() {
        return Err(LuError::Overflow);
    }
    Ok(r)
}

/// Swaps two entries through `get`/`get_mut` (no bounds-check panic path, unlike `<[T]>::swap`).
fn swap_checked<T: Copy, const N: usize>(a: &mut [T; N], i: usize, j: usize) {
    if let (Some(x), Some(y)) = (a.get(i).copied(), a.get(j).copied()) {
        if let Some(s) = a.get_mut(i) {
            *s = y;
        }
        if let Some(s) = a.get_mut(j) {
            *s = x;
        }
    }
}
