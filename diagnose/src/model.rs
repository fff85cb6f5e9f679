//! The parametric forward model: nominal rigid-body rotation driven by the commanded
//! thrusters, with every mechanism of the effect vocabulary as an optional modification.
//! The diagnosis predicts the gyro output with it (output-error fitting), so it must be
//! fast (one 60 s run at 1 kHz in a few milliseconds) and smooth in every parameter
//! (valve latency enters through the fraction of each 1 ms step a valve is open).

use nalgebra::{Matrix3, Vector3};
use reference_f64::satellite::Satellite;

use crate::series::Series;

/// How many predictions ran in this process (for the benchmark and profiling).
pub static PREDICTIONS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Most thrusters a model may have (a thruster word is 16 bits); a model with fewer has
/// zero force on the rest, and the rest never fire (the reader checks the words).
pub const NT: usize = reference_f64::satellite::MAX_THRUSTERS;

/// Every parameter of the rigid-body and gyro model. `Default` is "no effect" (the
/// nominal model). Gyro ringing is not here: it is incoherent from edge to edge and is
/// fitted on the residual (`ringing.rs`).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub thrust_scale: [f64; NT],
    pub open_ms: f64,
    pub close_ms: f64,
    /// Extra thrust lost per other open thruster, N (on top of the satellite's own).
    pub pressure_drop: f64,
    /// (start_s, tau_s)
    pub blowdown: Option<(f64, f64)>,
    /// True CoM minus the model's, mm.
    pub com_offset_mm: [f64; 3],
    /// True inertia (replaces the model's), kg m^2, xx yy zz xy xz yz; a NaN entry keeps
    /// the model's (`effects::HELD`).
    pub inertia: Option<[f64; 6]>,
    /// (at_s, CoM offset from the model's in mm, inertia after the change)
    pub mass_change: Option<(f64, [f64; 3], [f64; 6])>,
    /// (freq_hz, damping_ratio, fluid inertia fraction per axis): a liquid may move about
    /// some axes only (a baffled or part-filled tank), so each axis has its own fraction.
    pub slosh: Option<(f64, f64, [f64; 3])>,
    /// True gyro bias minus the model's, counts.
    pub gyro_bias_counts: [f64; 3],
    pub gyro_scale: [f64; 3],
    pub disturbance_nm: [f64; 3],
    /// Rate damping per axis (air bearing, drag): a torque `-damping * omega`, N m s/rad.
    pub damping_nms: [f64; 3],
    /// First-order thrust rise and decay time constant at every valve edge, ms (0: the
    /// valve's force steps).
    pub rise_ms: f64,
    /// The recorded rate is the body rate this long ago, ms (`measurement_delay`): applied
    /// as a shift of every valve edge and of the body's own events (change time, blowdown
    /// clock), its exact equal on rates.
    pub delay_ms: f64,
    /// Tilt of each thruster's force, rad, about its two axes of [`Plant::tilt_axes`]
    /// (`thruster_misalignment`; the force keeps its magnitude).
    pub tilt: [[f64; 2]; NT],
    /// Body rate at the first sample, rad/s (a nuisance parameter, always fitted).
    pub omega0: [f64; 3],
    /// Rate jumps (rad/s) at the first sample after each telemetry gap: the commands
    /// during a gap are unknown, so the state is re-estimated there (nuisance, always
    /// fitted; one entry per [`Series::gap_resets`] time).
    pub resets: Vec<[f64; 3]>,
}

impl Params {
    /// Equal, counting a held inertia term (NaN, `effects::HELD`) equal to a held one: the
    /// key test of `fit::Problem`'s recent predictions, which `==` would never match once
    /// a term is held (NaN != NaN).
    pub fn same(&self, o: &Params) -> bool {
        let terms = |a: &[f64; 6], b: &[f64; 6]| {
            a.iter()
                .zip(b)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
        };
        let inertia = match (&self.inertia, &o.inertia) {
            (Some(a), Some(b)) => terms(a, b),
            (None, None) => true,
            _ => false,
        };
        // every other field by `==`, without copying `resets`; the exhaustive pattern makes
        // a new field a compile error here until it is compared
        let Params {
            thrust_scale,
            open_ms,
            close_ms,
            pressure_drop,
            blowdown,
            com_offset_mm,
            inertia: _,
            mass_change,
            slosh,
            gyro_bias_counts,
            gyro_scale,
            disturbance_nm,
            damping_nms,
            rise_ms,
            delay_ms,
            tilt,
            omega0,
            resets,
        } = self;
        inertia
            && *thrust_scale == o.thrust_scale
            && *open_ms == o.open_ms
            && *close_ms == o.close_ms
            && *pressure_drop == o.pressure_drop
            && *blowdown == o.blowdown
            && *com_offset_mm == o.com_offset_mm
            && *mass_change == o.mass_change
            && *slosh == o.slosh
            && *gyro_bias_counts == o.gyro_bias_counts
            && *gyro_scale == o.gyro_scale
            && *disturbance_nm == o.disturbance_nm
            && *damping_nms == o.damping_nms
            && *rise_ms == o.rise_ms
            && *delay_ms == o.delay_ms
            && *tilt == o.tilt
            && *omega0 == o.omega0
            && *resets == o.resets
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            thrust_scale: [1.0; NT],
            open_ms: 0.0,
            close_ms: 0.0,
            pressure_drop: 0.0,
            blowdown: None,
            com_offset_mm: [0.0; 3],
            inertia: None,
            mass_change: None,
            slosh: None,
            gyro_bias_counts: [0.0; 3],
            gyro_scale: [1.0; 3],
            disturbance_nm: [0.0; 3],
            damping_nms: [0.0; 3],
            rise_ms: 0.0,
            delay_ms: 0.0,
            tilt: [[0.0; 2]; NT],
            omega0: [0.0; 3],
            resets: Vec::new(),
        }
    }
}

/// The valves' mean force fractions on the 1 ms grid, stored as runs of equal rows: the
/// rows change only near the valve edges, so a grid costs memory and time in proportion to
/// the commands, not to the milliseconds of the flight.
pub struct Duty {
    /// Each run's first step and its row, ascending; the first run starts at step 0 and
    /// no two neighbours are equal.
    runs: Vec<(usize, [f32; NT])>,
    /// Steps on the grid; past the last one the last row holds.
    len: usize,
}

impl Duty {
    /// Memory the grid holds, bytes.
    pub fn bytes(&self) -> usize {
        self.runs.len() * std::mem::size_of::<(usize, [f32; NT])>()
    }

    /// Steps on the grid.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the grid has no step.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The row in force at step `k` (the last row past the grid's end).
    pub fn row(&self, k: usize) -> &[f32; NT] {
        let r = self.runs.partition_point(|&(start, _)| start <= k);
        &self.runs[r.max(1) - 1].1
    }

    /// Runs of equal rows from dense rows.
    fn from_rows(rows: &[[f32; NT]]) -> Duty {
        let mut runs: Vec<(usize, [f32; NT])> =
            vec![(0, rows.first().copied().unwrap_or([0.0; NT]))];
        for (k, row) in rows.iter().enumerate().skip(1) {
            if *row != runs[runs.len() - 1].1 {
                runs.push((k, *row));
            }
        }
        Duty {
            runs,
            len: rows.len(),
        }
    }
}

/// Each thruster's open intervals (ms on the model's grid, latencies applied, not yet
/// clipped), in time order.
fn open_intervals(series: &Series, open_ms: f64, close_ms: f64) -> Vec<Vec<(f64, f64)>> {
    let n = series.word_ms.len();
    let used = series.word_ms.iter().fold(0u16, |a, &w| a | w);
    let top = NT - used.leading_zeros() as usize;
    (0..top)
        .map(|th| {
            let bit = 1u16 << th;
            let mut out = vec![];
            let mut on_start: Option<f64> = None;
            let mut prev = false;
            for (k, &w) in series.word_ms.iter().enumerate() {
                let on = w & bit != 0;
                if on && !prev {
                    on_start = Some(k as f64 + open_ms);
                } else if !on && prev {
                    if let Some(s) = on_start.take() {
                        out.push((s, k as f64 + close_ms));
                    }
                }
                prev = on;
            }
            if let Some(s) = on_start {
                out.push((s, n as f64 + close_ms));
            }
            out
        })
        .collect()
}

