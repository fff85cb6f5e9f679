//! `massid estimate REC.csv [--satellite sphN | --model FILE] --kernel f64|f32|fixed|all
//! [--json OUT.json]`: runs a recording through the mass-property identification and
//! prints (and optionally writes, as `contracts/estimate-output.md`) the estimate.
//!
//! The f64 path is the output-error identification (`reference_f64::flight_id`: any craft,
//! 3-D or planar, format v1 or v2, any maneuver, with its noise model and consistency test);
//! `--method seed` runs the seed's design instead (the reference's online pipeline, the
//! algorithm the kernels run, so `max_diff_vs_f64` then measures arithmetic; `--offline` its
//! zero-phase form). The f32 and fixed-point paths run the onboard kernel
//! (`massid_kernel::Pipeline`, the seed's design) one sample per tick ([`run_kernel`]).
use crate::cmd::Text;
use anyhow::{anyhow, bail, Context};
use reference_f64::flight_id::fit::SensorResponse;
use reference_f64::flight_id::flight::Flight;
use reference_f64::flight_id::{identify, FlightEstimate, Options as FlightOptions};
use reference_f64::mass_id::{COM_TERMS, INERTIA_TERMS};
use reference_f64::pipeline::{estimate_offline, estimate_online, Estimate, PipelineConfig};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;
use serde_json::{json, Map, Value};

const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Recording to identify (massid-recording/1 CSV, or /2 of a planar craft with --model).
    recording: PathBuf,
    /// Built-in satellite model (sph1..sph5); default: the recording's `satellite` metadata.
    #[arg(long, conflicts_with = "model")]
    satellite: Option<String>,
    /// Satellite model file (TOML, the fields of reference-f64's `Satellite`, or a
    /// simulator model file with a `[satellite]` table).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Implementation(s) to run: f64 (reference), f32, fixed, or all.
    #[arg(long, default_value = "f64")]
    kernel: String,
    /// Write the estimate as JSON (estimate-output v1) here (`-`: stdout).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Replace an existing --json file.
    #[arg(long)]
    force: bool,
    /// f64 path: `output-error` (default: every sample, any craft, fitted noise model) or
    /// `seed` (the seed's per-firing Kalman filter + RLS, the algorithm the kernels run).
    #[arg(long, default_value = "output-error")]
    method: String,
    /// With `--method seed`: the offline form (zero-phase filter over the whole recording)
    /// instead of the online one the kernels mirror.
    #[arg(long)]
    offline: bool,
    /// Known command-to-thrust (or measurement) delay, ms (output-error method).
    #[arg(long, default_value_t = 0.0)]
    latency_ms: f64,
    /// Rate sensor response: auto (gyro counts: point; rad/s: the most likely), point,
    /// backward-mean (attitude differenced over one sample), central-mean.
    #[arg(long, default_value = "auto")]
    sensor: String,
    /// Also fit a constant disturbance torque (e.g. a tilted air-bearing table).
    #[arg(long)]
    disturbance: bool,
    /// Also fit a yaw rate damping (planar craft).
    #[arg(long)]
    damping: bool,
}

/// The f64 identification method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    OutputError,
    Seed,
}

fn parse_method(s: &str) -> anyhow::Result<Method> {
    Ok(match s {
        "output-error" => Method::OutputError,
        "seed" => Method::Seed,
        other => bail!("--method {other:?}: expected output-error or seed"),
    })
}

fn parse_sensor(s: &str) -> anyhow::Result<Option<SensorResponse>> {
    Ok(match s {
        "auto" => None,
        "point" => Some(SensorResponse::Point),
        "backward-mean" => Some(SensorResponse::BackwardMean),
        "central-mean" => Some(SensorResponse::CentralMean),
        other => bail!("--sensor {other:?}: expected auto, point, backward-mean or central-mean"),
    })
}

impl Args {
    /// The human text goes to stderr when the JSON goes to stdout.
    fn text(&self) -> Text {
        Text::beside_json(self.json.as_deref())
    }

    fn flight_options(&self) -> anyhow::Result<FlightOptions> {
        if !(self.latency_ms.is_finite() && (0.0..=10_000.0).contains(&self.latency_ms)) {
            bail!("--latency-ms {}: must be in 0..=10000", self.latency_ms);
        }
        Ok(FlightOptions {
            latency_ms: self.latency_ms,
            sensor: parse_sensor(&self.sensor)?,
            disturbance: self.disturbance,
            damping: self.damping,
            ..FlightOptions::default()
        })
    }
}

