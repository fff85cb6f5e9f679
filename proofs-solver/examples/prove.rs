//! Proves the obligations whose name contains the first argument (all if none), printing
//! each verdict, Z3's resource count ("rlimit count") and time:
//! `cargo run --release -p massid-proofs-solver --example prove -- [filter] [--open] [--mutants] [--rlimit N] [--guard S]`.
//!
//! Without `--rlimit` each question gets the limit the tests use (`PROOF_RLIMIT`, or the
//! obligation's mutant limit); `--rlimit 0` removes it (then only the wall-clock guard,
//! `--guard S`, default 7200 s, stops Z3, and a guard hit is printed, not counted as a
//! verdict): that is how the consumption figures of `proofs/README.md` were measured.

use massid_proofs_solver::discharge::{self, Budget, Verdict};
use massid_proofs_solver::obligations;
use std::time::Duration;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let slow = args.iter().any(|a| a == "--open");
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .and_then(|s| s.parse::<u64>().ok())
    };
    let rlimit = value("--rlimit").map(|n| u32::try_from(n).expect("--rlimit fits u32"));
    let guard = value("--guard").map_or(discharge::GUARD, Duration::from_secs);
    let filter = args
        .first()
        .filter(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_default();
    let mut list = obligations::all();
    if slow {
        list.extend(obligations::open());
    }
    let mutate = args.iter().any(|a| a == "--mutants");
    for o in list.iter().filter(|o| o.label().contains(&filter)) {
        if mutate {
            let budget = Budget {
                rlimit: rlimit.unwrap_or(o.mutant_budget().rlimit),
                guard,
            };
            for site in 0..o.sites() {
                match o.prove(Some(site), budget) {
                    Ok(out) => {
                        let replays = match &out.verdict {
                            Verdict::Refuted(x) => {
                                let (inside, holds) = o.replay(Some(site), x);
                                Some(inside && !holds)
                            }
                            _ => None,
                        };
                        println!(
                            "{:28} site {:3} rlimit {:>11} {:>8.2} s {:?} replays {:?}",
                            o.label(),
                            site,
                            out.rlimit_used,
                            out.time.as_secs_f64(),
                            out.verdict,
                            replays
                        );
                    }
                    Err(e) => println!("{:28} site {:3} {e}", o.label(), site),
                }
            }
            continue;
        }
        let budget = Budget {
            rlimit: rlimit.unwrap_or(discharge::PROOF_RLIMIT),
            guard,
        };
        let out = match o.prove(None, budget) {
            Ok(out) => out,
            Err(e) => {
                println!("{:28} {e}", o.label());
                continue;
            }
        };
        let what = match &out.verdict {
            Verdict::Proved => "proved".to_string(),
            Verdict::Refuted(x) => {
                let (inside, holds) = o.replay(None, x);
                format!(
                    "REFUTED at {:?} = {x:x?} (replay: envelope {inside}, holds {holds})",
                    o.input_names()
                )
            }
            Verdict::Unknown(r) => format!("undecided within rlimit {} ({r})", budget.rlimit),
        };
        println!(
            "{:28} rlimit {:>11} {:>8.2} s  {what}",
            o.label(),
            out.rlimit_used,
            out.time.as_secs_f64()
        );
    }
}
