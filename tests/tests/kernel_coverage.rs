//! Issue 12 item 3: the reported standard errors are honest. 200 simulated rga12 flights of
//! the nominal SPH2 differing only in the noise seed, through f64, f32 and fixed
//! (`massid_tests::coverage`). For every CoM and principal-inertia term and every
//! implementation, the RMS error over the RMS reported sigma must lie in [0.7, 1.4] and the
//! mean error within 0.5 sigma. Before the kernels carried a variance factor their sigmas were
//! 15-20x too small; the planted-fault test shows the check catching exactly that.
use massid_tests::coverage::{run_flights, Table, IMPLS, TERMS};

const FLIGHTS: u64 = 200;

fn check(t: &Table, flights: u64) -> Vec<String> {
    let mut bad = Vec::new();
    for (k, name) in IMPLS.iter().enumerate() {
        for (j, term) in TERMS.iter().enumerate() {
            let c = &t.cells[k][j];
            if c.n != flights as u32 || !(0.7..=1.4).contains(&c.ratio()) || c.bias().abs() > 0.5 {
                bad.push(format!(
                    "{name} {term}: n {} ratio {:.2} bias {:+.2}",
                    c.n,
                    c.ratio(),
                    c.bias()
                ));
            }
        }
    }
    bad
}

#[test]
fn standard_errors_match_the_monte_carlo_scatter() {
    let t = run_flights(FLIGHTS, 10_000);
    println!("{}", t.markdown());
    let bad = check(&t, FLIGHTS);
    assert!(
        bad.is_empty(),
        "dishonest standard errors:\n{}",
        bad.join("\n")
    );
}

#[test]
fn the_check_catches_kernel_sigmas_without_the_variance_factor() {
    // Planted fault: the kernels' sigmas as they were before (LS variances only).
    let mut t = run_flights(40, 20_000);
    let honest = check(&t, 40).len();
    t = massid_tests::coverage::run_flights_with(40, 20_000, |e| {
        let [vc, vi] = e.variance_factor;
        for s in e.com_offset_stderr_mm.iter_mut() {
            *s /= vc.sqrt();
        }
        for s in e.inertia_stderr_kgm2.iter_mut() {
            *s /= vi.sqrt();
        }
    });
    let faulty = check(&t, 40);
    // the 40-flight sample may itself miss a cell or two; the fault must miss many more
    assert!(
        faulty.len() >= honest + 10,
        "planted fault not caught: {faulty:?}"
    );
}
