//! `massid mix`: one force/torque command through the f64 reference PWM mixer (seed 3.3,
//! Fig. 3.2), printing each thruster's ON/OFF time in ms within the control period.
use anyhow::{anyhow, bail, Context};
use reference_f64::mixer::{Mixer, DEFAULT_PERIOD_MS};
use reference_f64::satellite::Satellite;
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(
    about = "Turn a body-frame force/torque command into per-thruster PWM on/off times",
    long_about = "Runs the seed's PWM mixer (section 3.3, Fig. 3.2): mixing matrix from the calibrated \
thrusters about the CoM, pseudo-inverse, opposing/negative resolution, scaling by the maximum, \
pulse centring, multi-thruster pressure-drop correction (the model's parameter; 0 for the \
built-in sph1..sph5), 10 ms minimum pulse, 1 ms resolution. A craft without SPHERES' opposing \
thruster pairs (any other model: planar or 3-D, 1-16 thrusters) gets the smallest-norm \
non-negative duties instead of the pseudo-inverse and pair rules; a direction its thrusters \
cannot produce is an error, a planar craft takes Fx, Fy and Tz only. The command is the average force (N) \
and torque about the CoM (N m) wanted over one control period.",
    group(clap::ArgGroup::new("craft").required(true).args(["satellite", "model"])),
    allow_negative_numbers = true
)]
pub struct Args {
    /// Built-in satellite: sph1..sph5.
    #[arg(long)]
    satellite: Option<String>,
    /// Satellite model file (TOML), instead of --satellite.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// Force command, N, body axes: FX,FY,FZ.
    #[arg(long, value_name = "FX,FY,FZ", allow_hyphen_values = true, value_parser = parse_triple, default_value = "0,0,0")]
    force: [f64; 3],
    /// Torque command about the CoM, N m, body axes: TX,TY,TZ.
    #[arg(long, value_name = "TX,TY,TZ", allow_hyphen_values = true, value_parser = parse_triple, default_value = "0,0,0")]
    torque: [f64; 3],
    /// CoM estimate from the geometric centre, mm (default: the model's); lever arms are
    /// taken about it, so identified mass properties change firing times.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_triple)]
    com_mm: Option<[f64; 3]>,
    /// Control period, ms.
    #[arg(long, default_value_t = DEFAULT_PERIOD_MS)]
    period_ms: u32,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also print every intermediate stage of Fig. 3.2 (duties after the pseudo-inverse,
    /// after opposing/negative resolution, after the exact re-solve; scale; real on-times
    /// before and after the pressure-drop correction).
    #[arg(long)]
    trace: bool,
}

/// Commands scaled below this fraction to fit the thrusters are refused (a typo of the
/// units, e.g. 1e308, or mN for N): above it the mixer scales with a warning, as the seed's.
pub const MIN_REACH_SCALE: f64 = 1e-3;

/// Parses "a,b,c" into three finite numbers.
pub fn parse_triple(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected three comma-separated numbers, got {s:?}"));
    }
    let mut out = [0.0; 3];
    for (o, p) in out.iter_mut().zip(&parts) {
        let v: f64 = p
            .parse()
            .map_err(|_| format!("{p:?} is not a number (in {s:?})"))?;
        if !v.is_finite() {
            return Err(format!("{p:?} is not finite (in {s:?})"));
        }
        *o = v;
    }
    Ok(out)
}

