//! What the fit holds at the model and cannot know, in its covariance and its tests:
//! Schmidt's consider covariance, the reference's (`reference_f64::flight_id`) onboard.
//!
//! Two kinds of quantity are held at the model while their true values differ:
//! - **Terms the flight does not determine** ([`super::solve`] holds them at the nominal):
//!   each is known to no better than its scale. Held at the model, a CoM 25 mm off on an axis
//!   the flight cannot see put a random 3-D craft's inertia 9 sigma off (the reference).
//! - **Each thruster's thrust**, when the model states its uncertainty: a uniform thrust
//!   error is exactly an inertia error on rates, and one thruster's error looks like a CoM
//!   shift. Without it the kernels were `ok` 20-60 sigma off on random planar craft.
//!
//! Each such quantity `k` (variance `s_k`) has a rate signature `E_k` in the sums' drive
//! components; the fitted terms then have covariance `V0 + sum_k s_k g_k g_k^T` with
//! `g_k = V0 D^T W E_k`, and a score test's statistic allows for them in its variance.
//!
//! The kernel sees the command ([`crate::craft::Craft::command`]), not each thruster's
//! on-time: a thruster's on-time is recovered from the drive components it moves by the
//! table's pseudo-inverse, `t_i = b_i . z`: from the accumulated wrench alone where the
//! wrenches tell it from the others, else from the wrench and the open thrusters' positive
//! torques ([`RECOVERED_FROM`]), which tell the two thrusters of an opposing pair apart
//! ([`ThrustUncertainty::exact`]): either way exact whatever fires together. Both once took
//! the positive part of the summed torque, and thrusters fired together against each other
//! cancelled in it: random planar craft 78063 got a CoM sigma 0.47 of the reference's, and
//! 79105 (four thrusters the wrenches cannot tell apart) an `ok` Izz 5.6 sigma off. The
//! thrust-symmetry test reads the same components, and without them in the signature it
//! rejected 20 of 100 nominal random planar craft whose thrusts were drawn from the stated
//! uncertainty (p down to 1e-110; f32, seeds 63000-63099). What no component tells apart
//! (beyond 4 planar or 9 3-D thrusters, when they fire together against each other) is
//! missing from the signature; so is what a recording of wrench commands, not words, cannot say
//! ([`super::command_of_wrench`]).
use super::solve::{axis_forms, quad, ArNoise, SolveConfig, NP, NV};
use super::sums::{FlightSums, SPLIT_TORQUE};
use crate::craft::{Craft, MAX_THRUSTERS};
use crate::lu::Lu;
use crate::scalar::Scalar;

/// The drive components a thruster's on-time is recovered from: the accumulated wrench and
/// the open thrusters' accumulated positive torques about each axis (which tell a thruster
/// that turns the craft one way from one that turns it the other, an opposing pair's halves).
pub const RECOVERED_FROM: [usize; NR] = [
    0,
    1,
    2,
    3,
    4,
    5,
    SPLIT_TORQUE,
    SPLIT_TORQUE + 1,
    SPLIT_TORQUE + 2,
];
/// Number of [`RECOVERED_FROM`].
pub const NR: usize = 9;

/// Each thruster's thrust uncertainty as the fit sees it (in f32 whatever the kernel's
/// number format: configuration values, each reaching the format by its exact conversion at
/// the fit, and half the integer float's bytes in the state block).
#[derive(Clone, Copy, Debug)]
pub struct ThrustUncertainty {
    /// Per thruster, its wrench (torque N m, force N) times its relative thrust uncertainty:
    /// the wrench error of one sigma.
    sigma_wrench: [[f32; 6]; MAX_THRUSTERS],
    /// Per thruster, the row of the table's pseudo-inverse that recovers its on-time from
    /// the drive components [`RECOVERED_FROM`] (s per N m s and per N s).
    recover: [[f32; NR]; MAX_THRUSTERS],
    count: usize,
    exact: bool,
}

