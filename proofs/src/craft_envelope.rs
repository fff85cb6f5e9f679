//! One craft's envelope, derived from its model, and whether the kernel's fixed-point format
//! holds the craft's wrench table and the mixer's commands (issue 23 item 3).
//!
//! [`crate::envelope`] is SPHERES' envelope, written down once from the seed. Any other craft
//! gets its own from its model file: each thruster's thrust widened by the larger of 4 sigma
//! of its stated uncertainty and [`THRUST_MARGIN`]; the CoM anywhere in the box that holds
//! the thrusters and the model's CoM, widened by [`COM_MARGIN`] of the craft's size (the
//! mixer's lever arms are taken about the current CoM estimate); the pressure drop from none
//! to the model's. Over that box the kernel's own code runs with [`Interval`] scalars in the
//! format: [`Craft::wrench`] for **every** thruster word, which has no data-dependent branch,
//! so one interval run per word covers every craft in the envelope. The table's inputs are
//! widened by the f32 roundings [`Craft::new`] makes before they reach the format.
//!
//! What a craft can fail on, in the fixed format:
//! * a range: a wrench component, the mixer's command (twice what the thrusters can do, so
//!   that saturating commands are inside the envelope, as for SPHERES) or any intermediate
//!   reaching the format's limit;
//! * the resolution: a command is rounded into the format (to nearest: up to half a step).
//!   Where the allocation is locally linear (`B du = dc` on a fixed set of firing
//!   thrusters), a change `h` of one command component needs `h <= max|du| * sum_i |B_ki|`,
//!   so on the worst command the duty error is at least half a step over the thrusters'
//!   summed magnitude on that component (both senses, the whole period). It must stay below
//!   the mixer's budget against the f64 reference: a necessary condition, judged on the
//!   components the craft is commanded in (a planar craft: Fx, Fy, Tz). `massid model check`
//!   also measures the mixer against the reference on the pure-axis commands.
//!
//! The allocation itself scales its rows by powers of two (every quantity's range O(1)
//! whatever the craft, `massid_kernel::allocation`; its precision is what the resolution
//! check and the measured mixer speak to), and the identification of any craft runs in f32 or
//! the integer float, whose exponent (±2^20) holds the sums of any f32 inputs; neither needs a
//! per-craft range. The Z3 obligations are about the integer primitives over all their inputs,
//! so they hold for every envelope.

use crate::interval::{self, Format, Interval};
use crate::range::{RangeReport, VarRange};
use massid_kernel::craft::{Craft, Thruster, MAX_THRUSTERS};
use massid_kernel::Scalar;

/// Relative thrust margin when a model states no uncertainty: the seed's thrusters vary by
/// 2-8 % (Table C.3); a quarter covers that three times over.
pub const THRUST_MARGIN: f64 = 0.25;
/// Sigmas of a stated thrust uncertainty the envelope spans (when wider than the margin).
pub const THRUST_SIGMAS: f64 = 4.0;
/// The CoM box's margin on each side, as a share of the largest distance of a thruster from
/// the model's CoM (the estimate the mixer is rebuilt from may move).
pub const COM_MARGIN: f64 = 0.1;
/// Relative widening of the table's inputs for the f32 operations `Craft::new` makes before
/// converting (lever, cross product, times the thrust: four roundings of 2^-24, doubled).
const F32_INPUT_SLACK: f64 = 8.0 / 16_777_216.0;

/// The component names of a wrench, in the kernel's order.
const WRENCH: [&str; 6] = ["Tx", "Ty", "Tz", "Fx", "Fy", "Fz"];

/// One craft's envelope.
#[derive(Clone, Debug)]
pub struct CraftEnvelope {
    /// The model's thrusters (positions, directions, nominal thrust).
    pub thrusters: Vec<Thruster>,
    /// Per thruster, the thrust range, N.
    pub thrust_n: Vec<(f64, f64)>,
    /// CoM range per axis, m from the geometric centre.
    pub com_m: [(f64, f64); 3],
    /// Thrust lost per extra open thruster, N.
    pub pressure_drop_n: (f64, f64),
    /// The model's CoM, m from the geometric centre (the resolution is taken about it).
    pub com_nominal_m: [f64; 3],
    /// A planar craft: commanded in Fx, Fy and Tz only.
    pub planar: bool,
}

