//! The identification's sufficient statistics, accumulated one sample at a time.
//!
//! Within a window (a run of consecutive valid samples) the model says
//! `y_k = omega_0 + A z_k + e_k`: `z_k` (6) is the drive accumulated since the window's first
//! sample (torque, force, rate products; [`super::FlightId`] builds it), `A`
//! (3x12) holds the mass properties and `e` is coloured noise. Every quantity a Gauss-Newton
//! fit with an AR(p <= 2) noise model needs is a quadratic form in the lagged moments
//! `sum_k v_k v_(k-l)^T`, `v = (z, y)`, `l = 0..2`, and in the windows' sums (the initial
//! rates are eliminated as `sum_w s_w s_w^T / n_w`). So the kernel keeps a few hundred sums
//! instead of the flight, and the fit ([`super::solve`]) iterates on them at any time, as often
//! as it likes: no second pass over data it cannot store.
//!
//! Floating point keeps lags 1 and 2 as differences from lag 0 ([`LagForm`]): the noise
//! model's whitening cancels the levels to a few digits.
//!
//! Products go into recent sums that are folded into the flight's a few entries per sample,
//! so each entry is folded about every [`BLOCK`] samples (shorter f32 sums round less) and no
//! sample carries a whole fold (the M4F tick budget).

use core::mem::MaybeUninit;
use core::sync::atomic::{compiler_fence, Ordering};

use super::active::Active as ActiveOf;
use super::drive::{Compensated, DriveSum};
use super::reach::{FloatReach, Reach};
use crate::in_place::{assume_all_written, field, fill, fill2, fill3};
use crate::scalar::Scalar;

pub use super::components::{NZ, N_MODEL, SPLIT_TORQUE};
/// Which drive components the flight has moved so far ([`super::active`]).
pub type Active = ActiveOf<NZ>;
// Component numbers fit the active list's bytes.
const _: () = assert!(NZ <= u8::MAX as usize);
/// Lags kept: 0..LAGS-1 (an AR noise model of order up to LAGS - 1).
pub const LAGS: usize = 3;
// The window's history ring ([`WindowSums::push`]) holds the two lagged samples and the
// slot the next item is written into.
const _: () = assert!(LAGS == 3);

/// `sum_k v_k v_(k-l)^T` by blocks, `v = (z, y)`; the `z` block is shared by the three axes.
#[derive(Clone, Copy, Debug)]
pub struct LagMoments<S> {
    /// `zz[l][i][j] = sum z_k[i] z_(k-l)[j]`.
    pub zz: [[[S; NZ]; NZ]; LAGS],
    /// `zy[l][a][i] = sum z_k[i] y_(k-l)[a]`.
    pub zy: [[[S; NZ]; 3]; LAGS],
    /// `yz[l][a][i] = sum y_k[a] z_(k-l)[i]`.
    pub yz: [[[S; NZ]; 3]; LAGS],
    /// `yy[l][a] = sum y_k[a] y_(k-l)[a]`.
    pub yy: [[S; 3]; LAGS],
}

impl<T: Copy> LagMoments<T> {
    /// Every entry `v`.
    pub const fn filled(v: T) -> Self {
        LagMoments {
            zz: [[[v; NZ]; NZ]; LAGS],
            zy: [[[v; NZ]; 3]; LAGS],
            yz: [[[v; NZ]; 3]; LAGS],
            yy: [[v; 3]; LAGS],
        }
    }

    /// [`LagMoments::filled`] written in place: every entry of `slot` set to `v` (no copy
    /// of the moments on the stack).
    pub fn fill_in_place(slot: &mut MaybeUninit<Self>, v: T) -> &mut Self {
        fill3(field!(slot, Self, zz), v);
        fill3(field!(slot, Self, zy), v);
        fill3(field!(slot, Self, yz), v);
        fill2(field!(slot, Self, yy), v);
        // SAFETY: every field was written just above.
        unsafe { assume_all_written!(slot, Self { zz, zy, yz, yy }) }
    }

    /// Adds `v_k v_(k-l)^T` for lag `l` (`now` = v_k, `then` = v_(k-l)) by `mac(entry, a, b)`,
    /// which adds `a b` to the entry. At lag 0 the products are symmetric: only `zz[0][i][j]`
    /// with `i <= j` and `zy[0]` are kept (read them through [`LagMoments::zz_sym`] and
    /// [`LagMoments::zy_sym`]).
    /// Components that are not `active` are zero in both samples (their products are zero):
    /// they are skipped, which leaves every sum bit for bit the same ([`Active`]).
    #[inline(always)]
    pub(crate) fn add_pair_by<A: Copy>(
        &mut self,
        l: usize,
        now: &Sample<A>,
        then: &Sample<A>,
        active: &Active,
        mac: impl Fn(&mut T, A, A) + Copy,
    ) {
        let (Some(zz), Some(zy), Some(yz), Some(yy)) = (
            self.zz.get_mut(l),
            self.zy.get_mut(l),
            self.yz.get_mut(l),
            self.yy.get_mut(l),
        ) else {
            return;
        };
        if active.sparse() {
            add_sparse(zz, zy, yz, l, now, then, active.components(), mac);
            for ((m, yn), yt) in yy.iter_mut().zip(now.y).zip(then.y) {
                mac(m, yn, yt);
            }
            return;
        }
        if l == 0 {
            // Lag 0: the upper triangle only (row i from column i on).
            add_upper(zz, &now.z, &then.z, mac);
        } else {
            // Two rows at a time ([`add_rows`]).
            for (rows, a) in zz.chunks_exact_mut(2).zip(now.z.chunks_exact(2)) {
                if let (Ok(rows), Ok(a)) =
                    (<&mut [[T; NZ]; 2]>::try_from(rows), <[A; 2]>::try_from(a))
                {
                    add_rows(rows, a, &then.z, mac);
                }
            }
        }
        // `zy[a][i]` takes `z_k[i] y_(k-l)[a]`: the three axes' rows, the axis' `y` the row's
        // operand (the product's operands in the same order).
        add_axes(zy, then.y, &now.z, move |m, y, z| mac(m, z, y));
        if l > 0 {
            add_axes(yz, now.y, &then.z, mac);
        }
        for ((m, yn), yt) in yy.iter_mut().zip(now.y).zip(then.y) {
            mac(m, yn, yt);
        }
    }
}

