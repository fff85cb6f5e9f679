//! The one check of a recording against a model that every subcommand runs before it
//! computes anything: the time axis (a declared rate must agree with the time steps), the
//! thrusters (count and bits), planar against 3-D, and enough (but not unboundedly many)
//! samples and firings for what is asked. Errors name the file, and the line when there is
//! one; they never say `file:0:`.
use anyhow::{bail, Result};
use reference_f64::rate_recording::{Commands, RateRecording};
use reference_f64::recording::Recording;
use reference_f64::satellite::{Satellite, N_THRUSTERS};
use std::path::Path;

/// A recording in either format.
#[derive(Clone, Copy)]
pub enum Rec<'a> {
    V1(&'a Recording),
    V2(&'a RateRecording),
}

/// What the subcommand is about to do with the recording.
#[derive(Clone, Copy, Debug)]
pub struct Needs {
    /// Names the work in messages, e.g. "diagnose".
    pub what: &'static str,
    /// Fewest samples the work can use.
    pub min_samples: usize,
    /// Most samples the work is allowed to take on (time and memory grow with them).
    pub max_samples: usize,
    /// Fewest samples with a thruster open (or a non-zero commanded wrench).
    pub min_firing_samples: usize,
    /// The seed's design (`--method seed`, the onboard kernels): a 12-thruster 3-D craft
    /// recorded in format v1.
    pub spheres: bool,
    /// Refuse a gyro that does not respond to the firings (stuck at its bias).
    pub gyro_must_respond: bool,
}

impl Needs {
    /// `massid diagnose`: a noise estimate, residual whiteness tests over 30 lags and at
    /// least one firing to compare with the model; at most [`DIAGNOSE_MAX_SAMPLES`].
    pub const DIAGNOSE: Needs = Needs {
        what: "diagnose",
        min_samples: DIAGNOSE_MIN_SAMPLES,
        max_samples: DIAGNOSE_MAX_SAMPLES,
        min_firing_samples: 1,
        spheres: false,
        gyro_must_respond: true,
    };

    /// `massid estimate`: the identification reports too-short flights itself (status and
    /// error); this check only refuses what it cannot read right.
    pub fn estimate(spheres: bool) -> Needs {
        Needs {
            what: if spheres {
                "the seed's design (--method seed, --kernel f32/fixed)"
            } else {
                "estimate"
            },
            min_samples: 1,
            max_samples: ESTIMATE_MAX_SAMPLES,
            min_firing_samples: 0,
            spheres,
            gyro_must_respond: false,
        }
    }
}

/// Fewest samples `diagnose` analyses: its whiteness tests look 30 lags back and its noise
/// estimate needs a few hundred degrees of freedom; 2 or 3 rows gave a delta-BIC of -1e20.
pub const DIAGNOSE_MIN_SAMPLES: usize = 100;
/// Most samples `diagnose` analyses: 28 000 take 3.6 s and its working set grows with the
/// length (10^7 rows ran out of time and 3.4 GB); 10^6 is about 17 min at 1 kHz.
pub const DIAGNOSE_MAX_SAMPLES: usize = 1_000_000;
/// Most samples `estimate` takes on: about 2.8 h at 1 kHz.
pub const ESTIMATE_MAX_SAMPLES: usize = 10_000_000;

/// The line of a `# key = value` metadata line at the top of `path`, if any.
pub fn meta_line(path: &Path, key: &str) -> Option<usize> {
    use std::io::BufRead;
    let f = std::fs::File::open(path).ok()?;
    for (i, line) in std::io::BufReader::new(f).lines().enumerate().take(1000) {
        let line = line.ok()?;
        let t = line.trim_start_matches('\u{feff}').trim();
        let rest = t.strip_prefix('#')?;
        if let Some((k, _)) = rest.split_once('=') {
            if k.trim() == key {
                return Some(i + 1);
            }
        }
    }
    None
}

/// `file:line: reason`, or `file: reason` when no line is known.
pub fn at(file: &str, line: Option<usize>, reason: impl std::fmt::Display) -> anyhow::Error {
    match line {
        Some(l) if l > 0 => anyhow::anyhow!("{file}:{l}: {reason}"),
        _ => anyhow::anyhow!("{file}: {reason}"),
    }
}

fn median_step_ms(times: impl Iterator<Item = u64>) -> Option<f64> {
    let mut prev = None;
    let mut steps: Vec<u64> = Vec::new();
    for t in times {
        if let Some(p) = prev {
            steps.push(t.saturating_sub(p));
        }
        prev = Some(t);
    }
    if steps.is_empty() {
        return None;
    }
    let mid = steps.len() / 2;
    let (_, m, _) = steps.select_nth_unstable(mid);
    Some(*m as f64)
}

/// The time-axis rule every subcommand applies: a declared `sample_rate_hz` must agree
/// with the median `time_ms` step within 10 % (what `Recording::checked_period_ms` does
/// for v1, here for both formats).
fn check_time_axis(rec: Rec, path: &Path) -> Result<()> {
    let (source, declared, times): (&str, Option<&str>, Box<dyn Iterator<Item = u64>>) = match rec {
        Rec::V1(r) => (
            &r.source,
            r.meta("sample_rate_hz"),
            Box::new(r.samples.iter().map(|s| s.time_ms)),
        ),
        Rec::V2(r) => (
            &r.source,
            r.meta("sample_rate_hz"),
            Box::new(r.time_ms.iter().copied()),
        ),
    };
    let Some(declared) = declared else {
        return Ok(());
    };
    let line = meta_line(path, "sample_rate_hz");
    let rate = match declared.trim().parse::<f64>() {
        Ok(r) if r.is_finite() && r > 0.0 => r,
        _ => {
            return Err(at(
                source,
                line,
                format!("sample_rate_hz = {declared:?} is not a positive number"),
            ))
        }
    };
    if let Some(step) = median_step_ms(times) {
        let period = 1000.0 / rate;
        if (step - period).abs() > 0.1 * period.max(step) {
            return Err(at(
                source,
                line,
                format!(
                    "sample_rate_hz = {rate} declares a {period} ms period, but the time_ms steps are {step} ms (median); fix the rate or the time stamps"
                ),
            ));
        }
    }
    Ok(())
}

/// Checks `rec` (read from `path`) against `sat` for `needs`, before anything is computed.
pub fn check_recording(rec: Rec, path: &Path, sat: &Satellite, needs: &Needs) -> Result<()> {
    let source = match rec {
        Rec::V1(r) => r.source.as_str(),
        Rec::V2(r) => r.source.as_str(),
    };
    let n = match rec {
        Rec::V1(r) => r.samples.len(),
        Rec::V2(r) => r.time_ms.len(),
    };
    let what = needs.what;
    if n > needs.max_samples {
        bail!(
            "{source}: {n} samples; {what} takes at most {} (its time and memory grow with the length): split the recording",
            needs.max_samples
        );
    }
    if n < needs.min_samples {
        bail!(
            "{source}: {n} sample(s); {what} needs at least {} to say anything (noise estimate and residual tests)",
            needs.min_samples
        );
    }
    check_time_axis(rec, path)?;
    let model = &sat.name;
    let kind = |s: &Satellite| if s.planar { "planar" } else { "3-D" };
    if needs.spheres && (sat.planar || sat.n_thrusters() != N_THRUSTERS) {
        bail!(
            "{what} runs a 12-thruster 3-D SPHERES craft; model {model} is a {} craft with {} thrusters (use the default f64 output-error method)",
            kind(sat),
            sat.n_thrusters()
        );
    }
    // Thrusters: count (v2 declares it) and bits.
    let mask = sat.word_mask();
    match rec {
        Rec::V1(r) => {
            if let Some(s) = r.samples.iter().find(|s| s.thrusters & !mask != 0) {
                bail!(
                    "{source}: the sample at time_ms {} opens thruster(s) {} that model {model} ({} thrusters) does not have: the recording is of another craft",
                    s.time_ms,
                    thruster_list(s.thrusters & !mask),
                    sat.n_thrusters()
                );
            }
        }
        Rec::V2(r) => {
            if needs.spheres {
                bail!("{source}: {what} reads format v1 (gyro counts) only; this recording is format v2");
            }
            if let Commands::Thrusters { n: rn, words } = &r.commands {
                if *rn != sat.n_thrusters() {
                    bail!(
                        "{source}: {rn} thrusters in the recording, {} in model {model}",
                        sat.n_thrusters()
                    );
                }
                if let Some((k, w)) = words.iter().enumerate().find(|(_, w)| *w & !mask != 0) {
                    bail!(
                        "{source}: the sample at time_ms {} opens thruster(s) {} that model {model} ({} thrusters) does not have",
                        r.time_ms[k],
                        thruster_list(w & !mask),
                        sat.n_thrusters()
                    );
                }
            }
            // Planar against 3-D.
            if sat.planar && !r.axes[2] {
                bail!(
                    "{source}: model {model} is a planar craft (it turns about z), but the recording has no z rate (axes {})",
                    r.axes_text()
                );
            }
            if !sat.planar && r.axes != [true; 3] {
                bail!(
                    "{source}: model {model} is a 3-D craft, but the recording measures only {} (a craft on a table: add `planar = true` to the model)",
                    r.axes_text()
                );
            }
        }
    }
    let firing = match rec {
        Rec::V1(r) => r.samples.iter().filter(|s| s.thrusters != 0).count(),
        Rec::V2(r) => match &r.commands {
            Commands::Thrusters { words, .. } => words.iter().filter(|w| **w != 0).count(),
            Commands::Wrench { values, .. } => values
                .iter()
                .filter(|v| v.iter().any(|x| x.is_finite() && *x != 0.0))
                .count(),
        },
    };
    if firing < needs.min_firing_samples {
        bail!(
            "{source}: {firing} sample(s) with a thruster open; {what} compares the model's response to the thrusters with the recording and needs at least {}",
            needs.min_firing_samples
        );
    }
    if needs.gyro_must_respond {
        gyro_responds(rec, sat)?;
    }
    Ok(())
}

fn thruster_list(bits: u16) -> String {
    (0..16)
        .filter(|i| bits & (1 << i) != 0)
        .map(|i| (i + 1).to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Fraction of the model's predicted rate excursion below which the measured rate counts
/// as not responding (the f64 estimate's `no_gyro_response` uses 1/8 of the inertia).
pub const NO_RESPONSE_FRACTION: f64 = 0.125;

/// Refuses a rate sensor that does not move while the thrusters fire (e.g. a gyro stuck at
/// its bias): the model's open-loop rate (torque integrated through the inertia, from the
/// commands alone) swings by P on an axis, the measured rate by less than P / 8 on every
/// axis the model swings by at least a quarter of its largest swing.
fn gyro_responds(rec: Rec, sat: &Satellite) -> Result<()> {
    let j_inv = match sat.inertia_matrix().try_inverse() {
        Some(j) => j,
        None => return Ok(()),
    };
    // Predicted rate (from rest) and measured rate, per sample.
    let mut w = nalgebra::Vector3::zeros();
    let mut lo_p = [0.0f64; 3];
    let mut hi_p = [0.0f64; 3];
    let mut lo_m = [f64::INFINITY; 3];
    let mut hi_m = [f64::NEG_INFINITY; 3];
    let mut push_measured = |rate: [f64; 3], axes: [bool; 3]| {
        for a in 0..3 {
            if axes[a] && rate[a].is_finite() {
                lo_m[a] = lo_m[a].min(rate[a]);
                hi_m[a] = hi_m[a].max(rate[a]);
            }
        }
    };
    let (source, axes) = match rec {
        Rec::V1(r) => {
            for (k, s) in r.samples.iter().enumerate() {
                let rate: [f64; 3] =
                    std::array::from_fn(|a| sat.gyro_counts_to_rad_s(a, s.gyro[a] as f64));
                push_measured(rate, [true; 3]);
                if let Some(next) = r.samples.get(k + 1) {
                    let dt = (next.time_ms - s.time_ms) as f64 * 1e-3;
                    let (_, tau) = sat.force_torque_for_word(s.thrusters);
                    w += j_inv * tau * dt;
                    for a in 0..3 {
                        lo_p[a] = lo_p[a].min(w[a]);
                        hi_p[a] = hi_p[a].max(w[a]);
                    }
                }
            }
            (&r.source, [true; 3])
        }
        Rec::V2(r) => {
            for k in 0..r.time_ms.len() {
                push_measured(r.rate[k], r.axes);
                if k + 1 < r.time_ms.len() {
                    let dt = (r.time_ms[k + 1] - r.time_ms[k]) as f64 * 1e-3;
                    let tau = match &r.commands {
                        Commands::Thrusters { words, .. } => sat.force_torque_for_word(words[k]).1,
                        Commands::Wrench { values, .. } => {
                            let v = values[k];
                            let c = |x: f64| if x.is_finite() { x } else { 0.0 };
                            nalgebra::Vector3::new(c(v[3]), c(v[4]), c(v[5]))
                        }
                    };
                    w += j_inv * tau * dt;
                    for a in 0..3 {
                        lo_p[a] = lo_p[a].min(w[a]);
                        hi_p[a] = hi_p[a].max(w[a]);
                    }
                }
            }
            (&r.source, r.axes)
        }
    };
    let turns: [bool; 3] = if sat.planar {
        [false, false, axes[2]]
    } else {
        axes
    };
    let swing_p: [f64; 3] = std::array::from_fn(|a| hi_p[a] - lo_p[a]);
    let swing_m: [f64; 3] = std::array::from_fn(|a| (hi_m[a] - lo_m[a]).max(0.0));
    let largest = (0..3)
        .filter(|&a| turns[a])
        .map(|a| swing_p[a])
        .fold(0.0, f64::max);
    if !(largest.is_finite() && largest > 0.0) {
        return Ok(());
    }
    let checked: Vec<usize> = (0..3)
        .filter(|&a| turns[a] && swing_p[a] >= 0.25 * largest)
        .collect();
    if checked
        .iter()
        .all(|&a| swing_m[a] < NO_RESPONSE_FRACTION * swing_p[a])
    {
        let names = ["x", "y", "z"];
        let detail: Vec<String> = checked
            .iter()
            .map(|&a| {
                format!(
                    "{} moves {:.3e} rad/s where the model's firings swing it {:.3e}",
                    names[a], swing_m[a], swing_p[a]
                )
            })
            .collect();
        bail!(
            "{source}: the rate sensor does not respond to the thrusters ({}; estimate calls this no_gyro_response): check the gyro (stuck at its bias?) or the thruster column",
            detail.join(", ")
        );
    }
    Ok(())
}
