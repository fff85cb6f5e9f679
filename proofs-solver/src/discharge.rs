//! Running an obligation: the solver's proof (or counterexample), its replay on the
//! compiled code, and the mutants.

use crate::concrete::Concrete;
use crate::mutant::Mutant;
use crate::prover::Prover;
use crate::z3_int::Z3Int;
use crate::z3_machine::Z3;
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};
use z3::ast::{Bool, Int, BV};
use z3::{Config, Context, Params, SatResult, Solver, StatisticsValue, Tactic};

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
    /// The rlimit each of its mutants is given ([`MUTANT_RLIMIT`] unless its mutants are
    /// as hard as a product proof).
    fn mutant_rlimit(&self) -> u32 {
        MUTANT_RLIMIT
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
    /// Undecided: the solver used up its resource limit ([`Budget::rlimit`]; reason
    /// `"max. resource limit exceeded"`) or gave up for a reason of its own (the reason).
    /// Never a proof, never a refutation; as deterministic as the other two.
    Unknown(String),
}

/// How much Z3 may spend on one question.
///
/// The verdict depends only on `rlimit`: Z3's resource counter counts the solver's own
/// steps (propagations, conflicts, rewrites), not time, so the same question gets the same
/// verdict and the same count on a busy or an idle machine. `guard` is a wall-clock bound
/// that is only there so that a run cannot hang: it is set far above the time the largest
/// `rlimit` takes, and if it fires [`Discharge::prove`] returns a [`GuardHit`] error, never
/// a verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Z3's `rlimit` solver parameter: the resource count the question may use (0: none).
    pub rlimit: u32,
    /// Last-resort wall-clock bound; never decides a verdict.
    pub guard: Duration,
}

impl Budget {
    /// `rlimit` with the default [`GUARD`].
    pub const fn rlimit(rlimit: u32) -> Self {
        Budget {
            rlimit,
            guard: GUARD,
        }
    }
}

/// The rlimit for an obligation as written (the proofs, and the deliberately wrong variants
/// of the tests): 6.4 times the largest count measured, 314,915,035 for `q8_24_mul_direct`
/// (next: `widening_mul_direct` 163,279,266; every other obligation at most 6,811,390).
/// Measured with `cargo run --release -p massid-proofs-solver --example prove -- --rlimit 0`
/// (no limit; Z3 4.8.12, Debian's libz3) and printed by the tests: the same counts on a
/// quiet and on a loaded machine (`proofs/README.md`). It takes about 6 minutes to use
/// up, so an obligation that stops being provable fails in that time, as undecided.
pub const PROOF_RLIMIT: u32 = 2_000_000_000;

/// The rlimit for each mutant of the bit-vector products (`widening_mul_direct`,
/// `q8_24_mul_direct`; [`Obligation::mutant_rlimit`]): 4.5 times the largest
/// count of a mutant, 222,300,142 for `q8_24_mul_direct` site 9 (an equivalent mutant,
/// proved like the original; the largest refutation is site 3's, 158,227,978). With it
/// every mutant of theirs gets a verdict (all 17 of the Q8.24 product, all 3 of the
/// widening product). Measured with
/// `cargo run --release -p massid-proofs-solver --example prove -- mul --mutants --rlimit 0`.
pub const PRODUCT_MUTANT_RLIMIT: u32 = 1_000_000_000;

/// The rlimit for each mutant of the other obligations: 7.8 times the largest count of a
/// mutant, 6,412,096 for `shift_nearest` site 8 (equivalent, proved; the largest
/// refutation is `shift_nearest` site 35's, 2,277,385). On the integer engine one mutant,
/// `div_by_i64_q8_24` site 3, is not decided by the first solver at any limit tried
/// (none in 102,091,010, 120 s); it uses that solver's half of this and is refuted by the
/// second solver of the integer engine (25,061,655 in all). Measured with
/// `cargo run --release -p massid-proofs-solver --example prove -- --mutants --rlimit 0 --guard 120`.
pub const MUTANT_RLIMIT: u32 = 50_000_000;