/// [`LagMoments::add_pair_by`]'s products over the active components `comps` (increasing):
/// the `z` block (lag 0: its upper triangle), then `zy` and, past lag 0, `yz`. Each entry
/// takes at most one product a sample, so the order of the entries does not matter.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn add_sparse<T, A: Copy>(
    zz: &mut [[T; NZ]; NZ],
    zy: &mut [[T; NZ]; 3],
    yz: &mut [[T; NZ]; 3],
    l: usize,
    now: &Sample<A>,
    then: &Sample<A>,
    comps: &[u8],
    mac: impl Fn(&mut T, A, A) + Copy,
) {
    for (p, i) in comps.iter().map(|c| usize::from(*c)).enumerate() {
        let (Some(row), Some(a)) = (zz.get_mut(i), now.z.get(i).copied()) else {
            continue;
        };
        // Lag 0 is symmetric: row i from column i on (the list is increasing).
        let cols = if l == 0 {
            comps.get(p..).unwrap_or(&[])
        } else {
            comps
        };
        for j in cols.iter().map(|c| usize::from(*c)) {
            if let (Some(m), Some(b)) = (row.get_mut(j), then.z.get(j).copied()) {
                mac(m, a, b);
            }
        }
    }
    for ((zy_a, yz_a), (yn, yt)) in zy
        .iter_mut()
        .zip(yz.iter_mut())
        .zip(now.y.iter().zip(&then.y))
    {
        for i in comps.iter().map(|c| usize::from(*c)) {
            if let (Some(m), Some(z)) = (zy_a.get_mut(i), now.z.get(i).copied()) {
                mac(m, z, *yt);
            }
            if l > 0 {
                if let (Some(m), Some(z)) = (yz_a.get_mut(i), then.z.get(i).copied()) {
                    mac(m, *yn, z);
                }
            }
        }
    }
}

/// `rows[r][j]` takes the product `a[r] b[j]` (by `mac(entry, a[r], b[j])`) for every row `r`
/// and column `j`: column by column, each column's `b[j]` loaded once for the rows and the
/// rows' `a` held in registers. Not inlined, so that the rows' offsets from their first entry
/// are small (on the M4F one `ldrd`, `smlal`, `strd` per product, not two loads and two stores
/// at offsets computed from the whole moments' start); the compiler fence (no instruction)
/// keeps one column's loads, products and stores together, which spared the compiler's
/// scheduling from spilling the operands (measured: a tenth fewer instructions).
#[inline(never)]
fn add_rows<T, A: Copy, const K: usize>(
    rows: &mut [[T; NZ]; K],
    a: [A; K],
    b: &[A; NZ],
    mac: impl Fn(&mut T, A, A),
) {
    match (rows.as_mut_slice(), a.as_slice()) {
        ([r0, r1], &[a0, a1]) => {
            for ((m0, m1), bj) in r0.iter_mut().zip(r1.iter_mut()).zip(b) {
                mac(m0, a0, *bj);
                mac(m1, a1, *bj);
                compiler_fence(Ordering::SeqCst);
            }
        }
        ([r0, r1, r2], &[a0, a1, a2]) => {
            for (((m0, m1), m2), bj) in r0.iter_mut().zip(r1.iter_mut()).zip(r2.iter_mut()).zip(b) {
                mac(m0, a0, *bj);
                mac(m1, a1, *bj);
                mac(m2, a2, *bj);
                compiler_fence(Ordering::SeqCst);
            }
        }
        ([r0], &[a0]) => {
            for (m0, bj) in r0.iter_mut().zip(b) {
                mac(m0, a0, *bj);
                compiler_fence(Ordering::SeqCst);
            }
        }
        (rows, a) => {
            for (row, ar) in rows.iter_mut().zip(a) {
                for (m, bj) in row.iter_mut().zip(b) {
                    mac(m, *ar, *bj);
                }
            }
        }
    }
}

/// [`add_rows`] for the three axes' rows: at once in `f32`; two, then one, for wider sums (the
/// fixed kernel's `i64`: three at a time spilled the operands on the M4F).
#[inline(always)]
fn add_axes<T, A: Copy>(
    rows: &mut [[T; NZ]; 3],
    [a0, a1, a2]: [A; 3],
    b: &[A; NZ],
    mac: impl Fn(&mut T, A, A) + Copy,
) {
    if core::mem::size_of::<T>() <= 4 {
        add_rows(rows, [a0, a1, a2], b, mac);
    } else if let Some((pair, [last])) = rows.split_first_chunk_mut::<2>() {
        add_rows(pair, [a0, a1], b, mac);
        add_rows(core::array::from_mut(last), [a2], b, mac);
    }
}

/// Lag 0's upper triangle, `zz[i][j]` for `i <= j` taking `a[i] b[j]`: by row pairs
/// ([`add_rows_from`]), each pair's first column a constant (with the first column a run-time
/// argument, the loop's prologue and remainder made the triangle 1,140 instructions a sample on
/// the M4F instead of about 630).
#[inline(always)]
fn add_upper<T, A: Copy>(
    zz: &mut [[T; NZ]; NZ],
    a: &[A; NZ],
    b: &[A; NZ],
    mac: impl Fn(&mut T, A, A) + Copy,
) {
    let mut pairs = zz.chunks_exact_mut(2).zip(a.chunks_exact(2));
    macro_rules! pairs {
        ($($from:literal)*) => {$(
            if let Some((rows, a)) = pairs.next() {
                if let (Ok(rows), Ok(a)) =
                    (<&mut [[T; NZ]; 2]>::try_from(rows), <[A; 2]>::try_from(a))
                {
                    add_rows_from::<T, A, $from>(rows, a, b, mac);
                }
            }
        )*};
    }
    pairs!(0 2 4 6 8 10 12 14 16);
}
// The pairs listed in `add_upper` (and `add_pair_by`'s row pairs cover every row).
const _: () = assert!(NZ == 18);

/// [`add_rows`] for two rows of lag 0's upper triangle: row 0 from column `FROM` on, row 1
/// from column `FROM + 1` on.
#[inline(never)]
fn add_rows_from<T, A: Copy, const FROM: usize>(
    [r0, r1]: &mut [[T; NZ]; 2],
    [a0, a1]: [A; 2],
    b: &[A; NZ],
    mac: impl Fn(&mut T, A, A),
) {
    let (Some(d0), Some(d1), Some(src)) = (r0.get_mut(FROM..), r1.get_mut(FROM..), b.get(FROM..))
    else {
        return;
    };
    let (Some((h0, d0)), Some((_, d1)), Some((hb, src))) = (
        d0.split_first_mut(),
        d1.split_first_mut(),
        src.split_first(),
    ) else {
        return;
    };
    mac(h0, a0, *hb);
    for ((m0, m1), bj) in d0.iter_mut().zip(d1.iter_mut()).zip(src) {
        mac(m0, a0, *bj);
        mac(m1, a1, *bj);
        compiler_fence(Ordering::SeqCst);
    }
}

impl<S: Scalar> LagMoments<S> {
    /// All zero.
    pub const fn zero() -> Self {
        Self::filled(S::ZERO)
    }

    /// `(L_l + L_l^T) / 2` of the `z` block, entry `(i, j)`.
    pub fn zz_sym(&self, l: usize, i: usize, j: usize) -> S {
        let at = |r: usize, c: usize| {
            self.zz
                .get(l)
                .and_then(|m| m.get(r))
                .and_then(|row| row.get(c))
                .copied()
                .unwrap_or(S::ZERO)
        };
        if l == 0 {
            at(i.min(j), i.max(j))
        } else {
            at(i, j).plus(at(j, i)).mul_pow2(-1)
        }
    }

    /// `(L_l + L_l^T) / 2` between `z[i]` and axis `a`'s `y`.
    pub fn zy_sym(&self, l: usize, a: usize, i: usize) -> S {
        let at = |m: &[[[S; NZ]; 3]; LAGS]| {
            m.get(l)
                .and_then(|x| x.get(a))
                .and_then(|row| row.get(i))
                .copied()
                .unwrap_or(S::ZERO)
        };
        if l == 0 {
            at(&self.zy)
        } else {
            at(&self.zy).plus(at(&self.yz)).mul_pow2(-1)
        }
    }