/// Which form of the f64 reference runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceForm {
    /// Causal, per sample: the kernels' algorithm.
    Online,
    /// Zero-phase, whole recording.
    Offline,
}

/// The implementations `--kernel` may name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    F64,
    F32,
    Fixed,
}

impl Kernel {
    pub fn name(self) -> &'static str {
        match self {
            Kernel::F64 => "f64",
            Kernel::F32 => "f32",
            Kernel::Fixed => "fixed",
        }
    }
}

fn parse_kernels(s: &str) -> anyhow::Result<Vec<Kernel>> {
    Ok(match s {
        "f64" => vec![Kernel::F64],
        "f32" => vec![Kernel::F32],
        "fixed" => vec![Kernel::Fixed],
        "all" => vec![Kernel::F64, Kernel::F32, Kernel::Fixed],
        other => bail!("--kernel {other:?}: expected f64, f32, fixed or all"),
    })
}

/// Loads the satellite: `--model` (reference TOML, else a simulator model file), else
/// `--satellite`, else the recording's `satellite` metadata.
pub fn load_satellite(
    rec: &Recording,
    satellite: Option<&str>,
    model: Option<&Path>,
) -> anyhow::Result<Satellite> {
    if let Some(path) = model {
        // The one model format (either layout); its effects describe a simulated truth, the
        // estimators use its satellite.
        return Ok(massid_sim::model_file::ModelFile::read(path)?.satellite);
    }
    let name = match satellite {
        Some(n) => n.to_string(),
        None => rec.satellite().map(str::to_string).ok_or_else(|| {
            anyhow!(
                "{}: no `satellite` metadata; pass --satellite sphN or --model FILE",
                rec.source
            )
        })?,
    };
    Satellite::builtin(&name).ok_or_else(|| {
        anyhow!(
            "unknown satellite {name:?} (built-in: {}); pass --model FILE for other craft",
            Satellite::BUILTIN_NAMES.join(", ")
        )
    })
}

/// The f64 reference or one of the onboard kernels (`massid_kernel::Pipeline`, f32 or Q8.24
/// fixed point) run sample by sample as flight code would, telemetry gaps as gap ticks.
pub fn run_kernel(
    kernel: Kernel,
    rec: &Recording,
    sat: &Satellite,
    form: ReferenceForm,
) -> anyhow::Result<Estimate> {
    let cfg = PipelineConfig {
        keep_history: false,
        ..PipelineConfig::default()
    };
    match kernel {
        Kernel::F64 if form == ReferenceForm::Offline => Ok(estimate_offline(rec, sat, &cfg)),
        Kernel::F64 => Ok(estimate_online(rec, sat, &cfg)),
        Kernel::F32 => onboard::estimate::<f32>(rec, sat),
        Kernel::Fixed => onboard::estimate::<massid_kernel::Q8_24>(rec, sat),
    }
}

/// Glue between a recording/satellite of the ground tools and the onboard kernel (the
/// `massid-kernel-host` library).
pub mod onboard {
    /// The kernel's estimate of a recording, as the contract's result.
    pub fn estimate<S: massid_kernel::Scalar>(
        rec: &super::Recording,
        sat: &super::Satellite,
    ) -> anyhow::Result<super::Estimate> {
        Ok(massid_kernel_host::estimate::<S>(rec, sat)?)
    }
}

/// One implementation's result as the contract's JSON object.
pub fn result_json(e: &Estimate) -> Value {
    json!({
        "com_offset_mm": e.com_offset_mm,
        "com_offset_stderr_mm": e.com_offset_stderr_mm,
        "inertia_kgm2": e.inertia_kgm2,
        "inertia_stderr_kgm2": e.inertia_stderr_kgm2,
        "unobservable": e.unobservable,
        "updates": e.updates,
        "status": e.status,
    })
}

