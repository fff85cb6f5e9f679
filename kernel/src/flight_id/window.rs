//! Where a window of the onboard identification ends, and why its limits follow the craft.
//!
//! The kernel takes Euler's gyroscopic products of the *measured* rates and has no variational
//! equation, so how a parameter error moves the rate through the gyroscopic coupling is not in
//! its model. Over a window that spans much coupling this miscalibrates the products of inertia
//! (RMS error/sigma up to 1.55 on SPHERES rga12 at 60 s). The limits below were measured on
//! SPHERES (seeds 740-799, `identification_mc 60 740 FILTER f32`): windows up to 60 s, cut after
//! 8 s once the craft turned 4 rad (rga12 RMS 1.25, combo 1.17, closed loop 1.26; sigma
//! 0.95-1.01x the reference's on single and closed loop, 1.3-1.95x on rga12, combo and
//! random-pwm; windows cut at 8 s: sigma 1.03-2.29x; 60 s with no turn limit: RMS 1.55).
//!
//! What matters is not the turn but the coupling it brings: the rate Jacobian of Euler's
//! equation, `-J([w]x I - [I w]x)`, is linear in the rate, so a turn about axis `a` couples the
//! axes at the rate `kappa_a |w_a|` ([`coupling`]). A craft whose inertia couples no more than
//! SPHERES' keeps the SPHERES limits (a near-spherical free-flyer, the planar craft); for one
//! that couples more (a 3U cubesat: Izz a fifth of Ixx, kappa 3.56x SPHERES'), each axis' turn
//! counts `kappa_a / kappa_SPHERES` times and the 8 s floor shrinks by the largest of those
//! ratios ([`turn_weights`]). Before this rule the f32 kernel on that cubesat gave products with
//! RMS error/sigma up to 1.39 and 2-sigma coverage 83 % with status `ok` (README, 100 flights).

//!
//! The turn rule leaves windows shorter than the floor alone, and a craft that spins fast
//! turns far within it. There a second limit holds whatever the window's length, the
//! *coupled noise walk* ([`walk_weights`]): the measured rates in Euler's products carry the
//! rate noise `e`, `w_m x I w_m - w x I w ~ w x I e + e x I w`, which the window integrates
//! into a random walk in its residual. Its variance after the window, in units of the rate
//! noise's, is about `dt integral |kappa w|^2 dt` (white noise at the sample period `dt`):
//! the AR noise model does not describe it, and it correlates with the products it rides on.
//! A random 3-D craft spinning at 5-8 rad/s, sampled at 1 kHz (seed 70013, walk 0.13 over the
//! 1.9 s floor), was `ok` with products of inertia 3.8 sigma off in the kernel's algorithm in
//! f64 and 6.8 in the integer float, the same at a tenth and at three times the noise.

use super::solve::{inverse_inertia, mul3, skew, sym3};

/// Longest window, s.
pub const MAX_WINDOW_S: f32 = 60.0;
/// Longest (weighted) turn a 3-D craft's window spans past [`TURN_WINDOW_S`], rad.
pub const MAX_WINDOW_TURN_RAD: f32 = 4.0;
/// Windows shorter than this are not cut for their turn, s (for a craft that couples like
/// SPHERES; shorter in proportion for one that couples more).
pub const TURN_WINDOW_S: f32 = 8.0;
/// The nominal inertia the limits were measured on (SPHERES SPH2, kg m^2, xx yy zz xy xz yz).
pub const SPHERES_INERTIA_KGM2: [f32; 6] = crate::model::SPH2.inertia_kgm2;

/// Longest coupled noise walk a 3-D craft's window spans, whatever its length (variance in
/// units of the rate noise's; see the module doc). SPHERES' windows, where the other limits
/// were measured, reach 0.015-0.019 at most (combo and random PWM at 50 Hz, the 8 s floor,
/// seeds 71000-71004 and 72000-72019), so those limits stand there; the random 3-D craft of
/// seed 70013 reached 0.13.
pub const MAX_WINDOW_WALK: f32 = 0.02;

/// Shortest window cap, samples.
pub const MIN_WINDOW: u32 = 20;

/// `seconds` in sample periods of `period_s`, rounded to nearest (the quotient of an f32
/// period is not exact: 60 s / 0.001 s is 59999.996 in f32); 0 for NaN, at most 10^9.
pub fn samples(seconds: f32, period_s: f32) -> u32 {
    let v = (seconds / period_s + 0.5).clamp(0.0, 1e9);
    // `as` saturates and maps NaN to 0: no panic, no undefined behaviour.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n = v as u32;
    n
}

