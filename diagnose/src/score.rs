//! Scoring a diagnosis against a truth list, the way the hidden recordings are scored:
//! named correctly (same set of effects, nothing extra), parameter errors (inside the
//! reported uncertainty or 10 %), residual before and after.

use serde_json::Value;

use crate::output::DiagnosisOutput;

/// The score of one diagnosis.
#[derive(Clone, Debug)]
pub struct Score {
    pub named_correctly: bool,
    pub missing: Vec<String>,
    pub extra: Vec<String>,
    /// Contract parameters compared.
    pub params: usize,
    /// ... of which inside max(stderr, 10 % of truth).
    pub params_ok: usize,
    /// Largest relative parameter error (|est - truth| / |truth|, absolute when truth 0).
    pub worst_rel_err: f64,
    pub worst_param: String,
}

/// Flattens `{"k": 1.0, "a": [1, 2]}` to `[("k", 1.0), ("a[0]", 1.0), ("a[1]", 2.0)]`
/// (how parameters are named when compared with a truth file).
pub fn flatten(v: &Value) -> Vec<(String, f64)> {
    let mut out = vec![];
    if let Some(o) = v.as_object() {
        for (k, x) in o {
            match x {
                Value::Array(a) => {
                    for (i, y) in a.iter().enumerate() {
                        out.push((format!("{k}[{i}]"), y.as_f64().unwrap_or(f64::NAN)));
                    }
                }
                y => out.push((k.clone(), y.as_f64().unwrap_or(f64::NAN))),
            }
        }
    }
    out
}

/// Contract parameter names (extra keys such as amplitudes are not scored).
fn scored_key(k: &str) -> bool {
    !(k.contains("amplitude") || k.contains("fraction"))
}

/// Scores `out` against `truth` effects in contract JSON form (`[{"effect", "params"}]`).
pub fn score(out: &DiagnosisOutput, truth: &[Value]) -> Score {
    let want: Vec<String> = truth
        .iter()
        .filter_map(|e| e["effect"].as_str().map(String::from))
        .collect();
    let got: Vec<String> = out.effects.iter().map(|e| e.effect.clone()).collect();
    let missing: Vec<String> = want.iter().filter(|w| !got.contains(w)).cloned().collect();
    let extra: Vec<String> = got.iter().filter(|g| !want.contains(g)).cloned().collect();
    let mut s = Score {
        named_correctly: missing.is_empty() && extra.is_empty(),
        missing,
        extra,
        params: 0,
        params_ok: 0,
        worst_rel_err: 0.0,
        worst_param: String::new(),
    };
    for te in truth {
        let Some(e) = out
            .effects
            .iter()
            .find(|e| Some(e.effect.as_str()) == te["effect"].as_str())
        else {
            continue;
        };
        let est: std::collections::HashMap<String, f64> = flatten(&Value::Object(e.params.clone()))
            .into_iter()
            .collect();
        let se: std::collections::HashMap<String, f64> = flatten(&Value::Object(e.stderr.clone()))
            .into_iter()
            .collect();
        for (k, t) in flatten(&te["params"]) {
            if !scored_key(&k) {
                continue;
            }
            s.params += 1;
            let Some(&x) = est.get(&k) else { continue };
            let err = (x - t).abs();
            if err <= se.get(&k).copied().unwrap_or(0.0).max(0.1 * t.abs()) {
                s.params_ok += 1;
            }
            let rel = if t.abs() > 1e-12 { err / t.abs() } else { err };
            if rel > s.worst_rel_err {
                s.worst_rel_err = rel;
                s.worst_param = format!("{}.{k}", e.effect);
            }
        }
    }
    s
}
