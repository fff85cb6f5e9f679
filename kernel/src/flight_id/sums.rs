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
//! Products go into recent sums that are folded into the flight's a few entries per sample,
//! so each entry is folded about every [`BLOCK`] samples (shorter f32 sums round less) and no
//! sample carries a whole fold (the M4F tick budget).

use crate::scalar::Scalar;

/// Drive components: accumulated torque (N m s), force (N s), and the rate products
/// `integral omega_i omega_j dt` (rad^2/s, order xx yy zz xy xz yz) that the gyroscopic term
/// `omega x I omega` is linear in; then two sets the model leaves out, the directions of the
/// consistency tests (`super::consistency`):
/// - the torque held over the interval that ends at the sample: a command-to-thrust delay `L`
///   moves the accumulated torque by `-L` times it;
/// - the accumulated positive part of each torque component (N m s): a thrust error that
///   scales a turn one way and not the other (one weak thruster) is a torque error along it.
pub const NZ: usize = 18;
/// Components the model uses (the rest only enter the consistency tests).
pub const N_MODEL: usize = 12;
/// First of the accumulated positive torques (after the held torque, `N_MODEL..SPLIT_TORQUE`).
pub const SPLIT_TORQUE: usize = N_MODEL + 3;
/// Lags kept: 0..LAGS-1 (an AR noise model of order up to LAGS - 1).
pub const LAGS: usize = 3;

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

impl<S: Scalar> LagMoments<S> {
    /// All zero.
    pub const fn zero() -> Self {
        LagMoments {
            zz: [[[S::ZERO; NZ]; NZ]; LAGS],
            zy: [[[S::ZERO; NZ]; 3]; LAGS],
            yz: [[[S::ZERO; NZ]; 3]; LAGS],
            yy: [[S::ZERO; 3]; LAGS],
        }
    }

