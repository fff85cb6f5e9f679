//! The PWM mixer of seed section 3.3 (Fig. 3.2 "PWM Mixer Code Block Diagram") and 3.4:
//! a body-frame force/torque command for one control period becomes per-thruster ON/OFF
//! times in whole milliseconds.
//!
//! The stages, in the seed's order (each function below cites its rule):
//!
//! | # | stage | seed |
//! |---|---|---|
//! | 1 | mixing matrix `M` (6 x 12): force vectors on top, `L x F` below, `L` about the current CoM estimate | 3.3, eq. "(2.1)" of ch. 3 |
//! | 2 | pseudo-inverse `M* = M^T (M M^T)^-1`; `u = M* c` = duty per thruster (fraction of the period at full thrust) | 3.3 |
//! | 3 | resolve opposing thrust (both of a pair positive: the smaller cancels out of both) | Fig. 3.2 |
//! | 4 | resolve negative values (a negative command becomes a positive command to the opposite thruster) | Fig. 3.2 |
//! | 5 | exact re-solve on the chosen thruster of each pair (reference addition, see [`refine_on_active_set`]) | 3.3 "net impulse can be conserved" |
//! | 6 | scale by the maximum: if any duty exceeds 1, all are divided by it (direction kept) | 3.3, Fig. 3.2 |
//! | 7 | duty x control period = on-time | Fig. 3.2 "x T_c" |
//! | 8 | pulse centring about the middle of the period | 3.3, Fig. 3.2 |
//! | 9 | multiple-thruster pressure-drop correction, smallest pulse first | 3.3, 3.7, Fig. 3.2 |
//! | 10 | 1 ms resolution, 10 ms minimum pulse (deadband), round up near a full period | 3.3, 3.4 |
//! | 11 | check `0 <= on <= off <= T_c` | Fig. 3.2 |
//!
//! # Integer rules (normative: the fixed-point kernel must produce exactly these times)
//!
//! Let `P` = period (ms), `m` = minimum pulse (ms), `d_i` the real on-time of thruster `i`
//! after stage 9 (ms, clamped to `[0, P]`).
//! 1. **Resolution (1 ms, seed 3.4):** `D_i = floor(d_i + 1/2)`: round to nearest, ties round
//!    UP (toward the longer pulse).
//! 2. **Deadband (seed 3.3/3.4, 10 ms minimum impulse bit):** if `D_i < m` then `D_i = 0`. The
//!    test is on the rounded integer, so `d_i = 9.5` gives `D_i = 10` and fires.
//! 3. **Round up near a full period (seed 3.3):** if `D_i > P - m` then `D_i = P`. The seed
//!    does not print its threshold; this reference uses the minimum pulse: an OFF gap shorter
//!    than the valve's minimum cycle is not commanded.
//! 4. **Centring (seed 3.3):** `on_i = floor((P - D_i) / 2)` (integer division, so an odd
//!    slack puts the extra millisecond AFTER the pulse), `off_i = on_i + D_i`.
//!    A thruster that does not fire has `on_i = off_i = 0`.
//!
//! Ordering ties (stage 9): pulses are sorted by real on-time ascending; equal on-times are
//! ordered by thruster index ascending.
//!
//! # Impulse error bound (what the tests check)
//! Before stage 10 the firing delivers exactly the (scaled) commanded impulse (stage 5 makes
//! it exact for the calibrated force vectors). Stage 10 changes each thruster's on-time by
//! `e_i = D_i - d_i` with `|e_i| <= 1/2` ms if `0 < D_i < P`, and `|e_i| <= m - 1/2` ms if
//! `D_i` is `0` (dropped: `d_i < m - 1/2`) or `P` (rounded up: `d_i >= P - m + 1/2`).
//! Hence `|impulse - commanded| <= sum_i |e_i| |F_i|` for force and
//! `<= sum_i |e_i| |L_i x F_i|` for torque ([`Firing::quantisation_bound`]).
use crate::allocation::{allocate, AllocationError};
use crate::satellite::{Satellite, MAX_THRUSTERS, N_THRUSTERS, OPPOSING_PAIRS};
use nalgebra::{Matrix6, SMatrix, Vector3, Vector6};
use serde::{Deserialize, Serialize};

/// The SPHERES control period the CLI uses by default, ms.
pub const DEFAULT_PERIOD_MS: u32 = 200;
/// Minimum impulse bit of the solenoid valves, ms (seed 3.4: "10 ms opening transient").
pub const MIN_PULSE_MS: u32 = 10;

