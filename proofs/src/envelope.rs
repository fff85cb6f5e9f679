//! The envelope: every input range the proofs assume, written down once.
//!
//! Each harness, the range analysis and the differential tests draw their inputs from
//! these constants and nothing else, so "proven under the envelope" has one meaning.
//! Where a number comes from the seed thesis (SPHERES, MIT SSL 2007) the doc comment says
//! where; where it is a margin around a seed value the margin is stated.
//! `proofs/README.md` carries the same table for readers.

/// Raw 12-bit gyro ADC counts (recording format: `gyro_x..z` are 0..4095; 0 and 4095 are
/// saturated readings and stay inside the envelope).
pub const GYRO_COUNTS: (u16, u16) = (0, 4095);
/// Thruster words: bit i-1 set means thruster i (1..12) open, so every 12-bit word.
pub const THRUSTER_WORDS: (u16, u16) = (0, 4095);
/// Number of thrusters (seed Table 3.2).
pub const THRUSTERS: usize = 12;
/// Gyro scale, counts per rad/s (seed App. D.1, `conversion = 1412.79`).
pub const GYRO_COUNTS_PER_RAD_S: f64 = 1412.79;
/// Gyro bias counts over the built-in satellites (contracts/satellites.md: 2048..2079).
pub const GYRO_BIAS_COUNTS: (f64, f64) = (2048.0, 2079.0);
/// Largest body rate a 12-bit reading can express: max |counts - bias| / scale
/// = 2079 / 1412.79 = 1.4716 rad/s (a 0 count with the 2079 bias).
pub const MAX_RATE_RAD_S: f64 = 2079.0 / GYRO_COUNTS_PER_RAD_S;
/// IMU sample rate (seed: 1 kHz gyro sampling for mass ID), seconds per sample.
pub const SAMPLE_PERIOD_S: f64 = 1e-3;
/// Samples in one firing (one constant thruster configuration): the seed's maneuvers fire
/// for one second at 1 kHz (Sec. 4.3: "pairs of thrusters were turned on for one second");
/// twice that as margin.
pub const SAMPLES_PER_FIRING: (u32, u32) = (1, 2000);
/// Firings in one run: the RGA parabolas gave tens of firings; the envelope allows 1000
/// (1000 firings x 1000 samples is the 10^6-tick divergence run).
pub const FIRINGS_PER_RUN: (u32, u32) = (1, 1000);
/// Thrust of one thruster, N (seed Table C.3 spans 0.1041..0.1336 N; brief: 0.05..0.2).
pub const THRUST_N: (f64, f64) = (0.05, 0.2);
/// Thrust lost per extra open thruster, N (seed flight code `0.0106f`); the envelope lets a
/// model file choose 0 (built-in models) up to this.
pub const PRESSURE_DROP_N: (f64, f64) = (0.0, 0.0106);
/// Components of a thrust direction unit vector (seed Table C.4 norms 0.997..1.000).
pub const DIRECTION_COMPONENT: (f64, f64) = (-1.0, 1.0);
/// The main (nominal-axis) component of a thrust direction, in magnitude (seed Table C.4:
/// the smallest over SPH1..SPH5 is 0.9957).
pub const DIRECTION_MAIN: (f64, f64) = (0.99, 1.0);
/// The off-axis components of a thrust direction (seed Table C.4: largest |.| is 0.0835).
pub const DIRECTION_OFF_AXIS: (f64, f64) = (-0.09, 0.09);
/// Thruster position components from the geometric centre, m (seed Table 3.2: |x| <= 0.0965).
pub const THRUSTER_POSITION_M: (f64, f64) = (-0.0965, 0.0965);
/// Principal moments of inertia, kg m^2 (seed Table C.2 spans 0.0194..0.0275; a proof mass
/// attached mid-flight may raise them; margin to 0.015..0.040).
pub const INERTIA_PRINCIPAL: (f64, f64) = (0.015, 0.040);
/// Products of inertia, kg m^2 (seed Table C.2: |I_ij| <= 3e-4; margin to 2e-3, which keeps
/// the inertia matrix diagonally dominant and so positive definite over the whole box).
pub const INERTIA_PRODUCT: (f64, f64) = (-0.002, 0.002);
/// Inverse-inertia entries implied by the inertia box: its eigenvalues lie in
/// [0.015 - 2*0.002, 0.040 + 2*0.002] = [0.011, 0.044] (Gershgorin), so the diagonal of
/// inv(I) lies in [1/0.044, 1/0.011] ...
pub const INV_INERTIA_DIAG: (f64, f64) = (1.0 / 0.044, 1.0 / 0.011);
/// ... and each off-diagonal in +-(1/0.011 - 1/0.044)/2 (see `range::inertia_inverse_box`).
pub const INV_INERTIA_OFFDIAG: (f64, f64) = (
    -(1.0 / 0.011 - 1.0 / 0.044) / 2.0,
    (1.0 / 0.011 - 1.0 / 0.044) / 2.0,
);
/// Centre-of-mass offset from the geometric centre, m, per axis (seed Table C.1: <= 1.7 mm;
/// the demo's proof mass can move it further: margin to +-30 mm).
pub const COM_OFFSET_M: (f64, f64) = (-0.03, 0.03);
/// Angular acceleration a firing can produce, rad/s^2 per axis:
/// |tau| <= 12 thrusters x 0.2 N x |r x d| (|r| <= 0.0965*sqrt(2) + 0.03*sqrt(3)) over
/// lambda_min(I) = 0.011; rounded up to 50 rad/s^2 (the seed's firings give ~4 rad/s^2).
pub const OMEGA_DOT_RAD_S2: (f64, f64) = (-50.0, 50.0);
/// Gyro measurement noise variance per axis, (rad/s)^2 (seed App. E.2 `R_inv` 1.5e4..7.2e4,
/// i.e. R 1.4e-5..6.6e-5; Fig. 4.5 and D.4: 2.3e-7..9.6e-7); margin 1e-8..1e-3.
pub const GYRO_NOISE_VAR: (f64, f64) = (1e-8, 1e-3);
/// Mixer control period, ms (SPHERES controls at 1..5 Hz; the flight code's mixer works in
/// integer ms; 1000 ms = the seed's one-second firings).
pub const MIXER_PERIOD_MS: (u32, u32) = (20, 1000);
/// Minimum pulse, ms: "minimum impulse bit of 10ms" (seed Fig. 3.2 text); the flight test
/// code uses `min_pulse = 20`. A period holds at least two minimum pulses (period >= 2 x min).
pub const MIN_PULSE_MS: (u32, u32) = (10, 20);
/// Mixer force command per body axis, N, and torque command per axis, N m: anything the
/// thrusters can do twice over (2 x 0.2 N x 4 thrusters per axis; torque x 0.1 m lever),
/// so saturation paths are inside the envelope.
pub const MIXER_FORCE_N: (f64, f64) = (-1.6, 1.6);
/// Torque command per axis, N m (see `MIXER_FORCE_N`).
pub const MIXER_TORQUE_NM: (f64, f64) = (-0.16, 0.16);

