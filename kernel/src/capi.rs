//! C ABI (feature `capi`): `extern "C"` functions over opaque, fixed-size state structs, for
//! flight software written in C. The header is `kernel/include/massid_kernel.h`; the static
//! library is built by `kernel/capi-test/` (crate `massid-kernel-capi`).
//!
//! Two instantiations with the same functions: `massid_fixed_*` (Q8.24: every scalar crosses
//! the ABI as the raw `int32_t` bits, value = bits / 2^24) and `massid_f32_*` (`float`).
//!
//! Design (why):
//! * The caller owns the memory (no allocation): state structs are plain byte blocks of a
//!   size fixed in the header, with room to spare so that the kernel's internals can change
//!   without changing the ABI; a compile-time assertion below fails the build if the kernel's
//!   state outgrows them.
//! * Every function returns a [`MassidStatus`] and checks its pointers; a state block that
//!   was never initialised (no magic word) is refused rather than read.
//! * Nothing panics: bad numbers and bad parameters become status codes.
//! * Every function that reads or writes through a caller's pointer is an `unsafe extern "C"
//!   fn` with a `# Safety` section: the NULL checks cannot tell a dangling or short buffer.
//! * C callers choose what Rust callers can ([`MassidOptions`]: change detector, forgetting,
//!   gyroscopic correction), and a long telemetry gap is one O(1) call (`*_tick_gaps`).
#![allow(unsafe_code)]

pub mod craft;

use core::mem::{align_of, size_of};

use crate::mixer::{Firing, Mixer, MixerConfig, MixerError};
use crate::model::{SatelliteParams, N_THRUSTERS, SPH2};
use crate::pipeline::{Estimates, Pipeline, PipelineConfig, PipelineStatus, TickEvent, TickReport};
use crate::rls::DetectorConfig;
use crate::scalar::{Fx, Q8_24};
use crate::Scalar;

/// Status of every C ABI call.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MassidStatus {
    /// Success.
    Ok = 0,
    /// A pointer argument was NULL.
    NullPointer = 1,
    /// The state block was not initialised by the matching `*_init` function.
    NotInitialised = 2,
    /// Satellite parameters or settings are invalid (non-finite, singular inertia, zero period).
    BadParameters = 3,
    /// The thrusters cannot produce every axis (singular mixing matrix).
    Singular = 4,
    /// A value did not fit the number format.
    Overflow = 5,
    /// A mixer command was not a valid number.
    BadCommand = 6,
    /// With this many open thrusters the pressure drop exceeds a thruster's thrust.
    PressureDropExceedsThrust = 7,
    /// No non-negative firing gives the command's direction (or a planar craft was
    /// commanded off its plane).
    OutOfReach = 8,
    /// The identification has no usable window yet (no run of consecutive valid samples).
    NoData = 9,
    /// The identification's fit did not settle.
    NotConverged = 10,
}

/// Satellite parameters (mirror of [`SatelliteParams`] with C layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassidSatelliteParams {
    /// Thruster positions from the geometric centre, m.
    pub thruster_pos_m: [[f32; 3]; N_THRUSTERS],
    /// Force directions.
    pub thrust_dir: [[f32; 3]; N_THRUSTERS],
    /// Thrust strength, N.
    pub thrust_n: [f32; N_THRUSTERS],
    /// Inertia about the CoM, kg m^2, order xx yy zz xy xz yz.
    pub inertia_kgm2: [f32; 6],
    /// CoM minus geometric centre, mm.
    pub com_offset_mm: [f32; 3],
    /// Gyro scale, counts per rad/s.
    pub gyro_counts_per_rad_s: [f32; 3],
    /// Thrust lost per extra open thruster, N.
    pub pressure_drop_n_per_extra: f32,
}

impl From<&MassidSatelliteParams> for SatelliteParams {
    fn from(p: &MassidSatelliteParams) -> Self {
        SatelliteParams {
            thruster_pos_m: p.thruster_pos_m,
            thrust_dir: p.thrust_dir,
            thrust_n: p.thrust_n,
            inertia_kgm2: p.inertia_kgm2,
            com_offset_mm: p.com_offset_mm,
            gyro_counts_per_rad_s: p.gyro_counts_per_rad_s,
            pressure_drop_n_per_extra: p.pressure_drop_n_per_extra,
        }
    }
}

