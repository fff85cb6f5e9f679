//! Where the mismatch lives: by time window, by axis and by input condition (valve
//! edges, number of open valves, coasting after firings, time in the run).

use crate::series::Series;

/// Input condition of a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Condition {
    /// Within 20 ms after a commanded valve edge.
    NearEdge,
    /// Coasting: no valve open.
    Coasting,
    /// This many valves open (1, 2, 3+).
    Open(u8),
}

impl Condition {
    pub fn label(self) -> String {
        match self {
            Condition::NearEdge => "within 20 ms of valve edges".into(),
            Condition::Coasting => "coasting".into(),
            Condition::Open(n) if n >= 3 => "3+ valves open".into(),
            Condition::Open(n) => format!("{n} valve(s) open"),
        }
    }
}

/// Condition of every sample.
pub fn conditions(series: &Series) -> Vec<Condition> {
    let mut last_edge = i64::MIN / 2;
    let mut edge_at = vec![i64::MIN / 2; series.word_ms.len()];
    let mut prev = 0u16;
    for (k, &w) in series.word_ms.iter().enumerate() {
        if w != prev {
            last_edge = k as i64;
            prev = w;
        }
        edge_at[k] = last_edge;
    }
    series
        .t_ms
        .iter()
        .map(|&t| {
            let k = (t as usize).min(series.word_ms.len() - 1);
            let w = series.word_ms[k];
            if t - edge_at[k] < 20 {
                Condition::NearEdge
            } else if w == 0 {
                Condition::Coasting
            } else {
                Condition::Open(w.count_ones().min(3) as u8)
            }
        })
        .collect()
}

/// Mean-square residual per axis by condition: (condition, samples, ms per axis).
pub fn by_condition(series: &Series, r: &[[f64; 3]]) -> Vec<(Condition, usize, [f64; 3])> {
    let c = conditions(series);
    let mut acc: std::collections::BTreeMap<Condition, (usize, [f64; 3], [usize; 3])> =
        Default::default();
    for (i, ci) in c.iter().enumerate() {
        let e = acc.entry(*ci).or_insert((0, [0.0; 3], [0; 3]));
        e.0 += 1;
        for a in 0..3 {
            if series.valid[i][a] {
                e.1[a] += r[i][a] * r[i][a];
                e.2[a] += 1;
            }
        }
    }
    acc.into_iter()
        .map(|(k, (n, s, na))| (k, n, std::array::from_fn(|a| s[a] / na[a].max(1) as f64)))
        .collect()
}

/// Mean-square residual per axis in consecutive windows of `width_ms`: (start, end, ms).
pub fn by_window(series: &Series, r: &[[f64; 3]], width_ms: i64) -> Vec<(i64, i64, [f64; 3])> {
    let mut out = vec![];
    let mut start = series.t_ms[0] - series.t_ms[0].rem_euclid(width_ms);
    let (mut s, mut n) = ([0.0; 3], [0usize; 3]);
    let mean = |s: [f64; 3], n: [usize; 3]| std::array::from_fn(|a| s[a] / n[a].max(1) as f64);
    for (i, &t) in series.t_ms.iter().enumerate() {
        if t >= start + width_ms {
            if n.iter().any(|&k| k > 0) {
                out.push((start, start + width_ms, mean(s, n)));
            }
            start += (t - start) / width_ms * width_ms;
            s = [0.0; 3];
            n = [0; 3];
        }
        for a in 0..3 {
            if series.valid[i][a] {
                s[a] += r[i][a] * r[i][a];
                n[a] += 1;
            }
        }
    }
    if n.iter().any(|&k| k > 0) {
        out.push((start, start + width_ms, mean(s, n)));
    }
    out
}

/// The `count` windows where going from residual `before` to `after` removed the most
/// squared residual (summed over axes), in time order.
pub fn top_windows(
    series: &Series,
    before: &[[f64; 3]],
    after: &[[f64; 3]],
    width_ms: i64,
    count: usize,
) -> Vec<[i64; 2]> {
    let wb = by_window(series, before, width_ms);
    let wa = by_window(series, after, width_ms);
    let mut gain: Vec<(f64, i64, i64)> = wb
        .iter()
        .zip(wa.iter())
        .map(|(b, a)| {
            (
                (b.2[0] + b.2[1] + b.2[2]) - (a.2[0] + a.2[1] + a.2[2]),
                b.0,
                b.1,
            )
        })
        .collect();
    gain.sort_by(|x, y| y.0.total_cmp(&x.0));
    let mut w: Vec<[i64; 2]> = gain
        .iter()
        .take(count)
        .filter(|g| g.0 > 0.0)
        .map(|g| [g.1, g.2])
        .collect();
    w.sort();
    w
}

/// Per-axis RMS of a residual.
pub fn rms(r: &[[f64; 3]], valid: &[[bool; 3]]) -> [f64; 3] {
    let mut s = [0.0; 3];
    let mut n = [0usize; 3];
    for (x, v) in r.iter().zip(valid) {
        for a in 0..3 {
            if v[a] {
                s[a] += x[a] * x[a];
                n[a] += 1;
            }
        }
    }
    std::array::from_fn(|a| (s[a] / n[a].max(1) as f64).sqrt())
}

/// Change of the residual over the last `lag_ms` (zero where that sample is missing): a
/// model error in torque shows where it is *created* (during the responsible firings),
/// while the rate residual itself persists into the coasting that follows.
pub fn differenced(series: &Series, r: &[[f64; 3]], lag_ms: i64) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; r.len()];
    let mut j = 0usize;
    for i in 0..r.len() {
        let target = series.t_ms[i] - lag_ms;
        while j < i && series.t_ms[j] < target {
            j += 1;
        }
        if j < i && series.t_ms[j] == target {
            out[i] = std::array::from_fn(|a| r[i][a] - r[j][a]);
        }
    }
    out
}