/// The steps an interval covers on a grid of `n` steps, as pieces `(first, end, fraction)`
/// of equal fraction: the partial first step, the whole steps, the partial last step.
fn interval_pieces(n: usize, a: f64, b: f64) -> impl Iterator<Item = (usize, usize, f32)> {
    let a = a.max(0.0);
    let b = b.min(n as f64);
    let (ka, kb) = if b <= a {
        (0, 0)
    } else {
        (a.floor() as usize, (b.ceil() as usize).min(n))
    };
    let frac = move |k: usize| {
        let lo = (k as f64).max(a);
        let hi = ((k + 1) as f64).min(b);
        (hi > lo).then_some((hi - lo) as f32)
    };
    // (saturating: `then_some` evaluates its value even when the condition is false)
    let first = (kb > ka).then_some(ka);
    let last = (kb > ka + 1).then_some(kb.saturating_sub(1));
    let middle = (kb > ka + 2).then_some((ka + 1, kb.saturating_sub(1)));
    let piece = move |k: usize| frac(k).map(|f| (k, k + 1, f));
    first
        .and_then(piece)
        .into_iter()
        .chain(middle.and_then(|(s, e)| frac(s).map(|f| (s, e, f))))
        .chain(last.and_then(piece))
}

/// Per-step mean force fraction of every valve on a 1 ms grid, for given latencies and
/// thrust-rise time constant (0: the open fraction of each step). Without a rise the runs
/// are built from the valve edges alone; with one, from the dense lagged rows.
pub fn duty_grid(series: &Series, open_ms: f64, close_ms: f64, rise_ms: f64) -> Duty {
    if rise_ms > 0.0 {
        return Duty::from_rows(&dense_rows(series, open_ms, close_ms, rise_ms));
    }
    let n = series.word_ms.len();
    // every thruster's pieces, numbered in the order the dense rows add them, then sorted
    // by first step (intervals overlap when a latency is negative or a gap short)
    let pieces: Vec<Vec<(usize, usize, usize, f32)>> = open_intervals(series, open_ms, close_ms)
        .iter()
        .map(|iv| {
            let mut ps: Vec<(usize, usize, usize, f32)> = iv
                .iter()
                .flat_map(|&(a, b)| interval_pieces(n, a, b))
                .enumerate()
                .map(|(order, (s, e, f))| (s, order, e, f))
                .collect();
            ps.sort_unstable_by_key(|p| (p.0, p.1));
            ps
        })
        .collect();
    let mut cuts: Vec<usize> = pieces
        .iter()
        .flatten()
        .flat_map(|&(s, _, e, _)| [s, e])
        .filter(|&k| k < n)
        .collect();
    cuts.push(0);
    cuts.sort_unstable();
    cuts.dedup();
    // sweep the cuts; each thruster's covering pieces are summed in the dense rows' order
    let mut next = vec![0usize; pieces.len()];
    let mut active: Vec<Vec<(usize, usize, f32)>> = vec![vec![]; pieces.len()];
    let mut runs: Vec<(usize, [f32; NT])> = Vec::with_capacity(cuts.len());
    for &k in &cuts {
        let mut row = [0f32; NT];
        for (th, ps) in pieces.iter().enumerate() {
            let act = &mut active[th];
            while next[th] < ps.len() && ps[next[th]].0 <= k {
                let (_, order, e, f) = ps[next[th]];
                let at = act.partition_point(|a| a.0 < order);
                act.insert(at, (order, e, f));
                next[th] += 1;
            }
            act.retain(|&(_, e, _)| e > k);
            for &(_, _, f) in act.iter() {
                row[th] += f;
            }
        }
        if runs.last().is_none_or(|r| r.1 != row) {
            runs.push((k, row));
        }
    }
    Duty { runs, len: n }
}

/// The grid as one row per step (the definition the runs are checked against, and the
/// input of the thrust-rise lag).
fn dense_rows(series: &Series, open_ms: f64, close_ms: f64, rise_ms: f64) -> Vec<[f32; NT]> {
    let n = series.word_ms.len();
    let mut duty = vec![[0f32; NT]; n];
    let intervals = open_intervals(series, open_ms, close_ms);
    for (th, iv) in intervals.iter().enumerate() {
        for &(a, b) in iv {
            add_interval(&mut duty, th, a, b);
        }
    }
    if rise_ms > 0.0 {
        lag_in_place(&mut duty, intervals.len(), rise_ms);
    }
    duty
}

/// Passes each valve's open fraction through a first-order lag of `tau_ms`: with the input
/// held over a 1 ms step, the force starts at `x`, ends at `u + (x - u) e^(-1/tau)` and
/// averages `u + (x - u) tau (1 - e^(-1/tau))` over the step (exact for a held input).
fn lag_in_place(duty: &mut [[f32; NT]], top: usize, tau_ms: f64) {
    let decay = (-1.0 / tau_ms).exp();
    let mean = tau_ms * (1.0 - decay);
    for th in 0..top {
        let mut x = 0.0f64;
        for d in duty.iter_mut() {
            let u = d[th] as f64;
            d[th] = (u + (x - u) * mean) as f32;
            x = u + (x - u) * decay;
        }
    }
}

fn add_interval(duty: &mut [[f32; NT]], th: usize, a: f64, b: f64) {
    let n = duty.len() as f64;
    let a = a.max(0.0);
    let b = b.min(n);
    if b <= a {
        return;
    }
    let ka = a.floor() as usize;
    let kb = (b.ceil() as usize).min(duty.len());
    for k in ka..kb {
        let lo = (k as f64).max(a);
        let hi = ((k + 1) as f64).min(b);
        if hi > lo {
            duty[k][th] += (hi - lo) as f32;
        }
    }
}

/// The rigid-body part of the satellite the model needs, precomputed.
#[derive(Clone, Debug)]
pub struct Plant {
    pos: [Vector3<f64>; NT],
    force: [Vector3<f64>; NT],
    /// Each force's magnitude, N: the pressure drop's divisor, read at every change of
    /// duty, so taken once.
    thrust: [f64; NT],
    com: Vector3<f64>,
    inertia: [f64; 6],
    base_pressure_drop: f64,
    pub counts_per_rad_s: [f64; 3],
    /// A planar craft turns about z only (the bearing holds x and y).
    pub planar: bool,
    /// Thrusters the model has.
    pub n_thrusters: usize,
    /// Two unit axes perpendicular to each thruster's force along which it may tilt: the
    /// first moves the torque off its own direction, the second points the force at the
    /// nominal CoM's lever arm (a torque change only when the arm has a component along the
    /// force), so a fit can tell which of the two the data see.
    pub tilt_axes: [[Vector3<f64>; 2]; NT],
}

impl Plant {
    pub fn new(sat: &Satellite) -> Plant {
        let n = sat.n_thrusters();
        let com = sat.com_m();
        let tilt_axes = std::array::from_fn(|i| {
            if i >= n {
                return [Vector3::zeros(); 2];
            }
            let f = sat.force_n(i);
            let along = f.try_normalize(1e-12).unwrap_or_else(Vector3::x);
            let arm = sat.pos_m(i) - com;
            let perp = arm - along * arm.dot(&along);
            // any perpendicular when the arm lies along the force
            let second = perp.try_normalize(1e-9).unwrap_or_else(|| {
                let helper = if along.x.abs() < 0.9 {
                    Vector3::x()
                } else {
                    Vector3::y()
                };
                (helper - along * helper.dot(&along)).normalize()
            });
            [along.cross(&second), second]
        });
        let force: [Vector3<f64>; NT] = std::array::from_fn(|i| {
            if i < n {
                sat.force_n(i)
            } else {
                Vector3::zeros()
            }
        });
        Plant {
            tilt_axes,
            pos: std::array::from_fn(|i| {
                if i < n {
                    sat.pos_m(i)
                } else {
                    Vector3::zeros()
                }
            }),
            thrust: force.map(|f| f.norm()),
            force,
            com: sat.com_m(),
            inertia: sat.inertia_kgm2,
            base_pressure_drop: sat.pressure_drop_n_per_extra,
            counts_per_rad_s: sat.gyro_counts_per_rad_s,
            planar: sat.planar,
            n_thrusters: n,
        }
    }

    pub fn nominal_inertia(&self) -> [f64; 6] {
        self.inertia
    }

    /// The craft's size, m: the distance from the model's CoM to its farthest thruster.
    pub fn size_m(&self) -> f64 {
        self.pos[..self.n_thrusters.min(NT)]
            .iter()
            .map(|p| (p - self.com).norm())
            .fold(0.0, f64::max)
    }

    /// Nominal force magnitude of thruster i, N.
    pub fn thrust_n(&self, i: usize) -> f64 {
        self.thrust[i]
    }

