//! The effect vocabulary: one file per effect, each an [`Effect`] that says everything the
//! diagnosis needs to know about it (parameters and how they enter the model, search space,
//! "no effect" values, physical bounds, observability, its signature in words, how it is
//! reported). The selection, the acceptance checks and the report ask the effect; none of
//! them matches on the effect's name. Adding an effect is one file here, one variant of
//! [`Kind`] and one line of [`Kind::effect`] (and its simulator twin in `sim/src/effects/`).

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

pub use mass_property_change::MASS_CHANGE_STARTS;

use crate::json_number::{num, nums};
use crate::model::{Params, Plant, NT};
use crate::series::Series;
use serde_json::{Map, Value};

/// Effects of the vocabulary (contract names).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
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
    /// Extra (beyond the contract's list): torque against the body rate.
    RateDamping,
    /// Extra (beyond the contract's list): first-order thrust rise at valve edges.
    ThrustRise,
    MeasurementDelay,
    ThrusterMisalignment,
}

impl Kind {
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
        Kind::MeasurementDelay,
        Kind::ThrusterMisalignment,
    ];

    /// The effect's description: the one registry of the vocabulary.
    pub fn effect(self) -> &'static dyn Effect {
        match self {
            Kind::ThrusterLatency => &thruster_latency::ThrusterLatency,
            Kind::PressureDrop => &pressure_drop::PressureDrop,
            Kind::Blowdown => &blowdown::Blowdown,
            Kind::ThrustScale => &thrust_scale::ThrustScale,
            Kind::ComOffset => &com_offset::ComOffset,
            Kind::Inertia => &inertia::Inertia,
            Kind::MassPropertyChange => &mass_property_change::MassPropertyChange,
            Kind::FuelSlosh => &fuel_slosh::FuelSlosh,
            Kind::GyroBias => &gyro_bias::GyroBias,
            Kind::GyroScale => &gyro_scale::GyroScale,
            Kind::GyroRinging => &gyro_ringing::GyroRinging,
            Kind::DisturbanceTorque => &disturbance_torque::DisturbanceTorque,
            Kind::RateDamping => &rate_damping::RateDamping,
            Kind::ThrustRise => &thrust_rise::ThrustRise,
            Kind::MeasurementDelay => &measurement_delay::MeasurementDelay,
            Kind::ThrusterMisalignment => &thruster_misalignment::ThrusterMisalignment,
        }
    }

    /// Contract name.
    pub fn name(self) -> &'static str {
        self.effect().name()
    }

    pub fn from_name(s: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.name() == s)
    }
}

/// Bounds, steps and starting points of one effect's parameters.
pub struct Spec {
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    pub step: Vec<f64>,
    pub starts: Vec<Vec<f64>>,
}

/// What an effect may look at about the recording and the model.
pub struct Context<'a> {
    /// Length of the recording on its own clock, s.
    pub duration_s: f64,
    /// The model's inertia (Ixx, Iyy, Izz, Ixy, Ixz, Iyz), kg m^2.
    pub nominal_inertia: [f64; 6],
    /// The smallest thrust of the model's thrusters, N.
    pub min_thrust_n: f64,
    /// How many thrusters the model has (per-thruster arrays are reported this long).
    pub n_thrusters: usize,
    /// Which thrusters are ever commanded open.
    pub fired: &'a [bool; NT],
    /// Low-frequency peaks of the current residual, Hz (slosh starting points).
    pub slosh_hint_hz: &'a [f64],
    /// The recording's sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The model's rigid-body geometry (thruster arms and directions, planar or not).
    pub plant: &'a Plant,
    /// The typical time a thruster command holds (median run of one thruster word), ms:
    /// delay searches place their starts a few per step.
    pub command_step_ms: f64,
}

/// The reported parameters and their standard errors, in the contract's names and units.
pub type Reported = (Map<String, Value>, Map<String, Value>);