impl ThrustUncertainty {
    /// No stated uncertainty: nothing to consider.
    pub const fn none() -> Self {
        ThrustUncertainty {
            sigma_wrench: [[0.0; 6]; MAX_THRUSTERS],
            recover: [[0.0; NR]; MAX_THRUSTERS],
            count: 0,
            exact: true,
        }
    }

    /// The uncertainty of `craft`'s thrusters, each `sigma_rel[i]` of its thrust (missing or
    /// non-positive entries: known thrust). None if an entry is not finite or the table's
    /// pseudo-inverse cannot be formed (an all-zero table).
    pub fn of_craft<S: Scalar>(craft: &Craft<S>, sigma_rel: &[f32]) -> Option<Self> {
        if sigma_rel.iter().any(|s| !s.is_finite()) {
            return None;
        }
        let n = craft.count().min(MAX_THRUSTERS);
        let mut out = Self::none();
        if !sigma_rel.iter().take(n).any(|s| *s > 0.0) {
            return Some(out);
        }
        let column = columns(craft, n);
        // Each thruster's on-time from the wrench alone where the table allows, else from
        // the wrench and the open thrusters' positive torques (the wrench alone holds on
        // recordings of wrench commands too, [`super::command_of_wrench`]).
        let linear = recovery(&column, n, 6)?;
        let with_parts = recovery(&column, n, NR)?;
        out.count = n;
        for i in 0..n {
            let x = if recovers(&linear, &column, n, i) {
                linear.get(i).copied().unwrap_or([0.0; NR])
            } else {
                let x = with_parts.get(i).copied().unwrap_or([0.0; NR]);
                if !recovers(&with_parts, &column, n, i) {
                    out.exact = false;
                }
                x
            };
            let s = f64::from(sigma_rel.get(i).copied().unwrap_or(0.0).max(0.0));
            if let (Some(sw), Some(rc), Some(wi)) = (
                out.sigma_wrench.get_mut(i),
                out.recover.get_mut(i),
                column.get(i),
            ) {
                for (d, wc) in sw.iter_mut().zip(wi) {
                    *d = (s * wc) as f32;
                }
                for (r, xc) in rc.iter_mut().zip(x.iter()) {
                    *r = *xc as f32;
                }
            }
        }
        Some(out)
    }

    /// Thrusters with a stated uncertainty (0: none).
    pub fn count(&self) -> usize {
        self.count
    }

    /// Every thruster's on-time follows from the drive: from its wrench alone, or, for the
    /// thrusters the wrenches cannot tell apart (an opposing pair's halves), from the open
    /// thrusters' positive torques too: the consider covariance then covers the whole stated
    /// thrust error (on thruster words; [`super::command_of_wrench`] has the positive parts
    /// only while thrusters turning the craft opposite ways do not fire together).
    /// Not read by the kernel's rules; for a caller deciding how far to trust the sigma.
    pub fn exact(&self) -> bool {
        self.exact
    }

    /// Thruster `i`'s rate signature on axis `a` (coefficients of `(z, y)`) for the model
    /// row `row`: its one-sigma wrench error through the model, times its recovered on-time.
    fn signature<S: Scalar>(&self, i: usize, row: &[S]) -> [S; NV] {
        let mut e = [S::ZERO; NV];
        let (Some(sw), Some(rc)) = (self.sigma_wrench.get(i), self.recover.get(i)) else {
            return e;
        };
        let gain = sw
            .iter()
            .zip(row)
            .fold(S::ZERO, |acc, (w, r)| acc.mul_add(S::from_f32(*w), *r));
        for (c, r) in RECOVERED_FROM.iter().zip(rc) {
            if let Some(v) = e.get_mut(*c) {
                *v = gain.times(S::from_f32(*r));
            }
        }
        e
    }
}

