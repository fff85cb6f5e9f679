//! The PWM mixer of seed sec. 3.3-3.4 / Fig. 3.2: a body-frame force/torque command for one
//! control period becomes integer-millisecond ON/OFF times per thruster.
//!
//! Every stage follows the f64 reference (`reference_f64::mixer`, whose module doc states the
//! normative integer rules) so the times are identical:
//!
//! 1. mixing matrix `M` (6 x 12): force vectors over `L x F`, `L` about the **current CoM
//!    estimate** (rebuilt onboard by [`Mixer::new`] whenever the estimate changes);
//! 2. pseudo-inverse `M* = M' (M M')^-1` (LU, pivot threshold), duties `u = M* c`;
//! 3. resolve opposing thrust (the smaller force of a pair cancels out of both);
//! 4. resolve negative values (a negative duty becomes the same force on the opposite thruster);
//! 5. exact re-solve on the chosen thruster of each pair (switching a side whose duty comes
//!    out negative, at most 7 solves; on failure the stage-4 duties stand);
//! 6. scale by the maximum when a duty exceeds 1 (direction kept);
//! 7. duty x period; 8. pulses centred;
//! 9. multiple-thruster pressure-drop correction, shortest pulse first (ties by index);
//! 10. 1 ms resolution `D = floor(d + 1/2)`, 10 ms deadband `D < m => 0`, round up near the
//!     period `D > P - m => P`, centring `on = floor((P - D)/2)`, `off = on + D`.
//!
//! Units inside: force rows in units of 2^-7 N and torque rows in units of 2^-10 N m (the
//! minimum-norm right inverse is invariant to this row scaling; it puts the entries near the
//! top of the fixed-point range, so commands are limited to |F| < 1 N and |T| < 0.125 N m,
//! beyond any SPHERES thruster's reach; larger ones give [`MixerError::BadCommand`]); times as fractions of the period until the final
//! integer rounding, which is exact ([`Scalar::floor_times`]).

use crate::craft::cross;
use crate::lu::Lu;
use crate::model::{SatelliteParams, N_THRUSTERS, OPPOSING_PAIRS};
use crate::scalar::Scalar;

/// Mixer settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixerConfig<S> {
    /// Control period, ms.
    pub period_ms: u32,
    /// Minimum pulse (deadband), ms (seed 3.4: 10).
    pub min_pulse_ms: u32,
    /// Thrust lost per extra open thruster, N (stored internally in 2^-5 N).
    pub pressure_drop_n: S,
}

impl<S: Scalar> MixerConfig<S> {
    /// A period of at least two minimum pulses (and a minimum pulse) and a finite,
    /// non-negative pressure drop: what every mixer needs.
    pub fn check(&self) -> Result<(), MixerError> {
        if self.min_pulse_ms == 0 || self.period_ms < self.min_pulse_ms.saturating_mul(2) {
            return Err(MixerError::BadPeriod);
        }
        if self.pressure_drop_n.lt(S::ZERO) || !self.pressure_drop_n.is_valid() {
            return Err(MixerError::BadThruster);
        }
        Ok(())
    }
}

/// Why a mixer could not be built or a command not mixed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MixerError {
    /// `min_pulse_ms == 0` or `period_ms < 2 * min_pulse_ms`.
    BadPeriod,
    /// A thruster's thrust is not positive or a parameter is not finite.
    BadThruster,
    /// The thrusters cannot produce every axis (`M M'` singular at the pivot threshold).
    SingularMixingMatrix,
    /// The command is not a valid number.
    BadCommand,
    /// With this many open thrusters the pressure drop exceeds a thruster's thrust.
    PressureDropExceedsThrust,
    /// A value did not fit the scalar format.
    Overflow,
    /// No non-negative firing gives the command: its direction is outside what the thrusters
    /// can push ([`crate::allocation`]).
    OutOfReach,
    /// A planar craft was commanded a force along z or a torque about x or y.
    OffPlane,
}

