//! The drive accumulated within a window (see [`super::sums`]): thousands of small
//! increments per window, summed without drift. In floating point a Kahan-compensated sum
//! ([`Compensated`]); in the fixed kernel exact integers ([`super::exact::ExactDrive`]), an
//! integer add per increment instead of four rounded integer-float sums.
use super::components::{NZ, N_MODEL, PRODUCTS, SPLIT_TORQUE};
use crate::craft::COMMAND_LEN;
use crate::scalar::Scalar;

/// A window's drive components, `z` of [`super::sums::Sample`].
pub trait DriveSum<S>: Copy + core::fmt::Debug {
    /// The components as kept for the sensor's response ([`DriveSum::mean2`],
    /// [`DriveSum::mean3`]): the values in floating point; in the fixed kernel the exact
    /// integers, so that the means are exact and the sample is rounded once, in integers
    /// ([`super::sums::SumScalar::drive_item`]), not through the integer float.
    type Snapshot: Copy + core::fmt::Debug;
    /// The snapshot of an empty window.
    const ZERO_SNAPSHOT: Self::Snapshot;
    /// Adds `increment` to component `i`.
    fn add(&mut self, i: usize, increment: S);
    /// Sets component `i` (one that is held, not accumulated).
    fn set(&mut self, i: usize, value: S);
    /// The components now.
    fn snapshot(&self) -> Self::Snapshot;
    /// The components now, by reference (a point response reads them without a copy).
    fn current(&self) -> &Self::Snapshot;
    /// `(a + b) / 2` componentwise (the backward mean's response).
    fn mean2(a: &Self::Snapshot, b: &Self::Snapshot) -> Self::Snapshot;
    /// `(a + 2 b + c) / 4` componentwise (the central mean's response).
    fn mean3(a: &Self::Snapshot, b: &Self::Snapshot, c: &Self::Snapshot) -> Self::Snapshot;
    /// A snapshot's values.
    fn values_of(&self, snapshot: &Self::Snapshot) -> [S; NZ];
    /// All zero (a new window).
    fn clear(&mut self);

    /// What one interval of a held command adds to the drive's torque, force, held-torque
    /// and positive-torque components ([`DriveSum::held_step`]): the same for every
    /// interval of one command and step length, so the tick makes it once per change
    /// ([`super::FlightId`]) and adds it ([`DriveSum::add_step`]) in a few instructions.
    type Step: Copy + core::fmt::Debug;
    /// The step of nothing held.
    const ZERO_STEP: Self::Step;
    /// The step of `command` ([`crate::craft::Craft::command`]) held for `dt_s`: the
    /// torque and force times `dt_s` (components 0..6), the held torque (set, not summed,
    /// `N_MODEL..SPLIT_TORQUE`) and the positive torques times `dt_s` where positive
    /// (`SPLIT_TORQUE..NZ`).
    fn held_step(&self, command: &[S; COMMAND_LEN], dt_s: S) -> Self::Step;
    /// Adds `step` ([`DriveSum::held_step`]): the same as adding and setting its values.
    fn add_step(&mut self, step: &Self::Step);

    /// The rate products `omega_b omega_d` of one sample (order of [`PRODUCTS`]) as this drive
    /// integrates them, first: the values in floating point; in the fixed kernel exact integer
    /// products of the rates rounded once, then those rates ([`super::exact::ExactDrive`]).
    type Products: Copy + core::fmt::Debug;
    /// The products of a zero rate.
    const ZERO_PRODUCTS: Self::Products;
    /// The products of `rate`, written into `out` (in place: the tick's ring slot).
    fn products_into(&self, rate: &[S; 3], out: &mut Self::Products);
    /// The products of `rate`.
    fn products(&self, rate: &[S; 3]) -> Self::Products {
        let mut out = Self::ZERO_PRODUCTS;
        self.products_into(rate, &mut out);
        out
    }
    /// Adds the products' integral over a step of `dt_s` to components `first..first + 6`,
    /// from the products at the step's end (`now`), start (`then`) and the sample before
    /// (`before`): Adams-Moulton's third-order rule `dt (5 now + 8 then - before) / 12` if
    /// `third_order`, else the trapezoid `dt (then + now) / 2`.
    fn add_products(
        &mut self,
        first: usize,
        now: &Self::Products,
        then: &Self::Products,
        before: &Self::Products,
        dt_s: S,
        third_order: bool,
    );
}