    /// True if every sum is a valid number (no saturation, no NaN).
    pub fn is_valid(&self) -> bool {
        self.zz
            .iter()
            .flatten()
            .flatten()
            .chain(self.zy.iter().flatten().flatten())
            .chain(self.yz.iter().flatten().flatten())
            .chain(self.yy.iter().flatten())
            .all(|v| v.is_valid())
    }
}

/// One measurement as the sums take it: drive `z` and the rate `y` relative to the window's first, rad/s.
#[derive(Clone, Copy, Debug)]
pub struct Sample<S> {
    /// Accumulated drive, seen through the sensor's response.
    pub z: [S; NZ],
    /// Measured rate minus the window's first and the prediction of the sums' reference model
    /// ([`FlightSums::anchor`]).
    pub y: [S; 3],
}

impl<S: Scalar> Sample<S> {
    /// Every component zero.
    pub const ZERO: Self = Sample {
        z: [S::ZERO; NZ],
        y: [S::ZERO; 3],
    };

    /// The sample relative to a reference model `d` further on (`d` the new model matrix less
    /// the old, [`super::anchor`]): `y_a - d_a . z`.
    pub fn shifted(&self, d: &[[S; NZ]; 3]) -> Self {
        let mut out = *self;
        for (y, da) in out.y.iter_mut().zip(d) {
            let pred = da
                .iter()
                .zip(&self.z)
                .fold(S::ZERO, |acc, (dj, zj)| acc.mul_add(*dj, *zj));
            *y = y.minus(pred);
        }
        out
    }

    /// `self - other`, component by component.
    pub fn minus(&self, other: &Self) -> Self {
        let mut out = *self;
        for (v, o) in out.z.iter_mut().zip(other.z) {
            *v = v.minus(o);
        }
        for (v, o) in out.y.iter_mut().zip(other.y) {
            *v = v.minus(o);
        }
        out
    }
}

/// A window's sum of samples in floating point, compensated (Kahan): its error stays a few
/// roundings of the sum whatever the window's length.
///
/// Why: closing a window subtracts `s s^T / n` from the window's moments
/// ([`super::close`]), and the difference (the scatter about the window's mean, what carries the
/// information) is far smaller than either term when the drive drifts over a long window. A
/// plain f32 running sum of 10^4 samples is off by up to `10^4` roundings, about 3e-5 of the
/// sum; the difference amplified that into estimates 3.5-5 sigma off with status `ok` (planar
/// craft, 42 s windows at 250 Hz, random-craft seeds 73009 and 73017), where the same sums in
/// f64 were within 1.3 sigma.
#[derive(Clone, Copy, Debug)]
pub struct CompensatedSum<S> {
    sum: Sample<S>,
    /// The low-order part the sum lost, negated (Kahan's `c`).
    lost: Sample<S>,
}

impl<S: Scalar> CompensatedSum<S> {
    /// The empty sum.
    pub const ZERO: Self = CompensatedSum {
        sum: Sample::ZERO,
        lost: Sample::ZERO,
    };

    fn add_one(s: &mut S, lost: &mut S, x: S) {
        let y = x.minus(*lost);
        let t = s.plus(y);
        *lost = t.minus(*s).minus(y);
        *s = t;
    }

    /// Adds `item`.
    pub fn add(&mut self, item: &Sample<S>) {
        for ((s, c), x) in self.sum.z.iter_mut().zip(&mut self.lost.z).zip(item.z) {
            Self::add_one(s, c, x);
        }
        for ((s, c), x) in self.sum.y.iter_mut().zip(&mut self.lost.y).zip(item.y) {
            Self::add_one(s, c, x);
        }
    }

    /// A sum of value `v`, nothing lost.
    pub fn of(v: Sample<S>) -> Self {
        CompensatedSum {
            sum: v,
            lost: Sample::ZERO,
        }
    }

    /// The sum, its lost part restored.
    pub fn value(&self) -> Sample<S> {
        self.sum.minus(&self.lost)
    }
}

/// Entries of a [`LagMoments`], in the order `zz`, `zy`, `yz`, `yy`.
pub const ENTRIES: usize = LAGS * NZ * NZ + 2 * LAGS * 3 * NZ + LAGS * 3;

/// Samples over which every entry of the recent sums is folded into the flight's once: f32
/// sums then round like sums of `n / BLOCK + BLOCK` terms, not `n` (two-level summation).
pub const BLOCK: usize = 256;

/// Entries of floating-point recent sums folded per sample (a rolling fold: no tick carries
/// the whole fold), so that each is folded every [`BLOCK`] samples or sooner.
pub const FOLD_PER_SAMPLE: usize = ENTRIES.div_ceil(BLOCK);

/// Samples between two folds of one entry when `per_sample` entries are folded per sample, at
/// most: each sample adds at most one product to an entry, so this bounds the products a
/// recent entry holds ([`super::exact`]).
pub const fn fold_period(per_sample: usize) -> usize {
    ENTRIES.div_ceil(if per_sample == 0 { 1 } else { per_sample })
}

/// Which two components of `v = (z, y)` entry `k` of the flat order multiplies (`z[i]` is
/// component `i`, `y[a]` is `NZ + a`), or None past the last entry.
pub fn entry_components(k: usize) -> Option<(usize, usize)> {
    match locate(k)? {
        (Block::Zz, _, r, c) => Some((r, c)),
        (Block::Zy, _, a, c) => Some((c, NZ.checked_add(a)?)),
        (Block::Yz, _, a, c) => Some((NZ.checked_add(a)?, c)),
        (Block::Yy, _, a, _) => Some((NZ.checked_add(a)?, NZ.checked_add(a)?)),
    }
}

/// The blocks of a [`LagMoments`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Block {
    Zz,
    Zy,
    Yz,
    Yy,
}

/// Entry `k` of the flat order (`zz`, `zy`, `yz`, `yy`) as (block, lag, row, column).
fn locate(k: usize) -> Option<(Block, usize, usize, usize)> {
    const ZZ: usize = LAGS * NZ * NZ;
    const ZY: usize = LAGS * 3 * NZ;
    let split3 = |k: usize, inner: usize, mid: usize| {
        let outer = k.checked_div(inner.checked_mul(mid)?)?;
        let rest = k.checked_rem(inner.checked_mul(mid)?)?;
        Some((outer, rest.checked_div(inner)?, rest.checked_rem(inner)?))
    };
    if k < ZZ {
        let (l, r, c) = split3(k, NZ, NZ)?;
        Some((Block::Zz, l, r, c))
    } else if let Some(k) = k.checked_sub(ZZ).filter(|k| *k < ZY) {
        let (l, a, c) = split3(k, NZ, 3)?;
        Some((Block::Zy, l, a, c))
    } else if let Some(k) = k.checked_sub(ZZ + ZY).filter(|k| *k < ZY) {
        let (l, a, c) = split3(k, NZ, 3)?;
        Some((Block::Yz, l, a, c))
    } else {
        let k = k.checked_sub(ZZ + 2 * ZY).filter(|k| *k < LAGS * 3)?;
        Some((Block::Yy, k.checked_div(3)?, k.checked_rem(3)?, 0))
    }
}