/// ON/OFF times of one control period, ms from the period start (`on == off == 0`: not firing).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Firing {
    /// ON time per thruster, ms.
    pub on_ms: [u32; N_THRUSTERS],
    /// OFF time per thruster, ms.
    pub off_ms: [u32; N_THRUSTERS],
}

/// The mixer: geometry-derived matrices for one CoM estimate.
#[derive(Clone, Copy, Debug)]
pub struct Mixer<S> {
    cfg: MixerConfig<S>,
    /// Scaled mixing matrix, rows Fx Fy Fz (0.1 N) Tx Ty Tz (0.01 N m), one column per thruster.
    m: [[S; N_THRUSTERS]; 6],
    /// Scaled pseudo-inverse, 12 x 6.
    pinv: [[S; 6]; N_THRUSTERS],
    thrust_n: [S; N_THRUSTERS],
}

/// Force rows in units of 2^-7 N (a thruster's ~0.11 N is ~14): entries near the top of the
/// Q8_24 range keep the most significant bits (the exact stage-5 solve runs on these).
const FORCE_UNIT_LOG2: i32 = 7;
/// Torque rows in units of 2^-10 N m (a thruster's ~0.011 N m is ~11).
const TORQUE_UNIT_LOG2: i32 = 10;
/// Thrust strengths and the pressure drop in units of 2^-5 N (only their ratios matter).
const THRUST_UNIT_LOG2: i32 = 5;
/// The pseudo-inverse is computed from `M / 2^4` so that `M M'` stays O(10).
/// Stage 5 treats a duty above `-2^-REFINE_ZERO_LOG2` as zero rather than a wrong side
/// (duties are fractions of the period: 2^-20 is 0.2 microseconds of a 200 ms period).
const REFINE_ZERO_LOG2: i32 = 20;
const PINV_SHIFT: i32 = 4;

impl<S: Scalar> Mixer<S> {
    /// Builds the mixer for `params` with lever arms about the model CoM plus
    /// `com_delta_m` (the identified CoM offset, m; zeros for the model CoM).
    pub fn new(
        params: &SatelliteParams,
        com_delta_m: [S; 3],
        cfg: MixerConfig<S>,
    ) -> Result<Self, MixerError> {
        cfg.check()?;
        let milli = S::from_f32(1e-3);
        let com: [S; 3] = core::array::from_fn(|k| {
            let nominal = params
                .com_offset_mm
                .get(k)
                .copied()
                .map(S::from_f32)
                .unwrap_or(S::ZERO);
            nominal
                .times(milli)
                .plus(com_delta_m.get(k).copied().unwrap_or(S::ZERO))
        });
        let mut m = [[S::ZERO; N_THRUSTERS]; 6];
        let mut thrust_n = [S::ZERO; N_THRUSTERS];
        for i in 0..N_THRUSTERS {
            let (Some(pos), Some(dir), Some(&t)) = (
                params.thruster_pos_m.get(i),
                params.thrust_dir.get(i),
                params.thrust_n.get(i),
            ) else {
                return Err(MixerError::BadThruster);
            };
            if !(t.is_finite() && t > 0.0 && pos.iter().chain(dir.iter()).all(|v| v.is_finite())) {
                return Err(MixerError::BadThruster);
            }
            // Scaled before any product so no product loses the low bits of a small number:
            // force in 2^-7 N (~14), lever arm in 2^-3 m (~0.8), their cross product is then the
            // torque in 2^-10 N m (~11).
            let f: [S; 3] = dir.map(|d| S::from_f32(d * t).mul_pow2(FORCE_UNIT_LOG2));
            let l: [S; 3] = core::array::from_fn(|k| {
                let p = pos.get(k).copied().map(S::from_f32).unwrap_or(S::ZERO);
                p.minus(com.get(k).copied().unwrap_or(S::ZERO))
                    .mul_pow2(TORQUE_UNIT_LOG2.saturating_sub(FORCE_UNIT_LOG2))
            });
            let torque = cross(&l, &f);
            for (k, row) in m.iter_mut().enumerate() {
                let v = if k < 3 {
                    f.get(k).copied().unwrap_or(S::ZERO)
                } else {
                    torque.get(k.saturating_sub(3)).copied().unwrap_or(S::ZERO)
                };
                if let Some(e) = row.get_mut(i) {
                    *e = v;
                }
            }
            if let Some(e) = thrust_n.get_mut(i) {
                *e = S::from_f32(t).mul_pow2(THRUST_UNIT_LOG2);
            }
        }
        // With m = M / 2^k: M M' (6 x 6) and m* = m' (m m')^-1 = 2^k M*, i.e. column j of
        // m*' solves (m m') y = m e_j; stage 2 then uses m* (c / 2^k) = M* c.
        let small = m.map(|row| row.map(|v| v.mul_pow2(-PINV_SHIFT)));
        let mut mmt = [[S::ZERO; 6]; 6];
        for (r, out_row) in mmt.iter_mut().enumerate() {
            for (c, out) in out_row.iter_mut().enumerate() {
                let (Some(a), Some(b)) = (small.get(r), small.get(c)) else {
                    continue;
                };
                *out = a
                    .iter()
                    .zip(b.iter())
                    .fold(S::ZERO, |acc, (x, y)| acc.mul_add(*x, *y));
            }
        }
        let lu = Lu::factor(&mmt, S::from_int_pow2(1, -20))
            .map_err(|_| MixerError::SingularMixingMatrix)?;
        let mut pinv = [[S::ZERO; 6]; N_THRUSTERS];
        for (i, prow) in pinv.iter_mut().enumerate() {
            let col: [S; 6] = core::array::from_fn(|r| {
                small
                    .get(r)
                    .and_then(|row| row.get(i))
                    .copied()
                    .unwrap_or(S::ZERO)
            });
            *prow = lu
                .solve(&col)
                .map_err(|_| MixerError::SingularMixingMatrix)?;
        }
        let cfg = MixerConfig {
            pressure_drop_n: cfg.pressure_drop_n.mul_pow2(THRUST_UNIT_LOG2),
            ..cfg
        };
        Ok(Mixer {
            cfg,
            m,
            pinv,
            thrust_n,
        })
    }

