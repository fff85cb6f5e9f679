//! The rate noise's moving-average part, taken out before the sums.
//!
//! Rates differenced from attitude (motion capture) carry noise `e_k = eps_k - rho eps_(k-d)`
//! with `rho` near 1: the attitude noise differenced over one sample (`d = 1`) or, for a
//! central difference, over two (`d = 2`), plus a little white rate noise. No AR model of
//! order <= 2 whitens it; the kernel's sigmas came out 2-4 times too large on such flights,
//! and its consistency tests could not be applied.
//!
//! Passing the whole measurement (drive and rate alike) through `1 / (1 - rho B^d)` leaves
//! white noise and the same model, because the filter is linear and acts on both sides. So
//! the kernel's noise model is an MA of root `rho` at lag `d`, the root fixed before the
//! flight: the reference fits its MA coefficient, but a streaming kernel cannot re-read the
//! data.
//!
//! The filter has unit gain at zero frequency (`x~_k = x~_(k-d) + (1 - rho)(x_k - x~_(k-d))`,
//! an exponential average). So every bound on the drive and the rate holds for the filtered
//! values: the fixed kernel's envelope is unchanged. The window's initial rate stays a
//! constant once the filter's start-up transient has passed ([`MaPrefilter::settle`]).
//!
//! The root is a property of the rate sensor, measured on the ground from an earlier flight
//! (`massid estimate --kernel f32` finds it by conditional least squares over replays of the
//! flight through this kernel, and reports it as the noise's `ma`).

use super::sums::NZ;
use crate::scalar::Scalar;

/// The largest root accepted: beyond it the filter's transient spans most of a window.
pub const MAX_ROOT: f32 = 0.99;

/// The filter's state over the open window.
#[derive(Clone, Copy, Debug)]
pub struct MaPrefilter<S> {
    /// `1 - rho`.
    gain: S,
    /// False for `rho = 0`: the measurement passes unchanged (bit for bit).
    active: bool,
    /// The lag `d` ([`LAGS`]).
    lag: u8,
    /// Samples until the filter's start-up transient is below 2^-7 (see [`Self::settle`]).
    settle: u32,
    /// The rate axes filtered (those the fit reads; the others pass unchanged).
    axes: [bool; 3],
    /// The last two filtered measurements, a ring whose newest is at `newest`.
    z: [[S; NZ]; 2],
    y: [[S; 3]; 2],
    newest: usize,
}

/// The lags the filter runs at: 1 for attitude differenced over one sample, 2 over two (a
/// central difference).
pub const LAGS: core::ops::RangeInclusive<u8> = 1..=2;

impl<S: Scalar> MaPrefilter<S> {
    /// A filter for the root `rho` (0 for none) at `lag` ([`LAGS`]), of the rate `axes` the
    /// fit reads; None unless `0 <= rho <= MAX_ROOT` and the lag is 1 or 2.
    pub fn new(rho: S, lag: u8, axes: [bool; 3]) -> Option<Self> {
        if !rho.is_valid()
            || rho.lt(S::ZERO)
            || S::from_f32(MAX_ROOT).lt(rho)
            || !LAGS.contains(&lag)
        {
            return None;
        }
        let threshold = S::from_int_pow2(1, -7);
        let mut settle = 0u32;
        let mut power = S::ONE;
        while threshold.lt(power) && settle < 1024 {
            power = power.times(rho);
            settle = settle.saturating_add(1);
        }
        Some(MaPrefilter {
            gain: S::ONE.minus(rho),
            active: S::ZERO.lt(rho),
            lag,
            axes,
            settle: settle.saturating_mul(if lag == 2 { 2 } else { 1 }),
            z: [[S::ZERO; NZ]; 2],
            y: [[S::ZERO; 3]; 2],
            newest: 0,
        })
    }

