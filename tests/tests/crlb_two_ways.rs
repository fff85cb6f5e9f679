//! The Cramér–Rao bound of the output-error identification computed two independent ways
//! must agree: the estimator's own profile information at the truth
//! (`reference_f64::flight_id::cramer_rao_bound`, via `crlb_analytic`) and central
//! differences of the simulator's body rate with the initial rate a nuisance
//! (`crlb_fd_with_initial_rate`), on SPH2's rga12 at 1 kHz. A planted fault (the analytic
//! bound with the gyro noise 1.2 x too large) must break the comparison.
use massid_sim::{Maneuver, SimSpec};
use massid_tests::crlb::{crlb_analytic, crlb_fd_with_initial_rate, N};
use massid_tests::identification_mc::TERMS;
use reference_f64::satellite::Satellite;

#[test]
fn analytic_and_finite_difference_crlb_agree_on_rga12() {
    let sat = Satellite::builtin("sph2").expect("sph2");
    let spec = SimSpec::new(sat, Vec::new(), Maneuver::Rga12);
    let fd = crlb_fd_with_initial_rate(&spec);
    let analytic = crlb_analytic(&spec);
    for j in 0..N {
        let r = analytic[j] / fd[j];
        println!("{}: analytic / FD variance {r:.4}", TERMS[j]);
        assert!(
            fd[j].is_finite() && fd[j] > 0.0 && (r - 1.0).abs() <= 0.1,
            "{}: analytic variance {} vs finite-difference {} (ratio {r})",
            TERMS[j],
            analytic[j],
            fd[j]
        );
    }

    // Planted fault: the noise level 1.2 x the simulator's (the trajectory is noise-free, so
    // only the information's weight changes): every term must then disagree by over 10 %.
    let mut wrong = spec.clone();
    for s in wrong.sensors.gyro_noise_rad_s.iter_mut() {
        *s *= 1.2;
    }
    let bad = crlb_analytic(&wrong);
    for j in 0..N {
        let r = bad[j] / fd[j];
        assert!(
            (r - 1.0).abs() > 0.1,
            "{}: a bound with sigma x 1.2 still agrees (ratio {r})",
            TERMS[j]
        );
    }
}
