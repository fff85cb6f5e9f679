//! The Cramér–Rao bound of the output-error identification (`reference_f64::flight_id`)
//! computed two independent ways on SPH2 (1 kHz, rga12 and combo): the estimator's own
//! profile information at the truth (`crlb_analytic`) and central differences through the
//! simulator with the initial rate a nuisance (`crlb_fd_with_initial_rate`); then a Monte
//! Carlo of `identify` against the analytic bound, on every sample and on the samples the
//! recording delivered (combo flights that spin past the gyro's range lose samples).
//! `cargo run --release -p massid-tests --example crlb_two_ways -- [N] [SEED0] [IMPL]`
//! (IMPL `f64`, the default, or a kernel, `f32` / `fixed`: the Monte Carlo then runs that
//! implementation against the same bound, and the bound's two-way check is skipped);
//! `... -- diagnose [N] [SEED0] [rga12|combo]` separates model mismatch, quantisation and
//! noise in the errors (see `diagnose`).
use massid_sim::{Maneuver, SimSpec};
use massid_tests::crlb::{
    crlb_analytic, crlb_analytic_delivered, crlb_fd_with_initial_rate,
    crlb_fd_with_initial_rate_steps, FdSteps, N,
};
use massid_tests::identification_mc::{estimate_with, fly, Condition, Implementation, TERMS};
use reference_f64::flight_id::{identify, Options};
use reference_f64::satellite::Satellite;
use std::time::Instant;

/// The spec `identification_mc::fly` flies for `Condition::Spheres` (noise x1).
fn spheres_spec(maneuver: Maneuver, seed: u64) -> SimSpec {
    let sat = Satellite::builtin("sph2").expect("sph2");
    let mut spec = SimSpec::new(sat, Vec::new(), maneuver);
    spec.rate_hz = 1000.0;
    spec.seed = seed;
    spec
}

fn fmt_sd(j: usize, var: f64) -> String {
    if j < 3 {
        format!("{:.4} mm", var.sqrt())
    } else {
        format!("{:.3e}", var.sqrt())
    }
}

/// Per flight: error of each term (NaN when not estimated) and the analytic CRLB variances
/// of the flight's own commands, on every sample and on the samples the recording delivered
/// (saturated gyro counts are missing samples).
struct Outcome {
    seed: u64,
    err: [f64; N],
    bound: [f64; N],
    bound_delivered: [f64; N],
    missing: usize,
    status: String,
}

fn run_flight(
    maneuver: Maneuver,
    seed: u64,
    fixed_bound: Option<&[f64; N]>,
    imp: Implementation,
) -> Outcome {
    let cond = Condition::Spheres {
        maneuver,
        rate_hz: 1000.0,
        noise: 1.0,
    };
    let sim = fly(&cond, seed);
    let spec = spheres_spec(maneuver, seed);
    let bound = match fixed_bound {
        Some(b) => *b,
        None => crlb_analytic(&spec),
    };
    let missing = sim
        .flight
        .rate
        .iter()
        .filter(|r| r.iter().any(|v| !v.is_finite()))
        .count();
    let bound_delivered = if missing > 0 {
        crlb_analytic_delivered(&spec, &sim.flight)
    } else {
        bound
    };
    let (err, status) = match estimate_with(imp, &sim, &Options::default()) {
        Ok(e) => (
            core::array::from_fn(|j| {
                if e.unobservable.contains(&TERMS[j]) {
                    f64::NAN
                } else if j < 3 {
                    e.com_offset_mm[j] - sim.truth[j]
                } else {
                    e.inertia_kgm2[j - 3] - sim.truth[j]
                }
            }),
            e.status.to_string(),
        ),
        Err(why) => ([f64::NAN; N], why.to_string()),
    };
    Outcome {
        seed,
        err,
        bound,
        bound_delivered,
        missing,
        status,
    }
}

/// Mean over flights of `error^2 / var` and of `error / sd` per term, with the flights used.
fn ratios(outcomes: &[Outcome], var: impl Fn(&Outcome) -> [f64; N]) -> ([f64; N], [f64; N], usize) {
    let mut ratio = [0.0; N];
    let mut bias = [0.0; N];
    let mut count = [0usize; N];
    for o in outcomes {
        let v = var(o);
        for j in 0..N {
            if o.err[j].is_finite() {
                ratio[j] += o.err[j] * o.err[j] / v[j];
                bias[j] += o.err[j] / v[j].sqrt();
                count[j] += 1;
            }
        }
    }
    for j in 0..N {
        ratio[j] /= count[j].max(1) as f64;
        bias[j] /= count[j].max(1) as f64;
    }
    (ratio, bias, count.iter().copied().min().unwrap_or(0))
}