impl<T> LagMoments<T> {
    /// Entry `k` of the flat order (`zz`, `zy`, `yz`, `yy`).
    pub(crate) fn entry_mut(&mut self, k: usize) -> Option<&mut T> {
        let (block, l, r, c) = locate(k)?;
        self.entry_at(block, l, r, c)
    }

    /// The entry of `block` at lag `l`, row `r` (the axis of `zy`, `yz` and `yy`), column `c`.
    fn entry_at(&mut self, block: Block, l: usize, r: usize, c: usize) -> Option<&mut T> {
        match block {
            Block::Zz => self.zz.get_mut(l)?.get_mut(r)?.get_mut(c),
            Block::Zy => self.zy.get_mut(l)?.get_mut(r)?.get_mut(c),
            Block::Yz => self.yz.get_mut(l)?.get_mut(r)?.get_mut(c),
            Block::Yy => self.yy.get_mut(l)?.get_mut(r),
        }
    }
}

impl<S: Scalar> LagMoments<S> {
    /// Adds `v`, the part of flat entry `k` of level sums gathered since its last fold, to
    /// these sums kept in [`LagForm::Differences`]: a lag-0 entry to `L_0` and to every
    /// `M_l = L_0 - L_l` it is part of (both triangles of `zz`, `zy` and `yz` alike); a
    /// lag-`l` entry is taken from `M_l`. Each sum then holds what it would in levels, up to
    /// rounding, but rounds relative to its own size: a difference, not a level.
    pub fn fold_level_into_differences(&mut self, k: usize, v: S) {
        let Some((block, l, r, c)) = locate(k) else {
            return;
        };
        if l > 0 {
            if let Some(d) = self.entry_at(block, l, r, c) {
                *d = d.minus(v);
            }
            return;
        }
        let mut add = |block: Block, m: usize, r: usize, c: usize| {
            if let Some(d) = self.entry_at(block, m, r, c) {
                *d = d.plus(v);
            }
        };
        add(block, 0, r, c);
        if !(S::ZERO.lt(v) || v.lt(S::ZERO)) {
            // Nothing gathered (an inactive component, the lower triangle kept at zero).
            return;
        }
        for m in 1..LAGS {
            match block {
                Block::Zz => {
                    add(Block::Zz, m, r, c);
                    if r != c {
                        add(Block::Zz, m, c, r);
                    }
                }
                Block::Zy => {
                    add(Block::Zy, m, r, c);
                    add(Block::Yz, m, r, c);
                }
                // Not gathered at lag 0 (`zy[0]` holds it).
                Block::Yz => {}
                Block::Yy => add(Block::Yy, m, r, c),
            }
        }
    }
}

/// The lagged moments of the last few samples, before they are folded into the flight's:
/// how a number type accumulates them. Floating point adds products in its own format (to
/// short sums, [`BLOCK`]); the fixed kernel's integer float adds exact integer products
/// ([`super::exact`]), a multiply-accumulate each instead of a rounded sum.
pub trait Recent<S>: Copy + core::fmt::Debug {
    /// Entries folded into the flight's sums per sample ([`FOLD_PER_SAMPLE`] in floating
    /// point; the exact sums as few as their width allows).
    const FOLD_PER_SAMPLE: usize;
    /// What the flight's sums these fold into keep at lags 1 and 2 ([`LagForm`]).
    const LAG_FORM: LagForm;
    /// What these recent sums gather at lags 1 and 2: the fold turns levels into the flight's
    /// differences where the two differ ([`LagMoments::fold_level_into_differences`]).
    const RECENT_FORM: LagForm;
    /// The fit's pivot threshold on the information these sums give, as a power of two relative
    /// to its scaled diagonal ([`FlightSums::pivot_exp`]).
    const PIVOT_EXP: i32;
    /// A sample as these sums take it.
    type Item: Copy + core::fmt::Debug;
    /// The item of an all-zero sample.
    const ZERO_ITEM: Self::Item;
    /// A sum of items (a window's).
    type ItemSum: Copy + core::fmt::Debug;
    /// The empty sum.
    const ZERO_SUM: Self::ItemSum;
    /// The sample of drive `z` and rate `y_raw` relative to the window's first,
    /// its `y` the residual from the nominal model's prediction `nominal z` (so that the sums
    /// stay small whatever the rates), as an item; None if it cannot be represented (the
    /// flight's sums are then [`FlightSums::out_of_range`]).
    fn item(&self, z: &[S; NZ], y_raw: &[S; 3], nominal: &[[S; NZ]; 3]) -> Option<Self::Item>;
    /// [`Recent::item`] written into `out` ([`WindowSums::push`]'s slot); false if it cannot
    /// be represented.
    fn item_into(
        &self,
        z: &[S; NZ],
        y_raw: &[S; 3],
        nominal: &[[S; NZ]; 3],
        out: &mut Self::Item,
    ) -> bool {
        self.item(z, y_raw, nominal)
            .map(|item| *out = item)
            .is_some()
    }
    /// Adds `item` to `sum`.
    fn accumulate(sum: &mut Self::ItemSum, item: &Self::Item);
    /// A sum's value.
    fn sum_value(&self, sum: &Self::ItemSum) -> Sample<S>;
    /// Adds `now then^T` at lag `l` (at lag 0 the upper triangle of `zz` only; at lags 1 and 2
    /// `now (now - then)^T` in [`LagForm::Differences`]), skipping the components that are
    /// not `active` (zero in both).
    fn add_pair(&mut self, l: usize, now: &Self::Item, then: &Self::Item, active: &Active);
    /// True if `item`'s drive component `i` is other than zero or not a valid number.
    fn nonzero(item: &Self::Item, i: usize) -> bool;
    /// Whether [`Recent::shift`] moves these sums.
    const SHIFTS: bool;
    /// Moves `item` and the window sum `sum` to a reference model `d` further on (`y -= d z`,
    /// [`super::anchor`]); false, with nothing changed, where these sums are not moved (the
    /// fixed kernel's exact sums).
    fn shift(item: &mut [Self::Item], sum: &mut Self::ItemSum, d: &[[S; NZ]; 3]) -> bool;
    /// Entry `k` of the flat order, in `S`, and empties it.
    fn take(&mut self, k: usize) -> S;
}

