//! Mass-property identification from any flight, onboard: the output-error design of the
//! f64 reference (`reference_f64::flight_id`) in a form that streams. Every rate sample is a
//! measurement of its window's initial rate plus the drive accumulated since (Euler's
//! equation), so the rate is continuous across word changes, coasts and short pulses count,
//! and the gyroscopic term is in the model. The seed's per-firing Kalman filter + RLS (still
//! in [`crate::pipeline`]) measured each firing's acceleration from the rate change since one
//! noisy sample and threw the coasts away: its variance was 100-1000x the Cramér-Rao bound.
//!
//! One call of [`FlightId::push`] per sample adds the sample to a few hundred sums
//! ([`sums`]); [`FlightId::solve`] fits the mass properties and an AR noise model per axis
//! to those sums at any time ([`solve`]); [`FlightId::reanchor`] then moves the floating-point
//! sums to that fit's model, so that they hold noise rather than the drift from a model far
//! from the craft ([`anchor`]). Any craft: the thrusters are a table ([`crate::craft`])
//! and the caller passes the command ([`crate::craft::Craft::command`] of the thruster word,
//! or [`command_of_wrench`] of a commanded wrench), so thruster words and wrench commands
//! alike.
//!
//! The gyroscopic term `omega x I omega` is linear in the six rate products
//! `omega_i omega_j`, so their integrals are six more drive components and the inertia's
//! information in the gyroscopic dynamics is used as the reference uses it (the reference
//! integrates the model's rate, this the measured one). The noise model is AR of order <= 2,
//! or, for rates differenced from attitude, a moving average of a root fixed before the
//! flight, taken out of the measurement before the sums ([`ma_prefilter`]; the reference fits
//! ARMA(p,1)). What the reference does and this does not (yet): the score tests are of a
//! command delay and of thrust symmetry per torque axis ([`consistency`]), not of each
//! thruster's thrust.
pub mod active;
pub mod anchor;
pub mod close;
pub mod components;
pub mod consider;
pub mod consistency;
pub mod delay;
pub mod drive;
pub mod exact;
pub mod ma_prefilter;
pub mod reach;
pub mod solve;
pub mod sums;
#[cfg(test)]
pub(crate) mod test_flights;
pub mod window;

use core::mem::MaybeUninit;

use crate::craft::{Craft, COMMAND_LEN};
use crate::in_place::{assume_all_written, field};
use crate::scalar::Scalar;
use drive::DriveSum;
use reach::Reach;
use solve::{Solution, SolveConfig, SolveError, NP};
use sums::{DriveSnapshot, FlightSums, Recent, RecentSums, SumScalar, WindowSums, NZ};

/// How the measured rate relates to the body rate (the reference's `SensorResponse`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum SensorResponse {
    /// The rate at the sample instant (a gyro).
    Point = 0,
    /// The mean rate over the previous interval (attitude differenced over one sample).
    BackwardMean = 1,
    /// The mean over the previous and next intervals (attitude central-differenced).
    CentralMean = 2,
}

/// Settings of [`FlightId`].
#[derive(Clone, Copy, Debug)]
pub struct FlightIdConfig<S> {
    /// Nominal sample period, s; a step over 1.5 of it starts a new window.
    pub period_s: S,
    /// The rate sensor's response.
    pub sensor: SensorResponse,
    /// The root `rho` of the rate noise's moving-average part (`e_k = eps_k - rho eps_(k-d)`;
    /// 0 for a gyro's, near 1 for rates differenced from attitude): the measurement is
    /// filtered by `1 / (1 - rho B^d)` before the sums ([`ma_prefilter`]). A property of the
    /// sensor, measured on the ground from an earlier flight.
    pub rate_noise_ma_root: S,
    /// Its lag `d`: 1 for attitude differenced over one sample, 2 for a central difference.
    pub rate_noise_ma_lag: u8,
    /// Known command-to-thrust delay, in sample periods ([`delay::CommandDelay`]).
    pub delay_periods: f32,
    /// Cut the windows wherever the acting wrench changes (the interval before the change is
    /// left out): for replays of recordings that log commands at a coarser rate than the
    /// valves switch, so the instant of a change within an interval is unknown.
    pub cut_at_changes: bool,
    /// Windows are cut at this many samples (bounds every sum).
    pub max_window: u32,
    /// Past `turn_window` samples, a window is also cut once the craft has turned this far in
    /// it (rad, summed over the axes, each weighted by `turn_weight`): the kernel takes the
    /// gyroscopic products of the measured rates and has no variational equation, an
    /// approximation that degrades with the gyroscopic coupling a long window spans
    /// ([`window`]).
    pub max_window_turn_rad: S,
    /// Per axis, how much its turn counts ([`window::turn_weights`]: 1 for a craft that couples
    /// the axes no more than SPHERES).
    pub turn_weight: [S; 3],
    /// See `max_window_turn_rad`.
    pub turn_window: u32,
    /// A 3-D craft's window is also cut, whatever its length, once its coupled noise walk
    /// (`sum_a w_a omega_a^2 dt`, weights [`window::walk_weights`] of `turn_weight` and the
    /// period) reaches this ([`window::MAX_WINDOW_WALK`]; infinity: never).
    pub max_window_walk: S,
    /// Samples left out at each window's start: the noise model's highest order (their
    /// whitened residual would need samples before the window).
    pub skip: u32,
    /// What the fit estimates and how ([`solve::SolveConfig`]).
    pub solve: SolveConfig<S>,
    /// The largest wrench and rate the flight brings: the fixed kernel's exact sums are
    /// scaled to it ([`exact`]; a sample 2-4 times beyond it makes its fit answer `Overflow`).
    pub envelope: exact::Envelope<S>,
    /// The model's stated thrust uncertainty, in the covariance and the tests ([`consider`];
    /// [`consider::ThrustUncertainty::none`] when the model states none).
    pub thrust: consider::ThrustUncertainty,
}