/// The output-error estimate as the contract's JSON object, plus how it was made: the
/// method, the sensor response and noise model used, and the consistency tests. Terms a planar
/// craft cannot identify are null, as in the planar contract examples.
pub fn flight_result_json(e: &FlightEstimate) -> Value {
    // The values of `names`, null where a planar craft cannot know the term.
    let shown = |names: &[&str], values: &[f64]| -> Vec<Value> {
        names
            .iter()
            .zip(values)
            .map(|(n, v)| {
                if e.not_planar.contains(n) {
                    Value::Null
                } else {
                    json!(v)
                }
            })
            .collect()
    };
    let inertia = shown(&INERTIA_TERMS, &e.inertia_kgm2);
    let inertia_se = shown(&INERTIA_TERMS, &e.inertia_stderr_kgm2);
    let com = shown(&COM_TERMS, &e.com_offset_mm);
    let com_se = shown(&COM_TERMS, &e.com_offset_stderr_mm);
    let noise: Vec<Value> = e
        .noise
        .iter()
        .enumerate()
        .filter_map(|(a, n)| {
            n.as_ref().map(|n| {
                json!({
                    "axis": AXIS_NAMES[a],
                    "ar_coefficients": n.phi,
                    "ma_coefficient": n.ma,
                    "ma_lag": n.ma_lag,
                    "innovation_rad_s": n.sigma2.sqrt(),
                    "rate_noise_rad_s": n.process_variance().sqrt(),
                })
            })
        })
        .collect();
    let tests: Vec<Value> = e
        .consistency
        .iter()
        .map(|t| json!({"test": t.name, "statistic": t.statistic, "dof": t.dof, "p_value": t.p_value}))
        .collect();
    json!({
        "com_offset_mm": com,
        "com_offset_stderr_mm": com_se,
        "inertia_kgm2": inertia,
        "inertia_stderr_kgm2": inertia_se,
        "unobservable": e.unobservable,
        "updates": e.samples_used,
        "status": e.status,
        "method": "output_error",
        "sensor_response": e.sensor.name(),
        "noise_model": noise,
        "consistency": tests,
    })
}

/// Largest absolute difference of each numeric field from the f64 result (nulls skipped).
pub fn max_diff_json(e: &Value, f64_result: &Value) -> Value {
    let nums = |v: &Value| -> Vec<Option<f64>> {
        match v {
            Value::Array(a) => a.iter().map(Value::as_f64).collect(),
            other => vec![other.as_f64()],
        }
    };
    // `null` when one side has a number the other has not (e.g. f64 found the inertia
    // implausible): no difference to state, rather than a reassuring 0.
    let maxdiff = |key: &str| -> Option<f64> {
        nums(&e[key])
            .iter()
            .zip(nums(&f64_result[key]))
            .try_fold(0.0, |m: f64, (a, b)| match (a, b) {
                (Some(a), Some(b)) => Some(m.max((a - b).abs())),
                (None, None) => Some(m),
                _ => None,
            })
    };
    json!({
        "com_offset_mm": maxdiff("com_offset_mm"),
        "com_offset_stderr_mm": maxdiff("com_offset_stderr_mm"),
        "inertia_kgm2": maxdiff("inertia_kgm2"),
        "inertia_stderr_kgm2": maxdiff("inertia_stderr_kgm2"),
        "updates": maxdiff("updates"),
    })
}

/// The whole estimate-output v1 document.
pub fn output_json(recording: &str, model: &str, results: &[(Kernel, Value)]) -> Value {
    let mut res = Map::new();
    for (k, e) in results {
        res.insert(k.name().to_string(), e.clone());
    }
    let mut doc = Map::new();
    doc.insert("format".into(), json!("massid-estimate/1"));
    doc.insert("recording".into(), json!(recording));
    doc.insert("model".into(), json!(model));
    doc.insert("results".into(), Value::Object(res));
    if let Some((_, base)) = results.iter().find(|(k, _)| *k == Kernel::F64) {
        if results.len() > 1 {
            let mut diffs = Map::new();
            for (k, e) in results.iter().filter(|(k, _)| *k != Kernel::F64) {
                diffs.insert(k.name().to_string(), max_diff_json(e, base));
            }
            doc.insert("max_diff_vs_f64".into(), Value::Object(diffs));
        }
    }
    Value::Object(doc)
}

