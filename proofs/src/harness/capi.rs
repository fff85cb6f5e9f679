//! The C ABI (`kernel/src/capi.rs`, feature `capi`): every entry point, with NULL pointers in
//! any argument, blocks never initialised, blocks initialised for the other number type,
//! invalid parameters (NaN, zero or singular inertia, zero period) and then any sequence of
//! gyro counts and thruster words, returns a status and never panics; a successful tick
//! reports codes within the documented ranges; the mixer's firings satisfy the invariants.

use super::{draw, Harness};
use crate::cover;
use crate::engine::{any_bool, any_f64_in, any_in};
use crate::envelope as env;
use massid_kernel::capi::*;
use massid_kernel::model::SatelliteParams;

/// An all-zero block (never initialised: no magic word).
fn zeroed<T>() -> Box<T> {
    // SAFETY: the blocks are plain byte arrays (`#[repr(C)]` structs of `[u8; N]`), for which
    // all-zero is a valid value.
    unsafe { Box::new(core::mem::zeroed()) }
}

fn maybe_null<T>(p: *mut T) -> *mut T {
    if any_in(0u8, 5) == 0 {
        core::ptr::null_mut()
    } else {
        p
    }
}

fn params() -> MassidSatelliteParams {
    let p: SatelliteParams = draw::params_or_sph2();
    let mut c = MassidSatelliteParams::from(&p);
    match any_in(0u8, 7) {
        0 => c.thrust_n[any_in(0usize, 11)] = f32::NAN,
        1 => c.inertia_kgm2 = [0.0; 6],
        2 => c.inertia_kgm2 = [0.02, 0.02, 0.02, 0.02, 0.02, 0.02], // singular
        3 => c.thrust_dir[any_in(0usize, 11)][any_in(0usize, 2)] = f32::INFINITY,
        _ => {}
    }
    c
}

fn c_abi_any_use(fixed: bool) {
    // SAFETY: every pointer passed is NULL or to a live local of the right type and size.
    unsafe {
        let mut block: Box<MassidPipeline> = zeroed();
        let mut other: Box<MassidPipeline> = zeroed();
        let p = params();
        let period = [0u32, 1, 1, 1, 10, 20][any_in(0usize, 5)];
        let (init, tick, gap, finish, est): (
            unsafe extern "C" fn(
                *mut MassidPipeline,
                *const MassidSatelliteParams,
                u32,
            ) -> MassidStatus,
            unsafe extern "C" fn(
                *mut MassidPipeline,
                *const u16,
                u16,
                *mut MassidTickReport,
            ) -> MassidStatus,
            unsafe extern "C" fn(*mut MassidPipeline, *mut MassidTickReport) -> MassidStatus,
            unsafe extern "C" fn(*mut MassidPipeline, *mut u8) -> MassidStatus,
            bool,
        ) = if fixed {
            (
                massid_fixed_init,
                massid_fixed_tick,
                massid_fixed_tick_gap,
                massid_fixed_finish,
                true,
            )
        } else {
            (
                massid_f32_init,
                massid_f32_tick,
                massid_f32_tick_gap,
                massid_f32_finish,
                false,
            )
        };
        // The other flavour's block must be refused.
        let other_init: unsafe extern "C" fn(
            *mut MassidPipeline,
            *const MassidSatelliteParams,
            u32,
        ) -> MassidStatus = if fixed {
            massid_f32_init
        } else {
            massid_fixed_init
        };
        let sph2 = MassidSatelliteParams::from(&massid_kernel::model::SPH2);
        assert_eq!(other_init(&mut *other, &sph2, 1), MassidStatus::Ok);
        let mut report = MassidTickReport {
            event: 0,
            status: 0,
        };
        let counts = [2070u16; 3];
        assert_eq!(
            tick(&mut *other, counts.as_ptr(), 1, &mut report),
            MassidStatus::NotInitialised
        );
        // Before init: refused, never read.
        if any_bool() {
            assert_eq!(
                tick(&mut *block, counts.as_ptr(), 1, &mut report),
                MassidStatus::NotInitialised
            );
            cover!(true, "uninitialised refused");
        }
        let params_ptr: *const MassidSatelliteParams = if any_in(0u8, 5) == 0 {
            core::ptr::null()
        } else {
            &p
        };
        let st = init(maybe_null(&mut *block), params_ptr, period);
        if st != MassidStatus::Ok {
            cover!(st == MassidStatus::BadParameters, "bad parameters refused");
            cover!(st == MassidStatus::NullPointer, "null refused");
            assert!(
                matches!(st, MassidStatus::NullPointer | MassidStatus::BadParameters),
                "init: {st:?}"
            );
            return;
        }
        cover!(true, "initialised");
        let n = any_in(1u32, 60);
        let mut word = 0u16;
        for t in 0..n {
            if t % 15 == 0 {
                word = draw::word();
            }
            let c = draw::counts();
            let cptr: *const u16 = if any_in(0u8, 9) == 0 {
                core::ptr::null()
            } else {
                c.as_ptr()
            };
            let rptr = if any_bool() {
                &mut report as *mut _
            } else {
                core::ptr::null_mut()
            };
            let st = if any_in(0u8, 9) == 0 {
                gap(&mut *block, rptr)
            } else {
                tick(&mut *block, cptr, word, rptr)
            };
            if cptr.is_null() && st != MassidStatus::Ok {
                assert_eq!(st, MassidStatus::NullPointer);
                cover!(true, "null counts refused");
                continue;
            }
            assert_eq!(st, MassidStatus::Ok, "tick: {st:?}");
            if !rptr.is_null() {
                assert!(
                    report.event <= 6 && report.status <= 6,
                    "codes out of range: {report:?}"
                );
            }
        }
        let mut code = 0u8;
        assert_eq!(finish(&mut *block, &mut code), MassidStatus::Ok);
        assert!(code <= 6);
        assert_eq!(
            finish(&mut *block, core::ptr::null_mut()),
            MassidStatus::Ok,
            "finish with a NULL status is allowed"
        );
        if est {
            let mut out: MassidEstimates<i32> = core::mem::zeroed();
            assert_eq!(
                massid_fixed_estimates(&mut *block, &mut out),
                MassidStatus::Ok
            );
            assert_eq!(
                massid_fixed_estimates(&mut *block, core::ptr::null_mut()),
                MassidStatus::NullPointer
            );
        } else {
            let mut out: MassidEstimates<f32> = core::mem::zeroed();
            assert_eq!(
                massid_f32_estimates(&mut *block, &mut out),
                MassidStatus::Ok
            );
        }
    }
}