    /// Adds `v_k v_(k-l)^T` for lag `l` (`now` = v_k, `then` = v_(k-l)). At lag 0 the
    /// products are symmetric: only `zz[0][i][j]` with `i <= j` and `zy[0]` are kept (read
    /// them through [`LagMoments::zz_sym`] and [`LagMoments::zy_sym`]).
    fn add_pair(&mut self, l: usize, now: &Sample<S>, then: &Sample<S>) {
        let (Some(zz), Some(zy), Some(yz), Some(yy)) = (
            self.zz.get_mut(l),
            self.zy.get_mut(l),
            self.yz.get_mut(l),
            self.yy.get_mut(l),
        ) else {
            return;
        };
        for (i, (row, zi)) in zz.iter_mut().zip(now.z.iter()).enumerate() {
            // Lag 0: the upper triangle only (from column i on).
            let from = if l == 0 { i } else { 0 };
            let (Some(dst), Some(src)) = (row.get_mut(from..), then.z.get(from..)) else {
                continue;
            };
            for (m, zj) in dst.iter_mut().zip(src) {
                *m = m.mul_add(*zi, *zj);
            }
        }
        for (a, ((zya, yza), yya)) in zy
            .iter_mut()
            .zip(yz.iter_mut())
            .zip(yy.iter_mut())
            .enumerate()
        {
            let (yn, yt) = (
                now.y.get(a).copied().unwrap_or(S::ZERO),
                then.y.get(a).copied().unwrap_or(S::ZERO),
            );
            for (m, zi) in zya.iter_mut().zip(now.z) {
                *m = m.mul_add(zi, yt);
            }
            if l > 0 {
                for (m, zj) in yza.iter_mut().zip(then.z) {
                    *m = m.mul_add(yn, zj);
                }
            }
            *yya = yya.mul_add(yn, yt);
        }
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

/// One measurement as the sums take it: drive `z` and the anchored rate `y`, rad/s.
#[derive(Clone, Copy, Debug)]
pub struct Sample<S> {
    /// Accumulated drive, seen through the sensor's response.
    pub z: [S; NZ],
    /// Measured rate minus the window's anchor and the nominal model's prediction.
    pub y: [S; 3],
}

impl<S: Scalar> Sample<S> {
    const ZERO: Self = Sample {
        z: [S::ZERO; NZ],
        y: [S::ZERO; 3],
    };
}

/// Entries of a [`LagMoments`], in the order `zz`, `zy`, `yz`, `yy`.
pub const ENTRIES: usize = LAGS * NZ * NZ + 2 * LAGS * 3 * NZ + LAGS * 3;

/// Samples over which every entry of the recent sums is folded into the flight's once: f32
/// sums then round like sums of `n / BLOCK + BLOCK` terms, not `n` (two-level summation).
pub const BLOCK: usize = 256;

/// Entries folded per sample (a rolling fold: no tick carries the whole fold).
const FOLD_PER_SAMPLE: usize = ENTRIES.div_ceil(BLOCK);

impl<S: Scalar> LagMoments<S> {
    /// Entry `k` of the flat order (`zz`, `zy`, `yz`, `yy`).
    fn entry_mut(&mut self, k: usize) -> Option<&mut S> {
        const ZZ: usize = LAGS * NZ * NZ;
        const ZY: usize = LAGS * 3 * NZ;
        let split3 = |k: usize, inner: usize, mid: usize| {
            let outer = k.checked_div(inner.checked_mul(mid)?)?;
            let rest = k.checked_rem(inner.checked_mul(mid)?)?;
            Some((outer, rest.checked_div(inner)?, rest.checked_rem(inner)?))
        };
        if k < ZZ {
            let (l, r, c) = split3(k, NZ, NZ)?;
            self.zz.get_mut(l)?.get_mut(r)?.get_mut(c)
        } else if let Some(k) = k.checked_sub(ZZ).filter(|k| *k < ZY) {
            let (l, a, c) = split3(k, NZ, 3)?;
            self.zy.get_mut(l)?.get_mut(a)?.get_mut(c)
        } else if let Some(k) = k.checked_sub(ZZ + ZY).filter(|k| *k < ZY) {
            let (l, a, c) = split3(k, NZ, 3)?;
            self.yz.get_mut(l)?.get_mut(a)?.get_mut(c)
        } else {
            let k = k.checked_sub(ZZ + 2 * ZY)?;
            self.yy
                .get_mut(k.checked_div(3)?)?
                .get_mut(k.checked_rem(3)?)
        }
    }
}

/// The flight's sums: lagged moments and the windows' initial-rate terms.
#[derive(Clone, Copy, Debug)]
pub struct FlightSums<S> {
    /// Lagged moments, folded (see [`FlightSums::fold_all`]: the fit reads them folded).
    pub lag: LagMoments<S>,
    /// Recent lagged moments, folded into `lag` a few entries per sample.
    recent: LagMoments<S>,
    cursor: usize,
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
}

impl<S: Scalar> Default for FlightSums<S> {
    fn default() -> Self {
        FlightSums {
            lag: LagMoments::zero(),
            recent: LagMoments::zero(),
            cursor: 0,
            czz: [[S::ZERO; NZ]; NZ],
            czy: [[S::ZERO; NZ]; 3],
            cyy: [S::ZERO; 3],
            samples: 0,
            windows: 0,
        }
    }
}

impl<S: Scalar> FlightSums<S> {
    /// Moves `count` entries of the recent sums, from the cursor on, into the folded ones.
    fn fold(&mut self, count: usize) {
        for _ in 0..count {
            let k = self.cursor;
            if let Some(v) = self.recent.entry_mut(k) {
                let moved = *v;
                *v = S::ZERO;
                if let Some(d) = self.lag.entry_mut(k) {
                    *d = d.plus(moved);
                }
            }
            self.cursor = k.saturating_add(1);
            if self.cursor >= ENTRIES {
                self.cursor = 0;
            }
        }
    }

    /// Folds everything (before a fit; outside the tick).
    pub fn fold_all(&mut self) {
        self.fold(ENTRIES);
    }
}

/// The open window's sums.
#[derive(Clone, Copy, Debug)]
pub struct WindowSums<S> {
    sz: [S; NZ],
    sy: [S; 3],
    n: u32,
    /// Samples seen, including those left out at the start.
    seen: u32,
    /// The last two samples used (newest first) for the lagged products.
    history: [Sample<S>; LAGS - 1],
}

impl<S: Scalar> Default for WindowSums<S> {
    fn default() -> Self {
        WindowSums {
            sz: [S::ZERO; NZ],
            sy: [S::ZERO; 3],
            n: 0,
            seen: 0,
            history: [Sample::ZERO; LAGS - 1],
        }
    }
}

impl<S: Scalar> WindowSums<S> {
    /// Samples of the window in the sums.
    pub fn len(&self) -> u32 {
        self.n
    }

    /// True if the window has no sample in the sums.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Adds one measurement to `flight`'s sums, except the window's first `skip` (the noise
    /// model's order: their whitened residual would need samples before the window).
    pub fn push(&mut self, flight: &mut FlightSums<S>, v: &Sample<S>, skip: u32) {
        self.seen = self.seen.saturating_add(1);
        if self.seen <= skip {
            return;
        }
        flight.recent.add_pair(0, v, v);
        let back = usize::try_from(self.n).unwrap_or(usize::MAX);
        for (l, then) in self.history.iter().enumerate() {
            if l < back {
                flight.recent.add_pair(l.saturating_add(1), v, then);
            }
        }
        for (s, z) in self.sz.iter_mut().zip(v.z) {
            *s = s.plus(z);
        }
        for (s, y) in self.sy.iter_mut().zip(v.y) {
            *s = s.plus(y);
        }
        self.history.rotate_right(1);
        if let Some(h) = self.history.first_mut() {
            *h = *v;
        }
        self.n = self.n.saturating_add(1);
        flight.samples = flight.samples.saturating_add(1);
        flight.fold(FOLD_PER_SAMPLE);
    }

    /// Closes the window: its initial rate's term into `flight`; empties the window.
    pub fn close_into(&mut self, flight: &mut FlightSums<S>) {
        if self.n > 0 {
            let n = S::from_int_pow2(i32::try_from(self.n).unwrap_or(i32::MAX), 0);
            let mean_z = self.sz.map(|s| s.checked_div(n).unwrap_or(S::ZERO));
            let mean_y = self.sy.map(|s| s.checked_div(n).unwrap_or(S::ZERO));
            for (row, mz) in flight.czz.iter_mut().zip(mean_z) {
                for (c, sz) in row.iter_mut().zip(self.sz) {
                    *c = c.mul_add(mz, sz);
                }
            }
            for (row, my) in flight.czy.iter_mut().zip(mean_y) {
                for (c, sz) in row.iter_mut().zip(self.sz) {
                    *c = c.mul_add(my, sz);
                }
            }
            for ((c, my), sy) in flight.cyy.iter_mut().zip(mean_y).zip(self.sy) {
                *c = c.mul_add(my, sy);
            }
            flight.windows = flight.windows.saturating_add(1);
        }
        *self = WindowSums::default();
    }
}