impl From<&SatelliteParams> for MassidSatelliteParams {
    fn from(p: &SatelliteParams) -> Self {
        MassidSatelliteParams {
            thruster_pos_m: p.thruster_pos_m,
            thrust_dir: p.thrust_dir,
            thrust_n: p.thrust_n,
            inertia_kgm2: p.inertia_kgm2,
            com_offset_mm: p.com_offset_mm,
            gyro_counts_per_rad_s: p.gyro_counts_per_rad_s,
            pressure_drop_n_per_extra: p.pressure_drop_n_per_extra,
        }
    }
}

/// Pipeline options for `massid_*_init_with` (the seed's settings when all are zero).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MassidOptions {
    /// Non-zero: the CUSUM change detector on the RLS innovations (`DetectorConfig::standard`).
    pub change_detector: u8,
    /// Non-zero: take the gyroscopic acceleration of the nominal inertia off the measured rate
    /// (needs `gyro_bias_counts`).
    pub gyroscopic: u8,
    /// Gyro zero-rate counts per axis (used with `gyroscopic`).
    pub gyro_bias_counts: [f32; 3],
    /// Exponential forgetting factor per update, in (0, 1); 0 or 1: none.
    pub forgetting: f32,
}

/// What one tick did (codes of [`TickEvent`] and [`PipelineStatus`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MassidTickReport {
    /// 0 coasting, 1 transient, 2 updated, 3 solved, 4 KF overflow, 5 firing too long,
    /// 6 railed gyro sample (rest of the firing unused).
    pub event: u8,
    /// Pipeline status: 0 idle, 1 batch, 2 ok, 3 partly unobservable, 4 singular, 5 overflow,
    /// 6 implausible (previous estimate kept).
    pub status: u8,
}

impl From<TickReport> for MassidTickReport {
    fn from(r: TickReport) -> Self {
        let event = match r.event {
            TickEvent::Coasting => 0,
            TickEvent::Transient => 1,
            TickEvent::Updated => 2,
            TickEvent::Solved => 3,
            TickEvent::KfOverflow => 4,
            TickEvent::FiringTooLong => 5,
            TickEvent::Railed => 6,
        };
        MassidTickReport {
            event,
            status: r.status as u8,
        }
    }
}

/// Current estimates; `T` is `int32_t` (Q8.24 bits) or `float`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MassidEstimates<T> {
    /// CoM offset from the model's CoM, m.
    pub delta_com_m: [T; 3],
    /// Inverse-inertia parameters xx yy zz xy xz yz, 1/(kg m^2)/100.
    pub theta_inertia: [T; 6],
    /// Non-zero: the CoM term is held at the model (unobservable so far).
    pub unobservable_com: [u8; 3],
    /// Non-zero: the inverse-inertia term is held at the model.
    pub unobservable_inertia: [u8; 6],
    /// Pipeline status code (as in [`MassidTickReport::status`]).
    pub status: u8,
    /// Measurement updates folded in.
    pub updates: u32,
    /// Firings seen.
    pub firings: u32,
    /// Covariance resets by the change detector.
    pub resets: u32,
    /// Why the last solve was rejected: 0 none, 1 inertia not positive definite, 2 triangle
    /// inequality broken, 3 CoM outside the thruster envelope.
    pub invalid: u8,
    /// Gyro samples at a rail.
    pub railed_samples: u32,
    /// Firings cut short at a railed sample.
    pub railed_firings: u32,
    /// Firings with no gyro response to a clear predicted acceleration (not fitted).
    pub unresponsive_firings: u32,
}

/// ON/OFF times of one control period, ms from the period start (`on == off == 0`: off).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MassidFiring {
    /// ON time per thruster, ms.
    pub on_ms: [u32; N_THRUSTERS],
    /// OFF time per thruster, ms.
    pub off_ms: [u32; N_THRUSTERS],
}

impl From<Firing> for MassidFiring {
    fn from(f: Firing) -> Self {
        MassidFiring {
            on_ms: f.on_ms,
            off_ms: f.off_ms,
        }
    }
}

impl From<MixerError> for MassidStatus {
    fn from(e: MixerError) -> Self {
        match e {
            MixerError::BadPeriod | MixerError::BadThruster => MassidStatus::BadParameters,
            MixerError::SingularMixingMatrix => MassidStatus::Singular,
            MixerError::BadCommand => MassidStatus::BadCommand,
            MixerError::PressureDropExceedsThrust => MassidStatus::PressureDropExceedsThrust,
            MixerError::Overflow => MassidStatus::Overflow,
            MixerError::OutOfReach | MixerError::OffPlane => MassidStatus::OutOfReach,
        }
    }
}