fn c_abi_mixer(fixed: bool) {
    // SAFETY: every pointer passed is NULL or to a live local of the right type and size.
    unsafe {
        let mut block: Box<MassidMixer> = zeroed();
        let p = MassidSatelliteParams::from(&draw::params_or_sph2());
        let period = any_in(env::MIXER_PERIOD_MS.0, env::MIXER_PERIOD_MS.1);
        let min = any_in(0u32, env::MIN_PULSE_MS.1);
        let mut out = MassidFiring {
            on_ms: [0; 12],
            off_ms: [0; 12],
        };
        let f = [0; 3].map(|_| any_f64_in(env::MIXER_FORCE_N.0, env::MIXER_FORCE_N.1) * 0.2);
        let t = [0; 3].map(|_| any_f64_in(env::MIXER_TORQUE_NM.0, env::MIXER_TORQUE_NM.1) * 0.2);
        let (st_init, st_mix) = if fixed {
            let com: Option<[i32; 3]> =
                any_bool().then(|| [0; 3].map(|_| (any_f64_in(-0.03, 0.03) * 16_777_216.0) as i32));
            let st = massid_fixed_mixer_init(
                &mut *block,
                &p,
                com.as_ref().map_or(core::ptr::null(), |c| c.as_ptr()),
                period,
                min,
            );
            let fq = f.map(|v| (v * 16_777_216.0) as i32);
            let tq = t.map(|v| (v * 16_777_216.0) as i32);
            (
                st,
                massid_fixed_mix(&mut *block, fq.as_ptr(), tq.as_ptr(), &mut out),
            )
        } else {
            let st = massid_f32_mixer_init(&mut *block, &p, core::ptr::null(), period, min);
            let ff = f.map(|v| v as f32);
            let tf = t.map(|v| v as f32);
            (
                st,
                massid_f32_mix(&mut *block, ff.as_ptr(), tf.as_ptr(), &mut out),
            )
        };
        if st_init != MassidStatus::Ok {
            cover!(min == 0 || period < 2 * min, "bad period refused");
            assert_eq!(
                st_mix,
                MassidStatus::NotInitialised,
                "mix on a refused mixer"
            );
            return;
        }
        if st_mix == MassidStatus::Ok {
            cover!(true, "mixed");
            let firing = massid_kernel::mixer::Firing {
                on_ms: out.on_ms,
                off_ms: out.off_ms,
            };
            super::mixer::check_firing(&firing, period, min);
        }
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn c_abi_pipeline_fixed() {
    c_abi_any_use(true)
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn c_abi_pipeline_f32() {
    c_abi_any_use(false)
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn c_abi_mixer_fixed() {
    c_abi_mixer(true)
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn c_abi_mixer_f32() {
    c_abi_mixer(false)
}

const PIPE: &[&str] = &[
    "initialised",
    "bad parameters refused",
    "null refused",
    "uninitialised refused",
    "null counts refused",
];
pub const HARNESSES: [Harness; 4] = [
    Harness {
        name: "c_abi_pipeline_fixed",
        body: c_abi_pipeline_fixed,
        covers: PIPE,
        random_runs: 3_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "c_abi_pipeline_f32",
        body: c_abi_pipeline_f32,
        covers: PIPE,
        random_runs: 3_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "c_abi_mixer_fixed",
        body: c_abi_mixer_fixed,
        covers: &["mixed", "bad period refused"],
        random_runs: 3_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "c_abi_mixer_f32",
        body: c_abi_mixer_f32,
        covers: &["mixed", "bad period refused"],
        random_runs: 3_000,
        exhaustive_limit: None,
    },
];
