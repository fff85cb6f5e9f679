//! The drive accumulated within a window (see [`super::sums`]): thousands of small
//! increments per window, summed without drift. In floating point a Kahan-compensated sum
//! ([`Compensated`]); in the fixed kernel exact integers ([`super::exact::ExactDrive`]), an
//! integer add per increment instead of four rounded integer-float sums.
use super::components::NZ;
use crate::scalar::Scalar;

/// A window's drive components, `z` of [`super::sums::Sample`].
pub trait DriveSum<S>: Copy + core::fmt::Debug {
    /// Adds `increment` to component `i`.
    fn add(&mut self, i: usize, increment: S);
    /// Sets component `i` (one that is held, not accumulated).
    fn set(&mut self, i: usize, value: S);
    /// The components.
    fn values(&self) -> [S; NZ];
    /// All zero (a new window).
    fn clear(&mut self);
}

/// Kahan-compensated sums: without the compensation a window's small increments round into
/// a drift of the drive, a bias of the inertia, in `f32`.
#[derive(Clone, Copy, Debug)]
pub struct Compensated<S> {
    z: [S; NZ],
    carry: [S; NZ],
}

impl<S: Scalar> Default for Compensated<S> {
    fn default() -> Self {
        Compensated {
            z: [S::ZERO; NZ],
            carry: [S::ZERO; NZ],
        }
    }
}

impl<S: Scalar + core::fmt::Debug> DriveSum<S> for Compensated<S> {
    fn add(&mut self, i: usize, increment: S) {
        let (Some(zi), Some(carry)) = (self.z.get_mut(i), self.carry.get_mut(i)) else {
            return;
        };
        let y = increment.minus(*carry);
        let t = zi.plus(y);
        *carry = t.minus(*zi).minus(y);
        *zi = t;
    }
    fn set(&mut self, i: usize, value: S) {
        if let Some(zi) = self.z.get_mut(i) {
            *zi = value;
        }
    }
    fn values(&self) -> [S; NZ] {
        self.z
    }
    fn clear(&mut self) {
        *self = Self::default();
    }
}
