//! C ABI for any craft (issue 23 item 4): a thruster table of 1-16 slots
//! ([`MassidCraft`]), the craft's mixer ([`CraftMixer`], f32 and Q8.24 state blocks) and the
//! onboard identification ([`FlightId`]: in f32, and in the integer float [`IntFloat`] for
//! targets without a floating-point unit, whose block is larger: Q8.24 cannot hold the sums,
//! see `kernel/README.md`). Same conventions as the SPHERES functions of the parent module:
//! caller-owned blocks with a magic word, every call a [`MassidStatus`], no panics.

use core::mem::{align_of, size_of, MaybeUninit};

use super::{load, mix_block, store, write_out, CScalar, MassidSatelliteParams, MassidStatus};
use crate::allocation::CraftFiring;
use crate::craft::{Craft, Thruster, MAX_THRUSTERS};
use crate::craft_mixer::CraftMixer;
use crate::flight_id::consider::ThrustUncertainty;
use crate::flight_id::exact::Envelope;
use crate::flight_id::solve::{inverse_inertia, SolveConfig, SolveError, MAX_ORDER, NP};
use crate::flight_id::sums::SumScalar;
use crate::flight_id::window;
use crate::flight_id::{
    command_of_wrench, FlightId, FlightIdConfig, ReanchorError, SensorResponse,
};
use crate::in_place::field;
use crate::mixer::MixerConfig;
use crate::scalar::{Scalar, Q8_24};
use crate::IntFloat;

/// A craft's thruster table with C layout: `count` thrusters in the first slots (1-16),
/// positions from the geometric centre.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassidCraft {
    /// Thrusters in use, 1-16 (the slots beyond are ignored).
    pub count: u32,
    /// Non-zero: a planar (air-bearing) craft, which moves in x, y and turns about z only.
    pub planar: u32,
    /// Thruster positions from the geometric centre, m.
    pub thruster_pos_m: [[f32; 3]; MAX_THRUSTERS],
    /// Force directions (unit vectors).
    pub thrust_dir: [[f32; 3]; MAX_THRUSTERS],
    /// Thrust per thruster, N.
    pub thrust_n: [f32; MAX_THRUSTERS],
    /// Thrust lost per extra open thruster, N (0: none).
    pub pressure_drop_n_per_extra: f32,
}

/// ON/OFF times of one control period for up to 16 thrusters (slots beyond the craft's
/// count stay 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MassidCraftFiring {
    /// ON time per thruster slot, ms from the period start.
    pub on_ms: [u32; MAX_THRUSTERS],
    /// OFF time per thruster slot, ms (`on == off == 0`: off).
    pub off_ms: [u32; MAX_THRUSTERS],
}

impl From<CraftFiring> for MassidCraftFiring {
    fn from(f: CraftFiring) -> Self {
        MassidCraftFiring {
            on_ms: f.on_ms,
            off_ms: f.off_ms,
        }
    }
}

/// Bytes reserved for a craft mixer state (header: `MASSID_CRAFT_MIXER_BYTES`).
pub const CRAFT_MIXER_BYTES: usize = 2048;
/// Bytes reserved for an identification state (header: `MASSID_FLIGHT_ID_BYTES`).
pub const FLIGHT_ID_BYTES: usize = 20480;

const MAGIC_FIXED_CRAFT_MIXER: u32 = 0x4d49_4643; // "MIFC"
const MAGIC_F32_CRAFT_MIXER: u32 = 0x4d49_5343;
const MAGIC_F32_FLIGHT_ID: u32 = 0x4d49_5349;
const MAGIC_FIXED_FLIGHT_ID: u32 = 0x4d49_4649;

/// Bytes reserved for an integer-float identification (header:
/// `MASSID_FIXED_FLIGHT_ID_BYTES`): its numbers are 8 bytes where f32's are 4, so its state is
/// twice f32's (`massid_craft_state_bytes(3)`).
pub const FIXED_FLIGHT_ID_BYTES: usize = 36864;

/// Opaque craft mixer block.
#[repr(C, align(8))]
pub struct MassidCraftMixer {
    bytes: [u8; CRAFT_MIXER_BYTES],
}

/// Opaque identification block.
#[repr(C, align(8))]
pub struct MassidFlightId {
    bytes: [u8; FLIGHT_ID_BYTES],
}

/// Opaque integer-float identification block (`massid_fixed_flight_id_*`).
#[repr(C, align(8))]
pub struct MassidFixedFlightId {
    bytes: [u8; FIXED_FLIGHT_ID_BYTES],
}

/// What an identification block holds: the craft's wrench table (thruster word -> body
/// wrench) and the identification, in one number format.
struct FlightIdState<S: SumScalar> {
    craft: Craft<S>,
    id: FlightId<S>,
}

