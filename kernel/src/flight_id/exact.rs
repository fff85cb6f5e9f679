//! The fixed kernel's recent sums, exact: each sample's lagged products as integer
//! multiply-accumulates instead of integer-float sums.
//!
//! Why: in the integer float ([`crate::IntFloat`]) every product added to the sums is a
//! widening product, a normalisation and an aligned, rounded sum, about 200 instructions
//! where the FPU does one `vfma`; the ~1,100 products of a sample were 90 % of the fixed
//! kernel's tick. Here each component of a sample, `v = (z, y)`, is first rounded to a
//! signed integer at a per-component power of two chosen from the flight's [`Envelope`]
//! (`|q| < 2^VALUE_BITS`), and the products are summed exactly in `i64`: one 32 x 32 -> 64
//! multiply-accumulate each (`smlal` on the M4F). Every entry is folded into the flight's
//! integer-float sums (rounded once) at least every [`FOLD_PERIOD`] samples, so it holds at
//! most that many products: `FOLD_PERIOD 2^(2 VALUE_BITS) < 2^63`, checked below at compile
//! time and proved by Z3 (`massid_proofs_solver`, obligation `mul_acc`).
//!
//! What it costs in accuracy: a component is resolved to `2^-VALUE_BITS` of its bound (twice
//! its reach over the longest window, rounded up to a power of two), about 10^-8; the rate
//! residual to 10^-8 of its own bound, which grows with the longest window ([`MAX_REACH_S`]).
//! Every value the sums take is exact or refused: a value past its bound (a wrench or rate
//! 2-4 times beyond the envelope, the bounds' margin) is not rounded into a wrong sum, the
//! flight's sums are marked out of range and the fit answers `Overflow`.

use core::mem::MaybeUninit;

use super::drive::DriveSum;
use super::sums::{
    entry_components, fold_period, Active, LagForm, LagMoments, Recent, Sample, SumScalar,
    DEFAULT_PIVOT_EXP, ENTRIES, NZ, N_MODEL, SPLIT_TORQUE,
};
use crate::craft::COMMAND_LEN;
use crate::in_place::{assume_all_written, field};
use crate::int::mul::{mul_acc, round_product, widening_mul};
use crate::int::shift::shift_nearest;
use crate::int::Native;
use crate::scalar::{max_abs, Scalar};
use crate::IntFloat;

/// The longest reach of a window the fixed kernel takes, s (`max_window` steps of up to 1.5
/// periods). Every component, the rate residual included, is resolved to `2^-VALUE_BITS` of
/// its worst case over the longest window, so the resolution follows this setting: on a
/// low-noise test flight (100 Hz, 10 s windows) the fixed kernel's estimates were within 0.05
/// sigma of f32's with a 15 s reach, 0.03-0.24 sigma at 150 s, 1.9 sigma at 1,500 s. Longer
/// settings are refused. The ground tool and the C ABI's default take 60 s windows (90 s).
pub const MAX_REACH_S: f32 = 100.0;

/// Bits of a rounded component: `|q| < 2^VALUE_BITS`.
pub const VALUE_BITS: u32 = 27;

// An entry's products between two folds cannot overflow i64.
const _: () = assert!((FOLD_PERIOD as u128) << (2 * VALUE_BITS) < i64::MAX as u128);

/// Entries of the exact sums folded per sample: the fewest that keep [`FOLD_PERIOD`] products
/// of `2^(2 VALUE_BITS)` within `i64` (each fold is an integer-float rounding and sum, about
/// 130 instructions on the M4F: 3 a sample instead of the floating-point sums' 6).
pub const FOLD_PER_SAMPLE: usize = ENTRIES.div_ceil((i64::MAX >> (2 * VALUE_BITS)) as usize);

/// Samples between two folds of one exact entry, at most ([`fold_period`]).
pub const FOLD_PERIOD: usize = fold_period(FOLD_PER_SAMPLE);

/// What the flight can bring: the largest magnitude of each component of the commanded
/// wrench, and of each rate. The fixed kernel scales its exact sums to it; f32 ignores it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Envelope<S> {
    /// Torque N m, force N.
    pub wrench: [S; 6],
    /// Body rate, rad/s.
    pub rate: S,
}

/// The rate limit of [`Envelope::of_craft`]: one turn a second, beyond the maneuvers of the
/// craft this kernel is for (a rate 2-4 times beyond it makes the fixed kernel's fit answer
/// `Overflow`).
pub const RATE_LIMIT_RAD_S: f32 = core::f32::consts::TAU;

impl<S: Scalar> Envelope<S> {
    /// The envelope of a craft whose thrusters deliver at most `wrench` (per component, in
    /// magnitude; [`crate::craft::Craft::wrench_bound`]) and that turns at most
    /// [`RATE_LIMIT_RAD_S`].
    pub fn of_craft(wrench: [S; 6]) -> Self {
        Envelope {
            wrench,
            rate: S::from_f32(RATE_LIMIT_RAD_S),
        }
    }

    /// How far a window's rate products reach, rad^2/s: the rate squared times `window_s`,
    /// or less where the window ends at the coupled noise walk `max_walk` first (the walk
    /// weighs each axis' `omega_a^2 dt` by `walk_weight[a]`, [`super::window`]; the window's
    /// first sample and the one that crosses the limit are two steps of `step_s` beyond it).
    /// Then each `integral omega_a^2 dt` is at most (walk plus two steps) over its weight, and
    /// each cross product the largest of those. Also how many of the products' largest
    /// steps (`rate^2 step_s`) the reach holds, at most `max_window`.
    pub fn products_reach(
        &self,
        window_s: S,
        walk_weight: &[S; 3],
        max_walk: S,
        step_s: S,
        max_window: u32,
    ) -> (S, u32) {
        let rate2 = self.rate.times(self.rate);
        let by_time = rate2.times(window_s);
        let largest_step = rate2.times(step_s);
        let total = walk_weight.iter().fold(S::ZERO, |acc, w| acc.plus(*w));
        let least = walk_weight
            .iter()
            .fold(total, |m, w| if w.lt(m) { *w } else { m });
        let by_walk = max_walk
            .plus(total.times(largest_step).mul_pow2(1))
            .checked_div(least);
        match by_walk {
            Some(b) if b.is_valid() && S::ZERO.lt(least) && b.lt(by_time) => {
                // At least the two steps above; `as` saturates (no panic).
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let steps = b
                    .checked_div(largest_step)
                    .map_or(max_window, |n| n.to_f32() as u32);
                (b, steps.clamp(2, max_window.max(2)))
            }
            _ => (by_time, max_window),
        }
    }

    /// Per component of a sample (`z`, then `y`), a bound on its magnitude in a window of at
    /// most `window_s` seconds, for the nominal model's matrix `nominal` (its prediction is
    /// taken out of `y`): the drive integrates the wrench over the window, and the rate
    /// products up to `products_reach` (rad^2/s; at most the rate squared times the window,
    /// less where the window's noise walk ends it first), and the held torque is the wrench
    /// itself (each doubled for rounding's sake); the residual's bound is below.
    pub fn component_bounds(
        &self,
        window_s: S,
        products_reach: S,
        nominal: &[[S; NZ]; 3],
    ) -> [S; NZ + 3] {
        use super::sums::{N_MODEL, SPLIT_TORQUE};
        // A component the craft cannot push at all (a planar craft's roll torque) still gets
        // a bound, 2^-20 of the largest: a rounding residue there is not refused.
        let largest = self.wrench.iter().fold(S::ZERO, |m, v| max_abs(m, *v));
        let floor = largest.mul_pow2(-20);
        let w = |c: usize| max_abs(self.wrench.get(c).copied().unwrap_or(S::ZERO), floor);
        let rate = self.rate.abs();
        let mut out = [S::ZERO; NZ + 3];
        for (i, b) in out.iter_mut().enumerate().take(NZ) {
            *b = if i < 6 {
                w(i).times(window_s)
            } else if i < N_MODEL {
                products_reach
            } else if i < SPLIT_TORQUE {
                w(i.saturating_sub(N_MODEL))
            } else {
                w(i.saturating_sub(SPLIT_TORQUE)).times(window_s)
            };
        }
        // Each component's bound is twice its reach. The residual `y_raw - nominal z` is at
        // most twice the rate plus the prediction's worst case `P/2` (`P` from the doubled
        // bounds): its bound `2 (2 rate + P/4)` holds it with no margin to spare, because its
        // resolution matters (a bound four times larger moved the fixed kernel's rga12
        // estimates by 0.09-0.25 sigma). Each axis' bound is then at least half `|n|` times
        // each component's, the integer prediction's range ([`ExactMoments`]).
        let (z_bounds, y_bounds) = out.split_at_mut(NZ);
        for z in z_bounds.iter_mut() {
            *z = z.mul_pow2(1);
        }
        for (y, row) in y_bounds.iter_mut().zip(nominal) {
            let pred = row
                .iter()
                .zip(z_bounds.iter())
                .fold(S::ZERO, |acc, (n, z)| acc.mul_add(n.abs(), *z));
            *y = rate.mul_pow2(1).plus(pred.mul_pow2(-2)).mul_pow2(1);
        }
        out
    }
}

/// The recent sums of the integer float: exact `i64` sums of the rounded components'
/// products, and each component's power of two.
#[derive(Clone, Copy, Debug)]
pub struct ExactMoments {
    sums: LagMoments<i64>,
    /// Component `c` is `q 2^exp[c]`.
    exp: [i32; NZ + 3],
    /// The nominal model's matrix, entry `(a, j)` as `q 2^(exp_y[a] - exp_z[j] - PREDICTION_FRAC)`:
    /// its prediction of axis `a` is then the integer sum of `q z_q[j]`, rounded by
    /// `PREDICTION_FRAC` bits.
    nominal: [[i32; NZ]; 3],
}

