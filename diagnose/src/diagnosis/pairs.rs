//! Stage 2b, pairs: when no single effect of a round generalises, two true effects may each
//! fail alone (each fit alone is a compromise that predicts some held-out block worse), so
//! the strongest pairs are fitted jointly and put through the same checks.

use super::named::{Named, Taken};
use super::nominal::Nominal;
use super::{Log, Timing, MAX_TRIES};
use crate::candidate::Trial;
use crate::effects::Kind;
use crate::fit;
use crate::select::{self, combinable, wald, Settings};

/// Pairs are formed from this many of the round's strongest candidates.
pub(super) const PAIR_POOL: usize = 5;

/// The first pair from `pool` (delta BIC, effect, parameters of the round's candidates)
/// that passes every check of `trial`, or `None`; failures are logged.
pub(super) fn try_pairs(
    n: &Nominal,
    named: &Named,
    trial: &Trial,
    pool: &[(f64, Kind, Vec<f64>)],
    round: usize,
    log: &mut Log,
    settings: &Settings,
) -> Option<Taken> {
    let _timing = Timing::start("pairs");
    let chi2_cur = named.chi2();
    let ln_n = n.ln_n;
    let mut pairs = vec![];
    for a in 0..pool.len() {
        for b in a + 1..pool.len() {
            let (ka, kb) = (pool[a].1, pool[b].1);
            if !combinable(ka, kb) {
                continue;
            }
            let new = [(ka, pool[a].2.clone()), (kb, pool[b].2.clone())];
            let mut start = trial.rigid_acc.to_vec();
            start.extend_from_slice(&new);
            let Some((fr, sz)) = select::fit_joint(
                &n.prob,
                &n.fired,
                &start,
                None,
                &named.nuis,
                &n.slosh_hint,
                settings.max_iter * 2,
            ) else {
                continue;
            };
            let off_a: usize = sz[..sz.len() - 2].iter().sum();
            let off_b = off_a + sz[sz.len() - 2];
            let end = off_b + sz[sz.len() - 1];
            let k_pair = fit::identifiable(&fr.stderr[off_a..end]);
            let dbic = fr.chi2 - named.ring_gain() - chi2_cur + k_pair as f64 * ln_n;
            // each must earn its place beside the other
            if dbic > pool[a].0.min(pool[b].0) - settings.accept_margin {
                continue;
            }
            let own = |kind: Kind, from: usize, to: usize| {
                let se = &fr.stderr[from..to];
                let cov = fit::cov_block(&fr.cov, from, to - from);
                wald(kind, &fr.theta[from..to], se, &cov, &n.prob)
                    >= fit::identifiable(se) as f64 * ln_n
            };
            if !own(ka, off_a, off_b) || !own(kb, off_b, end) {
                continue;
            }
            let fitted = [
                (ka, fr.theta[off_a..off_b].to_vec()),
                (kb, fr.theta[off_b..end].to_vec()),
            ];
            pairs.push((dbic, fitted));
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    for (dbic, new) in pairs.into_iter().take(MAX_TRIES) {
        match trial.check(&new, None) {
            Ok(t) => {
                let together = |other: Kind| {
                    format!("named together with {}: alone neither generalised, together they predict held-out blocks better (delta BIC {dbic:.0} for both)", other.name())
                };
                return Some((
                    vec![
                        (dbic, new[0].0, together(new[1].0)),
                        (dbic, new[1].0, together(new[0].0)),
                    ],
                    t,
                ));
            }
            Err(reason) => log.reject(
                round,
                new[0].0,
                dbic,
                format!("together with {}: {reason}", new[1].0.name()),
            ),
        }
    }
    None
}