fn print_flight_result(out: Text, kernel: Kernel, e: &FlightEstimate, sat: &Satellite) {
    say!(
        out,
        "[{}] output-error  status {}  samples {}  sensor {}",
        kernel.name(),
        e.status,
        e.samples_used,
        e.sensor.name()
    );
    let shown = |name: &str| !e.not_planar.contains(&name);
    for (a, name) in COM_TERMS.iter().enumerate() {
        if shown(name) {
            say!(
                out,
                "  {name} - model: {:+.4} +- {:.4} mm",
                e.com_offset_mm[a],
                e.com_offset_stderr_mm[a]
            );
        }
    }
    for (j, name) in INERTIA_TERMS.iter().enumerate() {
        if shown(name) {
            say!(
                out,
                "  {name}: {:.6e} +- {:.1e} kg m^2  (model {:.6e})",
                e.inertia_kgm2[j],
                e.inertia_stderr_kgm2[j],
                sat.inertia_kgm2[j]
            );
        }
    }
    if let Some((d, s)) = &e.disturbance_nm {
        let parts: Vec<String> = (0..3)
            .filter(|&a| s[a].is_finite())
            .map(|a| format!("{} {:+.2e} +- {:.1e}", AXIS_NAMES[a], d[a], s[a]))
            .collect();
        if !parts.is_empty() {
            say!(out, "  disturbance torque (N m): {}", parts.join(", "));
        }
    }
    if let Some((b, s)) = e.damping_nms.filter(|(_, s)| s.is_finite()) {
        say!(out, "  yaw damping: {b:+.4e} +- {s:.1e} N m s/rad");
    }
    for (a, n) in e.noise.iter().enumerate() {
        if let Some(n) = n {
            let ma = if n.ma == 0.0 {
                String::new()
            } else {
                format!(", MA {:+.3} at lag {}", n.ma, n.ma_lag)
            };
            say!(
                out,
                "  rate noise {}: {:.2e} rad/s, AR order {}{ma} (innovation {:.2e})",
                ["x", "y", "z"][a],
                n.process_variance().sqrt(),
                n.order(),
                n.sigma2.sqrt()
            );
        }
    }
    for t in &e.consistency {
        say!(
            out,
            "  consistency {}: chi2 {:.1} on {} dof, p = {:.2e}",
            t.name,
            t.statistic,
            t.dof,
            t.p_value
        );
    }
    let held: Vec<&&str> = e.unobservable.iter().filter(|n| shown(n)).collect();
    if !held.is_empty() {
        say!(
            out,
            "  unobservable (held at the model's values): {}",
            held.iter().map(|s| **s).collect::<Vec<_>>().join(", ")
        );
    }
    if !e.not_planar.is_empty() {
        say!(
            out,
            "  not identifiable on a planar craft: {}",
            e.not_planar.join(", ")
        );
    }
}

fn print_result(out: Text, kernel: Kernel, e: &Estimate, sat: &Satellite) {
    say!(
        out,
        "[{}] seed design  status {}  updates {}",
        kernel.name(),
        e.status,
        e.updates
    );
    let c = e.com_offset_mm;
    let cs = e.com_offset_stderr_mm;
    say!(
        out,
        "  CoM offset (mm, vs model): x {:+.3} +- {:.3}  y {:+.3} +- {:.3}  z {:+.3} +- {:.3}",
        c[0],
        cs[0],
        c[1],
        cs[1],
        c[2],
        cs[2]
    );
    for (j, name) in reference_f64::mass_id::INERTIA_TERMS.iter().enumerate() {
        say!(
            out,
            "  {name}: {:.6e} +- {:.1e} kg m^2  (model {:.6e})",
            e.inertia_kgm2[j],
            e.inertia_stderr_kgm2[j],
            sat.inertia_kgm2[j]
        );
    }
    if !e.unobservable.is_empty() {
        say!(
            out,
            "  unobservable (held at the model's values): {}",
            e.unobservable.join(", ")
        );
    }
}

