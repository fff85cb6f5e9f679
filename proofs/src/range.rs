//! The range analysis: the kernel's own generic code run with [`Interval`] scalars over the
//! envelope, reporting each variable's worst-case range against the format's limit.
//!
//! * [`firing_terms`]: sound over the whole envelope. The model terms are built as
//!   intervals from the envelope boxes (thrust, directions, CoM offset, the inverse of every
//!   inertia in the box via the adjugate), then `ModelTerms::firing_terms` (kernel code) runs
//!   for **every** thruster word 0..4095. It has no data-dependent branch, so one interval run
//!   per word covers every parameter set in the envelope.
//! * [`pipeline_trajectory`]: the whole per-tick pipeline (`Pipeline::<Interval>::tick`) on
//!   one concrete gyro/thruster trajectory: the intervals enclose the format's rounding, and
//!   comparisons the intervals cannot decide are explored through the engine. Sound for that
//!   trajectory on the explored paths (not over all trajectories).
//!
//! Every run also reports the watch: the largest magnitude of *any* intermediate result,
//! divisions by intervals containing zero, undecided comparisons.

use crate::envelope as env;
use crate::interval::{self, Format, Interval, Watch};
use massid_kernel::model::{ModelTerms, SatelliteParams, N_THRUSTERS, SPH2};
use massid_kernel::Scalar;

/// One variable's worst-case range.
#[derive(Clone, Debug)]
pub struct VarRange {
    pub name: String,
    pub range: Interval,
}

/// The result of one analysis.
#[derive(Clone, Debug)]
pub struct RangeReport {
    pub what: String,
    pub format: Format,
    pub vars: Vec<VarRange>,
    pub watch: Watch,
}

impl RangeReport {
    /// Variables whose range reaches the format's limit.
    pub fn overflows(&self) -> Vec<&VarRange> {
        self.vars
            .iter()
            .filter(|v| v.range.mag() >= self.format.max)
            .collect()
    }
    /// True when every variable and every intermediate fits. (A division by an interval
    /// containing zero is not a failure: the kernel's `checked_div` then takes its `None`
    /// branch, a status; the table counts them.)
    pub fn fits(&self) -> bool {
        self.overflows().is_empty() && self.watch.max_abs < self.format.max
    }
    /// A plain-text table (one line per variable).
    pub fn table(&self) -> String {
        let mut s = format!(
            "{} in {} (limit +-{}): {}\n",
            self.what,
            self.format.name,
            self.format.max,
            if self.fits() { "FITS" } else { "DOES NOT FIT" }
        );
        for v in &self.vars {
            let ok = if v.range.mag() < self.format.max {
                "ok"
            } else {
                "OVERFLOW"
            };
            s += &format!(
                "  {:<40} [{:>12.6}, {:>12.6}]  {}\n",
                v.name,
                v.range.lo(),
                v.range.hi(),
                ok
            );
        }
        s += &format!(
            "  intermediates: max |x| = {:.6} over {} ops; divisions by 0-containing intervals (status branch): {}; undecided comparisons (explored by the engine): {}\n",
            self.watch.max_abs, self.watch.ops, self.watch.div_by_zero, self.watch.undecided
        );
        s
    }
}

fn iv(r: (f64, f64)) -> Interval {
    Interval::of(r)
}

/// The model terms over the whole envelope, as intervals, in the current [`interval::format`]
/// (each constant widened by the format's slack: the kernel rounds them into the format).
pub fn envelope_terms() -> ModelTerms<Interval> {
    let z = Interval::ZERO;
    // A model constant reaches the kernel as an f32 (`SatelliteParams` / `from_f32(v as f32)`,
    // relative rounding 2^-24) and is then rounded into the format (one operation's slack).
    let f32_ulp =
        Interval::new(1.0 - 1.0 / 16_777_216.0, 1.0 + 1.0 / 16_777_216.0).expect("ordered");
    let round = |x: Interval| x * f32_ulp + z;
    let com = [iv(env::COM_OFFSET_M); 3];
    let mut dir = [[z; 3]; N_THRUSTERS];
    let mut lxd = [[z; 3]; N_THRUSTERS];
    for i in 0..N_THRUSTERS {
        let nominal = SPH2.thrust_dir[i];
        let main = (0..3).fold(0, |m, k| {
            if nominal[k].abs() > nominal[m].abs() {
                k
            } else {
                m
            }
        });
        for k in 0..3 {
            dir[i][k] = if k == main {
                let m = iv(env::DIRECTION_MAIN);
                if nominal[k] < 0.0 {
                    -m
                } else {
                    m
                }
            } else {
                iv(env::DIRECTION_OFF_AXIS)
            };
        }
        let pos = SPH2.thruster_pos_m[i].map(|v| Interval::point(v as f64));
        let l = [pos[0] - com[0], pos[1] - com[1], pos[2] - com[2]];
        let d = dir[i];
        lxd[i] = [
            l[1] * d[2] - l[2] * d[1],
            l[2] * d[0] - l[0] * d[2],
            l[0] * d[1] - l[1] * d[0],
        ]
        .map(round);
        dir[i] = dir[i].map(round);
    }
    let inv = inertia_inverse_box();
    let hundredth = Interval::point(0.01);
    ModelTerms {
        dir,
        lever_x_dir: lxd,
        thrust_n: [round(iv(env::THRUST_N)); N_THRUSTERS],
        pressure_drop_n: round(iv(env::PRESSURE_DROP_N)),
        inertia_inv: inv.map(|r| r.map(round)),
        theta_inertia_nominal: [
            inv[0][0], inv[1][1], inv[2][2], inv[0][1], inv[0][2], inv[1][2],
        ]
        .map(|v| round(v * hundredth)),
        theta_inertia_matrix: inv.map(|r| r.map(|v| round(v * hundredth))),
    }
}

