//! The kernel's integer primitives proved by Z3 on their own source, counterexamples replayed
//! on the compiled code, and deliberately wrong variants refuted.
//! `cargo test -p massid-proofs-solver -- --nocapture` prints every verdict and time.

use massid_kernel::int::MachineExt;
use massid_proofs_solver::discharge::{mutants, Discharge, Obligation, Verdict};
use massid_proofs_solver::obligations::div::is_restoring_step;
use massid_proofs_solver::obligations::mul::is_rounded_product;
use massid_proofs_solver::obligations::{self, FRAC};
use massid_proofs_solver::prover::{Prover, ProverExt};
use std::time::Duration;

/// Far above every measured proof time (the slowest, the Q8.24 product, ~1 minute).
const TIMEOUT: Duration = Duration::from_secs(900);

fn prove_all(filter: impl Fn(&str) -> bool) {
    let mut failures = Vec::new();
    for o in obligations::all().iter().filter(|o| filter(&o.label())) {
        let out = o.prove(None, TIMEOUT);
        println!(
            "{:28} {:>8.2} s  {:?}",
            o.label(),
            out.time.as_secs_f64(),
            out.verdict
        );
        if out.verdict != Verdict::Proved {
            failures.push(format!("{}: {:?}", o.label(), out.verdict));
        }
    }
    assert!(failures.is_empty(), "not proved: {failures:#?}");
}

#[test]
fn products_are_proved() {
    prove_all(|n| n.contains("mul"));
}

#[test]
fn shifts_normalisation_and_division_parts_are_proved() {
    prove_all(|n| !n.contains("mul"));
}

/// A wrong fixed-point product: truncating (the floor of the shift) instead of rounding.
struct TruncatingProduct;

impl Obligation for TruncatingProduct {
    fn name(&self) -> String {
        "truncating_product".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a", "b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let r = p.under_test(|m| {
            let wide = m.mul_d(&m.sext(&x[0]), &m.sext(&x[1]));
            m.saturate_to_w(&m.ashr_dk(&wide, FRAC))
        });
        // the kernel's product's own property
        (p.b(true), is_rounded_product(p, &x[0], &x[1], &r, FRAC))
    }
}

/// A wrong restoring-division digit: `<` where the kernel has `<=` (a remainder equal to the
/// divisor is kept instead of taken off).
struct OffByOneStep;

impl Obligation for OffByOneStep {
    fn name(&self) -> String {
        "restoring_step_off_by_one".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["r", "q", "ub"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (r, q, ub) = (&x[0], &x[1], &x[2]);
        let (r2, q2) = p.under_test(|m| {
            let r = m.shl_k(r, 1);
            let take = m.ult(ub, &r);
            (
                m.select(&take, &m.sub(&r, ub), &r),
                m.select(&take, &m.or(q, &m.w(1)), q),
            )
        });
        // the kernel's step's own property, at bit 0
        is_restoring_step(p, (r, q, ub), (&r2, &q2), 0)
    }
}

fn refuted_and_replayed(o: &dyn Discharge) -> Vec<u32> {
    let out = o.prove(None, TIMEOUT);
    let Verdict::Refuted(x) = out.verdict else {
        panic!("{} was not refuted: {:?}", o.label(), out.verdict);
    };
    let (inside, holds) = o.replay(None, &x);
    println!("{} refuted at {:?} = {x:#x?}", o.label(), o.input_names());
    assert!(
        inside && !holds,
        "{}: the counterexample does not replay",
        o.label()
    );
    x
}

#[test]
fn wrong_variants_are_refuted_and_the_counterexamples_replay() {
    let x = refuted_and_replayed(&TruncatingProduct);
    // the replay is the compiled arithmetic: the truncated product differs from the
    // kernel's rounded one by one step there
    let (a, b) = (x[0] as i32, x[1] as i32);
    let exact = i128::from(a) * i128::from(b);
    assert!(exact.rem_euclid(1 << FRAC) >= 1 << (FRAC - 1));
    let y = refuted_and_replayed(&OffByOneStep);
    assert_eq!(
        2 * u64::from(y[0]),
        u64::from(y[2]),
        "only r = ub/2 exposes it"
    );
}

/// Mutants of `obligations`: every refutation must replay on the compiled mutant, each
/// obligation must refute at least two thirds of its mutants (the survivors are printed).
fn check_mutants(filter: impl Fn(&str) -> bool, timeout: Duration) {
    let mut report = Vec::new();
    for o in obligations::all().iter().filter(|o| filter(&o.label())) {
        let ms = mutants(o.as_ref(), timeout);
        let refuted = ms.iter().filter(|m| m.replays.is_some()).count();
        let survivors: Vec<u32> = ms
            .iter()
            .filter(|m| m.replays.is_none())
            .map(|m| m.site)
            .collect();
        for m in &ms {
            assert_ne!(
                m.replays,
                Some(false),
                "{} site {}: counterexample does not replay",
                o.label(),
                m.site
            );
        }
        println!(
            "{:28} {:3} mutants, {:3} refuted, survivors at {survivors:?}",
            o.label(),
            ms.len(),
            refuted
        );
        report.push((o.label(), ms.len(), refuted));
    }
    assert!(!report.is_empty());
    for (name, n, refuted) in &report {
        assert!(*refuted > 0, "{name}: no mutant refuted");
        assert!(
            *refuted * 3 >= *n * 2,
            "{name}: only {refuted} of {n} mutants refuted"
        );
    }
}

/// Every operation of the code under proof, altered one at a time: each obligation refutes
/// most of them, and every refutation replays on the compiled mutant. The survivors are
/// alterations that do not change the result (a bound compared with `<` or `<=` where the
/// two agree, a constant in an arm that a later selection overrides). One restoring step
/// stands for the 24 (the same code at another bit).
#[test]
fn mutants_are_refuted_and_replay() {
    check_mutants(
        |n| !n.contains("mul") && (!n.starts_with("restoring_step") || n == "restoring_step_bit7"),
        Duration::from_secs(60),
    );
}

/// The products' mutants: an equivalent one costs a whole proof, so each is given 30 s and
/// a time-out counts as a survivor.
#[test]
fn product_mutants_are_refuted_and_replay() {
    check_mutants(|n| n.contains("mul"), Duration::from_secs(30));
}
