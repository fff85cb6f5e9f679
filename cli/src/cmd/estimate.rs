//! `massid estimate REC.csv [--satellite sphN | --model FILE] --kernel f64|f32|fixed|all
//! [--json OUT.json]`: runs a recording through the mass-property identification and
//! prints (and optionally writes, as `contracts/estimate-output.md`) the estimate.
//!
//! The f64 path is the reference's online pipeline (causal filter, one sample at a time: the
//! same flight algorithm the kernels run, so `max_diff_vs_f64` measures arithmetic, not a
//! different method) or, with `--offline`, its zero-phase offline form; the f32 and
//! fixed-point paths run the onboard kernel (`massid_kernel::Pipeline`) one sample per tick
//! ([`run_kernel`]).
use anyhow::{anyhow, bail, Context};
use reference_f64::pipeline::{estimate_offline, estimate_online, Estimate, PipelineConfig};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
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
    /// Write the estimate as JSON (estimate-output v1) here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// f64 path: the offline form (zero-phase filter over the whole recording) instead of the
    /// online one the kernels mirror. Better on its own, but not a like-for-like oracle.
    #[arg(long)]
    offline: bool,
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

/// Largest absolute difference of each field from the f64 result.
pub fn max_diff_json(e: &Estimate, f64_result: &Estimate) -> Value {
    let maxdiff = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    json!({
        "com_offset_mm": maxdiff(&e.com_offset_mm, &f64_result.com_offset_mm),
        "com_offset_stderr_mm": maxdiff(&e.com_offset_stderr_mm, &f64_result.com_offset_stderr_mm),
        "inertia_kgm2": maxdiff(&e.inertia_kgm2, &f64_result.inertia_kgm2),
        "inertia_stderr_kgm2": maxdiff(&e.inertia_stderr_kgm2, &f64_result.inertia_stderr_kgm2),
        "updates": (e.updates as i64 - f64_result.updates as i64).abs(),
    })
}