impl CraftEnvelope {
    /// The envelope of a craft whose model states `thrusters`, per-thruster thrust sigmas
    /// (N; empty or zero: none stated), a pressure drop (N per extra open thruster), its
    /// CoM `com_nominal_m` (m from the geometric centre), and whether it is `planar`.
    pub fn new(
        thrusters: &[Thruster],
        thrust_sigma_n: &[f64],
        pressure_drop_n: f64,
        com_nominal_m: [f64; 3],
        planar: bool,
    ) -> Self {
        let thrust_n = thrusters
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let nominal = f64::from(t.thrust_n);
                let sigma = thrust_sigma_n.get(i).copied().unwrap_or(0.0).max(0.0);
                let half = (THRUST_SIGMAS * sigma).max(THRUST_MARGIN * nominal);
                ((nominal - half).max(0.0), nominal + half)
            })
            .collect();
        let mut com_m = com_nominal_m.map(|c| (c, c));
        let mut reach = 0.0f64;
        for t in thrusters {
            let mut d2 = 0.0;
            for ((c, p), n) in com_m.iter_mut().zip(t.pos_m).zip(com_nominal_m) {
                let p = f64::from(p);
                *c = (c.0.min(p), c.1.max(p));
                d2 += (p - n) * (p - n);
            }
            reach = reach.max(d2.sqrt());
        }
        let margin = COM_MARGIN * reach;
        CraftEnvelope {
            thrusters: thrusters.to_vec(),
            thrust_n,
            com_m: com_m.map(|(lo, hi)| (lo - margin, hi + margin)),
            pressure_drop_n: (0.0, pressure_drop_n.max(0.0)),
            com_nominal_m,
            planar,
        }
    }

    /// Per wrench component, the thrusters' summed magnitude on it at their nominal thrust
    /// about the model's CoM, `sum_i |B_ki|` (N m, N); 0 for a component no thruster acts on.
    pub fn authority(&self) -> [f64; 6] {
        let mut plus = [0.0f64; 6];
        let mut minus = [0.0f64; 6];
        for t in &self.thrusters {
            let d = t.dir.map(f64::from);
            let l: [f64; 3] =
                core::array::from_fn(|k| f64::from(t.pos_m[k]) - self.com_nominal_m[k]);
            let torque = [
                l[1] * d[2] - l[2] * d[1],
                l[2] * d[0] - l[0] * d[2],
                l[0] * d[1] - l[1] * d[0],
            ];
            let w = [torque[0], torque[1], torque[2], d[0], d[1], d[2]];
            for ((p, m), v) in plus.iter_mut().zip(minus.iter_mut()).zip(w) {
                let v = v * f64::from(t.thrust_n);
                *p += v.max(0.0);
                *m += (-v).max(0.0);
            }
        }
        core::array::from_fn(|k| plus[k] + minus[k])
    }
}

/// The verdict on one craft in one format.
#[derive(Clone, Debug)]
pub struct CraftFit {
    /// Each quantity's worst-case range against the format's limit.
    pub ranges: RangeReport,
    /// Half the format's step on a command component over the most the thrusters give it,
    /// worst component: a lower bound of the worst command's duty error (of the period).
    pub duty_resolution: f64,
    /// The component `duty_resolution` is worst on.
    pub resolution_component: &'static str,
    /// The budget `duty_resolution` is held to.
    pub duty_budget: f64,
}

impl CraftFit {
    /// Why the kernel cannot fly the craft in this format, naming the quantity; None if it can.
    pub fn refusal(&self) -> Option<String> {
        let limit = self.ranges.format.max;
        if let Some(v) = self.ranges.overflows().first() {
            return Some(format!(
                "{} reaches {:.4} (the {} limit is {limit})",
                v.name,
                v.range.mag(),
                self.ranges.format.name
            ));
        }
        if self.ranges.watch.max_abs >= limit {
            return Some(format!(
                "an intermediate of the wrench reaches {:.4} (the {} limit is {limit})",
                self.ranges.watch.max_abs, self.ranges.format.name
            ));
        }
        if self.duty_resolution > self.duty_budget {
            return Some(format!(
                "{} resolution: half a {} step is {:.1e} of all thrusters' {}, a duty error above the mixer's budget {:.0e}",
                self.resolution_component,
                self.ranges.format.name,
                self.duty_resolution,
                self.resolution_component,
                self.duty_budget
            ));
        }
        None
    }

