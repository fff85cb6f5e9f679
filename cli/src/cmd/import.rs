//! `massid import LOG.csv --mapping MAP.toml --out REC.csv`: a CSV log from another system
//! into a `massid-recording/2` file, driven by a TOML mapping (columns and units). The
//! conversion lives in `reference_f64::import`; this module parses arguments, refuses to
//! overwrite anything and prints a one-line summary.
use anyhow::anyhow;
use reference_f64::import::{import, Mapping};
use reference_f64::rate_recording::Commands;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(
    allow_negative_numbers = true,
    after_help = "Example (the real air-bearing run):\n  massid import real_test_data.csv --mapping examples/import/airbearing-mpc.toml --out airbearing.csv\n\nThe mapping names the log's time column and unit (s, ms, us), one rate column per measured\naxis (rad/s, deg/s, or counts with counts_per_rad_s and bias_counts) and either the thruster\nstates (one column each, a packed list, or a bitmask) or a body wrench; see\nexamples/import/ and reference-f64/README.md."
)]
pub struct Args {
    /// Log to convert (CSV with a header line; quoted fields allowed).
    log: PathBuf,
    /// Mapping file (TOML): which columns hold time, rates and commands, in which units.
    #[arg(long)]
    mapping: PathBuf,
    /// Recording to write (massid-recording/2; `-`: stdout, the summary then goes to
    /// stderr); an existing file only with --force.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing --out.
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    super::check_output(&args.out, &[&args.log, &args.mapping], args.force)?;
    let mapping = Mapping::read(&args.mapping)?;
    let mut rec = import(&mapping, &args.log)?;
    rec.source = args.out.display().to_string();
    let to_stdout = super::is_stdout(&args.out);
    if to_stdout {
        let mut text = Vec::new();
        rec.write_to(&mut text)
            .map_err(|e| anyhow!("cannot write the recording: {e}"))?;
        super::mix::emit(&String::from_utf8_lossy(&text))?;
    } else {
        rec.write(&args.out).map_err(|e| anyhow!("{e}"))?;
    }

    let duration_s = match (rec.time_ms.first(), rec.time_ms.last()) {
        (Some(a), Some(b)) => (b - a) as f64 / 1000.0,
        _ => 0.0,
    };
    let commands = match &rec.commands {
        Commands::Thrusters { n, .. } => format!("{n} thrusters"),
        Commands::Wrench { present, .. } => {
            let names: Vec<&str> = reference_f64::rate_recording::WRENCH_COLUMNS
                .iter()
                .zip(present)
                .filter(|(_, p)| **p)
                .map(|(c, _)| *c)
                .collect();
            format!("wrench {}", names.join(","))
        }
    };
    let summary = format!(
        "wrote {}: {} rows, {duration_s:.3} s at {:.3} Hz, axes {}, {commands}, {} gaps ({} missing samples), {} duplicate rows dropped\n",
        args.out.display(),
        rec.time_ms.len(),
        rec.sample_rate_hz(),
        rec.axes_text(),
        rec.issues.gaps,
        rec.issues.missing_samples,
        rec.issues.duplicates,
    );
    if to_stdout {
        eprint!("{summary}");
        Ok(())
    } else {
        super::mix::emit(&summary)
    }
}