/// The wall-clock guard of every budget: two hours per question. The largest rlimit here
/// ([`PROOF_RLIMIT`]) takes about 6 minutes of Z3 on this 2-core machine when it is quiet
/// (the Q8.24 product counts 5.4 million a second: 314,915,035 in 58 s) and 39 minutes at
/// the rate of the most loaded run measured (0.86 million a second: the same count in 367
/// s, beside two busy loops and other jobs, load average 5.8).
pub const GUARD: Duration = Duration::from_secs(7200);

/// The wall-clock guard fired before Z3 reached its resource limit: no verdict, and the
/// run must fail rather than count this as anything (it would depend on machine load).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GuardHit {
    /// What was asked (obligation, mutant site).
    pub what: String,
    /// The budget in force.
    pub budget: Budget,
    /// Resource count Z3 had reached when it was stopped.
    pub rlimit_used: u64,
    /// Wall-clock time spent.
    pub time: Duration,
}

impl fmt::Display for GuardHit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "resource guard hit: {} was stopped by the wall-clock guard after {:.1} s (guard \
             {:?}) at rlimit count {} of {}; no verdict is given (it would depend on \
             machine load): the rlimit is too large for the guard, or Z3 is stuck where it \
             does not count",
            self.what,
            self.time.as_secs_f64(),
            self.budget.guard,
            self.rlimit_used,
            self.budget.rlimit
        )
    }
}

impl std::error::Error for GuardHit {}

/// A verdict, the resources it took and how long.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The verdict.
    pub verdict: Verdict,
    /// Z3's resource count for the question ("rlimit count" of the solver's statistics,
    /// less its value before the check): deterministic, the figure the limits are set from.
    pub rlimit_used: u64,
    /// Solver time (wall clock; reported, never used to decide).
    pub time: Duration,
}

/// An obligation behind a non-generic interface, so that a list of them can be run.
pub trait Discharge {
    /// See [`Obligation::name`].
    fn label(&self) -> String;
    /// The input names.
    fn input_names(&self) -> &'static [&'static str];
    /// Asks Z3, on the code as written (`site: None`) or with one operation altered.
    /// The verdict depends only on `budget.rlimit`; `Err` when the wall-clock guard fired.
    fn prove(&self, site: Option<u32>, budget: Budget) -> Result<Outcome, GuardHit>;
    /// Runs the compiled code (or the same mutant) on concrete inputs: `(in envelope,
    /// property holds)`.
    fn replay(&self, site: Option<u32>, x: &[u32]) -> (bool, bool);
    /// Number of machine operations in the code under proof (the mutation sites).
    fn sites(&self) -> u32;
    /// See [`Obligation::mutant_rlimit`].
    fn mutant_budget(&self) -> Budget;
}