/// 6 x 12 mixing matrix (seed 3.3).
pub type MixingMatrix = SMatrix<f64, 6, MAX_THRUSTERS>;
/// 12 x 6 pseudo-inverse of the mixing matrix.
pub type MixingPinv = SMatrix<f64, MAX_THRUSTERS, 6>;

/// Why a mixer could not be built or a command could not be mixed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixerError {
    #[error("control period must be at least twice the minimum pulse ({min_pulse_ms} ms), got {period_ms} ms")]
    BadPeriod { period_ms: u32, min_pulse_ms: u32 },
    #[error("a model needs 1 to {MAX_THRUSTERS} thrusters, this one has {0}")]
    ThrusterCount(usize),
    #[error("thruster {thruster}: {reason}")]
    BadThruster { thruster: usize, reason: String },
    #[error("pressure drop per extra open thruster must be finite and >= 0, got {0}")]
    BadPressureDrop(f64),
    #[error(
        "the thrusters cannot produce every force and torque (mixing matrix M M^T is singular)"
    )]
    SingularMixingMatrix,
    #[error("command must be finite, got force {force:?} torque {torque:?}")]
    NonFiniteCommand { force: [f64; 3], torque: [f64; 3] },
    #[error("thruster {thruster}: pressure drop with {open} open thrusters exceeds its thrust")]
    PressureDropExceedsThrust { thruster: usize, open: usize },
    #[error(transparent)]
    OutOfReach(#[from] AllocationError),
    #[error("a planar craft has no {axis}: its command must be 0 (got {value})")]
    OffPlane { axis: &'static str, value: f64 },
}

/// Mixer settings (seed 3.3-3.4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MixerConfig {
    /// Control period `T_c`, ms.
    pub period_ms: u32,
    /// Minimum pulse (deadband), ms; seed 3.4: 10 ms.
    pub min_pulse_ms: u32,
    /// Thrust lost per extra open thruster, N (seed 3.7; flight code 0.0106, built-in models 0).
    pub pressure_drop_n_per_extra: f64,
}

impl Default for MixerConfig {
    fn default() -> Self {
        MixerConfig {
            period_ms: DEFAULT_PERIOD_MS,
            min_pulse_ms: MIN_PULSE_MS,
            pressure_drop_n_per_extra: 0.0,
        }
    }
}

/// Per-thruster ON/OFF times within one control period, integer ms from the period start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Firing {
    pub period_ms: u32,
    pub min_pulse_ms: u32,
    /// ON time of thruster i (0-based), ms; equals `off_ms[i]` (0) when it does not fire.
    pub on_ms: [u32; MAX_THRUSTERS],
    /// OFF time of thruster i, ms.
    pub off_ms: [u32; MAX_THRUSTERS],
    /// Factor (<= 1) the command was scaled by to fit the thrusters' reach (stage 6).
    pub scale: f64,
}

impl Firing {
    /// Pulse length of thruster `i`, ms.
    pub fn duration_ms(&self, i: usize) -> u32 {
        self.off_ms[i] - self.on_ms[i]
    }

    /// True when thruster `i` fires in this period.
    pub fn fires(&self, i: usize) -> bool {
        self.off_ms[i] > self.on_ms[i]
    }

    /// Thruster word (bit i = thruster i+1 open, recording-format convention) at time `t_ms`
    /// within the period (a thruster is open on `[on, off)`).
    pub fn word_at(&self, t_ms: u32) -> u16 {
        (0..MAX_THRUSTERS)
            .filter(|&i| self.on_ms[i] <= t_ms && t_ms < self.off_ms[i])
            .fold(0u16, |w, i| w | (1 << i))
    }

    /// Net force impulse (N s) and torque impulse (N m s) of this firing for constant
    /// thrusts `forces_n` with lever arms `lever_arms_m` (no pressure drop).
    pub fn impulse(&self, geometry: &ThrusterGeometry) -> (Vector3<f64>, Vector3<f64>) {
        let mut f = Vector3::zeros();
        let mut t = Vector3::zeros();
        for i in 0..MAX_THRUSTERS {
            let secs = self.duration_ms(i) as f64 * 1e-3;
            f += geometry.force_n[i] * secs;
            t += geometry.torque_nm(i) * secs;
        }
        (f, t)
    }