/// Per thruster (the first `n` of `craft`), its column of the recovered components
/// ([`RECOVERED_FROM`]): its wrench and the positive parts of its torque.
fn columns<S: Scalar>(craft: &Craft<S>, n: usize) -> [[f64; NR]; MAX_THRUSTERS] {
    core::array::from_fn(|i| {
        let w = craft
            .thruster_wrench(i)
            .filter(|_| i < n)
            .map_or([0.0; 6], |w| w.map(|v| f64::from(v.to_f32())));
        let g = |c: usize| w.get(c).copied().unwrap_or(0.0);
        core::array::from_fn(|c| {
            if c < 6 {
                g(c)
            } else {
                g(c.saturating_sub(6)).max(0.0)
            }
        })
    })
}

/// Per thruster, the row of the pseudo-inverse of the table's first `used` recovered
/// components (the others get zero): `b_i = S (B~ B~^T + eps I)^-1 S c_i`, `B~ = S B` with
/// `S` scaling each component to the table's size (torques and forces differ by the lever
/// arm) and a Tikhonov term 1e-9 of the trace that keeps unused components (a planar
/// craft's) invertible. In f64: configuration time, not a tick. None for an all-zero table.
fn recovery(
    column: &[[f64; NR]; MAX_THRUSTERS],
    n: usize,
    used: usize,
) -> Option<[[f64; NR]; MAX_THRUSTERS]> {
    let scale: [f64; NR] = core::array::from_fn(|c| {
        let m = column
            .iter()
            .take(n)
            .fold(0.0f64, |m, w| m.max(w.get(c).copied().unwrap_or(0.0).abs()));
        if c < used && m > 0.0 {
            1.0 / m
        } else {
            0.0
        }
    });
    let scaled: [[f64; NR]; MAX_THRUSTERS] = core::array::from_fn(|i| {
        let w = column.get(i).copied().unwrap_or([0.0; NR]);
        core::array::from_fn(|c| {
            w.get(c).copied().unwrap_or(0.0) * scale.get(c).copied().unwrap_or(0.0)
        })
    });
    let mut gram = [[0.0f64; NR]; NR];
    for w in scaled.iter().take(n) {
        for (row, wr) in gram.iter_mut().zip(w) {
            for (g, wc) in row.iter_mut().zip(w) {
                *g += wr * wc;
            }
        }
    }
    let trace: f64 = gram
        .iter()
        .enumerate()
        .map(|(c, row)| row.get(c).copied().unwrap_or(0.0))
        .sum();
    if trace.is_nan() || trace <= 0.0 {
        return None;
    }
    for (c, row) in gram.iter_mut().enumerate() {
        if let Some(g) = row.get_mut(c) {
            *g += 1e-9 * trace;
        }
    }
    let lu = Lu::factor(&gram, 1e-14).ok()?;
    let mut out = [[0.0f64; NR]; MAX_THRUSTERS];
    for (o, w) in out.iter_mut().zip(&scaled).take(n) {
        let x = lu.solve(w).ok()?;
        *o = core::array::from_fn(|c| {
            x.get(c).copied().unwrap_or(0.0) * scale.get(c).copied().unwrap_or(0.0)
        });
    }
    Some(out)
}

/// Row `i` of `rows` returns thruster `i`'s on-time and none of the others' (to 1e-3 of
/// each's own): the table's columns let the recovery tell it apart.
fn recovers(
    rows: &[[f64; NR]; MAX_THRUSTERS],
    column: &[[f64; NR]; MAX_THRUSTERS],
    n: usize,
    i: usize,
) -> bool {
    let b = rows.get(i).copied().unwrap_or([0.0; NR]);
    column.iter().take(n).enumerate().all(|(j, c)| {
        let got: f64 = b.iter().zip(c).map(|(x, y)| x * y).sum();
        let want = if j == i { 1.0 } else { 0.0 };
        (got - want).abs() <= 1e-3
    })
}

/// Considered quantities at most: every term held, every thruster.
pub const MAX_CONSIDERED: usize = NP + MAX_THRUSTERS;

/// One considered quantity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Considered {
    /// A term held at the nominal although the fit was free to move it.
    HeldTerm(usize),
    /// A thruster's thrust.
    Thrust(usize),
}