/// One effect of the vocabulary. `theta` is always in the effect's own layout, the one
/// [`Effect::spec`] bounds.
pub trait Effect: Sync {
    /// Contract name.
    fn name(&self) -> &'static str;
    /// Number of parameters (without the initial-rate nuisances).
    fn n_params(&self, fired: &[bool; NT]) -> usize;
    /// Writes the parameters into the model (on top of the effects already there).
    fn apply(&self, theta: &[f64], fired: &[bool; NT], p: &mut Params);
    /// Search space: bounds, steps, starts.
    fn spec(&self, cx: &Context) -> Spec;
    /// `(index, value)` of the parameters that are "no effect" at that value: the Wald
    /// test's null.
    fn no_effect(&self, theta: &[f64], cx: &Context) -> Vec<(usize, f64)>;
    /// Whether the fitted effect can be seen in this recording at all (a change in time
    /// needs firings on both sides). `first_s`, `last_s`: first and last firing.
    fn observable(&self, _theta: &[f64], _first_s: f64, _last_s: f64) -> bool {
        true
    }
    /// Why the fitted values are not physics (bounds written next to each effect), or
    /// `None`. `at_bound(i)`: parameter `i` sits on the edge of its search box.
    fn implausible(
        &self,
        _theta: &[f64],
        _at_bound: &dyn Fn(usize) -> bool,
        _cx: &Context,
    ) -> Option<String> {
        None
    }
    /// Whether the effect can be told from the others on this craft at all (a tilt in
    /// the plane of a planar craft is a thrust scale): not tried when false.
    fn applies(&self, _cx: &Context) -> bool {
        true
    }
    /// Fitted on the residual after the rigid-body model, edge by edge, rather than through
    /// the model's parameters (an additive tone with a random phase per edge).
    fn on_residual(&self) -> bool {
        false
    }
    /// The effect's signature in the residual, in words (the evidence's first clause).
    fn signature(&self) -> &'static str;
    /// Width of the windows that locate it, ms.
    fn window_ms(&self) -> i64 {
        1000
    }
    /// Parameters and standard errors as the contract names them.
    fn report(&self, theta: &[f64], stderr: &dyn Fn(usize) -> f64, cx: &Context) -> Reported;
}

/// Which thrusters are ever commanded open (others cannot be fitted).
pub fn fired_thrusters(series: &Series) -> [bool; NT] {
    let mut any = 0u16;
    for &w in &series.word_ms {
        any |= w;
    }
    std::array::from_fn(|i| any & (1 << i) != 0)
}

/// Number of effect parameters (without the 3 initial-rate nuisances) of `kind`.
pub fn n_params(kind: Kind, fired: &[bool; NT]) -> usize {
    kind.effect().n_params(fired)
}

/// Writes the effect parameters `th` of `kind` into `p`.
pub fn apply(kind: Kind, th: &[f64], fired: &[bool; NT], p: &mut Params) {
    kind.effect().apply(th, fired, p)
}

/// `name: value` and `name: stderr` of one scalar parameter.
fn scalar(r: &mut Reported, name: &str, v: f64, se: f64) {
    r.0.insert(name.into(), num(v));
    r.1.insert(name.into(), num(se));
}

/// `name: [values]` and `name: [stderrs]` of parameters `range` of `theta`.
fn vector(
    r: &mut Reported,
    name: &str,
    theta: &[f64],
    stderr: &dyn Fn(usize) -> f64,
    range: std::ops::Range<usize>,
) {
    r.0.insert(name.into(), nums(&theta[range.clone()]));
    r.1.insert(name.into(), nums(&range.map(stderr).collect::<Vec<_>>()));
}