    /// Upper bound (force N s, torque N m s) on `|impulse - scale * command * period|` from
    /// the integer rules of stage 10 alone (see the module doc's derivation).
    pub fn quantisation_bound(&self, geometry: &ThrusterGeometry) -> (f64, f64) {
        let half = 0.5e-3;
        let coarse = (self.min_pulse_ms as f64 - 0.5) * 1e-3;
        let mut bf = 0.0;
        let mut bt = 0.0;
        for i in 0..MAX_THRUSTERS {
            let d = self.duration_ms(i);
            let e = if d == 0 || d == self.period_ms {
                coarse
            } else {
                half
            };
            bf += e * geometry.force_n[i].norm();
            bt += e * geometry.torque_nm(i).norm();
        }
        (bf, bt)
    }
}

/// The calibrated thrusters the mixer is built from: force vectors (thrust x direction, N),
/// lever arms about the CURRENT CoM estimate (m) and thrust magnitudes (N) for the
/// pressure-drop model `thrust_n - p (n_open - 1)` of the seed's flight code.
#[derive(Clone, Debug, PartialEq)]
pub struct ThrusterGeometry {
    pub force_n: [Vector3<f64>; MAX_THRUSTERS],
    pub lever_arm_m: [Vector3<f64>; MAX_THRUSTERS],
    pub thrust_n: [f64; MAX_THRUSTERS],
    /// How many thrusters the model described (slots past it are empty: zero force).
    pub described: usize,
    /// A planar craft (air bearing): only `Fx`, `Fy` and `Tz` are mixed.
    pub planar: bool,
}

impl ThrusterGeometry {
    /// Geometry of a satellite model about its model CoM, or about `com_estimate_m` (m, from
    /// the geometric centre) when given, so identified mass properties change firing times.
    pub fn from_satellite(
        sat: &Satellite,
        com_estimate_m: Option<Vector3<f64>>,
    ) -> ThrusterGeometry {
        let com = com_estimate_m.unwrap_or_else(|| sat.com_m());
        let n = sat.n_thrusters();
        ThrusterGeometry {
            force_n: std::array::from_fn(|i| {
                if i < n {
                    sat.force_n(i)
                } else {
                    Vector3::zeros()
                }
            }),
            lever_arm_m: std::array::from_fn(|i| if i < n { sat.pos_m(i) - com } else { -com }),
            thrust_n: std::array::from_fn(|i| sat.thrust_n.get(i).copied().unwrap_or(0.0)),
            described: n,
            planar: sat.planar,
        }
    }

    /// Torque about the CoM of thruster `i` at full thrust, `L_i x F_i`.
    pub fn torque_nm(&self, i: usize) -> Vector3<f64> {
        self.lever_arm_m[i].cross(&self.force_n[i])
    }

    /// Whether the seed's opposing-pair rules (stages 3-5) apply: a 3-D craft of
    /// [`N_THRUSTERS`] thrusters whose [`OPPOSING_PAIRS`] push in opposite directions
    /// (within 8 degrees), as on SPHERES. Every other craft is mixed by the non-negative
    /// allocation ([`crate::allocation`]).
    pub fn has_opposing_pairs(&self) -> bool {
        !self.planar
            && self.described == N_THRUSTERS
            && OPPOSING_PAIRS.iter().all(|&(a, b)| {
                let (fa, fb) = (self.force_n[a], self.force_n[b]);
                fa.dot(&fb) < -0.99 * fa.norm() * fb.norm()
            })
    }

    /// The axes this craft's mixer controls (indices into `Fx Fy Fz Tx Ty Tz`).
    pub fn axes(&self) -> &'static [usize] {
        if self.planar {
            &[0, 1, 5]
        } else {
            &[0, 1, 2, 3, 4, 5]
        }
    }

    fn validate(&self) -> Result<(), MixerError> {
        if !(1..=MAX_THRUSTERS).contains(&self.described) {
            return Err(MixerError::ThrusterCount(self.described));
        }
        for i in 0..self.described {
            let finite = self.force_n[i]
                .iter()
                .chain(self.lever_arm_m[i].iter())
                .all(|v| v.is_finite());
            if !finite {
                return Err(MixerError::BadThruster {
                    thruster: i + 1,
                    reason: "non-finite force or lever arm".into(),
                });
            }
            if !(self.thrust_n[i].is_finite() && self.thrust_n[i] > 0.0) {
                return Err(MixerError::BadThruster {
                    thruster: i + 1,
                    reason: format!("thrust must be positive, got {}", self.thrust_n[i]),
                });
            }
            if self.force_n[i].norm() == 0.0 {
                return Err(MixerError::BadThruster {
                    thruster: i + 1,
                    reason: "zero force vector".into(),
                });
            }
        }
        Ok(())
    }
}

