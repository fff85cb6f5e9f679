//! Concealed-effect recordings made with the simulator (`massid_sim`), for the score
//! suite and the tests: SPHERES-style maneuvers (the RGA rotation/translation set and
//! random PWM), the simulator's noise-free gyro prediction with the effects switched on,
//! gyro ringing with a random phase per valve shock, white gyro noise, 12-bit
//! quantization, and sampling at 1000, 100 or 50 Hz.

use massid_sim::effects::{Effect, PlantConfig};
use massid_sim::predict::{ringing_at, shock_times_ms};
use massid_sim::{PredictOptions, Predictor};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use reference_f64::recording::{Recording, Sample};
use reference_f64::satellite::Satellite;

/// Per-sample gyro noise, rad/s per axis: what the diagnosis measures on the open nominal
/// recording o01 (`noise` in its summary), i.e. about 3, 2 and 2 counts.
pub const GYRO_NOISE_RAD_S: [f64; 3] = [0.0021, 0.0015, 0.0014];

/// Which command sequence to fly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Maneuver {
    /// Per axis: +rotation, -rotation, +translation, -translation, 1 s firings with 1 s
    /// coasts between (24 s of firings, 28 s in all).
    Rga12,
    /// Random PWM: every 200 ms period 1-4 random thrusters fire for 10-180 ms each.
    Combo { seconds: u32 },
}

/// The thruster pair that best gives pure torque (rotate) or pure force (translate) along
/// `axis` with `sign`.
fn best_pair(sat: &Satellite, axis: usize, sign: f64, rotate: bool) -> u16 {
    let mut best = (f64::MIN, 0u16);
    for i in 0..12 {
        for j in i + 1..12 {
            let f = sat.force_n(i) + sat.force_n(j);
            let t = sat.torque_nm(i) + sat.torque_nm(j);
            let score = if rotate {
                sign * t[axis] * 10.0 - f.norm() - (t.norm() - t[axis].abs())
            } else {
                sign * f[axis] - t.norm() * 10.0 - (f.norm() - f[axis].abs())
            };
            if score > best.0 {
                best = (score, (1 << i) | (1 << j));
            }
        }
    }
    best.1
}

/// Commanded word per ms.
pub fn commands(sat: &Satellite, m: Maneuver, period_ms: u64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    match m {
        Maneuver::Rga12 => {
            let mut w = vec![0u16; 2000];
            for axis in 0..3 {
                for (rotate, sign) in [(true, 1.0), (true, -1.0), (false, 1.0), (false, -1.0)] {
                    let word = best_pair(sat, axis, sign, rotate);
                    w.extend(std::iter::repeat_n(word, 1000));
                    w.extend(std::iter::repeat_n(0u16, 1000));
                }
            }
            w.truncate(28_000);
            w.resize(28_000, 0);
            w
        }
        Maneuver::Combo { seconds } => {
            let n = seconds as usize * 1000;
            let mut w = vec![0u16; n];
            let mut t = 1000;
            while t + 200 <= n.saturating_sub(500) {
                let count = rng.gen_range(1..=4);
                for _ in 0..count {
                    let th = rng.gen_range(0..12);
                    // pulse lengths on the sample grid so every rate shows them
                    let len =
                        (rng.gen_range(10..=180) / period_ms as usize).max(1) * period_ms as usize;
                    for x in w.iter_mut().skip(t).take(len) {
                        *x |= 1 << th;
                    }
                }
                t += 200;
            }
            w
        }
    }
}

/// One synthetic recording with its truth.
pub struct Synthetic {
    pub recording: Recording,
    pub satellite: Satellite,
    pub effects: Vec<Effect>,
}

/// Parses an effect from the contract's JSON form.
pub fn effect(json: &str) -> Effect {
    serde_json::from_str(json).unwrap_or_else(|e| panic!("bad effect {json}: {e}"))
}

/// Simulates `sat` flying `maneuver` with `effects`, sampled at `rate_hz`, noise from `seed`.
pub fn make(
    sat_name: &str,
    maneuver: Maneuver,
    rate_hz: u32,
    effects: Vec<Effect>,
    seed: u64,
) -> Synthetic {
    let sat = Satellite::builtin(sat_name).expect("built-in satellite");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let period = (1000 / rate_hz).max(1) as u64;
    let words = commands(&sat, maneuver, period, &mut rng);
    let times: Vec<u64> = (0..words.len() as u64).collect();
    let rigid: Vec<Effect> = effects
        .iter()
        .filter(|e| !matches!(e, Effect::GyroRinging(_)))
        .cloned()
        .collect();
    let pred =
        Predictor::new(&sat, &rigid).run(&times, &words, [0.0; 3], PredictOptions::default());
    // ringing with a random phase per shock and axis, on the actual valve edges
    let cfg = PlantConfig::new(&sat, &effects);
    let shocks = shock_times_ms(&pred.edges);
    let mut phase_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let phases: Vec<[f64; 3]> = (0..shocks.len())
        .map(|_| std::array::from_fn(|_| phase_rng.gen_range(0.0..std::f64::consts::TAU)))
        .collect();
    let ring = ringing_at(&cfg, &shocks, &times, |_, s, a| phases[s][a]);
    let noise: [Normal<f64>; 3] =
        std::array::from_fn(|a| Normal::new(0.0, GYRO_NOISE_RAD_S[a]).unwrap());
    let mut samples = vec![];
    for k in (0..times.len()).step_by(period as usize) {
        let mut gyro = [0u16; 3];
        for a in 0..3 {
            let rate =
                pred.gyro_rad_s[k][a] + cfg.gyro_scale[a] * ring[k][a] + noise[a].sample(&mut rng);
            let c = sat.rad_s_to_gyro_counts(a, rate).round().clamp(0.0, 4095.0);
            gyro[a] = c as u16;
        }
        samples.push(Sample {
            time_ms: times[k],
            gyro,
            accel: [2048; 3],
            thrusters: words[k],
        });
    }
    let rec = Recording::new(
        "synthetic.csv",
        Some(sat_name),
        Some(rate_hz as f64),
        samples,
    );
    Synthetic {
        recording: rec,
        satellite: sat,
        effects,
    }
}
