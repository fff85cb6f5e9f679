//! The whole diagnosis, a short orchestration of named stages, each in its own file:
//!
//! 1. `nominal.rs`: the nominal prediction with the initial rate fitted; the noise model
//!    from its residual.
//! 2. `forward.rs`: forward selection of mechanisms by BIC, each put through the acceptance
//!    checks; `pairs.rs` when no single one generalises; `indistinct.rs` keeps, for the one
//!    named, the strong candidates whose fitted rates the recording cannot tell from its own.
//! 3. `exchange.rs`: each named effect may be dropped (the others stand in for it) or
//!    replaced by a mechanism that fits better in its place.
//! 4. `conclusion.rs`: standard errors, the contract's reports, what is left unexplained.
//!
//! The stages hand on `named::Named` (the effects named so far and the model they make)
//! and a `Log` of every score and every reason a candidate was not named, from which
//! `evidence.rs` writes each named effect's sentence.

mod conclusion;
mod evidence;
mod exchange;
mod forward;
mod held;
mod indistinct;
mod named;
mod nominal;
mod pairs;

pub(crate) use nominal::initial_rate;

use crate::effects::Kind;
use crate::locate;
use crate::model::Plant;
use crate::noise::NoiseModel;
use crate::output::{DataIssues, DiagnosisOutput};
use crate::select::Settings;
use crate::series::Series;
use crate::stats::ResidualTests;

/// Runs the diagnosis of `series` against the satellite `plant`; `None` when the nominal
/// model does not predict the recording (a non-finite prediction).
pub fn diagnose(
    series: &Series,
    plant: &Plant,
    recording: &str,
    model: &str,
    issues: DataIssues,
    settings: &Settings,
) -> Option<Analysis> {
    let nominal = {
        let _timing = Timing::start("nominal");
        nominal::fit(series, plant)?
    };
    let mut named = named::Named::nominal(&nominal);
    let mut log = Log::default();
    let tone = {
        let _timing = Timing::start("forward selection");
        forward::select(&nominal, &mut named, &mut log, settings)
    };
    exchange::run(&nominal, &mut named, &mut log, settings);
    held::run(&nominal, &mut named, settings);
    let _timing = Timing::start("conclusion");
    Some(conclusion::conclude(
        nominal, named, log, tone, recording, model, issues,
    ))
}

/// How many of a round's strongest candidates (or pairs) are tried against the acceptance
/// checks.
const MAX_TRIES: usize = 3;

/// Everything the reports need.
#[derive(Clone, Debug)]
pub struct Analysis {
    pub output: DiagnosisOutput,
    /// The recording as diagnosed (for plots).
    pub series: Series,
    pub residual_before: Vec<[f64; 3]>,
    pub residual_after: Vec<[f64; 3]>,
    pub noise: NoiseModel,
    /// What the rate sensor reports of the rate (`crate::response`).
    pub response: crate::response::Response,
    pub tests_before: ResidualTests,
    pub tests_after: ResidualTests,
    /// Post-edge residual spectrum of the nominal model (frequency Hz, power).
    pub spectrum_before: Vec<(f64, f64)>,
    /// The statistic a tone must reach to be named (its parameters' BIC cost plus the
    /// acceptance margin): the spectrum's significance line.
    pub spectrum_threshold: f64,
    /// Apparent tone and the true frequencies it could fold from.
    pub alias_marks: (f64, Vec<f64>),
    pub scores: Vec<Score>,
    /// Strong candidates that were not named, with the reason.
    pub rejections: Vec<Rejection>,
    pub by_condition_before: Vec<(locate::Condition, usize, [f64; 3])>,
    pub by_condition_after: Vec<(locate::Condition, usize, [f64; 3])>,
    /// The named effects' parameters in the model's layout, in acceptance order (what
    /// a held-out prediction runs with, `holdout.rs`).
    pub fitted: Vec<(Kind, Vec<f64>)>,
}

/// One candidate's score in one selection round.
#[derive(Clone, Debug)]
pub struct Score {
    pub round: usize,
    pub effect: &'static str,
    pub delta_bic: f64,
}

/// A candidate the diagnosis did not name, and why.
#[derive(Clone, Debug)]
pub struct Rejection {
    pub round: usize,
    pub effect: &'static str,
    pub delta_bic: f64,
    pub reason: String,
}

/// Every candidate's score and every reason one was not named, round by round (the
/// exchange logs as round `max_effects`).
#[derive(Default)]
struct Log {
    scores: Vec<Score>,
    rejections: Vec<Rejection>,
}

impl Log {
    fn score(&mut self, round: usize, kind: Kind, delta_bic: f64) {
        self.scores.push(Score {
            round,
            effect: kind.name(),
            delta_bic,
        });
    }

    fn reject(&mut self, round: usize, kind: Kind, delta_bic: f64, reason: String) {
        self.rejections.push(Rejection {
            round,
            effect: kind.name(),
            delta_bic,
            reason,
        });
    }
}

/// Prints how long a stage or candidate took when MASSID_DIAG_PROFILE is set (development
/// aid).
struct Timing(&'static str, std::time::Instant, usize);

impl Timing {
    /// Starts timing the stage `name` (and counting its predictions).
    fn start(name: &'static str) -> Timing {
        let predictions = crate::model::PREDICTIONS.load(std::sync::atomic::Ordering::Relaxed);
        Timing(name, std::time::Instant::now(), predictions)
    }
}

impl Drop for Timing {
    fn drop(&mut self) {
        if std::env::var_os("MASSID_DIAG_PROFILE").is_some() {
            let now = crate::model::PREDICTIONS.load(std::sync::atomic::Ordering::Relaxed);
            eprintln!(
                "  {:>22}: {:.2} s, {} predictions",
                self.0,
                self.1.elapsed().as_secs_f64(),
                now - self.2
            );
        }
    }
}
