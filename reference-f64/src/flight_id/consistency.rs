//! Does the fitted model explain the data as well as its noise model says it should? A score
//! (Lagrange-multiplier) test per family of left-out effects: the whitened residuals'
//! correlation with the directions those effects would move the rates (per-thruster thrust,
//! valve opening and closing times), after removing what the fitted terms already explain.
//! Under the model the statistic is chi-square with the rank of those directions, so the
//! false-alarm rate is the test's level whatever the maneuver, rate or craft. A uniform
//! thrust error is not among the directions: on rates it is exactly an inertia error.
use nalgebra::{DMatrix, DVector};

/// One test's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct ScoreTest {
    /// "thrust", "valve_timing", "disturbance" or "rate_damping".
    pub name: &'static str,
    pub statistic: f64,
    /// Rank of the tested directions (after removing those the fitted terms explain).
    pub dof: usize,
    pub p_value: f64,
}

/// Share of a direction's own information that must remain after projecting out the fitted
/// terms for it to be tested (directions below it are indistinguishable from the terms).
const MIN_RESIDUAL_SHARE: f64 = 1e-3;

/// The score test of the columns `z` given the fitted columns `t` of one normal-equation set.
/// `consider` lists columns held at the model whose coefficients have a stated variance (a
/// thruster's relative thrust uncertainty, a pinned term's scale): their errors move the
/// score too, so its covariance is `V + W S W^T` rather than `V`, with `W` the columns'
/// cross-information with `z` after the fitted terms (`V` itself for a column of `z`).
/// Deviations within the stated uncertainties are then not called inconsistent.
pub fn score_test(
    name: &'static str,
    info: &DMatrix<f64>,
    score: &DVector<f64>,
    t: &[usize],
    z: &[usize],
    consider: &[(usize, f64)],
) -> Option<ScoreTest> {
    let ntt = DMatrix::from_fn(t.len(), t.len(), |i, j| info[(t[i], t[j])]);
    let ntz = DMatrix::from_fn(t.len(), z.len(), |i, j| info[(t[i], z[j])]);
    let nzz = DMatrix::from_fn(z.len(), z.len(), |i, j| info[(z[i], z[j])]);
    let sz = DVector::from_fn(z.len(), |i, _| score[z[i]]);
    let st = DVector::from_fn(t.len(), |i, _| score[t[i]]);
    let ntt_inv = ntt.clone().try_inverse()?;
    let v0 = &nzz - ntz.transpose() * &ntt_inv * &ntz;
    // The considered columns in `z` (a prior on a tested coefficient), then those outside it.
    let in_z: Vec<(usize, f64)> = consider
        .iter()
        .filter_map(|&(c, var)| z.iter().position(|&zc| zc == c).map(|i| (i, var)))
        .collect();
    let outside: Vec<(usize, f64)> = consider
        .iter()
        .copied()
        .filter(|(c, var)| !z.contains(c) && !t.contains(c) && *var > 0.0)
        .collect();
    let considered = !(in_z.is_empty() && outside.is_empty());
    let mut v = v0.clone();
    if !in_z.is_empty() {
        let p = DMatrix::from_fn(z.len(), z.len(), |i, j| {
            if i == j {
                in_z.iter()
                    .find(|(k, _)| *k == i)
                    .map_or(0.0, |(_, var)| *var)
            } else {
                0.0
            }
        });
        v += &v0 * p * &v0;
    }
    if !outside.is_empty() {
        let ntc = DMatrix::from_fn(t.len(), outside.len(), |i, k| info[(t[i], outside[k].0)]);
        let nzc = DMatrix::from_fn(z.len(), outside.len(), |i, k| info[(z[i], outside[k].0)]);
        let w = nzc - ntz.transpose() * &ntt_inv * ntc;
        let s2 = DMatrix::from_fn(outside.len(), outside.len(), |a, b| {
            if a == b {
                outside[a].1
            } else {
                0.0
            }
        });
        v += &w * s2 * w.transpose();
    }
    let s = &sz - ntz.transpose() * &ntt_inv * st;
    // Normalise by each direction's own information; keep directions with enough left.
    let d: Vec<f64> = (0..z.len()).map(|i| nzz[(i, i)]).collect();
    let keep: Vec<usize> = (0..z.len()).filter(|&i| d[i] > 0.0).collect();
    if keep.is_empty() {
        return None;
    }
    let vn = DMatrix::from_fn(keep.len(), keep.len(), |i, j| {
        v[(keep[i], keep[j])] / (d[keep[i]] * d[keep[j]]).sqrt()
    });
    let sn = DVector::from_fn(keep.len(), |i, _| s[keep[i]] / d[keep[i]].sqrt());
    let (mut stat, mut dof) = (0.0, 0);
    if considered {
        // The directions are those the fitted terms leave (chosen from V0, as without the
        // considered errors: a direction the terms explain almost wholly stays untested even
        // when a stated error inflates its variance); the statistic uses the widened V.
        let v0n = DMatrix::from_fn(keep.len(), keep.len(), |i, j| {
            v0[(keep[i], keep[j])] / (d[keep[i]] * d[keep[j]]).sqrt()
        });
        let eig0 = v0n.symmetric_eigen();
        let cols: Vec<usize> = (0..keep.len())
            .filter(|&k| eig0.eigenvalues[k] > MIN_RESIDUAL_SHARE)
            .collect();
        if cols.is_empty() {
            return None;
        }
        let q = DMatrix::from_fn(keep.len(), cols.len(), |i, k| {
            eig0.eigenvectors[(i, cols[k])]
        });
        let vq = q.transpose() * &vn * &q;
        let sq = q.transpose() * &sn;
        let x = vq.cholesky()?.solve(&sq);
        stat = sq.dot(&x);
        dof = cols.len();
    } else {
        let eig = vn.symmetric_eigen();
        for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
            if lambda > MIN_RESIDUAL_SHARE {
                let proj = eig.eigenvectors.column(k).dot(&sn);
                stat += proj * proj / lambda;
                dof += 1;
            }
        }
    }
    (dof > 0).then(|| ScoreTest {
        name,
        statistic: stat,
        dof,
        p_value: chi2_sf(stat, dof as f64),
    })
}

