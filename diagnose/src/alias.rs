//! Alias folding: a tone at true frequency f sampled at fs shows at |f - k fs| folded into
//! [0, fs/2]; conversely an apparent tone could be any of |k fs +/- f_app|. The seed's
//! 11.45 Hz (50 Hz sampling) and 38.33 Hz (100 Hz) tones were the same 338 Hz gyro
//! ringing (App. A).

/// Where a tone of true frequency `f_hz` shows when sampled at `fs_hz`.
pub fn apparent(f_hz: f64, fs_hz: f64) -> f64 {
    let r = f_hz.rem_euclid(fs_hz);
    if r > fs_hz / 2.0 {
        fs_hz - r
    } else {
        r
    }
}

/// Every true frequency up to `f_max_hz` that shows at `f_app_hz` when sampled at `fs_hz`,
/// ascending.
pub fn candidates(f_app_hz: f64, fs_hz: f64, f_max_hz: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut k = 0.0;
    while k * fs_hz - f_app_hz <= f_max_hz {
        for f in [k * fs_hz - f_app_hz, k * fs_hz + f_app_hz] {
            if f > 0.0 && f <= f_max_hz && !out.iter().any(|&g: &f64| (g - f).abs() < 1e-9) {
                out.push(f);
            }
        }
        k += 1.0;
    }
    out.sort_by(|a, b| a.total_cmp(b));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_aliases_of_338_hz() {
        // App. A: 338 Hz shows near 38 Hz at 100 Hz sampling and near 12 Hz at 50 Hz.
        assert!((apparent(338.0, 100.0) - 38.0).abs() < 1e-9);
        assert!((apparent(338.0, 50.0) - 12.0).abs() < 1e-9);
        assert!((apparent(338.0, 1000.0) - 338.0).abs() < 1e-9);
        for fs in [50.0, 100.0, 1000.0] {
            let c = candidates(apparent(338.0, fs), fs, 600.0);
            assert!(c.iter().any(|&f| (f - 338.0).abs() < 1e-9), "{fs}: {c:?}");
            for f in c {
                assert!((apparent(f, fs) - apparent(338.0, fs)).abs() < 1e-9);
            }
        }
    }
}