fn load_satellite(args: &Args) -> anyhow::Result<Satellite> {
    match (&args.satellite, &args.model) {
        (Some(name), None) => Satellite::builtin(name).ok_or_else(|| {
            anyhow!(
                "unknown satellite {name:?}; built-in models are {}",
                Satellite::BUILTIN_NAMES.join(", ")
            )
        }),
        (None, Some(path)) => Ok(massid_sim::model_file::ModelFile::read(path)?.satellite),
        _ => bail!("give exactly one of --satellite or --model"),
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let sat = load_satellite(&args)?;
    let com = args.com_mm.map(|c| nalgebra::Vector3::from(c) * 1e-3);
    if let Some(c) = &com {
        // Lever arms about a point outside the craft are no mixing matrix anyone can fly.
        reference_f64::mixer_check::com_inside(&sat, c).map_err(|e| anyhow!("--com-mm: {e}"))?;
    }
    let mixer =
        Mixer::from_satellite(&sat, com, args.period_ms).context("cannot build the mixer")?;
    let force = nalgebra::Vector3::from(args.force);
    let torque = nalgebra::Vector3::from(args.torque);
    let trace = mixer.mix_traced(force, torque).with_context(|| {
        format!(
            "--force {:?} --torque {:?}: cannot mix the command for satellite {}",
            args.force, args.torque, sat.name
        )
    })?;
    // A command the thrusters cannot come near (or whose duties overflow) is refused, not
    // "scaled to 0.0000 %" with nothing fired.
    let finite = [
        &trace.pinv_duty[..],
        &trace.resolved_duty[..],
        &trace.refined_duty[..],
        &trace.on_time_ms[..],
        &trace.corrected_ms[..],
    ]
    .iter()
    .all(|v| v.iter().all(|x| x.is_finite()));
    if !(finite && trace.scale.is_finite() && trace.scale >= MIN_REACH_SCALE) {
        bail!(
            "--force {:?} --torque {:?}: out of reach: satellite {} delivers about {:.3e} of it in a {} ms period (the mixer refuses commands over {:.0} times its reach; the command is in N and N m)",
            args.force,
            args.torque,
            sat.name,
            if trace.scale.is_finite() { trace.scale } else { 0.0 },
            args.period_ms,
            1.0 / MIN_REACH_SCALE
        );
    }
    let firing = &trace.firing;
    let n = sat.n_thrusters();
    let mut stages: Vec<(&str, &[f64])> = if mixer.pinv().is_some() {
        vec![
            ("pinv_duty", &trace.pinv_duty[..n]),
            ("resolved_duty", &trace.resolved_duty[..n]),
            ("refined_duty", &trace.refined_duty[..n]),
        ]
    } else {
        vec![("allocated_duty", &trace.refined_duty[..n])]
    };
    stages.push(("on_time_ms", &trace.on_time_ms[..n]));
    stages.push(("corrected_ms", &trace.corrected_ms[..n]));
    let (jf, jt) = firing.impulse(mixer.geometry());
    let delivery = reference_f64::mixer_check::check(&mixer, &trace, force, torque);
    let warnings: Vec<String> = delivery.warnings.iter().map(|w| w.to_string()).collect();
    let mut text = String::new();
    if args.json {
        let thrusters: Vec<_> = (0..sat.n_thrusters())
            .map(|i| {
                serde_json::json!({
                    "thruster": i + 1,
                    "on_ms": firing.on_ms[i],
                    "off_ms": firing.off_ms[i],
                    "duration_ms": firing.duration_ms(i),
                })
            })
            .collect();
        let mut out = serde_json::json!({
            "satellite": sat.name,
            "period_ms": firing.period_ms,
            "min_pulse_ms": firing.min_pulse_ms,
            "pressure_drop_n_per_extra": mixer.config().pressure_drop_n_per_extra,
            "com_mm": (com.unwrap_or_else(|| sat.com_m()) * 1e3).as_slice(),
            "force_n": args.force,
            "torque_nm": args.torque,
            "scale": firing.scale,
            "thrusters": thrusters,
            "force_impulse_n_s": jf.as_slice(),
            "torque_impulse_n_m_s": jt.as_slice(),
            "delivered_force_n": delivery.delivered_force_n.as_slice(),
            "delivered_torque_nm": delivery.delivered_torque_nm.as_slice(),
            "warnings": warnings,
        });
        if args.trace {
            let mut t = serde_json::Map::new();
            for (name, v) in &stages {
                t.insert(name.to_string(), serde_json::json!(v));
            }
            t.insert("scale".into(), serde_json::json!(trace.scale));
            out["trace"] = serde_json::Value::Object(t);
        }
        text.push_str(&serde_json::to_string_pretty(&out)?);
        text.push('\n');
    } else {
        writeln!(
            text,
            "satellite {}  period {} ms  minimum pulse {} ms  pressure drop {} N/extra thruster",
            sat.name,
            firing.period_ms,
            firing.min_pulse_ms,
            mixer.config().pressure_drop_n_per_extra
        )?;
        writeln!(
            text,
            "{:<8} {:>36} {:>36}",
            "", "commanded", "delivered (period average)"
        )?;
        let row =
            |v: &nalgebra::Vector3<f64>| format!("[{:+.4e}, {:+.4e}, {:+.4e}]", v.x, v.y, v.z);
        writeln!(
            text,
            "{:<8} {:>36} {:>36}",
            "force N",
            row(&delivery.commanded_force_n),
            row(&delivery.delivered_force_n)
        )?;
        writeln!(
            text,
            "{:<8} {:>36} {:>36}",
            "torque Nm",
            row(&delivery.commanded_torque_nm),
            row(&delivery.delivered_torque_nm)
        )?;
        for w in &warnings {
            writeln!(text, "warning: {w}")?;
        }
        if args.trace {
            for (name, v) in &stages {
                let vals: Vec<String> = v.iter().map(|x| format!("{x:.6}")).collect();
                writeln!(text, "{name:>13}: {}", vals.join(" "))?;
            }
            writeln!(text, "{:>13}: {:.9}", "scale", trace.scale)?;
        }
        writeln!(text, "thruster  on_ms  off_ms  duration_ms")?;
        for i in 0..sat.n_thrusters() {
            writeln!(
                text,
                "{:>8}  {:>5}  {:>6}  {:>11}",
                i + 1,
                firing.on_ms[i],
                firing.off_ms[i],
                firing.duration_ms(i)
            )?;
        }
        writeln!(
            text,
            "delivered impulse: force [{:.6e}, {:.6e}, {:.6e}] N s, torque [{:.6e}, {:.6e}, {:.6e}] N m s",
            jf.x, jf.y, jf.z, jt.x, jt.y, jt.z
        )?;
    }
    emit(&text)
}

/// Writes `text` to stdout; a closed pipe (e.g. `| head`) is not an error, other write
/// failures are reported instead of panicking.
pub fn emit(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(anyhow!("cannot write to stdout: {e}"))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_triple;

    #[test]
    fn triples_parse_or_explain() {
        assert_eq!(parse_triple("-0.1, 0,2e-3"), Ok([-0.1, 0.0, 2e-3]));
        assert!(parse_triple("1,2").unwrap_err().contains("three"));
        assert!(parse_triple("1,x,2")
            .unwrap_err()
            .contains("\"x\" is not a number"));
        assert!(parse_triple("1,inf,2").unwrap_err().contains("not finite"));
    }
}