/// True when `x` lies in the closed range `r`.
pub fn within(x: f64, r: (f64, f64)) -> bool {
    r.0 <= x && x <= r.1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_bound_is_the_worst_count_over_the_worst_bias() {
        let worst = [
            GYRO_COUNTS.0 as f64 - GYRO_BIAS_COUNTS.1,
            GYRO_COUNTS.1 as f64 - GYRO_BIAS_COUNTS.0,
        ]
        .iter()
        .fold(0.0f64, |m, c| m.max(c.abs()));
        assert_eq!(worst / GYRO_COUNTS_PER_RAD_S, MAX_RATE_RAD_S);
    }

    #[test]
    fn inertia_box_is_positive_definite_by_gershgorin() {
        // Smallest Gershgorin disc edge over the box: diag min minus two products max.
        let lambda_min = INERTIA_PRINCIPAL.0 - 2.0 * INERTIA_PRODUCT.1;
        assert!(lambda_min > 0.0);
        assert!((1.0 / lambda_min - INV_INERTIA_DIAG.1).abs() < 1e-9);
    }

    #[test]
    fn omega_dot_bound_covers_every_firing_in_the_box() {
        let lever = 0.0965 * 2f64.sqrt() + COM_OFFSET_M.1 * 3f64.sqrt();
        let torque = THRUSTERS as f64 * THRUST_N.1 * lever;
        let lambda_min = INERTIA_PRINCIPAL.0 - 2.0 * INERTIA_PRODUCT.1;
        assert!(
            torque / lambda_min <= OMEGA_DOT_RAD_S2.1,
            "{}",
            torque / lambda_min
        );
    }
}