    /// Samples to leave out at each window's start. The filter starts from zero, so a window's
    /// constant (its initial rate less the anchor, of the size of one sample's noise) enters
    /// as `1 - rho^(m/d+1)`, not as a constant; with a root near 1 that ramp spans hundreds
    /// of samples while the drive grows from zero. Past `settle` samples it is within 2^-7
    /// of its end; the samples left out are those where the drive is smallest. Measured:
    /// without them, random planar motion-capture craft gave RMS error/sigma 1.30-1.37
    /// instead of 0.94-1.08 (`identification_mc -- 100 67000 "motion capture" f32`).
    pub fn settle(&self) -> u32 {
        if self.active {
            self.settle
        } else {
            0
        }
    }

    /// True if the filter acts (a root other than zero).
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// A new window: the state starts from zero, as the rate relative to the window's first and the drive do.
    pub fn reset(&mut self) {
        self.z = [[S::ZERO; NZ]; 2];
        self.y = [[S::ZERO; 3]; 2];
        self.newest = 0;
    }

    /// One measurement (drive `z`, rate `y` relative to the window's first), filtered.
    pub fn apply<'a>(&'a mut self, z: &'a [S; NZ], y: &'a [S; 3]) -> (&'a [S; NZ], &'a [S; 3]) {
        if !self.active {
            return (z, y);
        }
        // The slot written is the older one: at lag 2 the filter's previous value is that
        // slot's, at lag 1 the newest's.
        let slot = 1usize.saturating_sub(self.newest);
        self.newest = slot;
        let from_newest = self.lag == 1;
        step(&mut self.z, slot, from_newest, z, self.gain, &[true; NZ]);
        step(&mut self.y, slot, from_newest, y, self.gain, &self.axes);
        match (self.z.get(slot), self.y.get(slot)) {
            (Some(zs), Some(ys)) => (zs, ys),
            _ => (z, y),
        }
    }
}