    /// Adds to `tau` the torque of one duty row `d` (each thruster's mean open fraction
    /// over a step), N m: thruster i's `torque[i]` at unit scale times its duty, its
    /// `thrust_scale` less the pressure drop `pd` (N) per other open valve, and the
    /// blowdown's `scale_t`. The one home of the thrusters' torque on the 1 ms grid.
    pub fn add_row_torque(
        &self,
        tau: &mut Vector3<f64>,
        torque: &[Vector3<f64>; NT],
        d: &[f32; NT],
        thrust_scale: &[f64; NT],
        pd: f64,
        scale_t: f64,
    ) {
        let n_open: f64 = d.iter().map(|&x| x as f64).sum();
        if n_open > 0.0 {
            for i in 0..NT {
                let di = d[i] as f64;
                if di > 0.0 {
                    let f = thrust_scale[i] - pd * (n_open - di) / self.thrust_n(i);
                    *tau += torque[i] * (di * f.max(0.0) * scale_t);
                }
            }
        }
    }

    /// Each thruster's torque at unit scale about the model's CoM, with the model's own
    /// pressure drop per other open valve, N: what [`Plant::add_row_torque`] takes for the
    /// nominal model.
    pub fn nominal_torques(&self) -> ([Vector3<f64>; NT], f64) {
        (
            std::array::from_fn(|i| self.torque(i, &self.com)),
            self.base_pressure_drop,
        )
    }

    /// Torque of thruster i at unit scale about the model's CoM moved by `dcom_mm`, N m.
    pub fn torque_about(&self, i: usize, dcom_mm: &[f64; 3]) -> [f64; 3] {
        self.torque(i, &(self.com + Vector3::from(*dcom_mm) * 1e-3))
            .into()
    }

    /// Torque of thruster i tilted by `tilt` ([`Plant::tilted_force`]) about the model's CoM.
    pub fn tilted_torque(&self, i: usize, tilt: [f64; 2]) -> Vector3<f64> {
        (self.pos[i] - self.com).cross(&self.tilted_force(i, tilt))
    }

    /// Torque of thruster i at unit scale for a CoM `com`.
    fn torque(&self, i: usize, com: &Vector3<f64>) -> Vector3<f64> {
        (self.pos[i] - com).cross(&self.force[i])
    }

    /// Force of thruster i tilted by `tilt` (rad about [`Plant::tilt_axes`]), same magnitude.
    pub fn tilted_force(&self, i: usize, tilt: [f64; 2]) -> Vector3<f64> {
        if tilt == [0.0; 2] {
            return self.force[i];
        }
        let f = self.force[i];
        let [a, b] = self.tilt_axes[i];
        let d = f + (a * tilt[0] + b * tilt[1]) * f.norm();
        d.try_normalize(1e-300).map(|u| u * f.norm()).unwrap_or(f)
    }
}

/// The symmetric matrix of (xx, yy, zz, xy, xz, yz).
pub(crate) fn inertia_matrix(i: &[f64; 6]) -> Matrix3<f64> {
    Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2])
}

/// Mass properties in force over one stretch of time.
struct MassProps {
    inertia: Matrix3<f64>,
    inv_rigid: Matrix3<f64>,
    torque: [Vector3<f64>; NT],
    /// Liquid inertia J per axis and its spring and damper (zero without slosh).
    slosh_j: Vector3<f64>,
    slosh_k: Vector3<f64>,
    slosh_c: Vector3<f64>,
}

impl MassProps {
    /// Slosh coupling as the open data's generator has it (and `massid_sim`): per axis a
    /// liquid rotor J = fraction I_aa tied to the body by a spring and damper chosen from
    /// the reduced inertia J (I_aa - J) / I_aa, so that the two-body mode seen in the body
    /// rate has `freq_hz` and `damping_ratio`; the gyroscopic term carries the liquid's
    /// momentum too.
    fn new(
        plant: &Plant,
        p: &Params,
        inertia6: &[f64; 6],
        dcom_mm: &[f64; 3],
    ) -> Option<MassProps> {
        let inertia = inertia_matrix(inertia6);
        let com = plant.com + Vector3::from(*dcom_mm) * 1e-3;
        let torque =
            std::array::from_fn(|i| (plant.pos[i] - com).cross(&plant.tilted_force(i, p.tilt[i])));
        let mut slosh_j = Vector3::zeros();
        let mut slosh_k = Vector3::zeros();
        let mut slosh_c = Vector3::zeros();
        if let Some((f, zeta, frac)) = p.slosh {
            let wn = 2.0 * std::f64::consts::PI * f;
            for a in 0..3 {
                let iaa = inertia[(a, a)];
                let j = frac[a] * iaa;
                let mu = j * (iaa - j) / iaa;
                slosh_j[a] = j;
                slosh_k[a] = mu * wn * wn;
                slosh_c[a] = 2.0 * zeta * mu * wn;
            }
        }
        let rigid = inertia - Matrix3::from_diagonal(&slosh_j);
        let inv_rigid = rigid.try_inverse()?;
        Some(MassProps {
            inertia,
            inv_rigid,
            torque,
            slosh_j,
            slosh_k,
            slosh_c,
        })
    }
}

/// Predicted gyro output (rad/s, nominal conversion) at every sample of `series`.
/// `duty` must come from [`duty_grid`] with the same latencies as `p`.
/// Returns None for parameters that make no physical sense (singular inertia, NaN).
///
/// A planar craft without slosh or blowdown turns by a linear equation with a constant
/// torque over each run of equal duty, so its prediction jumps from run end to run end
/// with the closed form of the same 1 ms RK4 steps (equal to them within rounding): the
/// cost follows the commands and samples, not the milliseconds of the flight. A rigid 3-D
/// craft takes RK4 steps of up to `LONG_STEP_MS` (10 ms) where the torque holds (or decays
/// smoothly, a blowdown) between samples more than 1 ms apart (below 1 kHz, and across a
/// 1 kHz recording's gaps).
pub fn predict(plant: &Plant, series: &Series, duty: &Duty, p: &Params) -> Option<Vec<[f64; 3]>> {
    predict_with(plant, series, duty, p, true, 1, false).map(|(y, _)| y)
}

/// [`predict`] at samples `0, every, 2 every, ...` only, in that order (entry `k` is
/// sample `k every`; the rate resets between them still apply): what a fit that uses
/// every `every`-th sample needs, and no more (with `every` 1, every sample). A rigid 3-D
/// craft takes RK4 steps of up to `LONG_STEP_MS` wherever the torque holds (with a
/// blowdown, the torque at each stage's time, `blowdown_rk4`), across the samples it
/// needs too (those inside a step come from the cubic through the step's ends, `Span`): a
/// step ends where the duty or the mass properties change, where a blowdown starts or the
/// model's clock jumps, at a rate reset, at the last sample or after `LONG_STEP_MS`. So a
/// fit of a 1 kHz recording at a stride of 5 no longer pays for the four samples in five
/// it does not read.
pub fn predict_every(
    plant: &Plant,
    series: &Series,
    duty: &Duty,
    p: &Params,
    every: usize,
) -> Option<Vec<[f64; 3]>> {
    predict_with(plant, series, duty, p, true, every.max(1), false).map(|(y, _)| y)
}

/// The body's equations over one step (1 ms, or longer where it may): which of the three
/// the prediction integrates is chosen once per prediction, so each inner loop is one
/// straight-line RK4.
#[derive(Clone, Copy, PartialEq)]
enum Motion {
    /// Euler's equation with the gyroscopic term and the rate damping.
    Rigid,
    /// Yaw only (the bearing holds x and y).
    Planar,
    /// Rigid body plus a liquid rotor per axis.
    Slosh,
}

/// The rate derivative of the rigid body, Euler's equation.
#[inline(always)]
fn rigid_rate(
    props: &MassProps,
    tau_c: &Vector3<f64>,
    damping: &Vector3<f64>,
    w: &Vector3<f64>,
) -> Vector3<f64> {
    let tau = tau_c - damping.component_mul(w);
    props.inv_rigid * (tau - w.cross(&(props.inertia * w)))
}

/// One classic RK4 step of `h` s of `w' = f(w)`.
#[inline(always)]
fn rk4(w: &Vector3<f64>, h: f64, f: impl Fn(&Vector3<f64>) -> Vector3<f64>) -> Vector3<f64> {
    rk4_from(w, f(w), h, f)
}

/// One classic RK4 step of `h` s of the rigid body whose torque changes within the step
/// (a blowdown's decay): `taus` at the step's start, middle and end. Returns the rate at
/// the end and the derivative at the start.
#[inline(always)]
fn blowdown_rk4(
    props: &MassProps,
    taus: &[Vector3<f64>; 3],
    damping: &Vector3<f64>,
    w: &Vector3<f64>,
    h: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let k1 = rigid_rate(props, &taus[0], damping, w);
    let k2 = rigid_rate(props, &taus[1], damping, &(w + k1 * (h / 2.0)));
    let k3 = rigid_rate(props, &taus[1], damping, &(w + k2 * (h / 2.0)));
    let k4 = rigid_rate(props, &taus[2], damping, &(w + k3 * h));
    (w + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0), k1)
}