/// Every intermediate of one mix, for tests, the CLI's `--trace` and differential checks.
/// For a craft without opposing pairs stages 2-5 are one step, the non-negative allocation,
/// and `pinv_duty`, `resolved_duty` and `refined_duty` all hold its duties.
#[derive(Clone, Debug, PartialEq)]
pub struct MixTrace {
    /// Stage 2: `M* c`, duty per thruster (can be negative / above 1).
    pub pinv_duty: [f64; MAX_THRUSTERS],
    /// Stages 3-4: after opposing-thrust and negative-value resolution (>= 0, one per pair).
    pub resolved_duty: [f64; MAX_THRUSTERS],
    /// Stage 5: exact duties on the chosen thrusters.
    pub refined_duty: [f64; MAX_THRUSTERS],
    /// Stage 6: the scale applied (1 when the command is within reach).
    pub scale: f64,
    /// Stages 7-8: real on-times, ms, before the pressure correction.
    pub on_time_ms: [f64; MAX_THRUSTERS],
    /// Stage 9: real on-times after the pressure-drop correction (clamped to the period), ms.
    pub corrected_ms: [f64; MAX_THRUSTERS],
    /// Stages 10-11: the output.
    pub firing: Firing,
}

/// The PWM mixer for one satellite geometry and configuration.
#[derive(Clone, Debug)]
pub struct Mixer {
    geometry: ThrusterGeometry,
    config: MixerConfig,
    matrix: MixingMatrix,
    /// The pseudo-inverse when the seed's pair rules apply; `None`: non-negative allocation.
    pinv: Option<MixingPinv>,
}

impl Mixer {
    /// Builds the mixing matrix and its pseudo-inverse (seed 3.3). Fails on non-physical
    /// thrusters, a period shorter than two minimum pulses, or a geometry that cannot
    /// produce all six axes.
    pub fn new(geometry: ThrusterGeometry, config: MixerConfig) -> Result<Mixer, MixerError> {
        geometry.validate()?;
        if config.min_pulse_ms == 0 || config.period_ms / 2 < config.min_pulse_ms {
            return Err(MixerError::BadPeriod {
                period_ms: config.period_ms,
                min_pulse_ms: config.min_pulse_ms,
            });
        }
        let p = config.pressure_drop_n_per_extra;
        if !(p.is_finite() && p >= 0.0) {
            return Err(MixerError::BadPressureDrop(p));
        }
        let matrix = mixing_matrix(&geometry);
        let pinv = if geometry.has_opposing_pairs() {
            Some(pseudo_inverse(&matrix).ok_or(MixerError::SingularMixingMatrix)?)
        } else {
            None
        };
        Ok(Mixer {
            geometry,
            config,
            matrix,
            pinv,
        })
    }

    /// Mixer for a satellite model (its pressure-drop parameter included), with lever arms
    /// about `com_estimate_m` when given (else the model CoM).
    pub fn from_satellite(
        sat: &Satellite,
        com_estimate_m: Option<Vector3<f64>>,
        period_ms: u32,
    ) -> Result<Mixer, MixerError> {
        let config = MixerConfig {
            period_ms,
            min_pulse_ms: MIN_PULSE_MS,
            pressure_drop_n_per_extra: sat.pressure_drop_n_per_extra,
        };
        Mixer::new(
            ThrusterGeometry::from_satellite(sat, com_estimate_m),
            config,
        )
    }

    pub fn geometry(&self) -> &ThrusterGeometry {
        &self.geometry
    }
    pub fn config(&self) -> &MixerConfig {
        &self.config
    }
    /// The 6 x 12 mixing matrix `M` (seed 3.3).
    pub fn matrix(&self) -> &MixingMatrix {
        &self.matrix
    }
    /// Its pseudo-inverse `M* = M^T (M M^T)^-1` when the seed's pair rules mix this craft.
    pub fn pinv(&self) -> Option<&MixingPinv> {
        self.pinv.as_ref()
    }

