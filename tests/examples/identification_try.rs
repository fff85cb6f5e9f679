use massid_sim::Maneuver;
use massid_tests::identification_mc::*;
use reference_f64::flight_id::{identify, Options};
fn main() {
    if std::env::var("BODYMC").is_ok() {
        body_rate_mc();
        return;
    }
    let args: Vec<String> = std::env::args().collect();
    let m = Maneuver::parse(&args[1]).unwrap();
    let rate: f64 = args[2].parse().unwrap();
    let seed: u64 = args[3].parse().unwrap();
    let cond = if args[1] == "rga12" && args.get(4).is_some() {
        Condition::PlanarMocap {
            step_ms: 40,
            control_ms: 80,
            closed_loop: true,
        }
    } else {
        Condition::Spheres {
            maneuver: m,
            rate_hz: rate,
            noise: std::env::var("NOISE")
                .map(|s| s.parse().unwrap())
                .unwrap_or(1.0),
        }
    };
    let t = std::time::Instant::now();
    let sim = fly(&cond, seed);
    let t1 = t.elapsed();
    dbg_flight(&sim.flight);
    let e = identify(&sim.flight, &sim.model, &Options::default()).unwrap();
    println!("sim {:?} id {:?}", t1, t.elapsed() - t1);
    println!("truth {:?}", sim.truth);
    println!(
        "I {:?}\n se {:?}\n cm {:?}\n se {:?}\n status {} sensor {:?} unobs {:?}",
        e.inertia_kgm2,
        e.inertia_stderr_kgm2,
        e.com_offset_mm,
        e.com_offset_stderr_mm,
        e.status,
        e.sensor,
        e.unobservable
    );
    for n in e.noise.iter().flatten() {
        println!(
            "noise order {} phi {:?} s {:.3e}",
            n.order(),
            &n.phi,
            n.sigma2.sqrt()
        );
    }
    println!("{:?}", e.consistency);
}
#[allow(dead_code)]
fn dbg_flight(f: &reference_f64::flight_id::flight::Flight) {
    let w = reference_f64::flight_id::flight::windows(f, 20, false);
    let nan = f
        .rate
        .iter()
        .filter(|r| r.iter().any(|x| x.is_nan()))
        .count();
    let mx = f
        .rate
        .iter()
        .flat_map(|r| r.iter())
        .filter(|x| x.is_finite())
        .fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!(
        "windows {} {:?} nan {} max {}",
        w.len(),
        &w[..w.len().min(5)],
        nan,
        mx
    );
}
#[allow(dead_code)]
pub fn body_rate_mc() {
    use massid_sim::{simulate, SimSpec};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use reference_f64::satellite::Satellite;
    let sat = Satellite::builtin("sph2").unwrap();
    let truth = sat.inertia_kgm2;
    let mut zs = vec![vec![]; 6];
    let spec = SimSpec::new(sat.clone(), vec![], Maneuver::Rga12);
    let out = simulate(&spec).unwrap();
    for seed in 0..40 {
        let mut f = reference_f64::flight_id::flight::Flight::from_v1(&out.recording, &sat);
        let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let nd = Normal::new(
            0.0,
            std::env::var("SIG")
                .map(|s| s.parse().unwrap())
                .unwrap_or(0.002),
        )
        .unwrap();
        for (k, w) in out.body_rate.iter().enumerate() {
            f.rate[k] = [
                w[0] + nd.sample(&mut r),
                w[1] + nd.sample(&mut r),
                w[2] + nd.sample(&mut r),
            ];
        }
        let e = identify(&f, &sat, &Options::default()).unwrap();
        for m in 0..6 {
            zs[m].push((e.inertia_kgm2[m] - truth[m]) / e.inertia_stderr_kgm2[m]);
        }
    }
    for m in 0..6 {
        let n = zs[m].len() as f64;
        let b = zs[m].iter().sum::<f64>() / n;
        let r = (zs[m].iter().map(|z| z * z).sum::<f64>() / n).sqrt();
        println!("term {m}: bias {b:+.2} rms {r:.2}");
    }
    let e = {
        let mut f = reference_f64::flight_id::flight::Flight::from_v1(&out.recording, &sat);
        for (k, w) in out.body_rate.iter().enumerate() {
            f.rate[k] = [w[0] + 1e-9 * (k % 7) as f64, w[1], w[2]];
        }
        identify(&f, &sat, &Options::default()).unwrap()
    };
    println!(
        "noise-free: {:?} vs {:?}\n cm {:?}",
        e.inertia_kgm2, truth, e.com_offset_mm
    );
}
