//! The mixer a craft gets: the seed's opposing-pair rules ([`crate::mixer`]) for a 3-D craft
//! whose 12 thrusters come in SPHERES' opposing pairs (SPHERES' times stay bit for bit),
//! the non-negative allocation ([`crate::allocation`]) for every other craft. One entry
//! point, one firing type of 16 slots, so flight code and the C ABI need not know which.

use crate::allocation::{AllocationMixer, CraftFiring};
use crate::craft::{Thruster, MAX_THRUSTERS};
use crate::mixer::{Mixer, MixerConfig, MixerError};
use crate::model::{N_THRUSTERS, OPPOSING_PAIRS};
use crate::scalar::Scalar;

/// Directions of a pair count as opposite when their cosine is below this (8 degrees).
const OPPOSITE_COS: f32 = -0.99;

/// A craft's mixer.
#[derive(Clone, Copy, Debug)]
pub enum CraftMixer<S> {
    /// The seed's rules (stages 3-5 need opposing pairs).
    OpposingPairs(Mixer<S>),
    /// Smallest non-negative duties.
    Allocation(AllocationMixer<S>),
}

/// Whether `thrusters` are SPHERES' layout for the seed's pair rules: 3-D, 12 thrusters, each
/// of [`OPPOSING_PAIRS`] pushing in opposite directions.
pub fn has_opposing_pairs(thrusters: &[Thruster], planar: bool) -> bool {
    !planar
        && thrusters.len() == N_THRUSTERS
        && OPPOSING_PAIRS.iter().all(|&(a, b)| {
            let (Some(ta), Some(tb)) = (thrusters.get(a), thrusters.get(b)) else {
                return false;
            };
            let dot: f32 = ta.dir.iter().zip(tb.dir.iter()).map(|(x, y)| x * y).sum();
            let na: f32 = ta.dir.iter().map(|x| x * x).sum();
            let nb: f32 = tb.dir.iter().map(|x| x * x).sum();
            dot < 0.0 && dot * dot > OPPOSITE_COS * OPPOSITE_COS * na * nb
        })
}

impl<S: Scalar> CraftMixer<S> {
    /// The mixer of `thrusters` (1 to 16) about the CoM `com_m` (m from the geometric centre:
    /// the model's, or the identified estimate); `planar` for an air-bearing craft.
    pub fn new(
        thrusters: &[Thruster],
        com_m: [S; 3],
        planar: bool,
        cfg: MixerConfig<S>,
    ) -> Result<Self, MixerError> {
        if thrusters.is_empty() || thrusters.len() > MAX_THRUSTERS {
            return Err(MixerError::BadThruster);
        }
        if has_opposing_pairs(thrusters, planar) {
            let mut params = crate::model::SPH2;
            params.com_offset_mm = [0.0; 3];
            params.pressure_drop_n_per_extra = 0.0;
            for (i, t) in thrusters.iter().enumerate() {
                if let (Some(p), Some(d), Some(f)) = (
                    params.thruster_pos_m.get_mut(i),
                    params.thrust_dir.get_mut(i),
                    params.thrust_n.get_mut(i),
                ) {
                    *p = t.pos_m;
                    *d = t.dir;
                    *f = t.thrust_n;
                }
            }
            // The pair mixer reads only the thruster tables and the CoM (here all in `com_m`).
            Ok(CraftMixer::OpposingPairs(Mixer::new(&params, com_m, cfg)?))
        } else {
            Ok(CraftMixer::Allocation(AllocationMixer::new(
                thrusters, com_m, planar, cfg,
            )?))
        }
    }

    /// Stages 2-9: pulse lengths as fractions of the period, per slot.
    pub fn pulse_fractions(
        &self,
        force_n: [S; 3],
        torque_nm: [S; 3],
    ) -> Result<[S; MAX_THRUSTERS], MixerError> {
        match self {
            CraftMixer::OpposingPairs(m) => {
                let f = m.pulse_fractions(force_n, torque_nm)?;
                let mut out = [S::ZERO; MAX_THRUSTERS];
                for (o, v) in out.iter_mut().zip(f.iter()) {
                    *o = *v;
                }
                Ok(out)
            }
            CraftMixer::Allocation(m) => m.pulse_fractions(force_n, torque_nm),
        }
    }

    /// Mixes a command: `force_n` (N) and `torque_nm` (N m about the CoM), the averages
    /// wanted over the control period.
    pub fn mix(&self, force_n: [S; 3], torque_nm: [S; 3]) -> Result<CraftFiring, MixerError> {
        match self {
            CraftMixer::OpposingPairs(m) => {
                let f = m.mix(force_n, torque_nm)?;
                let mut out = CraftFiring {
                    on_ms: [0; MAX_THRUSTERS],
                    off_ms: [0; MAX_THRUSTERS],
                };
                for (o, v) in out.on_ms.iter_mut().zip(f.on_ms.iter()) {
                    *o = *v;
                }
                for (o, v) in out.off_ms.iter_mut().zip(f.off_ms.iter()) {
                    *o = *v;
                }
                Ok(out)
            }
            CraftMixer::Allocation(m) => m.mix(force_n, torque_nm),
        }
    }
}
