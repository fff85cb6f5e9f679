//! `massid`: one binary for demo, simulate, estimate, diagnose, import, mix, characterize.
//! One module per subcommand in `cmd/`; each owns its clap `Args` and a `run`.
use clap::{Parser, Subcommand};

mod cmd;

#[derive(Parser)]
#[command(
    name = "massid",
    version,
    about = "SPHERES-style mass-property identification, simulation and mismatch diagnosis"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate an RGA flight with a proof mass attached half way and identify it online
    /// with the f64 reference and the f32 and fixed-point kernels.
    Demo(cmd::demo::Args),
    /// Simulate a satellite and write a recording plus its truth file.
    Simulate(cmd::simulate::Args),
    /// Run a recording through the mass-property identification (f64, f32, fixed kernels).
    Estimate(cmd::estimate::Args),
    /// Explain why a recording and the nominal model disagree.
    Diagnose(cmd::diagnose::Args),
    /// Convert a CSV log from another system into a recording (format v2), driven by a
    /// TOML mapping of its columns and units.
    Import(cmd::import::Args),
    /// Turn a force/torque command into per-thruster PWM on/off times.
    Mix(cmd::mix::Args),
    /// Ground characterization tools (trifilar pendulum, torsion spring, damping, ...).
    Characterize(cmd::characterize::Args),
    /// Show a model file normalised, or check it (the one format every subcommand reads).
    #[command(subcommand)]
    Model(cmd::model::Args),
}

/// A closed stdout (`massid ... | head`) ends the process quietly, as it does for other
/// Unix tools: Rust ignores SIGPIPE, so every `println!` after the reader left would panic
/// ("failed printing to stdout: Broken pipe"). Restoring the default action makes the write
/// end the process (status 141 in a shell), with no message, in every subcommand.
#[cfg(unix)]
fn default_sigpipe() {
    extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
    }
    const SIGPIPE: i32 = 13; // Linux and the BSDs
    const SIG_DFL: usize = 0;
    // SAFETY: `signal` with SIG_DFL installs no handler code; it runs before any thread is
    // started, so no other thread can observe the change midway.
    unsafe {
        signal(SIGPIPE, SIG_DFL);
    }
}

#[cfg(not(unix))]
fn default_sigpipe() {}

fn main() -> std::process::ExitCode {
    default_sigpipe();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(a) => cmd::demo::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Estimate(a) => cmd::estimate::run(a),
        Command::Diagnose(a) => cmd::run_diagnose(a),
        Command::Import(a) => cmd::import::run(a),
        Command::Mix(a) => cmd::mix::run(a),
        Command::Characterize(a) => cmd::characterize::run(a),
        Command::Model(a) => cmd::model::run(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("massid: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
