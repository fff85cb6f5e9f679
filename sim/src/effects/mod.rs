//! The effect vocabulary of `shared/contracts/diagnosis-output.md`: every piece of physics
//! the nominal model leaves out, one file per effect, each a [`Component`] that switches
//! itself into a [`PlantConfig`]. This module is the one home of each effect's contract
//! name ([`Kind`]) and of its parameters' names, shapes and units (its struct, which the
//! diagnosis fills to report a fitted effect). Adding an effect = adding a file, a variant of
//! [`Kind`] and of [`Effect`] and (if it is new physics) a field in `PlantConfig`; then its
//! description in `diagnose/src/effects/`.
//!
//! [`Effect`] (de)serialises exactly as the contract:
//! `{"effect": "thruster_latency", "params": {"open_ms": 6.0, "close_ms": 6.0}}`.
//!
//! The contract's table now also lists `rate_damping` and `thrust_rise` (added first here as
//! extras: effects craft other than SPHERES have), `thruster_misalignment` and
//! `measurement_delay`; [`Kind`] holds all sixteen names in the table's order.

mod blowdown;
mod com_offset;
mod disturbance_torque;
mod fuel_slosh;
mod gyro_bias;
mod gyro_ringing;
mod gyro_scale;
mod inertia;
mod mass_property_change;
mod measurement_delay;
mod pressure_drop;
mod rate_damping;
mod thrust_rise;
mod thrust_scale;
mod thruster_latency;
mod thruster_misalignment;

pub use blowdown::Blowdown;
pub use com_offset::ComOffset;
pub use disturbance_torque::DisturbanceTorque;
pub use fuel_slosh::FuelSlosh;
pub use gyro_bias::GyroBias;
pub use gyro_ringing::GyroRinging;
pub use gyro_scale::GyroScale;
pub use inertia::Inertia;
pub use mass_property_change::MassPropertyChange;
pub use measurement_delay::{DelayLine, MeasurementDelay};
pub use pressure_drop::PressureDrop;
pub use rate_damping::RateDamping;
pub use thrust_rise::ThrustRise;
pub use thrust_scale::ThrustScale;
pub use thruster_latency::ThrusterLatency;
pub use thruster_misalignment::{ThrusterMisalignment, MAX_TILT_DEG};

use reference_f64::satellite::{Satellite, MAX_THRUSTERS};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One physical effect: it writes itself into the plant configuration the simulator runs.
/// Several effects of one kind compose (delays add, scales multiply, tones superpose).
pub trait Component {
    fn apply(&self, plant: &mut PlantConfig);
}

/// Mass properties relative to the nominal model: CoM offset (true minus model's, metres,
/// body axes) and the true inertia about the CoM (xx yy zz xy xz yz).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassPhase {
    pub com_offset_m: [f64; 3],
    pub inertia_kgm2: [f64; 6],
}

/// Everything that differs from the nominal satellite, in the form the simulator uses.
/// Built by [`PlantConfig::new`] from the satellite and a list of effects.
#[derive(Clone, Debug, PartialEq)]
pub struct PlantConfig {
    pub open_delay_ms: f64,
    pub close_delay_ms: f64,
    pub pressure_drop_n: f64,
    pub blowdowns: Vec<Blowdown>,
    pub thrust_scale: [f64; MAX_THRUSTERS],
    /// Mass properties from t = 0.
    pub initial: MassPhase,
    /// Step changes (time s, values after), sorted by time.
    pub changes: Vec<(f64, MassPhase)>,
    pub slosh: Vec<FuelSlosh>,
    /// True minus nominal gyro bias, counts.
    pub gyro_bias_counts: [f64; 3],
    /// True / nominal gyro scale.
    pub gyro_scale: [f64; 3],
    pub ringing: Vec<GyroRinging>,
    pub disturbance_torque_nm: [f64; 3],
    /// First-order thrust rise/decay time constant at the valve edges, ms (0 = instantaneous;
    /// outside the vocabulary, see `thrust_rise.rs`).
    pub thrust_rise_tau_ms: f64,
    /// Torque against the body rate per axis, N m s/rad (outside the vocabulary, see
    /// `rate_damping.rs`).
    pub rate_damping_nms: [f64; 3],
    /// The rate sensor reports the body rate this long ago, ms (see `measurement_delay.rs`).
    pub measurement_delay_ms: f64,
    /// True force direction per thruster where it differs from the model's (unit, body axes;
    /// see `thruster_misalignment.rs`).
    pub thrust_dir: [Option<[f64; 3]>; MAX_THRUSTERS],
}

