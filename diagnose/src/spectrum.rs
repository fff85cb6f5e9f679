//! A spectrum that tolerates gaps: the Lomb-Scargle periodogram evaluates a least-squares
//! sinusoid fit at each frequency on whatever sample times exist, so dropped telemetry
//! neither shifts nor smears the peaks the way an FFT over a zero-filled grid would.

/// Lomb-Scargle power (normalised by the variance, 0..~N/2) at each frequency in `freqs_hz`
/// for values `y` at times `t_s`.
pub fn lomb_scargle(t_s: &[f64], y: &[f64], freqs_hz: &[f64]) -> Vec<f64> {
    let n = y.len();
    if n < 3 {
        return vec![0.0; freqs_hz.len()];
    }
    let mean = y.iter().sum::<f64>() / n as f64;
    let var = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    if var <= 0.0 {
        return vec![0.0; freqs_hz.len()];
    }
    freqs_hz
        .iter()
        .map(|&f| {
            let w = 2.0 * std::f64::consts::PI * f;
            let (mut s2, mut c2) = (0.0, 0.0);
            for &t in t_s {
                s2 += (2.0 * w * t).sin();
                c2 += (2.0 * w * t).cos();
            }
            let tau = s2.atan2(c2) / (2.0 * w);
            let (mut yc, mut ys, mut cc, mut ss) = (0.0, 0.0, 0.0, 0.0);
            for (&t, &v) in t_s.iter().zip(y) {
                let (s, c) = (w * (t - tau)).sin_cos();
                let d = v - mean;
                yc += d * c;
                ys += d * s;
                cc += c * c;
                ss += s * s;
            }
            let p = if cc > 0.0 { yc * yc / cc } else { 0.0 }
                + if ss > 0.0 { ys * ys / ss } else { 0.0 };
            0.5 * p / var
        })
        .collect()
}

/// Evenly spaced frequencies from `lo` to `hi` (inclusive) with `n` points.
pub fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n < 2 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}