/// [`rk4`] given its first stage `k1 = f(w)`.
#[inline(always)]
fn rk4_from(
    w: &Vector3<f64>,
    k1: Vector3<f64>,
    h: f64,
    f: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Vector3<f64> {
    let k2 = f(&(w + k1 * (h / 2.0)));
    let k3 = f(&(w + k2 * (h / 2.0)));
    let k4 = f(&(w + k3 * h));
    w + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0)
}

/// The yaw acceleration of a planar craft.
#[inline(always)]
fn planar_rate(
    props: &MassProps,
    tau_c: &Vector3<f64>,
    damping: &Vector3<f64>,
    w: &Vector3<f64>,
) -> Vector3<f64> {
    let tz = tau_c.z - damping.z * w.z;
    Vector3::new(0.0, 0.0, tz / props.inertia[(2, 2)])
}

/// Rate, slosh angle and slosh rate derivatives of the body with its liquid rotors.
#[inline(always)]
fn slosh_rates(
    props: &MassProps,
    tau_c: &Vector3<f64>,
    w: &Vector3<f64>,
    q: &Vector3<f64>,
    qd: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let spring = props.slosh_k.component_mul(q) + props.slosh_c.component_mul(qd);
    let h = props.inertia * w + props.slosh_j.component_mul(qd);
    let wd = props.inv_rigid * (tau_c - w.cross(&h) + spring);
    let mut qdd = Vector3::zeros();
    for a in 0..3 {
        if props.slosh_j[a] > 0.0 {
            qdd[a] = -spring[a] / props.slosh_j[a] - wd[a];
        }
    }
    (wd, *qd, qdd)
}

/// The run step `k` is in, searching forward from run `r` (steps only move forward).
fn run_at(runs: &[(usize, [f32; NT])], mut r: usize, k: usize) -> usize {
    while runs.get(r + 1).is_some_and(|&(start, _)| start <= k) {
        r += 1;
    }
    r
}

/// `m` classic RK4 steps of `h` s of `y' = a - b y` from `y0` in closed form: each step
/// multiplies the distance to the rest point by `R(-b h)`, the RK4 amplification
/// `1 + z + z^2/2 + z^3/6 + z^4/24` (with `b = 0`, each step adds `a h`).
fn linear_rk4_steps(y0: f64, a: f64, b: f64, h: f64, m: usize) -> f64 {
    if b == 0.0 {
        return y0 + a * (h * m as f64);
    }
    let z = -b * h;
    let r_minus_1 = z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)));
    // 1 - R^m over b, without cancellation when b h is small
    let gain = -(m as f64 * r_minus_1.ln_1p()).exp_m1() / b;
    y0 + gain * (a - b * y0)
}

/// Longest RK4 step of a rigid 3-D craft, ms, where the torque holds (or a blowdown decays
/// it smoothly, `blowdown_rk4`) over it between two
/// samples (below 1 kHz, or across a gap) or across samples a strided fit does not stop at
/// ([`predict_every`]): RK4's error grows as the step's fourth power; at
/// 10 ms it stays near rounding (`long_steps_agree_with_millisecond_steps`: 30 s turning at
/// up to 1 rad/s; about 1e-12 with a mass change, delay and gaps besides).
const LONG_STEP_MS: usize = 10;

/// [`predict_with_integral`]'s gyro output integrated in time from the first sample to each
/// sample (rad, each step by its trapezoid: exact for the rate linear in a step, as it is
/// under a step's constant torque without gyroscopic coupling or damping, and within
/// h^3 |w''| / 12 a step with them, 3e-7 rad for a 10 ms step at 1 rad/s and 2 rad/s^2): what
/// a sensor that reports the mean rate over an interval ([`crate::response`]) reads.
pub fn predict_with_integral(
    plant: &Plant,
    series: &Series,
    duty: &Duty,
    p: &Params,
) -> Option<(Vec<[f64; 3]>, Vec<[f64; 3]>)> {
    predict_with(plant, series, duty, p, true, 1, true)
}