    /// Mixes a command: `force_n` (N) and `torque_nm` (N m about the CoM), the averages wanted
    /// over the control period.
    pub fn mix(&self, force_n: [S; 3], torque_nm: [S; 3]) -> Result<Firing, MixerError> {
        let corrected = self.pulse_fractions(force_n, torque_nm)?;
        self.quantise(&corrected)
    }

    /// Stages 2-9: the real pulse lengths as fractions of the period (before the integer rules).
    pub fn pulse_fractions(
        &self,
        force_n: [S; 3],
        torque_nm: [S; 3],
    ) -> Result<[S; N_THRUSTERS], MixerError> {
        if !force_n.iter().chain(torque_nm.iter()).all(|v| v.is_valid()) {
            return Err(MixerError::BadCommand);
        }
        let cmd: [S; 6] = core::array::from_fn(|k| {
            if k < 3 {
                force_n
                    .get(k)
                    .copied()
                    .unwrap_or(S::ZERO)
                    .mul_pow2(FORCE_UNIT_LOG2)
            } else {
                torque_nm
                    .get(k.saturating_sub(3))
                    .copied()
                    .unwrap_or(S::ZERO)
                    .mul_pow2(TORQUE_UNIT_LOG2)
            }
        });
        if !cmd.iter().all(|v| v.is_valid()) {
            return Err(MixerError::BadCommand);
        }
        // Stage 2.
        let cmd_small = cmd.map(|v| v.mul_pow2(-PINV_SHIFT));
        let duty: [S; N_THRUSTERS] = self.pinv.map(|row| {
            row.iter()
                .zip(cmd_small.iter())
                .fold(S::ZERO, |acc, (a, c)| acc.mul_add(*a, *c))
        });
        // Stages 3-4.
        let resolved = self.resolve_negative(&self.resolve_opposing(&duty)?)?;
        // Stage 5.
        let refined = self.refine(&cmd, &resolved);
        // Stage 6.
        let scaled = scale_by_maximum(&refined)?;
        // Stage 9 (on fractions of the period; stages 7-8 are the scaling by the period in
        // stage 10 and the centring).
        self.pressure_correction(&scaled)
    }