/// A number type the identification's sums can be kept in.
pub trait SumScalar: Scalar {
    /// Its recent sums.
    type Recent: Recent<Self>;
    /// Its window's drive.
    type Drive: DriveSum<Self>;
    /// How far its window turned and walked ([`super::reach::Reach`]).
    type Reach: Reach<Self, <Self::Drive as DriveSum<Self>>::Products>;
    /// What the sums' representation needs to know of the flight: nothing in floating point;
    /// the fixed kernel's powers of two and quantized nominal matrix. Small, so that the large
    /// sums are built in place.
    type Scales: Copy + core::fmt::Debug;
    /// The scales for samples whose components (`z` then `y`) stay within `bounds` in
    /// magnitude, `y` taken from the prediction of `nominal`, in windows of at most
    /// `max_window` samples and `window_s` seconds, whose rate products reach their bound in
    /// no fewer than `products_window` of their largest steps; None if they are not usable.
    /// `rate`: the envelope's rate (rad/s); `max_step_s`: the longest step a window takes. The
    /// fixed kernel also refuses a zero or invalid rate or step (its rate products' scales,
    /// whether or not the craft has products).
    fn scales(
        bounds: &[Self; NZ + 3],
        nominal: &[[Self; NZ]; 3],
        max_window: u32,
        products_window: u32,
        window_s: Self,
        rate: Self,
        max_step_s: Self,
    ) -> Option<Self::Scales>;
    /// Writes empty recent sums to `slot` (in place: they are the state's largest part) and
    /// returns it.
    fn init_recent<'a>(
        slot: &'a mut MaybeUninit<Self::Recent>,
        scales: &Self::Scales,
    ) -> &'a mut Self::Recent;
    /// Empty recent sums, by value (a copy of [`SumScalar::init_recent`]'s).
    fn recent(scales: &Self::Scales) -> Self::Recent {
        *Self::init_recent(&mut MaybeUninit::uninit(), scales)
    }
    /// A zero drive.
    fn drive(scales: &Self::Scales) -> Self::Drive;
    /// Nothing turned or walked, against the limits `max_turn` and `max_walk` with the weights
    /// `turn_weight` and `walk_weight`, for steps up to `max_step_s`; None if the fixed kernel
    /// cannot hold them (an invalid weight, a zero or invalid longest step).
    fn reach(
        scales: &Self::Scales,
        turn_weight: [Self; 3],
        walk_weight: [Self; 3],
        max_turn: Self,
        max_walk: Self,
        max_step_s: Self,
    ) -> Option<Self::Reach>;
    /// The item of the drive snapshot `z` (the sensor's response of `drive`'s snapshots) and
    /// the rate `y_raw` relative to the window's first: [`Recent::item`] of its values in floating point; the fixed
    /// kernel rounds its exact drive once, in integers.
    /// Written into `out` (in place: no copy of the sample); false if not representable.
    fn drive_item(
        recent: &Self::Recent,
        drive: &Self::Drive,
        z: &DriveSnapshot<Self>,
        y_raw: &[Self; 3],
        nominal: &[[Self; NZ]; 3],
        out: &mut <Self::Recent as Recent<Self>>::Item,
    ) -> bool;
}

/// The drive's snapshot type of a [`SumScalar`] ([`DriveSum::Snapshot`]).
pub type DriveSnapshot<S> = <<S as SumScalar>::Drive as DriveSum<S>>::Snapshot;

impl<S: Scalar + core::fmt::Debug> Recent<S> for LagMoments<S> {
    const FOLD_PER_SAMPLE: usize = FOLD_PER_SAMPLE;
    const LAG_FORM: LagForm = LagForm::Differences;
    const RECENT_FORM: LagForm = LagForm::Differences;
    /// Rounded sums: f32's entries were measured 1e-7 - 1.6e-6 (relative) from the same sums in
    /// f64 (random planar craft 73017), so a pivot of 2^-20 (1e-6) was within f32's rounding of
    /// the information, and a nearly degenerate direction (two thrusters) passed for determined:
    /// 2^-16 sets the floor ten times above that rounding. In f64 the floor is the fit's own.
    const PIVOT_EXP: i32 = if core::mem::size_of::<S>() <= 4 {
        -16
    } else {
        DEFAULT_PIVOT_EXP
    };
    const SHIFTS: bool = true;
    type Item = Sample<S>;
    const ZERO_ITEM: Sample<S> = Sample::ZERO;
    type ItemSum = CompensatedSum<S>;
    const ZERO_SUM: CompensatedSum<S> = CompensatedSum::ZERO;
    fn item(&self, z: &[S; NZ], y_raw: &[S; 3], nominal: &[[S; NZ]; 3]) -> Option<Sample<S>> {
        let y = core::array::from_fn(|a| {
            let (Some(row), Some(y)) = (nominal.get(a), y_raw.get(a)) else {
                return S::ZERO;
            };
            let pred = row
                .iter()
                .zip(z.iter())
                .fold(S::ZERO, |acc, (r, zc)| acc.mul_add(*r, *zc));
            y.minus(pred)
        });
        Some(Sample { z: *z, y })
    }
    fn accumulate(sum: &mut CompensatedSum<S>, item: &Sample<S>) {
        sum.add(item);
    }
    fn sum_value(&self, sum: &CompensatedSum<S>) -> Sample<S> {
        sum.value()
    }
    fn add_pair(&mut self, l: usize, now: &Sample<S>, then: &Sample<S>, active: &Active) {
        let mac = |m: &mut S, a: S, b: S| *m = m.mul_add(a, b);
        if l == 0 {
            self.add_pair_by(l, now, then, active, mac);
            return;
        }
        self.add_pair_by(l, now, &now.minus(then), active, mac);
    }
    fn shift(items: &mut [Sample<S>], sum: &mut CompensatedSum<S>, d: &[[S; NZ]; 3]) -> bool {
        for item in items {
            *item = item.shifted(d);
        }
        *sum = CompensatedSum::of(sum.value().shifted(d));
        true
    }
    fn nonzero(item: &Sample<S>, i: usize) -> bool {
        item.z
            .get(i)
            .is_some_and(|v| S::ZERO.lt(*v) || v.lt(S::ZERO) || !v.is_valid())
    }
    fn take(&mut self, k: usize) -> S {
        self.entry_mut(k)
            .map_or(S::ZERO, |v| core::mem::replace(v, S::ZERO))
    }
}

/// Floating point keeps its sums in its own format: no scales, float recent sums, a
/// Kahan-compensated drive.
macro_rules! float_sums {
    ($($t:ty),*) => {$(
        impl SumScalar for $t {
            type Recent = LagMoments<$t>;
            type Drive = Compensated<$t>;
            type Reach = FloatReach<$t>;
            type Scales = ();
            fn scales(
                _: &[$t; NZ + 3],
                _: &[[$t; NZ]; 3],
                _: u32,
                _: u32,
                _: $t,
                _: $t,
                _: $t,
            ) -> Option<()> {
                Some(())
            }
            fn init_recent<'a>(
                slot: &'a mut MaybeUninit<Self::Recent>,
                _: &(),
            ) -> &'a mut Self::Recent {
                LagMoments::fill_in_place(slot, <$t as Scalar>::ZERO)
            }
            fn reach(
                _: &(),
                turn_weight: [$t; 3],
                walk_weight: [$t; 3],
                max_turn: $t,
                max_walk: $t,
                _: $t,
            ) -> Option<FloatReach<$t>> {
                Some(FloatReach::new(turn_weight, walk_weight, max_turn, max_walk))
            }
            fn drive(_: &()) -> Self::Drive {
                Compensated::default()
            }
            fn drive_item(
                recent: &Self::Recent,
                _: &Self::Drive,
                z: &[$t; NZ],
                y_raw: &[$t; 3],
                nominal: &[[$t; NZ]; 3],
                out: &mut Sample<$t>,
            ) -> bool {
                recent.item_into(z, y_raw, nominal, out)
            }
        }
    )*};
}
float_sums!(f32, f64);

