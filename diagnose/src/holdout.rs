//! The engineers' check of a diagnosis when there is no truth: name and fit the effects on
//! the first part of the recording only, then predict the rest, which the fit never saw,
//! with the nominal model and with the fitted one. Only the state nuisances (the rate at
//! the first held-out sample, rate jumps at gaps) are re-estimated on the held-out part,
//! for both models alike; every physical parameter comes from the fitted part.

use crate::diagnosis::{self, initial_rate, Analysis};
use crate::effects::Kind;
use crate::fit::Problem;
use crate::locate;
use crate::model::Plant;
use crate::noise;
use crate::output::DataIssues;
use crate::response::Response;
use crate::select::fit_nuisance_with;
use crate::select::Settings;
use crate::series::Series;

/// Residual of the held-out part under the nominal and the fitted model.
#[derive(Clone, Debug)]
pub struct Holdout {
    /// First held-out sample's time on the recording's clock, ms.
    pub split_ms: f64,
    /// Samples fitted on and held out.
    pub fitted_samples: usize,
    pub held_out_samples: usize,
    /// RMS of measured minus predicted rate on the held-out part, rad/s, per axis (0 on an
    /// axis without measurements): nominal model, and the model with the fitted effects.
    pub rms_nominal: [f64; 3],
    pub rms_fitted: [f64; 3],
    /// The diagnosis of the fitted part (its effects are the ones predicted with).
    pub analysis: Analysis,
}

/// Diagnoses the first `fraction` of `series`' samples and predicts the rest. None when a
/// part is empty or a model cannot predict it.
pub fn fit_then_predict(
    series: &Series,
    plant: &Plant,
    recording: &str,
    model: &str,
    settings: &Settings,
    fraction: f64,
) -> Option<Holdout> {
    let split = ((series.len() as f64) * fraction.clamp(0.0, 1.0)).round() as usize;
    let first = series.select(0..split)?;
    let rest = series.select(split..series.len())?;
    let issues = DataIssues {
        gaps: first.gaps,
        missing_samples: first.missing_samples,
        duplicates: 0,
        saturated: 0,
        railed: first.railed,
    };
    let analysis = diagnosis::diagnose(&first, plant, recording, model, issues, settings)?;
    let nominal = held_out_rms(&rest, plant, analysis.response, &[])?;
    let fitted = held_out_rms(&rest, plant, analysis.response, &analysis.fitted)?;
    Some(Holdout {
        split_ms: series.real_ms(rest.t_ms[0] as f64),
        fitted_samples: first.len(),
        held_out_samples: rest.len(),
        rms_nominal: nominal,
        rms_fitted: fitted,
        analysis,
    })
}

/// RMS residual of `part` under the model with `effects`, its state nuisances fitted, as the
/// rate sensor reports it (`response`, found on the fitted part).
fn held_out_rms(
    part: &Series,
    plant: &Plant,
    response: Response,
    effects: &[(Kind, Vec<f64>)],
) -> Option<[f64; 3]> {
    // weights only shape the nuisance fit; the noise of the part's own nominal residual
    let provisional = noise::NoiseModel::white([1e-6; 3]);
    let mut prob = Problem::new(plant, part, &provisional);
    prob.response = response;
    let mut start = initial_rate(part).to_vec();
    start.extend(std::iter::repeat_n(0.0, 3 * part.gap_resets.len()));
    let fr = fit_nuisance_with(&prob, effects, &start)?;
    let r = prob.residual(&fr.params)?;
    Some(locate::rms(&r, &part.valid))
}
