//! Any thruster craft as the kernel sees it (identification and mixer): each thruster's body wrench when open
//! (torque about the model's CoM and force), up to [`MAX_THRUSTERS`] slots with a mask, so
//! that one fixed-size table serves a 4-thruster cubesat and a 16-thruster free-flyer alike
//! (a const-generic count would make every craft a different type for the C ABI).

use crate::scalar::Scalar;

/// Thruster slots of the table (the recording format's word is 16 bits).
pub const MAX_THRUSTERS: usize = 16;
/// Entries of [`Craft::command`]: the wrench (6), then the open thrusters' positive torques (3).
pub const COMMAND_LEN: usize = 9;

/// Why a craft table cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CraftError {
    /// More thrusters than [`MAX_THRUSTERS`], or none.
    ThrusterCount,
    /// A position, direction or thrust is not a finite number, or a thrust is not positive.
    NotFinite {
        /// 0-based thruster.
        thruster: usize,
    },
}

/// One thruster as a ground model states it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thruster {
    /// Position from the geometric centre, m.
    pub pos_m: [f32; 3],
    /// Force direction (unit).
    pub dir: [f32; 3],
    /// Thrust, N.
    pub thrust_n: f32,
}

/// The table: per open thruster, its wrench `(lever x F, F)` about the model's CoM.
#[derive(Clone, Copy, Debug)]
pub struct Craft<S> {
    /// Per thruster, torque (N m) then force (N) per newton of thrust, times the thrust.
    wrench: [[S; 6]; MAX_THRUSTERS],
    /// Per thruster, the unit wrench (per newton) for the pressure-drop correction.
    unit: [[S; 6]; MAX_THRUSTERS],
    count: usize,
    /// Thrust lost per extra open thruster, N.
    pressure_drop_n: S,
}

/// `a x b`, in any scalar: the one cross product of the kernel (a thruster's torque in the
/// wrench table, the mixer and the allocation), and of the envelope's interval run.
pub fn cross<S: Scalar>(a: &[S; 3], b: &[S; 3]) -> [S; 3] {
    let [a0, a1, a2] = *a;
    let [b0, b1, b2] = *b;
    [
        a1.times(b2).minus(a2.times(b1)),
        a2.times(b0).minus(a0.times(b2)),
        a0.times(b1).minus(a1.times(b0)),
    ]
}

impl<S: Scalar> Craft<S> {
    /// The table of `thrusters` (at most 16) for a model whose CoM is `com_m` from the
    /// geometric centre; `pressure_drop_n` is subtracted from every open thruster per extra
    /// open one (the seed's pressure-drop correction; 0 for the built-in models).
    pub fn new(
        thrusters: &[Thruster],
        com_m: [f32; 3],
        pressure_drop_n: f32,
    ) -> Result<Self, CraftError> {
        if thrusters.is_empty() || thrusters.len() > MAX_THRUSTERS {
            return Err(CraftError::ThrusterCount);
        }
        let mut wrench = [[S::ZERO; 6]; MAX_THRUSTERS];
        let mut unit = [[S::ZERO; 6]; MAX_THRUSTERS];
        for (i, (t, (w, u))) in thrusters
            .iter()
            .zip(wrench.iter_mut().zip(unit.iter_mut()))
            .enumerate()
        {
            let finite = t.pos_m.iter().chain(t.dir.iter()).all(|v| v.is_finite())
                && t.thrust_n.is_finite()
                && t.thrust_n > 0.0;
            if !finite {
                return Err(CraftError::NotFinite { thruster: i });
            }
            let [px, py, pz] = t.pos_m;
            let [cx, cy, cz] = com_m;
            let torque = cross(&[px - cx, py - cy, pz - cz], &t.dir);
            let per_n = [
                torque[0], torque[1], torque[2], t.dir[0], t.dir[1], t.dir[2],
            ];
            for ((wv, uv), p) in w.iter_mut().zip(u.iter_mut()).zip(per_n) {
                *uv = S::from_f32(p);
                *wv = S::from_f32(p * t.thrust_n);
            }
        }
        Ok(Craft {
            wrench,
            unit,
            count: thrusters.len(),
            pressure_drop_n: S::from_f32(if pressure_drop_n.is_finite() {
                pressure_drop_n
            } else {
                0.0
            }),
        })
    }