/// A recording in format v2 (rates in rad/s, any craft): the output-error method only (the
/// onboard kernels fly 12-thruster v1 recordings).
fn run_v2(args: &Args, kernels: &[Kernel], method: Method) -> anyhow::Result<()> {
    use reference_f64::rate_recording::RateRecording;
    if method != Method::OutputError {
        bail!(
            "--method {}: a recording in format v2 is identified by the output-error method \
             only (the seed's design needs 12-thruster gyro counts, format v1)",
            args.method
        );
    }
    let rec = RateRecording::read(&args.recording)?;
    let sat = match &args.model {
        Some(path) => massid_sim::model_file::ModelFile::read(path)?.satellite,
        None => bail!(
            "{}: a recording in format v2 needs its craft's model: pass --model FILE",
            args.recording.display()
        ),
    };
    crate::cmd::inputs::check_recording(
        crate::cmd::inputs::Rec::V2(&rec),
        &args.recording,
        &sat,
        &crate::cmd::inputs::Needs::estimate(false),
    )?;
    check_json_output(args)?;
    let source = rec.source.clone();
    let results = output_error(args, &Flight::from_v2_owned(rec), &sat, kernels, &source)?;
    write_json(args, &source, &sat, &results)
}

/// The output-error identification of `flight` by each of `kernels`: the f64 reference
/// (`reference_f64::flight_id`) and the onboard kernel's form (`massid_kernel::flight_id`,
/// in f32 and in the fixed kernel's integer float), printed, with each kernel's largest
/// differences from f64. A kernel reading rates other than gyro counts is told the sensor
/// response the reference found likelier (`--sensor` overrides).
fn output_error(
    args: &Args,
    flight: &Flight,
    sat: &Satellite,
    kernels: &[Kernel],
    source: &str,
) -> anyhow::Result<Vec<(Kernel, Value)>> {
    let opts = args.flight_options()?;
    let out = args.text();
    let mut reference: Option<FlightEstimate> = None;
    let reference_of = |reference: &mut Option<FlightEstimate>| -> anyhow::Result<FlightEstimate> {
        if let Some(e) = reference {
            return Ok(e.clone());
        }
        let e = identify(flight, sat, &opts).map_err(|e| anyhow!("{source}: {e}"))?;
        *reference = Some(e.clone());
        Ok(e)
    };
    let mut results = Vec::new();
    for &k in kernels {
        let e = match k {
            Kernel::F64 => reference_of(&mut reference)?,
            Kernel::F32 | Kernel::Fixed => {
                let response = match opts.sensor {
                    Some(s) => Some(s),
                    None if flight.from_gyro_counts => None,
                    None => Some(reference_of(&mut reference)?.sensor),
                };
                let run = if k == Kernel::F32 {
                    massid_kernel_host::flight_id::identify::<f32>(
                        flight,
                        sat,
                        response,
                        opts.latency_ms,
                    )
                } else {
                    massid_kernel_host::flight_id::identify::<massid_kernel::IntFloat>(
                        flight,
                        sat,
                        response,
                        opts.latency_ms,
                    )
                };
                match run {
                    Ok(e) => e,
                    Err(why) if kernels.len() > 1 => {
                        say!(out, "[{}] output-error  not available: {why}", k.name());
                        continue;
                    }
                    Err(why) => bail!("{source}: [{}] {why}", k.name()),
                }
            }
        };
        print_flight_result(out, k, &e, sat);
        results.push((k, flight_result_json(&e)));
    }
    print_differences(out, &results);
    Ok(results)
}

/// Each kernel's largest differences from the f64 result.
fn print_differences(out: Text, results: &[(Kernel, Value)]) {
    if let Some((_, base)) = results.iter().find(|(k, _)| *k == Kernel::F64) {
        for (k, e) in results.iter().filter(|(k, _)| *k != Kernel::F64) {
            let d = max_diff_json(e, base);
            let show = |key: &str| {
                d[key].as_f64().map_or_else(
                    || "n/a (only one has a number)".to_string(),
                    |v| format!("{v:.3e}"),
                )
            };
            say!(
                out,
                "[{}] vs f64: max |diff| CoM {} mm, inertia {} kg m^2, inertia stderr {}",
                k.name(),
                show("com_offset_mm"),
                show("inertia_kgm2"),
                show("inertia_stderr_kgm2")
            );
        }
    }
}

fn check_json_output(args: &Args) -> anyhow::Result<()> {
    if let Some(out) = &args.json {
        let mut inputs: Vec<&Path> = vec![args.recording.as_path()];
        if let Some(m) = &args.model {
            inputs.push(m.as_path());
        }
        crate::cmd::check_output(out, &inputs, args.force)?;
    }
    Ok(())
}