impl PlantConfig {
    /// The nominal satellite: no effect switched on (a model file's satellite may carry
    /// its own pressure drop, `pressure_drop_n_per_extra`; 0 for the built-in models).
    pub fn nominal(sat: &Satellite) -> Self {
        PlantConfig {
            open_delay_ms: 0.0,
            close_delay_ms: 0.0,
            pressure_drop_n: sat.pressure_drop_n_per_extra,
            blowdowns: Vec::new(),
            thrust_scale: [1.0; MAX_THRUSTERS],
            initial: MassPhase {
                com_offset_m: [0.0; 3],
                inertia_kgm2: sat.inertia_kgm2,
            },
            changes: Vec::new(),
            slosh: Vec::new(),
            gyro_bias_counts: [0.0; 3],
            gyro_scale: [1.0; 3],
            ringing: Vec::new(),
            disturbance_torque_nm: [0.0; 3],
            thrust_rise_tau_ms: 0.0,
            rate_damping_nms: [0.0; 3],
            measurement_delay_ms: 0.0,
            thrust_dir: [None; MAX_THRUSTERS],
        }
    }

    /// The satellite with `effects` switched on (in list order).
    pub fn new(sat: &Satellite, effects: &[Effect]) -> Self {
        let mut p = Self::nominal(sat);
        for e in effects {
            e.component().apply(&mut p);
        }
        p
    }

    /// Mass properties in force at time `t_s`.
    pub fn mass_at(&self, t_s: f64) -> &MassPhase {
        let mut m = &self.initial;
        for (at, phase) in &self.changes {
            if t_s >= *at {
                m = phase;
            }
        }
        m
    }

    /// Product of all blowdown factors at `t_s`.
    pub fn blowdown_factor(&self, t_s: f64) -> f64 {
        self.blowdowns.iter().map(|b| b.factor(t_s)).product()
    }
}

/// One effect of the vocabulary with its parameters (names and units as in the contract).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(tag = "effect", content = "params", rename_all = "snake_case")]
pub enum Effect {
    ThrusterLatency(ThrusterLatency),
    PressureDrop(PressureDrop),
    Blowdown(Blowdown),
    ThrustScale(ThrustScale),
    ComOffset(ComOffset),
    Inertia(Inertia),
    MassPropertyChange(MassPropertyChange),
    FuelSlosh(FuelSlosh),
    GyroBias(GyroBias),
    GyroScale(GyroScale),
    GyroRinging(GyroRinging),
    DisturbanceTorque(DisturbanceTorque),
    /// `thrust_rise`, `tau_ms`.
    ThrustRise(ThrustRise),
    /// `rate_damping`, `nms_per_rad` (3).
    RateDamping(RateDamping),
    MeasurementDelay(MeasurementDelay),
    ThrusterMisalignment(ThrusterMisalignment),
}

/// The effect vocabulary, one variant per effect of the contract's table, in its order:
/// the one home of each effect's contract name (the simulator's [`Effect`] and the
/// diagnosis both name effects through it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    ThrusterLatency,
    PressureDrop,
    Blowdown,
    ThrustScale,
    ComOffset,
    Inertia,
    MassPropertyChange,
    FuelSlosh,
    GyroBias,
    GyroScale,
    GyroRinging,
    DisturbanceTorque,
    RateDamping,
    ThrustRise,
    ThrusterMisalignment,
    MeasurementDelay,
}

impl Kind {
    /// Every effect, in the contract table's order.
    pub const ALL: [Kind; 16] = [
        Kind::ThrusterLatency,
        Kind::PressureDrop,
        Kind::Blowdown,
        Kind::ThrustScale,
        Kind::ComOffset,
        Kind::Inertia,
        Kind::MassPropertyChange,
        Kind::FuelSlosh,
        Kind::GyroBias,
        Kind::GyroScale,
        Kind::GyroRinging,
        Kind::DisturbanceTorque,
        Kind::RateDamping,
        Kind::ThrustRise,
        Kind::ThrusterMisalignment,
        Kind::MeasurementDelay,
    ];