    /// Stage 10: integer ON/OFF times from the pulse fractions.
    pub fn quantise(&self, corrected: &[S; N_THRUSTERS]) -> Result<Firing, MixerError> {
        let (on_ms, off_ms) = quantise(corrected, self.cfg.period_ms, self.cfg.min_pulse_ms)?;
        Ok(Firing { on_ms, off_ms })
    }

    /// The scaled mixing matrix (rows: force in 2^-7 N, torque in 2^-10 N m).
    pub fn matrix(&self) -> &[[S; N_THRUSTERS]; 6] {
        &self.m
    }

    fn thrust(&self, i: usize) -> S {
        self.thrust_n.get(i).copied().unwrap_or(S::ONE)
    }

    /// Stage 3: both of a pair positive => the smaller force is removed from both.
    fn resolve_opposing(&self, duty: &[S; N_THRUSTERS]) -> Result<[S; N_THRUSTERS], MixerError> {
        let mut out = *duty;
        for &(a, b) in OPPOSING_PAIRS.iter() {
            let (ua, ub) = (get(&out, a), get(&out, b));
            if S::ZERO.lt(ua) && S::ZERO.lt(ub) {
                let (ta, tb) = (self.thrust(a), self.thrust(b));
                let (fa, fb) = (ua.times(ta), ub.times(tb));
                let common = if fb.lt(fa) { fb } else { fa };
                let na = ua.minus(common.checked_div(ta).ok_or(MixerError::Overflow)?);
                let nb = ub.minus(common.checked_div(tb).ok_or(MixerError::Overflow)?);
                let (na, nb) = if !nb.times(tb).lt(na.times(ta)) {
                    (S::ZERO, nb)
                } else {
                    (na, S::ZERO)
                };
                set(&mut out, a, na);
                set(&mut out, b, nb);
            }
        }
        Ok(out)
    }

    /// Stage 4: the pair's net force goes to the thruster that pushes that way.
    fn resolve_negative(&self, duty: &[S; N_THRUSTERS]) -> Result<[S; N_THRUSTERS], MixerError> {
        let mut out = *duty;
        for &(a, b) in OPPOSING_PAIRS.iter() {
            let (ta, tb) = (self.thrust(a), self.thrust(b));
            let net = get(&out, a).times(ta).minus(get(&out, b).times(tb));
            if !net.lt(S::ZERO) {
                set(
                    &mut out,
                    a,
                    net.checked_div(ta).ok_or(MixerError::Overflow)?,
                );
                set(&mut out, b, S::ZERO);
            } else {
                set(&mut out, a, S::ZERO);
                set(
                    &mut out,
                    b,
                    net.negate().checked_div(tb).ok_or(MixerError::Overflow)?,
                );
            }
        }
        Ok(out)
    }

