use massid_sim::Maneuver;
use massid_tests::identification_mc::*;
use reference_f64::flight_id::{identify, Options};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let m = Maneuver::parse(&args[1]).unwrap();
    let rate: f64 = args[2].parse().unwrap();
    let seed: u64 = args[3].parse().unwrap();
    let cond = if args[1] == "rga12" && args.get(4).is_some() { Condition::PlanarMocap { step_ms: 40, control_ms: 80, closed_loop: true } } else { Condition::Spheres { maneuver: m, rate_hz: rate, noise: 1.0 } };
    let t = std::time::Instant::now();
    let sim = fly(&cond, seed);
    let t1 = t.elapsed();
    dbg_flight(&sim.flight);
    let e = identify(&sim.flight, &sim.model, &Options::default()).unwrap();
    println!("sim {:?} id {:?}", t1, t.elapsed() - t1);
    println!("truth {:?}", sim.truth);
    println!("I {:?}\n se {:?}\n cm {:?}\n se {:?}\n status {} sensor {:?} unobs {:?}", e.inertia_kgm2, e.inertia_stderr_kgm2, e.com_offset_mm, e.com_offset_stderr_mm, e.status, e.sensor, e.unobservable);
    for n in e.noise.iter().flatten() { println!("noise order {} phi {:?} s {:.3e}", n.order(), &n.phi, n.sigma2.sqrt()); }
    println!("{:?}", e.consistency);
}
#[allow(dead_code)]
fn dbg_flight(f: &reference_f64::flight_id::flight::Flight) {
    let w = reference_f64::flight_id::flight::windows(f, 20);
    let nan = f.rate.iter().filter(|r| r.iter().any(|x| x.is_nan())).count();
    let mx = f.rate.iter().flat_map(|r| r.iter()).filter(|x| x.is_finite()).fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!("windows {} {:?} nan {} max {}", w.len(), &w[..w.len().min(5)], nan, mx);
}
