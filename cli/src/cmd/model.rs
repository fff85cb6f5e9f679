//! `massid model show|check FILE`: the one model format, read as every subcommand reads it
//! (`massid_sim::model_file`), printed back normalised or checked.
use massid_sim::model_file::ModelFile;
use std::path::PathBuf;

#[derive(clap::Subcommand, Debug)]
pub enum Args {
    /// Print the model in the normalised layout (the satellite in full, every section).
    Show {
        /// Model file (TOML): either layout; or a built-in name (sph1..sph5).
        file: PathBuf,
    },
    /// Check that every subcommand can use the model; errors name the file, line and column.
    Check {
        /// Model file (TOML): either layout; or a built-in name (sph1..sph5).
        file: PathBuf,
        /// Also print the craft's envelope in the kernel's fixed format: each quantity's
        /// worst-case range against the format's limit (the interval run of the kernel's
        /// wrench table over every thruster word).
        #[arg(long)]
        ranges: bool,
    },
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args {
        Args::Show { file } => {
            let m = ModelFile::read(&file)?;
            super::mix::emit(&m.to_toml_string())
        }
        Args::Check { file, ranges } => {
            let m = ModelFile::read(&file)?;
            let sat = &m.satellite;
            // Every craft is mixed: the seed's pair rules where thrusters come in SPHERES'
            // opposing pairs, the non-negative allocation otherwise. Say which, and which
            // pure axis commands the thrusters cannot produce at all.
            let mixer = reference_f64::mixer::Mixer::from_satellite(
                sat,
                None,
                reference_f64::mixer::DEFAULT_PERIOD_MS,
            )
            .map_err(|e| {
                anyhow::anyhow!(
                    "{}: the mixer cannot use this satellite: {e}",
                    file.display()
                )
            })?;
            let kind = if sat.planar {
                "planar (yaw only: Izz and CoM x, y identifiable)"
            } else {
                "3-D"
            };
            let rule = if mixer.pinv().is_some() {
                "mixer: the seed's opposing-pair rules"
            } else {
                "mixer: non-negative allocation"
            };
            let names = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];
            let mut unreachable = Vec::new();
            for &axis in mixer.geometry().axes() {
                for sign in [1.0, -1.0] {
                    let mut c = [0.0; 6];
                    c[axis] = sign * 1e-6;
                    let f = nalgebra::Vector3::new(c[0], c[1], c[2]);
                    let t = nalgebra::Vector3::new(c[3], c[4], c[5]);
                    if mixer.mix_traced(f, t).is_err() {
                        unreachable.push(format!(
                            "{}{}",
                            if sign > 0.0 { "+" } else { "-" },
                            names[axis]
                        ));
                    }
                }
            }
            let reach = if unreachable.is_empty() {
                "reaches every axis both ways".to_string()
            } else {
                format!("cannot produce {}", unreachable.join(", "))
            };
            let (envelope, table) = fixed_envelope(sat);
            let mixer = format!("; {rule}, {reach}; {}", kernel_fit(sat, &envelope));
            let mut text = format!(
                "{}: ok: satellite {}, {kind}, {} thrusters, {} effect(s) for the simulator{mixer}\n",
                file.display(),
                sat.name,
                sat.n_thrusters(),
                m.effects.len()
            );
            if ranges {
                text.push_str(&table);
            }
            super::mix::emit(&text)
        }
    }
}

/// Whether the onboard kernel flies this craft: its mixer in f32 and Q8.24 against the f64
/// reference on pure-axis commands (budgets `massid_kernel_host::craft::MIXER_BUDGET_*`),
/// and which identification it runs.
fn kernel_fit(sat: &reference_f64::satellite::Satellite, envelope: &str) -> String {
    use massid_kernel::scalar::Q8_24;
    use massid_kernel_host::craft::{
        axis_probes, mixer_deviation, MIXER_BUDGET_F32, MIXER_BUDGET_Q8_24,
    };
    let period = reference_f64::mixer::DEFAULT_PERIOD_MS;
    let probes = axis_probes(sat, period);
    let names = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];
    let probe_name = |j: usize| {
        probes
            .get(j)
            .map(|(f, t)| {
                let c = [f[0], f[1], f[2], t[0], t[1], t[2]];
                let k = c.iter().position(|v| *v != 0.0).unwrap_or(0);
                format!("{}{}", if c[k] > 0.0 { "+" } else { "-" }, names[k])
            })
            .unwrap_or_default()
    };
    let mut parts = Vec::new();
    for (flavour, dev, budget) in [
        (
            "f32",
            mixer_deviation::<f32>(sat, &probes, period),
            MIXER_BUDGET_F32,
        ),
        (
            "Q8.24",
            mixer_deviation::<Q8_24>(sat, &probes, period),
            MIXER_BUDGET_Q8_24,
        ),
    ] {
        parts.push(match dev {
            Ok((d, _)) if d <= budget => format!("{flavour} {d:.1e}"),
            Ok((d, j)) => format!(
                "{flavour} CANNOT: pulses {d:.1e} of the period off the reference on {} (budget {budget:.0e})",
                probe_name(j)
            ),
            Err(e) => format!("{flavour} CANNOT: {e}"),
        });
    }
    format!(
        "onboard kernel: {envelope}; mixer vs f64 reference (worst pulse error, of the period) {}; identification f32 and integer float",
        parts.join(", ")
    )
}

/// Whether the craft's envelope fits the kernel's fixed format (`massid_proofs::craft_envelope`:
/// the wrench table's interval run over every word, thrusts widened by their uncertainty, the
/// CoM anywhere in the box of the thrusters and the model's CoM), naming the quantity that
/// does not; and the range table.
fn fixed_envelope(sat: &reference_f64::satellite::Satellite) -> (String, String) {
    use massid_proofs::craft_envelope::{check, CraftEnvelope};
    use massid_proofs::interval::Format;
    let thrusters = match massid_kernel_host::craft::thrusters(sat) {
        Ok(t) => t,
        Err(e) => return (format!("Q8.24 CANNOT fly this craft: {e}"), String::new()),
    };
    let com = sat.com_m();
    let env = CraftEnvelope::new(
        &thrusters,
        &sat.thrust_sigma_n,
        sat.pressure_drop_n_per_extra,
        [com.x, com.y, com.z],
        sat.planar,
    );
    match check(
        &env,
        Format::Q8_24,
        massid_kernel_host::craft::MIXER_BUDGET_Q8_24,
    ) {
        Err(e) => (format!("Q8.24 CANNOT fly this craft: {e}"), String::new()),
        Ok(fit) => {
            let table = format!(
                "{}  resolution: half a step is {:.1e} of the thrusters' {} (a duty error; budget {:.0e})\n",
                fit.ranges.table(),
                fit.duty_resolution,
                fit.resolution_component,
                fit.duty_budget
            );
            let largest = fit.largest();
            let verdict = match fit.refusal() {
                Some(why) => format!("Q8.24 CANNOT fly this craft: {why}"),
                None => format!(
                    "Q8.24 envelope fits (largest {} {:.3} of {}; half a step is {:.1e} of the thrusters' {})",
                    largest.map(|v| v.name.as_str()).unwrap_or("-"),
                    largest.map(|v| v.range.mag()).unwrap_or(0.0),
                    fit.ranges.format.max,
                    fit.duty_resolution,
                    fit.resolution_component
                ),
            };
            (verdict, table)
        }
    }
}
