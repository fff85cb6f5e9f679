//! `massid simulate`: fly a maneuver on a simulated satellite (with the effects of a model
//! file) and write the recording plus its `.truth.json`. A SPHERES-like craft is recorded in
//! format v1 (gyro counts); any other (planar, another thruster count, a rate sensor in
//! rad/s) in format v2, flying a maneuver built from its own thrusters.
use anyhow::{anyhow, bail, Context};
use massid_sim::model_file::ModelFile;
use massid_sim::{simulate_into, Maneuver, SimSpec, Truth};
use reference_f64::satellite::Satellite;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Built-in satellite (sph1..sph5); a model file's satellite wins when both are given.
    #[arg(long, default_value = "sph2")]
    satellite: String,
    /// rga12 | single | combo | random-pwm | closed-loop (rga12 and closed-loop fly the SPHERES
    /// layout; single, combo and random-pwm are built from any craft's own thrusters)
    #[arg(long, default_value = "rga12")]
    maneuver: String,
    /// Model file (TOML): satellite, effects, sensors, telemetry artefacts.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Sample rate of the recording, Hz (a divisor of 1000).
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Length in seconds (default: the maneuver's own length).
    #[arg(long)]
    seconds: Option<f64>,
    /// Random seed: the same seed gives the same bytes.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Largest integration step, ms.
    #[arg(long, default_value_t = 1.0)]
    step_ms: f64,
    /// Output recording (CSV); the truth file goes beside it as NAME.truth.json.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing recording and truth file.
    #[arg(long)]
    force: bool,
}

/// The recording must not be named like a truth file: its truth would be written beside it
/// as `NAME.truth.truth.json`, and tools that pair `X.csv` with `X.truth.json` would take the
/// recording for a truth.
fn refuse_truth_name(out: &std::path::Path) -> anyhow::Result<()> {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if name.ends_with(".truth.json") || name.ends_with(".json") {
        bail!("{}: the recording is CSV (e.g. flight.csv); its truth goes beside it as flight.truth.json", out.display());
    }
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let maneuver = Maneuver::parse(&args.maneuver).ok_or_else(|| {
        anyhow!(
            "unknown maneuver {:?} (one of: {})",
            args.maneuver,
            Maneuver::NAMES.join(", ")
        )
    })?;
    if !(args.step_ms.is_finite() && args.step_ms > 0.0 && args.step_ms <= 10.0) {
        bail!("--step-ms {}: must be in (0, 10]", super::num(args.step_ms));
    }
    let mut spec = match &args.model {
        Some(path) => {
            let m = ModelFile::read(path)?;
            let mut s = SimSpec::new(m.satellite, m.effects, maneuver);
            s.sensors = m.sensors;
            s.artefacts = m.artefacts;
            s
        }
        None => {
            let sat = Satellite::builtin(&args.satellite).ok_or_else(|| {
                anyhow!(
                    "unknown satellite {:?} (built-in: {})",
                    args.satellite,
                    Satellite::BUILTIN_NAMES.join(", ")
                )
            })?;
            SimSpec::new(sat, Vec::new(), maneuver)
        }
    };
    spec.rate_hz = args.rate;
    spec.seconds = args.seconds;
    spec.seed = args.seed;
    spec.max_step_ms = args.step_ms;

    refuse_truth_name(&args.out)?;
    let truth_path = Truth::path_for(&args.out);
    let mut inputs: Vec<&std::path::Path> = Vec::new();
    if let Some(m) = &args.model {
        inputs.push(m);
    }
    if super::is_stdout(&args.out) {
        bail!("--out -: a recording goes to a file (its truth file goes beside it)");
    }
    super::check_output(&args.out, &inputs, args.force)?;
    super::check_output(&truth_path, &inputs, args.force)?;
    if truth_path == args.out {
        bail!(
            "{}: the output must not be named like a truth file",
            args.out.display()
        );
    }

    // The recording is written as it is simulated (an hour at 1 kHz is never held whole),
    // atomically: a temporary file beside it, renamed once complete, as
    // `Recording::write` does; a bad spec or a failure leaves nothing behind.
    let file_name = args
        .out
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = args
        .out
        .with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    let result = (|| {
        let (out, f) = simulate_into(&spec, || std::fs::File::create(&tmp))?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, &args.out)?;
        Ok::<_, massid_sim::SimError>(out)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    let out = result.map_err(|e| match e {
        massid_sim::SimError::SpheresOnly { .. } => match &args.model {
            Some(path) => anyhow!("{}: {e}", path.display()),
            None => e.into(),
        },
        massid_sim::SimError::TooManySteps { .. } => {
            anyhow!("--step-ms {}: {e}", super::num(args.step_ms))
        }
        massid_sim::SimError::BadSeconds(_) => anyhow!("--seconds: {e}"),
        massid_sim::SimError::BadRate(_) => anyhow!("--rate: {e}"),
        massid_sim::SimError::Write(_) => anyhow!("{}: {e}", args.out.display()),
        e => e.into(),
    })?;
    let span_s = match (out.first_ms, out.last_ms) {
        (Some(a), Some(b)) => (b - a) as f64 / 1000.0,
        _ => 0.0,
    };
    if let Some(asked) = args.seconds {
        if (span_s - asked).abs() > 0.5 {
            eprintln!(
                "note: --seconds {asked} is the maneuver's firing time; the recording spans {span_s:.3} s (the {} script ends its last command and coast there)",
                maneuver.name()
            );
        }
    }
    let rows = out.rows;
    out.truth
        .write(&truth_path)
        .with_context(|| format!("{}: cannot write", truth_path.display()))?;
    eprintln!(
        "wrote {} ({} samples, {} Hz, {} s, maneuver {}, {} effects) and {}",
        args.out.display(),
        rows,
        spec.rate_hz,
        out.commanded_ms as f64 / 1000.0,
        maneuver.name(),
        out.truth.effects.len(),
        truth_path.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::refuse_truth_name;
    use std::path::Path;

    #[test]
    fn a_recording_is_not_named_like_a_truth_file() {
        // `--out x.truth.json` used to write the recording there and its truth to
        // x.truth.truth.json.
        assert!(refuse_truth_name(Path::new("out/x.truth.json")).is_err());
        assert!(refuse_truth_name(Path::new("x.JSON")).is_err());
        assert!(refuse_truth_name(Path::new("out/flight.csv")).is_ok());
    }
}
