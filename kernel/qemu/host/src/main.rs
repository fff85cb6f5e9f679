//! Host side of the QEMU checks (`scripts/cross-check.sh`, `scripts/kernel-report.sh`).
//!
//! ```text
//! massid-qemu-host run                      # the sequence on the host build, to stdout
//! massid-qemu-host compare HOST.txt QEMU.txt [MAX_ULP]
//! massid-qemu-host count FIRMWARE.elf [PROFILE.tsv [PCS.tsv]] < trace   # per-kind instruction counts from a QEMU exec trace (per function, per PC)
//! massid-qemu-host stack FIRMWARE.elf OBJDUMP.txt SYMBOL...   # worst-case stack per entry point
//! ```
use std::process::ExitCode;

mod compare;
mod stack;
mod trace;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("run") => {
            // `run --no-identification`: the suite of a core that cannot hold it (the M0)
            let identification = args.get(1).map(String::as_str) != Some("--no-identification");
            let mut out = String::new();
            match massid_qemu_runner::run_suite(&mut out, identification) {
                Ok(()) => {
                    print!("{out}");
                    Ok(())
                }
                Err(_) => Err("formatting the output failed".to_string()),
            }
        }
        Some("compare") => compare::main(args.get(1..).unwrap_or(&[])),
        Some("count") => trace::main(args.get(1..).unwrap_or(&[])),
        Some("stack") => stack::main(args.get(1..).unwrap_or(&[])),
        _ => Err("usage: massid-qemu-host run [--no-identification] | compare HOST QEMU [MAX_ULP] | count ELF [PROFILE [PCS]] < TRACE | stack ELF OBJDUMP SYMBOL...".to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("massid-qemu-host: {msg}");
            ExitCode::FAILURE
        }
    }
}