/// Bytes reserved for a pipeline state (header: `MASSID_PIPELINE_BYTES`).
pub const PIPELINE_BYTES: usize = 4096;
/// Bytes reserved for a mixer state (header: `MASSID_MIXER_BYTES`).
pub const MIXER_BYTES: usize = 1024;

const MAGIC_FIXED_PIPELINE: u32 = 0x4d49_4650; // "MIFP"
const MAGIC_F32_PIPELINE: u32 = 0x4d49_5350;
const MAGIC_FIXED_MIXER: u32 = 0x4d49_464d;
const MAGIC_F32_MIXER: u32 = 0x4d49_534d;

/// Opaque pipeline state block (the C side sees only its size and alignment).
#[repr(C, align(8))]
pub struct MassidPipeline {
    bytes: [u8; PIPELINE_BYTES],
}

/// Opaque mixer state block.
#[repr(C, align(8))]
pub struct MassidMixer {
    bytes: [u8; MIXER_BYTES],
}

/// What is stored in a block: a magic word naming the instantiation, then the value.
#[repr(C)]
struct Slot<T> {
    magic: u32,
    value: T,
}

// The kernel's state must fit the blocks the header promises (raise the reservation and the
// header's constants together if this fails).
const _: () = assert!(size_of::<Slot<Pipeline<Q8_24>>>() <= PIPELINE_BYTES);
const _: () = assert!(size_of::<Slot<Pipeline<f32>>>() <= PIPELINE_BYTES);
const _: () =
    assert!(align_of::<Slot<Pipeline<Q8_24>>>() <= 8 && align_of::<Slot<Pipeline<f32>>>() <= 8);
const _: () = assert!(size_of::<Slot<Mixer<Q8_24>>>() <= MIXER_BYTES);
const _: () = assert!(size_of::<Slot<Mixer<f32>>>() <= MIXER_BYTES);
const _: () = assert!(align_of::<Slot<Mixer<Q8_24>>>() <= 8 && align_of::<Slot<Mixer<f32>>>() <= 8);

/// Stores `value` in the block behind `block` (which has room and alignment, see the asserts).
///
/// # Safety
/// `block` must point to a writable block of at least `size_of::<Slot<T>>()` bytes aligned to 8.
unsafe fn store<T>(block: *mut u8, magic: u32, value: T) {
    // SAFETY: guaranteed by the caller and the compile-time size/alignment assertions.
    unsafe { block.cast::<Slot<T>>().write(Slot { magic, value }) }
}

/// The value in an initialised block, or `None` if the magic word does not match.
///
/// # Safety
/// `block` must point to a readable block of at least `size_of::<Slot<T>>()` bytes aligned to
/// 8, which holds a `Slot<T>` whenever its first word equals `magic`.
unsafe fn load<'a, T>(block: *mut u8, magic: u32) -> Option<&'a mut Slot<T>> {
    // SAFETY: the magic word is read as plain bytes (always initialised memory of the caller);
    // the value is only referenced when it was written by `store` with the same magic.
    unsafe {
        if block.cast::<u32>().read() == magic {
            block.cast::<Slot<T>>().as_mut()
        } else {
            None
        }
    }
}

/// A scalar as it crosses the ABI.
pub trait CScalar: Scalar {
    /// The C type (`int32_t` Q8.24 bits, or `float`).
    type C: Copy + Default;
    /// To the C representation.
    fn to_c(self) -> Self::C;
    /// From the C representation.
    fn from_c(c: Self::C) -> Self;
}

impl CScalar for Q8_24 {
    type C = i32;
    fn to_c(self) -> i32 {
        self.0.to_bits()
    }
    fn from_c(c: i32) -> Self {
        Fx(fixed::FixedI32::from_bits(c))
    }
}

impl CScalar for f32 {
    type C = f32;
    fn to_c(self) -> f32 {
        self
    }
    fn from_c(c: f32) -> Self {
        c
    }
}

fn estimates_to_c<S: CScalar>(e: &Estimates<S>) -> MassidEstimates<S::C> {
    MassidEstimates {
        delta_com_m: e.delta_com_m.map(S::to_c),
        theta_inertia: e.theta_inertia.map(S::to_c),
        unobservable_com: e.unobservable_com.map(u8::from),
        unobservable_inertia: e.unobservable_inertia.map(u8::from),
        status: e.status as u8,
        updates: e.updates,
        firings: e.firings,
        resets: e.resets,
        invalid: e.invalid.map_or(0, |v| v as u8),
        railed_samples: e.data.railed_samples,
        railed_firings: e.data.railed_firings,
        unresponsive_firings: e.data.unresponsive_firings,
    }
}