    /// The contract's name, e.g. `"thruster_latency"`.
    pub const fn name(self) -> &'static str {
        match self {
            Kind::ThrusterLatency => "thruster_latency",
            Kind::PressureDrop => "pressure_drop",
            Kind::Blowdown => "blowdown",
            Kind::ThrustScale => "thrust_scale",
            Kind::ComOffset => "com_offset",
            Kind::Inertia => "inertia",
            Kind::MassPropertyChange => "mass_property_change",
            Kind::FuelSlosh => "fuel_slosh",
            Kind::GyroBias => "gyro_bias",
            Kind::GyroScale => "gyro_scale",
            Kind::GyroRinging => "gyro_ringing",
            Kind::DisturbanceTorque => "disturbance_torque",
            Kind::RateDamping => "rate_damping",
            Kind::ThrustRise => "thrust_rise",
            Kind::ThrusterMisalignment => "thruster_misalignment",
            Kind::MeasurementDelay => "measurement_delay",
        }
    }

    /// The effect of that contract name.
    pub fn from_name(s: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.name() == s)
    }
}

/// The contract's effect names, in the table's order.
pub const EFFECT_NAMES: [&str; 16] = {
    let mut names = [""; 16];
    let mut i = 0;
    while i < 16 {
        names[i] = Kind::ALL[i].name();
        i += 1;
    }
    names
};

impl Effect {
    /// The part that switches this effect into a plant.
    pub fn component(&self) -> &dyn Component {
        match self {
            Effect::ThrusterLatency(e) => e,
            Effect::PressureDrop(e) => e,
            Effect::Blowdown(e) => e,
            Effect::ThrustScale(e) => e,
            Effect::ComOffset(e) => e,
            Effect::Inertia(e) => e,
            Effect::MassPropertyChange(e) => e,
            Effect::FuelSlosh(e) => e,
            Effect::GyroBias(e) => e,
            Effect::GyroScale(e) => e,
            Effect::GyroRinging(e) => e,
            Effect::DisturbanceTorque(e) => e,
            Effect::ThrustRise(e) => e,
            Effect::RateDamping(e) => e,
            Effect::MeasurementDelay(e) => e,
            Effect::ThrusterMisalignment(e) => e,
        }
    }

    /// Which effect of the vocabulary this is.
    pub fn kind(&self) -> Kind {
        match self {
            Effect::ThrusterLatency(_) => Kind::ThrusterLatency,
            Effect::PressureDrop(_) => Kind::PressureDrop,
            Effect::Blowdown(_) => Kind::Blowdown,
            Effect::ThrustScale(_) => Kind::ThrustScale,
            Effect::ComOffset(_) => Kind::ComOffset,
            Effect::Inertia(_) => Kind::Inertia,
            Effect::MassPropertyChange(_) => Kind::MassPropertyChange,
            Effect::FuelSlosh(_) => Kind::FuelSlosh,
            Effect::GyroBias(_) => Kind::GyroBias,
            Effect::GyroScale(_) => Kind::GyroScale,
            Effect::GyroRinging(_) => Kind::GyroRinging,
            Effect::DisturbanceTorque(_) => Kind::DisturbanceTorque,
            Effect::ThrustRise(_) => Kind::ThrustRise,
            Effect::RateDamping(_) => Kind::RateDamping,
            Effect::MeasurementDelay(_) => Kind::MeasurementDelay,
            Effect::ThrusterMisalignment(_) => Kind::ThrusterMisalignment,
        }
    }

    /// The contract's name, e.g. `"thruster_latency"`.
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// The parameters in the contract's form, `{"open_ms": 6.0, ...}`: the names and
    /// shapes of this effect's struct (a non-finite value, e.g. an unbounded standard
    /// error, serialises as JSON `null`).
    pub fn params_json(&self) -> serde_json::Map<String, serde_json::Value> {
        match serde_json::to_value(self) {
            Ok(serde_json::Value::Object(mut o)) => match o.remove("params") {
                Some(serde_json::Value::Object(p)) => p,
                _ => Default::default(),
            },
            _ => Default::default(),
        }
    }