fn at<S: Scalar>(v: &[S; NZ], i: usize) -> S {
    v.get(i).copied().unwrap_or(S::ZERO)
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
    type Snapshot = [S; NZ];
    const ZERO_SNAPSHOT: [S; NZ] = [S::ZERO; NZ];
    fn snapshot(&self) -> [S; NZ] {
        self.z
    }
    fn current(&self) -> &[S; NZ] {
        &self.z
    }
    fn mean2(a: &[S; NZ], b: &[S; NZ]) -> [S; NZ] {
        let h = S::from_int_pow2(1, -1);
        core::array::from_fn(|i| h.times(at(a, i).plus(at(b, i))))
    }
    fn mean3(a: &[S; NZ], b: &[S; NZ], c: &[S; NZ]) -> [S; NZ] {
        let q = S::from_int_pow2(1, -2);
        core::array::from_fn(|i| q.times(at(a, i).plus(at(b, i).mul_pow2(1)).plus(at(c, i))))
    }
    fn values_of(&self, snapshot: &[S; NZ]) -> [S; NZ] {
        *snapshot
    }
    fn clear(&mut self) {
        *self = Self::default();
    }
    /// Increments (`None`: a positive torque that is not, which adds nothing: adding a zero
    /// would still apply the compensation's carry), then the held torques.
    type Step = ([Option<S>; 9], [S; 3]);
    const ZERO_STEP: Self::Step = ([None; 9], [S::ZERO; 3]);
    fn held_step(&self, command: &[S; COMMAND_LEN], dt_s: S) -> Self::Step {
        let at = |i: usize| command.get(i).copied().unwrap_or(S::ZERO);
        let increments = core::array::from_fn(|c| {
            let w = at(c);
            // Components 0..6 always; the positive torques (command 6..9) where positive.
            (c < 6 || S::ZERO.lt(w)).then(|| w.times(dt_s))
        });
        (increments, core::array::from_fn(at))
    }
    fn add_step(&mut self, (increments, held): &Self::Step) {
        for (i, v) in increments.iter().enumerate() {
            if let Some(v) = v {
                // Command entries 6..9 drive components SPLIT_TORQUE..NZ.
                let c = if i < 6 {
                    i
                } else {
                    SPLIT_TORQUE.saturating_add(i.saturating_sub(6))
                };
                self.add(c, *v);
            }
        }
        for (b, v) in held.iter().enumerate() {
            self.set(N_MODEL.saturating_add(b), *v);
        }
    }
    type Products = [S; 6];
    const ZERO_PRODUCTS: [S; 6] = [S::ZERO; 6];
    fn products_into(&self, rate: &[S; 3], out: &mut [S; 6]) {
        let get = |i: usize| rate.get(i).copied().unwrap_or(S::ZERO);
        for (o, (b, d)) in out.iter_mut().zip(PRODUCTS) {
            *o = get(b).times(get(d));
        }
    }
    fn add_products(
        &mut self,
        first: usize,
        now: &[S; 6],
        then: &[S; 6],
        before: &[S; 6],
        dt_s: S,
        third_order: bool,
    ) {
        let h = S::from_int_pow2(1, -1).times(dt_s);
        let twelfth = dt_s.times(S::from_f32(1.0 / 12.0));
        for (p, ((then, now), before)) in then.iter().zip(now).zip(before).enumerate() {
            let step = if third_order {
                twelfth.times(
                    now.times(S::from_int_pow2(5, 0))
                        .plus(then.mul_pow2(3))
                        .minus(*before),
                )
            } else {
                h.times(then.plus(*now))
            };
            self.add(first.saturating_add(p), step);
        }
    }
}