fn fill_params(out: *mut MassidSatelliteParams, p: &SatelliteParams) -> MassidStatus {
    // SAFETY: `out` is NULL or points to a writable MassidSatelliteParams (caller's contract).
    match unsafe { out.as_mut() } {
        Some(o) => {
            *o = MassidSatelliteParams::from(p);
            MassidStatus::Ok
        }
        None => MassidStatus::NullPointer,
    }
}

/// Fills `out` with the built-in SPH2 parameters (seed App. C, contract `satellites.md`).
///
/// # Safety
/// `out` is NULL or points to a writable `massid_satellite_params`.
#[no_mangle]
pub unsafe extern "C" fn massid_params_sph2(out: *mut MassidSatelliteParams) -> MassidStatus {
    fill_params(out, &SPH2)
}

/// Size of the Rust state inside a pipeline block, bytes (for reports and checks).
#[no_mangle]
pub extern "C" fn massid_pipeline_state_bytes(fixed_point: u8) -> u32 {
    let n = if fixed_point != 0 {
        size_of::<Pipeline<Q8_24>>()
    } else {
        size_of::<Pipeline<f32>>()
    };
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The C ABI's version (`MASSID_ABI_VERSION` in `massid_kernel.h`), raised with every change
/// of a struct's layout or of a function's meaning, so that a caller built against another
/// header refuses to run instead of misreading a struct: 1 the first ABI, 2
/// `massid_flight_id_settings.turn_weight`, 3 its `thrust_sigma_rel`, 4 its
/// `rate_noise_ma_root` and `rate_noise_ma_lag`, 5 `massid_fixed_flight_id` 36,864 bytes
/// (the closed windows waiting for their term, `flight_id::close`), 6 the identification's
/// windows of a 3-D craft also end at the coupled noise walk (`flight_id::window`; same
/// layout, other answers on fast-spinning craft), 7 `massid_f32_flight_id_reanchor`, and a
/// solve mid-window includes the open window (same layout, other answers mid-flight).
/// [`ABI_LAYOUTS`] records each version's struct sizes from version 3 on.
pub const ABI_VERSION: u32 = 7;

/// Per version (append-only: a new version adds a row, no row is edited), the sizes of the
/// ABI's types on a 64-bit host (`massid_type_size(0..8)` then `massid_craft_type_size(0..7)`;
/// every field is a fixed-width type, so a 32-bit target lays them out alike). A struct that
/// changes size without a new version no longer matches its version's row
/// ([`abi_layout_check`]). A change that keeps every size (fields reordered or retyped alike)
/// is not seen here: the version must still be raised by hand.
pub const ABI_LAYOUTS: [(u32, [u32; 15]); 5] = [
    (
        3,
        [
            388, 2, 76, 76, 96, 4096, 1024, 20, 460, 128, 2048, 20480, 188, 436, 32768,
        ],
    ),
    (
        4,
        [
            388, 2, 76, 76, 96, 4096, 1024, 20, 460, 128, 2048, 20480, 196, 436, 32768,
        ],
    ),
    (
        5,
        [
            388, 2, 76, 76, 96, 4096, 1024, 20, 460, 128, 2048, 20480, 196, 436, 36864,
        ],
    ),
    (
        6,
        [
            388, 2, 76, 76, 96, 4096, 1024, 20, 460, 128, 2048, 20480, 196, 436, 36864,
        ],
    ),
    (
        7,
        [
            388, 2, 76, 76, 96, 4096, 1024, 20, 460, 128, 2048, 20480, 196, 436, 36864,
        ],
    ),
];

/// Whether `sizes` ([`abi_sizes`]) are the layout recorded for `version` in [`ABI_LAYOUTS`]:
/// `Err` names the first type whose size differs, or says the version has no row.
pub fn abi_layout_check(version: u32, sizes: &[u32; 15]) -> Result<(), AbiMismatch> {
    let Some((_, recorded)) = ABI_LAYOUTS.iter().find(|(v, _)| *v == version) else {
        return Err(AbiMismatch::UnknownVersion(version));
    };
    match recorded.iter().zip(sizes).position(|(r, s)| r != s) {
        Some(i) => Err(AbiMismatch::Size {
            index: i,
            recorded: recorded.get(i).copied().unwrap_or(0),
            now: sizes.get(i).copied().unwrap_or(0),
        }),
        None => Ok(()),
    }
}

/// How a layout differs from its version's row ([`abi_layout_check`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AbiMismatch {
    /// No row for this version in [`ABI_LAYOUTS`].
    UnknownVersion(u32),
    /// Type `index` (in [`abi_sizes`]' order) has another size than recorded.
    Size {
        /// Position in [`abi_sizes`]' order.
        index: usize,
        /// Bytes recorded for the version.
        recorded: u32,
        /// Bytes now.
        now: u32,
    },
}