/// The streaming identification.
#[derive(Clone, Copy, Debug)]
pub struct FlightId<S: SumScalar> {
    cfg: FlightIdConfig<S>,
    sums: FlightSums<S>,
    /// The last samples' products, folded into `sums` a few entries per sample.
    recent: RecentSums<S::Recent>,
    window: WindowSums<S>,
    /// Closed windows whose initial-rate term is still being added to `sums` ([`close`]).
    pending: close::PendingCloses<S>,
    /// Drive accumulated since the window's first sample ([`drive`]).
    drive: S::Drive,
    /// The last three samples' rate products (order of [`solve::PRODUCTS`]): a ring, the
    /// newest at `products_newest` (the sample before it valid from a window's second sample,
    /// the one before that from its third: where the rule reads them).
    products: [<S::Drive as DriveSum<S>>::Products; 3],
    products_newest: usize,
    /// The previous step's length, s (Adams-Moulton's equal-step weights need it).
    dt_before: S,
    /// A step longer than this starts a new window (1.5 periods).
    gap: S,
    /// The window's last three (drive, measured rate), a ring whose newest is at `newest`
    /// (the older ones follow, modulo 3); `filled` of them valid. The drive is kept only for
    /// the sensor means: a point response reads the drive itself ([`DriveSum::current`]).
    last: [(DriveSnapshot<S>, [S; 3]); 3],
    newest: usize,
    filled: u32,
    /// The window's weighted rotation (sum over the axes of `w_a |omega_a| dt`, rad) and
    /// coupled noise walk so far, against their limits ([`reach::Reach`]; the walk's weights
    /// are zero for a planar craft, which has no gyroscopic products).
    reach: S::Reach,
    /// The window's first measured rate (the sums hold rates relative to it; the model they
    /// are relative to is the sums' [`FlightSums::anchor`]).
    first_rate: Option<[S; 3]>,
    /// The delay line of the commands.
    delay: delay::CommandDelay<S>,
    /// The rate noise's moving-average part, taken out of each measurement.
    prefilter: ma_prefilter::MaPrefilter<S>,
    /// The held command's step ([`DriveSum::held_step`]) of the acting command whose key
    /// ([`delay::CommandDelay::acting_key`]) and step length are given: remade only when
    /// either changes (None: a new window).
    held: Option<((u32, u32), S)>,
    held_step: <S::Drive as DriveSum<S>>::Step,
    /// Whether the previous sample was valid (the command acting since it is the delay
    /// line's [`delay::CommandDelay::acting`] one back).
    previous: bool,
    /// The nominal model's matrix: the sums hold rates minus its prediction, so that they
    /// stay small (f32 rounding) whatever the rates.
    nominal: [[S; NZ]; 3],
}

fn get<S: Scalar>(v: &[S], i: usize) -> S {
    v.get(i).copied().unwrap_or(S::ZERO)
}

/// Whether two commands' wrenches differ in any component (the window cut at word changes,
/// `cut_at_changes`, is for the model's timing; a change of the positive torques alone, an
/// opposing pair opening, moves only the consistency tests' components).
fn differs<S: Scalar>(a: &[S; COMMAND_LEN], b: &[S; COMMAND_LEN]) -> bool {
    a.iter().zip(b).take(6).any(|(x, y)| x.lt(*y) || y.lt(*x))
}