/// Fractional bits of the nominal prediction's products, dropped by [`round_product`]
/// (proved for this count: `massid_proofs_solver`, obligation `round_sum_24`).
pub const PREDICTION_FRAC: u32 = 24;

/// An exponent for components of magnitude below `bound`: `|v| < 2^(exp + VALUE_BITS)`. A zero
/// bound (a component that is always zero) gets one far below any value.
fn exponent_for(bound: IntFloat) -> Option<i32> {
    if !bound.is_valid() {
        return None;
    }
    let (m, e) = bound.parts();
    if m == 0 {
        return Some(-100);
    }
    // |bound| < 2^(MANT_BITS + e)
    let bits = i32::try_from(crate::int::float::MANT_BITS).ok()?;
    let v = i32::try_from(VALUE_BITS).ok()?;
    e.checked_add(bits)?.checked_sub(v)
}

impl ExactMoments {
    /// The item of the rounded drive already in `out.z` and the rate `y_raw` relative to the
    /// window's first: the rate rounded, less the nominal model's prediction from the drive
    /// (in integers), into `out.y`; false if out of range.
    fn item_of(&self, out: &mut Sample<i32>, y_raw: &[IntFloat; 3]) -> bool {
        let ey = self.exp.get(NZ..).unwrap_or(&[]);
        let zq = &out.z;
        for ((o, (x, e)), row) in out
            .y
            .iter_mut()
            .zip(y_raw.iter().zip(ey))
            .zip(&self.nominal)
        {
            let Some(raw) = Self::round(*x, *e) else {
                return false;
            };
            let sum = row.iter().zip(zq.iter()).fold(0u64, |acc, (n, q)| {
                mul_acc(&Native, &acc, &(*n as u32), &(*q as u32))
            });
            let pred = round_product(&Native, &sum, PREDICTION_FRAC) as i32;
            match raw.checked_sub(pred) {
                Some(r) if r.unsigned_abs() < 1u32 << VALUE_BITS => *o = r,
                _ => return false,
            }
        }
        true
    }

    /// The item of an exact drive snapshot `z` (component `c` in units `2^-(extra[c] + bits)`
    /// of the sums' resolution, [`ExactDrive`]'s [`DriveSum::snapshot`] and the sensor's exact
    /// means): each component rounded once to nearest ([`round_product`], proved for every
    /// shift of [`response_frac`]), where the integer float rounded twice (to its mantissa, then to
    /// the sums' resolution) and cost a conversion each way.
    pub(crate) fn item_of_drive(
        &self,
        z: &[i64; NZ],
        extra: &[i32; NZ],
        bits: u32,
        y_raw: &[IntFloat; 3],
        out: &mut Sample<i32>,
    ) -> bool {
        for ((o, v), x) in out.z.iter_mut().zip(z).zip(extra) {
            if *v == 0 {
                // Most of a planar craft's components.
                *o = 0;
                continue;
            }
            // Anything past round_product's |v| <= 2^62, the sentinel `i64::MAX` included, is
            // out of range (a component within its bound is far below): one comparison,
            // `v + 2^62` within `[0, 2^63]`.
            if (*v as u64).wrapping_add(1 << 62) > 1 << 63 {
                return false;
            }
            let frac = x.unsigned_abs().wrapping_add(bits);
            let q = round_product(&Native, &(*v as u64), frac) as i32;
            if q.unsigned_abs() >= 1u32 << VALUE_BITS {
                return false;
            }
            *o = q;
        }
        self.item_of(out, y_raw)
    }

    /// `v` rounded to the integer multiple of `2^exp`, if `|q| < 2^VALUE_BITS`.
    fn round(v: IntFloat, exp: i32) -> Option<i32> {
        if !v.is_valid() {
            return None;
        }
        let (m, e) = v.parts();
        let q = shift_nearest(&Native, &(m as u32), &(e.saturating_sub(exp) as u32)) as i32;
        (q.unsigned_abs() < 1u32 << VALUE_BITS).then_some(q)
    }
}

impl Recent<IntFloat> for ExactMoments {
    const FOLD_PER_SAMPLE: usize = FOLD_PER_SAMPLE;
    /// Differences: the exact sums gather levels (their accumulators and proofs are sized for
    /// `|a b|`), and each fold takes a lag-`l` entry from `M_l` and adds a lag-0 entry to every
    /// `M_l` it is part of, so the flight's integer-float sums round relative to the
    /// differences. In levels, a gyro filtered far below the sampling rate (AR root near 1) left
    /// the whitened information in the last digits of the 25-bit mantissa: random planar craft
    /// 79024 and 79109 (1 kHz, 25-26 Hz gyros) `ok` 3.6-3.8 sigma off where f32 says 1.4 and 1.0.
    const LAG_FORM: LagForm = LagForm::Differences;
    const RECENT_FORM: LagForm = LagForm::Levels;
    /// Exact integer products, each entry rounded once per fold.
    const PIVOT_EXP: i32 = DEFAULT_PIVOT_EXP;
    const SHIFTS: bool = false;
    type Item = Sample<i32>;
    const ZERO_ITEM: Sample<i32> = Sample {
        z: [0; NZ],
        y: [0; 3],
    };

    type ItemSum = Sample<i64>;
    const ZERO_SUM: Sample<i64> = Sample {
        z: [0; NZ],
        y: [0; 3],
    };

    /// The components rounded; the residual `y_raw - nominal z` in integers: the prediction's
    /// products are exact (`|q| < 2^26`, `|z_q| < 2^27`: 18 of them within `mul_acc`'s
    /// envelope), rounded once; a prediction beyond 32 bits saturates, and its residual is then
    /// beyond the bound and refused.
    fn item(
        &self,
        z: &[IntFloat; NZ],
        y_raw: &[IntFloat; 3],
        _: &[[IntFloat; NZ]; 3],
    ) -> Option<Sample<i32>> {
        let mut out = Self::ZERO_ITEM;
        self.item_into(z, y_raw, &[[IntFloat::ZERO; NZ]; 3], &mut out)
            .then_some(out)
    }

    fn item_into(
        &self,
        z: &[IntFloat; NZ],
        y_raw: &[IntFloat; 3],
        _: &[[IntFloat; NZ]; 3],
        out: &mut Sample<i32>,
    ) -> bool {
        let ez = self.exp.get(..NZ).unwrap_or(&[]);
        for (o, (x, e)) in out.z.iter_mut().zip(z.iter().zip(ez)) {
            match Self::round(*x, *e) {
                Some(q) => *o = q,
                None => return false,
            }
        }
        self.item_of(out, y_raw)
    }

    fn accumulate(sum: &mut Sample<i64>, item: &Sample<i32>) {
        // |q| < 2^27 and a window has fewer than 2^32 samples: no wrap. Two plain loops (a
        // chained iterator compiled to about 19 instructions a component on the M4F).
        for (s, q) in sum.z.iter_mut().zip(&item.z) {
            *s = s.wrapping_add(i64::from(*q));
        }
        for (s, q) in sum.y.iter_mut().zip(&item.y) {
            *s = s.wrapping_add(i64::from(*q));
        }
    }

    fn sum_value(&self, sum: &Sample<i64>) -> Sample<IntFloat> {
        let at =
            |v: i64, c: usize| IntFloat::from_i64_pow2(v, self.exp.get(c).copied().unwrap_or(0));
        Sample {
            z: core::array::from_fn(|i| at(sum.z.get(i).copied().unwrap_or(0), i)),
            y: core::array::from_fn(|a| {
                at(sum.y.get(a).copied().unwrap_or(0), NZ.saturating_add(a))
            }),
        }
    }

    fn nonzero(item: &Sample<i32>, i: usize) -> bool {
        item.z.get(i).is_some_and(|q| *q != 0)
    }

    /// Not moved: the exact sums do not round, and their scales are derived for the model
    /// they were built for ([`super::anchor`]).
    fn shift(_: &mut [Sample<i32>], _: &mut Sample<i64>, _: &[[IntFloat; NZ]; 3]) -> bool {
        false
    }

    fn add_pair(&mut self, l: usize, now: &Sample<i32>, then: &Sample<i32>, active: &Active) {
        // |a b| < 2^(2 VALUE_BITS) and an entry holds at most FOLD_PERIOD products between
        // folds (the assertion above): no wrap.
        self.sums.add_pair_by(l, now, then, active, |m, a, b| {
            *m = mul_acc(&Native, &(*m as u64), &(a as u32), &(b as u32)) as i64;
        });
    }

    fn take(&mut self, k: usize) -> IntFloat {
        let v = self
            .sums
            .entry_mut(k)
            .map_or(0, |v| core::mem::replace(v, 0));
        let e = entry_components(k)
            .and_then(|(i, j)| Some(self.exp.get(i)?.saturating_add(*self.exp.get(j)?)))
            .unwrap_or(0);
        IntFloat::from_i64_pow2(v, e)
    }
}

/// Bits the drive is kept finer than its rounded components, for a window of at most
/// `max_window` samples: `4 + floor(log2(max_window))`. A component's bound is at least
/// `2 max_window` times its largest increment ([`Envelope::component_bounds`]), so at this
/// resolution every increment within the envelope is below 2^30 units: the largest is
/// resolved to 2^-28 to 2^-30 of itself. Finer matters: the increments vary slowly, so their
/// rounding errors do not cancel but add up over a window (resolved to `2^-35` of the
/// component's bound instead, the fixed kernel's inertia moved by 0.36 sigma on an rga12
/// flight, seed 31000). A window's drive then errs by at most `2^-30` of the bound.
pub const fn drive_extra_bits(max_window: u32) -> i32 {
    let n = if max_window == 0 { 1 } else { max_window };
    4i32.saturating_add(31i32.saturating_sub(n.leading_zeros() as i32))
}