/// [`ABI_VERSION`], for a C caller to compare with the `MASSID_ABI_VERSION` it was built
/// against before any other call.
#[no_mangle]
pub extern "C" fn massid_abi_version() -> u32 {
    ABI_VERSION
}

/// Every ABI type's size as laid out here, in [`ABI_LAYOUTS`]' order.
pub fn abi_sizes() -> [u32; 15] {
    core::array::from_fn(|i| match u32::try_from(i) {
        Ok(k) if k < 8 => massid_type_size(k),
        Ok(k) => craft::massid_craft_type_size(k.saturating_sub(8)),
        Err(_) => 0,
    })
}

/// Size in bytes of an ABI type as Rust lays it out, so that C code can check the header:
/// 0 params, 1 tick report, 2 fixed estimates, 3 f32 estimates, 4 firing, 5 pipeline block,
/// 6 mixer block, 7 options; 0 for any other code.
#[no_mangle]
pub extern "C" fn massid_type_size(which: u32) -> u32 {
    let n = match which {
        0 => size_of::<MassidSatelliteParams>(),
        1 => size_of::<MassidTickReport>(),
        2 => size_of::<MassidEstimates<i32>>(),
        3 => size_of::<MassidEstimates<f32>>(),
        4 => size_of::<MassidFiring>(),
        5 => size_of::<MassidPipeline>(),
        6 => size_of::<MassidMixer>(),
        7 => size_of::<MassidOptions>(),
        _ => 0,
    };
    u32::try_from(n).unwrap_or(0)
}

/// Size of the Rust state inside a mixer block, bytes.
#[no_mangle]
pub extern "C" fn massid_mixer_state_bytes(fixed_point: u8) -> u32 {
    let n = if fixed_point != 0 {
        size_of::<Mixer<Q8_24>>()
    } else {
        size_of::<Mixer<f32>>()
    };
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The pipeline configuration for options `o` (`None`: the seed's); `None` if an option is
/// out of range.
fn config_for<S: CScalar>(
    sample_period_ms: u32,
    o: Option<&MassidOptions>,
) -> Option<PipelineConfig<S>> {
    let mut cfg = PipelineConfig::<S>::seed(sample_period_ms);
    let Some(o) = o else { return Some(cfg) };
    if o.change_detector != 0 {
        cfg.rls.detector = Some(DetectorConfig::standard());
    }
    if o.gyroscopic != 0 {
        if !o
            .gyro_bias_counts
            .iter()
            .all(|b| b.is_finite() && (0.0..=4095.0).contains(b))
        {
            return None;
        }
        cfg.gyro_bias_counts = Some(o.gyro_bias_counts);
    }
    let l = o.forgetting;
    if !(l.is_finite() && (0.0..=1.0).contains(&l)) {
        return None;
    }
    if l > 0.0 && l < 1.0 {
        cfg.rls.forgetting = Some(S::from_f32(l));
    }
    Some(cfg)
}

fn pipeline_init<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    params: *const MassidSatelliteParams,
    sample_period_ms: u32,
    options: *const MassidOptions,
) -> MassidStatus {
    if block.is_null() || params.is_null() {
        return MassidStatus::NullPointer;
    }
    if sample_period_ms == 0 {
        return MassidStatus::BadParameters;
    }
    // SAFETY: checked non-NULL; the caller passes a valid parameter struct.
    let p = SatelliteParams::from(unsafe { &*params });
    // SAFETY: NULL (the seed's settings) or a valid options struct (caller's contract).
    let Some(cfg) = config_for::<S>(sample_period_ms, unsafe { options.as_ref() }) else {
        return MassidStatus::BadParameters;
    };
    match Pipeline::<S>::new(&p, cfg) {
        Ok(pipe) => {
            // SAFETY: `block` is a non-NULL MassidPipeline (size/alignment asserted above).
            unsafe { store(block.cast::<u8>(), magic, pipe) };
            MassidStatus::Ok
        }
        Err(_) => MassidStatus::BadParameters,
    }
}

fn with_pipeline<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    f: impl FnOnce(&mut Pipeline<S>) -> MassidStatus,
) -> MassidStatus {
    if block.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL MassidPipeline; only a block written by `pipeline_init` has the magic.
    match unsafe { load::<Pipeline<S>>(block.cast::<u8>(), magic) } {
        Some(slot) => f(&mut slot.value),
        None => MassidStatus::NotInitialised,
    }
}

