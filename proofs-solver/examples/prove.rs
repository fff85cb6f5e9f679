//! Proves the obligations whose name contains the first argument (all if none), printing
//! each verdict and time: `cargo run --release -p massid-proofs-solver --example prove -- [filter] [--open] [--mutants] [--timeout S]`.

use massid_proofs_solver::discharge::Verdict;
use massid_proofs_solver::obligations;
use std::time::Duration;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let slow = args.iter().any(|a| a == "--open");
    let timeout = args
        .iter()
        .position(|a| a == "--timeout")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse::<u64>().ok())
        .unwrap_or(600);
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
            let ms =
                massid_proofs_solver::discharge::mutants(o.as_ref(), Duration::from_secs(timeout));
            for m in &ms {
                println!(
                    "{:28} site {:3} {:>7.2} s {:?} replays {:?}",
                    o.label(),
                    m.site,
                    m.outcome.time.as_secs_f64(),
                    m.outcome.verdict,
                    m.replays
                );
            }
            continue;
        }
        let out = o.prove(None, Duration::from_secs(timeout));
        let what = match &out.verdict {
            Verdict::Proved => "proved".to_string(),
            Verdict::Refuted(x) => {
                let (inside, holds) = o.replay(None, x);
                format!(
                    "REFUTED at {:?} = {x:x?} (replay: envelope {inside}, holds {holds})",
                    o.input_names()
                )
            }
            Verdict::Unknown(r) => format!("unknown ({r})"),
        };
        println!("{:28} {:>8.2} s  {what}", o.label(), out.time.as_secs_f64());
    }
}