/// The recent sums and where their rolling fold stands.
#[derive(Clone, Copy, Debug)]
pub struct RecentSums<R> {
    sums: R,
    cursor: usize,
    /// The drive components the flight has moved so far (the others are skipped).
    active: Active,
}

impl<R> RecentSums<R> {
    /// Empty `sums`, the fold at the first entry.
    pub fn new(sums: R) -> Self {
        RecentSums {
            sums,
            cursor: 0,
            active: Active::NONE,
        }
    }

    /// [`RecentSums::new`] in place: `sums` writes the empty sums to the slot it is given
    /// and returns it.
    pub fn init_in_place(
        slot: &mut MaybeUninit<Self>,
        sums: impl FnOnce(&mut MaybeUninit<R>) -> &mut R,
    ) -> &mut Self
    where
        R: Copy,
    {
        let written: *const R = sums(field!(slot, Self, sums));
        let at = field!(slot, Self, sums).as_mut_ptr();
        if !core::ptr::eq(written, at) {
            // `sums` returned other sums than its slot's (no implementation does): they are
            // copied in, so the slot is initialised whatever `sums` did.
            // SAFETY: `written` comes from a `&mut R` (a valid `R`, readable), `at` is the
            // slot's field (writable, aligned); `copy` allows overlap.
            unsafe { core::ptr::copy(written, at, 1) };
        }
        field!(slot, Self, cursor).write(0);
        field!(slot, Self, active).write(Active::NONE);
        // SAFETY: every field was written just above (the sums by `sums` or the copy).
        unsafe {
            assume_all_written!(
                slot,
                Self {
                    sums,
                    cursor,
                    active
                }
            )
        }
    }

    /// The drive components the flight has moved so far.
    pub fn active(&self) -> &Active {
        &self.active
    }

    /// Moves `count` entries, from the cursor on, into `flight`'s folded ones.
    fn fold<S: Scalar>(&mut self, flight: &mut FlightSums<S>, count: usize)
    where
        R: Recent<S>,
    {
        for _ in 0..count {
            let k = self.cursor;
            let moved = self.sums.take(k);
            if R::RECENT_FORM == LagForm::Levels && flight.lag_form == LagForm::Differences {
                flight.lag.fold_level_into_differences(k, moved);
            } else if let Some(d) = flight.lag.entry_mut(k) {
                *d = d.plus(moved);
            }
            self.cursor = k.saturating_add(1);
            if self.cursor >= ENTRIES {
                self.cursor = 0;
            }
        }
    }

    /// Folds everything into `flight` (before a fit; outside the tick).
    pub fn fold_all<S: Scalar>(&mut self, flight: &mut FlightSums<S>)
    where
        R: Recent<S>,
    {
        self.fold(flight, ENTRIES);
    }
}

/// What the flight's sums keep at lags `l` = 1, 2: the lagged moments `L_l = sum v_k v_(k-l)^T`
/// or their differences from lag 0, `M_l = sum v_k (v_k - v_(k-l))^T = L_0 - L_l`.
///
/// Why both: the fit weighs the lags by the AR noise model, `sum_l w_l L_l`, and for strongly
/// coloured noise (AR roots near 1: a gyro filtered well below the sampling rate) the weights
/// sum to the gain squared, ~1e-4 of the largest, so the levels cancel to four digits in the
/// smooth drive and an f32 sum of levels has nothing left (planar random craft seed 73009:
/// AR(0.66, 0.33) at 250 Hz, an estimate 5 sigma off with status `ok`). The differences are of
/// the size of what remains, `sum_l w_l L_l = (sum_l w_l) L_0 - w_1 M_1 - w_2 M_2`. The fixed
/// kernel gathers exact integer products of levels (its accumulators and their proofs are
/// sized for `|a b|`) and its fold turns them into differences
/// ([`LagMoments::fold_level_into_differences`]): its 25-bit integer float rounds like f32.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LagForm {
    /// `L_l`.
    Levels,
    /// `M_l = L_0 - L_l`.
    Differences,
}

/// The fit's pivot threshold where the sums do not round (exact integer or f64 sums), as a power
/// of two relative to the information's scaled diagonal.
pub const DEFAULT_PIVOT_EXP: i32 = -20;

/// The flight's sums: lagged moments and the windows' initial-rate terms.
#[derive(Clone, Copy, Debug)]
pub struct FlightSums<S> {
    /// Lagged moments, folded (the fit reads them after [`RecentSums::fold_all`]); at lags 1
    /// and 2 in `lag_form`.
    pub lag: LagMoments<S>,
    /// What `lag` keeps at lags 1 and 2.
    pub lag_form: LagForm,
    /// Below `2^pivot_exp` of its scaled diagonal, the fit takes a pivot of the information as
    /// zero (the direction as undetermined): the resolution of the sums' representation
    /// ([`Recent::PIVOT_EXP`]).
    pub pivot_exp: i32,
    /// `sum_w s_w s_w^T / n_w` by the same blocks (`s_w` the window's sum of `v`).
    pub czz: [[S; NZ]; NZ],
    /// See `czz`: `z` sum times axis `a`'s `y` sum.
    pub czy: [[S; NZ]; 3],
    /// See `czz`: axis `a`'s `y` sum squared.
    pub cyy: [S; 3],
    /// Samples in the sums (each measures every axis the fit uses).
    pub samples: u32,
    /// Closed windows.
    pub windows: u32,
    /// A sample could not be represented in the recent sums (the fixed kernel's: a value
    /// beyond the envelope its exact sums are scaled to): the sums do not hold the flight.
    pub out_of_range: bool,
    /// The inverse inertia and CoM offset (as in [`super::solve::Solution::theta`]) whose
    /// model's prediction the rates in the sums are relative to ([`super::anchor`]); None: the
    /// configuration's nominal (`j_nominal`, the model's CoM).
    pub anchor: Option<([S; 6], [S; 3])>,
}

impl<S: Scalar> FlightSums<S> {
    /// Empty sums written to `slot` in place (no copy of them on the stack).
    pub fn init_in_place(slot: &mut MaybeUninit<Self>) -> &mut Self {
        LagMoments::fill_in_place(field!(slot, Self, lag), S::ZERO);
        field!(slot, Self, lag_form).write(LagForm::Levels);
        field!(slot, Self, pivot_exp).write(DEFAULT_PIVOT_EXP);
        fill2(field!(slot, Self, czz), S::ZERO);
        fill2(field!(slot, Self, czy), S::ZERO);
        fill(field!(slot, Self, cyy), S::ZERO);
        field!(slot, Self, samples).write(0);
        field!(slot, Self, windows).write(0);
        field!(slot, Self, out_of_range).write(false);
        field!(slot, Self, anchor).write(None);
        // SAFETY: every field was written just above.
        unsafe {
            assume_all_written!(
                slot,
                Self {
                    lag,
                    lag_form,
                    pivot_exp,
                    czz,
                    czy,
                    cyy,
                    samples,
                    windows,
                    out_of_range,
                    anchor
                }
            )
        }
    }
}

impl<S: Scalar> Default for FlightSums<S> {
    /// Empty sums ([`FlightSums::init_in_place`]'s, copied).
    fn default() -> Self {
        *Self::init_in_place(&mut MaybeUninit::uninit())
    }
}