/// The considered quantities of one fit and what each does to the fitted terms.
#[derive(Clone, Copy, Debug)]
pub struct Consider<S> {
    what: [Option<Considered>; MAX_CONSIDERED],
    /// Per quantity, its variance (1 for a thruster, whose signature is of one sigma).
    variance: [S; MAX_CONSIDERED],
    /// Per quantity, `g_k = V0 D^T W E_k`: the fitted terms' change per unit of it.
    gain: [[S; NP]; MAX_CONSIDERED],
}

impl<S: Scalar> Consider<S> {
    /// Nothing considered.
    pub fn none() -> Self {
        Consider {
            what: [None; MAX_CONSIDERED],
            variance: [S::ZERO; MAX_CONSIDERED],
            gain: [[S::ZERO; NP]; MAX_CONSIDERED],
        }
    }

    /// The quantities: every term in `free_by_config` the fit `held`, with variance its
    /// scale squared, then every thruster of `thrust`.
    pub fn new(
        free_by_config: &[bool; NP],
        held: &[bool; NP],
        scale: &[S; NP],
        thrust: &ThrustUncertainty,
    ) -> Self {
        let mut out = Self::none();
        let mut k = 0usize;
        let mut push = |what: Considered, variance: S| {
            if let (Some(w), Some(v)) = (out.what.get_mut(k), out.variance.get_mut(k)) {
                *w = Some(what);
                *v = variance;
                k = k.saturating_add(1);
            }
        };
        for m in 0..NP {
            if free_by_config.get(m).copied().unwrap_or(false)
                && held.get(m).copied().unwrap_or(false)
            {
                let s = scale.get(m).copied().unwrap_or(S::ZERO);
                push(Considered::HeldTerm(m), s.times(s));
            }
        }
        for i in 0..thrust.count() {
            push(Considered::Thrust(i), S::ONE);
        }
        out
    }

    /// Quantity `k`'s signature on axis `a`: from the parameter derivatives `d` at the fit and
    /// the fitted model matrix's row `row`.
    pub(crate) fn signature(
        &self,
        k: usize,
        d: &[[S; NV]; NP],
        row: &[S],
        thrust: &ThrustUncertainty,
    ) -> [S; NV] {
        match self.what.get(k).copied().flatten() {
            Some(Considered::HeldTerm(m)) => d.get(m).copied().unwrap_or([S::ZERO; NV]),
            Some(Considered::Thrust(i)) => thrust.signature(i, row),
            None => [S::ZERO; NV],
        }
    }

    /// Sets the gains from `cross[k][m] = sum_a D_m^T W_a E_k / sigma_a^2` and the fitted
    /// terms' covariance `v0`.
    pub(crate) fn set_gains(&mut self, cross: &[[S; NP]; MAX_CONSIDERED], v0: &[[S; NP]; NP]) {
        for (g, c) in self.gain.iter_mut().zip(cross) {
            *g = core::array::from_fn(|m| {
                v0.get(m).map_or(S::ZERO, |row| {
                    row.iter()
                        .zip(c)
                        .fold(S::ZERO, |acc, (v, x)| acc.mul_add(*v, *x))
                })
            });
        }
    }

    /// Considered quantities (the first `len` slots are used).
    pub fn len(&self) -> usize {
        self.what.iter().take_while(|w| w.is_some()).count()
    }

    /// True if nothing is considered.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Quantity `k`'s variance and gain.
    pub(crate) fn term(&self, k: usize) -> (S, [S; NP]) {
        (
            self.variance.get(k).copied().unwrap_or(S::ZERO),
            self.gain.get(k).copied().unwrap_or([S::ZERO; NP]),
        )
    }