// The header's MASSID_MAX_THRUSTERS, MASSID_ID_TERMS and MASSID_ID_MAX_NOISE_ORDER.
const _: () = assert!(MAX_THRUSTERS == 16 && NP == 9 && MAX_ORDER == 2);
const _: () = assert!(size_of::<super::Slot<CraftMixer<Q8_24>>>() <= CRAFT_MIXER_BYTES);
const _: () = assert!(size_of::<super::Slot<CraftMixer<f32>>>() <= CRAFT_MIXER_BYTES);
const _: () = assert!(
    align_of::<super::Slot<CraftMixer<Q8_24>>>() <= 8
        && align_of::<super::Slot<CraftMixer<f32>>>() <= 8
);
const _: () = assert!(size_of::<super::Slot<FlightIdState<f32>>>() <= FLIGHT_ID_BYTES);
const _: () = assert!(align_of::<super::Slot<FlightIdState<f32>>>() <= 8);
const _: () = assert!(size_of::<super::Slot<FlightIdState<IntFloat>>>() <= FIXED_FLIGHT_ID_BYTES);
const _: () = assert!(align_of::<super::Slot<FlightIdState<IntFloat>>>() <= 8);

/// The thrusters of `c` and their count, or `None` if the count is not 1-16 or a value is not
/// a finite number (thrust positive, pressure drop non-negative).
fn thrusters(c: &MassidCraft) -> Option<([Thruster; MAX_THRUSTERS], usize)> {
    let n = usize::try_from(c.count).ok()?;
    if n == 0 || n > MAX_THRUSTERS {
        return None;
    }
    let drop_ok = c.pressure_drop_n_per_extra.is_finite() && c.pressure_drop_n_per_extra >= 0.0;
    if !drop_ok {
        return None;
    }
    let mut out = [Thruster {
        pos_m: [0.0; 3],
        dir: [0.0; 3],
        thrust_n: 0.0,
    }; MAX_THRUSTERS];
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let (Some(p), Some(d), Some(f)) = (
            c.thruster_pos_m.get(i),
            c.thrust_dir.get(i),
            c.thrust_n.get(i),
        ) else {
            return None;
        };
        let finite = p.iter().chain(d.iter()).all(|v| v.is_finite()) && f.is_finite();
        if !finite || *f <= 0.0 || d.iter().all(|v| *v == 0.0) {
            return None;
        }
        *o = Thruster {
            pos_m: *p,
            dir: *d,
            thrust_n: *f,
        };
    }
    Some((out, n))
}

/// Reads a `massid_craft`, or `None` (NULL or invalid).
///
/// # Safety
/// `craft` is NULL or points to a readable `massid_craft`.
unsafe fn read_craft(
    craft: *const MassidCraft,
) -> Result<(MassidCraft, [Thruster; MAX_THRUSTERS], usize), MassidStatus> {
    // SAFETY: NULL or a readable craft (caller's contract).
    let Some(c) = (unsafe { craft.as_ref() }) else {
        return Err(MassidStatus::NullPointer);
    };
    let c = *c;
    match thrusters(&c) {
        Some((t, n)) => Ok((c, t, n)),
        None => Err(MassidStatus::BadParameters),
    }
}

/// Fills `out` with the craft of SPHERES parameters `params` (12 thrusters, 3-D): the
/// SPHERES craft through the functions for any craft.
///
/// # Safety
/// `params` is NULL or points to a readable `massid_satellite_params`; `out` is NULL or points
/// to a writable `massid_craft`.
#[no_mangle]
pub unsafe extern "C" fn massid_craft_from_params(
    params: *const MassidSatelliteParams,
    out: *mut MassidCraft,
) -> MassidStatus {
    // SAFETY: NULL or readable / writable (caller's contract).
    let (Some(p), Some(o)) = (unsafe { params.as_ref() }, unsafe { out.as_mut() }) else {
        return MassidStatus::NullPointer;
    };
    let mut c = MassidCraft {
        count: 12,
        planar: 0,
        thruster_pos_m: [[0.0; 3]; MAX_THRUSTERS],
        thrust_dir: [[0.0; 3]; MAX_THRUSTERS],
        thrust_n: [0.0; MAX_THRUSTERS],
        pressure_drop_n_per_extra: p.pressure_drop_n_per_extra,
    };
    for (d, s) in c.thruster_pos_m.iter_mut().zip(p.thruster_pos_m.iter()) {
        *d = *s;
    }
    for (d, s) in c.thrust_dir.iter_mut().zip(p.thrust_dir.iter()) {
        *d = *s;
    }
    for (d, s) in c.thrust_n.iter_mut().zip(p.thrust_n.iter()) {
        *d = *s;
    }
    *o = c;
    MassidStatus::Ok
}

/// Size in bytes of a craft ABI type as Rust lays it out: 0 `massid_craft`, 1
/// `massid_craft_firing`, 2 `massid_craft_mixer`, 3 `massid_flight_id`, 4
/// `massid_flight_id_settings`, 5 `massid_flight_id_result`, 6 `massid_fixed_flight_id`; 0 for
/// any other code.
#[no_mangle]
pub extern "C" fn massid_craft_type_size(which: u32) -> u32 {
    let n = match which {
        0 => size_of::<MassidCraft>(),
        1 => size_of::<MassidCraftFiring>(),
        2 => size_of::<MassidCraftMixer>(),
        3 => size_of::<MassidFlightId>(),
        4 => size_of::<MassidFlightIdSettings>(),
        5 => size_of::<MassidFlightIdResult>(),
        6 => size_of::<MassidFixedFlightId>(),
        _ => 0,
    };
    u32::try_from(n).unwrap_or(0)
}

