//! Planar flights whose yaw rate is motion-capture attitude differenced, centrally
//! `(a_(k+1) - a_(k-1)) / 2 dt` (the sensor of open3's pl6) or with the previous sample
//! `(a_k - a_(k-1)) / dt`, written independently of the simulator (whose differenced sensor
//! is the point rate with differenced noise): the diagnosis's test and Monte Carlo of those
//! sensors (`tests/tests/diagnose_central_difference.rs`, `examples/diagnose_central_mc.rs`).
use crate::identification_mc::airbearing_model;

/// Attitude noise, rad per sample, and white rate noise, rad/s (open3 pl6's).
pub const ATTITUDE_RAD: f64 = 0.00015;
pub const WHITE_RAD_S: f64 = 0.002;

/// A 60 s flight at 25 Hz of the air-bearing craft (`examples/models/airbearing-mpc.toml`),
/// random words held for 80 ms control steps, the yaw integrated exactly on the 1 ms grid,
/// the attitude measured every 40 ms with white noise and central-differenced, plus white rate
/// noise: the recording's text (format v2). `izz_scale` multiplies the true Izz
/// against the model's (1: nominal).
pub fn central_differenced_csv(seed: u64, izz_scale: f64) -> String {
    differenced_csv(seed, izz_scale, Difference::Central)
}

/// Over which samples the attitude is differenced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Difference {
    /// `(a_(k+1) - a_(k-1)) / 2 dt`.
    Central,
    /// `(a_k - a_(k-1)) / dt`.
    Backward,
}

/// [`central_differenced_csv`] with the attitude differenced as `difference` says.
pub fn differenced_csv(seed: u64, izz_scale: f64, difference: Difference) -> String {
    let model = airbearing_model();
    let n = model.n_thrusters();
    let izz = model.inertia_kgm2[2] * izz_scale;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5DEE_CE66;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut normal = move || {
        // Box-Muller from two uniforms
        let (u, v) = (uniform(), uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let (sample_ms, control_ms, total_ms) = (40u64, 80u64, 60_000u64);
    let mut omega = 0.05;
    let mut angle = 0.0f64;
    let mut word = 0u16;
    // per sample: time, word, true attitude
    let mut rows: Vec<(u64, u16, f64)> = Vec::new();
    for t in 0..=total_ms {
        if t % control_ms == 0 {
            // each thruster on with probability 1/4, redrawn each control step
            word = (0..n).fold(0u16, |w, i| if uniform() < 0.25 { w | (1 << i) } else { w });
        }
        if t % sample_ms == 0 {
            rows.push((t, word, angle));
        }
        let f = model.thrusts_for_word(word);
        let tau: f64 = (0..n)
            .filter(|&i| f[i] > 0.0)
            .map(|i| model.torque_nm(i).z * f[i] / model.thrust_n[i])
            .sum();
        let a = tau / izz;
        angle += omega * 1e-3 + 0.5 * a * 1e-6;
        omega += a * 1e-3;
    }
    let measured: Vec<f64> = rows.iter().map(|r| r.2 + ATTITUDE_RAD * normal()).collect();
    let dt = sample_ms as f64 * 1e-3;
    let mut text = format!(
        "# format = massid-recording/2\n# satellite = airbearing-mpc\n# axes = z\n\
         # thrusters = {n}\n# sample_rate_hz = 25.0\ntime_ms,rate_z,thrusters\n"
    );
    for k in 1..rows.len() - 1 {
        let rate = match difference {
            Difference::Central => (measured[k + 1] - measured[k - 1]) / (2.0 * dt),
            Difference::Backward => (measured[k] - measured[k - 1]) / dt,
        } + WHITE_RAD_S * normal();
        text.push_str(&format!("{},{rate},{}\n", rows[k].0, rows[k].1));
    }
    text
}
