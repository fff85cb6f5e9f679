//! Speed of the whole diagnosis (issue 11: a 60 s, 1 kHz recording in under 10 s on one
//! core, and how the time grows with the recording's length). Simulated random-PWM
//! flights of sph2 at 1 kHz, 15/30/60/120 s long: nominal, with thruster latency, and with
//! three effects at once; against a baseline in the same run, one nominal prediction of
//! the same recording (the inner loop the fit repeats). The diagnosis is single-threaded.
//!
//!     cargo bench -p massid-diagnose --bench diagnose_60s
//!     cargo bench -p massid-diagnose --bench diagnose_60s -- 60     (only the 60 s rows)
//!
//! A second table runs the three-effect flight sampled at 100 and 250 Hz (60 s): the
//! prediction's cost there follows the samples and commands, not the milliseconds.
//!
//! "CPU per s of recording" and "vs 60 s" (CPU time against the 60 s row's) show the
//! growth: a linear cost keeps the first constant and the second at length / 60. CPU time
//! (user + system, /proc/self/stat) is what one core spends; the wall time also counts
//! waiting for a core on a shared machine.
use std::time::Instant;

use massid_diagnose::synth::{self, Maneuver};
use massid_diagnose::{diagnose_recording, model, series::Series, Settings};

const LATENCY: &str = r#"{"effect":"thruster_latency","params":{"open_ms":5.0,"close_ms":5.0}}"#;
const PRESSURE: &str = r#"{"effect":"pressure_drop","params":{"newton_per_extra_thruster":0.006}}"#;
const COM: &str = r#"{"effect":"com_offset","params":{"offset_mm":[1.5,-2.0,3.0]}}"#;

/// CPU time of this process so far (user + system), s, from /proc (Linux; NaN elsewhere):
/// on a shared machine the wall time also counts time spent waiting for a core.
fn cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // fields after the parenthesised command name; utime and stime are fields 14 and 15
    let Some(rest) = stat.rsplit(')').next() else {
        return f64::NAN;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| {
        f.get(i)
            .and_then(|x| x.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    // USER_HZ is 100 on Linux
    (tick(11) + tick(12)) / 100.0
}

struct Row {
    seconds: u32,
    samples: usize,
    pred_ms: f64,
    diag_s: f64,
    cpu_s: f64,
    n_pred: usize,
    found: String,
}

fn run(seconds: u32, rate_hz: u32, effects: &[&str]) -> Row {
    let eff = effects.iter().map(|j| synth::effect(j)).collect();
    let s = synth::make("sph2", Maneuver::Combo { seconds }, rate_hz, eff, 60);
    let series = Series::from_recording(&s.recording, &s.satellite).expect("samples");
    let plant = model::Plant::new(&s.satellite);
    let duty = model::duty_grid(&series, 0.0, 0.0, 0.0);
    let p = model::Params::default();
    let t = Instant::now();
    let reps = 10;
    for _ in 0..reps {
        std::hint::black_box(model::predict(&plant, &series, &duty, &p));
    }
    let pred = t.elapsed().as_secs_f64() / reps as f64;
    model::PREDICTIONS.store(0, std::sync::atomic::Ordering::Relaxed);
    let t = Instant::now();
    let c = cpu_s();
    let a =
        diagnose_recording(&s.recording, &s.satellite, &Settings::default()).expect("diagnosis");
    let diag = t.elapsed().as_secs_f64();
    let cpu = cpu_s() - c;
    let n_pred = model::PREDICTIONS.load(std::sync::atomic::Ordering::Relaxed);
    let found: Vec<&str> = a.output.effects.iter().map(|e| e.effect.as_str()).collect();
    Row {
        seconds,
        samples: series.len(),
        pred_ms: pred * 1e3,
        diag_s: diag,
        cpu_s: cpu,
        n_pred,
        found: if found.is_empty() {
            "-".into()
        } else {
            found.join(", ")
        },
    }
}

fn main() {
    // `cargo bench` passes `--bench`; any number among the arguments selects lengths
    let only: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let lengths: Vec<u32> = [15, 30, 60, 120]
        .into_iter()
        .filter(|l| only.is_empty() || only.contains(l))
        .collect();
    let cases: [(&str, Vec<&str>); 3] = [
        ("nominal", vec![]),
        ("latency 5 ms", vec![LATENCY]),
        (
            "latency + pressure drop + CoM offset",
            vec![LATENCY, PRESSURE, COM],
        ),
    ];
    println!(
        "| recording (sph2, 1 kHz, random PWM) | s | samples | one prediction (ms) | diagnosis wall (s) | CPU (s) | CPU per s of recording (ms) | vs 60 s | predictions run | diagnosis / prediction | found | 60 s under 10 s CPU |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, effects) in &cases {
        let rows: Vec<Row> = lengths.iter().map(|&l| run(l, 1000, effects)).collect();
        let at60 = rows.iter().find(|r| r.seconds == 60).map(|r| r.cpu_s);
        for r in &rows {
            println!(
                "| {name} | {} | {} | {:.2} | {:.1} | {:.1} | {:.0} | {} | {} | {:.0} | {} | {} |",
                r.seconds,
                r.samples,
                r.pred_ms,
                r.diag_s,
                r.cpu_s,
                1e3 * r.cpu_s / r.seconds as f64,
                at60.map(|d| format!("{:.2}", r.cpu_s / d))
                    .unwrap_or_else(|| "-".into()),
                r.n_pred,
                r.diag_s / (r.pred_ms * 1e-3),
                r.found,
                if r.seconds != 60 {
                    ""
                } else if r.cpu_s < 10.0 {
                    "met"
                } else {
                    "MISSED"
                }
            );
        }
    }
    // below 1 kHz a rigid craft's prediction takes steps of up to 10 ms between samples
    if only.is_empty() || only.contains(&60) {
        println!();
        println!("| recording (sph2, 60 s, random PWM, latency + pressure drop + CoM offset) | rate (Hz) | samples | one prediction (ms) | diagnosis wall (s) | CPU per min of recording (s) | predictions run | found |");
        println!("|---|---|---|---|---|---|---|---|");
        for rate in [100, 250] {
            let r = run(60, rate, &[LATENCY, PRESSURE, COM]);
            println!(
                "| three effects | {rate} | {} | {:.2} | {:.1} | {:.1} | {} | {} |",
                r.samples, r.pred_ms, r.diag_s, r.cpu_s, r.n_pred, r.found
            );
        }
    }
}