/// Bytes of the kernel state inside a craft mixer block (`fixed_point` non-zero: Q8.24) or,
/// for `fixed_point == 2`, inside an identification block (3: the integer-float one).
#[no_mangle]
pub extern "C" fn massid_craft_state_bytes(fixed_point: u8) -> u32 {
    let n = match fixed_point {
        0 => size_of::<CraftMixer<f32>>(),
        2 => size_of::<FlightIdState<f32>>(),
        3 => size_of::<FlightIdState<IntFloat>>(),
        _ => size_of::<CraftMixer<Q8_24>>(),
    };
    u32::try_from(n).unwrap_or(u32::MAX)
}

fn craft_mixer_init<S: CScalar>(
    block: *mut MassidCraftMixer,
    magic: u32,
    craft: *const MassidCraft,
    com_m: *const S::C,
    period_ms: u32,
    min_pulse_ms: u32,
) -> MassidStatus {
    if block.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: NULL or a readable craft (caller's contract).
    let (c, t, n) = match unsafe { read_craft(craft) } {
        Ok(v) => v,
        Err(s) => return s,
    };
    let com = if com_m.is_null() {
        [S::ZERO; 3]
    } else {
        // SAFETY: non-NULL; the caller passes three values.
        unsafe { com_m.cast::<[S::C; 3]>().read_unaligned() }.map(S::from_c)
    };
    if !com.iter().all(|v| v.is_valid()) {
        return MassidStatus::BadParameters;
    }
    let cfg = MixerConfig {
        period_ms,
        min_pulse_ms,
        pressure_drop_n: S::from_f32(c.pressure_drop_n_per_extra),
    };
    let Some(table) = t.get(..n) else {
        return MassidStatus::BadParameters;
    };
    match CraftMixer::<S>::new(table, com, c.planar != 0, cfg) {
        Ok(m) => {
            // SAFETY: non-NULL MassidCraftMixer (size/alignment asserted above).
            unsafe { store(block.cast::<u8>(), magic, m) };
            MassidStatus::Ok
        }
        Err(e) => MassidStatus::from(e),
    }
}

fn craft_mix<S: CScalar>(
    block: *mut MassidCraftMixer,
    magic: u32,
    force_n: *const S::C,
    torque_nm: *const S::C,
    out: *mut MassidCraftFiring,
) -> MassidStatus {
    mix_block::<S, CraftMixer<S>, _, _>(
        block.cast::<u8>(),
        magic,
        force_n,
        torque_nm,
        out,
        |m, f, t| m.mix(f, t),
    )
}

fn craft_mixer_rule<S: CScalar>(
    block: *mut MassidCraftMixer,
    magic: u32,
    opposing_pairs: *mut u8,
) -> MassidStatus {
    if block.is_null() || opposing_pairs.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL MassidCraftMixer; only a block written by `craft_mixer_init` has the magic.
    match unsafe { load::<CraftMixer<S>>(block.cast::<u8>(), magic) } {
        Some(slot) => {
            let pairs = matches!(slot.value, CraftMixer::OpposingPairs(_));
            write_out(opposing_pairs, u8::from(pairs));
            MassidStatus::Ok
        }
        None => MassidStatus::NotInitialised,
    }
}

macro_rules! craft_flavour {
    ($S:ty, $C:ty, $magic:expr, $init:ident, $mix:ident, $rule:ident) => {
        /// Builds the mixer of `craft` with lever arms about `com_m` (three values, m from the
        /// geometric centre: the model's CoM or the identified one; NULL: the geometric
        /// centre). SPHERES' 12-thruster layout gets the seed's pair rules, every other craft
        /// the smallest non-negative allocation.
        ///
        /// # Safety
        /// `block` is NULL or points to a writable, 8-aligned `massid_craft_mixer`; `craft` is
        /// NULL or points to a readable `massid_craft`; `com_m` is NULL or points to three
        /// readable values.
        #[no_mangle]
        pub unsafe extern "C" fn $init(
            block: *mut MassidCraftMixer,
            craft: *const MassidCraft,
            com_m: *const $C,
            period_ms: u32,
            min_pulse_ms: u32,
        ) -> MassidStatus {
            craft_mixer_init::<$S>(block, $magic, craft, com_m, period_ms, min_pulse_ms)
        }

        /// Mixes a force (N, 3 values) and torque (N m about the CoM, 3 values) command into
        /// integer-millisecond ON/OFF times per thruster slot. A command no non-negative
        /// firing produces (or off a planar craft's plane) is `MASSID_OUT_OF_REACH`.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_craft_mixer`; `force_n` and `torque_nm` are
        /// NULL or point to three readable values each; `out` is NULL or points to a writable
        /// `massid_craft_firing`.
        #[no_mangle]
        pub unsafe extern "C" fn $mix(
            block: *mut MassidCraftMixer,
            force_n: *const $C,
            torque_nm: *const $C,
            out: *mut MassidCraftFiring,
        ) -> MassidStatus {
            craft_mix::<$S>(block, $magic, force_n, torque_nm, out)
        }

        /// Which rule the mixer runs: writes 1 for the seed's opposing-pair rules, 0 for the
        /// non-negative allocation.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_craft_mixer`; `opposing_pairs` is NULL or
        /// points to a writable `uint8_t`.
        #[no_mangle]
        pub unsafe extern "C" fn $rule(
            block: *mut MassidCraftMixer,
            opposing_pairs: *mut u8,
        ) -> MassidStatus {
            craft_mixer_rule::<$S>(block, $magic, opposing_pairs)
        }
    };
}

craft_flavour!(
    Q8_24,
    i32,
    MAGIC_FIXED_CRAFT_MIXER,
    massid_fixed_craft_mixer_init,
    massid_fixed_craft_mix,
    massid_fixed_craft_mixer_rule
);
craft_flavour!(
    f32,
    f32,
    MAGIC_F32_CRAFT_MIXER,
    massid_f32_craft_mixer_init,
    massid_f32_craft_mix,
    massid_f32_craft_mixer_rule
);

/// Settings of the onboard identification ([`FlightIdConfig`] with C layout, plus the
/// model's nominal mass properties). `massid_flight_id_settings_default` fills the ground
/// tool's choices.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassidFlightIdSettings {
    /// Nominal inertia about the CoM, kg m^2, xx yy zz xy xz yz.
    pub inertia_kgm2: [f32; 6],
    /// The model's CoM from the geometric centre, m (the wrench table's reference point).
    pub com_m: [f32; 3],
    /// Nominal sample period, s; a step over 1.5 of it starts a new window.
    pub period_s: f32,
    /// Known command-to-thrust delay, sample periods.
    pub delay_periods: f32,
    /// The rate noise's moving-average root, 0 to `flight_id::ma_prefilter::MAX_ROOT` (0 for
    /// a gyro; for rates differenced from attitude, the root `massid estimate --kernel f32`
    /// finds on an earlier flight with the same sensor: its noise `ma`, negated).
    pub rate_noise_ma_root: f32,
    /// Past `turn_window` samples a window is cut once the craft turned this far, rad, each
    /// axis' turn weighted by `turn_weight` (infinity: never).
    pub max_window_turn_rad: f32,
    /// Per axis, how much its turn counts (`flight_id::window::turn_weights`); finite and
    /// positive (a zeroed struct is refused rather than flown without a turn limit).
    pub turn_weight: [f32; 3],
    /// Per term (inverse inertia xx yy zz xy xz yz, CoM x y z), the standard error beyond
    /// which the term is held at the nominal (1/(kg m^2) and m).
    pub scale: [f32; NP],
    /// Per thruster, its thrust's relative standard uncertainty (the model's `thrust_sigma_n`
    /// over `thrust_n`; 0: known). The covariance and the tests allow for it
    /// (`flight_id::consider`); `massid_flight_id_settings_default` leaves it 0.
    pub thrust_sigma_rel: [f32; MAX_THRUSTERS],
    /// Windows are cut at this many samples.
    pub max_window: u32,
    /// See `max_window_turn_rad`, samples.
    pub turn_window: u32,
    /// Samples left out at each window's start (the noise model's highest order).
    pub skip: u32,
    /// 0 point (gyro), 1 backward mean, 2 central mean (rates differenced from attitude).
    pub sensor: u8,
    /// Non-zero: cut the windows wherever the acting wrench changes.
    pub cut_at_changes: u8,
    /// Non-zero: Euler's gyroscopic term is in the model (3-D craft).
    pub gyroscopic: u8,
    /// Highest AR noise order tried (0-2).
    pub max_noise_order: u8,
    /// The lag of the rate noise's moving average: 1 (attitude differenced over one sample)
    /// or 2 (a central difference); the `ma_lag` `massid estimate` reports.
    pub rate_noise_ma_lag: u8,
    /// Per term (order of `scale`), non-zero: the fit may move it.
    pub free: [u8; NP],
    /// Per axis, non-zero: its rate enters the fit.
    pub axes: [u8; 3],
}