impl<T: Obligation> Discharge for T {
    fn label(&self) -> String {
        self.name()
    }
    fn input_names(&self) -> &'static [&'static str] {
        self.inputs()
    }
    fn prove(&self, site: Option<u32>, budget: Budget) -> Result<Outcome, GuardHit> {
        let _slot = Slot::take();
        let ctx = Context::new(&Config::new());
        let what = match site {
            None => self.name(),
            Some(s) => format!("{} mutant at site {s}", self.name()),
        };
        let names = self.inputs();
        match self.engine() {
            Engine::BitVector => {
                let vars: Vec<BV> = names.iter().map(|n| BV::new_const(&ctx, *n, 32)).collect();
                let (envelope, property) = match site {
                    None => self.check(&Z3 { ctx: &ctx }, &vars),
                    Some(s) => self.check(&Mutant::new(Z3 { ctx: &ctx }, s), &vars),
                };
                // Z3's default solver: for bit-vectors its QF_BV tactic (simplification,
                // bit-blasting, AIG, SAT), whose only non-logical input is a probe of the
                // process's Z3 memory (see `Slot`).
                let solvers = [Solver::new(&ctx)];
                solve(&ctx, &solvers, &[envelope], &property, budget, &what, |m| {
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
                let solvers = nonlinear_integer_solvers(&ctx);
                solve(&ctx, &solvers, &facts, &property, budget, &what, |m| {
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
    fn mutant_budget(&self) -> Budget {
        Budget::rlimit(self.mutant_rlimit())
    }
}

/// The solvers for the integer engine, tried in turn: Z3's nonlinear procedure nlsat
/// behind the `qfnra-nlsat` tactic's simplifications, then the same after `simplify` and
/// `propagate-values` (each gets half the rlimit; the second only if the first is
/// undecided).
///
/// Not Z3's own `QF_NIA` strategy: in Z3 4.8.12 that tries a bit-blasting attempt, then
/// `smt` cut off after 2 s of wall clock (`try_for`), then nlsat cut off after 3 s, then
/// `smt` with no bound; which branch answered, and the resource count, depended on machine
/// load (`unsigned_mul_by_halves` measured 1,238,867 and then 504,223 on two runs, each
/// about 2.0 s: the 2 s branch expiring), and its last branch barely counts resources
/// (22,969,468 in 600 s on a `div_by_i64_q8_24` mutant), so an rlimit could not stop it.
/// The first nlsat alone proves both integer obligations (47,359 and 675,788) and decides
/// every mutant but `div_by_i64_q8_24` site 3, which the second refutes with 61,655 more
/// after the first's half; with the preprocessing the other way round, site 11 is the one
/// left.
/// nlsat's count grows about 5 million a second.
fn nonlinear_integer_solvers(ctx: &Context) -> [Solver<'_>; 2] {
    let t = |name| Tactic::new(ctx, name);
    [
        t("qfnra-nlsat").solver(),
        t("simplify")
            .and_then(&t("propagate-values"))
            .and_then(&t("qfnra-nlsat"))
            .solver(),
    ]
}

/// Z3 questions running at once in this process, at most [`SLOTS`].
static RUNNING: Mutex<usize> = Mutex::new(0);
static FREED: Condvar = Condvar::new();

/// At most two Z3 questions at once per process. Z3's QF_BV tactic (4.8.12) runs its AIG
/// step only while the memory Z3 has allocated in the whole process is under 300 MB, a
/// figure that includes other threads' questions: with at most two at once it stays under
/// 300 MB (one question's peak, "max memory" in the statistics, is 113 MB for the largest,
/// the products), so the tactic, and so the verdict and the count, do not depend on how
/// many test threads run.
const SLOTS: usize = 2;

/// A place among the [`SLOTS`], held while a question is built and solved.
struct Slot;

impl Slot {
    fn take() -> Slot {
        let mut n = RUNNING.lock().unwrap_or_else(PoisonError::into_inner);
        while *n >= SLOTS {
            n = FREED.wait(n).unwrap_or_else(PoisonError::into_inner);
        }
        *n += 1;
        Slot
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        *RUNNING.lock().unwrap_or_else(PoisonError::into_inner) -= 1;
        FREED.notify_one();
    }
}

/// The resource count Z3 has reached in `solver`'s context.
fn rlimit_count(solver: &Solver) -> u64 {
    match solver.get_statistics().value("rlimit count") {
        Some(StatisticsValue::UInt(n)) => u64::from(n),
        Some(StatisticsValue::Double(x)) => x as u64,
        None => 0,
    }
}

/// Asks whether `assumed` can hold with `property` false, within `budget`: `solvers` in
/// turn until one decides, each with an equal share of the rlimit (the last with what is
/// left); a model is read back by `inputs`.
fn solve<'c>(
    ctx: &'c Context,
    solvers: &[Solver<'c>],
    assumed: &[Bool<'c>],
    property: &Bool<'c>,
    budget: Budget,
    what: &str,
    inputs: impl Fn(&z3::Model<'c>) -> Vec<u32>,
) -> Result<Outcome, GuardHit> {
    let Some(first) = solvers.first() else {
        panic!("{what}: no solver");
    };
    let before = rlimit_count(first);
    let fired = AtomicBool::new(false);
    let start = Instant::now();
    // The guard: a watchdog that interrupts Z3 if the solvers are still running after
    // `budget.guard`, and says so through `fired`.
    let (verdict, last) = std::thread::scope(|s| {
        let (done, wait) = mpsc::channel::<()>();
        let handle = ctx.handle();
        let fired = &fired;
        s.spawn(move || {
            if let Err(RecvTimeoutError::Timeout) = wait.recv_timeout(budget.guard) {
                fired.store(true, Ordering::SeqCst);
                handle.interrupt();
            }
        });
        let mut reasons = Vec::new();
        let mut verdict = None;
        let mut last = first;
        for (i, solver) in solvers.iter().enumerate() {
            last = solver;
            let used = rlimit_count(solver).saturating_sub(before);
            let share = if budget.rlimit == 0 {
                0 // no limit
            } else if i + 1 == solvers.len() {
                // what the others left (at least 1: 0 would mean no limit)
                u64::from(budget.rlimit).saturating_sub(used).max(1) as u32
            } else {
                budget.rlimit / solvers.len() as u32
            };
            // The rlimit is the only bound Z3 is given; no "timeout" parameter.
            let mut params = Params::new(ctx);
            params.set_u32("rlimit", share);
            solver.set_params(&params);
            for a in assumed {
                solver.assert(a);
            }
            solver.assert(&property.not());
            match solver.check() {
                SatResult::Unsat => verdict = Some(Verdict::Proved),
                SatResult::Sat => {
                    verdict = Some(Verdict::Refuted(
                        solver.get_model().map(|m| inputs(&m)).unwrap_or_default(),
                    ))
                }
                SatResult::Unknown => reasons.push(solver.get_reason_unknown().unwrap_or_default()),
            }
            if verdict.is_some() || fired.load(Ordering::SeqCst) {
                break;
            }
        }
        drop(done);
        (
            verdict.unwrap_or_else(|| Verdict::Unknown(reasons.join("; "))),
            last,
        )
    });
    let time = start.elapsed();
    let rlimit_used = rlimit_count(last).saturating_sub(before);
    if fired.load(Ordering::SeqCst) {
        return Err(GuardHit {
            what: what.to_string(),
            budget,
            rlimit_used,
            time,
        });
    }
    Ok(Outcome {
        verdict,
        rlimit_used,
        time,
    })
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

impl MutantOutcome {
    /// What the mutant counts as: refuted (killed), proved (an equivalent mutant, survived)
    /// or undecided within its rlimit (survived, and said so).
    pub fn fate(&self) -> &'static str {
        match self.outcome.verdict {
            Verdict::Refuted(_) => "refuted",
            Verdict::Proved => "equivalent",
            Verdict::Unknown(_) => "undecided",
        }
    }
}

/// Every mutant of an obligation's code (one per operation), each asked of the solver with
/// `budget`, and every counterexample replayed on the compiled mutant.
pub fn mutants(o: &dyn Discharge, budget: Budget) -> Result<Vec<MutantOutcome>, GuardHit> {
    (0..o.sites())
        .map(|site| {
            let outcome = o.prove(Some(site), budget)?;
            let replays = match &outcome.verdict {
                Verdict::Refuted(x) => {
                    let (inside, holds) = o.replay(Some(site), x);
                    Some(inside && !holds)
                }
                _ => None,
            };
            Ok(MutantOutcome {
                site,
                outcome,
                replays,
            })
        })
        .collect()
}
