//! `massid model show|check FILE`: the one model format, read as every subcommand reads it
//! (`massid_sim::model_file`), printed back normalised or checked.
use massid_sim::model_file::ModelFile;
use std::path::PathBuf;

#[derive(clap::Subcommand, Debug)]
pub enum Args {
    /// Print the model in the normalised layout (the satellite in full, every section).
    Show {
        /// Model file (TOML): either layout.
        file: PathBuf,
    },
    /// Check that every subcommand can use the model; errors name the file, line and column.
    Check {
        /// Model file (TOML): either layout.
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
            // The mixer needs thrusters that reach every axis: build it too.
            reference_f64::mixer::Mixer::from_satellite(
                &m.satellite,
                None,
                reference_f64::mixer::DEFAULT_PERIOD_MS,
            )
            .map_err(|e| {
                anyhow::anyhow!(
                    "{}: the mixer cannot use this satellite: {e}",
                    file.display()
                )
            })?;
            super::mix::emit(&format!(
                "{}: ok: satellite {}, {} effect(s) for the simulator\n",
                file.display(),
                m.satellite.name,
                m.effects.len()
            ))
        }
    }
}