    /// Parameters flattened to `(name, value)`; array entries are named `scale[5]` (0-based).
    /// Includes extra keys (e.g. `inertia_fraction[0]`). Lets a fitter treat every effect alike.
    pub fn params(&self) -> Vec<(String, f64)> {
        let v = serde_json::to_value(self).expect("effects serialise");
        let mut out = Vec::new();
        if let Some(obj) = v.get("params").and_then(|p| p.as_object()) {
            for (k, val) in obj {
                match val {
                    serde_json::Value::Array(a) => {
                        for (i, x) in a.iter().enumerate() {
                            match x {
                                // rows of a matrix (a direction per thruster): `dir[2][0]`
                                serde_json::Value::Array(row) => {
                                    for (j, y) in row.iter().enumerate() {
                                        out.push((
                                            format!("{k}[{i}][{j}]"),
                                            y.as_f64().unwrap_or(f64::NAN),
                                        ));
                                    }
                                }
                                _ => {
                                    out.push((format!("{k}[{i}]"), x.as_f64().unwrap_or(f64::NAN)))
                                }
                            }
                        }
                    }
                    other => out.push((k.clone(), other.as_f64().unwrap_or(f64::NAN))),
                }
            }
        }
        out
    }

    /// A copy with the named parameters (as [`Effect::params`] names them) replaced.
    pub fn with_params(&self, values: &[(&str, f64)]) -> Result<Effect, String> {
        let mut v = serde_json::to_value(self).expect("effects serialise");
        let obj = v
            .get_mut("params")
            .and_then(|p| p.as_object_mut())
            .ok_or_else(|| "effect has no params".to_string())?;
        for (name, x) in values {
            let (key, idx, row) = match name.find('[') {
                Some(b) => {
                    let bad = || format!("bad parameter index in {name:?}");
                    let inner = name[b + 1..].strip_suffix(']').ok_or_else(bad)?;
                    let mut parts = inner.split("][");
                    let i: usize = parts.next().unwrap_or("").parse().map_err(|_| bad())?;
                    let j = match parts.next() {
                        Some(p) => Some(p.parse::<usize>().map_err(|_| bad())?),
                        None => None,
                    };
                    (&name[..b], Some(i), j)
                }
                None => (*name, None, None),
            };
            let slot = obj
                .get_mut(key)
                .ok_or_else(|| format!("{}: no parameter {key:?}", self.name()))?;
            // a matrix entry `dir[i][j]`: descend into row i
            let slot = match (slot, idx, row) {
                (serde_json::Value::Array(a), Some(i), Some(_)) if i < a.len() => &mut a[i],
                (s, _, None) => s,
                _ => {
                    return Err(format!(
                        "{}: parameter {name:?} has the wrong shape",
                        self.name()
                    ))
                }
            };
            let idx = row.or(idx);
            let num = serde_json::Value::from(*x);
            match (slot, idx) {
                (serde_json::Value::Array(a), Some(i)) if i < a.len() => a[i] = num,
                (s, None) if !s.is_array() => *s = num,
                _ => {
                    return Err(format!(
                        "{}: parameter {name:?} has the wrong shape",
                        self.name()
                    ))
                }
            }
        }
        serde_json::from_value(v).map_err(|e| e.to_string())
    }