/// Component `c` of the drive is a rate product (their reach is the noise walk's,
/// [`Envelope::products_reach`]).
const fn is_product(c: usize) -> bool {
    c >= 6 && c < super::sums::N_MODEL
}

/// The integer float's window drive: exact `i64` sums of increments rounded at a
/// per-component power of two [`drive_extra_bits`] below the sums' ([`ExactMoments`]). A
/// component within its bound is below `2^(VALUE_BITS + 35)` (`max_window < 2^32`), so no sum
/// wraps; an increment that does not fit 32 bits (a wrench or rate beyond the envelope)
/// saturates the component, which the sums then refuse as out of range.
#[derive(Clone, Copy, Debug)]
pub struct ExactDrive {
    /// The sums, as a point response reads them ([`DriveSum::current`]; `bits` 0).
    now: Response,
    exp: [i32; NZ],
    /// Per component, the drive's resolution below the sums' ([`drive_extra_bits`]).
    extra: [i32; NZ],
    /// The rate products' integers ([`RateProducts`]).
    products: RateProducts,
}

/// Bits of a rate rounded for its products: `|r| < 2^RATE_BITS`, so a product is below
/// `2^(2 RATE_BITS)` and Adams-Moulton's combination of three (`5 + 8 + 1` of them) below
/// `2^60`, within [`round_product`]'s `2^62`.
pub const RATE_BITS: u32 = 28;
/// Bits dropped from that combination before it multiplies the step's coefficient: it then fits
/// 31 bits. A shift `round_product` is proved for ([`response_frac`]'s range, 4..=29).
pub const COMBINATION_SHIFT: u32 = 29;
/// Bits of the step's coefficient (`dt / 12` or `dt / 2`): `|c| < 2^31`.
pub const COEFFICIENT_BITS: u32 = 31;
// The combination (below 14 products: 2^4) is within round_product's 2^62, and after the
// shift it fits the 31 bits its product with the coefficient takes (below 2^62 again).
const _: () = assert!(2 * RATE_BITS + 4 <= 62);
const _: () = assert!(2 * RATE_BITS + 4 - COMBINATION_SHIFT <= 31);
const _: () = assert!(COEFFICIENT_BITS + 31 <= 62);

/// The fixed kernel's rate products in integers: each rate rounded once to a multiple of
/// `2^rate_exp` (`|r| < 2^RATE_BITS`, [`Envelope::rate`] four times over), the products exact,
/// and a step's integral `c (5 p_k + 8 p_(k-1) - p_(k-2))` (or `c (p_(k-1) + p_k)`) rounded to
/// the drive's resolution: the combination by [`COMBINATION_SHIFT`] bits, the coefficient
/// `c` at `2^coef_exp`, their product by `frac` bits. In the integer float each product and
/// each term of the rule was a rounded operation: the six cost the 3-D craft's push about 1,950
/// instructions more on the M4F on average and 2,400 at worst (`scripts/kernel-report.sh`).
/// What a step errs by, in units of the drive's resolution: the combination's shift up to
/// `c / 2^(frac + 1)` of them (about 3 at 1 kHz with 60 s windows and the rate limit of
/// [`Envelope::of_craft`]), the final rounding half of one, and the rates' rounding about as
/// much as the shift; the integer float's step erred by `2^-25` of itself (up to about 30 of
/// them for the largest steps).
#[derive(Clone, Copy, Debug)]
pub struct RateProducts {
    rate_exp: i32,
    coef_exp: i32,
    frac: [u32; 6],
}

impl RateProducts {
    /// The scales for rates below `4 rate` (up to `8 rate`: a power of two), steps up to
    /// `max_step_s` and the six products' drives at `2^drive_exp[p]`; None if a drive is too
    /// coarse for a proved final shift (below 4 bits).
    fn new(rate: IntFloat, max_step_s: IntFloat, drive_exp: &[i32; 6]) -> Option<Self> {
        let bits = exponent_of_width;
        let rate_exp = bits(rate.mul_pow2(2), RATE_BITS)?;
        // The coefficient is at most half the longest step.
        let mut coef_exp = bits(max_step_s.mul_pow2(-1), COEFFICIENT_BITS)?;
        let shift = i32::try_from(COMBINATION_SHIFT).ok()?;
        let product_exp = |coef_exp: i32| {
            rate_exp
                .checked_mul(2)?
                .checked_add(shift)?
                .checked_add(coef_exp)
        };
        // A coarser coefficient where a drive needs fewer bits than the proved shifts drop
        // (the one coefficient serves the six: the most any of them needs).
        let mut coarser = 0;
        for e in drive_exp {
            coarser = coarser.max(final_shift(*e, product_exp(coef_exp)?)?.1);
        }
        coef_exp = coef_exp.checked_add(coarser)?;
        let mut frac = [0u32; 6];
        for (f, e) in frac.iter_mut().zip(drive_exp) {
            let (shift, more) = final_shift(*e, product_exp(coef_exp)?)?;
            if more > 0 {
                return None;
            }
            *f = shift;
        }
        Some(RateProducts {
            rate_exp,
            coef_exp,
            frac,
        })
    }
}

/// Bits of a turn or walk weight in [`ExactReach`]: `|k| < 2^REACH_WEIGHT_BITS`.
pub const REACH_WEIGHT_BITS: u32 = 28;
// A rate times a weight is below 2^56, three of them below 2^58: within round_product's 2^62;
// after its shift the sum fits 31 bits, and its product with a 31-bit step is below 2^62.
const _: () = assert!(RATE_BITS + REACH_WEIGHT_BITS + 2 <= 62);
const _: () = assert!(RATE_BITS + REACH_WEIGHT_BITS + 2 - COMBINATION_SHIFT <= 31);
const _: () = assert!(2 * RATE_BITS - COMBINATION_SHIFT + REACH_WEIGHT_BITS + 2 <= 62);

/// The fixed kernel's window reach ([`super::reach::Reach`]) in integers: the turn
/// `sum_a k_a |r_a|` of the rounded rates ([`RateProducts`]) and the walk `sum_a w_a p_aa` of
/// their exact squares (each rounded by [`COMBINATION_SHIFT`] bits first: to `2^-27` of the
/// largest square, so a rate below about `2^-13.5` of the rate bound adds nothing to the walk,
/// which acts only on craft spinning far faster), each times the step, every product exact and
/// each rounding a proved shift of [`COMBINATION_SHIFT`] bits; the limits in the same units,
/// rounded up, so that `turned < limit` holds where the values' comparison does. A step adds at most `2^31`
/// units and a window has at most [`MAX_WINDOW_SAMPLES`] (`2^24`), so the sums stay below
/// `2^55` (and saturate, never wrap). In the integer float the twelve multiply-adds cost
/// the 3-D push about 1,500 instructions on the M4F.
#[derive(Clone, Copy, Debug)]
pub struct ExactReach {
    turned: i64,
    walked: i64,
    turn_weight: [i32; 3],
    walk_weight: [i32; 3],
    max_turn: i64,
    max_walk: i64,
    dt_exp: i32,
    /// The rates' power of two ([`RateProducts`]): where the drive has no products (a planar
    /// craft), the turn rounds the rates itself.
    rate_exp: i32,
}

/// `v` in units of `2^unit`, rounded up (`x < v` for an integer `x` of those units exactly
/// where `x < result`); 0 for `v <= 0`, `i64::MAX` beyond `i64` or for an invalid `v`.
fn ceil_in_units(v: IntFloat, unit: i32) -> i64 {
    if !v.is_valid() {
        return i64::MAX;
    }
    let (m, e) = v.parts();
    if m <= 0 {
        return 0;
    }
    let m = i64::from(m);
    match e.checked_sub(unit) {
        Some(up) if up >= 0 => u32::try_from(up)
            .ok()
            .filter(|s| *s < 38)
            .map_or(i64::MAX, |s| m << s),
        Some(down) => {
            let s = down.unsigned_abs();
            if s >= 40 {
                1
            } else {
                // 0 < m < 2^25 and s < 40: no overflow.
                m.wrapping_add((1i64 << s).wrapping_sub(1)) >> s
            }
        }
        None => i64::MAX,
    }
}

/// Integer weights below `2^REACH_WEIGHT_BITS` at one power of two, and that power; zeros at
/// 0 where every weight is zero.
fn weights_in_integers(w: &[IntFloat; 3]) -> Option<([i32; 3], i32)> {
    let largest = w.iter().fold(IntFloat::ZERO, |m, v| max_abs(m, *v));
    if largest == IntFloat::ZERO {
        return Some(([0; 3], 0));
    }
    let e = exponent_of_width(largest, REACH_WEIGHT_BITS)?;
    let mut out = [0i32; 3];
    for (o, v) in out.iter_mut().zip(w) {
        *o = i32::try_from(ExactDrive::rounded(*v, e)).ok()?;
    }
    Some((out, e))
}