/// The whole estimate-output v1 document.
pub fn output_json(recording: &str, model: &str, results: &[(Kernel, Estimate)]) -> Value {
    let mut res = Map::new();
    for (k, e) in results {
        res.insert(k.name().to_string(), result_json(e));
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

fn print_result(kernel: Kernel, e: &Estimate, sat: &Satellite) {
    println!(
        "[{}] status {}  updates {}",
        kernel.name(),
        e.status,
        e.updates
    );
    let c = e.com_offset_mm;
    let cs = e.com_offset_stderr_mm;
    println!(
        "  CoM offset (mm, vs model): x {:+.3} +- {:.3}  y {:+.3} +- {:.3}  z {:+.3} +- {:.3}",
        c[0], cs[0], c[1], cs[1], c[2], cs[2]
    );
    for (j, name) in reference_f64::mass_id::INERTIA_TERMS.iter().enumerate() {
        println!(
            "  {name}: {:.6e} +- {:.1e} kg m^2  (model {:.6e})",
            e.inertia_kgm2[j], e.inertia_stderr_kgm2[j], sat.inertia_kgm2[j]
        );
    }
    if !e.unobservable.is_empty() {
        println!(
            "  unobservable (held at the model's values): {}",
            e.unobservable.join(", ")
        );
    }
}

/// A recording in format v2 of a planar craft: yaw-rate identification of Izz, the CoM's
/// x/y, rate damping and a disturbance torque (`reference_f64::planar_id`), reported in the
/// contract's layout with every term a planar craft cannot identify listed unobservable.
fn run_planar(args: &Args, kernels: &[Kernel]) -> anyhow::Result<()> {
    use reference_f64::planar_id::{self, PlanarModel, PlanarOptions, NOT_PLANAR_TERMS};
    use reference_f64::rate_recording::{Commands, RateRecording};
    if kernels != [Kernel::F64] {
        bail!(
            "--kernel {}: the onboard kernels fly the 12-thruster 3-D SPHERES layout; a planar \
             recording (format v2) is identified by the f64 reference only (--kernel f64)",
            args.kernel
        );
    }
    let rec = RateRecording::read(&args.recording)?;
    let sat = match (&args.model, &args.satellite) {
        (Some(path), _) => massid_sim::model_file::ModelFile::read(path)?.satellite,
        _ => bail!(
            "{}: a recording in format v2 needs its craft's model: pass --model FILE",
            args.recording.display()
        ),
    };
    let model = PlanarModel::from_satellite(&sat).ok_or_else(|| {
        anyhow!(
            "{}: model {} is 3-D; recordings in format v2 are identified for planar craft \
             only (`planar = true`)",
            args.recording.display(),
            sat.name
        )
    })?;
    let Commands::Thrusters { n, words } = &rec.commands else {
        bail!(
            "{}: the commands are a body wrench; identification needs thruster states",
            rec.source
        );
    };
    if *n != sat.n_thrusters() {
        bail!(
            "{}: {n} thrusters in the recording, {} in model {}",
            rec.source,
            sat.n_thrusters(),
            sat.name
        );
    }
    if let Some(out) = &args.json {
        let mut inputs: Vec<&Path> = vec![args.recording.as_path()];
        if let Some(m) = &args.model {
            inputs.push(m.as_path());
        }
        crate::cmd::check_output(out, &inputs)?;
    }
    let rate_z: Vec<f64> = rec.rate.iter().map(|r| r[2]).collect();
    let e = planar_id::identify(
        &model,
        &rec.time_ms,
        &rate_z,
        words,
        &PlanarOptions::default(),
    )
    .map_err(|e| anyhow!("{}: {e} (status {})", rec.source, e.status()))?;
    let mm = |v: Option<f64>| v.map(|x| x * 1e3);
    let mut unobservable: Vec<&str> = NOT_PLANAR_TERMS.to_vec();
    unobservable.extend(e.unobservable.iter().filter(|t| t.starts_with("cm_")));
    let i = sat.inertia_kgm2;
    let result = json!({
        "com_offset_mm": [mm(e.com_offset_m[0]), mm(e.com_offset_m[1]), Value::Null],
        "com_offset_stderr_mm": [mm(e.com_stderr_m[0]), mm(e.com_stderr_m[1]), Value::Null],
        "inertia_kgm2": [i[0], i[1], e.izz_kgm2, i[3], i[4], i[5]],
        "inertia_stderr_kgm2": [Value::Null, Value::Null, e.izz_stderr, Value::Null, Value::Null, Value::Null],
        "unobservable": unobservable,
        "updates": e.intervals_used,
        "status": "ok",
    });
    let se = |v: Option<f64>, s: Option<f64>, k: f64| match (v, s) {
        (Some(v), Some(s)) => format!("{:+.4} ± {:.4}", v * k, s * k),
        _ => "unobservable (held at the model)".to_string(),
    };
    println!(
        "planar identification of {} against {} ({} intervals, rate noise RMS {:.4} rad/s)",
        rec.source, sat.name, e.intervals_used, e.residual_rms_rad_s
    );
    println!(
        "  Izz        {:.4} ± {:.4} kg m^2 (model {:.4})",
        e.izz_kgm2, e.izz_stderr, model.izz_kgm2
    );
    println!(
        "  cm_x - model {} mm",
        se(e.com_offset_m[0], e.com_stderr_m[0], 1e3)
    );
    println!(
        "  cm_y - model {} mm",
        se(e.com_offset_m[1], e.com_stderr_m[1], 1e3)
    );
    println!(
        "  damping    {} N m s/rad",
        se(e.damping_nms, e.damping_stderr, 1.0)
    );
    println!(
        "  disturbance {} mN m",
        se(e.disturbance_nm, e.disturbance_stderr, 1e3)
    );
    println!(
        "  not identifiable on a planar craft: {}",
        NOT_PLANAR_TERMS.join(", ")
    );
    if let Some(out) = &args.json {
        let doc = json!({
            "format": "massid-estimate/1",
            "recording": args.recording.file_name().map(|f| f.to_string_lossy().into_owned()),
            "model": sat.name,
            "results": { "f64": result },
        });
        std::fs::write(out, serde_json::to_string_pretty(&doc)? + "\n")
            .with_context(|| format!("{}: cannot write", out.display()))?;
    }
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let kernels = parse_kernels(&args.kernel)?;
    if reference_f64::rate_recording::format_version(&args.recording)? == 2 {
        return run_planar(&args, &kernels);
    }
    let rec = Recording::read(&args.recording)?;
    // A declared rate that contradicts the time steps is an error (file and line) for every
    // implementation: flight code counts time in ticks of the declared period.
    rec.checked_period_ms()?;
    let sat = load_satellite(&rec, args.satellite.as_deref(), args.model.as_deref())?;
    if let Some(out) = &args.json {
        let mut inputs: Vec<&Path> = vec![args.recording.as_path()];
        if let Some(m) = &args.model {
            inputs.push(m.as_path());
        }
        crate::cmd::check_output(out, &inputs)?;
    }
    let form = if args.offline {
        ReferenceForm::Offline
    } else {
        ReferenceForm::Online
    };
    let mut results = Vec::new();
    for k in kernels {
        let e = run_kernel(k, &rec, &sat, form)?;
        print_result(k, &e, &sat);
        results.push((k, e));
    }
    if let Some(out) = &args.json {
        let file_name = args
            .recording
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_else(|| rec.source.clone());
        let model = match &args.model {
            Some(m) => m.display().to_string(),
            None => sat.name.clone(),
        };
        let doc = output_json(&file_name, &model, &results);
        let text = serde_json::to_string_pretty(&doc)? + "\n";
        let tmp = out.with_extension("json.tmp");
        std::fs::write(&tmp, text).with_context(|| format!("{}: cannot write", tmp.display()))?;
        std::fs::rename(&tmp, out).with_context(|| format!("{}: cannot write", out.display()))?;
        println!("wrote {}", out.display());
    }
    Ok(())
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
            &[(Kernel::F64, e.clone()), (Kernel::F64, e)],
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