/// The command for a sample whose wrench is all that is known (a recording of wrench
/// commands, not thruster words): the positive parts are those of the summed torque, which
/// is each thruster's only while thrusters turning the craft opposite ways do not fire
/// together ([`crate::craft::Craft::command`] has them per thruster).
pub fn command_of_wrench<S: Scalar>(wrench: [S; 6]) -> [S; COMMAND_LEN] {
    core::array::from_fn(|c| {
        let w = get(&wrench, c % 6);
        if c < 6 || S::ZERO.lt(w) {
            w
        } else {
            S::ZERO
        }
    })
}

impl<S: SumScalar> FlightId<S> {
    /// Nothing measured yet; None if the nominal inverse inertia is singular or the delay is
    /// out of range. ([`FlightId::init_in_place`]'s state, copied.)
    pub fn new(cfg: FlightIdConfig<S>) -> Option<Self> {
        Self::init_in_place(&mut MaybeUninit::uninit(), cfg).map(|id| *id)
    }

    /// [`FlightId::new`] written in place in `slot` (a state block: the sums are tens of kB,
    /// which a returned value would carry through the stack); None, with nothing written, if
    /// the nominal inverse inertia is singular or the delay is out of range.
    pub fn init_in_place(
        slot: &mut MaybeUninit<Self>,
        cfg: FlightIdConfig<S>,
    ) -> Option<&mut Self> {
        // What can fail comes first, so that a refused configuration writes nothing.
        let delay = delay::CommandDelay::new(cfg.delay_periods).ok()?;
        let prefilter = ma_prefilter::MaPrefilter::new(
            cfg.rate_noise_ma_root,
            cfg.rate_noise_ma_lag,
            cfg.solve.axes,
        )?;
        let nominal =
            solve::model_matrix(&cfg.solve.j_nominal, &[S::ZERO; 3], cfg.solve.gyroscopic)?;
        // The longest window: `max_window` samples, each step up to 1.5 periods.
        let window_s = S::from_int_pow2(i32::try_from(cfg.max_window).unwrap_or(i32::MAX), 0)
            .times(cfg.period_s)
            .times(S::from_f32(1.5));
        let walk_weight = if cfg.solve.gyroscopic {
            window::walk_weights(&cfg.turn_weight.map(S::to_f32), cfg.period_s.to_f32())?
                .map(S::from_f32)
        } else {
            [S::ZERO; 3]
        };
        let (reach, products_window) = cfg.envelope.products_reach(
            window_s,
            &walk_weight,
            cfg.max_window_walk,
            S::from_f32(1.5).times(cfg.period_s),
            cfg.max_window,
        );
        let bounds = cfg.envelope.component_bounds(window_s, reach, &nominal);
        let scales = S::scales(
            &bounds,
            &nominal,
            cfg.max_window,
            products_window,
            window_s,
            cfg.envelope.rate,
            S::from_f32(1.5).times(cfg.period_s),
        )?;
        let reach = S::reach(
            &scales,
            cfg.turn_weight,
            walk_weight,
            cfg.max_window_turn_rad,
            cfg.max_window_walk,
            S::from_f32(1.5).times(cfg.period_s),
        )?;
        field!(slot, Self, cfg).write(cfg);
        let sums = FlightSums::init_in_place(field!(slot, Self, sums));
        sums.lag_form = <S::Recent as Recent<S>>::LAG_FORM;
        sums.pivot_exp = <S::Recent as Recent<S>>::PIVOT_EXP;
        RecentSums::init_in_place(field!(slot, Self, recent), |r| S::init_recent(r, &scales));
        field!(slot, Self, window).write(WindowSums::default());
        field!(slot, Self, pending).write(close::PendingCloses::default());
        field!(slot, Self, drive).write(S::drive(&scales));
        field!(slot, Self, products).write([<S::Drive as DriveSum<S>>::ZERO_PRODUCTS; 3]);
        field!(slot, Self, products_newest).write(0);
        field!(slot, Self, dt_before).write(S::ZERO);
        field!(slot, Self, gap).write(S::from_f32(1.5).times(cfg.period_s));
        field!(slot, Self, last).write([(S::Drive::ZERO_SNAPSHOT, [S::ZERO; 3]); 3]);
        field!(slot, Self, newest).write(0);
        field!(slot, Self, filled).write(0);
        field!(slot, Self, reach).write(reach);
        field!(slot, Self, first_rate).write(None);
        field!(slot, Self, previous).write(false);
        field!(slot, Self, held).write(None);
        field!(slot, Self, held_step).write(<S::Drive as DriveSum<S>>::ZERO_STEP);
        field!(slot, Self, delay).write(delay);
        field!(slot, Self, prefilter).write(prefilter);
        field!(slot, Self, nominal).write(nominal);
        // SAFETY: every field was written just above.
        Some(unsafe {
            assume_all_written!(
                slot,
                Self {
                    cfg,
                    sums,
                    recent,
                    window,
                    pending,
                    drive,
                    products,
                    products_newest,
                    dt_before,
                    gap,
                    last,
                    newest,
                    filled,
                    reach,
                    first_rate,
                    delay,
                    prefilter,
                    previous,
                    held,
                    held_step,
                    nominal
                }
            )
        })
    }