impl ExactReach {
    /// Nothing turned or walked: rates at `2^rate_exp` ([`RateProducts`]), these weights and
    /// limits, steps up to `max_step_s`.
    fn new(
        rate_exp: i32,
        turn_weight: &[IntFloat; 3],
        walk_weight: &[IntFloat; 3],
        max_turn: IntFloat,
        max_walk: IntFloat,
        max_step_s: IntFloat,
    ) -> Option<Self> {
        let (turn_q, turn_exp) = weights_in_integers(turn_weight)?;
        let (walk_q, walk_exp) = weights_in_integers(walk_weight)?;
        let dt_exp = exponent_of_width(max_step_s, COEFFICIENT_BITS)?;
        let shift = i32::try_from(COMBINATION_SHIFT).ok()?;
        // The step's units: rate x weight, shifted, x step, shifted; the walk's square too.
        let turn_unit = rate_exp
            .checked_add(turn_exp)?
            .checked_add(dt_exp)?
            .checked_add(shift.checked_mul(2)?)?;
        let walk_unit = rate_exp
            .checked_mul(2)?
            .checked_add(walk_exp)?
            .checked_add(dt_exp)?
            .checked_add(shift.checked_mul(3)?)?;
        Some(ExactReach {
            turned: 0,
            walked: 0,
            turn_weight: turn_q,
            walk_weight: walk_q,
            max_turn: ceil_in_units(max_turn, turn_unit),
            max_walk: ceil_in_units(max_walk, walk_unit),
            dt_exp,
            rate_exp,
        })
    }
}

/// The rates as integers at `2^rate_exp` ([`RateProducts`]), the sentinel `i64::MAX` for one
/// beyond `2^RATE_BITS` of them.
fn rounded_rates(rate: &[IntFloat; 3], rate_exp: i32) -> [i64; 3] {
    core::array::from_fn(|a| {
        let q = ExactDrive::rounded(rate.get(a).copied().unwrap_or(IntFloat::ZERO), rate_exp);
        if q.unsigned_abs() < 1u64 << RATE_BITS {
            q
        } else {
            i64::MAX
        }
    })
}

/// `a b` of two words rounded by [`COMBINATION_SHIFT`] bits (`|a b| <= 2^62`).
fn product_shifted(a: i64, b: i64) -> i64 {
    let product = widening_mul(&Native, &(a as u32), &(b as u32));
    i64::from(round_product(&Native, &product, COMBINATION_SHIFT) as i32)
}

impl super::reach::Reach<IntFloat, [i64; 9]> for ExactReach {
    fn add(&mut self, rate: &[IntFloat; 3], products: &[i64; 9], dt_s: IntFloat, gyro: bool) {
        let dt = ExactDrive::rounded(dt_s, self.dt_exp);
        // With products the drive has rounded the rates already; without (a planar craft), the
        // turn rounds them here.
        let own = if gyro {
            [0; 3]
        } else {
            rounded_rates(rate, self.rate_exp)
        };
        let rates = if gyro {
            products.get(6..).unwrap_or(&[])
        } else {
            &own
        };
        if dt == i64::MAX || rates.contains(&i64::MAX) || (gyro && products.contains(&i64::MAX)) {
            // A rate beyond its bound (the sample is refused): the window ends.
            self.turned = i64::MAX;
            self.walked = i64::MAX;
            return;
        }
        // |r| < 2^RATE_BITS and |k| < 2^REACH_WEIGHT_BITS (assertions above).
        let turn = rates
            .iter()
            .zip(self.turn_weight)
            .fold(0i64, |acc, (r, k)| {
                acc.wrapping_add(
                    widening_mul(&Native, &(r.unsigned_abs() as u32), &(k as u32)) as i64,
                )
            });
        let turn = i64::from(round_product(&Native, &(turn as u64), COMBINATION_SHIFT) as i32);
        self.turned = self.turned.saturating_add(product_shifted(turn, dt));
        if gyro {
            let walk = products
                .iter()
                .zip(self.walk_weight)
                .fold(0i64, |acc, (p, w)| {
                    let square =
                        i64::from(round_product(&Native, &(*p as u64), COMBINATION_SHIFT) as i32);
                    acc.wrapping_add(widening_mul(&Native, &(square as u32), &(w as u32)) as i64)
                });
            let walk = i64::from(round_product(&Native, &(walk as u64), COMBINATION_SHIFT) as i32);
            self.walked = self.walked.saturating_add(product_shifted(walk, dt));
        }
    }
    fn turn_within(&self) -> bool {
        self.turned < self.max_turn
    }
    fn walk_within(&self) -> bool {
        self.walked < self.max_walk
    }
    fn clear(&mut self) {
        self.turned = 0;
        self.walked = 0;
    }
}

/// The power of two at which values below `|v|` are integers below `2^width`; None for zero or
/// an invalid `v`.
fn exponent_of_width(v: IntFloat, width: u32) -> Option<i32> {
    // |v| < 2^(MANT_BITS + e): as a multiple of 2^(e + MANT_BITS - width) it is below 2^width.
    let (m, e) = v.abs().parts();
    if m == 0 || !v.is_valid() {
        return None;
    }
    let mant = i32::try_from(crate::int::float::MANT_BITS).ok()?;
    e.checked_add(mant)?.checked_sub(i32::try_from(width).ok()?)
}

/// The final shift of a product at `2^product_exp` rounded to a drive at `2^drive_exp`,
/// within [`proved_fracs`]: the shift, and how much coarser one factor must be taken so that
/// it is not beyond the proved shifts; None if it is below them (the drive too coarse).
fn final_shift(drive_exp: i32, product_exp: i32) -> Option<(u32, i32)> {
    let frac = drive_exp.checked_sub(product_exp)?;
    let (lo, hi) = (*proved_fracs().start(), *proved_fracs().end());
    if frac < lo {
        return None;
    }
    let coarser = frac.saturating_sub(hi).max(0);
    Some((u32::try_from(frac.min(hi)).ok()?, coarser))
}

/// The final shifts [`round_product`] is proved for from a drive's response and here:
/// [`response_frac`] of the shortest and longest window.
pub const fn proved_fracs() -> core::ops::RangeInclusive<i32> {
    (response_frac(1, 0) as i32)..=(response_frac(MAX_WINDOW_SAMPLES, RESPONSE_BITS) as i32)
}

impl ExactDrive {
    /// `v` as a multiple of `2^exp`, or i64::MAX (out of range) if it does not fit 32 bits.
    fn rounded(v: IntFloat, exp: i32) -> i64 {
        if !v.is_valid() {
            return i64::MAX;
        }
        let (m, e) = v.parts();
        let q = shift_nearest(&Native, &(m as u32), &(e.saturating_sub(exp) as u32)) as i32;
        if q == i32::MAX || q == i32::MIN {
            i64::MAX
        } else {
            i64::from(q)
        }
    }
}

/// Adds `a b`, two integers of at most 32 bits, rounded by `frac` bits, to the drive component
/// `z`: the product is exact and below `2^62` ([`round_product`]'s domain), the rounded step
/// must fit 32 bits. Any of them the sentinel, or a step beyond 32 bits: the component becomes
/// the sentinel (refused, as [`ExactDrive::rounded`]'s saturation).
fn add_rounded_product(z: &mut i64, a: i64, b: i64, frac: u32) {
    if a == i64::MAX || b == i64::MAX || *z == i64::MAX {
        *z = i64::MAX;
        return;
    }
    let (Ok(a), Ok(b)) = (i32::try_from(a), i32::try_from(b)) else {
        *z = i64::MAX;
        return;
    };
    let product = widening_mul(&Native, &(a as u32), &(b as u32));
    let q = round_product(&Native, &product, frac) as i32;
    *z = if q == i32::MAX || q == i32::MIN {
        i64::MAX
    } else {
        // |z| <= 2^(VALUE_BITS + extra) <= 2^62 and |q| < 2^31 (see the type's doc).
        z.saturating_add(i64::from(q))
    };
}

/// The most bits below the drive's resolution a sensor's response takes: two, the central
/// mean's quarter ([`Response`]).
pub const RESPONSE_BITS: u32 = 2;

/// The fixed kernel's drive as the sensor's response combines it: exact integer sums `z` in
/// units `2^-bits` of the drive's resolution (0 for a point response, 1 for the backward mean's
/// half, 2 for the central mean's quarter), so that the means are exact and the sample is
/// rounded once (`ExactMoments::item_of_drive`). A component that is `i64::MAX` is out of
/// range (the drive's sentinel).
#[derive(Clone, Copy, Debug)]
pub struct Response {
    z: [i64; NZ],
    bits: u32,
}

/// `a + w b` of two sums of a [`Response`], or the sentinel if either is the sentinel or the
/// result does not fit.
#[inline]
fn add_weighted(a: i64, b: i64, w: i64) -> i64 {
    if a == i64::MAX || b == i64::MAX {
        return i64::MAX;
    }
    b.checked_mul(w)
        .and_then(|t| a.checked_add(t))
        .filter(|v| *v != i64::MAX)
        .unwrap_or(i64::MAX)
}

/// The longest window the fixed kernel takes, samples (100 s at 168 kHz: no rate sensor
/// samples that fast). It keeps [`response_frac`] within 29 bits, where every shift's rounding
/// is proved and its mutants refuted (past 31 bits the result cannot saturate, so the
/// saturation's mutants are equivalent).
pub const MAX_WINDOW_SAMPLES: u32 = (1 << 24) - 1;
const _: () = assert!(response_frac(MAX_WINDOW_SAMPLES, RESPONSE_BITS) <= 29);

/// The fractional bits [`SumScalar::drive_item`] drops from the response of a drive of
/// `max_window` samples: the drive's extra bits and the response's (`bits` of [`Response`]).
pub const fn response_frac(max_window: u32, bits: u32) -> u32 {
    // drive_extra_bits is 4..=27 for windows up to MAX_WINDOW_SAMPLES and bits 0..=2, so
    // this is 4..=29.
    drive_extra_bits(max_window)
        .unsigned_abs()
        .saturating_add(bits)
}

impl ExactDrive {
    /// Component `i`'s increment in the drive's units (the sentinel if out of range).
    fn increment_of(&self, i: usize, increment: IntFloat) -> i64 {
        self.exp
            .get(i)
            .map_or(i64::MAX, |e| Self::rounded(increment, *e))
    }