    /// Mixes a body-frame command: `force_n` (N) and `torque_nm` (N m, about the CoM) are the
    /// averages wanted over the control period, i.e. the impulse is `command * T_c`.
    pub fn mix(
        &self,
        force_n: Vector3<f64>,
        torque_nm: Vector3<f64>,
    ) -> Result<Firing, MixerError> {
        self.mix_traced(force_n, torque_nm).map(|t| t.firing)
    }

    /// [`Mixer::mix`] returning every intermediate stage.
    pub fn mix_traced(
        &self,
        force_n: Vector3<f64>,
        torque_nm: Vector3<f64>,
    ) -> Result<MixTrace, MixerError> {
        if !(force_n
            .iter()
            .chain(torque_nm.iter())
            .all(|v| v.is_finite()))
        {
            return Err(MixerError::NonFiniteCommand {
                force: force_n.into(),
                torque: torque_nm.into(),
            });
        }
        let command = Vector6::new(
            force_n.x,
            force_n.y,
            force_n.z,
            torque_nm.x,
            torque_nm.y,
            torque_nm.z,
        );
        let period = self.config.period_ms as f64;

        let (pinv_duty, resolved_duty, refined_duty) = match &self.pinv {
            Some(pinv) => {
                // Stage 2: duties from the pseudo-inverse.
                let pinv_duty: [f64; MAX_THRUSTERS] = (pinv * command).into();
                // Stages 3-4.
                let resolved_duty = resolve_negative_values(
                    &resolve_opposing_thrust(&pinv_duty, &self.geometry.thrust_n),
                    &self.geometry.thrust_n,
                );
                // Stage 5.
                let refined_duty = refine_on_active_set(&self.matrix, &command, &resolved_duty);
                (pinv_duty, resolved_duty, refined_duty)
            }
            None => {
                let duty = self.allocate(&command)?;
                (duty, duty, duty)
            }
        };
        // Stage 6.
        let (scaled, scale) = scale_by_maximum(&refined_duty);
        // Stages 7-8 (centring is implicit: all pulses share the period's midpoint, which is
        // what makes the overlaps of stage 9 nested).
        let on_time_ms: [f64; MAX_THRUSTERS] = std::array::from_fn(|i| scaled[i] * period);
        // Stage 9.
        let corrected_ms = pressure_drop_correction(
            &on_time_ms,
            &self.geometry.thrust_n,
            self.config.pressure_drop_n_per_extra,
            period,
        )?;
        // Stages 10-11.
        let firing = quantise(
            &corrected_ms,
            self.config.period_ms,
            self.config.min_pulse_ms,
            scale,
        );
        Ok(MixTrace {
            pinv_duty,
            resolved_duty,
            refined_duty,
            scale,
            on_time_ms,
            corrected_ms,
            firing,
        })
    }
}

impl Mixer {
    /// Stages 2-5 for a craft without opposing pairs: the smallest-norm non-negative duties
    /// ([`crate::allocation`]); a planar craft's off-plane axes must not be commanded.
    fn allocate(&self, command: &Vector6<f64>) -> Result<[f64; MAX_THRUSTERS], MixerError> {
        let axes = self.geometry.axes();
        for (k, name) in ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"].iter().enumerate() {
            if !axes.contains(&k) && command[k] != 0.0 {
                return Err(MixerError::OffPlane {
                    axis: name,
                    value: command[k],
                });
            }
        }
        let n = self.geometry.described;
        let columns: Vec<Vector6<f64>> = (0..n).map(|i| self.matrix.column(i).into()).collect();
        let duty = allocate(&columns, axes, command)?;
        let mut out = [0.0; MAX_THRUSTERS];
        out[..n].copy_from_slice(&duty);
        Ok(out)
    }
}

/// Stage 1 (seed 3.3): column `i` is `[F_i ; L_i x F_i]` with the calibrated force vector
/// `F_i` and the lever arm `L_i` about the current CoM estimate.
pub fn mixing_matrix(geometry: &ThrusterGeometry) -> MixingMatrix {
    let mut m = MixingMatrix::zeros();
    for i in 0..MAX_THRUSTERS {
        let f = geometry.force_n[i];
        let t = geometry.torque_nm(i);
        m.fixed_view_mut::<3, 1>(0, i).copy_from(&f);
        m.fixed_view_mut::<3, 1>(3, i).copy_from(&t);
    }
    m
}

