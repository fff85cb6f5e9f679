//! Simulated flights for the noise-model tests (`diagnose_noise.rs`,
//! `diagnose_noise_planted.rs`): a craft of `examples/models/`, a rate sensor, a noise
//! level and optionally a residual the vocabulary cannot explain.

use massid_diagnose::noise::NoiseKind;
use massid_diagnose::{diagnose_rate_recording, DiagnosisOutput, Settings};
use massid_sim::sensors::{RateSensor, SensorConfig};
use massid_sim::{simulate, Maneuver, SimSpec};
use reference_f64::rate_recording::RateRecording;
use reference_f64::satellite::Satellite;
use std::path::Path;

/// The rate sensor of a simulated flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sensor {
    White,
    BandLimited,
    Differenced,
}

/// One simulated flight's conditions.
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    pub model: &'static str,
    pub rate_hz: f64,
    pub sensor: Sensor,
    /// Noise level, times the base level.
    pub level: f64,
    pub seconds: f64,
    pub seed: u64,
    /// Residual the vocabulary cannot explain, as a total RMS over the noise's (1.3: the
    /// residual is 1.3x the noise); 1.0 for none.
    pub excess: f64,
}

/// Base white noise, rad/s: the motion-capture white part of `identification_mc.rs`.
const WHITE_RAD_S: f64 = 0.002;
/// Base attitude noise of the differenced sensor, rad (also `identification_mc.rs`).
const ATTITUDE_RAD: f64 = 0.0003;

fn satellite(model: &str) -> Satellite {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace");
    massid_sim::model_file::ModelFile::read(&root.join("examples/models").join(model))
        .expect("model")
        .satellite
}

fn sensors(f: &Flight) -> SensorConfig {
    let mut s = SensorConfig {
        gyro_noise_rad_s: [WHITE_RAD_S * f.level; 3],
        // far above the sample rate: white
        gyro_bandwidth_hz: 1e6,
        ..SensorConfig::default()
    };
    match f.sensor {
        Sensor::White => {}
        // lag-1 correlation exp(-2 pi bw / rate) = 0.73: still 0.4 three samples on
        Sensor::BandLimited => s.gyro_bandwidth_hz = f.rate_hz / 20.0,
        Sensor::Differenced => {
            s.rate_sensor = RateSensor::DifferencedAttitude;
            s.attitude_noise_rad = ATTITUDE_RAD * f.level;
        }
    }
    s
}

/// Per-sample noise RMS of the sensor, rad/s (what `unexplained` compares with).
pub fn noise_rms(f: &Flight) -> f64 {
    let w = WHITE_RAD_S * f.level;
    match f.sensor {
        Sensor::Differenced => {
            let d = ATTITUDE_RAD * f.level * f.rate_hz;
            (w * w + 2.0 * d * d).sqrt()
        }
        _ => w,
    }
}

/// Deterministic normal numbers (no test depends on a crate's RNG stream).
struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// The recording (format v2) of flight `f` and its nominal satellite.
pub fn record(f: &Flight) -> (RateRecording, Satellite) {
    let sat = satellite(f.model);
    let mut spec = SimSpec::new(sat.clone(), vec![], Maneuver::RandomPwm);
    spec.rate_hz = f.rate_hz;
    spec.seconds = Some(f.seconds);
    spec.seed = f.seed;
    spec.sensors = sensors(f);
    let out = simulate(&spec).expect("simulate");
    let mut rec = out.rate_recording.expect("a rad/s craft is recorded in v2");
    if f.excess > 1.0 {
        // a rate offset wandering with a 2 s time constant (first-order Gauss-Markov),
        // RMS sqrt(excess^2 - 1) of the noise: not a constant gyro bias, not any effect
        let amp = (f.excess * f.excess - 1.0).sqrt() * noise_rms(f);
        let mut g = Lcg(f.seed ^ 0xA5A5_5A5A);
        let mut x = [amp * g.normal(), amp * g.normal(), amp * g.normal()];
        let mut t0 = rec.time_ms.first().copied().unwrap_or(0);
        for (t, r) in rec.time_ms.iter().zip(rec.rate.iter_mut()) {
            let c = (-((t - t0) as f64) / 2000.0).exp();
            let s = (1.0 - c * c).sqrt();
            for a in 0..3 {
                x[a] = c * x[a] + s * amp * g.normal();
                r[a] += x[a];
            }
            t0 = *t;
        }
    }
    (rec, sat)
}

/// Diagnoses flight `f`.
pub fn diagnose(f: &Flight) -> DiagnosisOutput {
    let (rec, sat) = record(f);
    diagnose_rate_recording(&rec, &sat, &Settings::default())
        .expect("diagnose")
        .output
}

pub fn summary(out: &DiagnosisOutput) -> String {
    let named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
    format!(
        "named {named:?}; noise {:?}; unexplained {:?}",
        out.noise,
        out.unexplained.as_ref().map(|u| &u.note)
    )
}

pub fn kind_of(s: Sensor) -> NoiseKind {
    match s {
        Sensor::White => NoiseKind::White,
        Sensor::BandLimited => NoiseKind::BandLimited,
        Sensor::Differenced => NoiseKind::DifferencedAttitude,
    }
}