/// Where the Monte Carlo's excess over the bound comes from (`diagnose [N] [SEED0]
/// [MANEUVER]`): per flight of `maneuver`, the identification's error in sd of the
/// all-sample CRLB (`crlb_analytic`) of the same commands with
/// (A) the true rates, no noise (model mismatch between the simulator and the estimator);
/// (B) the noise-free rates through the 12-bit gyro counts (quantisation, undithered);
/// (C) the true rates plus the simulator's AR(1) gyro noise, not quantised;
/// (D) the Monte Carlo's flight (noise, then quantised); and the estimator's reported
/// standard error over the CRLB sd in (D). A and B: RMS error/sd; C and D: mean error^2/var.
/// With at most 5 flights, each flight's saturated (missing) samples and windows too.
fn diagnose(maneuver: Maneuver, flights: u64, seed0: u64) {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use reference_f64::flight_id::flight::Flight;
    let term_err = |e: &reference_f64::flight_id::FlightEstimate, truth: &[f64; N]| -> [f64; N] {
        core::array::from_fn(|j| {
            if j < 3 {
                e.com_offset_mm[j] - truth[j]
            } else {
                e.inertia_kgm2[j - 3] - truth[j]
            }
        })
    };
    let run = |seed: u64| -> [[f64; N]; 5] {
        let spec = spheres_spec(maneuver, seed);
        let sat = spec.satellite.clone();
        let mut truth = [0.0; N];
        truth[3..].copy_from_slice(&sat.inertia_kgm2);
        let bound = crlb_analytic(&spec);
        let mut quiet = spec.clone();
        quiet.sensors.noiseless = true;
        let out = massid_sim::simulate(&quiet).expect("simulation");
        let counts = Flight::from_v1(&out.recording, &sat);
        let mut exact = counts.clone();
        exact.rate = out.body_rate.clone().into();
        let rho = massid_tests::crlb::gyro_rho(&spec);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xC0FFEE);
        let mut noisy = exact.clone();
        let mut v = [0.0f64; 3];
        let rates = noisy.rate.rad_s_mut().expect("true rates, rad/s");
        for (k, r) in rates.iter_mut().enumerate() {
            for a in 0..3 {
                let w: f64 = StandardNormal.sample(&mut rng);
                let sigma = spec.sensors.gyro_noise_rad_s[a];
                v[a] = if k == 0 {
                    sigma * w
                } else {
                    rho * v[a] + sigma * (1.0 - rho * rho).sqrt() * w
                };
                r[a] += v[a];
            }
        }
        let cond = Condition::Spheres {
            maneuver,
            rate_hz: 1000.0,
            noise: 1.0,
        };
        let mc = fly(&cond, seed).flight;
        if flights <= 5 {
            let missing = mc
                .rate
                .iter()
                .filter(|r| r.iter().any(|v| !v.is_finite()))
                .count();
            let wins = reference_f64::flight_id::flight::windows(&mc, 20, false);
            let peak: [f64; 3] = core::array::from_fn(|a| {
                out.body_rate.iter().map(|r| r[a].abs()).fold(0.0, f64::max)
            });
            println!(
                "seed {seed}: {missing} of {} samples missing (saturated counts), {} windows, peak |rate| {peak:.3?} rad/s",
                mc.rate.len(),
                wins.len()
            );
        }
        let opts = Options::default();
        let mut rows = [[f64::NAN; N]; 5];
        for (i, f) in [&exact, &counts, &noisy, &mc].into_iter().enumerate() {
            if let Ok(e) = identify(f, &sat, &opts) {
                let err = term_err(&e, &truth);
                rows[i] = core::array::from_fn(|j| err[j] / bound[j].sqrt());
                if i == 3 {
                    rows[4] = core::array::from_fn(|j| {
                        let se = if j < 3 {
                            e.com_offset_stderr_mm[j]
                        } else {
                            e.inertia_stderr_kgm2[j - 3]
                        };
                        se / bound[j].sqrt()
                    });
                }
            }
        }
        rows
    };
    let seeds: Vec<u64> = (seed0..seed0 + flights).collect();
    let all: Vec<[[f64; N]; 5]> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..2)
            .map(|th| {
                let mine: Vec<u64> = seeds.iter().copied().skip(th).step_by(2).collect();
                let run = &run;
                s.spawn(move || mine.into_iter().map(run).collect::<Vec<_>>())
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("worker"))
            .collect()
    });
    println!(
        "## Diagnosis: {} , {flights} flights (seeds {seed0}..)\n",
        maneuver.name()
    );
    print!("| case |");
    for t in TERMS {
        print!(" {t} |");
    }
    println!("\n|---|{}", "---|".repeat(N));
    let labels = [
        "A true rates, no noise: RMS error / CRLB sd",
        "B counts, no noise: RMS error / CRLB sd",
        "C true rates + AR(1) noise: mean error^2 / CRLB var",
        "D Monte Carlo flight: mean error^2 / CRLB var",
        "D reported stderr / CRLB sd (mean)",
    ];
    for (i, label) in labels.iter().enumerate() {
        print!("| {label} |");
        for j in 0..N {
            let vals: Vec<f64> = all
                .iter()
                .map(|r| r[i][j])
                .filter(|v| v.is_finite())
                .collect();
            let m = vals.len().max(1) as f64;
            let v = match i {
                0 | 1 => (vals.iter().map(|x| x * x).sum::<f64>() / m).sqrt(),
                2 | 3 => vals.iter().map(|x| x * x).sum::<f64>() / m,
                _ => vals.iter().sum::<f64>() / m,
            };
            print!(" {v:.2} |");
        }
        println!();
    }
    // The largest single-flight contributions in D (outliers or a general excess?).
    for j in 6..N {
        let mut z2: Vec<(f64, u64)> = all
            .iter()
            .zip(&seeds)
            .map(|(r, &s)| (r[3][j] * r[3][j], s))
            .collect();
        z2.sort_by(|a, b| b.0.total_cmp(&a.0));
        let top: Vec<String> = z2
            .iter()
            .take(5)
            .map(|(v, s)| {
                format!(
                    "{v:.1} (seed {s}, A {:+.2})",
                    all[(s - seed0) as usize][0][j]
                )
            })
            .collect();
        println!("{} largest error^2/var in D: {}", TERMS[j], top.join(", "));
    }
}