    /// Adds an increment of [`ExactDrive::increment_of`] to component `i`.
    fn add_increment(&mut self, i: usize, q: i64) {
        if let Some(z) = self.now.z.get_mut(i) {
            *z = if q == i64::MAX || *z == i64::MAX {
                i64::MAX
            } else {
                // |z| <= 2^(VALUE_BITS + extra) <= 2^62 and |q| < 2^31 (see the type's doc).
                z.saturating_add(q)
            };
        }
    }

    /// Held component `i`'s value in the drive's units (the sentinel if out of range).
    fn held_of(&self, i: usize, value: IntFloat) -> i64 {
        let (Some(e), Some(extra)) = (self.exp.get(i), self.extra.get(i)) else {
            return i64::MAX;
        };
        // A held value is as large as its bound: rounded at the sums' resolution (it fits
        // 32 bits there), then brought to the drive's, exactly.
        let q = Self::rounded(value, e.saturating_add(*extra));
        if q == i64::MAX {
            q
        } else {
            // |q| < 2^31 and extra <= 35: a value beyond its bound saturates to the
            // sentinel (refused); within it |q| < 2^VALUE_BITS and nothing saturates.
            q.saturating_mul(1i64 << (*extra).clamp(0, 35))
        }
    }
}

impl DriveSum<IntFloat> for ExactDrive {
    fn add(&mut self, i: usize, increment: IntFloat) {
        let q = self.increment_of(i, increment);
        self.add_increment(i, q);
    }
    fn set(&mut self, i: usize, value: IntFloat) {
        let v = self.held_of(i, value);
        if let Some(z) = self.now.z.get_mut(i) {
            *z = v;
        }
    }
    /// The increments in the drive's units (a positive torque that is not adds zero, which
    /// changes nothing), then the held torques'.
    type Step = ([i64; 9], [i64; 3]);
    const ZERO_STEP: Self::Step = ([0; 9], [0; 3]);
    fn held_step(&self, command: &[IntFloat; COMMAND_LEN], dt_s: IntFloat) -> Self::Step {
        let at = |i: usize| command.get(i).copied().unwrap_or(IntFloat::ZERO);
        let increments = core::array::from_fn(|c| {
            let w = at(c);
            if c < 6 {
                self.increment_of(c, w.times(dt_s))
            } else if IntFloat::ZERO.lt(w) {
                // Command entries 6..9 drive components SPLIT_TORQUE..NZ.
                self.increment_of(
                    SPLIT_TORQUE.saturating_add(c.saturating_sub(6)),
                    w.times(dt_s),
                )
            } else {
                0
            }
        });
        let held = core::array::from_fn(|b| self.held_of(N_MODEL.saturating_add(b), at(b)));
        (increments, held)
    }
    fn add_step(&mut self, (increments, held): &Self::Step) {
        for (i, q) in increments.iter().enumerate() {
            let c = if i < 6 {
                i
            } else {
                SPLIT_TORQUE.saturating_add(i.saturating_sub(6))
            };
            self.add_increment(c, *q);
        }
        for (z, v) in self.now.z.iter_mut().skip(N_MODEL).zip(held) {
            *z = *v;
        }
    }
    type Snapshot = Response;
    const ZERO_SNAPSHOT: Response = Response {
        z: [0; NZ],
        bits: 0,
    };
    fn snapshot(&self) -> Response {
        self.now
    }
    fn current(&self) -> &Response {
        &self.now
    }
    fn mean2(a: &Response, b: &Response) -> Response {
        // The sum at one bit finer: the half, exactly. (Snapshots, bits 0.)
        let mut z = a.z;
        for (s, v) in z.iter_mut().zip(&b.z) {
            *s = add_weighted(*s, *v, 1);
        }
        Response {
            z,
            bits: a.bits.saturating_add(1),
        }
    }
    fn mean3(a: &Response, b: &Response, c: &Response) -> Response {
        // The sum at two bits finer: the quarter, exactly. (Snapshots, bits 0.)
        let mut z = a.z;
        for ((s, v), w) in z.iter_mut().zip(&b.z).zip(&c.z) {
            *s = add_weighted(add_weighted(*s, *v, 2), *w, 1);
        }
        Response {
            z,
            bits: a.bits.saturating_add(RESPONSE_BITS),
        }
    }
    fn values_of(&self, r: &Response) -> [IntFloat; NZ] {
        let shift = i32::try_from(r.bits).unwrap_or(0);
        core::array::from_fn(|i| {
            let (z, e) = (
                r.z.get(i).copied().unwrap_or(0),
                self.exp.get(i).copied().unwrap_or(0),
            );
            if z == i64::MAX {
                // Saturated, not a large valid number: it stays invalid through the
                // moving-average filter, and the sample is refused.
                IntFloat::from_i64_pow2(i64::MAX, crate::int_float::EXP_LIMIT)
            } else if z == 0 {
                // Most of a planar craft's components.
                IntFloat::ZERO
            } else {
                IntFloat::from_i64_pow2(z, e.saturating_sub(shift))
            }
        })
    }
    fn clear(&mut self) {
        self.now.z = [0; NZ];
    }
    /// Exact integer products of the rates rounded once ([`RateProducts`]), then the rounded
    /// rates themselves (the window's turn, [`ExactReach`]); `i64::MAX` for a rate beyond the
    /// bound (the sentinel: the step's components saturate and the sample is refused).
    type Products = [i64; 9];
    const ZERO_PRODUCTS: [i64; 9] = [0; 9];
    fn products_into(&self, rate: &[IntFloat; 3], out: &mut [i64; 9]) {
        let r = rounded_rates(rate, self.products.rate_exp);
        for (o, (b, d)) in out.iter_mut().zip(super::solve::PRODUCTS) {
            let (x, y) = (
                r.get(b).copied().unwrap_or(0),
                r.get(d).copied().unwrap_or(0),
            );
            *o = if x == i64::MAX || y == i64::MAX {
                i64::MAX
            } else {
                // |x|, |y| < 2^RATE_BITS: the widening product is exact.
                widening_mul(&Native, &(x as u32), &(y as u32)) as i64
            };
        }
        if let Some(rates) = out.get_mut(6..) {
            rates.copy_from_slice(&r);
        }
    }
    fn add_products(
        &mut self,
        first: usize,
        now: &[i64; 9],
        then: &[i64; 9],
        before: &[i64; 9],
        dt_s: IntFloat,
        third_order: bool,
    ) {
        let scales = self.products;
        let coefficient = if third_order {
            dt_s.times(IntFloat::from_f32(1.0 / 12.0))
        } else {
            dt_s.mul_pow2(-1)
        };
        let c = Self::rounded(coefficient, scales.coef_exp);
        for (p, ((n, t), b)) in now.iter().zip(then).zip(before).take(6).enumerate() {
            let Some(z) = self.now.z.get_mut(first.saturating_add(p)) else {
                continue;
            };
            // `before` counts only in the third-order rule (in the trapezoid it may be a sample
            // before the window).
            if [*n, *t, c, *z].contains(&i64::MAX) || (third_order && *b == i64::MAX) {
                *z = i64::MAX;
                continue;
            }
            // |products| < 2^(2 RATE_BITS): the combination is below 2^(2 RATE_BITS + 4).
            let combination = if third_order {
                n.wrapping_mul(5)
                    .wrapping_add(t.wrapping_mul(8))
                    .wrapping_sub(*b)
            } else {
                n.wrapping_add(*t)
            };
            let shifted = round_product(&Native, &(combination as u64), COMBINATION_SHIFT);
            // |shifted| < 2^31 and |c| < 2^31.
            let frac = scales.frac.get(p).copied().unwrap_or(0);
            add_rounded_product(z, i64::from(shifted as i32), c, frac);
        }
    }
}

/// The integer float's scales: each component's power of two, the quantized nominal matrix,
/// and the drive's finer powers of two. Small, computed once at init, so that the large sums
/// are built in place (as zeros) and not moved through the stack.
#[derive(Clone, Copy, Debug)]
pub struct ExactScales {
    exp: [i32; NZ + 3],
    nominal: [[i32; NZ]; 3],
    drive_exp: [i32; NZ],
    extra: [i32; NZ],
    products: RateProducts,
}