    /// The largest quantity as a share of the format's limit (the headroom left).
    pub fn largest(&self) -> Option<&VarRange> {
        self.ranges
            .vars
            .iter()
            .max_by(|a, b| a.range.mag().total_cmp(&b.range.mag()))
    }
}

/// Runs the kernel's wrench table for every thruster word over `env` in `format`, with
/// `duty_budget` the mixer's budget (fraction of the period) for the resolution check.
/// `Err` names why the kernel cannot even build the table (a thruster count outside 1-16).
pub fn check(env: &CraftEnvelope, format: Format, duty_budget: f64) -> Result<CraftFit, String> {
    interval::set_format(format);
    interval::reset_watch();
    let com = env.com_m.map(Interval::of);
    // The f32 operations of `Craft::new` (the model's path) round before the format does.
    let f32_ops = Interval::of((1.0 - F32_INPUT_SLACK, 1.0 + F32_INPUT_SLACK));
    let unit: Vec<[Interval; 6]> = env
        .thrusters
        .iter()
        .map(|t| {
            let dir = t.dir.map(|d| Interval::point(f64::from(d)));
            let lever: [Interval; 3] =
                core::array::from_fn(|k| Interval::point(f64::from(t.pos_m[k])) - com[k]);
            let torque = massid_kernel::craft::cross(&lever, &dir);
            [torque[0], torque[1], torque[2], dir[0], dir[1], dir[2]].map(|v| v * f32_ops)
        })
        .collect();
    let thrust: Vec<Interval> = env
        .thrust_n
        .iter()
        .map(|r| Interval::of(*r) * f32_ops)
        .collect();
    let mut vars = Vec::new();
    let table = Craft::from_unit_wrenches(&unit, &thrust, Interval::of(env.pressure_drop_n));
    match table {
        Ok(craft) => {
            let n = env.thrusters.len().min(MAX_THRUSTERS);
            let mut hull = [Interval::ZERO; 6];
            for word in 0..(1u32 << n) {
                let w = craft.wrench(u16::try_from(word).unwrap_or(u16::MAX));
                for (h, v) in hull.iter_mut().zip(w) {
                    *h = h.hull(v);
                }
            }
            for (name, h) in WRENCH.iter().zip(hull) {
                vars.push(VarRange {
                    name: format!("wrench {name} (any word)"),
                    range: h,
                });
            }
            for (name, h) in WRENCH.iter().zip(hull) {
                let twice = Interval::point(2.0) * h;
                vars.push(VarRange {
                    name: format!("mixer command {name} (twice the reachable)"),
                    range: twice,
                });
            }
            for (k, name) in WRENCH.iter().enumerate() {
                let h = unit.iter().fold(Interval::ZERO, |m, u| m.hull(u[k]));
                vars.push(VarRange {
                    name: format!("per-newton wrench {name}"),
                    range: h,
                });
            }
        }
        Err(_) => {
            interval::set_format(Format::REAL);
            return Err(format!(
                "{} thrusters: the kernel takes 1-{MAX_THRUSTERS}",
                env.thrusters.len()
            ));
        }
    }
    let watch = interval::reset_watch();
    interval::set_format(Format::REAL);
    // The components the craft is commanded in: a planar craft's Fx, Fy, Tz; a 3-D craft's
    // every component a thruster acts on (beyond rounding: 1e-9 of the strongest of its kind,
    // torques against torques, forces against forces).
    let authority = env.authority();
    let strongest = |k: usize| {
        let kind = if k < 3 { 0..3 } else { 3..6 };
        authority[kind].iter().copied().fold(0.0f64, f64::max)
    };
    let commanded = |k: usize| {
        if env.planar {
            matches!(k, 2..=4)
        } else {
            authority[k] > 1e-9 * strongest(k)
        }
    };
    let (duty_resolution, resolution_component) = (0..6)
        .filter(|&k| commanded(k) && authority[k] > 0.0)
        .map(|k| (0.5 * format.slack.abs / authority[k], WRENCH[k]))
        .fold((0.0f64, "-"), |m, r| if r.0 > m.0 { r } else { m });
    Ok(CraftFit {
        ranges: RangeReport {
            what: format!(
                "craft wrench table, every word of {} thrusters, thrust and CoM over the craft's envelope",
                env.thrusters.len()
            ),
            format,
            vars,
            watch,
        },
        duty_resolution,
        resolution_component,
        duty_budget,
    })
}