    /// The table from each thruster's wrench per newton (`unit`: torque about the CoM, then
    /// the force direction) and its thrust, both already in `S`. The range analysis builds it
    /// with interval thrusts and CoM (a craft's envelope, `massid_proofs::craft_envelope`);
    /// [`Craft::new`] is the model's path.
    pub fn from_unit_wrenches(
        unit: &[[S; 6]],
        thrust_n: &[S],
        pressure_drop_n: S,
    ) -> Result<Self, CraftError> {
        if unit.is_empty() || unit.len() > MAX_THRUSTERS || thrust_n.len() != unit.len() {
            return Err(CraftError::ThrusterCount);
        }
        let mut table = Craft {
            wrench: [[S::ZERO; 6]; MAX_THRUSTERS],
            unit: [[S::ZERO; 6]; MAX_THRUSTERS],
            count: unit.len(),
            pressure_drop_n,
        };
        for ((u, t), (w_dst, u_dst)) in unit
            .iter()
            .zip(thrust_n)
            .zip(table.wrench.iter_mut().zip(table.unit.iter_mut()))
        {
            *u_dst = *u;
            *w_dst = u.map(|v| v.times(*t));
        }
        Ok(table)
    }

    /// Number of thrusters.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Thruster `i`'s wrench when open alone (torque N m, force N); None past the count.
    pub fn thruster_wrench(&self, i: usize) -> Option<[S; 6]> {
        self.wrench.get(i).copied().filter(|_| i < self.count)
    }

    /// Bits of the word that name a thruster.
    pub fn word_mask(&self) -> u16 {
        u16::try_from((1u32 << self.count.min(MAX_THRUSTERS)).saturating_sub(1)).unwrap_or(u16::MAX)
    }

    /// Per wrench component, a bound on its magnitude for any word: each thruster's own
    /// wrench plus the most the pressure drop can take from it (every other thruster open).
    pub fn wrench_bound(&self) -> [S; 6] {
        let others = S::from_int_pow2(
            i32::try_from(self.count.saturating_sub(1)).unwrap_or(i32::MAX),
            0,
        );
        let drop = self.pressure_drop_n.abs().times(others);
        let mut out = [S::ZERO; 6];
        for (w, u) in self.wrench.iter().zip(self.unit.iter()).take(self.count) {
            for ((o, wv), uv) in out.iter_mut().zip(w).zip(u) {
                *o = o.plus(wv.abs()).plus(drop.times(uv.abs()));
            }
        }
        out
    }

    /// The body wrench (torque N m, force N) while `word` is open; bits beyond the craft's
    /// thrusters are ignored (the host checks words against the model before flying).
    pub fn wrench(&self, word: u16) -> [S; 6] {
        let mut out = [S::ZERO; 6];
        self.each_open(word, |w, u, drop| {
            for ((o, wv), uv) in out.iter_mut().zip(w).zip(u) {
                *o = o.plus(*wv).minus(drop.times(*uv));
            }
        });
        out
    }

    /// What the identification ([`crate::flight_id::FlightId::push`]) is told while `word`
    /// is open: the body wrench, then per torque axis the sum of the open thrusters' positive
    /// torques about it. The summed torque's positive part cannot tell two thrusters turning
    /// the craft opposite ways and fired together from neither firing; these sums can, and a
    /// thruster's thrust error is along them (the thrust-uncertainty recovery,
    /// [`crate::flight_id::consider`], and the thrust-symmetry test).
    pub fn command(&self, word: u16) -> [S; COMMAND_LEN] {
        let mut out = [S::ZERO; COMMAND_LEN];
        self.command_into(word, &mut out);
        out
    }