/// The identification's result (f32).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassidFlightIdResult {
    /// Inverse inertia xx yy zz xy xz yz (1/(kg m^2)), then the CoM minus the model's CoM
    /// (`settings.com_m`), m; held terms at the nominal.
    pub theta: [f32; NP],
    /// Covariance of `theta` (zero rows and columns for held terms).
    pub covariance: [[f32; NP]; NP],
    /// Per axis, AR noise coefficients (zero beyond the order).
    pub noise_phi: [[f32; MAX_ORDER]; 3],
    /// Per axis, innovation variance, (rad/s)^2.
    pub noise_sigma2: [f32; 3],
    /// The timing consistency statistic (chi-square, 1 dof), if `has_timing_statistic`.
    pub timing_statistic: f32,
    /// Per torque axis, the thrust-symmetry statistic (chi-square, 1 dof), where
    /// `has_symmetry_statistic`.
    pub symmetry_statistic: [f32; 3],
    /// Gauss-Newton steps taken.
    pub steps: u32,
    /// Per term, non-zero: held at the nominal (not free, or not determined by the data).
    pub held: [u8; NP],
    /// Per axis, the AR order.
    pub noise_order: [u8; 3],
    /// Non-zero: the inverse inertia is positive definite.
    pub positive_definite: u8,
    /// Non-zero: `timing_statistic` is set.
    pub has_timing_statistic: u8,
    /// Per axis, non-zero: `symmetry_statistic` is set.
    pub has_symmetry_statistic: [u8; 3],
}

fn sensor_of(code: u8) -> Option<SensorResponse> {
    match code {
        0 => Some(SensorResponse::Point),
        1 => Some(SensorResponse::BackwardMean),
        2 => Some(SensorResponse::CentralMean),
        _ => None,
    }
}