impl SumScalar for IntFloat {
    type Recent = ExactMoments;
    type Drive = ExactDrive;
    type Reach = ExactReach;
    type Scales = ExactScales;
    fn scales(
        bounds: &[IntFloat; NZ + 3],
        nominal: &[[IntFloat; NZ]; 3],
        max_window: u32,
        products_window: u32,
        window_s: IntFloat,
        rate: IntFloat,
        max_step_s: IntFloat,
    ) -> Option<ExactScales> {
        if IntFloat::from_f32(MAX_REACH_S).lt(window_s) || max_window > MAX_WINDOW_SAMPLES {
            return None;
        }
        let mut exp = [0i32; NZ + 3];
        for (e, b) in exp.iter_mut().zip(bounds) {
            *e = exponent_for(*b)?;
        }
        let (ez, ey) = exp.split_at(NZ);
        let frac = i32::try_from(PREDICTION_FRAC).ok()?;
        let mut nominal_q = [[0i32; NZ]; 3];
        for ((row_q, row), e_y) in nominal_q.iter_mut().zip(nominal).zip(ey) {
            for ((q, n), e_z) in row_q.iter_mut().zip(row).zip(ez) {
                let e = e_y.checked_sub(*e_z)?.checked_sub(frac)?;
                *q = ExactMoments::round(*n, e)?;
                // each axis' bound is at least half |n| times the component's: |n| < 2^(exp_y -
                // exp_z + 2), so |q| < 2^26
                if q.unsigned_abs() >= 1 << 26 {
                    return None;
                }
            }
        }
        // The rate products' bound may be reached in fewer steps than a window has (a window
        // that ends at its noise walk): their drive is kept finer by what that many steps
        // need, so that their increments still fit 32 bits.
        let extra: [i32; NZ] = core::array::from_fn(|c| {
            drive_extra_bits(if is_product(c) {
                products_window.clamp(1, max_window.max(1))
            } else {
                max_window
            })
        });
        let mut drive_exp = [0i32; NZ];
        for ((d, e), x) in drive_exp.iter_mut().zip(ez).zip(extra) {
            *d = e.checked_sub(x)?;
        }
        let products_exp: &[i32; 6] = drive_exp.get(6..N_MODEL)?.try_into().ok()?;
        let products = RateProducts::new(rate, max_step_s, products_exp)?;
        Some(ExactScales {
            exp,
            nominal: nominal_q,
            drive_exp,
            extra,
            products,
        })
    }
    fn init_recent<'a>(
        slot: &'a mut MaybeUninit<ExactMoments>,
        scales: &ExactScales,
    ) -> &'a mut ExactMoments {
        LagMoments::fill_in_place(field!(slot, ExactMoments, sums), 0);
        field!(slot, ExactMoments, exp).write(scales.exp);
        field!(slot, ExactMoments, nominal).write(scales.nominal);
        // SAFETY: every field was written just above.
        unsafe { assume_all_written!(slot, ExactMoments { sums, exp, nominal }) }
    }
    fn reach(
        scales: &ExactScales,
        turn_weight: [IntFloat; 3],
        walk_weight: [IntFloat; 3],
        max_turn: IntFloat,
        max_walk: IntFloat,
        max_step_s: IntFloat,
    ) -> Option<ExactReach> {
        ExactReach::new(
            scales.products.rate_exp,
            &turn_weight,
            &walk_weight,
            max_turn,
            max_walk,
            max_step_s,
        )
    }
    fn drive(scales: &ExactScales) -> ExactDrive {
        ExactDrive {
            now: Response {
                z: [0; NZ],
                bits: 0,
            },
            exp: scales.drive_exp,
            extra: scales.extra,
            products: scales.products,
        }
    }
    fn drive_item(
        recent: &ExactMoments,
        drive: &ExactDrive,
        z: &Response,
        y_raw: &[IntFloat; 3],
        _: &[[IntFloat; NZ]; 3],
        out: &mut Sample<i32>,
    ) -> bool {
        recent.item_of_drive(&z.z, &drive.extra, z.bits, y_raw, out)
    }
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )]
    use super::*;

    /// The envelope's rate of the tests' scales.
    const ONE_RAD_S: IntFloat = IntFloat::ONE;
    /// Their longest step, s (1.5 ms).
    fn step_s() -> IntFloat {
        IntFloat::from_f32(1.5e-3)
    }

    /// [`SumScalar::scales`] for windows of `n` samples and `window_s` seconds (their rate
    /// products reaching their bound in as many steps), the tests' rate and step.
    fn scales_for(
        bounds: &[IntFloat; NZ + 3],
        nominal: &[[IntFloat; NZ]; 3],
        n: u32,
        window_s: IntFloat,
    ) -> Option<ExactScales> {
        IntFloat::scales(bounds, nominal, n, n, window_s, ONE_RAD_S, step_s())
    }

    #[test]
    fn components_round_to_nearest_within_their_bound_and_refuse_beyond_it() {
        let bound = IntFloat::from_f32(3.0);
        let e = exponent_for(bound).unwrap();
        // 3 < 2^2: the exponent leaves VALUE_BITS bits below 4.
        assert_eq!(e, 2 - VALUE_BITS as i32);
        let q = ExactMoments::round(IntFloat::from_f32(1.0), e).unwrap();
        assert_eq!(q, 1 << (VALUE_BITS - 2));
        let q = ExactMoments::round(IntFloat::from_f32(-2.9), e).unwrap();
        assert!((f64::from(q) * 2f64.powi(e) + 2.9).abs() <= 2f64.powi(e - 1) + 1e-7);
        assert_eq!(ExactMoments::round(IntFloat::from_f32(4.0), e), None);
        assert_eq!(ExactMoments::round(IntFloat::from_f32(-4.0), e), None);
        assert_eq!(ExactMoments::round(IntFloat::from_f32(1e-12), e), Some(0));
        assert_eq!(exponent_for(IntFloat::ZERO), Some(-100));
    }

    #[test]
    fn exact_sums_equal_the_integer_products_and_fold_to_their_value() {
        let bounds = [IntFloat::from_f32(2.0); NZ + 3];
        let mut r = IntFloat::recent(
            &scales_for(&bounds, &[[IntFloat::ZERO; NZ]; 3], 1000, IntFloat::ONE).unwrap(),
        );
        let v = Sample {
            z: core::array::from_fn(|i| IntFloat::from_f32(0.1 * i as f32 - 0.7)),
            y: [0.25, -0.5, 1.5].map(IntFloat::from_f32),
        };
        let item = r.item(&v.z, &v.y, &[[IntFloat::ZERO; NZ]; 3]).unwrap();
        for _ in 0..FOLD_PERIOD {
            r.add_pair(0, &item, &item, &Active::full());
        }
        // Entry (0, 1) of zz at lag 0: z0 z1 FOLD_PERIOD times, exactly.
        let want = f64::from(item.z[0]) * f64::from(item.z[1]) * FOLD_PERIOD as f64;
        let got = r.take(1).to_f32();
        let e = 2.0 * f64::from(r.exp[0]);
        assert!((f64::from(got) - want * 2f64.powf(e)).abs() <= 1e-6 * want.abs() * 2f64.powf(e));
        // And close to the values' own products.
        let exact = (-0.7f64) * (0.1 - 0.7) * FOLD_PERIOD as f64;
        assert!(
            (f64::from(got) - exact).abs() < 1e-5 * exact.abs(),
            "{got} {exact}"
        );
        // Taken: empty.
        assert_eq!(r.take(1), IntFloat::ZERO);
        // A component beyond its bound is refused, not wrapped.
        let mut big = v;
        big.y[2] = IntFloat::from_f32(9.0);
        assert!(r.item(&big.z, &big.y, &[[IntFloat::ZERO; NZ]; 3]).is_none());
    }

    /// The products' drive (components 6..12) after 2,000 samples of a smooth turn at 1 kHz,
    /// the integer path against the rule in f64 on the rates and coefficient it rounded, in
    /// units of the drive's resolution: the largest error over the six, and the bound it must
    /// stay within (per step: the combination's shift and the final rounding).
    fn products_error(swapped: bool) -> (f64, f64) {
        let bounds = [IntFloat::from_f32(60.0); NZ + 3];
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 20_000, IntFloat::from_f32(30.0)).unwrap();
        let mut d = IntFloat::drive(&scales);
        // The step as the kernel is told it (f32's 1 ms).
        let dt = f64::from(1e-3f32);
        let measured = |k: usize| {
            let t = k as f64 * dt;
            [
                0.6 * (2.0 * core::f64::consts::PI * 0.3 * t).sin(),
                0.4 * (2.0 * core::f64::consts::PI * 0.7 * t).cos(),
                -0.2 + 0.1 * t,
            ]
            .map(|w| IntFloat::from_f32(w as f32))
        };
        let rate_unit = 2f64.powi(d.products.rate_exp);
        // The products of the rates the kernel rounded (its products' last three).
        let exact = |p: &[i64; 9]| {
            super::super::solve::PRODUCTS
                .map(|(b, c)| p[6 + b] as f64 * rate_unit * p[6 + c] as f64 * rate_unit)
        };
        let unit = 2f64.powi(d.exp[6]);
        // The coefficient as the kernel rounds it (`dt / 12` in the integer float, then to 31 bits).
        let (dt_int, coef_exp) = (IntFloat::from_f32(dt as f32), d.products.coef_exp);
        let coefficient = |third: bool| {
            let c = if third {
                dt_int.times(IntFloat::from_f32(1.0 / 12.0))
            } else {
                dt_int.mul_pow2(-1)
            };
            ExactDrive::rounded(c, coef_exp) as f64 * 2f64.powi(coef_exp)
        };
        // The largest of the six final shifts' units (all equal here).
        let frac = d.products.frac.iter().copied().min().unwrap() as i32;
        let shift_units =
            |third: bool| coefficient(third) / 2f64.powi(coef_exp) / 2f64.powi(frac + 1);
        let mut reference = [0.0f64; 6];
        let mut bound = 0.0;
        let (mut before, mut then) = (d.products(&measured(0)), d.products(&measured(0)));
        for k in 1..2_000 {
            let now = d.products(&measured(k));
            let third = k >= 2;
            let (a, b) = if swapped {
                (&then, &now)
            } else {
                (&now, &then)
            };
            d.add_products(6, a, b, &before, IntFloat::from_f32(dt as f32), third);
            let (p, q, r) = (exact(&now), exact(&then), exact(&before));
            let mut largest: f64 = 0.0;
            for c in 0..6 {
                let step = if third {
                    coefficient(true) * (5.0 * p[c] + 8.0 * q[c] - r[c])
                } else {
                    coefficient(false) * (p[c] + q[c])
                };
                reference[c] += step;
                largest = largest.max(step.abs());
            }
            // The rates' products in f64 (2^-52 of them) and the two integer roundings.
            bound += largest * 2f64.powi(-50) / unit + shift_units(third) + 0.5;
            (before, then) = (then, now);
        }
        let values = d.values_of(&d.snapshot());
        let f64_of = |v: IntFloat| {
            let (m, e) = v.parts();
            f64::from(m) * 2f64.powi(e)
        };
        let error = (0..6)
            .map(|c| (f64_of(values[6 + c]) - reference[c]).abs() / unit)
            .fold(0.0, f64::max);
        (error, bound)
    }

    #[test]
    fn rate_products_integrate_by_the_rule_within_their_rounding() {
        let (error, bound) = products_error(false);
        assert!(error <= bound, "error {error:e} beyond {bound:e}");
        // Not vacuous: the roundings show (about 3,200 of a 22,900-unit bound here).
        assert!(error > 0.0, "no rounding at all: {error}");
        // Planted: the step's start and end products swapped (weights 8 and 5 exchanged).
        let (error, bound) = products_error(true);
        assert!(error > bound, "the swap passed: {error:e} within {bound:e}");
    }

    /// The samples (1 kHz, a turn about every axis) at which the integer reach and the
    /// integer float's own leave their turn and walk limits; the integer one's walk weights
    /// scaled by `walk_scale` (1: as configured); `gyro` false: a craft without products (the
    /// drive's products are zero, the walk is not counted).
    fn reach_crossings(walk_scale: f32, gyro: bool) -> ([Option<usize>; 2], [Option<usize>; 2]) {
        use super::super::reach::{FloatReach, Reach};
        let bounds = [IntFloat::from_f32(60.0); NZ + 3];
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 20_000, IntFloat::from_f32(30.0)).unwrap();
        let d = IntFloat::drive(&scales);
        let turn = [1.0, 1.0, 3.56].map(IntFloat::from_f32);
        let walk = [0.5, 0.5, 2.0].map(IntFloat::from_f32);
        let (max_turn, max_walk) = (IntFloat::from_f32(4.0), IntFloat::from_f32(0.5));
        let planted = walk.map(|w| w.times(IntFloat::from_f32(walk_scale)));
        let mut exact =
            IntFloat::reach(&scales, turn, planted, max_turn, max_walk, step_s()).unwrap();
        let mut float = FloatReach::new(turn, walk, max_turn, max_walk);
        let dt = IntFloat::from_f32(1e-3);
        let (mut e, mut f) = ([None; 2], [None; 2]);
        for k in 0..3_000 {
            let t = k as f32 * 1e-3;
            let rate = [
                0.6 * (2.0 * core::f32::consts::PI * 0.3 * t).sin(),
                0.4 * (2.0 * core::f32::consts::PI * 0.7 * t).cos(),
                0.5,
            ]
            .map(IntFloat::from_f32);
            let p = super::super::solve::PRODUCTS.map(|(b, c)| rate[b].times(rate[c]));
            let products = if gyro { d.products(&rate) } else { [0; 9] };
            exact.add(&rate, &products, dt, gyro);
            float.add(&rate, &p, dt, gyro);
            for (i, (x, y)) in [
                (exact.turn_within(), float.turn_within()),
                (exact.walk_within(), float.walk_within()),
            ]
            .into_iter()
            .enumerate()
            {
                if !x && e[i].is_none() {
                    e[i] = Some(k);
                }
                if !y && f[i].is_none() {
                    f[i] = Some(k);
                }
            }
        }
        (e, f)
    }

    #[test]
    fn the_integer_reach_leaves_its_limits_where_the_values_do() {
        let (exact, float) = reach_crossings(1.0, true);
        // Both limits are crossed within the run (turn about 1.6 s, walk about 0.8 s) ...
        assert!(
            float
                .iter()
                .all(|c| c.is_some_and(|k| k > 100 && k < 2_900)),
            "{float:?}"
        );
        // ... at the same sample, or the next (the roundings near the limit).
        for (x, y) in exact.iter().zip(&float) {
            let (x, y) = (x.unwrap(), y.unwrap());
            assert!(
                x.abs_diff(y) <= 1,
                "integer {exact:?}, integer float {float:?}"
            );
        }
        // Planted: walk weights a twentieth off cross elsewhere.
        let (exact, float) = reach_crossings(1.05, true);
        assert!(
            exact[1].unwrap().abs_diff(float[1].unwrap()) > 1,
            "{exact:?} {float:?}"
        );
        // Without products (a planar craft) the turn still counts, the walk does not.
        let (exact, float) = reach_crossings(1.0, false);
        assert_eq!((exact[1], float[1]), (None, None));
        let (x, y) = (exact[0].unwrap(), float[0].unwrap());
        assert!(
            x.abs_diff(y) <= 1,
            "integer {exact:?}, integer float {float:?}"
        );
    }

    #[test]
    fn a_rate_beyond_the_products_bound_is_refused() {
        let bounds = [IntFloat::from_f32(60.0); NZ + 3];
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 1000, IntFloat::ONE).unwrap();
        let mut d = IntFloat::drive(&scales);
        // The rate's integer holds 4 to 8 times the envelope's rate (a power of two): twenty
        // times does not fit.
        let fast = d.products(&[IntFloat::from_f32(20.0), IntFloat::ZERO, IntFloat::ZERO]);
        assert_eq!(fast[0], i64::MAX);
        let zero = d.products(&[IntFloat::ZERO; 3]);
        d.add_products(6, &fast, &zero, &zero, step_s().mul_pow2(-1), false);
        assert_eq!(d.now.z[6], i64::MAX);
        // xy and xz carry the sentinel too; yy, zz and yz do not.
        assert_eq!((d.now.z[9], d.now.z[10]), (i64::MAX, i64::MAX));
        assert_eq!((d.now.z[7], d.now.z[8], d.now.z[11]), (0, 0, 0));
    }

    #[test]
    fn the_drive_sums_increments_exactly_and_holds_values_as_large_as_their_bound() {
        let bounds = [IntFloat::from_f32(3.0); NZ + 3];
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 20_000, IntFloat::ONE).unwrap();
        let mut d = IntFloat::drive(&scales);
        assert_eq!(d.extra, [4 + 14; NZ]);
        // 10,000 increments of 1e-4: exactly their rounded sum, close to 1.
        for _ in 0..10_000 {
            d.add(0, IntFloat::from_f32(1e-4));
        }
        let step = ExactDrive::rounded(IntFloat::from_f32(1e-4), d.exp[0]);
        assert_eq!(d.now.z[0], 10_000 * step);
        let values = |d: &ExactDrive| d.values_of(&d.snapshot());
        assert!((values(&d)[0].to_f32() - 1.0).abs() < 1e-6);
        // A held value at its bound (it does not fit 32 bits at the drive's resolution).
        d.set(1, IntFloat::from_f32(-2.9));
        assert!(
            (values(&d)[1].to_f32() + 2.9).abs() < 1e-6,
            "{:?}",
            values(&d)[1]
        );
        // An increment far beyond the bound saturates the component: the sums refuse it.
        d.add(2, IntFloat::from_f32(1e6));
        d.add(2, IntFloat::from_f32(-1e6));
        assert_eq!(d.now.z[2], i64::MAX);
        let r = IntFloat::recent(&scales);
        assert!(r.item(&values(&d), &[IntFloat::ZERO; 3], &none).is_none());
        // The same through the integer path.
        let zero = [IntFloat::ZERO; 3];
        let mut item = ExactMoments::ZERO_ITEM;
        assert!(!IntFloat::drive_item(
            &r,
            &d,
            &d.snapshot(),
            &zero,
            &none,
            &mut item
        ));
        d.clear();
        assert!(values(&d).iter().all(|v| *v == IntFloat::ZERO));
    }

    /// The sensor's means of the exact drive are exact, and the sample's drive is rounded once
    /// to the sums' resolution (within half a step of the exact mean; the integer float's
    /// conversion and rounding, the path before, erred by up to a step).
    #[test]
    fn the_drive_s_item_is_its_exact_mean_rounded_once() {
        let bounds = [IntFloat::from_f32(3.0); NZ + 3];
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 20_000, IntFloat::ONE).unwrap();
        let r = IntFloat::recent(&scales);
        let mut drives = [IntFloat::drive(&scales); 3];
        for (k, d) in drives.iter_mut().enumerate() {
            for i in 0..NZ {
                let sign = if i % 3 == 0 { -1.0 } else { 1.0 };
                let inc = IntFloat::from_f32(sign * 5.01e-5 * (1.0 + 0.041 * i as f32));
                for _ in 0..(12_000 + 500 * k + 300 * i) {
                    d.add(i, inc);
                }
            }
        }
        let snaps = drives.map(|d| d.snapshot());
        let frac_of = |d: &ExactDrive, r: &Response| d.extra[0] as u32 + r.bits;
        assert_eq!(frac_of(&drives[0], &snaps[0]), response_frac(20_000, 0));
        let zero = [IntFloat::ZERO; 3];
        let exact_of = |i: usize, w: [f64; 3]| -> f64 {
            let sum: f64 = (0..3).map(|k| w[k] * drives[k].now.z[i] as f64).sum();
            sum / w.iter().sum::<f64>() / 2f64.powi(drives[0].extra[i])
        };
        let responses = [
            (snaps[2], [0.0, 0.0, 1.0]),
            (ExactDrive::mean2(&snaps[1], &snaps[2]), [0.0, 1.0, 1.0]),
            (
                ExactDrive::mean3(&snaps[0], &snaps[1], &snaps[2]),
                [1.0, 2.0, 1.0],
            ),
        ];
        let mut worst_before = 0.0f64;
        for (z, w) in responses {
            let mut item = ExactMoments::ZERO_ITEM;
            assert!(IntFloat::drive_item(
                &r, &drives[0], &z, &zero, &none, &mut item
            ));
            let old = r.item(&drives[0].values_of(&z), &zero, &none).unwrap();
            for i in 0..NZ {
                let exact = exact_of(i, w);
                assert!(
                    exact.abs() > 2f64.powi(24),
                    "a component that matters: {exact}"
                );
                let err = f64::from(item.z[i]) - exact;
                assert!(err.abs() <= 0.5, "component {i}: {} vs {exact}", item.z[i]);
                worst_before = worst_before.max((f64::from(old.z[i]) - exact).abs());
            }
            // Planted: a shift one bit short is a different item.
            let short = drives[0].extra.map(|x| x - 1);
            let mut wrong = ExactMoments::ZERO_ITEM;
            assert!(r.item_of_drive(&z.z, &short, z.bits, &zero, &mut wrong));
            assert_ne!(wrong.z, item.z);
        }
        assert!(worst_before > 0.5, "{worst_before}");
    }

    /// Windows past [`MAX_WINDOW_SAMPLES`] are refused (the shifts proved stop there).
    #[test]
    fn windows_beyond_the_proved_shifts_are_refused() {
        let bounds = [IntFloat::from_f32(3.0); NZ + 3];
        let none = [[IntFloat::ZERO; NZ]; 3];
        let at = |n| scales_for(&bounds, &none, n, IntFloat::ONE);
        assert!(at(MAX_WINDOW_SAMPLES).is_some());
        assert!(at(MAX_WINDOW_SAMPLES + 1).is_none());
    }

    #[test]
    fn the_integer_prediction_is_the_nominal_model_s_to_a_few_resolution_steps() {
        use crate::flight_id::solve::model_matrix;
        let j = [20.0f32, 25.0, 30.0, 1.0, -0.5, 0.3].map(IntFloat::from_f32);
        let nominal = model_matrix(&j, &[IntFloat::ZERO; 3], true).unwrap();
        let env = Envelope::of_craft([0.05f32, 0.05, 0.05, 0.5, 0.5, 0.5].map(IntFloat::from_f32));
        let window_s = IntFloat::from_f32(90.0);
        let reach = env.rate * env.rate * window_s;
        let bounds = env.component_bounds(window_s, reach, &nominal);
        let r = IntFloat::recent(&scales_for(&bounds, &nominal, 20_000, IntFloat::ONE).unwrap());
        // Each component at a third of its bound or less.
        let z: [IntFloat; NZ] =
            core::array::from_fn(|i| bounds[i] * IntFloat::from_f32(0.15 * (i as f32 + 1.0).sin()));
        let y_raw = [0.3f32, -0.2, 0.1].map(IntFloat::from_f32);
        let item = r.item(&z, &y_raw, &nominal).unwrap();
        for (a, row) in nominal.iter().enumerate() {
            let pred: f64 = row
                .iter()
                .zip(&z)
                .map(|(n, zc)| f64::from(n.to_f32()) * f64::from(zc.to_f32()))
                .sum();
            let want = f64::from(y_raw[a].to_f32()) - pred;
            let step = 2f64.powi(r.exp[NZ + a]);
            let got = f64::from(item.y[a]) * step;
            // each of the 18 terms within half a step, and the rounding of the sum
            assert!(
                (got - want).abs() <= 10.0 * step,
                "axis {a}: {got} vs {want}, step {step}"
            );
            assert!(pred.abs() > 1e3 * step, "a prediction that matters: {pred}");
        }
        // A planted fault: the prediction left out is seen.
        let none = [[IntFloat::ZERO; NZ]; 3];
        let r0 = IntFloat::recent(&scales_for(&bounds, &none, 20_000, IntFloat::ONE).unwrap());
        let raw = r0.item(&z, &y_raw, &none).unwrap();
        assert!((0..3).any(|a| (raw.y[a] - item.y[a]).abs() > 1000));
    }

    /// Through the window's rings and the rolling fold, every lagged moment is the direct sum
    /// of the lagged products (the pairing of lags 1 and 2 and each entry's power of two are
    /// what this checks: exact values, so only the fold's last rounding is allowed).
    #[test]
    fn exact_lagged_moments_equal_the_direct_sums_of_lagged_products() {
        use crate::flight_id::sums::{FlightSums, RecentSums, WindowSums, LAGS};
        let bounds: [IntFloat; NZ + 3] =
            core::array::from_fn(|c| IntFloat::from_f32(2.0 + (c % 5) as f32));
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 1000, IntFloat::ONE).unwrap();
        let mut recent = RecentSums::new(IntFloat::recent(&scales));
        // The form the fixed kernel's flight keeps (the fold turns the levels into it).
        let mut flight = FlightSums::<IntFloat> {
            lag_form: <ExactMoments as Recent<IntFloat>>::LAG_FORM,
            ..FlightSums::default()
        };
        let mut window = WindowSums::<IntFloat>::default();
        // Multiples of 1/64 in [-1, 1.3]: exact in every format here.
        let v = |k: usize, c: usize| ((k * 7 + c * 13) % 17) as f64 / 8.0 - 1.0 + c as f64 / 64.0;
        let n = 40;
        for k in 0..n {
            let z: [IntFloat; NZ] = core::array::from_fn(|i| IntFloat::from_f32(v(k, i) as f32));
            let y: [IntFloat; 3] =
                core::array::from_fn(|a| IntFloat::from_f32(v(k, NZ + a) as f32));
            window.push(&mut flight, &mut recent, 0, |r, out| {
                r.item_into(&z, &y, &none, out)
            });
        }
        recent.fold_all(&mut flight);
        let close = |got: IntFloat, want: f64, what: &str| {
            let got = f64::from(got.to_f32());
            assert!(
                (got - want).abs() <= 1e-6 * (1.0 + want.abs()),
                "{what}: {got} vs {want}"
            );
        };
        // The symmetrised lag-`l` sum of the products of components `c` and `d`, and what the
        // flight keeps of it: the level, or at lags 1 and 2 in differences `L_0 - L_l`.
        let level = |l: usize, c: usize, d: usize| -> f64 {
            (l..n)
                .map(|k| 0.5 * (v(k, c) * v(k - l, d) + v(k, d) * v(k - l, c)))
                .sum()
        };
        assert_eq!(flight.lag_form, LagForm::Differences);
        let kept = |l: usize, c: usize, d: usize| {
            if l == 0 {
                level(0, c, d)
            } else {
                level(0, c, d) - level(l, c, d)
            }
        };
        for l in 0..LAGS {
            for i in 0..NZ {
                for j in 0..NZ {
                    close(flight.lag.zz_sym(l, i, j), kept(l, i, j), "zz");
                }
                for a in 0..3 {
                    close(flight.lag.zy_sym(l, a, i), kept(l, i, NZ + a), "zy");
                }
            }
            for a in 0..3 {
                close(flight.lag.yy[l][a], kept(l, NZ + a, NZ + a), "yy");
            }
        }
        assert_eq!(flight.samples, n as u32);
    }

    /// The whitened cost at the true parameter, `u^T W u`, of a strongly coloured flight
    /// (`test_flights::coloured_yaw`) from the lag sums gathered by `recent` and folded, sample by sample,
    /// into a flight keeping `form`.
    fn coloured_cost<S: SumScalar>(recent: S::Recent, form: LagForm) -> f64 {
        use crate::flight_id::sums::{FlightSums, RecentSums, WindowSums};
        use crate::flight_id::test_flights::{coloured_cost_of, coloured_yaw};
        let mut recent = RecentSums::new(recent);
        let mut flight = FlightSums::<S> {
            lag_form: form,
            ..FlightSums::default()
        };
        let mut window = WindowSums::<S>::default();
        let none = [[S::ZERO; NZ]; 3];
        for (z, y) in coloured_yaw(10_000) {
            let zs: [S; NZ] =
                core::array::from_fn(|i| S::from_f32(if i == 2 { z as f32 } else { 0.0 }));
            let ys: [S; 3] =
                core::array::from_fn(|a| S::from_f32(if a == 2 { y as f32 } else { 0.0 }));
            window.push(&mut flight, &mut recent, 0, |r, out| {
                r.item_into(&zs, &ys, &none, out)
            });
        }
        recent.fold_all(&mut flight);
        coloured_cost_of(&flight)
    }

    /// The fixed kernel's fold of its exact sums into differences keeps the whitened cost of
    /// a strongly coloured noise (within 1 % of f64's: 0.03 %); planted: the same exact sums folded
    /// into levels, what the kernel kept before (random planar craft 79024 and 79109, 1 kHz
    /// and 25-26 Hz gyros: `ok` 3.6-3.8 sigma off where f32 said 1.4 and 1.0).
    #[test]
    fn folding_into_differences_keeps_the_whitened_cost_of_a_coloured_noise() {
        let truth = coloured_cost::<f64>(f64::recent(&()), LagForm::Differences);
        let mut bounds = [IntFloat::from_f32(1.0 / 1024.0); NZ + 3];
        bounds[2] = IntFloat::from_f32(4.0);
        bounds[NZ + 2] = IntFloat::from_f32(1.0);
        let none = [[IntFloat::ZERO; NZ]; 3];
        let scales = scales_for(&bounds, &none, 20_000, IntFloat::ONE).unwrap();
        let exact = IntFloat::recent(&scales);
        let differences = coloured_cost::<IntFloat>(exact, LagForm::Differences);
        assert!(
            (differences / truth - 1.0).abs() < 0.01,
            "differences: {differences} against {truth}"
        );
        // Planted: levels, 5.6 % off here (10,000 samples; the error grows with the flight).
        let levels = coloured_cost::<IntFloat>(exact, LagForm::Levels);
        assert!(
            (levels / truth - 1.0).abs() > 0.03,
            "levels: {levels} against {truth}"
        );
    }
}
