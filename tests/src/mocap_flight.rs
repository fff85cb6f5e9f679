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
    differenced_csv(seed, izz_scale, Difference::Central, false)
}

/// Over which samples the attitude is differenced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Difference {
    /// `(a_(k+1) - a_(k-1)) / 2 dt`.
    Central,
    /// `(a_k - a_(k-1)) / dt`.
    Backward,
}

/// A random-number stream (an LCG; the words and the noise each draw from their own).
struct Stream(u64);

impl Stream {
    fn new(seed: u64, salt: u64) -> Stream {
        Stream(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt)
    }
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    /// Box-Muller from two uniforms.
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// [`central_differenced_csv`] with the attitude differenced as `difference` says; with
/// `closed_loop`, each control step fires the thrusters that turn the craft towards a target
/// rate (redrawn every 3 s) from the rate the controller has then (the last two attitudes
/// differenced), so the commands answer the noise, as on open3's pl6.
pub fn differenced_csv(
    seed: u64,
    izz_scale: f64,
    difference: Difference,
    closed_loop: bool,
) -> String {
    let model = airbearing_model();
    let n = model.n_thrusters();
    let izz = model.inertia_kgm2[2] * izz_scale;
    let (mut words, mut noise) = (
        Stream::new(seed, 0x5DEE_CE66),
        Stream::new(seed, 0xB5AD_4ECE),
    );
    let (sample_ms, control_ms, total_ms) = (40u64, 80u64, 60_000u64);
    let dt = sample_ms as f64 * 1e-3;
    let mut omega = 0.05;
    let mut angle = 0.0f64;
    let mut word = 0u16;
    let mut target = 0.0;
    // per sample: time, word, measured attitude
    let mut rows: Vec<(u64, u16, f64)> = Vec::new();
    for t in 0..=total_ms {
        if t % sample_ms == 0 {
            rows.push((t, word, angle + ATTITUDE_RAD * noise.normal()));
        }
        if t % control_ms == 0 {
            word = if closed_loop {
                if t % 3000 == 0 {
                    target = 0.3 * (2.0 * words.uniform() - 1.0);
                }
                let k = rows.len();
                let rate = if k >= 2 {
                    (rows[k - 1].2 - rows[k - 2].2) / dt
                } else {
                    omega
                };
                // the torque that removes the error in two control steps, by whole thrusters
                let want =
                    model.inertia_kgm2[2] * (target - rate) / (2.0 * control_ms as f64 * 1e-3);
                let turning: Vec<usize> = (0..n)
                    .filter(|&i| model.torque_nm(i).z * want > 0.0)
                    .collect();
                let per = turning
                    .iter()
                    .map(|&i| model.torque_nm(i).z.abs())
                    .sum::<f64>()
                    / turning.len().max(1) as f64;
                let count = ((want.abs() / per.max(1e-9)).round() as usize).min(turning.len());
                turning.iter().take(count).fold(0u16, |w, &i| w | (1 << i))
            } else {
                // each thruster on with probability 1/4, redrawn each control step
                (0..n).fold(0u16, |w, i| {
                    if words.uniform() < 0.25 {
                        w | (1 << i)
                    } else {
                        w
                    }
                })
            };
            if let Some(last) = rows.last_mut() {
                if last.0 == t {
                    last.1 = word;
                }
            }
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
    let measured: Vec<f64> = rows.iter().map(|r| r.2).collect();
    let mut text = format!(
        "# format = massid-recording/2\n# satellite = airbearing-mpc\n# axes = z\n\
         # thrusters = {n}\n# sample_rate_hz = 25.0\ntime_ms,rate_z,thrusters\n"
    );
    for k in 1..rows.len() - 1 {
        let rate = match difference {
            Difference::Central => (measured[k + 1] - measured[k - 1]) / (2.0 * dt),
            Difference::Backward => (measured[k] - measured[k - 1]) / dt,
        } + WHITE_RAD_S * noise.normal();
        text.push_str(&format!("{},{rate},{}\n", rows[k].0, rows[k].1));
    }
    text
}