fn write_out<T>(out: *mut T, value: T) {
    // SAFETY: `out` is NULL (ignored) or points to a writable T (caller's contract).
    if let Some(o) = unsafe { out.as_mut() } {
        *o = value;
    }
}

fn pipeline_tick<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    gyro_counts: *const u16,
    thrusters: u16,
    report: *mut MassidTickReport,
) -> MassidStatus {
    if gyro_counts.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: checked non-NULL; the caller passes three gyro counts.
    let g = unsafe { gyro_counts.cast::<[u16; 3]>().read_unaligned() };
    with_pipeline::<S>(block, magic, |p| {
        write_out(report, MassidTickReport::from(p.tick(g, thrusters)));
        MassidStatus::Ok
    })
}

fn pipeline_tick_gap<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    report: *mut MassidTickReport,
) -> MassidStatus {
    with_pipeline::<S>(block, magic, |p| {
        write_out(report, MassidTickReport::from(p.tick_gap()));
        MassidStatus::Ok
    })
}

fn pipeline_tick_gaps<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    periods: u64,
    report: *mut MassidTickReport,
) -> MassidStatus {
    with_pipeline::<S>(block, magic, |p| {
        write_out(report, MassidTickReport::from(p.tick_gaps(periods)));
        MassidStatus::Ok
    })
}

fn pipeline_finish<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    status: *mut u8,
) -> MassidStatus {
    with_pipeline::<S>(block, magic, |p| {
        let s: PipelineStatus = p.finish();
        write_out(status, s as u8);
        MassidStatus::Ok
    })
}

fn pipeline_estimates<S: CScalar>(
    block: *mut MassidPipeline,
    magic: u32,
    out: *mut MassidEstimates<S::C>,
) -> MassidStatus {
    if out.is_null() {
        return MassidStatus::NullPointer;
    }
    with_pipeline::<S>(block, magic, |p| {
        write_out(out, estimates_to_c(&p.estimates()));
        MassidStatus::Ok
    })
}

fn mixer_store<S: CScalar>(
    block: *mut MassidMixer,
    magic: u32,
    params: *const MassidSatelliteParams,
    com_delta_m: [S; 3],
    period_ms: u32,
    min_pulse_ms: u32,
) -> MassidStatus {
    if block.is_null() || params.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: checked non-NULL; the caller passes a valid parameter struct.
    let p = SatelliteParams::from(unsafe { &*params });
    let cfg = MixerConfig {
        period_ms,
        min_pulse_ms,
        pressure_drop_n: S::from_f32(p.pressure_drop_n_per_extra),
    };
    match Mixer::<S>::new(&p, com_delta_m, cfg) {
        Ok(m) => {
            // SAFETY: `block` is a non-NULL MassidMixer (size/alignment asserted above).
            unsafe { store(block.cast::<u8>(), magic, m) };
            MassidStatus::Ok
        }
        Err(e) => MassidStatus::from(e),
    }
}

fn mixer_init<S: CScalar>(
    block: *mut MassidMixer,
    magic: u32,
    params: *const MassidSatelliteParams,
    com_delta_m: *const S::C,
    period_ms: u32,
    min_pulse_ms: u32,
) -> MassidStatus {
    let delta = if com_delta_m.is_null() {
        [S::ZERO; 3]
    } else {
        // SAFETY: non-NULL; the caller passes three values.
        unsafe { com_delta_m.cast::<[S::C; 3]>().read_unaligned() }.map(S::from_c)
    };
    mixer_store::<S>(block, magic, params, delta, period_ms, min_pulse_ms)
}

fn mixer_from_pipeline<S: CScalar>(
    block: *mut MassidMixer,
    magic: u32,
    params: *const MassidSatelliteParams,
    pipeline: *mut MassidPipeline,
    pipeline_magic: u32,
    period_ms: u32,
    min_pulse_ms: u32,
) -> MassidStatus {
    let mut delta = [S::ZERO; 3];
    let s = with_pipeline::<S>(pipeline, pipeline_magic, |p| {
        delta = p.estimates().delta_com_m;
        MassidStatus::Ok
    });
    if s != MassidStatus::Ok {
        return s;
    }
    mixer_store::<S>(block, magic, params, delta, period_ms, min_pulse_ms)
}