/// One filter step of each component of `x` into `ring[slot]`, from `ring[slot]` (lag 2) or
/// the other slot (lag 1: `from_newest`); components not `used` pass unfiltered.
fn step<S: Scalar, const N: usize>(
    ring: &mut [[S; N]; 2],
    slot: usize,
    from_newest: bool,
    x: &[S; N],
    gain: S,
    used: &[bool; N],
) {
    let [r0, r1] = ring;
    let (out, newest) = if slot == 0 { (r0, r1) } else { (r1, r0) };
    for (((o, n), xi), u) in out.iter_mut().zip(newest.iter()).zip(x).zip(used) {
        let prev = if from_newest { *n } else { *o };
        *o = if !u {
            *xi
        } else if xi.is_certainly_zero() && prev.is_certainly_zero() {
            // Still zero, in and out: most of a planar craft's drive (the fixed kernel's
            // products are the tick's dearest operations).
            prev
        } else {
            prev.mul_add(gain, xi.minus(prev))
        };
    }
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )]
    use super::*;
    use crate::IntFloat;

    /// Autocovariances (lags 0-2) of `(1 - rho B^d) eps` filtered by the kernel's filter of
    /// root `c` at lag `lag`, by the series itself (a long pseudo-random run).
    fn filtered_at(rho: f64, d: usize, c: f32, lag: u8) -> [f64; 3] {
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        };
        let mut filter = MaPrefilter::new(c, lag, [true; 3]).unwrap();
        let mut eps_back = [0.0f64; 2];
        let (mut back1, mut back2) = (0.0, 0.0);
        let mut sums = [0.0f64; 3];
        let n = 400_000;
        for _ in 0..n {
            let eps = uniform();
            let e = eps - rho * eps_back[d - 1];
            eps_back = [eps, eps_back[0]];
            let y = [e as f32, 0.0, 0.0];
            let (_, fy) = filter.apply(&[0.0; NZ], &y);
            let f = f64::from(fy[0]);
            sums[0] += f * f;
            sums[1] += f * back1;
            sums[2] += f * back2;
            back2 = back1;
            back1 = f;
        }
        sums.map(|v| v / f64::from(n))
    }

    #[test]
    fn the_filter_with_the_noise_root_leaves_white_noise() {
        for lag in LAGS {
            let d = usize::from(lag);
            // MA noise of root 0.88 at the lag (correlation -0.496 there), filtered with its
            // root: white.
            let g = filtered_at(0.88, d, 0.88, lag);
            assert!(
                (g[1] / g[0]).abs() < 0.01 && (g[2] / g[0]).abs() < 0.01,
                "{lag}: {g:?}"
            );
            // Planted fault: a filter of another root leaves it coloured.
            let g = filtered_at(0.88, d, 0.5, lag);
            assert!(g[d] / g[0] < -0.2, "{lag}: {g:?}");
        }
        // Central-difference noise (lag 2) through the lag-1 filter stays coloured.
        let g = filtered_at(0.88, 2, 0.88, 1);
        assert!((g[1] / g[0]).abs() > 0.2, "{g:?}");
    }

    #[test]
    fn the_integer_float_filters_as_f32_does() {
        let mut a = MaPrefilter::new(0.875f32, 1, [true; 3]).unwrap();
        let mut b = MaPrefilter::new(IntFloat::from_f32(0.875), 1, [true; 3]).unwrap();
        assert_eq!(a.settle(), b.settle());
        for k in 0..200 {
            let x = ((k * 37 % 101) as f32 - 50.0) * 1e-3;
            let za = [x; NZ];
            let ya = [x, -x, 0.5 * x];
            let (fa, ga) = a.apply(&za, &ya);
            let (fa, ga) = (*fa, *ga);
            let zb = za.map(IntFloat::from_f32);
            let yb = ya.map(IntFloat::from_f32);
            let (fb, gb) = b.apply(&zb, &yb);
            for (p, q) in fa.iter().chain(&ga).zip(fb.iter().chain(gb)) {
                assert!(
                    (p - q.to_f32()).abs() <= 1e-6 * (1.0 + p.abs()),
                    "{k}: {p} {q:?}"
                );
            }
        }
    }

    #[test]
    fn a_zero_root_passes_the_measurement_unchanged_and_others_keep_unit_gain() {
        let z = [0.25f32; NZ];
        let y = [1.0f32, -2.0, 0.5];
        let mut off = MaPrefilter::new(0.0f32, 1, [true; 3]).unwrap();
        let (fz, fy) = off.apply(&z, &y);
        assert_eq!((*fz, *fy), (z, y));
        let mut on = MaPrefilter::new(0.9f32, 1, [true; 3]).unwrap();
        // 0.9^47 = 0.0071 is the first power below 2^-7.
        assert_eq!((off.settle(), on.settle()), (0, 47));
        let mut last = ([0.0f32; NZ], [0.0f32; 3]);
        for _ in 0..400 {
            let (fz, fy) = on.apply(&z, &y);
            last = (*fz, *fy);
        }
        assert!((last.0[0] - 0.25).abs() < 1e-5 && (last.1[1] + 2.0).abs() < 1e-5);
        on.reset();
        let (fz, _) = on.apply(&z, &y);
        assert!((fz[0] - 0.025).abs() < 1e-6);
        // An axis the fit does not read passes unfiltered.
        let mut planar = MaPrefilter::new(0.9f32, 1, [false, false, true]).unwrap();
        let (_, fy) = planar.apply(&z, &y);
        assert!(fy[0] == y[0] && fy[1] == y[1] && (fy[2] - 0.05).abs() < 1e-6);
        assert!(MaPrefilter::new(-0.1f32, 1, [true; 3]).is_none());
        assert!(MaPrefilter::new(0.995f32, 1, [true; 3]).is_none());
        assert!(MaPrefilter::new(f32::NAN, 1, [true; 3]).is_none());
        assert!(MaPrefilter::new(0.5f32, 0, [true; 3]).is_none());
        assert!(MaPrefilter::new(0.5f32, 3, [true; 3]).is_none());
    }
}