    /// Stage 5: exact solve on the chosen side of each pair.
    fn refine(&self, cmd: &[S; 6], resolved: &[S; N_THRUSTERS]) -> [S; N_THRUSTERS] {
        let mut side: [usize; 6] = core::array::from_fn(|k| {
            let (a, b) = OPPOSING_PAIRS.get(k).copied().unwrap_or((0, 6));
            if get(resolved, a).lt(get(resolved, b)) {
                b
            } else {
                a
            }
        });
        for _ in 0..=6 {
            let mut s = [[S::ZERO; 6]; 6];
            for (r, row) in s.iter_mut().enumerate() {
                for (k, e) in row.iter_mut().enumerate() {
                    let i = side.get(k).copied().unwrap_or(0);
                    *e = self
                        .m
                        .get(r)
                        .and_then(|mr| mr.get(i))
                        .copied()
                        .unwrap_or(S::ZERO);
                }
            }
            let Some(v) = Lu::factor(&s, S::from_int_pow2(1, -20))
                .ok()
                .and_then(|lu| solve_in_range(&lu, cmd))
            else {
                return *resolved;
            };
            // A pair whose exact duty is zero comes out as a rounding-sized value of either
            // sign; below -REFINE_ZERO it is a wrong side, above it a zero (clamped). Without
            // the tolerance f32 flipped such a pair's side on every solve and fell back to the
            // stage-4 duties: 11 ms on a thruster the f64 reference leaves off (SPHERES, a
            // command beyond reach, tests/tests/kernel_mixer_any_craft.rs).
            let neg_tol = S::from_int_pow2(-1, -REFINE_ZERO_LOG2);
            if v.iter().all(|x| !x.lt(neg_tol)) {
                let mut out = [S::ZERO; N_THRUSTERS];
                for (k, &i) in side.iter().enumerate() {
                    let x = v.get(k).copied().unwrap_or(S::ZERO);
                    set(&mut out, i, if x.lt(S::ZERO) { S::ZERO } else { x });
                }
                return out;
            }
            for (k, sd) in side.iter_mut().enumerate() {
                if v.get(k).copied().unwrap_or(S::ZERO).lt(neg_tol) {
                    let (a, b) = OPPOSING_PAIRS.get(k).copied().unwrap_or((0, 6));
                    *sd = if *sd == a { b } else { a };
                }
            }
        }
        *resolved
    }

    fn pressure_correction(&self, frac: &[S; N_THRUSTERS]) -> Result<[S; N_THRUSTERS], MixerError> {
        pressure_correction(frac, &self.thrust_n, self.cfg.pressure_drop_n)
    }
}

/// Stage 10: integer ON/OFF times (ms) from pulse fractions of the period, for any number of
/// thruster slots.
pub fn quantise<S: Scalar, const N: usize>(
    corrected: &[S; N],
    period_ms: u32,
    min_pulse_ms: u32,
) -> Result<([u32; N], [u32; N]), MixerError> {
    let mut on_ms = [0; N];
    let mut off_ms = [0; N];
    for (i, d) in corrected.iter().enumerate() {
        let dur = quantise_duration(*d, period_ms, min_pulse_ms).ok_or(MixerError::Overflow)?;
        if dur > 0 {
            let on = period_ms.saturating_sub(dur) / 2;
            if let (Some(o), Some(f)) = (on_ms.get_mut(i), off_ms.get_mut(i)) {
                *o = on;
                *f = on.saturating_add(dur);
            }
        }
    }
    Ok((on_ms, off_ms))
}

/// Stage 9 on fractions of the period: pulse of rank r (ascending, ties by index) loses
/// `p (sum of shorter + (N - r) d_r)` and is stretched by that over `F_r - p (N - r)`.
/// `thrust` and `p` in one unit (only their ratios matter); then clamped to `[0, 1]`.
pub fn pressure_correction<S: Scalar, const N: usize>(
    frac: &[S; N],
    thrust: &[S; N],
    p: S,
) -> Result<[S; N], MixerError> {
    let mut out = *frac;
    let thrust_of = |i: usize| thrust.get(i).copied().unwrap_or(S::ONE);
    if S::ZERO.lt(p) {
        // Active thrusters sorted ascending (insertion sort is stable: ties keep index order).
        let mut order = [0usize; N];
        let mut n = 0usize;
        for (i, d) in frac.iter().enumerate() {
            if S::ZERO.lt(*d) {
                let mut pos = n;
                while pos > 0 {
                    let prev = order.get(pos.saturating_sub(1)).copied().unwrap_or(0);
                    if d.lt(get(frac, prev)) {
                        if let Some(slot) = order.get_mut(pos) {
                            *slot = prev;
                        }
                        pos = pos.saturating_sub(1);
                    } else {
                        break;
                    }
                }
                if let Some(slot) = order.get_mut(pos) {
                    *slot = i;
                }
                n = n.saturating_add(1);
            }
        }
        let mut shorter = S::ZERO;
        for (rank0, &i) in order.iter().take(n).enumerate() {
            let longer = n.saturating_sub(rank0).saturating_sub(1);
            let longer_s = S::from_int_pow2(longer as i32, 0);
            let all_others = S::from_int_pow2(n.saturating_sub(1) as i32, 0);
            let during = thrust_of(i).minus(p.times(longer_s));
            let peak = thrust_of(i).minus(p.times(all_others));
            if !S::ZERO.lt(peak) || !S::ZERO.lt(during) {
                return Err(MixerError::PressureDropExceedsThrust);
            }
            let d = get(frac, i);
            let loss = p.times(shorter.mul_add(longer_s, d));
            set(
                &mut out,
                i,
                d.plus(loss.checked_div(during).ok_or(MixerError::Overflow)?),
            );
            shorter = shorter.plus(d);
        }
    }
    for v in out.iter_mut() {
        if v.lt(S::ZERO) {
            *v = S::ZERO;
        } else if S::ONE.lt(*v) {
            *v = S::ONE;
        }
    }
    Ok(out)
}

