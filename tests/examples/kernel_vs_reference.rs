//! The onboard output-error identification (f32) against the f64 reference on the same
//! flights: per term, the mean and largest |kernel - f64| in units of the f64's sigma, and the
//! ratio of the kernel's sigma to the f64's (efficiency).
//! `cargo run --release -p massid-tests --example kernel_vs_reference -- FLIGHTS SEED0 [FILTER]`
use massid_tests::identification_mc::*;
use reference_f64::flight_id::Options;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flights: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(20);
    let seed0: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(700);
    let filter = args.get(3).cloned().unwrap_or_default();
    let opts = Options::default();
    println!("| condition | flights | max mean abs(f32-f64)/sigma | max abs(f32-f64)/sigma | sigma f32/f64 (min-max) |");
    println!("|---|---|---|---|---|");
    for cond in grid()
        .into_iter()
        .chain(craft_grid())
        .filter(|c| c.label().contains(&filter))
    {
        let mut diff_sum = [0.0f64; 9];
        let mut diff_max = [0.0f64; 9];
        let mut ratio = [0.0f64; 9];
        let mut n = [0u32; 9];
        // Per term: sum of squared (kernel - truth)/kernel sigma and (f64 - truth)/f64 sigma.
        let mut z2 = [[0.0f64; 2]; 9];
        for seed in seed0..seed0 + flights {
            let sim = fly(&cond, seed);
            let (Ok(a), Ok(b)) = (
                estimate_with(Implementation::F64, &sim, &opts),
                estimate_with(Implementation::F32, &sim, &opts),
            ) else {
                continue;
            };
            if std::env::var_os("SHOW_NOISE").is_some() {
                let f = |e: &reference_f64::flight_id::FlightEstimate| {
                    e.noise
                        .iter()
                        .map(|n| n.as_ref().map_or(f64::NAN, |n| n.sigma2.sqrt()))
                        .collect::<Vec<_>>()
                };
                eprintln!(
                    "seed {seed}: noise f64 {:?} f32 {:?} f32 phi {:?}",
                    f(&a),
                    f(&b),
                    b.noise
                        .iter()
                        .map(|n| n.as_ref().map(|n| n.phi.clone()))
                        .collect::<Vec<_>>()
                );
            }
            for t in 0..9 {
                if sim.truth[t].is_nan()
                    || a.unobservable.contains(&TERMS[t])
                    || b.unobservable.contains(&TERMS[t])
                {
                    continue;
                }
                let (va, sa, vb, sb) = if t < 3 {
                    (
                        a.com_offset_mm[t],
                        a.com_offset_stderr_mm[t],
                        b.com_offset_mm[t],
                        b.com_offset_stderr_mm[t],
                    )
                } else {
                    (
                        a.inertia_kgm2[t - 3],
                        a.inertia_stderr_kgm2[t - 3],
                        b.inertia_kgm2[t - 3],
                        b.inertia_stderr_kgm2[t - 3],
                    )
                };
                let truth = sim.truth[t];
                z2[t][0] += ((vb - truth) / sb).powi(2);
                z2[t][1] += ((va - truth) / sa).powi(2);
                let d = ((vb - va) / sa).abs();
                diff_sum[t] += d;
                diff_max[t] = diff_max[t].max(d);
                ratio[t] += sb / sa;
                n[t] += 1;
            }
        }
        let used: Vec<usize> = (0..9).filter(|&t| n[t] > 0).collect();
        for &t in &used {
            let k = f64::from(n[t]);
            eprintln!(
                "   {}: sigma f32/f64 {:.2}, RMS err/sigma f32 {:.2} f64 {:.2}, mean |f32-f64|/sigma {:.2}",
                TERMS[t],
                ratio[t] / k,
                (z2[t][0] / k).sqrt(),
                (z2[t][1] / k).sqrt(),
                diff_sum[t] / k
            );
        }
        if used.is_empty() {
            println!("| {} | {flights} | - | - | - |", cond.label());
            continue;
        }
        let mean_max = used
            .iter()
            .map(|&t| diff_sum[t] / n[t] as f64)
            .fold(0.0, f64::max);
        let max = used.iter().map(|&t| diff_max[t]).fold(0.0, f64::max);
        let r: Vec<f64> = used.iter().map(|&t| ratio[t] / n[t] as f64).collect();
        println!(
            "| {} | {flights} | {mean_max:.2} | {max:.2} | {:.2}-{:.2} |",
            cond.label(),
            r.iter().cloned().fold(f64::INFINITY, f64::min),
            r.iter().cloned().fold(0.0, f64::max)
        );
    }
}
