//! Regenerates the score table of diagnose/README.md: concealed-effect recordings made
//! with the simulator (other satellites, sample rates, values, two effects at once,
//! effects below the time-domain noise) and nominal recordings for the false-positive
//! calibration, each diagnosed and scored.
//!
//!     cargo run --release -p massid-diagnose --example score_suite [-- --quick]
//!
//! `MASSID_SUITE_SEED_OFFSET` (u64, default 0) is added to every case's seed: the same
//! conditions with fresh noise, ringing phases and random-PWM commands (held-out validation).
use massid_diagnose::synth::{self, Maneuver};
use massid_diagnose::{diagnose_recording, score, Settings};

struct Case {
    name: &'static str,
    sat: &'static str,
    maneuver: Maneuver,
    rate: u32,
    effects: Vec<&'static str>,
    seed: u64,
}

fn cases() -> Vec<Case> {
    let combo = Maneuver::Combo { seconds: 30 };
    let rga = Maneuver::Rga12;
    let c = |name, sat, maneuver, rate, effects: Vec<&'static str>, seed| Case {
        name,
        sat,
        maneuver,
        rate,
        effects,
        seed,
    };
    vec![
        c("s01 nominal", "sph1", combo, 1000, vec![], 11),
        c("s02 nominal", "sph4", rga, 100, vec![], 12),
        c("s03 nominal", "sph5", combo, 50, vec![], 13),
        c("s04 nominal", "sph3", rga, 1000, vec![], 14),
        c(
            "s05 latency",
            "sph3",
            combo,
            1000,
            vec![r#"{"effect":"thruster_latency","params":{"open_ms":4.0,"close_ms":8.0}}"#],
            21,
        ),
        c(
            "s06 pressure drop",
            "sph1",
            combo,
            100,
            vec![r#"{"effect":"pressure_drop","params":{"newton_per_extra_thruster":0.006}}"#],
            22,
        ),
        c(
            "s07 blowdown",
            "sph4",
            combo,
            1000,
            vec![r#"{"effect":"blowdown","params":{"start_s":12.0,"tau_s":40.0}}"#],
            23,
        ),
        c(
            "s08 thrust scale",
            "sph5",
            combo,
            1000,
            vec![r#"{"effect":"thrust_scale","params":{"scale":[1,1,0.85,1,1,1,1,1,1,1,1,1]}}"#],
            24,
        ),
        c(
            "s09 com offset",
            "sph3",
            rga,
            1000,
            vec![r#"{"effect":"com_offset","params":{"offset_mm":[-2.0,1.0,1.5]}}"#],
            25,
        ),
        c(
            "s10 inertia",
            "sph1",
            rga,
            1000,
            vec![
                r#"{"effect":"inertia","params":{"inertia_kgm2":[0.024517,0.021529,0.0219,-0.000084,0.000014,0.00029]}}"#,
            ],
            26,
        ),
        c(
            "s11 fuel slosh",
            "sph4",
            rga,
            1000,
            vec![r#"{"effect":"fuel_slosh","params":{"freq_hz":0.5,"damping_ratio":0.01}}"#],
            27,
        ),
        c(
            "s12 ringing 50 Hz",
            "sph3",
            rga,
            50,
            vec![
                r#"{"effect":"gyro_ringing","params":{"freq_hz":338.0,"decay_ms":20.0,"apparent_hz":12.0}}"#,
            ],
            28,
        ),
        c(
            "s13 gyro bias",
            "sph2",
            rga,
            1000,
            vec![r#"{"effect":"gyro_bias","params":{"counts":[6.0,-4.0,3.0]}}"#],
            29,
        ),
        c(
            "s14 gyro scale",
            "sph5",
            combo,
            1000,
            vec![r#"{"effect":"gyro_scale","params":{"scale":[1.03,0.98,1.0]}}"#],
            30,
        ),
        c(
            "s15 disturbance",
            "sph1",
            combo,
            1000,
            vec![
                r#"{"effect":"disturbance_torque","params":{"torque_nm":[0.00003,-0.00002,0.0]}}"#,
            ],
            31,
        ),
        c(
            "s16 latency + thrust scale",
            "sph2",
            combo,
            1000,
            vec![
                r#"{"effect":"thruster_latency","params":{"open_ms":5.0,"close_ms":5.0}}"#,
                r#"{"effect":"thrust_scale","params":{"scale":[1,1,1,1,1,1,1,1,0.8,1,1,1]}}"#,
            ],
            32,
        ),
        c(
            "s17 slosh + com offset",
            "sph3",
            rga,
            1000,
            vec![
                r#"{"effect":"fuel_slosh","params":{"freq_hz":0.39,"damping_ratio":0.004}}"#,
                r#"{"effect":"com_offset","params":{"offset_mm":[1.0,2.0,-1.5]}}"#,
            ],
            33,
        ),
        c(
            "s18 below noise: latency 1.5 ms",
            "sph4",
            combo,
            1000,
            vec![r#"{"effect":"thruster_latency","params":{"open_ms":1.5,"close_ms":1.5}}"#],
            34,
        ),
        c(
            "s19 below noise: pressure drop",
            "sph2",
            combo,
            1000,
            vec![r#"{"effect":"pressure_drop","params":{"newton_per_extra_thruster":0.002}}"#],
            35,
        ),
        c(
            "s20 ringing 100 Hz + latency",
            "sph1",
            rga,
            100,
            vec![
                r#"{"effect":"gyro_ringing","params":{"freq_hz":338.0,"decay_ms":30.0,"apparent_hz":38.0}}"#,
                r#"{"effect":"thruster_latency","params":{"open_ms":6.0,"close_ms":6.0}}"#,
            ],
            36,
        ),
        c(
            "s21 mass property change",
            "sph2",
            rga,
            1000,
            vec![
                r#"{"effect":"mass_property_change","params":{"at_s":14.0,"offset_mm":[3.0,0.0,-2.0],"inertia_kgm2":[0.0266,0.0235,0.0213,0.000108,0.000157,0.0000123]}}"#,
            ],
            37,
        ),
        c(
            "s22 com offset + inertia",
            "sph5",
            combo,
            1000,
            vec![
                r#"{"effect":"com_offset","params":{"offset_mm":[2.0,-1.5,1.0]}}"#,
                r#"{"effect":"inertia","params":{"inertia_kgm2":[0.0254,0.021529,0.0212,-0.00022,0.0,0.0001]}}"#,
            ],
            38,
        ),
        c(
            "s23 ringing 1 kHz",
            "sph4",
            combo,
            1000,
            vec![
                r#"{"effect":"gyro_ringing","params":{"freq_hz":338.0,"decay_ms":25.0,"apparent_hz":338.0}}"#,
            ],
            39,
        ),
        c(
            "s24 ringing 100 Hz + blowdown",
            "sph5",
            combo,
            100,
            vec![
                r#"{"effect":"gyro_ringing","params":{"freq_hz":338.0,"decay_ms":30.0,"apparent_hz":38.0}}"#,
                r#"{"effect":"blowdown","params":{"start_s":10.0,"tau_s":25.0}}"#,
            ],
            40,
        ),
    ]
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let only: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let seed_offset: u64 = match std::env::var("MASSID_SUITE_SEED_OFFSET") {
        Ok(v) => v
            .trim()
            .parse()
            .unwrap_or_else(|e| panic!("MASSID_SUITE_SEED_OFFSET={v:?}: {e}")),
        Err(_) => 0,
    };
    println!("| case | sat | rate Hz | maneuver | truth | diagnosed | named | params within | worst rel. error | noise rms x | rms before (x y z) | rms after (x y z) | s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut named = 0;
    let mut total = 0;
    for c in cases()
        .into_iter()
        .filter(|c| !quick || c.name.contains("nominal"))
        .filter(|c| only.is_empty() || only.iter().any(|o| c.name.starts_with(o.as_str())))
    {
        let effects: Vec<_> = c.effects.iter().map(|j| synth::effect(j)).collect();
        let truth: Vec<serde_json::Value> = c
            .effects
            .iter()
            .map(|j| serde_json::from_str(j).unwrap())
            .collect();
        let s = synth::make(
            c.sat,
            c.maneuver,
            c.rate,
            effects,
            c.seed.wrapping_add(seed_offset),
        );
        let t0 = std::time::Instant::now();
        let a = diagnose_recording(&s.recording, &s.satellite, &Settings::default()).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        let sc = score::score(&a.output, &truth);
        if std::env::var_os("MASSID_DIAG_PROFILE").is_some() {
            eprintln!("{}", massid_diagnose::report::summary(&a));
            for sc in &a.scores {
                eprint!("[{} {} {:.0}] ", sc.round, sc.effect, sc.delta_bic);
            }
            eprintln!();
        }
        total += 1;
        if sc.named_correctly {
            named += 1;
        }
        let f = |v: [f64; 3]| format!("{:.4} {:.4} {:.4}", v[0], v[1], v[2]);
        let truth_names: Vec<&str> = truth
            .iter()
            .map(|t| t["effect"].as_str().unwrap())
            .collect();
        let got: Vec<&str> = a.output.effects.iter().map(|e| e.effect.as_str()).collect();
        let man = match c.maneuver {
            Maneuver::Rga12 => "rga12".to_string(),
            Maneuver::Combo { seconds } => format!("combo {seconds} s"),
        };
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {}/{} | {} | {:.4} | {} | {} | {:.0} |",
            c.name,
            c.sat,
            c.rate,
            man,
            if truth_names.is_empty() {
                "-".into()
            } else {
                truth_names.join(" + ")
            },
            if got.is_empty() {
                "-".into()
            } else {
                got.join(" + ")
            },
            if sc.named_correctly { "yes" } else { "NO" },
            sc.params_ok,
            sc.params,
            if sc.params > 0 {
                format!("{:.1} % ({})", 100.0 * sc.worst_rel_err, sc.worst_param)
            } else {
                "-".into()
            },
            a.noise.var[0].sqrt(),
            f(a.output.residual_rms_before),
            f(a.output.residual_rms_after),
            secs
        );
    }
    println!("\nnamed correctly: {named}/{total}");
}