/// [`predict`], with the planar run jumps and the rigid long steps on or off (off: every
/// 1 ms step, the reference both are tested against), and with the integral of
/// [`predict_with_integral`] when `integrate` (at every sample only; else empty).
#[allow(clippy::too_many_arguments)]
fn predict_with(
    plant: &Plant,
    series: &Series,
    grid: &Duty,
    p: &Params,
    jumps: bool,
    every: usize,
    integrate: bool,
) -> Option<(Vec<[f64; 3]>, Vec<[f64; 3]>)> {
    if grid.is_empty() || (integrate && every != 1) {
        return None;
    }
    PREDICTIONS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let inertia0 = match p.inertia {
        Some(i) => std::array::from_fn(|k| {
            if i[k].is_nan() {
                plant.inertia[k]
            } else {
                i[k]
            }
        }),
        None => plant.inertia,
    };
    let props_a = MassProps::new(plant, p, &inertia0, &p.com_offset_mm)?;
    let props_b = match &p.mass_change {
        Some((_, off, inr)) => Some(MassProps::new(plant, p, inr, off)?),
        None => None,
    };
    // the change time and the blowdown's clock are the recording's; steps run on the model's.
    // A measurement delay shifts every input (`fit.rs` moves the valve edges), so the body's
    // own events move with them: step k is the body at recording time k - delay.
    let change_ms = p
        .mass_change
        .map(|m| series.model_ms(m.0 * 1e3) + p.delay_ms)
        .unwrap_or(f64::INFINITY);
    let motion = if p.slosh.is_some() {
        Motion::Slosh
    } else if plant.planar {
        Motion::Planar
    } else {
        Motion::Rigid
    };
    let jump = jumps && motion == Motion::Planar && p.blowdown.is_none();
    let long_steps = jumps && motion == Motion::Rigid;
    let dist = Vector3::from(p.disturbance_nm);
    let damping = Vector3::from(p.damping_nms);
    let pd = plant.base_pressure_drop + p.pressure_drop;
    // the change takes effect from the first step whose middle is at or after it
    let after_change = |k: usize| (k as f64) + 0.5 >= change_ms;
    let props_at = |k: usize| match &props_b {
        Some(b) if after_change(k) => b,
        _ => &props_a,
    };
    // torque of one duty row (the disturbance included) at blowdown scale `scale_t`
    let torque = |props: &MassProps, d: &[f32; NT], scale_t: f64| {
        let mut tau_c = dist;
        plant.add_row_torque(&mut tau_c, &props.torque, d, &p.thrust_scale, pd, scale_t);
        tau_c
    };

    // state: omega (3), slosh q (3), slosh qdot (3)
    let mut w = Vector3::from(p.omega0);
    let mut q = Vector3::zeros();
    let mut qd = Vector3::zeros();
    let n_ms = grid.len;
    let t0 = series.t_ms[0];
    let mut out = Vec::with_capacity(series.len().div_ceil(every));
    let mut si = 0usize;
    // Samples before the first sample time do not exist; the state starts at t0.
    let emit = |w: &Vector3<f64>, out: &mut Vec<[f64; 3]>| {
        let mut y = [0.0; 3];
        for a in 0..3 {
            y[a] = p.gyro_scale[a] * w[a] + p.gyro_bias_counts[a] / plant.counts_per_rad_s[a];
        }
        out.push(y);
    };
    // the body's rate integrated from t0 (when `integrate`), and per sample the gyro
    // output's integral (the bias integrated over the time since t0)
    let mut theta = Vector3::zeros();
    let mut integrals = Vec::with_capacity(if integrate { series.len() } else { 0 });
    let emit_integral = |theta: &Vector3<f64>, t_ms: i64, out: &mut Vec<[f64; 3]>| {
        let since_s = (t_ms - t0) as f64 * 1e-3;
        out.push(std::array::from_fn(|a| {
            p.gyro_scale[a] * theta[a] + p.gyro_bias_counts[a] / plant.counts_per_rad_s[a] * since_s
        }));
    };
    let h = 1e-3;
    let mut k = t0.max(0) as usize;
    // the torque of the step before (None until a step has been taken: a recording that
    // starts inside a firing must not start from the disturbance alone)
    let mut last_tau: Option<Vector3<f64>> = None;
    // the first step of the mass change
    let change_step = if change_ms.is_finite() {
        (change_ms - 0.5).ceil().max(0.0) as usize
    } else {
        usize::MAX
    };
    // the run of the duty grid step k is in
    let runs = &grid.runs;
    let mut r = runs.partition_point(|&(start, _)| start <= k).max(1) - 1;
    // with a blowdown the torque decays in time: a step takes it at its stages' times
    // ([`blowdown_rk4`]) and ends on both sides of where the decay starts and of where the
    // model's clock jumps (the decay's clock is the recording's), so the torque is smooth
    // within every step longer than 1 ms
    let blowdown_breaks: Vec<usize> = match p.blowdown {
        Some((start, _)) => {
            let mut at: Vec<f64> = series
                .clock_shifts
                .iter()
                .map(|&(from, _)| from as f64 + p.delay_ms)
                .collect();
            at.push(series.model_ms(start * 1e3) + p.delay_ms);
            let mut b: Vec<usize> = at
                .iter()
                .filter(|x| x.is_finite())
                .flat_map(|x| [x.floor().max(0.0) as usize, x.ceil().max(0.0) as usize])
                .collect();
            b.sort_unstable();
            b.dedup();
            b
        }
        None => vec![],
    };
    // the torque holds from step k (in run r) until `ts` (the next sample, or for a strided
    // fit the next step's end it must stop at), the next run, the mass change or a
    // blowdown's break, whichever comes first
    let held_until = |k: usize, r: usize, ts: usize| {
        let mut end = ts.min(runs.get(r + 1).map_or(usize::MAX, |&(start, _)| start));
        if k < change_step {
            end = end.min(change_step);
        }
        let next = blowdown_breaks.partition_point(|&b| b <= k);
        blowdown_breaks.get(next).map_or(end, |&b| end.min(b))
    };
    // the blowdown's thrust scale at the recording's time `real` ms (1 before it starts)
    let scale_at_real = |real: f64| match p.blowdown {
        Some((start, tau)) => {
            let t = real * 1e-3;
            if t > start {
                (-(t - start) / tau).exp()
            } else {
                1.0
            }
        }
        None => 1.0,
    };
    // ... and at the model's time `x` ms
    let blowdown_scale = |x: f64| scale_at_real(series.real_ms(x - p.delay_ms));
    // where a rigid long step may end past the samples a strided fit reads: the next
    // sample that must be a step's end (a rate reset), or the last one
    let last_ms = series.t_ms.last().map_or(0, |&t| t.max(0) as usize);
    let mut stop_ms = last_ms;
    // the last long step that ended past a sample to be read: its ends and rates there
    // (a cubic through them gives the samples inside)
    let mut spanned: Option<Span> = None;
    // the rate derivative at the last step's end when it was computed (for a span) and the
    // next step takes the same torque and mass properties: that step's first stage, not
    // evaluated again (the same inputs give the same value)
    let mut f_end: Option<Vector3<f64>> = None;
    while si < series.len() {
        if si % every != 0 && series.gap_resets.binary_search(&si).is_err() {
            si += 1;
            continue;
        }
        let ts = series.t_ms[si] as usize;
        if every > 1 && stop_ms < ts.max(k) || si == 0 {
            let next = series.gap_resets.partition_point(|&g| g < si);
            stop_ms = series
                .gap_resets
                .get(next)
                .map_or(last_ms, |&g| series.t_ms[g].max(0) as usize);
        }
        while jump && k < ts {
            // a run of equal duty rows from k, ending at the sample, a change of duty or
            // the mass change
            r = run_at(runs, r, k);
            let end = held_until(k, r, ts);
            let props = props_at(k);
            let tau_c = torque(props, &runs[r].1, 1.0);
            let izz = props.inertia[(2, 2)];
            let w_before = w;
            w.z = linear_rk4_steps(w.z, tau_c.z / izz, damping.z / izz, h, end - k);
            if integrate {
                theta += (w_before + w) * ((end - k) as f64 * 1e-3 * 0.5);
            }
            k = end;
        }
        while k < ts {
            // one step from k: 1 ms with the step's mean duty, or m ms (below) where it holds
            r = run_at(runs, r, k);
            let props = props_at(k);
            let d = &runs[r].1;
            let scale_t = blowdown_scale(k as f64 + 0.5);
            // the row is the one before unless a run starts here (runs differ from their
            // neighbours)
            let same = k > 0
                && k < n_ms
                && runs[r].0 != k
                && p.blowdown.is_none()
                && !((k as f64) - 0.5 < change_ms && (k as f64) + 0.5 >= change_ms);
            let tau_c = match last_tau {
                Some(tau) if same => tau,
                _ => torque(props, d, scale_t),
            };
            last_tau = Some(tau_c);
            let f_start = if same { f_end.take() } else { None };
            f_end = None;
            // steps taken at once: up to LONG_STEP_MS while the torque holds or decays
            // smoothly (between samples, changes of duty, the mass change and a
            // blowdown's breaks), else one (past the sample at ts when the fit does not
            // read the samples between)
            let m = if long_steps {
                let until = if every > 1 { stop_ms } else { ts };
                (held_until(k, r, until) - k).clamp(1, LONG_STEP_MS)
            } else {
                1
            };
            let w_before = w;
            match motion {
                Motion::Rigid => {
                    let h = m as f64 * 1e-3;
                    let w0 = w;
                    // the step, its start's derivative and the torque at its end
                    let (f0, tau_end) = if p.blowdown.is_some() {
                        // the stages' times on the recording's clock: from the step's
                        // start (after a jump at the start; so the end's is the left
                        // limit where the clock jumps at the end), or each read from the
                        // clock where it jumps strictly inside the step (a 1 ms step: the
                        // steps end on both sides of a jump)
                        let from = k as f64 - p.delay_ms;
                        let to = from + m as f64;
                        let jumps_inside = series
                            .clock_shifts
                            .iter()
                            .any(|&(at, _)| (at as f64) > from && (at as f64) < to);
                        let stage = |dt: f64| {
                            let real = if jumps_inside {
                                series.real_ms(from + dt)
                            } else {
                                series.real_ms(from) + dt
                            };
                            torque(props, d, scale_at_real(real))
                        };
                        let taus = [stage(0.0), stage(0.5 * m as f64), stage(m as f64)];
                        let f0;
                        (w, f0) = blowdown_rk4(props, &taus, &damping, &w, h);
                        (f0, taus[2])
                    } else {
                        let f = |w: &Vector3<f64>| rigid_rate(props, &tau_c, &damping, w);
                        let f0 = f_start.unwrap_or_else(|| f(&w));
                        w = rk4_from(&w, f0, h, f);
                        (f0, tau_c)
                    };
                    if k + m > ts {
                        let f1 = rigid_rate(props, &tau_end, &damping, &w);
                        if p.blowdown.is_none() {
                            f_end = Some(f1);
                        }
                        spanned = Some(Span {
                            from: k,
                            to: k + m,
                            w0,
                            f0,
                            w1: w,
                            f1,
                        });
                    }
                }
                Motion::Planar => {
                    w = rk4(&w, h, |w| planar_rate(props, &tau_c, &damping, w));
                }
                Motion::Slosh => {
                    let (k1w, k1q, k1d) = slosh_rates(props, &tau_c, &w, &q, &qd);
                    let (k2w, k2q, k2d) = slosh_rates(
                        props,
                        &tau_c,
                        &(w + k1w * (h / 2.0)),
                        &(q + k1q * (h / 2.0)),
                        &(qd + k1d * (h / 2.0)),
                    );
                    let (k3w, k3q, k3d) = slosh_rates(
                        props,
                        &tau_c,
                        &(w + k2w * (h / 2.0)),
                        &(q + k2q * (h / 2.0)),
                        &(qd + k2d * (h / 2.0)),
                    );
                    let (k4w, k4q, k4d) = slosh_rates(
                        props,
                        &tau_c,
                        &(w + k3w * h),
                        &(q + k3q * h),
                        &(qd + k3d * h),
                    );
                    w += (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
                    q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
                    qd += (k1d + k2d * 2.0 + k3d * 2.0 + k4d) * (h / 6.0);
                }
            }
            if integrate {
                theta += (w_before + w) * (m as f64 * 1e-3 * 0.5);
            }
            k += m;
        }
        if let Some(g) = series.gap_resets.iter().position(|&i| i == si) {
            if let Some(d) = p.resets.get(g) {
                w += Vector3::from(*d);
                f_end = None;
            }
        }
        // the sample inside the last long step, when it ended past it
        let at = match &spanned {
            Some(span) if k > ts => span.at(ts),
            _ => w,
        };
        // no craft turns at 1000 rad/s (squared: no square root per sample)
        if !(at[0].is_finite() && at[1].is_finite() && at[2].is_finite()) || at.norm_squared() > 1e6
        {
            return None;
        }
        if si % every == 0 {
            emit(&at, &mut out);
            if integrate {
                emit_integral(&theta, series.t_ms[si], &mut integrals);
            }
        }
        si += 1;
    }
    Some((out, integrals))
}

/// One RK4 step of a rigid craft, its ends' rates and derivatives: the cubic Hermite
/// through them gives the samples inside the step (a strided fit's samples between its
/// long steps' ends), with an error of the fourth order in the step, one below RK4's own
/// local error (2.3e-12 rad/s from 1 ms steps in `every_fifth_sample_agrees_with_every_sample`).
struct Span {
    from: usize,
    to: usize,
    w0: Vector3<f64>,
    f0: Vector3<f64>,
    w1: Vector3<f64>,
    f1: Vector3<f64>,
}

impl Span {
    /// The rate at step `k` (ms) of the span.
    fn at(&self, k: usize) -> Vector3<f64> {
        let len = (self.to - self.from) as f64;
        let t = (k - self.from) as f64 / len;
        let h = len * 1e-3;
        let (t2, t3) = (t * t, t * t * t);
        self.w0 * (2.0 * t3 - 3.0 * t2 + 1.0)
            + self.f0 * (h * (t3 - 2.0 * t2 + t))
            + self.w1 * (3.0 * t2 - 2.0 * t3)
            + self.f1 * (h * (t3 - t2))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A small reproducible generator for test flights: `rnd(m)` is in `0..m`.
    pub(crate) fn lcg(seed: u64) -> impl FnMut(u64) -> u64 {
        let mut state = seed;
        move |m| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) % m
        }
    }

    /// A model with held products is the same model as itself (the prediction cache
    /// answers the repeat), and not the same as one with those products fitted at 0 or
    /// with another moment. Planted: `==` never matches a held term, so the first fails.
    #[test]
    fn held_terms_are_the_same_as_held_terms_and_only_those() {
        let held = Params {
            inertia: Some([0.02, 0.03, 0.04, f64::NAN, f64::NAN, f64::NAN]),
            ..Params::default()
        };
        assert!(held.same(&held.clone()));
        let fitted = Params {
            inertia: Some([0.02, 0.03, 0.04, 0.0, 0.0, 0.0]),
            ..Params::default()
        };
        assert!(!held.same(&fitted) && !fitted.same(&held));
        let other = Params {
            inertia: Some([0.02, 0.03, 0.05, f64::NAN, f64::NAN, f64::NAN]),
            ..Params::default()
        };
        assert!(!held.same(&other));
        let shifted = Params {
            open_ms: 1.0,
            ..held.clone()
        };
        assert!(!held.same(&shifted) && !held.same(&Params::default()));
    }

    /// A 1 kHz recording of `words` (one per ms) with the gyro at its bias: what a model
    /// test predicts from.
    pub(crate) fn commanded(sat: &Satellite, words: &[u16]) -> Series {
        let t: Vec<i64> = (0..words.len() as i64).collect();
        let counts = vec![[2048, 2048, 2048]; words.len()];
        Series::from_counts(
            &t,
            &counts,
            words,
            sat.gyro_bias_counts,
            sat.gyro_counts_per_rad_s,
            Some(1000.0),
        )
        .unwrap()
    }

    /// With every valve shut the body spins freely: angular momentum magnitude |I w| and
    /// kinetic energy w.I.w / 2 are conserved (Euler's equations), whatever the inertia.
    #[test]
    fn torque_free_spin_conserves_momentum_and_energy() {
        let sat = Satellite::builtin("sph3").unwrap();
        let plant = Plant::new(&sat);
        let n = 20_000;
        let series = commanded(&sat, &vec![0u16; n as usize]);
        let duty = duty_grid(&series, 0.0, 0.0, 0.0);
        let p = Params {
            omega0: [0.6, -0.3, 0.9],
            ..Params::default()
        };
        let y = predict(&plant, &series, &duty, &p).unwrap();
        let i = inertia_matrix(&sat.inertia_kgm2);
        let h = |w: &[f64; 3]| (i * Vector3::from(*w)).norm();
        let e = |w: &[f64; 3]| Vector3::from(*w).dot(&(i * Vector3::from(*w)));
        let (h0, e0) = (h(&y[0]), e(&y[0]));
        for w in &y {
            assert!((h(w) - h0).abs() < 1e-9 * h0, "momentum drifted");
            assert!((e(w) - e0).abs() < 1e-9 * e0, "energy drifted");
        }
        // and the spin is not trivially constant (products of inertia couple the axes)
        assert!((y[n as usize - 1][0] - y[0][0]).abs() > 1e-3);
    }

    /// A planar craft's prediction jumps over runs of equal duty in closed form; it must
    /// equal the 1 ms RK4 steps it replaces (damping, latencies, a
    /// mass-property change inside a run, a pressure drop, rate resets), within rounding.
    #[test]
    fn planar_run_jumps_equal_the_millisecond_steps() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../examples/models/airbearing-mpc.toml"
        );
        let sat = Satellite::from_toml_file(std::path::Path::new(path)).unwrap();
        assert!(sat.planar);
        let plant = Plant::new(&sat);
        // 20 Hz samples (the real flight's kind) over 30 s; a few thrusters pulse with
        // different periods, so runs of all lengths occur
        let t: Vec<i64> = (0..600).map(|i| i * 50).collect();
        let words: Vec<u16> = t
            .iter()
            .map(|&k| {
                let mut w = 0u16;
                if k % 700 < 230 {
                    w |= 1;
                }
                if k % 1100 > 800 {
                    w |= 1 << 3;
                }
                if k % 2500 < 90 {
                    w |= 1 << 5;
                }
                w
            })
            .collect();
        let counts = vec![[2048, 2048, 2048]; t.len()];
        let bias = sat.gyro_bias_counts;
        let scale = sat.gyro_counts_per_rad_s;
        let mut series = Series::from_counts(&t, &counts, &words, bias, scale, None).unwrap();
        series.gap_resets = vec![100, 333];
        let duty = duty_grid(&series, 3.0, 5.0, 0.0);
        let mut inertia = sat.inertia_kgm2;
        inertia[2] *= 1.2;
        let p = Params {
            omega0: [0.0, 0.0, 0.05],
            damping_nms: [0.0, 0.0, 0.02],
            pressure_drop: 0.01,
            mass_change: Some((12.3456, [4.0, -3.0, 0.0], inertia)),
            resets: vec![[0.0, 0.0, -0.01], [0.0, 0.0, 0.02]],
            ..Params::default()
        };
        let jumped = rates(&plant, &series, &duty, &p, true);
        let stepped = rates(&plant, &series, &duty, &p, false);
        let worst = jumped
            .iter()
            .zip(&stepped)
            .map(|(a, b)| (a[2] - b[2]).abs())
            .fold(0.0, f64::max);
        let scale = stepped.iter().map(|y| y[2].abs()).fold(0.0, f64::max);
        assert!(scale > 0.05, "the test flight must turn");
        assert!(
            worst <= 1e-12 * scale,
            "jumps differ from steps by {worst:e}"
        );
        // the comparison's power: a change 1 ms later (less than a run that ran over the
        // change would make) is caught by it many times over
        let mut later = p.clone();
        later.mass_change = Some((12.3466, [4.0, -3.0, 0.0], inertia));
        let moved = rates(&plant, &series, &duty, &later, false);
        let shift = moved
            .iter()
            .zip(&stepped)
            .map(|(a, b)| (a[2] - b[2]).abs())
            .fold(0.0, f64::max);
        assert!(
            shift > 1e3 * 1e-12 * scale,
            "a 1 ms change shift moves the rates by {shift:e}"
        );
    }

    /// The duty grid's runs, built from the valve edges alone, hold the same rows as the
    /// dense per-step definition, bit for bit: latencies that leave partial steps, a close
    /// latency shorter than the open one (short pulses vanish: empty intervals), a negative
    /// open latency (an interval starting before the step 0, and intervals overlapping
    /// across 1-2 ms gaps, which add), intervals cut by the grid's ends. A run dropped (a
    /// planted fault) is caught.
    #[test]
    fn duty_runs_equal_the_dense_rows() {
        let sat = Satellite::builtin("sph2").unwrap();
        let n = 5_000usize;
        // a pseudo-random pulse train per thruster, pulses and gaps 1-40 ms
        let mut rnd = lcg(12345);
        let mut words = vec![0u16; n];
        for th in 0..12 {
            let mut k = rnd(50) as usize;
            while k < n {
                let on = 1 + rnd(40) as usize;
                for w in words.iter_mut().skip(k).take(on) {
                    *w |= 1 << th;
                }
                k += on + 1 + rnd(40) as usize;
            }
        }
        let series = commanded(&sat, &words);
        for (open, close) in [
            (0.0, 0.0),
            (0.25, 0.5),
            (3.7, 1.2),
            (17.3, 2.9),
            (-2.5, 0.0),
        ] {
            let grid = duty_grid(&series, open, close, 0.0);
            let dense = dense_rows(&series, open, close, 0.0);
            assert_eq!(grid.len(), dense.len());
            for (k, row) in dense.iter().enumerate() {
                assert_eq!(grid.row(k), row, "step {k} at latencies {open} {close}");
            }
            assert!(grid.runs.len() > 100);
            // a planted fault: one run fewer
            let mut dropped = duty_grid(&series, open, close, 0.0);
            dropped.runs.remove(dropped.runs.len() / 2);
            assert!((0..n).any(|k| dropped.row(k) != &dense[k]));
        }
    }

    /// SPHERES sampled at 100 Hz for 30 s, a random word at each sample (about a quarter of
    /// the thrusters open): a flight that turns at up to about 1 rad/s.
    fn pulses_at_100_hz(seed: u64) -> (Plant, Series) {
        let sat = Satellite::builtin("sph2").unwrap();
        let mut rnd = lcg(seed);
        let t: Vec<i64> = (0..3000).map(|i| i * 10).collect();
        let words: Vec<u16> = t.iter().map(|_| (rnd(4096) & rnd(4096)) as u16).collect();
        let counts = vec![[2048, 2048, 2048]; t.len()];
        let bias = sat.gyro_bias_counts;
        let scale = sat.gyro_counts_per_rad_s;
        let series = Series::from_counts(&t, &counts, &words, bias, scale, None).unwrap();
        (Plant::new(&sat), series)
    }

    /// The rates at every sample, with the long steps and run jumps on or off.
    fn rates(
        plant: &Plant,
        series: &Series,
        duty: &Duty,
        p: &Params,
        jumps: bool,
    ) -> Vec<[f64; 3]> {
        predict_with(plant, series, duty, p, jumps, 1, false)
            .unwrap()
            .0
    }

    /// [`pulses_at_100_hz`] with latencies and a craft turning at up to about 1 rad/s, damped.
    fn tumbling_at_100_hz(seed: u64) -> (Plant, Series, Duty, Params) {
        let (plant, series) = pulses_at_100_hz(seed);
        let duty = duty_grid(&series, 3.3, 5.1, 0.0);
        let p = Params {
            omega0: [0.5, -0.4, 0.8],
            damping_nms: [1e-4, 0.0, 2e-4],
            ..Params::default()
        };
        (plant, series, duty, p)
    }

    /// The time integral a mean-rate sensor reads ([`predict_with_integral`]): over each
    /// sample's period, the rigid long steps' (a trapezoid per step of up to 10 ms) is the 1 ms
    /// steps' within 1e-7 rad (measured 1.1e-8: 1e-6 rad/s as a mean over 10 ms), with the
    /// gyroscopic term, damping and a gyro bias. Planted: the trapezoid of the rates at the
    /// samples alone, blind to the pulses' edges between them, is off by more than 1e-6 rad.
    #[test]
    fn the_integral_of_long_steps_is_that_of_millisecond_steps() {
        let (plant, series, duty, mut p) = tumbling_at_100_hz(778);
        p.gyro_bias_counts = [5.0, 0.0, -3.0];
        let (y, long) = predict_with(&plant, &series, &duty, &p, true, 1, true).unwrap();
        let (_, short) = predict_with(&plant, &series, &duty, &p, false, 1, true).unwrap();
        assert_eq!((long.len(), short.len()), (series.len(), series.len()));
        assert_eq!(long[0], [0.0; 3]);
        // over each sample's period (what a mean reads), in rad
        let increment = |v: &[[f64; 3]], k: usize, i: usize| v[k][i] - v[k - 1][i];
        let worst = (1..series.len())
            .flat_map(|k| (0..3).map(move |i| (k, i)))
            .map(|(k, i)| (increment(&long, k, i) - increment(&short, k, i)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-7, "{worst}");
        // the trapezoid of the samples' rates misses the pulses' edges between them
        let mut off = 0.0f64;
        for k in 1..y.len() {
            let h = (series.t_ms[k] - series.t_ms[k - 1]) as f64 * 1e-3;
            for i in 0..3 {
                let trapezoid = 0.5 * h * (y[k - 1][i] + y[k][i]);
                off = off.max((trapezoid - increment(&short, k, i)).abs());
            }
        }
        assert!(off > 1e-6, "{off} {worst}");
    }

    /// A rigid 3-D craft sampled at 100 Hz takes RK4 steps of up to 10 ms where the torque
    /// holds; over 30 s of pulses, turning at up to about 1 rad/s with the gyroscopic term,
    /// the rates stay within 1e-11 rad/s of the 1 ms steps' (measured: 2.9e-14). The
    /// comparison's power: a thrust 1e-8 higher (far below what a fit can see) moves the
    /// rates by more than the bound (6e-9).
    #[test]
    fn long_steps_agree_with_millisecond_steps() {
        let (plant, series, duty, p) = tumbling_at_100_hz(777);
        let long = rates(&plant, &series, &duty, &p, true);
        let short = rates(&plant, &series, &duty, &p, false);
        let gap = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            a.iter()
                .zip(b)
                .flat_map(|(x, y)| (0..3).map(move |i| (x[i] - y[i]).abs()))
                .fold(0.0, f64::max)
        };
        let peak = short.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(peak > 0.5, "the test flight must turn fast ({peak})");
        let err = gap(&long, &short);
        assert!(err < 1e-11, "long steps differ by {err:e}");
        let mut stronger = p.clone();
        stronger.thrust_scale = [1.0 + 1e-8; NT];
        let moved = rates(&plant, &series, &duty, &stronger, false);
        assert!(gap(&moved, &short) > 1e-11);
    }

    /// With a blowdown the torque decays in time: steps take it at each RK4 stage's time,
    /// and end on both sides of where the decay starts and where the model's clock jumps.
    /// Over 30 s of pulses at 100 Hz (the decay starting at 7.5034 s with a 20 s constant,
    /// the clock 3 ms ahead from 12 s, a 0.4 ms delay) long steps stay within 1e-12 rad/s
    /// of 1 ms steps (measured: 2.3e-14). Power: the decay's constant 1e-6 longer moves the
    /// rates past the bound. Planted: steps not ended at the decay's start and the clock's
    /// jump, 8.3e-8; the torque of a step's start for all four stages, 2.1e-5.
    #[test]
    fn blowdown_long_steps_agree_with_millisecond_steps() {
        let (plant, mut series) = pulses_at_100_hz(4242);
        series.clock_shifts = vec![(12_000, 3)];
        let duty = duty_grid(&series, 3.3, 5.1, 0.0);
        let p = Params {
            omega0: [0.5, -0.4, 0.8],
            blowdown: Some((7.5034, 20.0)),
            delay_ms: 0.4,
            ..Params::default()
        };
        let gap = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            a.iter()
                .zip(b)
                .flat_map(|(x, y)| (0..3).map(move |i| (x[i] - y[i]).abs()))
                .fold(0.0, f64::max)
        };
        let long = rates(&plant, &series, &duty, &p, true);
        let short = rates(&plant, &series, &duty, &p, false);
        let peak = short.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(peak > 0.5, "the test flight must turn fast ({peak})");
        let err = gap(&long, &short);
        assert!(err < 1e-12, "long steps with a blowdown differ by {err:e}");
        let mut slower = p.clone();
        slower.blowdown = Some((7.5034, 20.0 * (1.0 + 1e-6)));
        let moved = rates(&plant, &series, &duty, &slower, false);
        assert!(gap(&moved, &short) > 1e-12);
        // A step that ends where the clock jumps takes the torque from before the jump
        // there: with no delay the jump at 12 s falls on a step's end, and up to that
        // sample the rates are those of the same flight without the jump, bit for bit
        // (planted: the end's torque read after a 2 s jump, 2.6e-5 by that sample).
        let mut no_delay = p.clone();
        no_delay.delay_ms = 0.0;
        let mut jumped = series.clone();
        jumped.clock_shifts = vec![(12_000, 2_000)];
        let mut plain = series.clone();
        plain.clock_shifts = vec![];
        for long_steps in [true, false] {
            let a = rates(&plant, &jumped, &duty, &no_delay, long_steps);
            let b = rates(&plant, &plain, &duty, &no_delay, long_steps);
            let upto = series.t_ms.iter().take_while(|&&t| t <= 12_000).count();
            assert_eq!(
                a[..upto],
                b[..upto],
                "before the jump (long steps {long_steps})"
            );
            assert!(gap(&a[upto..], &b[upto..]) > 1e-3, "the jump acts after it");
        }
    }

    /// A fit at a stride of 5 on a 1 kHz recording reads every fifth sample: predicted at
    /// those alone (steps of up to 10 ms where the torque holds, the samples inside a step
    /// from the cubic through its ends), they agree with the every-sample prediction within
    /// 1e-11 rad/s (measured: 2.3e-12); the samples not read are not in the prediction, and
    /// a rate reset on a sample off the stride still acts. Power: a thrust 1e-8
    /// higher moves the rates past the bound. Planted: the state at the step's end given
    /// for the samples inside it (1.1e-2).
    #[test]
    fn every_fifth_sample_agrees_with_every_sample() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let mut rnd = lcg(4242);
        // 1 kHz, the word held for 20-60 ms at a time (pulses and coasts)
        let t: Vec<i64> = (0..20_000).collect();
        let mut words = Vec::with_capacity(t.len());
        while words.len() < t.len() {
            let w = (rnd(4096) & rnd(4096) & rnd(4096)) as u16;
            let hold = 20 + rnd(40) as usize;
            words.extend(std::iter::repeat_n(w, hold));
        }
        words.truncate(t.len());
        let counts = vec![[2048, 2048, 2048]; t.len()];
        let bias = sat.gyro_bias_counts;
        let scale = sat.gyro_counts_per_rad_s;
        let mut series = Series::from_counts(&t, &counts, &words, bias, scale, None).unwrap();
        // a reset on a sample the stride does not read
        series.gap_resets = vec![7_003];
        let duty = duty_grid(&series, 3.3, 5.1, 0.0);
        let p = Params {
            omega0: [0.5, -0.4, 0.8],
            damping_nms: [1e-4, 0.0, 2e-4],
            resets: vec![[0.01, -0.02, 0.03]],
            ..Params::default()
        };
        let every = predict(&plant, &series, &duty, &p).unwrap();
        let fifth = predict_every(&plant, &series, &duty, &p, 5).unwrap();
        // entry k is sample 5 k, and only those (the last one too when the length is not a
        // multiple of the stride)
        assert_eq!(fifth.len(), every.len().div_ceil(5));
        let seventh = predict_every(&plant, &series, &duty, &p, 7).unwrap();
        assert_eq!(seventh.len(), every.len().div_ceil(7));
        assert_ne!(every.len() % 7, 0);
        let mut err: f64 = 0.0;
        for (a, b) in every.iter().step_by(5).zip(&fifth) {
            for k in 0..3 {
                assert!(b[k].is_finite(), "a sample read but not predicted");
                err = err.max((a[k] - b[k]).abs());
            }
        }
        let peak = every.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(peak > 0.5, "the test flight must turn fast ({peak})");
        assert!(err < 1e-11, "every fifth sample differs by {err:e}");
        // a blowdown's steps (the torque at each stage's time) and a mass change read at a
        // stride too (measured: 2.0e-12; planted, the cubic's end derivative with the step
        // start's torque: 7.4e-7)
        let changing = Params {
            blowdown: Some((7.5034, 20.0)),
            mass_change: Some((12.3456, [4.0, -3.0, 0.0], plant.inertia)),
            ..p.clone()
        };
        let every_c = predict(&plant, &series, &duty, &changing).unwrap();
        let fifth_c = predict_every(&plant, &series, &duty, &changing, 5).unwrap();
        let err_c = every_c
            .iter()
            .step_by(5)
            .zip(&fifth_c)
            .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
            .fold(0.0, f64::max);
        assert!(
            err_c < 1e-11,
            "with a blowdown and a mass change: {err_c:e}"
        );
        assert!(
            every_c.iter().zip(&every).any(|(a, b)| a != b),
            "the changes act"
        );
        let mut stronger = p.clone();
        stronger.thrust_scale = [1.0 + 1e-8; NT];
        let moved = predict_every(&plant, &series, &duty, &stronger, 5).unwrap();
        let moved_by = moved
            .iter()
            .zip(&fifth)
            .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
            .fold(0.0, f64::max);
        assert!(moved_by > 1e-11, "{moved_by:e}");
        // without the reset the samples after it differ: the reset off the stride acted
        let mut no_reset = p.clone();
        no_reset.resets = vec![[0.0; 3]];
        let without = predict_every(&plant, &series, &duty, &no_reset, 5).unwrap();
        assert!((without[7_005 / 5][2] - fifth[7_005 / 5][2]).abs() > 0.02);
    }

    /// A recording whose first step comes inside a firing (here through a negative open
    /// latency: the valve's interval starts before the first sample) feels that firing from
    /// its first step, as a recording that starts earlier does. (Before 2026-11-27 the
    /// first step took the torque of "the step before", which it had not computed: the
    /// disturbance alone, so the firing was lost until the next change of duty and this
    /// fails.)
    #[test]
    fn a_recording_that_starts_inside_a_firing_feels_it() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        // the rate at `ms` of a recording from `t0` that starts at `omega0`
        let run = |t0: i64, omega0: [f64; 3], ms: i64| {
            let t: Vec<i64> = (t0..1000).collect();
            let words: Vec<u16> = t
                .iter()
                .map(|&k| u16::from((400..700).contains(&k)))
                .collect();
            let counts = vec![[2048, 2048, 2048]; t.len()];
            let series = Series::from_counts(
                &t,
                &counts,
                &words,
                sat.gyro_bias_counts,
                sat.gyro_counts_per_rad_s,
                Some(1000.0),
            )
            .unwrap();
            let duty = duty_grid(&series, -150.0, 0.0, 0.0);
            let p = Params {
                omega0,
                open_ms: -150.0,
                ..Params::default()
            };
            predict(&plant, &series, &duty, &p).unwrap()[(ms - t0) as usize]
        };
        // the same body at 500 ms, once from 0 ms and once from a recording starting there
        let at_500 = run(0, [0.0; 3], 500);
        let (early, late) = (run(0, [0.0; 3], 900), run(500, at_500, 900));
        let turn = (0..3)
            .map(|a| (early[a] - at_500[a]).abs())
            .fold(0.0, f64::max);
        assert!(turn > 1e-3, "the firing must turn the craft");
        for a in 0..3 {
            assert!(
                (late[a] - early[a]).abs() < 1e-9 * turn,
                "axis {a}: {late:?} vs {early:?}"
            );
        }
    }

    /// A valve open for exactly one 1 ms step with latency l (0 < l < 1) contributes
    /// (1 - l) of the step: latency enters smoothly.
    #[test]
    fn duty_is_the_open_fraction_of_each_step() {
        let sat = Satellite::builtin("sph2").unwrap();
        let t: Vec<i64> = (0..10).collect();
        let counts = vec![[2048, 2048, 2048]; 10];
        let mut words = vec![0u16; 10];
        words[3] = 1;
        words[4] = 1;
        let series = Series::from_counts(
            &t,
            &counts,
            &words,
            sat.gyro_bias_counts,
            sat.gyro_counts_per_rad_s,
            None,
        )
        .unwrap();
        let d = duty_grid(&series, 0.25, 0.5, 0.0);
        let on: Vec<f32> = (0..10).map(|k| d.row(k)[0]).collect();
        assert_eq!(on, vec![0.0, 0.0, 0.0, 0.75, 1.0, 0.5, 0.0, 0.0, 0.0, 0.0]);
    }

    /// A measurement delay shifts everything the body does, its own events included: with
    /// a mass-property change and a blowdown, the delayed prediction is the undelayed one
    /// later by the delay. (With the events left on the recording's clock, as before
    /// 2026-11-27, the two differ from the change on and this fails.)
    #[test]
    fn a_measurement_delay_shifts_the_bodys_own_events_too() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let n = 4000usize;
        // two thrusters pulse 100 ms in every 400 ms
        let words: Vec<u16> = (0..n)
            .map(|k| if k % 400 < 100 { 0b1001 } else { 0 })
            .collect();
        let series = commanded(&sat, &words);
        let noise = crate::noise::NoiseModel::white([1e-6; 3]);
        let prob = crate::fit::Problem::new(&plant, &series, &noise);
        let mut after = sat.inertia_kgm2;
        after[2] *= 1.3;
        let base = Params {
            mass_change: Some((1.5, [2.0, 0.0, 0.0], after)),
            blowdown: Some((2.2, 3.0)),
            ..Params::default()
        };
        let d = 40;
        let y0 = prob.predict(&base).unwrap();
        let y1 = prob
            .predict(&Params {
                delay_ms: d as f64,
                ..base.clone()
            })
            .unwrap();
        let worst = (d..n)
            .map(|i| {
                (0..3)
                    .map(|a| (y1[i][a] - y0[i - d][a]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        let scale = y0.iter().map(|y| y[2].abs()).fold(0.0, f64::max);
        assert!(scale > 1e-3, "the pulses must turn the body");
        assert!(
            worst <= 1e-9 * scale,
            "delayed != shifted: {worst:e} of {scale:e}"
        );
    }
}
