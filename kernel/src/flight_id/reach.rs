//! How far the open window has turned and walked, against the limits [`super::window`]
//! derives: in floating point the values themselves ([`FloatReach`]); the fixed kernel keeps
//! integers of its rounded rates ([`super::exact::ExactReach`]).
use crate::scalar::Scalar;

/// How far the open window has turned (`sum_a k_a |omega_a| dt`, weights
/// [`super::window::turn_weights`]) and walked (`sum_a w_a omega_a^2 dt`, weights
/// [`super::window::walk_weights`]), step by step, against the
/// limits: in floating point the values themselves ([`FloatReach`]); the fixed kernel keeps
/// integers of its rounded rates ([`super::exact::ExactReach`]), where the integer float's
/// twelve multiply-adds cost the 3-D push about 1,500 instructions on the M4F.
pub trait Reach<S, P>: Copy + core::fmt::Debug {
    /// Adds a step of `dt_s` at `rate`, whose products (the drive's, [`super::drive::DriveSum`])
    /// are `products`; the walk only if `gyro` (a planar craft has no products).
    fn add(&mut self, rate: &[S; 3], products: &P, dt_s: S, gyro: bool);
    /// The turn is below its limit.
    fn turn_within(&self) -> bool;
    /// The walk is below its limit.
    fn walk_within(&self) -> bool;
    /// A new window: nothing turned or walked.
    fn clear(&mut self);
}

/// [`Reach`] in the number type itself.
#[derive(Clone, Copy, Debug)]
pub struct FloatReach<S> {
    turned: S,
    walked: S,
    turn_weight: [S; 3],
    walk_weight: [S; 3],
    max_turn: S,
    max_walk: S,
}

impl<S: Scalar> FloatReach<S> {
    /// Nothing turned or walked, with these weights and limits.
    pub fn new(turn_weight: [S; 3], walk_weight: [S; 3], max_turn: S, max_walk: S) -> Self {
        FloatReach {
            turned: S::ZERO,
            walked: S::ZERO,
            turn_weight,
            walk_weight,
            max_turn,
            max_walk,
        }
    }
}

impl<S: Scalar + core::fmt::Debug> Reach<S, [S; 6]> for FloatReach<S> {
    fn add(&mut self, rate: &[S; 3], products: &[S; 6], dt_s: S, gyro: bool) {
        for (w, k) in rate.iter().zip(self.turn_weight) {
            self.turned = self.turned.plus(w.abs().times(k).times(dt_s));
        }
        // The squared rates are the products' first three.
        if gyro {
            let walk = products
                .iter()
                .zip(self.walk_weight)
                .fold(S::ZERO, |acc, (p, k)| acc.mul_add(*p, k));
            self.walked = self.walked.mul_add(walk, dt_s);
        }
    }
    fn turn_within(&self) -> bool {
        self.turned.lt(self.max_turn)
    }
    fn walk_within(&self) -> bool {
        self.walked.lt(self.max_walk)
    }
    fn clear(&mut self) {
        self.turned = S::ZERO;
        self.walked = S::ZERO;
    }
}