fn mixer_mix<S: CScalar>(
    block: *mut MassidMixer,
    magic: u32,
    force_n: *const S::C,
    torque_nm: *const S::C,
    out: *mut MassidFiring,
) -> MassidStatus {
    mix_block::<S, Mixer<S>, _, _>(
        block.cast::<u8>(),
        magic,
        force_n,
        torque_nm,
        out,
        |m, f, t| m.mix(f, t),
    )
}

/// The C side of every mixer block: checks the pointers, reads the command, finds the mixer
/// stored under `magic` and writes its firing (or the error's status). One copy for the
/// SPHERES mixer and the craft mixer.
fn mix_block<S: CScalar, M, F, O: From<F>>(
    block: *mut u8,
    magic: u32,
    force_n: *const S::C,
    torque_nm: *const S::C,
    out: *mut O,
    mix: impl FnOnce(&M, [S; 3], [S; 3]) -> Result<F, MixerError>,
) -> MassidStatus {
    if block.is_null() || force_n.is_null() || torque_nm.is_null() || out.is_null() {
        return MassidStatus::NullPointer;
    }
    // SAFETY: non-NULL; the caller passes three values each.
    let (f, t) = unsafe {
        (
            force_n.cast::<[S::C; 3]>().read_unaligned(),
            torque_nm.cast::<[S::C; 3]>().read_unaligned(),
        )
    };
    // SAFETY: non-NULL mixer block; only a block written by its init function has the magic.
    match unsafe { load::<M>(block, magic) } {
        Some(slot) => match mix(&slot.value, f.map(S::from_c), t.map(S::from_c)) {
            Ok(firing) => {
                write_out(out, O::from(firing));
                MassidStatus::Ok
            }
            Err(e) => MassidStatus::from(e),
        },
        None => MassidStatus::NotInitialised,
    }
}

