//! `mixer::Mixer::mix` (the PWM mixer) and its stage-10 bookkeeping: for any command in the
//! envelope, either a status or a firing with `0 <= on <= off <= period`, every pulse 0 or at
//! least the minimum, no opposing pair firing together, and the direction of the command
//! kept when it is scaled to the thrusters' reach; and for every thruster word, the pulses
//! the quantiser emits are exactly the drawn durations under the integer rules.

use super::{draw, Harness};
use crate::budget::Exact;
use crate::cover;
use crate::engine::{any_bool, any_f64_in, any_in, assume};
use crate::envelope as env;
use massid_kernel::mixer::{Firing, Mixer, MixerConfig, MixerError};
use massid_kernel::model::{SatelliteParams, OPPOSING_PAIRS};
use massid_kernel::Q8_24;

/// The invariants every emitted firing satisfies.
pub fn check_firing(f: &Firing, period: u32, min_pulse: u32) {
    for i in 0..12 {
        let (on, off) = (f.on_ms[i], f.off_ms[i]);
        assert!(
            on <= off && off <= period,
            "thruster {i}: on {on} off {off} period {period}"
        );
        let d = off - on;
        assert!(
            d == 0 || d >= min_pulse,
            "thruster {i}: pulse {d} ms shorter than {min_pulse}"
        );
        if d == 0 {
            assert_eq!(
                (on, off),
                (0, 0),
                "a thruster that does not fire has on = off = 0"
            );
        }
    }
    for (a, b) in OPPOSING_PAIRS {
        let overlap = f.on_ms[a].max(f.on_ms[b]) < f.off_ms[a].min(f.off_ms[b]);
        assert!(
            !overlap,
            "opposing thrusters {} and {} fire together",
            a + 1,
            b + 1
        );
    }
}

/// The net (force, torque) direction of `fractions` through the thruster geometry.
fn net(p: &SatelliteParams, fractions: &[f64; 12]) -> [f64; 6] {
    let mut out = [0.0; 6];
    for i in 0..12 {
        let t = p.thrust_n[i] as f64;
        let d = p.thrust_dir[i].map(|v| v as f64 * t);
        let l = [0, 1, 2].map(|k| p.thruster_pos_m[i][k] as f64 - p.com_offset_mm[k] as f64 * 1e-3);
        let tq = [
            l[1] * d[2] - l[2] * d[1],
            l[2] * d[0] - l[0] * d[2],
            l[0] * d[1] - l[1] * d[0],
        ];
        for k in 0..3 {
            out[k] += fractions[i] * d[k];
            out[3 + k] += fractions[i] * tq[k];
        }
    }
    out
}