/// The inverse of every inertia matrix in the envelope box. Every matrix in the box is
/// symmetric with eigenvalues in `[a, b]` (Gershgorin: principal -+ two products), so its
/// inverse has eigenvalues in `[1/b, 1/a]`; hence each diagonal entry `e_i' J e_i` lies in
/// `[1/b, 1/a]` and each off-diagonal entry, `((e_i+e_j)' J (e_i+e_j) - (e_i-e_j)' J (e_i-e_j)) / 4`,
/// in `+-(1/a - 1/b) / 2`. (The naive interval adjugate over the box is ten times looser.)
pub fn inertia_inverse_box() -> [[Interval; 3]; 3] {
    let a = env::INERTIA_PRINCIPAL.0 - 2.0 * env::INERTIA_PRODUCT.1;
    let b = env::INERTIA_PRINCIPAL.1 + 2.0 * env::INERTIA_PRODUCT.1;
    let one = Interval::ONE;
    let (ia, ib) = (one / Interval::point(a), one / Interval::point(b));
    let diag = Interval::new(ib.lo(), ia.hi()).expect("ordered");
    let half = (ia - ib) * Interval::point(0.5);
    let off = Interval::new(-half.hi(), half.hi()).expect("ordered");
    [[diag, off, off], [off, diag, off], [off, off, diag]]
}

/// Runs `ModelTerms::firing_terms` for every thruster word over the envelope in `format`.
pub fn firing_terms(format: Format) -> RangeReport {
    interval::set_format(format);
    interval::reset_watch();
    let terms = envelope_terms();
    let mut hull: Option<Vec<Interval>> = None;
    for word in 0u16..=0x0fff {
        let ft = terms.firing_terms(word);
        let vals: Vec<Interval> = ft
            .force_n
            .iter()
            .chain(ft.torque_cnm.iter())
            .chain(ft.omega_dot_nominal.iter())
            .chain(ft.a_com.iter().flatten())
            .copied()
            .collect();
        hull = Some(match hull {
            None => vals,
            Some(h) => h.iter().zip(vals.iter()).map(|(a, b)| a.hull(*b)).collect(),
        });
    }
    let hull = hull.expect("4096 words");
    let mut names = Vec::new();
    for n in ["force_n", "torque_cnm", "omega_dot_nominal"] {
        for ax in ["x", "y", "z"] {
            names.push(format!("{n}.{ax}"));
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            names.push(format!("a_com[{i}][{j}]"));
        }
    }
    let inv = inertia_inverse_box();
    let mut vars: Vec<VarRange> = names
        .into_iter()
        .zip(hull)
        .map(|(name, range)| VarRange { name, range })
        .collect();
    for (k, (i, j)) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]
        .iter()
        .enumerate()
    {
        vars.push(VarRange {
            name: format!("inertia_inv[{k}]"),
            range: inv[*i][*j],
        });
    }
    let watch = interval::reset_watch();
    interval::set_format(Format::REAL);
    RangeReport {
        what: "firing_terms, every word 0..4095, whole envelope".into(),
        format,
        vars,
        watch,
    }
}

/// Runs the pipeline on one trajectory of `(gyro counts, thruster word)` with interval
/// scalars in `format`; must be called inside [`crate::engine::check`] (undecided
/// comparisons draw from it). Returns the report; the estimates' ranges are its variables.
pub fn pipeline_trajectory(
    format: Format,
    params: &SatelliteParams,
    samples: &[([u16; 3], u16)],
) -> RangeReport {
    use massid_kernel::{Pipeline, PipelineConfig};
    interval::set_format(format);
    interval::reset_watch();
    let mut vars: Vec<VarRange> = Vec::new();
    let mut pl =
        Pipeline::<Interval>::new(params, PipelineConfig::seed(1)).expect("valid parameters");
    let mut od_hull: Option<[Interval; 3]> = None;
    for (counts, word) in samples {
        pl.tick(*counts, *word);
        if let Some(e) = pl.omega_dot() {
            od_hull = Some(match od_hull {
                None => e.omega_dot,
                Some(h) => [0, 1, 2].map(|i| h[i].hull(e.omega_dot[i])),
            });
        }
    }
    pl.finish();
    let est = pl.estimates();
    for (i, v) in est.delta_com_m.iter().enumerate() {
        vars.push(VarRange {
            name: format!("delta_com_m[{i}]"),
            range: *v,
        });
    }
    for (i, v) in est.theta_inertia.iter().enumerate() {
        vars.push(VarRange {
            name: format!("theta_inertia[{i}]"),
            range: *v,
        });
    }
    if let Some(h) = od_hull {
        for (i, v) in h.iter().enumerate() {
            vars.push(VarRange {
                name: format!("omega_dot[{i}] (hull)"),
                range: *v,
            });
        }
    }
    let watch = interval::reset_watch();
    interval::set_format(Format::REAL);
    RangeReport {
        what: format!("pipeline, one trajectory of {} ticks", samples.len()),
        format,
        vars,
        watch,
    }
}
