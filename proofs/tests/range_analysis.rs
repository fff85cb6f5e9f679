//! The range analysis in CI: prints each variable's worst-case range against the format's
//! limit and fails when one does not fit; and shows the analysis (and a harness) flag a
//! deliberately too narrow format.

use massid_proofs::interval::Format;
use massid_proofs::range;

#[test]
fn firing_terms_fit_q8_24_for_every_word_over_the_envelope() {
    let r = range::firing_terms(Format::Q8_24);
    println!("{}", r.table());
    assert!(r.fits(), "{}", r.table());
}

#[test]
fn firing_terms_fit_f32() {
    let r = range::firing_terms(Format::F32);
    println!("{}", r.table());
    assert!(r.fits(), "{}", r.table());
}

#[test]
fn a_too_narrow_format_is_flagged_by_the_range_analysis_and_a_harness() {
    // Q4.28 (range +-8) where the torque regressor reaches tens of cN m.
    let r = range::firing_terms(Format::Q4_28);
    println!("{}", r.table());
    assert!(!r.fits(), "the range analysis must flag Q4.28");
    assert!(r.overflows().iter().any(|v| v.name.starts_with("torque_cnm")));
    // The same kernel code instantiated with the too narrow fixed type: the harness fails.
    let e = massid_proofs::engine::check(
        "firing_terms_q4_28",
        massid_proofs::engine::Mode::Random { runs: 2000, seed: 9 },
        &[],
        massid_proofs::harness::model::firing_terms_q4_28,
    )
    .expect_err("the firing-terms harness must fail for Q4.28");
    println!("harness flagged Q4.28: {e}");
}
