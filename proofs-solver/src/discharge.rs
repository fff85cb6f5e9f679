//! Running an obligation: the solver's proof (or counterexample), its replay on the
//! compiled code, and the mutants.

use crate::concrete::Concrete;
use crate::mutant::Mutant;
use crate::prover::Prover;
use crate::z3_int::Z3Int;
use crate::z3_machine::Z3;
use std::time::{Duration, Instant};
use z3::ast::{Bool, Int, BV};
use z3::{Config, Context, Params, SatResult, Solver};

/// A property of kernel code over the machine, for every input of an envelope.
pub trait Obligation {
    /// A name for reports (primitive, format, variant).
    fn name(&self) -> String;
    /// The 32-bit inputs, named.
    fn inputs(&self) -> &'static [&'static str];
    /// `(envelope, property)`: the property must hold whenever the envelope does. Runs the
    /// code under proof on `p` inside [`crate::prover::ProverExt::under_test`].
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool);
    /// Which Z3 theory the obligation is put to.
    fn engine(&self) -> Engine {
        Engine::BitVector
    }
}

/// How the machine is given to Z3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// Bit-vectors ([`Z3`]): exact for any bit-level code; slow on multiplier or divider
    /// equivalences.
    BitVector,
    /// Integers modulo 2^32 / 2^64 ([`Z3Int`]): nonlinear integer reasoning, for code that
    /// builds a product or a quotient from smaller ones.
    Integer,
}

/// What the solver concluded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// No input of the envelope violates the property.
    Proved,
    /// An input of the envelope that violates it (the inputs' bits, in order).
    Refuted(Vec<u32>),
    /// The solver gave up (time limit), with its reason.
    Unknown(String),
}

/// A verdict and how long it took.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The verdict.
    pub verdict: Verdict,
    /// Solver time.
    pub time: Duration,
}

/// An obligation behind a non-generic interface, so that a list of them can be run.
pub trait Discharge {
    /// See [`Obligation::name`].
    fn label(&self) -> String;
    /// The input names.
    fn input_names(&self) -> &'static [&'static str];
    /// Asks Z3, on the code as written (`site: None`) or with one operation altered.
    fn prove(&self, site: Option<u32>, timeout: Duration) -> Outcome;
    /// Runs the compiled code (or the same mutant) on concrete inputs: `(in envelope,
    /// property holds)`.
    fn replay(&self, site: Option<u32>, x: &[u32]) -> (bool, bool);
    /// Number of machine operations in the code under proof (the mutation sites).
    fn sites(&self) -> u32;
}

impl<T: Obligation> Discharge for T {
    fn label(&self) -> String {
        self.name()
    }
    fn input_names(&self) -> &'static [&'static str] {
        self.inputs()
    }
    fn prove(&self, site: Option<u32>, timeout: Duration) -> Outcome {
        let ctx = Context::new(&Config::new());
        let names = self.inputs();
        match self.engine() {
            Engine::BitVector => {
                let vars: Vec<BV> = names.iter().map(|n| BV::new_const(&ctx, *n, 32)).collect();
                let (envelope, property) = match site {
                    None => self.check(&Z3 { ctx: &ctx }, &vars),
                    Some(s) => self.check(&Mutant::new(Z3 { ctx: &ctx }, s), &vars),
                };
                solve(&ctx, None, &[envelope], &property, timeout, |m| {
                    vars.iter()
                        .map(|v| m.eval(v, true).and_then(|x| x.as_u64()).unwrap_or(0) as u32)
                        .collect()
                })
            }
            Engine::Integer => {
                let vars: Vec<Int> = names.iter().map(|n| Int::new_const(&ctx, *n)).collect();
                let z = Z3Int::new(&ctx);
                let mut facts: Vec<Bool> = vars
                    .iter()
                    .map(|v| Bool::and(&ctx, &[&v.ge(&z.num(0)), &v.lt(&z.num(1i128 << 32))]))
                    .collect();
                let (envelope, property, machine_facts) = match site {
                    None => {
                        let (e, p) = self.check(&z, &vars);
                        (e, p, z.facts.take())
                    }
                    Some(s) => {
                        let m = Mutant::new(z, s);
                        let (e, p) = self.check(&m, &vars);
                        (e, p, m.inner.facts.take())
                    }
                };
                facts.extend(machine_facts);
                facts.push(envelope);
                solve(&ctx, Some("QF_NIA"), &facts, &property, timeout, |m| {
                    vars.iter()
                        .map(|v| m.eval(v, true).and_then(|x| x.as_u64()).unwrap_or(0) as u32)
                        .collect()
                })
            }
        }
    }
    fn replay(&self, site: Option<u32>, x: &[u32]) -> (bool, bool) {
        match site {
            None => self.check(&Concrete, x),
            Some(s) => self.check(&Mutant::new(Concrete, s), x),
        }
    }
    fn sites(&self) -> u32 {
        let m = Mutant::new(Concrete, u32::MAX);
        let zeros = vec![0u32; self.inputs().len()];
        let _ = self.check(&m, &zeros);
        m.operations()
    }
}

/// Asks whether `assumed` can hold with `property` false; a model is read back by `inputs`.
fn solve<'c>(
    ctx: &'c Context,
    logic: Option<&str>,
    assumed: &[Bool<'c>],
    property: &Bool<'c>,
    timeout: Duration,
    inputs: impl Fn(&z3::Model<'c>) -> Vec<u32>,
) -> Outcome {
    let solver = logic
        .and_then(|l| Solver::new_for_logic(ctx, l))
        .unwrap_or_else(|| Solver::new(ctx));
    let mut params = Params::new(ctx);
    params.set_u32(
        "timeout",
        timeout.as_millis().min(u128::from(u32::MAX)) as u32,
    );
    solver.set_params(&params);
    for a in assumed {
        solver.assert(a);
    }
    solver.assert(&property.not());
    let start = Instant::now();
    let verdict = match solver.check() {
        SatResult::Unsat => Verdict::Proved,
        SatResult::Sat => {
            Verdict::Refuted(solver.get_model().map(|m| inputs(&m)).unwrap_or_default())
        }
        SatResult::Unknown => Verdict::Unknown(solver.get_reason_unknown().unwrap_or_default()),
    };
    Outcome {
        verdict,
        time: start.elapsed(),
    }
}

/// One mutant's fate.
#[derive(Clone, Debug)]
pub struct MutantOutcome {
    /// The altered operation.
    pub site: u32,
    /// What the solver said about the altered code.
    pub outcome: Outcome,
    /// For a refutation: whether the compiled mutant, run on the counterexample, is inside
    /// the envelope and violates the property (it must).
    pub replays: Option<bool>,
}

/// Every mutant of an obligation's code (one per operation), each asked of the solver with
/// `timeout`, and every counterexample replayed on the compiled mutant.
pub fn mutants(o: &dyn Discharge, timeout: Duration) -> Vec<MutantOutcome> {
    (0..o.sites())
        .map(|site| {
            let outcome = o.prove(Some(site), timeout);
            let replays = match &outcome.verdict {
                Verdict::Refuted(x) => {
                    let (inside, holds) = o.replay(Some(site), x);
                    Some(inside && !holds)
                }
                _ => None,
            };
            MutantOutcome {
                site,
                outcome,
                replays,
            }
        })
        .collect()
}