/// The open window's sums.
#[derive(Clone, Copy, Debug)]
pub struct WindowSums<S: SumScalar> {
    /// The sum of the window's samples.
    sum: <S::Recent as Recent<S>>::ItemSum,
    n: u32,
    /// Samples seen, including those left out at the start.
    seen: u32,
    /// The last two samples used for the lagged products and the slot the next is made in:
    /// a ring, the newest at `newest`, the one before it next (modulo [`LAGS`]), then the
    /// free slot (items are made in place: no copy of a sample per push).
    history: [<S::Recent as Recent<S>>::Item; LAGS],
    newest: usize,
}

impl<S: SumScalar> Default for WindowSums<S> {
    fn default() -> Self {
        WindowSums {
            sum: <S::Recent as Recent<S>>::ZERO_SUM,
            n: 0,
            seen: 0,
            history: [<S::Recent as Recent<S>>::ZERO_ITEM; LAGS],
            newest: 0,
        }
    }
}

impl<S: SumScalar> WindowSums<S> {
    /// Samples of the window in the sums.
    pub fn len(&self) -> u32 {
        self.n
    }

    /// True if the window has no sample in the sums.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Adds one measurement, the item `item` writes of it into its slot ([`Recent::item`],
    /// [`SumScalar::drive_item`]; false: not representable), to `flight`'s sums (its products
    /// through `recent`), except the window's first `skip` (the noise model's order: their
    /// whitened residual would need samples before the window), whose item is not made.
    pub fn push(
        &mut self,
        flight: &mut FlightSums<S>,
        recent: &mut RecentSums<S::Recent>,
        skip: u32,
        item: impl FnOnce(&S::Recent, &mut <S::Recent as Recent<S>>::Item) -> bool,
    ) {
        self.seen = self.seen.saturating_add(1);
        if self.seen <= skip {
            return;
        }
        // The ring: lag 1 at `newest`, lag 2 after it, the free slot after that.
        let at = |k: usize| k.checked_rem(LAGS).unwrap_or(0);
        let (lag1, lag2, free) = (
            self.newest,
            at(self.newest.saturating_add(1)),
            at(self.newest.saturating_add(2)),
        );
        let made = self
            .history
            .get_mut(free)
            .is_some_and(|slot| item(&recent.sums, slot));
        let (true, Some(item)) = (made, self.history.get(free)) else {
            flight.out_of_range = true;
            return;
        };
        recent
            .active
            .note(|i| <S::Recent as Recent<S>>::nonzero(item, i));
        recent.sums.add_pair(0, item, item, &recent.active);
        let back = usize::try_from(self.n).unwrap_or(usize::MAX);
        for (l, k) in [lag1, lag2].into_iter().enumerate() {
            if let (true, Some(then)) = (l < back, self.history.get(k)) {
                recent
                    .sums
                    .add_pair(l.saturating_add(1), item, then, &recent.active);
            }
        }
        S::Recent::accumulate(&mut self.sum, item);
        self.newest = free;
        self.n = self.n.saturating_add(1);
        flight.samples = flight.samples.saturating_add(1);
        recent.fold(flight, <S::Recent as Recent<S>>::FOLD_PER_SAMPLE);
    }
    /// The value of the window's sum and its sample count, for its initial-rate term
    /// ([`super::close`]; None for an empty window).
    pub fn term(&self, recent: &RecentSums<S::Recent>) -> Option<(Sample<S>, u32)> {
        (self.n > 0).then(|| (recent.sums.sum_value(&self.sum), self.n))
    }

    /// Closes the window: [`WindowSums::term`]; empties the window.
    pub fn close(&mut self, recent: &RecentSums<S::Recent>) -> Option<(Sample<S>, u32)> {
        let closed = self.term(recent);
        *self = WindowSums::default();
        closed
    }

