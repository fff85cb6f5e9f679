//! Issue 12 item 5: the Cramér–Rao bound of the rate-output model (`massid_tests::crlb`) and
//! the estimators' Monte Carlo variance against it. No unbiased estimator beats the bound, so
//! every ratio must be at least 1 up to the Monte Carlo's sampling error (100 flights: the
//! variance is known to about +-15 %, hence 0.7): a bound computed with a wrong noise level,
//! sample spacing or sensitivity would break this. The ratios themselves (75-800, far from the
//! issue's 1.5) are the measured finding, in the README.
use massid_tests::crlb::{mc_against_crlb, ESTIMATORS, N};

#[test]
fn no_estimator_beats_the_cramer_rao_bound() {
    let (mc, bound) = mc_against_crlb(100, 30_000);
    println!("{}", massid_tests::crlb::markdown(&mc, &bound));
    for j in 0..N {
        assert!(
            bound[j].is_finite() && bound[j] > 0.0,
            "bound {j}: {}",
            bound[j]
        );
        for (k, name) in ESTIMATORS.iter().enumerate() {
            assert!(
                mc[k][j] / bound[j] >= 0.7,
                "{name}, unknown {j}: variance {} below the bound {}",
                mc[k][j],
                bound[j]
            );
        }
    }
}
