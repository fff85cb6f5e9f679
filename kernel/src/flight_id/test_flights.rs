//! Synthetic flights for the identification's unit tests: a configuration and a planar craft
//! whose thrusters fire one at a time, pushed sample by sample (no simulator in the kernel).
#![allow(
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects
)]

use super::solve::{SolveConfig, NP};
use super::sums::SumScalar;
use super::{consider, exact, FlightId, FlightIdConfig, SensorResponse};

/// A 3-D craft at 1 kHz, windows of 700 samples, the gyroscopic term in, every term free.
pub(crate) fn config<S: SumScalar>(j_nominal: [f32; 6]) -> FlightIdConfig<S> {
    let c = S::from_f32;
    FlightIdConfig {
        period_s: c(1e-3),
        sensor: SensorResponse::Point,
        rate_noise_ma_root: S::ZERO,
        rate_noise_ma_lag: 1,
        delay_periods: 0.0,
        cut_at_changes: false,
        max_window: 700,
        max_window_turn_rad: c(f32::INFINITY),
        turn_weight: [S::ONE; 3],
        turn_window: 0,
        max_window_walk: c(f32::INFINITY),
        skip: 2,
        solve: SolveConfig {
            j_nominal: j_nominal.map(c),
            free: [true; NP],
            axes: [true; 3],
            gyroscopic: true,
            max_noise_order: 2,
            scale: [S::ONE; NP],
        },
        envelope: exact::Envelope::of_craft([S::ONE; 6]),
        thrust: consider::ThrustUncertainty::none(),
    }
}

/// A planar craft at 500 Hz, one window, the model's Izz `izz` (the craft's is 0.1), Izz and
/// the CoM free.
pub(crate) fn planar<S: SumScalar>(izz: f32) -> FlightIdConfig<S> {
    let mut cfg = config::<S>([1.0, 1.0, 1.0 / izz, 0.0, 0.0, 0.0]);
    cfg.period_s = S::from_f32(2e-3);
    cfg.max_window = 100_000;
    cfg.solve.free = core::array::from_fn(|m| matches!(m, 2 | 6 | 7));
    cfg.solve.axes = [false, false, true];
    cfg.solve.gyroscopic = false;
    cfg
}

/// A planar thruster: position (m), direction, thrust (N).
pub(crate) type PlanarThruster = ((f64, f64), (f64, f64), f64);

/// Pushes `n` samples of a planar craft (Izz 0.1, CoM (10, -20) mm from the model's) whose
/// `thrusters` fire in turn, 100 samples each, its yaw rate measured with AR(`phi`) noise
/// (innovations uniform, 0.027 rad/s wide, from generator seed `seed`); `after(id, k)` runs
/// after sample `k`.
pub(crate) fn fly_planar<S: SumScalar>(
    id: &mut FlightId<S>,
    thrusters: &[PlanarThruster],
    n: u32,
    (phi, seed): (f64, u64),
    mut after: impl FnMut(&mut FlightId<S>, u32),
) {
    let c = |v: f64| S::from_f32(v as f32);
    let (j_zz, dc) = (10.0f64, (0.01f64, -0.02f64));
    let (mut w, mut e, mut x) = (0.0f64, 0.0f64, seed);
    for k in 0..n {
        let ((rx, ry), (fx, fy), f) = thrusters[(k / 100) as usize % thrusters.len()];
        let wrench = [0.0, 0.0, f * (rx * fy - ry * fx), f * fx, f * fy, 0.0];
        x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        e = phi * e + 0.027 * ((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
        id.push(c(2e-3), [S::ZERO, S::ZERO, c(w + e)], true, wrench.map(c));
        // The torque about the true CoM, integrated exactly over the held interval.
        w += j_zz * (wrench[2] + wrench[3] * dc.1 - wrench[4] * dc.0) * 2e-3;
        after(id, k);
    }
}