    /// Moves the window's sum and lag history to a reference `d` further on
    /// ([`Recent::shift`]; false where the sums are not moved).
    pub fn shift(&mut self, d: &[[S; NZ]; 3]) -> bool {
        <S::Recent as Recent<S>>::shift(&mut self.history, &mut self.sum, d)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )]
    use super::*;
    use crate::IntFloat;
    use core::fmt::Write;

    /// A hash of text (FNV-1a): two values' `Debug` text compared without an allocator.
    struct Fnv(u64);
    impl Write for Fnv {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            for b in s.bytes() {
                self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
            }
            Ok(())
        }
    }
    pub(crate) fn text_hash(v: &impl core::fmt::Debug) -> u64 {
        let mut h = Fnv(0xcbf2_9ce4_8422_2325);
        write!(h, "{v:?}").unwrap();
        h.0
    }

    /// Pushes `n` samples (two windows) whose drive is zero outside `moved` until sample
    /// `late`, where component `late_c` starts to move, with the active set starting at
    /// `start`; the flight's sums after the fold, as text (every bit of every sum).
    fn sums_of<S: SumScalar + core::fmt::Debug>(
        start: Active,
        moved: &[usize],
        late: usize,
        late_c: usize,
    ) -> u64 {
        let bounds: [S; NZ + 3] = core::array::from_fn(|_| S::from_f32(4.0));
        let none = [[S::ZERO; NZ]; 3];
        let scales = S::scales(
            &bounds,
            &none,
            1000,
            1000,
            S::ONE,
            S::ONE,
            S::from_f32(1.5e-3),
        )
        .unwrap();
        let mut recent = RecentSums::new(S::recent(&scales));
        recent.active = start;
        let mut flight = FlightSums::<S>::default();
        let mut window = WindowSums::<S>::default();
        let mut pending = crate::flight_id::close::PendingCloses::<S>::default();
        let close = |w: &mut WindowSums<S>,
                     f: &mut FlightSums<S>,
                     p: &mut crate::flight_id::close::PendingCloses<S>,
                     r: &RecentSums<S::Recent>| {
            if let Some((sum, n)) = w.close(r) {
                p.close(f, sum, n, r.active());
            }
        };
        let v = |k: usize, c: usize| ((k * 7 + c * 13) % 17) as f32 / 8.0 - 1.0 + c as f32 / 64.0;
        for k in 0..90 {
            let z: [S; NZ] = core::array::from_fn(|i| {
                if moved.contains(&i) || (i == late_c && k >= late) {
                    S::from_f32(v(k, i))
                } else {
                    S::ZERO
                }
            });
            let y: [S; 3] = core::array::from_fn(|a| S::from_f32(v(k, NZ + a)));
            window.push(&mut flight, &mut recent, 0, |r, out| {
                r.item_into(&z, &y, &none, out)
            });
            if k == 50 {
                close(&mut window, &mut flight, &mut pending, &recent);
            }
            pending.drain(&mut flight, crate::flight_id::close::DRAIN_PER_SAMPLE);
        }
        close(&mut window, &mut flight, &mut pending, &recent);
        pending.drain_all(&mut flight);
        recent.fold_all(&mut flight);
        text_hash(&flight)
    }

    /// One window of a drifting yaw torque and a rate `0.2 z + e`, `e` an AR(0.66, 0.33) noise
    /// (a gyro filtered far below the sampling rate, as on random craft seed 73009): the
    /// whitened cost at the true parameter, `u^T W u`, from sums kept in `form` in `S` (each
    /// window sum and `C` in f64, so only the lag form differs).
    fn whitened_cost<S: Scalar>(form: LagForm) -> f64 {
        use crate::flight_id::test_flights::{coloured_cost_of, coloured_yaw};
        let n = 10_000usize;
        let mut flight = FlightSums::<S> {
            lag_form: form,
            ..FlightSums::default()
        };
        let mac = |m: &mut S, a: S, b: S| *m = m.mul_add(a, b);
        let mut history: [Sample<S>; 2] = [Sample::ZERO; 2];
        let mut sum = [0.0f64; NZ + 3];
        for (k, (z, y)) in coloured_yaw(n).enumerate() {
            let mut item = Sample::<S>::ZERO;
            item.z[2] = S::from_f32(z as f32);
            item.y[2] = S::from_f32(y as f32);
            flight
                .lag
                .add_pair_by(0, &item, &item, &Active::full(), mac);
            for (l, then) in [history[1], history[0]].iter().enumerate() {
                if k > l {
                    let other = match form {
                        LagForm::Levels => *then,
                        LagForm::Differences => item.minus(then),
                    };
                    flight
                        .lag
                        .add_pair_by(l + 1, &item, &other, &Active::full(), mac);
                }
            }
            history = [history[1], item];
            sum[2] += f64::from(item.z[2].to_f32());
            sum[NZ + 2] += f64::from(item.y[2].to_f32());
        }
        let c = |a: f64, b: f64| S::from_f32((a * b / n as f64) as f32);
        flight.czz[2][2] = c(sum[2], sum[2]);
        flight.czy[2][2] = c(sum[2], sum[NZ + 2]);
        flight.cyy[2] = c(sum[NZ + 2], sum[NZ + 2]);
        coloured_cost_of(&flight)
    }

    #[test]
    fn differenced_lags_keep_the_whitened_cost_of_a_coloured_noise_in_f32() {
        let truth = whitened_cost::<f64>(LagForm::Levels);
        // The forms agree where the arithmetic is exact enough.
        let f64_differences = whitened_cost::<f64>(LagForm::Differences);
        assert!(
            (f64_differences / truth - 1.0).abs() < 1e-3,
            "{f64_differences} {truth}"
        );
        let differences = whitened_cost::<f32>(LagForm::Differences);
        assert!(
            (differences / truth - 1.0).abs() < 0.05,
            "{differences} {truth}"
        );
        // Planted: the levels in f32 (what the kernel kept before) lose the cost.
        let levels = whitened_cost::<f32>(LagForm::Levels);
        assert!((levels / truth - 1.0).abs() > 0.5, "{levels} {truth}");
    }

    fn skipping_equals_the_dense_sums<S: SumScalar + core::fmt::Debug>() {
        // A planar craft's components (yaw torque, the two forces, held and positive yaw
        // torque) and one that starts to move in the second window.
        let planar = [2, 3, 4, 14, 17];
        let dense = sums_of::<S>(Active::full(), &planar, 60, 7);
        assert_eq!(sums_of::<S>(Active::NONE, &planar, 60, 7), dense);
        // The comparison sees a one-sample change of one component.
        assert_ne!(sums_of::<S>(Active::full(), &planar, 61, 7), dense);
        // Half the components, then one more in the second window: the skipping gives way to
        // the dense loops mid-flight.
        let half: [usize; 9] = core::array::from_fn(|i| 2 * i);
        let dense = sums_of::<S>(Active::full(), &half, 60, 7);
        assert_eq!(sums_of::<S>(Active::NONE, &half, 60, 7), dense);
    }

    /// Planted: a set that did not grow with the data (decided in advance) would lose the
    /// products of a component that moves.
    #[test]
    fn a_component_left_out_of_the_set_loses_its_products() {
        let mut guessed = Active::NONE;
        guessed.note(|i| [2, 3, 4].contains(&i));
        let now = Sample {
            z: core::array::from_fn(|i| if i <= 7 { 0.5 + i as f32 } else { 0.0 }),
            y: [0.25, -0.5, 1.0],
        };
        let add = |active: &Active| {
            let mut m = LagMoments::<f32>::zero();
            // The trait's `e + a b` (f32's own `mul_add` is `e a + b`).
            m.add_pair_by(1, &now, &now, active, |e, a, b| {
                *e = Scalar::mul_add(*e, a, b)
            });
            text_hash(&m)
        };
        assert_ne!(add(&guessed), add(&Active::full()));
        let mut grown = guessed;
        grown.note(|i| now.z[i] != 0.0);
        assert_eq!(add(&grown), add(&Active::full()));
    }

    /// The f32 sums' pivot floor: on a nearly degenerate planar craft (two thrusters give Izz
    /// and the CoM's two coordinates from two directions) f32 holds the term f64 holds, with
    /// f64's sigmas to 1 %. Planted, f64's floor (2^-20) in f32: it held Izz instead, with a CoM
    /// x sigma of 14 m (random planar craft 77127 with motion capture: `ok` 5.5 sigma off,
    /// where f64 holds a term).
    #[test]
    fn f32_holds_the_term_f64_holds_on_a_nearly_degenerate_craft() {
        use crate::flight_id::test_flights::{fly_planar, planar};
        use crate::flight_id::FlightId;
        fn fit<S: SumScalar>(pivot_exp: Option<i32>, seed: u64) -> ([bool; 3], [f64; 3]) {
            let mut cfg = planar::<S>(0.085);
            cfg.solve.scale = [1.0, 1.0, 100.0, 1.0, 1.0, 1.0, 0.05, 0.05, 1.0].map(S::from_f32);
            let mut id = FlightId::new(cfg).unwrap();
            if let Some(e) = pivot_exp {
                id.sums.pivot_exp = e;
            }
            let two = [
                ((0.0, 0.1), (1.0, 0.05), 1.0),
                ((0.0, -0.1), (1.0, -0.05), 1.0),
            ];
            fly_planar(&mut id, &two, 20_000, (0.0, seed), |_, _| {});
            id.finish();
            let f = id.solve().unwrap();
            let terms = [2, 6, 7];
            (
                terms.map(|m| f.held[m]),
                terms.map(|m| f64::from(f.covariance[m][m].to_f32()).sqrt()),
            )
        }
        for seed in 1..=3 {
            let (held, sd) = fit::<f64>(None, seed);
            let (held_f32, sd_f32) = fit::<f32>(None, seed);
            assert_eq!(held_f32, held, "seed {seed}");
            for (a, b) in sd_f32.iter().zip(sd) {
                assert!((a - b).abs() <= 0.01 * b, "seed {seed}: {sd_f32:?} {sd:?}");
            }
            let (planted, _) = fit::<f32>(Some(DEFAULT_PIVOT_EXP), seed);
            assert_ne!(planted, held, "seed {seed}");
        }
    }

    /// Components that have only been zero are skipped in the products and the windows' terms,
    /// and the sums are bit for bit the dense ones (f32 and the fixed kernel's exact sums).
    #[test]
    fn skipping_the_components_never_moved_leaves_every_sum_bit_for_bit() {
        skipping_equals_the_dense_sums::<f32>();
        skipping_equals_the_dense_sums::<IntFloat>();
    }
}