/// The kernel's configuration for `s`, or `None` if a setting is out of range.
/// (The settings are f32; each reaches `S` by its exact `from_f32`, and the nominal inverse
/// inertia is computed in `S`. The one floating-point computation is the thrust uncertainty's
/// pseudo-inverse, in f64 once here: software double on the M0 and M4F, not in a tick.)
fn flight_id_config<S: Scalar>(
    s: &MassidFlightIdSettings,
    craft: &Craft<S>,
) -> Option<FlightIdConfig<S>> {
    let envelope = Envelope::of_craft(craft.wrench_bound());
    let finite = s
        .inertia_kgm2
        .iter()
        .chain(s.com_m.iter())
        .chain(s.scale.iter())
        .all(|v| v.is_finite())
        && s.period_s.is_finite()
        && s.period_s > 0.0
        && !s.max_window_turn_rad.is_nan()
        && s.turn_weight.iter().all(|w| w.is_finite() && *w > 0.0)
        && usize::from(s.max_noise_order) <= MAX_ORDER
        && (0.0..=crate::flight_id::ma_prefilter::MAX_ROOT).contains(&s.rate_noise_ma_root)
        && crate::flight_id::ma_prefilter::LAGS.contains(&s.rate_noise_ma_lag)
        && s.thrust_sigma_rel
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0);
    if !finite {
        return None;
    }
    let j_nominal = inverse_inertia(&s.inertia_kgm2.map(S::from_f32))?;
    Some(FlightIdConfig {
        period_s: S::from_f32(s.period_s),
        sensor: sensor_of(s.sensor)?,
        delay_periods: s.delay_periods,
        rate_noise_ma_root: S::from_f32(s.rate_noise_ma_root),
        rate_noise_ma_lag: s.rate_noise_ma_lag,
        cut_at_changes: s.cut_at_changes != 0,
        max_window: s.max_window,
        max_window_turn_rad: S::from_f32(s.max_window_turn_rad),
        turn_window: s.turn_window,
        max_window_walk: S::from_f32(window::MAX_WINDOW_WALK),
        turn_weight: s.turn_weight.map(S::from_f32),
        skip: s.skip,
        solve: SolveConfig {
            j_nominal,
            free: s.free.map(|v| v != 0),
            axes: s.axes.map(|v| v != 0),
            gyroscopic: s.gyroscopic != 0,
            max_noise_order: s.max_noise_order,
            scale: s.scale.map(S::from_f32),
        },
        envelope,
        thrust: ThrustUncertainty::of_craft(craft, &s.thrust_sigma_rel)?,
    })
}

