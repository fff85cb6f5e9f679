//! Monte Carlo of `reference_f64::flight_id` over the grid (README table):
//! `cargo run --release -p massid-tests --example identification_mc -- FLIGHTS SEED0 [FILTER] [f64|f32|fixed]`
//! (the README's table: 100 flights per cell from seed 1000, which no development run used).
use massid_tests::identification_mc::*;
use reference_f64::flight_id::Options;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flights: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100);
    let seed0: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let filter = args.get(3).cloned().unwrap_or_default();
    let imp = args
        .get(4)
        .map(|s| Implementation::parse(s).expect("implementation: f64, f32 or fixed"))
        .unwrap_or(Implementation::F64);
    let cells: Vec<Condition> = grid()
        .into_iter()
        .chain(mocap_central_grid())
        .chain(craft_grid())
        .chain(random_craft_grid())
        .filter(|c| c.label().contains(&filter))
        .collect();
    println!("{MARKDOWN_HEADER}");
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(vec![None; cells.len()]);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let Some(cond) = cells.get(i) else { break };
                let cell = run_cell_by(cond, flights, seed0, &Options::default(), imp);
                eprintln!("{}", markdown_row(cond, &cell));
                if cell.ok < cell.flights {
                    let mut st = cell.statuses.clone();
                    st.sort();
                    st.dedup();
                    eprintln!("   statuses other than ok: {st:?}");
                }
                for (t, s) in TERMS.iter().zip(&cell.terms) {
                    if s.n > 0 {
                        eprintln!(
                            "   {t}: bias {:+.2} rms {:.2} c1 {:.0} c2 {:.0}",
                            s.bias(),
                            s.rms(),
                            s.cover1(),
                            s.cover2()
                        );
                    }
                }
                results.lock().unwrap()[i] = Some(cell);
            });
        }
    });
    for (cond, cell) in cells.iter().zip(results.into_inner().unwrap()) {
        if let Some(c) = cell {
            println!("{}", markdown_row(cond, &c));
        }
    }
}
