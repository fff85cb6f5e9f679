//! Synthetic flights for the identification's unit tests: a configuration and a planar craft
//! whose thrusters fire one at a time, pushed sample by sample, and a strongly coloured rate
//! noise (no simulator in the kernel).
#![allow(
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects
)]

use super::solve::{SolveConfig, NP};
use super::sums::SumScalar;
use super::{consider, exact, FlightId, FlightIdConfig, SensorResponse};
use crate::craft::{Craft, Thruster};
use crate::scalar::Scalar;

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
        id.push(
            c(2e-3),
            [S::ZERO, S::ZERO, c(w + e)],
            true,
            super::command_of_wrench(wrench.map(c)),
        );
        // The torque about the true CoM, integrated exactly over the held interval.
        w += j_zz * (wrench[2] + wrench[3] * dc.1 - wrench[4] * dc.0) * 2e-3;
        after(id, k);
    }
}

/// The AR coefficients of [`coloured_yaw`]'s noise, and its rate's true parameter.
pub(crate) const COLOURED_PHI: [f64; 2] = [0.66, 0.33];
/// See [`COLOURED_PHI`].
pub(crate) const COLOURED_THETA: f64 = 0.2;

/// One window of `n` samples `(z, y)`: a drifting yaw torque's drive `z` (a changing sign, 4 ms
/// steps) and a rate `0.2 z + e`, `e` an AR(0.66, 0.33) noise of 1e-4 rad/s innovations (a gyro
/// filtered far below the sampling rate, as on random planar craft 73009).
pub(crate) fn coloured_yaw(n: usize) -> impl Iterator<Item = (f64, f64)> {
    let (mut z, mut e1, mut e2, mut seed) = (0.0f64, 0.0f64, 0.0f64, 7u64);
    (0..n).map(move |k| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let uniform = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        z += if (k / 700) % 3 == 1 { -0.02 } else { 0.03 } * 0.004;
        let e = COLOURED_PHI[0] * e1 + COLOURED_PHI[1] * e2 + 3.5e-4 * uniform;
        (e2, e1) = (e1, e);
        (z, COLOURED_THETA * z + e)
    })
}

/// The whitened cost at [`coloured_yaw`]'s true parameter, `u^T W u`, from `flight`'s sums of
/// its samples (axis z, drive component 2) under its AR noise model.
pub(crate) fn coloured_cost_of<S: crate::scalar::Scalar>(
    flight: &super::sums::FlightSums<S>,
) -> f64 {
    use super::solve::{ar_weights, quad, weighted, NV};
    use super::sums::NZ;
    let mut u = [S::ZERO; NV];
    u[2] = S::from_f32(-COLOURED_THETA as f32);
    u[NZ] = S::ONE;
    let k = ar_weights(&COLOURED_PHI.map(|v| S::from_f32(v as f32)));
    f64::from(quad(&weighted(flight, 2, &k), &u, &u).to_f32())
}

/// Five thrusters of a 3-D craft (three open at once take a pressure drop).
pub(crate) fn five_thrusters<S: Scalar>() -> Craft<S> {
    five_thrusters_with_drop(0.01)
}

/// [`five_thrusters`] with a pressure drop of `drop_n` per extra open thruster.
pub(crate) fn five_thrusters_with_drop<S: Scalar>(drop_n: f32) -> Craft<S> {
    let t = |pos_m: [f32; 3], dir: [f32; 3], thrust_n: f32| Thruster {
        pos_m,
        dir,
        thrust_n,
    };
    let thrusters = [
        t([0.1, 0.1, 0.0], [1.0, 0.0, 0.0], 0.2),
        t([0.1, -0.1, 0.05], [0.0, 1.0, 0.0], 0.25),
        t([-0.1, 0.0, -0.05], [0.0, -1.0, 0.0], 0.2),
        t([0.0, 0.1, 0.1], [0.0, 0.0, 1.0], 0.3),
        t([0.1, 0.1, 0.0], [-1.0, 0.0, 0.0], 0.15),
    ];
    Craft::new(&thrusters, [0.01, -0.02, 0.0], drop_n).unwrap()
}

/// `n` thruster words of [`five_thrusters`]: runs of 1-9 samples of a few words that hold,
/// change and come back.
pub(crate) fn words(n: u32) -> impl Iterator<Item = u16> {
    let seq = [
        0b00001u16, 0b00011, 0b00011, 0b10110, 0, 0b01000, 0b00001, 0b11111,
    ];
    (0..n).map(move |k| seq[((k * k / 7 + k / 3) % 8) as usize])
}