/// Per axis `a`, the largest entry of `|J([e_a]x I - [I e_a]x)|`: how fast a turn about `a`
/// at 1 rad/s couples the axes (1/s per rad/s; the spectral norm for a principal-axis
/// inertia). None for a singular inertia.
pub fn coupling(inertia_kgm2: &[f32; 6]) -> Option<[f32; 3]> {
    let j = sym3(&inverse_inertia(inertia_kgm2)?);
    let i = sym3(inertia_kgm2);
    let mut out = [0.0f32; 3];
    // `I e_a` is row `a` of the symmetric `I`.
    for (a, (k, i_e)) in out.iter_mut().zip(i.iter()).enumerate() {
        let e: [f32; 3] = core::array::from_fn(|r| if r == a { 1.0 } else { 0.0 });
        let mut d = mul3(&skew(&e), &i);
        for (drow, srow) in d.iter_mut().zip(skew(i_e)) {
            for (v, s) in drow.iter_mut().zip(srow) {
                *v -= s;
            }
        }
        *k = mul3(&j, &d)
            .iter()
            .flatten()
            .fold(0.0f32, |m, v| m.max(v.abs()));
    }
    out.iter().all(|k| k.is_finite()).then_some(out)
}

/// SPHERES' largest coupling, the reference of the turn and walk weights.
fn spheres_coupling() -> Option<f32> {
    Some(
        coupling(&SPHERES_INERTIA_KGM2)?
            .into_iter()
            .fold(0.0f32, f32::max),
    )
}

/// Each axis' weight in the window's turn, `max(1, kappa_a / max kappa_SPHERES)`; the floor
/// ([`TURN_WINDOW_S`]) is divided by the largest. All ones for a craft that couples no more
/// than SPHERES. None for a singular inertia or one so ill-conditioned that a weight is not
/// finite.
pub fn turn_weights(inertia_kgm2: &[f32; 6]) -> Option<[f32; 3]> {
    let reference = spheres_coupling()?;
    let w = coupling(inertia_kgm2)?.map(|v| (v / reference).max(1.0));
    w.iter().all(|v| v.is_finite()).then_some(w)
}

/// The floor of a craft with weights `w`, s.
pub fn turn_window_s(weights: &[f32; 3]) -> f32 {
    TURN_WINDOW_S / weights.iter().fold(1.0f32, |m, w| m.max(*w))
}

/// Per axis `a`, the weight of `omega_a^2 dt` in the window's coupled noise walk:
/// `(kappa_a)^2 period_s`, with `kappa_a` bounded as the turn rule bounds it (SPHERES'
/// largest coupling times the axis' turn weight, at least the axis' own coupling). None if
/// a weight is not finite.
pub fn walk_weights(turn_weight: &[f32; 3], period_s: f32) -> Option<[f32; 3]> {
    let reference = spheres_coupling()?;
    let w = turn_weight.map(|t| {
        let k = reference * t;
        k * k * period_s
    });
    w.iter().all(|v| v.is_finite() && *v >= 0.0).then_some(w)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
    use super::*;

    #[test]
    fn spheres_keeps_its_limits_and_a_cubesat_counts_its_turn_more() {
        assert_eq!(turn_weights(&SPHERES_INERTIA_KGM2), Some([1.0; 3]));
        // A sphere does not couple at all: the SPHERES limits.
        assert_eq!(
            turn_weights(&[0.1, 0.1, 0.1, 0.0, 0.0, 0.0]),
            Some([1.0; 3])
        );
        // A 3U cubesat: (Ixx - Izz) / Iyy = 0.8 for turns about x, y and z.
        let w = turn_weights(&[0.0333, 0.0333, 0.0067, 0.0, 0.0, 0.0]).unwrap();
        let k = coupling(&[0.0333, 0.0333, 0.0067, 0.0, 0.0, 0.0]).unwrap();
        for v in k {
            assert!((v - 0.7988).abs() < 1e-3, "{k:?}");
        }
        assert!(w.iter().all(|v| *v > 3.5 && *v < 3.6), "{w:?}");
        assert!((turn_window_s(&w) - 8.0 / w[0]).abs() < 1e-6);
        assert_eq!(samples(60.0, 0.001), 60_000);
        assert_eq!(samples(turn_window_s(&w), 0.01), 225);
        assert_eq!(samples(f32::NAN, 0.01), 0);
        assert_eq!(turn_weights(&[1.0, 1.0, 0.0, 0.0, 0.0, 0.0]), None);
        // Invertible in f32, but its coupling overflows: no weights rather than infinite ones.
        assert_eq!(turn_weights(&[1e30, 1e30, 1e-30, 0.0, 0.0, 0.0]), None);
    }

    #[test]
    fn coupling_is_euler_s_coefficient_for_principal_axes() {
        let (a, b, c) = (0.3f32, 0.2f32, 0.1f32);
        let k = coupling(&[a, b, c, 0.0, 0.0, 0.0]).unwrap();
        // A turn about x: w_y' = -(a - c)/b w_x w_z ..., entries (a-c)/b and (b-a)/c.
        let want = [
            ((a - c) / b).abs().max(((b - a) / c).abs()),
            ((c - b) / a).abs().max(((a - b) / c).abs()),
            ((c - b) / a).abs().max(((a - c) / b).abs()),
        ];
        for (g, w) in k.iter().zip(want) {
            assert!((g - w).abs() < 1e-5, "{k:?} {want:?}");
        }
    }
}