/// Stage 2 (seed 3.3): `M* = M^T (M M^T)^-1`, the minimum-norm right inverse. `None` when
/// `M M^T` is singular (the thrusters do not span all six axes).
pub fn pseudo_inverse(m: &MixingMatrix) -> Option<MixingPinv> {
    let mmt: Matrix6<f64> = m * m.transpose();
    let inv = mmt.cholesky()?.inverse();
    Some(m.transpose() * inv)
}

/// Stage 3 (Fig. 3.2 "Resolve Opposing Thrust": "firing in opposite directions is
/// inefficient"): when both thrusters of a pair have positive duty, the smaller force
/// (duty x thrust, N) is removed from both, leaving only the net on one of them.
pub fn resolve_opposing_thrust(
    duty: &[f64; MAX_THRUSTERS],
    thrust_n: &[f64; MAX_THRUSTERS],
) -> [f64; MAX_THRUSTERS] {
    let mut out = *duty;
    for &(a, b) in OPPOSING_PAIRS.iter() {
        if out[a] > 0.0 && out[b] > 0.0 {
            let (fa, fb) = (out[a] * thrust_n[a], out[b] * thrust_n[b]);
            if fa >= fb {
                out[a] = (fa - fb) / thrust_n[a];
                out[b] = 0.0;
            } else {
                out[a] = 0.0;
                out[b] = (fb - fa) / thrust_n[b];
            }
        }
    }
    out
}

/// Stage 4 (Fig. 3.2 "Resolve Negative Values": "negative commands are equal to positive
/// commands to the opposite thruster"): a negative duty becomes the same force (N) on the
/// opposite thruster of its pair, converted with that thruster's own strength.
pub fn resolve_negative_values(
    duty: &[f64; MAX_THRUSTERS],
    thrust_n: &[f64; MAX_THRUSTERS],
) -> [f64; MAX_THRUSTERS] {
    let mut out = *duty;
    for &(a, b) in OPPOSING_PAIRS.iter() {
        // net force along thruster a's direction, N
        // (a negative duty on b pushes along a's direction, and vice versa)
        let net = out[a] * thrust_n[a] - out[b] * thrust_n[b];
        if net >= 0.0 {
            out[a] = net / thrust_n[a];
            out[b] = 0.0;
        } else {
            out[a] = 0.0;
            out[b] = -net / thrust_n[b];
        }
    }
    out
}

/// Stage 5 (reference addition to keep the seed's promise "net impulse can be conserved",
/// 3.3): stages 3-4 treat the two thrusters of a pair as exactly opposite, but calibrated
/// directions differ by up to a few percent (App. C.4), which would leave an impulse error
/// of that order. With one thruster chosen per pair the six chosen columns of `M` form a
/// square system; it is solved exactly (LU). A negative solution component means that pair's
/// side was chosen wrongly (near-zero pair command): every such side is switched and the
/// system solved again, at most 7 solves in all (6 rounds of switching). If no consistent
/// choice is found or the system is singular, the stage-4 duties are returned unchanged
/// (never happened in `tests/tests/mixer_reference.rs`, which asserts the exact impulse for
/// 300 pure commands and the pressure-free half of 400 random ones).
///
/// The kernel may compare against the `MixTrace` of this stage directly.
///
/// Side rule: the thruster of a pair with the larger resolved duty; on a tie (both 0) the
/// first thruster of the pair (seed numbering 1-6).
pub fn refine_on_active_set(
    m: &MixingMatrix,
    command: &Vector6<f64>,
    resolved: &[f64; MAX_THRUSTERS],
) -> [f64; MAX_THRUSTERS] {
    let mut side: [usize; 6] = std::array::from_fn(|k| {
        let (a, b) = OPPOSING_PAIRS[k];
        if resolved[b] > resolved[a] {
            b
        } else {
            a
        }
    });
    for _ in 0..=6 {
        let mut s = Matrix6::<f64>::zeros();
        for (k, &i) in side.iter().enumerate() {
            s.set_column(k, &m.column(i));
        }
        let Some(v) = s.lu().solve(command) else {
            return *resolved;
        };
        if v.iter().all(|x| *x >= 0.0) {
            let mut out = [0.0; MAX_THRUSTERS];
            for (k, &i) in side.iter().enumerate() {
                out[i] = v[k];
            }
            return out;
        }
        for k in 0..6 {
            if v[k] < 0.0 {
                let (a, b) = OPPOSING_PAIRS[k];
                side[k] = if side[k] == a { b } else { a };
            }
        }
    }
    *resolved
}