    /// The sums so far: the closed windows whose term is in ([`close`]; after
    /// [`FlightId::finish`], every window).
    pub fn sums(&self) -> &FlightSums<S> {
        &self.sums
    }

    /// One sample: `dt_s` since the previous sample, the measured `rate` (rad/s; `valid` false
    /// for a missing or railed sample) and the `command` held until the next:
    /// [`crate::craft::Craft::command`] of the thruster word (the wrench, torque about the
    /// model's CoM N m and force N, then the open thrusters' positive torques), or
    /// [`command_of_wrench`].
    pub fn push(&mut self, dt_s: S, rate: [S; 3], valid: bool, command: [S; COMMAND_LEN]) {
        self.push_with(dt_s, rate, valid, |slot| *slot = command);
    }

    /// [`FlightId::push`] with the command written in place by `command` (into the delay
    /// line: no copy of it in the tick), e.g. by [`crate::craft::Craft::command_into`].
    pub fn push_with(
        &mut self,
        dt_s: S,
        rate: [S; 3],
        valid: bool,
        command: impl FnOnce(&mut [S; COMMAND_LEN]),
    ) {
        // The command history runs on whatever happens to the rate samples.
        self.delay.push_with(command);
        self.step(dt_s, rate, valid);
    }

    /// [`FlightId::push`] of the thruster word `word` of `craft` (the craft the
    /// identification was configured for, the same table on every call: a repeated word's
    /// command is copied, not remade, [`delay::CommandDelay::push_word`]), the same arithmetic
    /// as `push(.., craft.command(word))`. A caller that changes the table pushes
    /// [`FlightId::push`] once after the change (which forgets the word).
    pub fn push_word(&mut self, dt_s: S, rate: [S; 3], valid: bool, craft: &Craft<S>, word: u16) {
        self.delay.push_word(craft, word);
        self.step(dt_s, rate, valid);
    }