fn main() {
    if std::env::args().nth(1).as_deref() == Some("diagnose") {
        let n = std::env::args()
            .nth(2)
            .and_then(|v| v.parse().ok())
            .unwrap_or(20);
        let seed0 = std::env::args()
            .nth(3)
            .and_then(|v| v.parse().ok())
            .unwrap_or(2000);
        let only = std::env::args().nth(4);
        for m in [Maneuver::Rga12, Maneuver::Combo] {
            if only.as_deref().is_some_and(|o| o != m.name()) {
                continue;
            }
            diagnose(m, n, seed0);
            println!();
        }
        return;
    }
    let flights: u64 = std::env::args()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap_or(100);
    let seed0: u64 = std::env::args()
        .nth(2)
        .and_then(|v| v.parse().ok())
        .unwrap_or(2000);
    let imp_name = std::env::args().nth(3).unwrap_or_else(|| "f64".into());
    let imp = Implementation::parse(&imp_name)
        .unwrap_or_else(|| panic!("unknown implementation {imp_name} (f64, f32, fixed)"));
    let maneuvers = [(Maneuver::Rga12, 0u64), (Maneuver::Combo, 1000u64)];

    // 1. The bound two ways (for the reference; a kernel's run takes the analytic bound).
    let mut analytic_rga12 = [f64::NAN; N];
    if imp != Implementation::F64 {
        analytic_rga12 = crlb_analytic(&spheres_spec(Maneuver::Rga12, 0));
    } else {
        println!("## CRLB two ways (SPH2, 1 kHz, gyro noise x1, initial rate unknown)\n");
        for &(m, seed) in &maneuvers {
            let spec = spheres_spec(m, seed);
            let t = Instant::now();
            let an = crlb_analytic(&spec);
            let t_an = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let fd = crlb_fd_with_initial_rate(&spec);
            let t_fd = t.elapsed().as_secs_f64();
            if m == Maneuver::Rga12 {
                analytic_rga12 = an;
            }
            println!(
                "### {} (seed {seed}; analytic {t_an:.1} s, finite differences {t_fd:.1} s)\n",
                m.name()
            );
            println!(
                "| term | CRLB sd analytic | CRLB sd finite-difference | var analytic / var FD |"
            );
            println!("|---|---|---|---|");
            for j in 0..N {
                println!(
                    "| {} | {} | {} | {:.4} |",
                    TERMS[j],
                    fmt_sd(j, an[j]),
                    fmt_sd(j, fd[j]),
                    an[j] / fd[j]
                );
            }
            let known = massid_tests::crlb::crlb(&spec);
            let (lo, hi) = (0..N)
                .map(|j| known[j] / fd[j])
                .fold((f64::INFINITY, 0.0f64), |(l, h), r| (l.min(r), h.max(r)));
            println!(
            "\nInitial rate known (`crlb::crlb`) / unknown (FD): variance ratio {lo:.3}..{hi:.3}\n"
        );
        }

        // Step-size check of the finite differences (rga12): every step halved and doubled.
        let spec = spheres_spec(Maneuver::Rga12, 0);
        let d = FdSteps::default();
        let fd = crlb_fd_with_initial_rate(&spec);
        for (label, f) in [("halved", 0.5), ("doubled", 2.0)] {
            let steps = FdSteps {
                com_mm: d.com_mm * f,
                inertia_rel: d.inertia_rel * f,
                rate_rad_s: d.rate_rad_s * f,
            };
            let other = crlb_fd_with_initial_rate_steps(&spec, &steps);
            let worst = (0..N)
                .map(|j| (other[j] / fd[j] - 1.0).abs())
                .fold(0.0, f64::max);
            println!("FD steps {label}: largest relative change of a variance {worst:.2e}");
        }
        println!();
    }

    // 2. Monte Carlo against the analytic bound.
    println!(
        "## Monte Carlo: {flights} flights per maneuver (seeds {seed0}..{}), {imp_name} with default options\n",
        seed0 + flights - 1
    );
    println!("Ratio: mean over flights of error^2 / (that flight's analytic CRLB variance); for rga12 (identical commands every seed) this is the MC variance (mean square error about the truth) / CRLB. Its sampling sd is about sqrt(2/N) = {:.2}. `all samples`: `crlb_analytic` (the true rate at every sample); `delivered`: `crlb_analytic_delivered` (the samples whose gyro counts did not saturate, as the estimator sees them).\n", (2.0 / flights as f64).sqrt());
    let mut table = String::new();
    let mut notes = String::new();
    for &(m, _) in &maneuvers {
        let t = Instant::now();
        let fixed = (m == Maneuver::Rga12).then_some(&analytic_rga12);
        let seeds: Vec<u64> = (seed0..seed0 + flights).collect();
        let outcomes: Vec<Outcome> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..2)
                .map(|th| {
                    let mine: Vec<u64> = seeds.iter().copied().skip(th).step_by(2).collect();
                    s.spawn(move || {
                        mine.into_iter()
                            .map(|seed| run_flight(m, seed, fixed, imp))
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().expect("worker"))
                .collect()
        });
        let secs = t.elapsed().as_secs_f64();
        let (r_all, _, used) = ratios(&outcomes, |o| o.bound);
        let (r_del, b_del, _) = ratios(&outcomes, |o| o.bound_delivered);
        let mut row = |label: &str, v: &[f64; N], signed: bool| {
            table += &format!("| {} {label} | {used} |", m.name());
            for x in v {
                table += &if signed {
                    format!(" {x:+.2} |")
                } else {
                    format!(" {x:.2} |")
                };
            }
            table += "\n";
        };
        row("MC var / CRLB (all samples)", &r_all, false);
        row("MC var / CRLB (delivered)", &r_del, false);
        row("mean error / CRLB sd (delivered)", &b_del, true);

        let saturated: Vec<&Outcome> = outcomes.iter().filter(|o| o.missing > 0).collect();
        let mut statuses: Vec<String> = outcomes
            .iter()
            .filter(|o| o.status != "ok")
            .map(|o| o.status.clone())
            .collect();
        statuses.sort();
        statuses.dedup();
        notes += &format!(
            "{}: {secs:.0} s; statuses other than ok: {}; flights with saturated gyro samples: {}{}\n",
            m.name(),
            if statuses.is_empty() {
                "none".to_string()
            } else {
                statuses.join(", ")
            },
            saturated.len(),
            if saturated.is_empty() {
                String::new()
            } else {
                let list: Vec<String> = saturated
                    .iter()
                    .map(|o| format!("{} ({} samples)", o.seed, o.missing))
                    .collect();
                format!(" — {}", list.join(", "))
            }
        );
        // The flights contributing most to the delivered-sample ratio (a general excess or a
        // few outliers?).
        for j in 0..N {
            let mut z2: Vec<(f64, u64)> = outcomes
                .iter()
                .map(|o| (o.err[j] * o.err[j] / o.bound_delivered[j], o.seed))
                .filter(|(v, _)| v.is_finite())
                .collect();
            z2.sort_by(|a, b| b.0.total_cmp(&a.0));
            let sum: f64 = z2.iter().map(|x| x.0).sum();
            let list: Vec<String> = z2
                .iter()
                .take(3)
                .map(|(v, s)| format!("{v:.1} (seed {s})"))
                .collect();
            notes += &format!(
                "  {}: largest error^2/var (delivered) {}; {:.0} % of the sum\n",
                TERMS[j],
                list.join(", "),
                100.0 * z2.iter().take(3).map(|x| x.0).sum::<f64>() / sum
            );
        }
    }
    print!("| maneuver, quantity | flights used |");
    for t in TERMS {
        print!(" {t} |");
    }
    println!("\n|---|---|{}", "---|".repeat(N));
    println!("{table}");
    print!("{notes}");
}