    /// Physical sanity of the parameters (finite, positive where the physics needs it).
    pub fn validate(&self) -> Result<(), String> {
        let bad = self.params().into_iter().find(|(_, v)| !v.is_finite());
        if let Some((k, _)) = bad {
            return Err(format!(
                "{}: parameter {k} is not a finite number",
                self.name()
            ));
        }
        let positive = |what: &str, v: f64| {
            if v > 0.0 {
                Ok(())
            } else {
                Err(format!("{}: {what} must be > 0 (got {v})", self.name()))
            }
        };
        let non_negative = |what: &str, v: f64| {
            if v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{}: {what} must be >= 0 (got {v})", self.name()))
            }
        };
        match self {
            Effect::ThrusterLatency(e) => {
                non_negative("open_ms", e.open_ms)?;
                non_negative("close_ms", e.close_ms)
            }
            Effect::Blowdown(e) => positive("tau_s", e.tau_s),
            Effect::ThrustScale(e) => e.scale.iter().try_for_each(|s| non_negative("scale", *s)),
            Effect::Inertia(e) => e.inertia_kgm2[..3]
                .iter()
                .try_for_each(|v| positive("inertia_kgm2 diagonal", *v)),
            Effect::MassPropertyChange(e) => {
                non_negative("at_s", e.at_s)?;
                e.inertia_kgm2[..3]
                    .iter()
                    .try_for_each(|v| positive("inertia_kgm2 diagonal", *v))
            }
            Effect::FuelSlosh(e) => {
                positive("freq_hz", e.freq_hz)?;
                non_negative("damping_ratio", e.damping_ratio)?;
                e.inertia_fraction
                    .iter()
                    .try_for_each(|v| non_negative("inertia_fraction", *v))
            }
            Effect::GyroScale(e) => e.scale.iter().try_for_each(|s| positive("scale", *s)),
            Effect::GyroRinging(e) => {
                positive("freq_hz", e.freq_hz)?;
                positive("decay_ms", e.decay_ms)
            }
            Effect::ThrustRise(e) => non_negative("tau_ms", e.tau_ms),
            Effect::MeasurementDelay(e) => non_negative("delay_ms", e.delay_ms),
            Effect::RateDamping(e) => e
                .nms_per_rad
                .iter()
                .try_for_each(|v| non_negative("nms_per_rad", *v)),
            _ => Ok(()),
        }
    }
}

/// Longest valve delay or rise time a model may state, ms.
pub const MAX_DELAY_MS: f64 = 1000.0;
/// Largest thrust or gyro scale factor a model may state.
pub const MAX_SCALE: f64 = 10.0;