/// Stage 5's solve `S v = cmd`. A command beyond reach can saturate an intermediate of the
/// substitution (an error since proofs finding 1), and falling back to the stage-4 duties
/// loses the direction (proofs finding 5): the command is then solved scaled down by 2^4 or
/// 2^8 and the result brought back up, or, if that saturates, divided by its maximum (the
/// stage-6 scaling done here: same direction, largest duty 1).
fn solve_in_range<S: Scalar>(lu: &Lu<S, 6>, cmd: &[S; 6]) -> Option<[S; 6]> {
    if let Ok(v) = lu.solve(cmd) {
        return Some(v);
    }
    for (shift, down) in [(4, -4), (8, -8)] {
        let Ok(v) = lu.solve(&cmd.map(|c| c.mul_pow2(down))) else {
            continue;
        };
        let up = v.map(|x| x.mul_pow2(shift));
        if up.iter().all(|x| x.is_valid()) {
            return Some(up);
        }
        let max = v.iter().fold(S::ZERO, |m, x| if m.lt(*x) { *x } else { m });
        if !S::ZERO.lt(max) {
            return None;
        }
        let mut out = [S::ZERO; 6];
        for (o, x) in out.iter_mut().zip(v.iter()) {
            *o = x.checked_div(max)?;
        }
        return Some(out);
    }
    None
}

/// Stage 6: if any duty exceeds 1, all are divided by the largest.
pub fn scale_by_maximum<S: Scalar, const N: usize>(duty: &[S; N]) -> Result<[S; N], MixerError> {
    let max = duty
        .iter()
        .fold(S::ZERO, |m, v| if m.lt(*v) { *v } else { m });
    if S::ONE.lt(max) {
        let mut out = [S::ZERO; N];
        for (o, d) in out.iter_mut().zip(duty.iter()) {
            *o = d.checked_div(max).ok_or(MixerError::Overflow)?;
        }
        Ok(out)
    } else {
        Ok(*duty)
    }
}

/// Stage 10 for one pulse given as a fraction of the period: `D = floor(f P + 1/2)` computed
/// exactly as `(floor(2 f P) + 1) div 2`, then the deadband and the round-up near the period.
pub fn quantise_duration<S: Scalar>(frac: S, period_ms: u32, min_pulse_ms: u32) -> Option<u32> {
    let f = if frac.lt(S::ZERO) {
        S::ZERO
    } else if S::ONE.lt(frac) {
        S::ONE
    } else {
        frac
    };
    let twice = f.floor_times(period_ms.checked_mul(2)?)?;
    let d = twice.checked_add(1)?.div_euclid(2);
    let mut d = u32::try_from(d).ok()?.min(period_ms);
    if d < min_pulse_ms {
        d = 0;
    }
    if d > period_ms.saturating_sub(min_pulse_ms) {
        d = period_ms;
    }
    Some(d)
}

fn get<S: Scalar, const N: usize>(v: &[S; N], i: usize) -> S {
    v.get(i).copied().unwrap_or(S::ZERO)
}

fn set<S: Scalar, const N: usize>(v: &mut [S; N], i: usize, x: S) {
    if let Some(e) = v.get_mut(i) {
        *e = x;
    }
}
