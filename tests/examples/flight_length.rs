//! What users gain (issue 22 item 6): each term's precision against flight length, the seed's
//! design (the reference's online pipeline, what the kernels run) against the output-error
//! identification, on nominal SPH2 at 1 kHz. rga12 cut at 7, 14, 28 s; combo of 10, 20, 40 s.
//! Per cell: the RMS error over the flights and the median reported sigma, per term.
//! `cargo run --release -p massid-tests --example flight_length -- FLIGHTS SEED0`
use massid_sim::{simulate, Maneuver, SimSpec};
use reference_f64::flight_id::flight::Flight;
use reference_f64::flight_id::{identify, Options};
use reference_f64::pipeline::{estimate_online, PipelineConfig};
use reference_f64::satellite::Satellite;

const TERMS: [&str; 9] = [
    "cm_x", "cm_y", "cm_z", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz",
];

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flights: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(20);
    let seed0: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5000);
    let sat = Satellite::builtin("sph2").expect("sph2");
    let mut truth = [0.0; 9];
    truth[3..].copy_from_slice(&sat.inertia_kgm2);
    println!("| maneuver | length s | method | {} |", TERMS.join(" | "));
    println!("|---|---|---|{}", "---|".repeat(9));
    for (m, lengths) in [
        (Maneuver::Rga12, [7.0, 14.0, 28.0]),
        (Maneuver::Combo, [10.0, 20.0, 40.0]),
    ] {
        for len in lengths {
            // Per method: per term (errors, reported sigmas); unobservable terms skipped.
            let mut acc: [[(Vec<f64>, Vec<f64>); 9]; 2] =
                std::array::from_fn(|_| std::array::from_fn(|_| (Vec::new(), Vec::new())));
            for seed in seed0..seed0 + flights {
                let mut spec = SimSpec::new(sat.clone(), Vec::new(), m);
                spec.seed = seed;
                spec.seconds = Some(len);
                let out = simulate(&spec).expect("simulation");
                let seed_design = estimate_online(&out.recording, &sat, &PipelineConfig::default());
                let values = |c: [f64; 3], cs: [f64; 3], i: [f64; 6], is: [f64; 6]| {
                    let mut v = [(0.0, 0.0); 9];
                    for a in 0..3 {
                        v[a] = (c[a], cs[a]);
                    }
                    for a in 0..6 {
                        v[3 + a] = (i[a], is[a]);
                    }
                    v
                };
                let before = values(
                    seed_design.com_offset_mm,
                    seed_design.com_offset_stderr_mm,
                    seed_design.inertia_kgm2,
                    seed_design.inertia_stderr_kgm2,
                );
                for t in 0..9 {
                    if !seed_design.unobservable.iter().any(|u| u == TERMS[t]) {
                        acc[0][t].0.push(before[t].0 - truth[t]);
                        acc[0][t].1.push(before[t].1);
                    }
                }
                if let Ok(e) = identify(
                    &Flight::from_v1(&out.recording, &sat),
                    &sat,
                    &Options::default(),
                ) {
                    let after = values(
                        e.com_offset_mm,
                        e.com_offset_stderr_mm,
                        e.inertia_kgm2,
                        e.inertia_stderr_kgm2,
                    );
                    for t in 0..9 {
                        if !e.unobservable.contains(&TERMS[t]) {
                            acc[1][t].0.push(after[t].0 - truth[t]);
                            acc[1][t].1.push(after[t].1);
                        }
                    }
                }
            }
            for (k, name) in ["seed design", "output-error"].iter().enumerate() {
                let cells: Vec<String> = acc[k]
                    .iter()
                    .enumerate()
                    .map(|(t, (err, sig))| {
                        if err.is_empty() {
                            return "unobservable".to_string();
                        }
                        let rms =
                            (err.iter().map(|e| e * e).sum::<f64>() / err.len() as f64).sqrt();
                        let s = median(sig.clone());
                        if t < 3 {
                            format!("{s:.3} ({rms:.3})")
                        } else {
                            format!("{s:.1e} ({rms:.1e})")
                        }
                    })
                    .collect();
                println!("| {} | {len} | {name} | {} |", m.name(), cells.join(" | "));
            }
        }
    }
    println!("\nEach cell: median reported sigma (RMS error over {flights} flights, seeds {seed0}..); CoM in mm, inertia in kg m^2.");
}