macro_rules! flavour {
    ($S:ty, $C:ty, $pm:expr, $mm:expr,
     $init:ident, $init_with:ident, $tick:ident, $gap:ident, $gaps:ident, $finish:ident, $est:ident,
     $minit:ident, $mfrom:ident, $mix:ident) => {
        /// Initialises a pipeline block for `params` with the seed's settings at the given
        /// sample period (1 for 1 kHz).
        ///
        /// # Safety
        /// `block` is NULL or points to a writable, 8-aligned `massid_pipeline`; `params` is
        /// NULL or points to a readable `massid_satellite_params`.
        #[no_mangle]
        pub unsafe extern "C" fn $init(
            block: *mut MassidPipeline,
            params: *const MassidSatelliteParams,
            sample_period_ms: u32,
        ) -> MassidStatus {
            pipeline_init::<$S>(block, $pm, params, sample_period_ms, core::ptr::null())
        }

        /// `*_init` with options (change detector, forgetting, gyroscopic correction);
        /// `options` NULL is the seed's settings. Out-of-range options: `BadParameters`.
        ///
        /// # Safety
        /// As `*_init`; `options` is NULL or points to a readable `massid_options`.
        #[no_mangle]
        pub unsafe extern "C" fn $init_with(
            block: *mut MassidPipeline,
            params: *const MassidSatelliteParams,
            sample_period_ms: u32,
            options: *const MassidOptions,
        ) -> MassidStatus {
            pipeline_init::<$S>(block, $pm, params, sample_period_ms, options)
        }

        /// One sample period: three raw gyro counts and the commanded thruster word
        /// (bit i = thruster i+1). `report` may be NULL.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_pipeline`; `gyro_counts` is NULL or points
        /// to three readable `uint16_t`; `report` is NULL or points to a writable
        /// `massid_tick_report`.
        #[no_mangle]
        pub unsafe extern "C" fn $tick(
            block: *mut MassidPipeline,
            gyro_counts: *const u16,
            thrusters: u16,
            report: *mut MassidTickReport,
        ) -> MassidStatus {
            pipeline_tick::<$S>(block, $pm, gyro_counts, thrusters, report)
        }

        /// One sample period without a sample (telemetry gap). `report` may be NULL.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_pipeline`; `report` is NULL or points to a
        /// writable `massid_tick_report`.
        #[no_mangle]
        pub unsafe extern "C" fn $gap(
            block: *mut MassidPipeline,
            report: *mut MassidTickReport,
        ) -> MassidStatus {
            pipeline_tick_gap::<$S>(block, $pm, report)
        }

        /// `periods` sample periods without a sample, in O(1) whatever the count.
        ///
        /// # Safety
        /// As `*_tick_gap`.
        #[no_mangle]
        pub unsafe extern "C" fn $gaps(
            block: *mut MassidPipeline,
            periods: u64,
            report: *mut MassidTickReport,
        ) -> MassidStatus {
            pipeline_tick_gaps::<$S>(block, $pm, periods, report)
        }

        /// Ends the current firing (end of data); writes the pipeline status code if `status`
        /// is not NULL.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_pipeline`; `status` is NULL or points to a
        /// writable `uint8_t`.
        #[no_mangle]
        pub unsafe extern "C" fn $finish(
            block: *mut MassidPipeline,
            status: *mut u8,
        ) -> MassidStatus {
            pipeline_finish::<$S>(block, $pm, status)
        }

        /// Reads the current estimates.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_pipeline`; `out` is NULL or points to a
        /// writable estimates struct of this flavour.
        #[no_mangle]
        pub unsafe extern "C" fn $est(
            block: *mut MassidPipeline,
            out: *mut MassidEstimates<$C>,
        ) -> MassidStatus {
            pipeline_estimates::<$S>(block, $pm, out)
        }

        /// Builds a mixer for `params` with lever arms about the model CoM plus `com_delta_m`
        /// (three values, m; NULL for the model CoM).
        ///
        /// # Safety
        /// `block` is NULL or points to a writable, 8-aligned `massid_mixer`; `params` is NULL
        /// or points to a readable `massid_satellite_params`; `com_delta_m` is NULL or points
        /// to three readable values.
        #[no_mangle]
        pub unsafe extern "C" fn $minit(
            block: *mut MassidMixer,
            params: *const MassidSatelliteParams,
            com_delta_m: *const $C,
            period_ms: u32,
            min_pulse_ms: u32,
        ) -> MassidStatus {
            mixer_init::<$S>(block, $mm, params, com_delta_m, period_ms, min_pulse_ms)
        }

        /// Rebuilds a mixer from the pipeline's current CoM estimate (the seed's point:
        /// identified mass properties change the firing times).
        ///
        /// # Safety
        /// As `*_mixer_init`; `pipeline` is NULL or points to a `massid_pipeline`.
        #[no_mangle]
        pub unsafe extern "C" fn $mfrom(
            block: *mut MassidMixer,
            params: *const MassidSatelliteParams,
            pipeline: *mut MassidPipeline,
            period_ms: u32,
            min_pulse_ms: u32,
        ) -> MassidStatus {
            mixer_from_pipeline::<$S>(block, $mm, params, pipeline, $pm, period_ms, min_pulse_ms)
        }

        /// Mixes a force (N, 3 values) and torque (N m about the CoM, 3 values) command into
        /// integer-millisecond ON/OFF times.
        ///
        /// # Safety
        /// `block` is NULL or points to a `massid_mixer`; `force_n` and `torque_nm` are NULL or
        /// point to three readable values each; `out` is NULL or points to a writable
        /// `massid_firing`.
        #[no_mangle]
        pub unsafe extern "C" fn $mix(
            block: *mut MassidMixer,
            force_n: *const $C,
            torque_nm: *const $C,
            out: *mut MassidFiring,
        ) -> MassidStatus {
            mixer_mix::<$S>(block, $mm, force_n, torque_nm, out)
        }
    };
}

flavour!(
    Q8_24,
    i32,
    MAGIC_FIXED_PIPELINE,
    MAGIC_FIXED_MIXER,
    massid_fixed_init,
    massid_fixed_init_with,
    massid_fixed_tick,
    massid_fixed_tick_gap,
    massid_fixed_tick_gaps,
    massid_fixed_finish,
    massid_fixed_estimates,
    massid_fixed_mixer_init,
    massid_fixed_mixer_from_pipeline,
    massid_fixed_mix
);
flavour!(
    f32,
    f32,
    MAGIC_F32_PIPELINE,
    MAGIC_F32_MIXER,
    massid_f32_init,
    massid_f32_init_with,
    massid_f32_tick,
    massid_f32_tick_gap,
    massid_f32_tick_gaps,
    massid_f32_finish,
    massid_f32_estimates,
    massid_f32_mixer_init,
    massid_f32_mixer_from_pipeline,
    massid_f32_mix
);
