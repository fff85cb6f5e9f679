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
    },
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args {
        Args::Show { file } => {
            let m = ModelFile::read(&file)?;
            super::mix::emit(&m.to_toml_string())
        }
        Args::Check { file } => {
            let m = ModelFile::read(&file)?;
            let sat = &m.satellite;
            // A 3-D SPHERES-layout model is mixed by the PWM mixer: it needs thrusters that
            // reach every axis, so build it too. Other craft are not mixed (said below).
            let spheres = !sat.planar && sat.n_thrusters() == reference_f64::satellite::N_THRUSTERS;
            if spheres {
                reference_f64::mixer::Mixer::from_satellite(
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
            }
            let kind = if sat.planar {
                "planar (yaw only: Izz and CoM x, y identifiable)"
            } else {
                "3-D"
            };
            let mixer = if spheres {
                ""
            } else {
                "; not a 12-thruster 3-D craft: no PWM mixer, no onboard kernel"
            };
            super::mix::emit(&format!(
                "{}: ok: satellite {}, {kind}, {} thrusters, {} effect(s) for the simulator{mixer}\n",
                file.display(),
                sat.name,
                sat.n_thrusters(),
                m.effects.len()
            ))
        }
    }
}