    /// [`Craft::command`] written into `out` (every entry), in place: the tick's
    /// [`crate::flight_id::FlightId::push_with`] has it written straight into its delay line.
    pub fn command_into(&self, word: u16, out: &mut [S; COMMAND_LEN]) {
        out.fill(S::ZERO);
        self.each_open(word, |w, u, drop| {
            let (wrench, positive) = out.split_at_mut(6);
            // The pressure drop's share of each component, made once for the wrench and the
            // positive torques; none where the drop is an exact zero times a valid number
            // (one thruster open, or no drop modelled): subtracting that zero changes no bit,
            // so it is skipped (a 16-thruster word costs the integer float a third less).
            let zero_drop = drop.is_valid() && !(drop.lt(S::ZERO) || S::ZERO.lt(drop));
            let share: [Option<S>; 6] = core::array::from_fn(|c| {
                let uv = u.get(c).copied().unwrap_or(S::ZERO);
                (!zero_drop || !uv.is_valid()).then(|| drop.times(uv))
            });
            let less = |v: S, t: Option<S>| t.map_or(v, |t| v.minus(t));
            for ((o, wv), t) in wrench.iter_mut().zip(w).zip(share) {
                *o = less(o.plus(*wv), t);
            }
            for ((o, wv), t) in positive.iter_mut().zip(w).zip(share) {
                // Summed as the wrench is: the same value where no open thruster turns
                // the craft the other way.
                if S::ZERO.lt(less(*wv, t)) {
                    *o = less(o.plus(*wv), t);
                }
            }
        });
    }

    /// Calls `each` with the wrench and unit wrench of every thruster open in `word` and the
    /// pressure drop the others open take from its thrust; bits beyond the craft's thrusters
    /// are ignored.
    fn each_open(&self, word: u16, mut each: impl FnMut(&[S; 6], &[S; 6], S)) {
        let word = word & self.word_mask();
        let extra = word.count_ones().saturating_sub(1);
        let drop = self
            .pressure_drop_n
            .times(S::from_int_pow2(i32::try_from(extra).unwrap_or(0), 0));
        for (i, (w, u)) in self.wrench.iter().zip(self.unit.iter()).enumerate() {
            if word & (1u16 << i.min(15)) == 0 || i >= self.count {
                continue;
            }
            each(w, u, drop);
        }
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
    use crate::flight_id::sums::tests::text_hash;
    use crate::flight_id::test_flights::five_thrusters_with_drop;
    use crate::IntFloat;

    /// The command with every operation spelled out, as first written: the oracle of
    /// [`Craft::command_into`]'s shared and skipped pressure-drop shares.
    fn spelled_out<S: Scalar>(craft: &Craft<S>, word: u16) -> [S; COMMAND_LEN] {
        let mut out = [S::ZERO; COMMAND_LEN];
        craft.each_open(word, |w, u, drop| {
            for c in 0..6 {
                out[c] = out[c].plus(w[c]).minus(drop.times(u[c]));
            }
            for b in 0..3 {
                if S::ZERO.lt(w[b].minus(drop.times(u[b]))) {
                    out[6 + b] = out[6 + b].plus(w[b]).minus(drop.times(u[b]));
                }
            }
        });
        out
    }

    /// Bit for bit the spelled-out command for every word of five thrusters, with a pressure
    /// drop, without one, with a drop that is not a number, and with a unit wrench that is not
    /// finite and no drop (whose products with the zero drop are not zero), in f32 and the
    /// integer float. Planted (checked by hand, 2026-11-30): skipping the share whenever the
    /// drop compares equal to zero fails on the last two.
    fn the_command_is_the_spelled_out_one<S: Scalar + core::fmt::Debug>() {
        let mut crafts = [
            five_thrusters_with_drop::<S>(0.01),
            five_thrusters_with_drop::<S>(0.0),
            five_thrusters_with_drop::<S>(0.0),
            five_thrusters_with_drop::<S>(0.0),
        ];
        crafts[2].pressure_drop_n = S::from_f32(f32::NAN);
        crafts[3].unit[1][0] = S::from_f32(f32::INFINITY);
        for (i, craft) in crafts.iter().enumerate() {
            for word in 0..32u16 {
                assert_eq!(
                    text_hash(&craft.command(word)),
                    text_hash(&spelled_out(craft, word)),
                    "craft {i}, word {word:#b}: {:?} vs {:?}",
                    craft.command(word),
                    spelled_out(craft, word)
                );
            }
        }
    }

    #[test]
    fn the_command_is_the_spelled_out_one_f32_and_fixed() {
        the_command_is_the_spelled_out_one::<f32>();
        the_command_is_the_spelled_out_one::<IntFloat>();
    }
}
