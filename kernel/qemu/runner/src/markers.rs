//! Marker functions for instruction counting in a QEMU trace.
//!
//! `massid_mark_begin` and `massid_mark_end` bracket one kernel call; the `massid_mark_kind_*`
//! function called right after says what the call did. The trace counter
//! (`massid-qemu-host count`) finds these symbols in the ELF, counts executed instructions
//! from the first instruction of `begin` to the first of `end`, and files the count under the
//! kind that follows. Each function stores a different constant, so LLVM cannot merge them
//! into one address; `#[inline(never)]` + `#[no_mangle]` keep them as real, named calls.
use core::ptr::{addr_of_mut, write_volatile};
use massid_kernel::pipeline::DeferredStage;

static mut SINK: u32 = 0;

macro_rules! marker {
    ($(#[$doc:meta])* $name:ident = $value:expr) => {
        $(#[$doc])*
        #[no_mangle]
        #[inline(never)]
        pub extern "C" fn $name() {
            // SAFETY: a volatile store to a private static; the firmware is single-threaded and
            // the value is never read (it only makes the function bodies distinct).
            unsafe { write_volatile(addr_of_mut!(SINK), $value) }
        }
    };
}

marker!(/// Start of a measured call.
    massid_mark_begin = 0x4d42_0001);
marker!(/// End of a measured call.
    massid_mark_end = 0x4d42_0002);
marker!(/// The empty bracket measured once at start-up (marker overhead).
    massid_mark_kind_calibration = 0x4d42_0010);
marker!(/// A tick with thrusters off or in the valve transient.
    massid_mark_kind_idle = 0x4d42_0011);
marker!(/// A Kalman-filter tick during the batch firings (no RLS measurement).
    massid_mark_kind_kf = 0x4d42_0012);
marker!(/// A Kalman-filter tick that also folds an RLS measurement in (firing 3 on).
    massid_mark_kind_kf_rls = 0x4d42_0013);
marker!(/// A tick at the end of a firing that solves the batch or RLS estimate (LU).
    massid_mark_kind_solve = 0x4d42_0014);
marker!(/// A mixer call (force/torque command to thruster on/off times).
    massid_mark_kind_mixer = 0x4d42_0015);
marker!(/// Anything else (overflow events).
    massid_mark_kind_other = 0x4d42_0016);
marker!(/// One sample of the output-error identification (`massid_kernel::flight_id`): the
    /// thruster word's wrench and the push into the sums.
    massid_mark_kind_flight_id_push = 0x4d42_001a);
marker!(/// One sample of the output-error identification for the air-bearing craft (planar, 8).
    massid_mark_kind_flight_id_push_airbearing = 0x4d42_001b);
marker!(/// One sample of the output-error identification for the 16-thruster free-flyer.
    massid_mark_kind_flight_id_push_freeflyer16 = 0x4d42_001c);
marker!(/// The output-error identification's window close (`FlightId::finish`: the open window's
    /// initial-rate terms into the flight's sums), SPHERES.
    massid_mark_kind_flight_id_close = 0x4d42_001d);
marker!(/// The window close for the air-bearing craft (planar, 8).
    massid_mark_kind_flight_id_close_airbearing = 0x4d42_0043);
marker!(/// The window close for the 16-thruster free-flyer.
    massid_mark_kind_flight_id_close_freeflyer16 = 0x4d42_0044);
marker!(/// One sample for the air-bearing craft with motion-capture rates (the moving-average
    /// filter on: `massid_kernel::flight_id::ma_prefilter`).
    massid_mark_kind_flight_id_push_airbearing_mocap = 0x4d42_0045);
marker!(/// The window close for the air-bearing craft with motion-capture rates.
    massid_mark_kind_flight_id_close_airbearing_mocap = 0x4d42_0046);
marker!(/// A tick where the thruster word changed without a solve (firing edge: KF reset, batch row).
    massid_mark_kind_edge = 0x4d42_0017);
marker!(/// A mixer rebuild from the current CoM estimate (mixing matrix, pseudo-inverse by LU).
    massid_mark_kind_mixer_build = 0x4d42_0018);
marker!(/// A tick shortly after a thruster-word change (thrusters off or in the valve transient),
    /// where the pipeline runs the ended firing's deferred stages one per tick.
    massid_mark_kind_deferred = 0x4d42_0019);
marker!(/// A deferred tick that ran the `Measure` stage (the firing's final estimate).
    massid_mark_kind_deferred_measure = 0x4d42_0031);
marker!(/// A deferred tick that ran the `Aggregate` stage (the aggregate measurement).
    massid_mark_kind_deferred_aggregate = 0x4d42_0032);
marker!(/// A deferred tick that ran the `FoldCom` stage (CoM information).
    massid_mark_kind_deferred_fold_com = 0x4d42_0037);
marker!(/// A deferred tick that ran the `PlanInertia` stage (the inverse-inertia add's exponent).
    massid_mark_kind_deferred_plan_inertia = 0x4d42_0038);
marker!(/// A deferred tick that ran the `FoldInertia` stage (inverse-inertia information).
    massid_mark_kind_deferred_fold_inertia = 0x4d42_0033);
marker!(/// A deferred tick that ran the `Detect` stage (change test, first rows).
    massid_mark_kind_deferred_detect = 0x4d42_003a);
marker!(/// A deferred tick that ran the `DetectFinish` stage (change test, last row and test).
    massid_mark_kind_deferred_detect_finish = 0x4d42_003b);
marker!(/// A deferred tick that ran the `MergeCom` stage (forgetting, CoM merge and solve).
    massid_mark_kind_deferred_merge_com = 0x4d42_0034);
marker!(/// A deferred tick that ran the `MergeInertia` stage.
    massid_mark_kind_deferred_merge_inertia = 0x4d42_0035);
marker!(/// A deferred tick that ran the `SolveCom` stage (CoM LU solve).
    massid_mark_kind_deferred_solve_com = 0x4d42_0036);
marker!(/// A deferred tick that ran the `FactorInertia` stage (inverse-inertia LU factorisation).
    massid_mark_kind_deferred_factor_inertia = 0x4d42_0039);
marker!(/// One mix by the any-craft mixer for SPHERES (the seed's pair rules).
    massid_mark_kind_craft_mixer_sph2 = 0x4d42_0040);
marker!(/// One mix by the any-craft mixer for the 8-thruster planar air-bearing craft.
    massid_mark_kind_craft_mixer_airbearing = 0x4d42_0041);
marker!(/// One mix by the any-craft mixer for the 16-thruster 3-D free-flyer.
    massid_mark_kind_craft_mixer_freeflyer16 = 0x4d42_0042);
marker!(/// The following calls run the fixed-point kernel.
    massid_mark_flavour_fixed = 0x4d42_0020);
marker!(/// The following calls run the f32 kernel.
    massid_mark_flavour_f32 = 0x4d42_0021);

/// What a measured call did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Marker overhead.
    Calibration,
    /// Thrusters off / transient.
    Idle,
    /// Kalman filter only.
    Kf,
    /// Kalman filter + RLS measurement.
    KfRls,
    /// End of firing: batch or RLS solve.
    Solve,
    /// Mixer.
    Mixer,
    /// Other (overflow events).
    Other,
    /// Firing edge without a solve.
    Edge,
    /// Mixer rebuild.
    MixerBuild,
    /// Tick within [`DEFERRED_TICKS`] after a word change (deferred end-of-firing stages)
    /// that ran none of them.
    Deferred,
    /// A tick that ran one deferred end-of-firing stage (other than the final solve, which
    /// is [`Kind::Solve`]).
    Stage(DeferredStage),
    /// One sample of the output-error identification (SPHERES).
    FlightIdPush,
    /// One sample of the output-error identification for the air-bearing craft.
    FlightIdPushAirbearing,
    /// One sample of the output-error identification for the 16-thruster free-flyer.
    FlightIdPushFreeflyer16,
    /// The identification's window close (SPHERES).
    FlightIdClose,
    /// The window close for the air-bearing craft.
    FlightIdCloseAirbearing,
    /// The window close for the 16-thruster free-flyer.
    FlightIdCloseFreeflyer16,
    /// One sample for the air-bearing craft with motion-capture rates.
    FlightIdPushAirbearingMocap,
    /// The window close for the air-bearing craft with motion-capture rates.
    FlightIdCloseAirbearingMocap,
    /// One mix by `massid_kernel::craft_mixer` for SPHERES.
    CraftMixerSph2,
    /// One mix by `massid_kernel::craft_mixer` for the air-bearing craft.
    CraftMixerAirbearing,
    /// One mix by `massid_kernel::craft_mixer` for the 16-thruster free-flyer.
    CraftMixerFreeflyer16,
}

/// Ticks after a thruster-word change counted as [`Kind::Deferred`] (fewer than the 10 ms
/// valve transient, so no Kalman update falls in them).
pub const DEFERRED_TICKS: u32 = 8;

/// Marks the start of a measured call.
#[inline(always)]
pub fn begin() {
    massid_mark_begin();
}

/// Marks the end of a measured call.
#[inline(always)]
pub fn end() {
    massid_mark_end();
}

/// Files the call just measured under `k`.
#[inline(always)]
pub fn kind(k: Kind) {
    match k {
        Kind::Calibration => massid_mark_kind_calibration(),
        Kind::Idle => massid_mark_kind_idle(),
        Kind::Kf => massid_mark_kind_kf(),
        Kind::KfRls => massid_mark_kind_kf_rls(),
        Kind::Solve => massid_mark_kind_solve(),
        Kind::Mixer => massid_mark_kind_mixer(),
        Kind::Other => massid_mark_kind_other(),
        Kind::Edge => massid_mark_kind_edge(),
        Kind::MixerBuild => massid_mark_kind_mixer_build(),
        Kind::Deferred => massid_mark_kind_deferred(),
        Kind::Stage(DeferredStage::Measure) => massid_mark_kind_deferred_measure(),
        Kind::Stage(DeferredStage::Aggregate) => massid_mark_kind_deferred_aggregate(),
        Kind::Stage(DeferredStage::FoldCom) => massid_mark_kind_deferred_fold_com(),
        Kind::Stage(DeferredStage::PlanInertia) => massid_mark_kind_deferred_plan_inertia(),
        Kind::Stage(DeferredStage::FoldInertia) => massid_mark_kind_deferred_fold_inertia(),
        Kind::Stage(DeferredStage::Detect) => massid_mark_kind_deferred_detect(),
        Kind::Stage(DeferredStage::DetectFinish) => massid_mark_kind_deferred_detect_finish(),
        Kind::Stage(DeferredStage::MergeCom) => massid_mark_kind_deferred_merge_com(),
        Kind::Stage(DeferredStage::MergeInertia) => massid_mark_kind_deferred_merge_inertia(),
        Kind::Stage(DeferredStage::SolveCom) => massid_mark_kind_deferred_solve_com(),
        Kind::Stage(DeferredStage::FactorInertia) => massid_mark_kind_deferred_factor_inertia(),
        // the final stage reports `TickEvent::Solved`: filed as `Kind::Solve`
        Kind::Stage(DeferredStage::SolveInertia) => massid_mark_kind_solve(),
        Kind::FlightIdPush => massid_mark_kind_flight_id_push(),
        Kind::FlightIdPushAirbearing => massid_mark_kind_flight_id_push_airbearing(),
        Kind::FlightIdPushFreeflyer16 => massid_mark_kind_flight_id_push_freeflyer16(),
        Kind::FlightIdClose => massid_mark_kind_flight_id_close(),
        Kind::FlightIdCloseAirbearing => massid_mark_kind_flight_id_close_airbearing(),
        Kind::FlightIdCloseFreeflyer16 => massid_mark_kind_flight_id_close_freeflyer16(),
        Kind::FlightIdPushAirbearingMocap => massid_mark_kind_flight_id_push_airbearing_mocap(),
        Kind::FlightIdCloseAirbearingMocap => massid_mark_kind_flight_id_close_airbearing_mocap(),
        Kind::CraftMixerSph2 => massid_mark_kind_craft_mixer_sph2(),
        Kind::CraftMixerAirbearing => massid_mark_kind_craft_mixer_airbearing(),
        Kind::CraftMixerFreeflyer16 => massid_mark_kind_craft_mixer_freeflyer16(),
    }
}

/// Says which kernel the following calls run (`true`: fixed point).
#[inline(always)]
pub fn flavour(fixed: bool) {
    if fixed {
        massid_mark_flavour_fixed()
    } else {
        massid_mark_flavour_f32()
    }
}
