//! The effect vocabulary: one file per effect, each an [`Effect`] that says everything the
//! diagnosis needs to know about it (parameters and how they enter the model, search space,
//! "no effect" values, physical bounds, observability, its signature in words, how it is
//! reported). The selection, the acceptance checks and the report ask the effect; none of
//! them matches on the effect's name. The effect's contract name and its parameters' names,
//! shapes and units have one home, the simulator's (`massid_sim::effects`: [`Kind`] and the
//! effect's struct, which [`Effect::report`] fills). Adding an effect is its simulator file
//! (struct, physics) and variant, then one file here and one line of [`Describe`].

mod blowdown;
mod com_offset;
mod craft_scale;
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

pub use com_offset::plausible_mm as plausible_com_mm;
pub use mass_property_change::MASS_CHANGE_STARTS;

use crate::json_number::num;
use crate::model::{Params, Plant, NT};
use crate::series::Series;
use massid_sim::effects as contract;
use serde_json::{Map, Value};

/// The effects of the vocabulary, with their contract names: the simulator's registry,
/// shared so that both crates name every effect the same way.
pub use massid_sim::effects::Kind;

/// The diagnosis's description of each effect of the vocabulary.
pub trait Describe {
    /// The effect's description: the one registry of what the diagnosis knows about it.
    fn effect(self) -> &'static dyn Effect;
}

impl Describe for Kind {
    fn effect(self) -> &'static dyn Effect {
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
    /// The inertia the recording's own rate changes give (`equation_error.rs`; 3-D craft):
    /// an inertia fit's second start.
    pub inertia_start: Option<[f64; 6]>,
}