/// Stage 6 (seed 3.3: "If any of these values is greater than 1, then they are all scaled
/// down so that the net direction of the commanded firing will remain the same"). Returns the
/// duties and the scale applied (1 when none exceeds 1).
pub fn scale_by_maximum(duty: &[f64; MAX_THRUSTERS]) -> ([f64; MAX_THRUSTERS], f64) {
    let max = duty.iter().cloned().fold(0.0, f64::max);
    if max > 1.0 {
        (std::array::from_fn(|i| duty[i] / max), 1.0 / max)
    } else {
        (*duty, 1.0)
    }
}

/// Stage 9 (seed 3.3, 3.7, Fig. 3.2 "Multiple Thruster Correction"): with `n` valves open each
/// thruster gives `F_i - p (n - 1)` (seed flight code). Pulses are centred, so the overlaps
/// are nested. Taking the `N` active pulses in ascending order (rank `r = 1..N`, ties by
/// index), pulse `r` of original length `d_r` loses the impulse
/// `p (sum_{k<r} d_k + (N - r) d_r)` (the shorter pulses use their ORIGINAL lengths: "ignoring
/// change to minimum command"), and is stretched at both ends, where `N - r` others are still
/// open, by `loss / (F_r - p (N - r))`. For `r = 1` this is "stretched by an amount relative to
/// # of other active thrusters"; for `r = 2` "relative to (N-2)". One pass only, as the seed's
/// mixer ("for now our mixer does this just once"). Results are clamped to the period.
/// Every pulse with a positive real on-time counts as open, including ones stage 10 will
/// drop below the minimum pulse: the seed's order is correction first, deadband last.
pub fn pressure_drop_correction(
    on_time_ms: &[f64; MAX_THRUSTERS],
    thrust_n: &[f64; MAX_THRUSTERS],
    drop_n_per_extra: f64,
    period_ms: f64,
) -> Result<[f64; MAX_THRUSTERS], MixerError> {
    let mut out = *on_time_ms;
    if drop_n_per_extra > 0.0 {
        let mut active: Vec<usize> = (0..MAX_THRUSTERS)
            .filter(|&i| on_time_ms[i] > 0.0)
            .collect();
        active.sort_by(|&a, &b| on_time_ms[a].total_cmp(&on_time_ms[b]).then(a.cmp(&b)));
        let n = active.len();
        let mut shorter_sum = 0.0;
        for (rank0, &i) in active.iter().enumerate() {
            let longer = (n - rank0 - 1) as f64;
            let thrust_during_stretch = thrust_n[i] - drop_n_per_extra * longer;
            let thrust_at_peak = thrust_n[i] - drop_n_per_extra * (n - 1) as f64;
            if thrust_at_peak <= 0.0 || thrust_during_stretch <= 0.0 {
                return Err(MixerError::PressureDropExceedsThrust {
                    thruster: i + 1,
                    open: n,
                });
            }
            let d = on_time_ms[i];
            let loss = drop_n_per_extra * (shorter_sum + longer * d);
            out[i] = d + loss / thrust_during_stretch;
            shorter_sum += d;
        }
    }
    for v in out.iter_mut() {
        *v = v.clamp(0.0, period_ms);
    }
    Ok(out)
}

/// Stages 10-11: the integer rules of the module doc (1 ms resolution with ties up, 10 ms
/// deadband, round up near the full period, centring with floor).
pub fn quantise(
    corrected_ms: &[f64; MAX_THRUSTERS],
    period_ms: u32,
    min_pulse_ms: u32,
    scale: f64,
) -> Firing {
    let mut on_ms = [0u32; MAX_THRUSTERS];
    let mut off_ms = [0u32; MAX_THRUSTERS];
    for i in 0..MAX_THRUSTERS {
        let dur = quantise_duration(corrected_ms[i], period_ms, min_pulse_ms);
        if dur > 0 {
            on_ms[i] = (period_ms - dur) / 2;
            off_ms[i] = on_ms[i] + dur;
        }
    }
    Firing {
        period_ms,
        min_pulse_ms,
        on_ms,
        off_ms,
        scale,
    }
}