/// Every parameter has the same "no effect" value.
fn all_at(theta: &[f64], v: f64) -> Vec<(usize, f64)> {
    (0..theta.len()).map(|i| (i, v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn context<'a>(fired: &'a [bool; NT], hint: &'a [f64], plant: &'a Plant) -> Context<'a> {
        Context {
            duration_s: 60.0,
            nominal_inertia: [0.023, 0.024, 0.021, 1e-4, -2e-4, 3e-4],
            min_thrust_n: 0.1,
            n_thrusters: 12,
            fired,
            slosh_hint_hz: hint,
            sample_rate_hz: 1000.0,
            command_step_ms: 200.0,
            plant,
        }
    }

    /// Why an effect's description is not consistent with itself: the search space must
    /// have one bound and step per parameter, every start must lie inside it and not be
    /// called implausible, the "no effect" values must index real parameters, the name
    /// must round-trip and the report must say something.
    fn inconsistency(
        e: &dyn Effect,
        kind: Kind,
        fired: &[bool; NT],
        cx: &Context,
    ) -> Option<String> {
        let name = e.name();
        if Kind::from_name(name) != Some(kind) {
            return Some(format!("{name}: name does not round-trip"));
        }
        let n = e.n_params(fired);
        let sp = e.spec(cx);
        if kind == Kind::GyroRinging {
            // fitted on the residual, not through the model's parameters
            return (!sp.starts.is_empty()).then(|| format!("{name}: starts"));
        }
        if (sp.lo.len(), sp.hi.len(), sp.step.len()) != (n, n, n) || sp.starts.is_empty() {
            return Some(format!("{name}: search space not sized {n}"));
        }
        for st in &sp.starts {
            if st.len() != n || (0..n).any(|i| !(sp.lo[i] <= st[i] && st[i] <= sp.hi[i])) {
                return Some(format!("{name}: start {st:?} outside its bounds"));
            }
            if let Some(why) = e.implausible(st, &|_| false, cx) {
                return Some(format!("{name}: a start is implausible: {why}"));
            }
        }
        if e.no_effect(&sp.starts[0], cx).iter().any(|&(i, _)| i >= n) {
            return Some(format!("{name}: no-effect index beyond its parameters"));
        }
        let (p, s) = e.report(&sp.starts[0], &|_| 0.1, cx);
        (p.is_empty() || s.is_empty()).then(|| format!("{name}: empty report"))
    }

    #[test]
    fn every_effect_describes_its_parameters_consistently() {
        let mut fired = [true; NT];
        fired[3] = false;
        let plant = Plant::new(&reference_f64::satellite::Satellite::builtin("sph2").unwrap());
        let cx = context(&fired, &[0.45], &plant);
        for kind in Kind::ALL {
            assert_eq!(inconsistency(kind.effect(), kind, &fired, &cx), None);
        }
    }

    /// An effect whose search space lost a bound (a planted fault) is caught.
    struct LostBound;
    impl Effect for LostBound {
        fn name(&self) -> &'static str {
            "com_offset"
        }
        fn n_params(&self, f: &[bool; NT]) -> usize {
            com_offset::ComOffset.n_params(f)
        }
        fn apply(&self, th: &[f64], f: &[bool; NT], p: &mut Params) {
            com_offset::ComOffset.apply(th, f, p)
        }
        fn spec(&self, cx: &Context) -> Spec {
            let mut sp = com_offset::ComOffset.spec(cx);
            sp.hi.pop();
            sp
        }
        fn no_effect(&self, th: &[f64], cx: &Context) -> Vec<(usize, f64)> {
            com_offset::ComOffset.no_effect(th, cx)
        }
        fn signature(&self) -> &'static str {
            "planted"
        }
        fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, cx: &Context) -> Reported {
            com_offset::ComOffset.report(th, se, cx)
        }
    }

    #[test]
    fn a_missized_spec_is_caught() {
        let fired = [true; NT];
        let plant = Plant::new(&reference_f64::satellite::Satellite::builtin("sph2").unwrap());
        let cx = context(&fired, &[], &plant);
        let why = inconsistency(&LostBound, Kind::ComOffset, &fired, &cx);
        assert!(why.is_some_and(|w| w.contains("not sized")));
    }
}