    /// A sample whose command is in the delay line.
    fn step(&mut self, dt_s: S, rate: [S; 3], valid: bool) {
        // A few entries of the closed windows' terms ([`close`]).
        self.pending.drain_tick(&mut self.sums);
        if !valid {
            self.close_window();
            self.previous = false;
            return;
        }
        let gap = self.gap;
        let joins = self.previous
            && !gap.lt(dt_s)
            && S::ZERO.lt(dt_s)
            && self.filled < self.cfg.max_window
            && (self.filled < self.cfg.turn_window || self.reach.turn_within())
            && self.reach.walk_within()
            && !(self.cfg.cut_at_changes && differs(self.delay.acting(1), self.delay.acting(0)));
        if !joins {
            self.close_window();
        }
        let gyro = self.cfg.solve.gyroscopic;
        // The rate products (the gyroscopic term `omega x I omega` is linear in them).
        // Into the ring's next slot (no copy of the older ones).
        let (now, then, before) = match self.products_newest {
            0 => (1, 0, 2),
            1 => (2, 1, 0),
            _ => (0, 2, 1),
        };
        self.products_newest = now;
        if let Some(p) = self.products.get_mut(now) {
            if gyro {
                self.drive.products_into(&rate, p);
            } else {
                *p = <S::Drive as DriveSum<S>>::ZERO_PRODUCTS;
            }
        }
        let zero = <S::Drive as DriveSum<S>>::ZERO_PRODUCTS;
        let at = |k: usize| self.products.get(k).unwrap_or(&zero);
        let (products, then, before) = (at(now), at(then), at(before));
        if joins {
            // The command acting over the interval that ends at this sample, held: its
            // torque and force accumulated, the held torque (the timing test's direction, set,
            // not summed) and the open thrusters' positive torques about each axis
            // accumulated (the thrust-symmetry test's direction, [`consistency`], and what
            // tells thrusters apart in the thrust-uncertainty recovery, [`consider`]). The
            // same for every interval of one command and step: made once per change.
            let key = (self.delay.acting_key(1), dt_s);
            let same = self
                .held
                .is_some_and(|(k, dt)| k == key.0 && !(dt.lt(dt_s) || dt_s.lt(dt)));
            if !same {
                self.held_step = self.drive.held_step(self.delay.acting(1), dt_s);
                self.held = Some(key);
            }
            self.drive.add_step(&self.held_step);
            if gyro {
                // The integral of the measured rate products over the step (unbiased: the
                // noise products have zero mean in every component of omega x I omega; taking
                // them of a Kalman-filtered rate instead changed no Monte Carlo figure). From a
                // window's third sample, Adams-Moulton's third-order rule
                // `h (5 f_k + 8 f_(k-1) - f_(k-2)) / 12`: the trapezoid's error, `h^2/12` times
                // the products' change of slope, was a systematic residual on craft spinning
                // fast at low sample rates (6.9 rad/s at 50 Hz: inertia 5 sigma off, `ok`).
                // (Equal steps: with a step 1/64 longer or shorter than the one before, the
                // rule's error on a linear product, `f' dt (dt_before - dt) / 12`, stays below
                // the trapezoid's on the curvature; with more jitter the trapezoid, exact on a
                // linear product.)
                let jitter = dt_s.minus(self.dt_before).abs();
                let third_order = self.filled >= 2 && !dt_s.mul_pow2(-6).lt(jitter);
                self.drive
                    .add_products(6, products, then, before, dt_s, third_order);
            }
        }
        self.dt_before = dt_s;
        if joins {
            self.reach.add(&rate, products, dt_s, gyro);
        }
        // A ring, not a rotation: no copying of the older entries per sample.
        self.newest = if self.newest == 0 {
            2
        } else {
            self.newest.saturating_sub(1)
        };
        if let Some(r) = self.last.get_mut(self.newest) {
            // A point response reads the drive itself ([`DriveSum::current`]).
            if self.cfg.sensor != SensorResponse::Point {
                r.0 = self.drive.snapshot();
            }
            r.1 = rate;
        }
        self.filled = self.filled.saturating_add(1);
        self.emit();
        self.previous = true;
    }

    /// The measurement the newest sample completes, through the sensor's response.
    fn emit(&mut self) {
        let back = |i: usize| {
            let k = self.newest.saturating_add(i);
            self.last.get(if k >= 3 { k.saturating_sub(3) } else { k })
        };
        let (Some((z2, y2)), Some((z1, y1)), Some((z0, _))) = (back(0), back(1), back(2)) else {
            return;
        };
        let mean: DriveSnapshot<S>;
        let (z, y) = match self.cfg.sensor {
            SensorResponse::Point => (self.drive.current(), y2),
            SensorResponse::BackwardMean if self.filled >= 2 => {
                mean = S::Drive::mean2(z1, z2);
                (&mean, y2)
            }
            SensorResponse::CentralMean if self.filled >= 3 => {
                mean = S::Drive::mean3(z0, z1, z2);
                (&mean, y1)
            }
            _ => return,
        };
        let first = *self.first_rate.get_or_insert(*y);
        let y_raw = core::array::from_fn(|a| get(y, a).minus(get(&first, a)));
        let skip = self.cfg.skip.saturating_add(self.prefilter.settle());
        if self.prefilter.is_active() {
            // The filter runs on values (in the fixed kernel: converted from its integers).
            let values = self.drive.values_of(z);
            let (fz, fy) = self.prefilter.apply(&values, &y_raw);
            let nominal = &self.nominal;
            self.window
                .push(&mut self.sums, &mut self.recent, skip, |r, out| {
                    r.item_into(fz, fy, nominal, out)
                });
        } else {
            let (drive, nominal) = (&self.drive, &self.nominal);
            self.window
                .push(&mut self.sums, &mut self.recent, skip, |r, out| {
                    S::drive_item(r, drive, z, &y_raw, nominal, out)
                });
        }
    }

    fn close_window(&mut self) {
        if let Some((sum, n)) = self.window.close(&self.recent) {
            self.pending
                .close(&mut self.sums, sum, n, self.recent.active());
        }
        self.drive.clear();
        self.held = None;
        self.prefilter.reset();
        self.filled = 0;
        self.reach.clear();
        self.first_rate = None;
    }