fn mix_any<S: Exact>() {
    let p = draw::params_or_sph2();
    let period = any_in(env::MIXER_PERIOD_MS.0, env::MIXER_PERIOD_MS.1);
    let min_pulse = any_in(env::MIN_PULSE_MS.0, env::MIN_PULSE_MS.1);
    // The envelope's period/pulse pairs: a period holds two minimum pulses.
    assume(period >= 2 * min_pulse);
    let no_drop = any_bool();
    let drop = if no_drop {
        0.0
    } else {
        any_f64_in(env::PRESSURE_DROP_N.0, env::PRESSURE_DROP_N.1)
    };
    let cfg = MixerConfig {
        period_ms: period,
        min_pulse_ms: min_pulse,
        pressure_drop_n: S::from_f32(drop as f32),
    };
    let mixer = match Mixer::<S>::new(&p, [S::ZERO; 3], cfg) {
        Ok(m) => m,
        Err(e) => panic!("mixer rejected envelope parameters: {e:?}"),
    };
    // Commands: small (every pulse in the deadband), typical, and beyond reach (scaled).
    let scale = [0.01, 0.2, 1.0][any_in(0usize, 2)];
    let force = [0; 3].map(|_| any_f64_in(env::MIXER_FORCE_N.0, env::MIXER_FORCE_N.1) * scale);
    let torque = [0; 3].map(|_| any_f64_in(env::MIXER_TORQUE_NM.0, env::MIXER_TORQUE_NM.1) * scale);
    let fs = force.map(|v| S::from_f32(v as f32));
    let ts = torque.map(|v| S::from_f32(v as f32));
    match mixer.mix(fs, ts) {
        Err(MixerError::BadCommand) => cover!(true, "command beyond the scaled units: status"),
        Err(e) => {
            cover!(true, "other status");
            assert!(
                matches!(
                    e,
                    MixerError::Overflow | MixerError::PressureDropExceedsThrust
                ),
                "{e:?}"
            );
        }
        Ok(f) => {
            cover!(
                f.on_ms.iter().zip(f.off_ms.iter()).any(|(a, b)| b > a),
                "fires"
            );
            cover!(
                f.on_ms.iter().zip(f.off_ms.iter()).all(|(a, b)| b == a),
                "all in the deadband"
            );
            check_firing(&f, period, min_pulse);
        }
    }
    // Direction kept: before the pressure-drop stretch the fractions produce s * command.
    if no_drop {
        if let Ok(fr) = mixer.pulse_fractions(fs, ts) {
            let fr = fr.map(|v| v.exact());
            assert!(
                fr.iter().all(|v| (-1e-6..=1.0 + 1e-6).contains(v)),
                "fraction outside [0, 1]: {fr:?}"
            );
            let got = net(&p, &fr);
            let want = [
                force[0], force[1], force[2], torque[0], torque[1], torque[2],
            ]
            .map(|v| v as f32 as f64);
            // Compare in units where a full-period firing of one thruster is O(1): N / 0.1, N m / 0.01.
            let w = [10.0, 10.0, 10.0, 100.0, 100.0, 100.0];
            let dot: f64 = (0..6).map(|k| got[k] * want[k] * w[k] * w[k]).sum();
            let ng = (0..6).map(|k| (got[k] * w[k]).powi(2)).sum::<f64>().sqrt();
            let nw = (0..6).map(|k| (want[k] * w[k]).powi(2)).sum::<f64>().sqrt();
            if nw > 1e-3 && ng > 0.0 {
                let cos = dot / (ng * nw);
                let scaled = fr.iter().any(|v| *v >= 1.0 - 1e-6);
                cover!(scaled, "scaled to reach");
                assert!(cos > 1.0 - 1e-4, "direction not kept: cos {cos}, scaled {scaled}; force {force:?} torque {torque:?} period {period} fractions {fr:?} net {got:?}");
                assert!(ng <= nw * (1.0 + 1e-3), "more than commanded: {ng} > {nw}");
            }
        }
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn mixer_q8_24() {
    mix_any::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn mixer_f32() {
    mix_any::<f32>()
}

/// Stage 10 for every thruster word: the drawn pulse fractions of the open thrusters
/// become exactly the durations of the integer rules (reference: `reference_f64::mixer`'s
/// normative rules, re-derived here in integers) and nothing else fires.
fn quantise_word<S: Exact>() {
    let p = massid_kernel::model::SPH2;
    let period = any_in(env::MIXER_PERIOD_MS.0, 200);
    let min_pulse = any_in(env::MIN_PULSE_MS.0, env::MIN_PULSE_MS.1);
    assume(period >= 2 * min_pulse);
    let word = any_in(0u16, 0x0fff);
    // One duration in half-milliseconds for all open thrusters (so exhaustive stays small).
    let half_ms = any_in(0u32, 2 * period);
    let cfg = MixerConfig {
        period_ms: period,
        min_pulse_ms: min_pulse,
        pressure_drop_n: S::ZERO,
    };
    let mixer = Mixer::<S>::new(&p, [S::ZERO; 3], cfg).expect("SPH2 mixes");
    // fraction = half_ms / (2 period), exactly representable? compute it in S.
    let frac = S::from_int_pow2(half_ms as i32, 0)
        .checked_div(S::from_int_pow2(2 * period as i32, 0))
        .expect("nonzero");
    let fractions: [S; 12] =
        core::array::from_fn(|i| if word & (1 << i) != 0 { frac } else { S::ZERO });
    let f = mixer
        .quantise(&fractions)
        .expect("quantise never overflows on fractions in [0, 1]");
    check_firing_bookkeeping(&f, word, frac.exact(), period, min_pulse);
    cover!(word == 0x0fff, "every thruster");
}

/// The integer rules of the reference mixer's module doc, in exact arithmetic.
pub fn expected_duration(frac: f64, period: u32, min_pulse: u32) -> u32 {
    let d_real = frac.clamp(0.0, 1.0) * period as f64;
    let mut d = ((d_real + 0.5).floor() as u32).min(period);
    if d < min_pulse {
        d = 0;
    }
    if d > period - min_pulse {
        d = period;
    }
    d
}

fn check_firing_bookkeeping(f: &Firing, word: u16, frac: f64, period: u32, min_pulse: u32) {
    let d = expected_duration(frac, period, min_pulse);
    for i in 0..12 {
        let want = if word & (1 << i) != 0 { d } else { 0 };
        assert_eq!(
            f.off_ms[i] - f.on_ms[i],
            want,
            "thruster {i} word {word:#05x} frac {frac}"
        );
        if want > 0 {
            assert_eq!(f.on_ms[i], (period - want) / 2, "centring");
        }
    }
    // Opposing pairs may both be in the word here (quantise is bookkeeping only), so only the
    // per-thruster invariants apply.
    for i in 0..12 {
        assert!(f.on_ms[i] <= f.off_ms[i] && f.off_ms[i] <= period);
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn mixer_quantise_every_word_q8_24() {
    quantise_word::<Q8_24>()
}

pub const HARNESSES: [Harness; 3] = [
    Harness {
        name: "mixer_q8_24",
        body: mixer_q8_24,
        covers: &["fires", "all in the deadband", "scaled to reach"],
        random_runs: 3_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "mixer_f32",
        body: mixer_f32,
        covers: &["fires", "all in the deadband", "scaled to reach"],
        random_runs: 3_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "mixer_quantise_every_word_q8_24",
        body: mixer_quantise_every_word_q8_24,
        covers: &["every thruster"],
        random_runs: 20_000,
        exhaustive_limit: None,
    },
];