/// One pulse's integer duration (rules 1-3 of the module doc).
pub fn quantise_duration(ms: f64, period_ms: u32, min_pulse_ms: u32) -> u32 {
    let clamped = ms.clamp(0.0, period_ms as f64);
    // `round` (half away from zero) is half-up for non-negative values and, unlike
    // `(x + 0.5).floor()`, adds no rounding error of its own.
    let mut d = clamped.round() as u32;
    if d < min_pulse_ms {
        d = 0;
    }
    if d > period_ms - min_pulse_ms {
        d = period_ms;
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_rules_are_as_documented() {
        assert_eq!(quantise_duration(9.49, 200, 10), 0);
        assert_eq!(quantise_duration(9.5, 200, 10), 10);
        assert_eq!(quantise_duration(10.5, 200, 10), 11);
        assert_eq!(quantise_duration(190.0, 200, 10), 190);
        assert_eq!(quantise_duration(190.5, 200, 10), 200);
        assert_eq!(quantise_duration(-3.0, 200, 10), 0);
        assert_eq!(quantise_duration(250.0, 200, 10), 200);
        let f = quantise(
            &[
                21.0, 20.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 200.0, 0.0, 0.0, 0.0, 0.0,
            ],
            200,
            10,
            1.0,
        );
        assert_eq!((f.on_ms[0], f.off_ms[0]), (89, 110));
        assert_eq!((f.on_ms[1], f.off_ms[1]), (90, 110));
        assert_eq!((f.on_ms[2], f.off_ms[2]), (0, 0));
        assert_eq!((f.on_ms[11], f.off_ms[11]), (0, 200));
    }

    #[test]
    fn absurd_configs_are_errors() {
        let sat = Satellite::builtin("sph1").unwrap();
        let g = ThrusterGeometry::from_satellite(&sat, None);
        for (period_ms, min_pulse_ms) in [(19, 10), (200, 0), (u32::MAX, u32::MAX), (0, 10)] {
            let c = MixerConfig {
                period_ms,
                min_pulse_ms,
                pressure_drop_n_per_extra: 0.0,
            };
            assert!(matches!(
                Mixer::new(g.clone(), c),
                Err(MixerError::BadPeriod { .. })
            ));
        }
        let c = MixerConfig {
            pressure_drop_n_per_extra: f64::NAN,
            ..MixerConfig::default()
        };
        assert!(matches!(
            Mixer::new(g.clone(), c),
            Err(MixerError::BadPressureDrop(_))
        ));
        // a drop larger than the thrust with several valves open is reported, not mixed
        let c = MixerConfig {
            pressure_drop_n_per_extra: 0.2,
            ..MixerConfig::default()
        };
        let m = Mixer::new(g, c).unwrap();
        let r = m.mix(Vector3::new(0.1, 0.1, 0.1), Vector3::zeros());
        assert!(matches!(
            r,
            Err(MixerError::PressureDropExceedsThrust { .. })
        ));
    }

    #[test]
    fn opposing_and_negative_resolution_keep_the_pair_net() {
        let mut thrust = [0.1; MAX_THRUSTERS];
        thrust[6] = 0.2;
        let mut duty = [0.0; MAX_THRUSTERS];
        duty[0] = 0.5; // 0.05 N
        duty[6] = 0.1; // 0.02 N the other way
        duty[1] = -0.3; // -> thruster 8 gets 0.03 N
        let r = resolve_negative_values(&resolve_opposing_thrust(&duty, &thrust), &thrust);
        assert!((r[0] - 0.3).abs() < 1e-15 && r[6] == 0.0);
        assert!(r[1] == 0.0 && (r[7] - 0.3).abs() < 1e-15);
    }

    #[test]
    fn pressure_correction_of_the_smallest_pulse_uses_all_others() {
        let thrust = [0.1; MAX_THRUSTERS];
        let mut d = [0.0; MAX_THRUSTERS];
        d[0] = 50.0;
        d[1] = 100.0;
        d[2] = 100.0;
        let c = pressure_drop_correction(&d, &thrust, 0.01, 200.0).unwrap();
        // smallest: thrust 0.1 - 2*0.01 throughout -> stretched by 0.1/0.08
        assert!((c[0] - 50.0 * 0.1 / 0.08).abs() < 1e-12);
        // second (index 1): loss 0.01*(50 + 1*100) = 1.5; stretch at 0.09 N
        assert!((c[1] - (100.0 + 1.5 / 0.09)).abs() < 1e-12);
        // third: loss 0.01*(50+100) at 0.1 N
        assert!((c[2] - (100.0 + 1.5 / 0.1)).abs() < 1e-12);
    }
}