    /// Ends the flight: closes the open window and adds every closed window's term to the
    /// sums (call before the final [`FlightId::solve`]; the end of the flight, not a tick).
    pub fn finish(&mut self) {
        self.close_window();
        self.pending.drain_all(&mut self.sums);
        self.previous = false;
    }

    /// Fits the mass properties to the closed windows and tests their consistency (on a
    /// folded copy of the sums: this is a background task's work, not a tick's).
    pub fn solve(&self) -> Result<Solution<S>, SolveError> {
        let sums = self.sums_so_far();
        if sums.out_of_range {
            return Err(SolveError::Overflow);
        }
        let mut solution = solve::solve(&sums, &self.cfg.solve)?;
        let free = solution.held.map(|h| !h);
        // What the fit holds at the model (unobservable terms, stated thrust errors) widens
        // the covariance and the tests' variance ([`consider`]).
        let considered = consider::of_fit(
            &sums,
            &self.cfg.solve,
            &solution.theta,
            &solution.noise,
            &solution.held,
            &solution.covariance,
            &self.cfg.thrust,
        )
        // None only where the fitted model matrix does not exist (a singular inverse
        // inertia, which the validity rules refuse): the estimate then keeps its plain
        // covariance rather than being lost.
        .unwrap_or_else(consider::Consider::none);
        let test = |direction| {
            consistency::score_statistic(
                &sums,
                &self.cfg.solve,
                &solution.theta,
                &solution.noise,
                &free,
                &solution.covariance,
                (&considered, &self.cfg.thrust),
                direction,
            )
        };
        let timing = test(consistency::Direction::Timing);
        let symmetry = core::array::from_fn(|b| test(consistency::Direction::Symmetry(b)));
        solution.timing_statistic = timing;
        solution.symmetry_statistic = symmetry;
        solution.covariance = considered.widen(&solution.covariance);
        Ok(solution)
    }

    /// Every sample's sums so far, folded, the open window's initial-rate term included (as
    /// if it closed now: without it, a fit mid-window took the window's samples as measured
    /// from a known initial rate). A copy: the flight goes on.
    fn sums_so_far(&self) -> FlightSums<S> {
        let mut sums = self.sums;
        let mut recent = self.recent;
        recent.fold_all(&mut sums);
        let mut pending = self.pending;
        if let Some((sum, n)) = self.window.term(&recent) {
            pending.close(&mut sums, sum, n, recent.active());
        }
        pending.drain_all(&mut sums);
        sums
    }

    /// Whether [`FlightId::reanchor`] moves this format's sums (floating point; the fixed
    /// kernel's exact sums are not moved).
    pub const REANCHORS: bool = <S::Recent as sums::Recent<S>>::SHIFTS;

    /// Moves the sums' reference model to `theta` (a fit's [`Solution::theta`]): from here on
    /// the sums hold the rates' residual from that model rather than from the configuration's
    /// nominal ([`anchor`]: exact, so a fit before and after differ by rounding only; where the
    /// nominal is far from the craft, f32's later fits are the better). Background work, as
    /// [`FlightId::solve`]: it folds every waiting sum. Nothing changes on an error.
    pub fn reanchor(&mut self, theta: &[S; NP]) -> Result<(), ReanchorError> {
        let (j6, dc) = theta.split_at(6);
        let new = solve::model_matrix(j6, dc, self.cfg.solve.gyroscopic)
            .ok_or(ReanchorError::Singular)?;
        let d: [[S; NZ]; 3] = core::array::from_fn(|a| {
            core::array::from_fn(|j| {
                let at = |m: &[[S; NZ]; 3]| m.get(a).and_then(|r| r.get(j)).copied();
                at(&new)
                    .zip(at(&self.nominal))
                    .map_or(S::ZERO, |(n, o)| n.minus(o))
            })
        });
        let mut window = self.window;
        if !window.shift(&d) {
            return Err(ReanchorError::ExactSums);
        }
        let mut sums = self.sums;
        let mut recent = self.recent;
        recent.fold_all(&mut sums);
        let mut pending = self.pending;
        pending.drain_all(&mut sums);
        anchor::shift_sums(&mut sums, &d);
        let valid = |v: &[S]| v.iter().all(|x| x.is_valid());
        if !(sums.lag.is_valid() && valid(sums.czy.as_flattened()) && valid(&sums.cyy)) {
            return Err(ReanchorError::Overflow);
        }
        sums.anchor = Some((
            core::array::from_fn(|m| get(j6, m)),
            core::array::from_fn(|m| get(dc, m)),
        ));
        self.sums = sums;
        self.recent = recent;
        self.pending = pending;
        self.window = window;
        self.nominal = new;
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &FlightIdConfig<S> {
        &self.cfg
    }
}

/// Why [`FlightId::reanchor`] did not move the sums.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReanchorError {
    /// The new model's inverse inertia is singular.
    Singular,
    /// The fixed kernel's exact sums are not moved: they do not round, and their integer
    /// scales are derived for the model they were built for.
    ExactSums,
    /// A moved sum left the number format.
    Overflow,
}