/// Fills `out` with the ground tool's settings for `craft` (`massid estimate --kernel f32`,
/// `kernel-host/src/flight_id.rs`): planar craft fit Izz and the CoM's x and y from the z
/// rate, 3-D craft every term from all three rates with the gyroscopic term; windows up to
/// 60 s, cut after 8 s once a 3-D craft turned 4 rad (both for a craft whose inertia couples
/// the axes like SPHERES'; `flight_id::window`); AR noise up to order 2; gyro sensor; no
/// delay; `scale` as the reference's `term_scale` (half the nominal principal inverse
/// inertia, a quarter of its mean for products, a quarter of the largest lever arm for the
/// CoM).
///
/// # Safety
/// `craft` is NULL or points to a readable `massid_craft`; `inertia_kgm2` to six and `com_m`
/// to three readable floats (or NULL); `out` is NULL or points to a writable
/// `massid_flight_id_settings`.
#[no_mangle]
pub unsafe extern "C" fn massid_flight_id_settings_default(
    craft: *const MassidCraft,
    inertia_kgm2: *const f32,
    com_m: *const f32,
    period_s: f32,
    out: *mut MassidFlightIdSettings,
) -> MassidStatus {
    if inertia_kgm2.is_null() || com_m.is_null() || out.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: NULL or a readable craft (caller's contract).
    let (c, t, n) = match unsafe { read_craft(craft) } {
        Ok(v) => v,
        Err(s) => return s,
    };
    // SAFETY: non-NULL; the caller passes six and three floats.
    let (inertia, com) = unsafe {
        (
            inertia_kgm2.cast::<[f32; 6]>().read_unaligned(),
            com_m.cast::<[f32; 3]>().read_unaligned(),
        )
    };
    if !(period_s.is_finite() && period_s > 0.0) {
        return MassidStatus::BadParameters;
    }
    let (Some(j), Some(turn_weight)) = (inverse_inertia(&inertia), window::turn_weights(&inertia))
    else {
        return MassidStatus::BadParameters;
    };
    let planar = c.planar != 0;
    let radius = t.iter().take(n).fold(0.0f32, |acc, th| {
        let d: f32 = th
            .pos_m
            .iter()
            .zip(com.iter())
            .map(|(p, c)| (p - c) * (p - c))
            .sum();
        acc.max(libm_sqrt(d))
    });
    let [jxx, jyy, jzz, ..] = j;
    let mean_principal = (jxx + jyy + jzz) / 3.0;
    let mut scale = [0.0f32; NP];
    for (m, s) in scale.iter_mut().enumerate() {
        *s = match m {
            0..=2 => 0.5 * j.get(m).copied().unwrap_or(0.0).abs(),
            3..=5 => 0.25 * mean_principal,
            _ => 0.25 * radius,
        };
    }
    let samples = |seconds: f32| window::samples(seconds, period_s);
    let free: [u8; NP] = core::array::from_fn(|m| u8::from(!planar || matches!(m, 2 | 6 | 7)));
    let settings = MassidFlightIdSettings {
        inertia_kgm2: inertia,
        com_m: com,
        period_s,
        delay_periods: 0.0,
        rate_noise_ma_root: 0.0,
        max_window_turn_rad: if planar {
            f32::INFINITY
        } else {
            window::MAX_WINDOW_TURN_RAD
        },
        turn_weight,
        scale,
        thrust_sigma_rel: [0.0; MAX_THRUSTERS],
        max_window: samples(window::MAX_WINDOW_S).max(window::MIN_WINDOW),
        turn_window: samples(window::turn_window_s(&turn_weight)),
        skip: u32::try_from(MAX_ORDER).unwrap_or(0),
        sensor: 0,
        cut_at_changes: 0,
        gyroscopic: u8::from(!planar),
        max_noise_order: u8::try_from(MAX_ORDER).unwrap_or(0),
        rate_noise_ma_lag: 1,
        free,
        axes: if planar { [0, 0, 1] } else { [1, 1, 1] },
    };
    write_out(out, settings);
    MassidStatus::Ok
}

/// Square root without `std` (Newton from the exponent halved; exact to an ulp or two, used
/// only for the default CoM scale).
fn libm_sqrt(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 || x.is_infinite() {
        return 0.0;
    }
    let mut y = f32::from_bits((x.to_bits() >> 1).wrapping_add(0x1fc0_0000));
    for _ in 0..6 {
        y = 0.5 * (y + x / y);
    }
    y
}

/// Initialises the identification in `block` (checked non-NULL by the caller; a block of the
/// format's size, see the asserts) for `craft` with `settings`.
///
/// # Safety
/// `block` points to a writable, 8-aligned block of at least `size_of::<Slot<FlightIdState<S>>>()`
/// bytes; `craft` and `settings` are NULL or readable.
unsafe fn flight_id_init<S: SumScalar>(
    block: *mut u8,
    magic: u32,
    craft: *const MassidCraft,
    settings: *const MassidFlightIdSettings,
) -> MassidStatus {
    // SAFETY: NULL or readable (caller's contract).
    let (c, t, n) = match unsafe { read_craft(craft) } {
        Ok(v) => v,
        Err(s) => return s,
    };
    // SAFETY: NULL or a readable settings struct (caller's contract).
    let Some(s) = (unsafe { settings.as_ref() }) else {
        return MassidStatus::NullPointer;
    };
    let Some(table) = t.get(..n) else {
        return MassidStatus::BadParameters;
    };
    let Ok(craft) = Craft::<S>::new(table, s.com_m, c.pressure_drop_n_per_extra) else {
        return MassidStatus::BadParameters;
    };
    let Some(cfg) = flight_id_config::<S>(s, &craft) else {
        return MassidStatus::BadParameters;
    };
    // The state is built in the block, not returned and moved there: the sums are tens of kB.
    // SAFETY: the caller's contract: `block` is writable and 8-aligned with room for the slot
    // (size and alignment asserted at compile time); as `MaybeUninit` nothing is assumed of
    // its bytes, and no other reference to it is live during this call.
    let slot = unsafe { &mut *block.cast::<MaybeUninit<super::Slot<FlightIdState<S>>>>() };
    let state = field!(slot, super::Slot<FlightIdState<S>>, value);
    // A refused configuration writes nothing: a block initialised before keeps its state.
    if FlightId::init_in_place(field!(state, FlightIdState<S>, id), cfg).is_none() {
        return MassidStatus::BadParameters;
    }
    field!(state, FlightIdState<S>, craft).write(craft);
    // The magic word last: the block is a valid state from here on (as `store` left it).
    field!(slot, super::Slot<FlightIdState<S>>, magic).write(magic);
    MassidStatus::Ok
}

/// Runs `f` on the identification in `block`, or says why not.
fn with_flight_id<S: SumScalar>(
    block: *mut u8,
    magic: u32,
    f: impl FnOnce(&mut FlightIdState<S>) -> MassidStatus,
) -> MassidStatus {
    if block.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL block of the format's type; only a block written by the init of that
    // format has the magic.
    match unsafe { load::<FlightIdState<S>>(block, magic) } {
        Some(slot) => f(&mut slot.value),
        None => MassidStatus::NotInitialised,
    }
}

/// One sample with a thruster word (see `massid_f32_flight_id_push`).
///
/// # Safety
/// `block` as for [`with_flight_id`]; `rate_rad_s` NULL or three readable floats.
unsafe fn flight_id_push<S: SumScalar>(
    block: *mut u8,
    magic: u32,
    dt_s: f32,
    rate_rad_s: *const f32,
    valid: u8,
    thrusters: u16,
) -> MassidStatus {
    if rate_rad_s.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL; the caller passes three floats.
    let rate = unsafe { rate_rad_s.cast::<[f32; 3]>().read_unaligned() };
    with_flight_id::<S>(block, magic, |st| {
        st.id.push_word(
            S::from_f32(dt_s),
            rate.map(S::from_f32),
            valid != 0,
            &st.craft,
            thrusters,
        );
        MassidStatus::Ok
    })
}

/// One sample with a body wrench (see `massid_f32_flight_id_push_wrench`).
///
/// # Safety
/// As [`flight_id_push`]; `wrench` NULL or six readable floats.
unsafe fn flight_id_push_wrench<S: SumScalar>(
    block: *mut u8,
    magic: u32,
    dt_s: f32,
    rate_rad_s: *const f32,
    valid: u8,
    wrench: *const f32,
) -> MassidStatus {
    if rate_rad_s.is_null() || wrench.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL; the caller passes three and six floats.
    let (rate, w) = unsafe {
        (
            rate_rad_s.cast::<[f32; 3]>().read_unaligned(),
            wrench.cast::<[f32; 6]>().read_unaligned(),
        )
    };
    with_flight_id::<S>(block, magic, |st| {
        st.id.push(
            S::from_f32(dt_s),
            rate.map(S::from_f32),
            valid != 0,
            command_of_wrench(w.map(S::from_f32)),
        );
        MassidStatus::Ok
    })
}

/// Closes the open window.
fn flight_id_finish<S: SumScalar>(block: *mut u8, magic: u32) -> MassidStatus {
    with_flight_id::<S>(block, magic, |st| {
        st.id.finish();
        MassidStatus::Ok
    })
}

/// 1 if the result's consistency tests reject the model (the timing test, or any axis' thrust
/// symmetry; the estimate is then `inconsistent` and not to be vouched for), 0 if not; 1 for
/// NULL. The tests are sized for a gyro (sensor 0): for rates differenced from attitude the
/// ground tool does not apply them and says `consistency_untested`.
///
/// # Safety
/// `result` is NULL or points to a readable `massid_flight_id_result`.
#[no_mangle]
pub unsafe extern "C" fn massid_flight_id_inconsistent(result: *const MassidFlightIdResult) -> u8 {
    // SAFETY: NULL or readable (caller's contract).
    let Some(r) = (unsafe { result.as_ref() }) else {
        return 1;
    };
    let timing = (r.has_timing_statistic != 0).then_some(r.timing_statistic);
    let symmetry: [Option<f32>; 3] = core::array::from_fn(|b| {
        let set = r.has_symmetry_statistic.get(b).is_some_and(|h| *h != 0);
        r.symmetry_statistic.get(b).copied().filter(|_| set)
    });
    u8::from(crate::flight_id::consistency::rejects(timing, &symmetry))
}

/// Fits and writes the result in f32 (see `massid_f32_flight_id_solve`).
fn flight_id_solve<S: SumScalar>(
    block: *mut u8,
    magic: u32,
    out: *mut MassidFlightIdResult,
) -> MassidStatus {
    if out.is_null() {
        return MassidStatus::NullPointer;
    }
    with_flight_id::<S>(block, magic, |st| match st.id.solve() {
        Ok(sol) => {
            let mut r = MassidFlightIdResult {
                theta: sol.theta.map(S::to_f32),
                covariance: sol.covariance.map(|row| row.map(S::to_f32)),
                noise_phi: [[0.0; MAX_ORDER]; 3],
                noise_sigma2: [0.0; 3],
                timing_statistic: sol.timing_statistic.map_or(0.0, S::to_f32),
                symmetry_statistic: sol.symmetry_statistic.map(|v| v.map_or(0.0, S::to_f32)),
                steps: sol.steps,
                held: sol.held.map(u8::from),
                noise_order: [0; 3],
                positive_definite: u8::from(sol.positive_definite),
                has_timing_statistic: u8::from(sol.timing_statistic.is_some()),
                has_symmetry_statistic: sol.symmetry_statistic.map(|v| u8::from(v.is_some())),
            };
            for (a, n) in sol.noise.iter().enumerate() {
                if let Some(p) = r.noise_phi.get_mut(a) {
                    *p = n.phi.map(S::to_f32);
                }
                if let Some(s) = r.noise_sigma2.get_mut(a) {
                    *s = n.sigma2.to_f32();
                }
                if let Some(o) = r.noise_order.get_mut(a) {
                    *o = n.order;
                }
            }
            write_out(out, r);
            MassidStatus::Ok
        }
        Err(e) => match e {
            SolveError::NoData => MassidStatus::NoData,
            SolveError::Singular => MassidStatus::Singular,
            SolveError::Overflow => MassidStatus::Overflow,
            SolveError::NotConverged => MassidStatus::NotConverged,
        },
    })
}

/// Moves the f32 identification's sums to the model of `theta` (9 floats, a solve's result
/// `theta`: inverse inertia xx yy zz xy xz yz in 1/(kg m^2), then the CoM offset from the
/// model's in m): from then on they hold the rates' residual from that model, so that f32 keeps
/// its precision on a craft far from the model it was configured with
/// (`massid_kernel::flight_id::anchor`). Exact: a solve before and after agree up to rounding.
/// Background work, as the solve (it folds every waiting sum; never while a push on the block
/// can run). Errors: `MASSID_SINGULAR` (the inverse inertia), `MASSID_OVERFLOW` (a moved sum
/// left f32; nothing changed). The integer-float form has no such call: its sums are exact.
///
/// # Safety
/// `block` is NULL or points to a `massid_flight_id`; `theta` is NULL or points to nine
/// readable floats.
#[no_mangle]
pub unsafe extern "C" fn massid_f32_flight_id_reanchor(
    block: *mut MassidFlightId,
    theta: *const f32,
) -> MassidStatus {
    if theta.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL; the caller passes nine floats.
    let theta = unsafe { theta.cast::<[f32; NP]>().read_unaligned() };
    with_flight_id::<f32>(block.cast::<u8>(), MAGIC_F32_FLIGHT_ID, |st| {
        match st.id.reanchor(&theta) {
            Ok(()) => MassidStatus::Ok,
            Err(ReanchorError::Singular) => MassidStatus::Singular,
            Err(ReanchorError::Overflow | ReanchorError::ExactSums) => MassidStatus::Overflow,
        }
    })
}

/// The identification's entry points for one block type, number format and magic word.
macro_rules! flight_id_abi {
    ($block:ty, $s:ty, $magic:expr, $what:literal,
     $init:ident, $push:ident, $push_wrench:ident, $finish:ident, $solve:ident) => {
        #[doc = concat!("Initialises an identification block for `craft` with `settings` (", $what, ").")]
        ///
        /// # Safety
        /// `block` is NULL or points to a writable, 8-aligned block of its type; `craft` and
        /// `settings` are NULL or point to a readable `massid_craft` /
        /// `massid_flight_id_settings`.
        #[no_mangle]
        pub unsafe extern "C" fn $init(
            block: *mut $block,
            craft: *const MassidCraft,
            settings: *const MassidFlightIdSettings,
        ) -> MassidStatus {
            if block.is_null() {
                return MassidStatus::NullPointer;
            }
            // SAFETY: non-NULL block of the type sized for this format (asserted above).
            unsafe { flight_id_init::<$s>(block.cast::<u8>(), $magic, craft, settings) }
        }

        /// One sample: `dt_s` since the previous sample, the measured body rate (3 floats,
        /// rad/s; `valid` zero for a missing or railed sample) and the thruster word commanded
        /// from this sample until the next (bit i = thruster i+1).
        ///
        /// # Safety
        /// `block` is NULL or points to a block of its type; `rate_rad_s` is NULL or points to
        /// three readable floats.
        #[no_mangle]
        pub unsafe extern "C" fn $push(
            block: *mut $block,
            dt_s: f32,
            rate_rad_s: *const f32,
            valid: u8,
            thrusters: u16,
        ) -> MassidStatus {
            // SAFETY: the caller's contract, passed on.
            unsafe {
                flight_id_push::<$s>(block.cast::<u8>(), $magic, dt_s, rate_rad_s, valid, thrusters)
            }
        }

        /// As the push with a thruster word, with a commanded body wrench instead: 6 floats,
        /// torque about the model's CoM (N m) then force (N).
        ///
        /// # Safety
        /// As the push; `wrench` is NULL or points to six readable floats.
        #[no_mangle]
        pub unsafe extern "C" fn $push_wrench(
            block: *mut $block,
            dt_s: f32,
            rate_rad_s: *const f32,
            valid: u8,
            wrench: *const f32,
        ) -> MassidStatus {
            // SAFETY: the caller's contract, passed on.
            unsafe {
                flight_id_push_wrench::<$s>(block.cast::<u8>(), $magic, dt_s, rate_rad_s, valid, wrench)
            }
        }

        /// Ends the flight (closes the open window; call before the final solve).
        ///
        /// # Safety
        /// `block` is NULL or points to a block of its type.
        #[no_mangle]
        pub unsafe extern "C" fn $finish(block: *mut $block) -> MassidStatus {
            flight_id_finish::<$s>(block.cast::<u8>(), $magic)
        }

        /// Fits the mass properties to the windows closed so far (a background task's work: it
        /// copies the sums onto the stack). Errors: `MASSID_NO_DATA`, `MASSID_SINGULAR`,
        /// `MASSID_OVERFLOW`, `MASSID_NOT_CONVERGED`.
        ///
        /// # Safety
        /// `block` is NULL or points to a block of its type; `out` is NULL or points to a
        /// writable `massid_flight_id_result`.
        #[no_mangle]
        pub unsafe extern "C" fn $solve(
            block: *mut $block,
            out: *mut MassidFlightIdResult,
        ) -> MassidStatus {
            flight_id_solve::<$s>(block.cast::<u8>(), $magic, out)
        }
    };
}

flight_id_abi!(
    MassidFlightId,
    f32,
    MAGIC_F32_FLIGHT_ID,
    "f32",
    massid_f32_flight_id_init,
    massid_f32_flight_id_push,
    massid_f32_flight_id_push_wrench,
    massid_f32_flight_id_finish,
    massid_f32_flight_id_solve
);

flight_id_abi!(
    MassidFixedFlightId,
    IntFloat,
    MAGIC_FIXED_FLIGHT_ID,
    "the integer float: its arithmetic in integer instructions; f32 at the boundary only, where the results are converted",
    massid_fixed_flight_id_init,
    massid_fixed_flight_id_push,
    massid_fixed_flight_id_push_wrench,
    massid_fixed_flight_id_finish,
    massid_fixed_flight_id_solve
);
