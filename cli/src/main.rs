//! `massid`: one binary for demo, simulate, estimate, diagnose, mix, characterize.
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "massid", version, about = "SPHERES-style mass-property identification and mismatch diagnosis")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate an RGA flight with a proof mass attached half way and identify it online.
    Demo,
}

fn main() {
    let cli = Cli::parse();
    match cli.command {
        Command::Demo => {
            eprintln!("massid demo: not built yet");
            std::process::exit(2);
        }
    }
}