impl Effect {
    /// Plausibility of the effect on `sat`, checked when a model file is read (after
    /// [`Effect::validate`]): arrays have the model's length (one `thrust_scale` entry per
    /// thruster), delays and rise times at most [`MAX_DELAY_MS`], scales at most
    /// [`MAX_SCALE`], a gyro bias within the 12-bit range, a CoM offset inside the thrusters,
    /// inertias a rigid body within the satellite's envelope
    /// (`Satellite::check_plausible`), times and frequencies finite and positive.
    pub fn check_plausible(&self, sat: &Satellite) -> Result<(), String> {
        self.validate()?;
        let name = self.name();
        let at_most = |what: &str, v: f64, max: f64, unit: &str| {
            if v <= max {
                Ok(())
            } else {
                Err(format!(
                    "{name}: {what} = {v}{unit} is implausible (at most {max}{unit})"
                ))
            }
        };
        let inertia_ok = |i: &[f64; 6]| {
            let mut s = sat.clone();
            s.inertia_kgm2 = *i;
            s.check_plausible().map_err(|r| format!("{name}: {r}"))
        };
        let r_max_mm = (0..sat.n_thrusters())
            .map(|i| nalgebra::Vector3::from(sat.thruster_pos_m[i]).norm() * 1e3)
            .fold(0.0, f64::max);
        let com_ok = |c: &[f64; 3]| {
            let d = nalgebra::Vector3::from(*c).norm();
            if d <= r_max_mm {
                Ok(())
            } else {
                Err(format!(
                    "{name}: offset_mm moves the CoM {d:.1} mm, outside the thrusters ({r_max_mm:.1} mm)"
                ))
            }
        };
        match self {
            Effect::ThrusterLatency(e) => {
                at_most("open_ms", e.open_ms, MAX_DELAY_MS, " ms")?;
                at_most("close_ms", e.close_ms, MAX_DELAY_MS, " ms")
            }
            Effect::ThrustRise(e) => at_most("tau_ms", e.tau_ms, MAX_DELAY_MS, " ms"),
            Effect::MeasurementDelay(e) => at_most("delay_ms", e.delay_ms, MAX_DELAY_MS, " ms"),
            Effect::ThrusterMisalignment(e) => {
                let n = sat.n_thrusters();
                if e.dir.len() != n {
                    return Err(format!(
                        "thruster_misalignment: dir has {} entries; satellite {} has {n} thrusters (one direction each, the model's where unchanged)",
                        e.dir.len(),
                        sat.name
                    ));
                }
                for (i, d) in e.dir.iter().enumerate() {
                    let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    if !(0.5..=1.5).contains(&norm) {
                        return Err(format!(
                            "thruster_misalignment: dir[{i}] is not a direction (norm {norm})"
                        ));
                    }
                    let tilt = thruster_misalignment::angle_deg(*d, sat.thrust_dir[i]);
                    if tilt > MAX_TILT_DEG {
                        return Err(format!(
                            "thruster_misalignment: thruster {} is tilted {tilt:.1} degrees from the model's direction (at most {MAX_TILT_DEG})",
                            i + 1
                        ));
                    }
                }
                Ok(())
            }
            Effect::ThrustScale(e) => {
                let n = sat.n_thrusters();
                if e.scale.len() != n {
                    return Err(format!(
                        "thrust_scale: scale has {} entries; satellite {} has {n} thrusters (one entry each, 1.0 for unchanged)",
                        e.scale.len(),
                        sat.name
                    ));
                }
                e.scale
                    .iter()
                    .try_for_each(|s| at_most("scale", *s, MAX_SCALE, ""))
            }
            Effect::GyroScale(e) => e
                .scale
                .iter()
                .try_for_each(|s| at_most("scale", *s, MAX_SCALE, "")),
            Effect::GyroBias(e) => e
                .counts
                .iter()
                .try_for_each(|c| at_most("|counts|", c.abs(), 4095.0, "")),
            Effect::PressureDrop(e) => {
                let f_max = sat.thrust_n.iter().cloned().fold(0.0, f64::max);
                non_negative_at_most(
                    name,
                    "newton_per_extra_thruster",
                    e.newton_per_extra_thruster,
                    f_max,
                )
            }
            Effect::ComOffset(e) => com_ok(&e.offset_mm),
            Effect::Inertia(e) => inertia_ok(&e.inertia_kgm2),
            Effect::MassPropertyChange(e) => {
                com_ok(&e.offset_mm)?;
                inertia_ok(&e.inertia_kgm2)
            }
            Effect::FuelSlosh(e) => e
                .inertia_fraction
                .iter()
                .try_for_each(|f| at_most("inertia_fraction", *f, 1.0, "")),
            Effect::Blowdown(e) => {
                if e.start_s < 0.0 {
                    return Err(format!("{name}: start_s = {} must be >= 0", e.start_s));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}

fn non_negative_at_most(name: &str, what: &str, v: f64, max: f64) -> Result<(), String> {
    if (0.0..=max).contains(&v) {
        Ok(())
    } else {
        Err(format!(
            "{name}: {what} = {v} N must be in 0..={max} N (the largest thrust)"
        ))
    }
}

/// The `.truth.json` beside a simulated recording: every effect present beyond the nominal model.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Truth {
    pub satellite: String,
    pub effects: Vec<Effect>,
}

/// Why a truth file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: line {line}, column {column}: {msg}")]
    Parse {
        path: String,
        line: usize,
        column: usize,
        msg: String,
    },
    #[error("{path}: {msg}")]
    Invalid { path: String, msg: String },
}

impl Truth {
    /// Parses a truth document (JSON) and checks every effect's parameters.
    pub fn from_json_str(text: &str, path: &str) -> Result<Truth, TruthError> {
        let t: Truth = serde_json::from_str(text).map_err(|e| TruthError::Parse {
            path: path.to_string(),
            line: e.line(),
            column: e.column(),
            msg: e.to_string(),
        })?;
        for e in &t.effects {
            e.validate().map_err(|msg| TruthError::Invalid {
                path: path.to_string(),
                msg,
            })?;
        }
        Ok(t)
    }

    /// Reads `NAME.truth.json`.
    pub fn read(path: &Path) -> Result<Truth, TruthError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| TruthError::Io {
            path: p.clone(),
            source,
        })?;
        Self::from_json_str(&text, &p)
    }

    /// Pretty JSON with a trailing newline (deterministic: field order is fixed).
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("truth serialises");
        s.push('\n');
        s
    }

    /// Writes the truth file.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        std::fs::write(path, self.to_json())
    }

    /// The truth path beside a recording: `X.csv` -> `X.truth.json`.
    pub fn path_for(recording: &Path) -> std::path::PathBuf {
        let stem = recording
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        recording.with_file_name(format!("{stem}.truth.json"))
    }
}