/// A fitted effect's parameters and standard errors in the contract's form: the
/// simulator's effect structs, the one home of each parameter's name, shape and unit (so a
/// diagnosis's effects read back as the simulator's, e.g. into a model file's `[[effects]]`),
/// plus keys beyond the struct's.
#[derive(Clone, Debug)]
pub struct Reported {
    pub params: contract::Effect,
    pub stderr: contract::Effect,
    /// Extra keys: (name, value, standard error or `None`).
    pub extra: Vec<(&'static str, Value, Option<Value>)>,
    /// Parameters whose error is not estimated: left out of `stderr`.
    pub unestimated: Vec<&'static str>,
    /// Array entries [`HELD`] at the model's value: (contract key, 0-based indices).
    pub held: Vec<(&'static str, Vec<usize>)>,
}

impl Reported {
    pub fn new(params: contract::Effect, stderr: contract::Effect) -> Self {
        Reported {
            params,
            stderr,
            extra: vec![],
            unestimated: vec![],
            held: vec![],
        }
    }

    /// With the entries `indices` of the array `key` held at the model's value (none: as
    /// it was).
    pub fn held(mut self, key: &'static str, indices: Vec<usize>) -> Self {
        if !indices.is_empty() {
            self.held.push((key, indices));
        }
        self
    }

    /// The extra key `held` of the contract's JSON: `{"inertia_kgm2": [3, 4, 5]}`, the
    /// entries (0-based) not fitted but held at the model's value; their `stderr` is the
    /// "not estimated" placeholder. Empty when nothing is held.
    pub fn held_json(&self) -> Map<String, Value> {
        self.held
            .iter()
            .map(|(k, ix)| ((*k).into(), ix.iter().map(|&i| Value::from(i)).collect()))
            .collect()
    }

    /// With the error of `key` not estimated (no `stderr` entry).
    pub fn unestimated(mut self, key: &'static str) -> Self {
        self.unestimated.push(key);
        self
    }

    /// With one more key beyond the struct's.
    pub fn with(mut self, key: &'static str, value: Value, stderr: Option<Value>) -> Self {
        self.extra.push((key, value, stderr));
        self
    }

    /// The `params` and `stderr` objects of the contract's JSON; a non-finite number (an
    /// unbounded or unestimated error) is written as JSON can carry it (`json_number`).
    pub fn maps(&self) -> (Map<String, Value>, Map<String, Value>) {
        let mut p = finite(self.params.params_json());
        let mut s = finite(self.stderr.params_json());
        for k in &self.unestimated {
            s.remove(*k);
        }
        for (k, v, e) in &self.extra {
            p.insert((*k).into(), v.clone());
            if let Some(e) = e {
                s.insert((*k).into(), e.clone());
            }
        }
        (p, s)
    }
}

/// An effect as the contract's JSON writes it, `{"effect": ..., "params": {...}}` (an
/// equivalent effect under `equivalent_to`).
pub fn contract_json(e: &contract::Effect) -> Value {
    let mut o = Map::new();
    o.insert("effect".into(), e.name().into());
    o.insert("params".into(), Value::Object(finite(e.params_json())));
    Value::Object(o)
}

/// serde writes a non-finite f64 as `null`; the contract writes it as [`num`] does.
fn finite(m: Map<String, Value>) -> Map<String, Value> {
    fn fix(v: Value) -> Value {
        match v {
            Value::Null => num(f64::INFINITY),
            Value::Array(a) => Value::Array(a.into_iter().map(fix).collect()),
            other => other,
        }
    }
    m.into_iter().map(|(k, v)| (k, fix(v))).collect()
}

/// One effect of the vocabulary. `theta` is always in the effect's own layout, the one
/// [`Effect::spec`] bounds.
pub trait Effect: Sync {
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
    /// The rates have kinks in these parameters, where a forward difference is one side's
    /// slope: the fit's Jacobian takes their columns by central differences
    /// (`fit::Family::two_sided`).
    fn kinked(&self) -> bool {
        false
    }
    /// Parameters no fit steps (`fit::Family::held`): searched by the effect's starts and
    /// a scan instead, because their Jacobian column is a difference across whatever
    /// firing the step happens to cross.
    fn held(&self) -> &'static [usize] {
        &[]
    }
    /// The effect's signature in the residual, in words (the evidence's first clause).
    fn signature(&self) -> &'static str;
    /// Width of the windows that locate it, ms.
    fn window_ms(&self) -> i64 {
        1000
    }
    /// Parameters and standard errors as the contract names them.
    fn report(&self, theta: &[f64], stderr: &dyn Fn(usize) -> f64, cx: &Context) -> Reported;
    /// Parameters that may be [`HELD`] at their "no effect" values, with their names (an
    /// inertia's products). The selection holds those the whole fit does not move beyond
    /// their BIC price and keeps the smaller form when the BIC prefers it, so a change the
    /// data explain with fewer parameters is not charged for more.
    fn holdable(&self, _cx: &Context) -> Vec<(usize, &'static str)> {
        vec![]
    }
}

/// A parameter held at the model's value: the effect's `apply` passes it on as NaN and the
/// prediction puts the model's value in its place (`model.rs`, `Params::inertia`), so no
/// sample depends on it and the fit neither moves it nor counts it in the BIC (its error is
/// NaN, as for every parameter the recording cannot see: `fit::identifiable`). It stays held
/// through every later fit, since it is carried in the effect's parameters.
pub const HELD: f64 = f64::NAN;

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

/// Parameters `off..off + 3` of `theta` (one per axis).
fn vec3(theta: &[f64], off: usize) -> [f64; 3] {
    std::array::from_fn(|i| theta[off + i])
}

/// Standard errors of parameters `off..off + 3`.
fn errors(se: &dyn Fn(usize) -> f64, off: usize) -> [f64; 3] {
    std::array::from_fn(|i| se(off + i))
}

/// Starting points of a timing search (a valve latency, a measurement delay): every `step`
/// from `from` to below `to` (ms), at most `max` of them, with the step at least a quarter
/// of the command step (a shift by a whole step is the next local minimum).
fn timing_starts(from: f64, to: f64, cx: &Context, max: usize) -> Vec<f64> {
    let step = (cx.command_step_ms / 4.0)
        .max((to - from) / max as f64)
        .max(1.0);
    let mut out = vec![];
    let mut d = from;
    while d < to && out.len() < max {
        out.push(d);
        d += step;
    }
    out
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
            inertia_start: None,
            plant,
        }
    }

    /// Why an effect's description is not consistent with itself: the search space must
    /// have one bound and step per parameter, every start must lie inside it and not be
    /// called implausible, the "no effect" values must index real parameters, and the
    /// report must be this effect's in the simulator's form (its contract name and
    /// parameters) and read back as the simulator's effect.
    fn inconsistency(
        e: &dyn Effect,
        kind: Kind,
        fired: &[bool; NT],
        cx: &Context,
    ) -> Option<String> {
        let name = kind.name();
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
        let r = e.report(&sp.starts[0], &|_| 0.1, cx);
        if r.params.kind() != kind || r.stderr.kind() != kind {
            return Some(format!("{name}: reported as {}", r.params.name()));
        }
        let (p, s) = r.maps();
        if p.is_empty() || s.is_empty() {
            return Some(format!("{name}: empty report"));
        }
        // what a diagnosis writes reads back as the simulator's effect
        let doc = serde_json::json!({"effect": name, "params": Value::Object(p)});
        match serde_json::from_value::<contract::Effect>(doc) {
            Ok(back) if back.kind() == kind => None,
            Ok(back) => Some(format!("{name}: reads back as {}", back.name())),
            Err(why) => Some(format!("{name}: does not read back: {why}")),
        }
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

    /// An effect that reports another effect's parameters (a planted fault) is caught.
    struct WrongReport;
    impl Effect for WrongReport {
        fn n_params(&self, f: &[bool; NT]) -> usize {
            com_offset::ComOffset.n_params(f)
        }
        fn apply(&self, th: &[f64], f: &[bool; NT], p: &mut Params) {
            com_offset::ComOffset.apply(th, f, p)
        }
        fn spec(&self, cx: &Context) -> Spec {
            com_offset::ComOffset.spec(cx)
        }
        fn no_effect(&self, th: &[f64], cx: &Context) -> Vec<(usize, f64)> {
            com_offset::ComOffset.no_effect(th, cx)
        }
        fn signature(&self) -> &'static str {
            "planted"
        }
        fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, cx: &Context) -> Reported {
            disturbance_torque::DisturbanceTorque.report(th, se, cx)
        }
    }

    #[test]
    fn a_report_in_another_effects_form_is_caught() {
        let fired = [true; NT];
        let plant = Plant::new(&reference_f64::satellite::Satellite::builtin("sph2").unwrap());
        let cx = context(&fired, &[], &plant);
        let why = inconsistency(&WrongReport, Kind::ComOffset, &fired, &cx);
        assert!(why.is_some_and(|w| w.contains("reported as disturbance_torque")));
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