/// Terms of [`Solution::theta`], in order: inverse inertia xx yy zz xy xz yz, then the CoM.
pub const THETA_TERMS: usize = NP;

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )]
    use super::*;

    /// Windows of a craft turning about x at 1 rad/s for 1 s, cut after `limit` rad of
    /// weighted turn.
    fn windows_of(weight: [f32; 3], limit: f32) -> u32 {
        let mut cfg = test_flights::config::<f32>([10.0, 10.0, 10.0, 0.0, 0.0, 0.0]);
        cfg.max_window = 100_000;
        cfg.max_window_turn_rad = limit;
        cfg.turn_weight = weight;
        cfg.skip = 0;
        cfg.solve.max_noise_order = 0;
        let mut id = FlightId::new(cfg).expect("config");
        for _ in 0..1000 {
            id.push(1e-3, [1.0, 0.0, 0.0], true, [0.0; COMMAND_LEN]);
        }
        id.finish();
        id.sums().windows
    }

    #[test]
    fn a_window_ends_after_its_weighted_turn() {
        // No limit: one window; 0.1 rad: about ten; the x turn counted twice: about twenty.
        assert_eq!(windows_of([1.0; 3], f32::INFINITY), 1);
        let plain = windows_of([1.0; 3], 0.1);
        let doubled = windows_of([2.0, 1.0, 1.0], 0.1);
        assert!((9..=11).contains(&plain), "{plain}");
        assert!((19..=21).contains(&doubled), "{doubled}");
        // A weight on an axis the craft does not turn about changes nothing.
        assert_eq!(windows_of([1.0, 5.0, 5.0], 0.1), plain);
    }

    /// A word's held step is made once per change of the acting command or of the step
    /// length (`FlightId::held`): pushing words (steps reused) gives the sums bit for bit of
    /// pushing each sample's command (a new command each time: every step remade), with a
    /// fractional delay, steps that change within a word's run, and words that hold and
    /// change. Planted (checked by hand, 2026-11-30): a key without the step length fails.
    #[test]
    fn held_steps_are_remade_when_the_command_or_the_step_changes() {
        use crate::IntFloat;
        fn run<S: SumScalar + core::fmt::Debug>(by_word: bool) -> u64 {
            let c = S::from_f32;
            let mut cfg = test_flights::config::<S>([10.0, 10.0, 10.0, 0.0, 0.0, 0.0]);
            cfg.delay_periods = 1.5;
            let craft = test_flights::five_thrusters::<S>();
            let mut id = FlightId::new(cfg).expect("config");
            for (k, word) in test_flights::words(1500).enumerate() {
                let dt = c(if k % 7 == 3 { 1.01e-3 } else { 1e-3 });
                let t = k as f32 * 1e-3;
                let rate = [c(0.1 + 0.2 * t), c(-0.05 + 0.1 * t), c(0.02 * t)];
                if by_word {
                    id.push_word(dt, rate, true, &craft, word);
                } else {
                    id.push(dt, rate, true, craft.command(word));
                }
            }
            id.finish();
            sums::tests::text_hash(id.sums())
        }
        assert_eq!(run::<f32>(true), run::<f32>(false));
        assert_eq!(run::<IntFloat>(true), run::<IntFloat>(false));
    }

    /// A 3-D test craft's configuration at 1 kHz, no turn limit, with the window length, the
    /// turn weights, the noise walk limit, the nominal inertia, the free terms and the envelope
    /// given.
    fn config_3d<S: SumScalar>(
        max_window: u32,
        turn_weight: [S; 3],
        max_window_walk: S,
        inertia_inverse: [f32; 6],
        free: [bool; NP],
        envelope: exact::Envelope<S>,
    ) -> FlightIdConfig<S> {
        let mut cfg = test_flights::config::<S>(inertia_inverse);
        cfg.max_window = max_window;
        cfg.turn_weight = turn_weight;
        cfg.max_window_walk = max_window_walk;
        cfg.skip = 0;
        cfg.solve.free = free;
        cfg.solve.max_noise_order = 0;
        cfg.envelope = envelope;
        cfg
    }

    /// The fixed kernel's exact sums are scaled to the envelope: a wrench beyond it makes the
    /// fit answer Overflow (f32, which has no such scale, answers).
    #[test]
    fn the_fixed_kernel_refuses_a_wrench_beyond_its_envelope() {
        use crate::IntFloat;
        fn run<S: SumScalar>(torque: f32) -> Result<(), SolveError> {
            let c = S::from_f32;
            let cfg = config_3d(
                2000,
                [S::ONE; 3],
                c(f32::INFINITY),
                [10.0, 10.0, 10.0, 0.0, 0.0, 0.0],
                // the principal terms: the pulses excite them and nothing else
                core::array::from_fn(|m| m < 3),
                exact::Envelope::of_craft([0.01f32, 0.01, 0.01, 0.1, 0.1, 0.1].map(c)),
            );
            let mut id = FlightId::new(cfg).expect("config");
            let mut w = [0.0f32; 3];
            let mut x = 12345u32;
            for k in 0..6000 {
                let on = (k / 100) % 3;
                let wrench: [S; 6] =
                    core::array::from_fn(|i| if i == on { c(torque) } else { S::ZERO });
                // the rate that follows the torque (J = 10), measured with noise
                let noisy = w.map(|v| {
                    x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    c(v + 1e-3 * ((x >> 8) as f32 / (1u32 << 24) as f32 - 0.5))
                });
                id.push(c(1e-3), noisy, true, command_of_wrench(wrench));
                w[on] += 10.0 * torque * 1e-3;
            }
            id.finish();
            id.solve().map(|_| ())
        }
        assert_eq!(run::<IntFloat>(0.005), Ok(()));
        assert_eq!(run::<f32>(0.005), Ok(()));
        assert_eq!(run::<IntFloat>(0.5), Err(SolveError::Overflow));
        assert_ne!(run::<f32>(0.5), Err(SolveError::Overflow));
    }

    /// A 3-D craft spinning near its envelope's rate: its windows end at the coupled noise
    /// walk whatever the turn limit says (one window without it), and the integer float's
    /// rate products, whose bound is then the walk's and not the window's length
    /// (`Envelope::products_reach`), stay in range. Measured with the products' drive kept at
    /// the window's resolution instead of the walk's (`IntFloat::scales`): out of range.
    #[test]
    fn a_spinning_craft_s_windows_end_at_the_noise_walk_and_stay_in_range() {
        use crate::IntFloat;
        fn run<S: SumScalar>(walk: f32) -> (u32, bool, Result<(), SolveError>) {
            let c = S::from_f32;
            let cfg = config_3d(
                60_000,
                // a craft that couples the axes four times as much as SPHERES
                [c(4.0); 3],
                c(walk),
                [10.0, 12.0, 14.0, 0.0, 0.0, 0.0],
                [true; NP],
                exact::Envelope {
                    wrench: [0.01f32, 0.01, 0.01, 0.1, 0.1, 0.1].map(c),
                    rate: c(6.0),
                },
            );
            let mut id = FlightId::new(cfg).expect("config");
            let mut x = 12345u32;
            for k in 0..20_000u32 {
                // 5.9 rad/s about x and 0.5 about y, pulses about z, the rate noisy
                let on = (k / 150) % 2 == 0;
                let torque = if on { c(0.005) } else { S::ZERO };
                let rate = [5.9f32, 0.5, 0.0].map(|v| {
                    x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    c(v + 1e-3 * ((x >> 8) as f32 / (1u32 << 24) as f32 - 0.5))
                });
                id.push(
                    c(1e-3),
                    rate,
                    true,
                    command_of_wrench([S::ZERO, S::ZERO, torque, S::ZERO, S::ZERO, S::ZERO]),
                );
            }
            id.finish();
            let sums = id.sums();
            (sums.windows, sums.out_of_range, id.solve().map(|_| ()))
        }
        // The walk: 1e-3 s times the integral of (kappa omega)^2, kappa four times SPHERES'
        // 0.22: about 0.027 a second, so 0.02 ends a window every 0.7 s (about 27 over the
        // 20 s); without the limit: one window.
        let (windows, beyond, _) = run::<IntFloat>(window::MAX_WINDOW_WALK);
        assert!(!beyond, "{windows}");
        assert!(windows > 20, "{windows}");
        assert_eq!(run::<f32>(window::MAX_WINDOW_WALK).0, windows);
        let (one, beyond, _) = run::<IntFloat>(f32::INFINITY);
        assert_eq!((one, beyond), (1, false));
    }
}