    /// `v0 + sum_k s_k g_k g_k^T`.
    pub(crate) fn widen(&self, v0: &[[S; NP]; NP]) -> [[S; NP]; NP] {
        let mut v = *v0;
        for k in 0..self.len() {
            let (s, g) = self.term(k);
            for (r, row) in v.iter_mut().enumerate() {
                let gr = g.get(r).copied().unwrap_or(S::ZERO).times(s);
                for (c, e) in row.iter_mut().enumerate() {
                    *e = e.mul_add(gr, g.get(c).copied().unwrap_or(S::ZERO));
                }
            }
        }
        v
    }
}

/// The considered quantities of a fit ([`Consider::new`]) with their gains, from the sums
/// `s` at the fitted `theta`, noise models and covariance `v0` of the `free` terms.
pub(crate) fn of_fit<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &[S; NP],
    noise: &[ArNoise<S>; 3],
    held: &[bool; NP],
    v0: &[[S; NP]; NP],
    thrust: &ThrustUncertainty,
) -> Option<Consider<S>> {
    let mut consider = Consider::new(&cfg.free, held, &cfg.scale, thrust);
    let len = consider.len();
    if len == 0 {
        return Some(consider);
    }
    let mut cross = [[S::ZERO; NP]; MAX_CONSIDERED];
    for (a, (used, nz)) in cfg.axes.iter().zip(noise).enumerate() {
        if !used {
            continue;
        }
        let f = axis_forms(s, cfg, theta, nz, a)?;
        for (k, ck) in cross.iter_mut().enumerate().take(len) {
            let e = consider.signature(k, &f.d, &f.row, thrust);
            for ((c, dm), h) in ck.iter_mut().zip(&f.d).zip(held) {
                if !h {
                    *c = c.plus(f.inv_sigma2.times(quad(&f.wm, dm, &e)));
                }
            }
        }
    }
    consider.set_gains(&cross, v0);
    Some(consider)
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )]
    use super::*;
    use crate::craft::{Thruster, COMMAND_LEN};

    fn thruster(pos_m: [f32; 3], dir: [f32; 3]) -> Thruster {
        Thruster {
            pos_m,
            dir,
            thrust_n: 0.2,
        }
    }

    /// A planar craft's three thrusters: yaw both ways and a push along x; the wrenches alone
    /// tell them apart.
    fn three_planar_thrusters() -> Craft<f32> {
        Craft::<f32>::new(
            &[
                thruster([0.1, 0.1, 0.0], [1.0, 0.0, 0.0]),
                thruster([0.1, -0.1, 0.0], [0.0, 1.0, 0.0]),
                thruster([-0.1, 0.0, 0.0], [0.0, -1.0, 0.0]),
            ],
            [0.0; 3],
            0.0,
        )
        .unwrap()
    }

    /// Recovered on-time of thruster `i` from the drive of `on` seconds of each thruster,
    /// one at a time (each adds its wrench, and its torque's positive parts).
    fn recovered(t: &ThrustUncertainty, craft: &Craft<f32>, on: &[f32], i: usize) -> f32 {
        let z: [f32; NR] = core::array::from_fn(|c| {
            on.iter()
                .enumerate()
                .map(|(j, s)| {
                    let w = craft.thruster_wrench(j).unwrap();
                    s * if c < 6 {
                        w[c]
                    } else {
                        w[c.saturating_sub(6)].max(0.0)
                    }
                })
                .sum()
        });
        t.recover[i].iter().zip(&z).map(|(b, v)| b * v).sum()
    }

    /// Independent thruster wrenches: each on-time comes back from the accumulated wrench,
    /// whatever the others did; the signature is one sigma of the thruster's wrench.
    #[test]
    fn independent_thrusters_are_recovered_exactly() {
        let craft = three_planar_thrusters();
        let t = ThrustUncertainty::of_craft(&craft, &[0.05, 0.0, 0.02]).unwrap();
        assert!(t.exact());
        assert_eq!(t.count(), 3);
        let on = [0.7, 1.9, 0.3];
        for (i, want) in on.iter().enumerate() {
            let got = recovered(&t, &craft, &on, i);
            assert!((got - want).abs() < 1e-4, "thruster {i}: {got} vs {want}");
        }
        let w0 = craft.thruster_wrench(0).unwrap();
        for c in 0..6 {
            assert!((t.sigma_wrench[0][c] - 0.05 * w0[c]).abs() < 1e-7);
            assert_eq!(t.sigma_wrench[1][c], 0.0);
        }
        // An opposing pair alone is told apart by the positive torque part.
        let pair = Craft::<f32>::new(
            &[
                thruster([0.1, 0.0, 0.0], [0.0, 1.0, 0.0]),
                thruster([0.1, 0.0, 0.0], [0.0, -1.0, 0.0]),
            ],
            [0.0; 3],
            0.0,
        )
        .unwrap();
        let p = ThrustUncertainty::of_craft(&pair, &[0.05; 2]).unwrap();
        assert!(p.exact());
        assert!((recovered(&p, &pair, &[0.4, 1.5], 1) - 1.5).abs() < 1e-4);
    }

    /// Thrusters turning the craft opposite ways, fired together, on a recording of wrench
    /// commands: the drive holds the positive part of their summed torque
    /// ([`super::super::command_of_wrench`]), not the sum of theirs, so a recovery that reads
    /// the positive parts is wrong; where the wrenches alone tell the thrusters apart the
    /// recovery reads only them. Planted: the recovery from every component (before, random
    /// planar craft 78063 got a CoM sigma 0.47 of the reference's and was `ok` 4.6 sigma off).
    #[test]
    fn thrusters_fired_together_are_recovered_from_the_wrench() {
        let craft = three_planar_thrusters();
        let t = ThrustUncertainty::of_craft(&craft, &[0.05; 3]).unwrap();
        assert!(t.exact());
        // Thrusters 0 (yaw -) and 1 (yaw +) on together for 1 s: no net yaw, so no positive part.
        let on = [1.0f32, 1.0, 0.0];
        let z: [f64; NR] = core::array::from_fn(|c| {
            let sum = |k: usize| -> f64 {
                on.iter()
                    .enumerate()
                    .map(|(j, s)| f64::from(s * craft.thruster_wrench(j).unwrap()[k]))
                    .sum()
            };
            if c < 6 {
                sum(c)
            } else {
                sum(c - 6).max(0.0)
            }
        });
        let read = |rows: &[[f64; NR]], i: usize| -> f64 {
            rows[i].iter().zip(&z).map(|(b, v)| b * v).sum()
        };
        let chosen: [[f64; NR]; 3] = core::array::from_fn(|i| t.recover[i].map(f64::from));
        let every = recovery(&columns(&craft, 3), 3, NR).unwrap();
        for (i, want) in on.iter().enumerate() {
            let got = read(&chosen, i);
            assert!((got - f64::from(*want)).abs() < 1e-4, "thruster {i}: {got}");
        }
        let worst = (0..3)
            .map(|i| (read(&every, i) - f64::from(on[i])).abs())
            .fold(0.0, f64::max);
        assert!(worst > 0.05, "every component: off by {worst} only");
    }

    /// Four planar thrusters, two of them an opposing pair the wrenches cannot tell apart,
    /// fired together against each other: the open thrusters' positive torques
    /// ([`Craft::command`]) recover every on-time. Planted: the positive part of the summed
    /// torque, all a drive of wrenches has (random planar craft 79105 was `ok` 5.6 sigma off).
    #[test]
    fn an_opposing_pair_fired_together_is_recovered_from_the_command() {
        let mut four = [
            thruster([0.1, 0.1, 0.0], [1.0, 0.0, 0.0]),
            thruster([0.1, -0.1, 0.0], [0.0, 1.0, 0.0]),
            thruster([-0.1, 0.0, 0.0], [0.0, -1.0, 0.0]),
            thruster([0.1, 0.1, 0.0], [-1.0, 0.0, 0.0]),
        ];
        four[3].thrust_n = 0.3;
        let craft = Craft::<f32>::new(&four, [0.0; 3], 0.0).unwrap();
        let t = ThrustUncertainty::of_craft(&craft, &[0.05; 4]).unwrap();
        assert!(t.exact());
        // (word, seconds): the pair 0 and 3 together, with 1 and alone.
        let firings = [
            (0b1001u16, 0.6f32),
            (0b1011, 0.5),
            (0b0001, 0.2),
            (0b0100, 0.4),
        ];
        let on: [f32; 4] = core::array::from_fn(|i| {
            firings
                .iter()
                .filter(|(w, _)| w & (1 << i) != 0)
                .map(|(_, s)| s)
                .sum()
        });
        let drive = |command: &dyn Fn(u16) -> [f32; COMMAND_LEN]| -> [f32; NR] {
            core::array::from_fn(|c| firings.iter().map(|(w, s)| s * command(*w)[c]).sum())
        };
        let read = |z: &[f32; NR], i: usize| -> f32 {
            t.recover[i].iter().zip(z).map(|(b, v)| b * v).sum()
        };
        let per_thruster = drive(&|w| craft.command(w));
        for (i, want) in on.iter().enumerate() {
            let got = read(&per_thruster, i);
            assert!((got - want).abs() < 1e-4, "thruster {i}: {got} vs {want}");
        }
        let summed = drive(&|w| super::super::command_of_wrench(craft.wrench(w)));
        let worst = (0..4)
            .map(|i| (read(&summed, i) - on[i]).abs())
            .fold(0.0, f32::max);
        assert!(worst > 0.05, "summed torque: off by {worst} only");
    }

    /// Two opposing pairs along parallel lines: what one pair does, the other can, so the
    /// on-times are not recoverable and the uncertainty is not exact; none stated: nothing.
    #[test]
    fn redundant_thrusters_are_not_exact() {
        let craft = Craft::<f32>::new(
            &[
                thruster([0.1, 0.0, 0.0], [0.0, 1.0, 0.0]),
                thruster([0.1, 0.0, 0.0], [0.0, -1.0, 0.0]),
                thruster([-0.1, 0.0, 0.0], [0.0, 1.0, 0.0]),
                thruster([-0.1, 0.0, 0.0], [0.0, -1.0, 0.0]),
            ],
            [0.0; 3],
            0.0,
        )
        .unwrap();
        let t = ThrustUncertainty::of_craft(&craft, &[0.05; 4]).unwrap();
        assert!(!t.exact());
        // The two pairs' halves fired one at a time give the same drive: the recovery
        // cannot tell the pairs apart.
        let a = recovered(&t, &craft, &[1.0, 1.0, 0.0, 0.0], 0);
        let b = recovered(&t, &craft, &[0.0, 0.0, 1.0, 1.0], 0);
        assert!((a - b).abs() < 1e-4, "{a} vs {b}");
        let none = ThrustUncertainty::of_craft(&craft, &[0.0; 4]).unwrap();
        assert_eq!(none.count(), 0);
        assert!(ThrustUncertainty::of_craft(&craft, &[f32::NAN; 4]).is_none());
    }

    /// The widening adds `s g g^T` for each quantity and nothing when none is considered.
    #[test]
    fn the_covariance_grows_by_each_quantity() {
        let v0: [[f32; NP]; NP] =
            core::array::from_fn(|r| core::array::from_fn(|c| if r == c { 1.0 } else { 0.0 }));
        let mut c = Consider::new(
            &[true; NP],
            &core::array::from_fn(|m| m == 4),
            &[3.0; NP],
            &ThrustUncertainty::none(),
        );
        assert_eq!(c.len(), 1);
        assert_eq!(c.term(0).0, 9.0);
        let mut cross = [[0.0f32; NP]; MAX_CONSIDERED];
        cross[0][1] = 2.0;
        c.set_gains(&cross, &v0);
        let v = c.widen(&v0);
        assert_eq!(v[1][1], 1.0 + 9.0 * 4.0);
        assert_eq!(v[0][0], 1.0);
        assert!(Consider::<f32>::none().widen(&v0) == v0);
    }
}