/// Upper tail of the chi-square distribution: `Q(k/2, x/2)`.
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    upper_gamma_regularized(0.5 * k, 0.5 * x)
}

/// `Q(a, x)` by its series (x < a + 1) or continued fraction (Numerical Recipes 6.2).
fn upper_gamma_regularized(a: f64, x: f64) -> f64 {
    let gln = ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut del, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * (-x + a * x.ln() - gln).exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        ((-x + a * x.ln() - gln).exp() * h).clamp(0.0, 1.0)
    }
}

/// Lanczos approximation of `ln Gamma(a)`, a > 0.
fn ln_gamma(a: f64) -> f64 {
    const C: [f64; 6] = [
        76.180_091_729_471_46,
        -86.505_320_329_416_77,
        24.014_098_240_830_91,
        -1.231_739_572_450_155,
        0.001_208_650_973_866_179,
        -0.000_005_395_239_384_953,
    ];
    let mut y = a;
    let tmp = a + 5.5;
    let tmp = tmp - (a + 0.5) * tmp.ln();
    let mut ser = 1.000_000_000_190_015;
    for c in C {
        y += 1.0;
        ser += c / y;
    }
    -tmp + (2.506_628_274_631_000_5 * ser / a).ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_square_tail_matches_tables() {
        // Known quantiles: chi2(1) 3.841 -> 0.05, chi2(2) 13.816 -> 0.001, chi2(10) 18.307 -> 0.05.
        for (x, k, p) in [
            (3.841, 1.0, 0.05),
            (13.816, 2.0, 0.001),
            (18.307, 10.0, 0.05),
            (29.588, 10.0, 0.001),
        ] {
            let got = chi2_sf(x, k);
            assert!(
                (got - p).abs() < 2e-4 * p.max(0.01) * 10.0,
                "chi2({k}) at {x}: {got} vs {p}"
            );
        }
        assert_eq!(chi2_sf(0.0, 3.0), 1.0);
    }

    #[test]
    fn a_direction_the_terms_explain_is_not_tested() {
        // Column 1 equals column 0: nothing left to test; column 2 independent: one dof.
        let info = DMatrix::from_row_slice(3, 3, &[4.0, 4.0, 0.0, 4.0, 4.0, 0.0, 0.0, 0.0, 1.0]);
        let score = DVector::from_row_slice(&[0.0, 0.0, 3.0]);
        assert!(score_test("x", &info, &score, &[0], &[1], &[]).is_none());
        let t = score_test("x", &info, &score, &[0], &[1, 2], &[]).unwrap();
        assert_eq!(t.dof, 1);
        assert!((t.statistic - 9.0).abs() < 1e-9);
        // A stated prior variance of 1 on that direction: score variance 1 + 1 = 2.
        let t = score_test("x", &info, &score, &[0], &[1, 2], &[(2, 1.0)]).unwrap();
        assert!((t.statistic - 4.5).abs() < 1e-9);
    }

    #[test]
    fn a_considered_column_outside_the_test_widens_its_covariance() {
        // Column 2 (tested) and column 3 (held, variance 1) share information 1: the score of
        // column 2 varies by 1 (noise) + 1 * 1 * 1 (column 3's error), so 3^2 / 2.
        let info = DMatrix::from_row_slice(
            4,
            4,
            &[
                4.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0,
            ],
        );
        let score = DVector::from_row_slice(&[0.0, 0.0, 3.0, 0.0]);
        let plain = score_test("x", &info, &score, &[0, 1], &[2], &[]).unwrap();
        assert!((plain.statistic - 9.0).abs() < 1e-9);
        let t = score_test("x", &info, &score, &[0, 1], &[2], &[(3, 1.0)]).unwrap();
        assert!((t.statistic - 4.5).abs() < 1e-9, "{}", t.statistic);
        // A fitted column is not a held one: listing it changes nothing.
        let t = score_test("x", &info, &score, &[0, 1], &[2], &[(1, 5.0)]).unwrap();
        assert!((t.statistic - 9.0).abs() < 1e-9);
    }

    #[test]
    fn a_direction_the_terms_explain_stays_untested_whatever_is_considered() {
        // Column 1 is column 0 but for 1e-4 of its information: untested. A held column 2
        // with a large stated variance moves column 1's score, but must not make it testable.
        let info =
            DMatrix::from_row_slice(3, 3, &[1.0, 0.99995, 0.0, 0.99995, 1.0, 1.0, 0.0, 1.0, 1.0]);
        let score = DVector::from_row_slice(&[0.0, 1.0, 0.0]);
        assert!(score_test("x", &info, &score, &[0], &[1], &[]).is_none());
        assert!(score_test("x", &info, &score, &[0], &[1], &[(2, 1e6)]).is_none());
    }
}
