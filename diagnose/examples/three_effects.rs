//! The speed bench's three-effect recording (sph2, random PWM, 1 kHz, seed 60; latency
//! 5/5 ms + pressure drop 0.006 N + CoM offset (1.5, -2, 3) mm) at the lengths given on
//! the command line (default 60 s): the diagnosis, every candidate's delta BIC and every
//! rejection with its reason (issue 11: the named set must not change with length).
//!
//!     cargo run --release -p massid-diagnose --example three_effects -- 30 60 120
use massid_diagnose::synth::{self, Maneuver};
use massid_diagnose::{diagnose_recording, model, report, Settings};

const LATENCY: &str = r#"{"effect":"thruster_latency","params":{"open_ms":5.0,"close_ms":5.0}}"#;
const PRESSURE: &str = r#"{"effect":"pressure_drop","params":{"newton_per_extra_thruster":0.006}}"#;
const COM: &str = r#"{"effect":"com_offset","params":{"offset_mm":[1.5,-2.0,3.0]}}"#;

fn main() {
    let mut lengths: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    if lengths.is_empty() {
        lengths.push(60);
    }
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    for seconds in lengths {
        let eff = [LATENCY, PRESSURE, COM]
            .iter()
            .map(|j| synth::effect(j))
            .collect();
        let s = synth::make("sph2", Maneuver::Combo { seconds }, 1000, eff, seed);
        model::PREDICTIONS.store(0, std::sync::atomic::Ordering::Relaxed);
        let t0 = std::time::Instant::now();
        let a = diagnose_recording(&s.recording, &s.satellite, &Settings::default())
            .expect("diagnosis");
        let n = model::PREDICTIONS.load(std::sync::atomic::Ordering::Relaxed);
        println!(
            "== {seconds} s, seed {seed} ({:.1} s, {n} predictions, {} repeats)",
            t0.elapsed().as_secs_f64(),
            massid_diagnose::fit::REPEATS.load(std::sync::atomic::Ordering::Relaxed)
        );
        print!("{}", report::summary(&a));
        for sc in &a.scores {
            print!("[{} {} {:.0}] ", sc.round, sc.effect, sc.delta_bic);
        }
        println!();
        for r in &a.rejections {
            println!(
                "  rejected round {} {} (dBIC {:.0}): {}",
                r.round, r.effect, r.delta_bic, r.reason
            );
        }
        let found: Vec<&str> = a.output.effects.iter().map(|e| e.effect.as_str()).collect();
        println!("named: {}", found.join(" + "));
    }
}