fn write_json(
    args: &Args,
    source: &str,
    sat: &Satellite,
    results: &[(Kernel, Value)],
) -> anyhow::Result<()> {
    let Some(out) = &args.json else {
        return Ok(());
    };
    let file_name = args
        .recording
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string());
    let model = match &args.model {
        Some(m) => m.display().to_string(),
        None => sat.name.clone(),
    };
    let doc = output_json(&file_name, &model, results);
    let text = serde_json::to_string_pretty(&doc)? + "\n";
    if crate::cmd::is_stdout(out) {
        return crate::cmd::write_output(out, &text);
    }
    let tmp = out.with_extension("json.tmp");
    std::fs::write(&tmp, text).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, out).with_context(|| format!("{}: cannot write", out.display()))?;
    say!(args.text(), "wrote {}", out.display());
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let kernels = parse_kernels(&args.kernel)?;
    let method = parse_method(&args.method)?;
    if args.offline && method != Method::Seed {
        bail!("--offline is a form of --method seed");
    }
    if reference_f64::rate_recording::format_version(&args.recording)? == 2 {
        return run_v2(&args, &kernels, method);
    }
    let rec = Recording::read(&args.recording)?;
    // A declared rate that contradicts the time steps is an error (file and line) for every
    // implementation: flight code counts time in ticks of the declared period.
    rec.checked_period_ms()?;
    let sat = load_satellite(&rec, args.satellite.as_deref(), args.model.as_deref())?;
    let spheres = method == Method::Seed;
    crate::cmd::inputs::check_recording(
        crate::cmd::inputs::Rec::V1(&rec),
        &args.recording,
        &sat,
        &crate::cmd::inputs::Needs::estimate(spheres),
    )?;
    check_json_output(&args)?;
    let form = if args.offline {
        ReferenceForm::Offline
    } else {
        ReferenceForm::Online
    };
    if method == Method::OutputError {
        // The flight keeps what the fit reads; the rows as read are freed before it runs.
        let flight = Flight::from_v1(&rec, &sat);
        let source = rec.source.clone();
        drop(rec);
        let results = output_error(&args, &flight, &sat, &kernels, &source)?;
        return write_json(&args, &source, &sat, &results);
    }
    let out = args.text();
    let mut results = Vec::new();
    for k in kernels {
        let e = run_kernel(k, &rec, &sat, form)?;
        print_result(out, k, &e, &sat);
        results.push((k, result_json(&e)));
    }
    print_differences(out, &results);
    write_json(&args, &rec.source, &sat, &results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_parse_and_unknown_is_an_error() {
        assert_eq!(
            parse_kernels("all").unwrap(),
            vec![Kernel::F64, Kernel::F32, Kernel::Fixed]
        );
        assert!(parse_kernels("f16")
            .unwrap_err()
            .to_string()
            .contains("f16"));
    }

    #[test]
    fn json_has_the_contract_fields() {
        let sat = Satellite::builtin("sph2").unwrap();
        let rec = Recording::new("r.csv", Some("sph2"), Some(1000.0), Vec::new());
        let e = run_kernel(Kernel::F64, &rec, &sat, ReferenceForm::Online).unwrap();
        assert_eq!(e.status, "no_firings");
        let doc = output_json(
            "r.csv",
            "sph2",
            &[
                (Kernel::F64, result_json(&e)),
                (Kernel::F64, result_json(&e)),
            ],
        );
        assert_eq!(doc["format"], "massid-estimate/1");
        let r = &doc["results"]["f64"];
        for k in [
            "com_offset_mm",
            "com_offset_stderr_mm",
            "inertia_kgm2",
            "inertia_stderr_kgm2",
            "unobservable",
            "updates",
            "status",
        ] {
            assert!(!r[k].is_null(), "missing {k}");
        }
        assert_eq!(r["inertia_kgm2"].as_array().unwrap().len(), 6);
        // The onboard kernels run too (no firings: nothing identified, the model is reported).
        let k = run_kernel(Kernel::Fixed, &rec, &sat, ReferenceForm::Online).unwrap();
        assert_eq!(k.status, "no_firings");
        assert_eq!(k.inertia_kgm2, sat.inertia_kgm2);
    }
}
