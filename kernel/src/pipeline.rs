//! The per-tick pipeline: one call per gyro sample (the 1 kHz interrupt). Gyro counts and the
//! commanded thruster word in; firing detection, valve-transient skip, the angular-acceleration
//! Kalman filter, the batch over the first two firings, then RLS; estimates and status out.
//!
//! Flow (mirrors the seed's flight code, App. E):
//! * a change of thruster word ends the current firing and, if the new word is non-zero,
//!   starts the next one: the Kalman filter is reset to the nominal prediction and skips the
//!   10 ms valve transient;
//! * firings 1 and 2 contribute their final angular-acceleration estimate (one measurement
//!   each) to the batch, solved when firing 2 ends;
//! * from firing 3 on, every tick with a Kalman update adds an RLS measurement (the current
//!   estimate weighted by its information); the estimate is re-solved (LU) when the firing
//!   ends, after the optional change test and forgetting.

use crate::gyro_filter::{GyroLowPass, LowPassCoefs, COUNT_FRAC_BITS};

const _: () = assert!(
    COUNT_FRAC_BITS == 12,
    "Gyroscopic::omega assumes Q12 counts"
);
pub use crate::deferred_stage::DeferredStage;
use crate::model::{inertia_rows, mat_vec, FiringTerms, ModelError, ModelTerms, SatelliteParams};
use crate::observability::{min_updates_for, Excitation, N_TERMS};
use crate::omega_dot::{
    KfConfig, KfSnapshot, KfStatus, OmegaDotEstimate, OmegaDotKf, GYRO_FILTER_HZ,
};
use crate::rls::{FiringFold, FoldStep};
use crate::rls::{MassId, Measurement, RlsConfig, RlsStatus};
use crate::scalar::{Scalar, Scaled};
use crate::validity::{Invalid, Validity};

/// Pipeline configuration.
#[derive(Clone, Copy, Debug)]
pub struct PipelineConfig<S> {
    /// Kalman-filter constants.
    pub kf: KfConfig,
    /// RLS options.
    pub rls: RlsConfig<S>,
    /// Firings that form the batch (the seed: 2).
    pub batch_firings: u32,
    /// Gyro zero-rate counts per axis. When given, the gyroscopic acceleration
    /// `-I^-1 (omega x I omega)` of the nominal inertia is integrated and taken off the
    /// measured rate, so the Kalman state is the thrust-induced acceleration (as the f64
    /// reference does); `None` = the seed's flight code, which neglects it.
    pub gyro_bias_counts: Option<[f32; 3]>,
    /// Excited Kalman updates a term needs to be observable
    /// ([`crate::observability`]; the reference's 50 ms of samples).
    pub min_excitation_updates: u32,
}

impl<S: Scalar> PipelineConfig<S> {
    /// The seed's settings at sample period `dt_ms`: R0 of Fig. 4.5, P0 = 0.5, 10 ms transient,
    /// batch over two firings, RLS without forgetting or change detection.
    pub fn seed(dt_ms: u32) -> Self {
        PipelineConfig {
            kf: KfConfig::seed(dt_ms),
            rls: RlsConfig::default(),
            batch_firings: 2,
            gyro_bias_counts: None,
            min_excitation_updates: min_updates_for(dt_ms),
        }
    }

    /// [`PipelineConfig::seed`] plus the gyroscopic terms (gyro bias `bias_counts`), the
    /// form the f64 reference's online pipeline runs.
    pub fn with_gyroscopic(dt_ms: u32, bias_counts: [f32; 3]) -> Self {
        PipelineConfig {
            gyro_bias_counts: Some(bias_counts),
            ..Self::seed(dt_ms)
        }
    }
}

/// Overall state, reported every tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum PipelineStatus {
    /// No firing finished yet.
    Idle = 0,
    /// Collecting the batch firings.
    Batch = 1,
    /// Estimates valid, every term observable.
    Ok = 2,
    /// Estimates valid; some terms are held at the nominal model (see the masks).
    PartlyUnobservable = 3,
    /// The information matrix was singular at the last solve; previous estimate kept.
    Singular = 4,
    /// A value did not fit the scalar format at the last solve; previous estimate kept.
    Overflow = 5,
    /// The last solve was not physical (see [`Estimates::invalid`]); previous estimate kept.
    Implausible = 6,
}

/// What happened during one tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickEvent {
    /// Thrusters off (or in a gap), nothing to do.
    Coasting,
    /// Inside the 10 ms valve transient.
    Transient,
    /// Kalman-filter update (and an RLS measurement if past the batch).
    Updated,
    /// A firing ended and the estimate was re-solved (batch or RLS).
    Solved,
    /// The Kalman filter could not form an estimate in this format (sample skipped).
    KfOverflow,
    /// The firing is longer than the Kalman accumulators allow: frozen.
    FiringTooLong,
    /// A gyro sample at a rail (count 0 or 4095): the rest of the firing is not used.
    Railed,
}

/// Per-tick output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TickReport {
    /// What this tick did.
    pub event: TickEvent,
    /// The pipeline's status after the tick.
    pub status: PipelineStatus,
}

/// The whole onboard identification state (fixed size, no allocation).
#[derive(Clone, Copy, Debug)]
pub struct Pipeline<S> {
    cfg: PipelineConfig<S>,
    terms: ModelTerms<S>,
    filter: GyroLowPass,
    gyro: Option<Gyroscopic<S>>,
    filtered: [i32; 3],
    /// The last acceleration estimate of the current run of firings (zero after a coast).
    accel_before: [S; 3],
    /// Filter delay times the gyro scale, counts per rad/s^2, per axis.
    lag_counts: [S; 3],
    /// Half a sample period times the gyro scale, counts per rad/s^2 (trapezoid step).
    half_dt_counts: [S; 3],
    /// Rate change since the word change due to the gyroscopic acceleration, Q12 counts.
    gyro_integral_q12: [i32; 3],
    /// Gyroscopic acceleration at the previous sample of the firing, rad/s^2.
    gyro_prev: [S; 3],
    /// Sample periods since the previous sample of the firing (gaps count).
    gyro_step_ticks: u32,
    kf: OmegaDotKf<S>,
    mass: MassId<S>,
    word: u16,
    firing_terms: FiringTerms<S>,
    firings: u32,
    firings_with_data: u32,
    firing_has_data: bool,
    last: Option<Measurement<S>>,
    last_estimate: Option<OmegaDotEstimate<S>>,
    deferred: Option<Pending>,
    /// The ended firing's fold (valid while `deferred` is `Pending::Fold`).
    fold: FiringFold<S>,
    ended: EndedFiring<S>,
    status: PipelineStatus,
    ticks: u64,
    /// Which terms the current firing's word excites ([`crate::observability`]).
    firing_excites: [bool; N_TERMS],
    excitation: Excitation<S>,
    validity: Validity<S>,
    invalid: Option<Invalid>,
    /// A railed sample ended the current firing's use.
    firing_railed: bool,
    /// The inverse inertia the CoM rows are formed at ([`coupled`]): the estimate, kept
    /// while a change detector re-learns its level.
    trusted_theta: [S; 6],
    counters: DataCounters,
}

/// What the pipeline left out, and why (telemetry; never silently).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DataCounters {
    /// Gyro samples with some axis at a rail (count 0 or 4095).
    pub railed_samples: u32,
    /// Firings cut short (or wholly dropped) at a railed sample.
    pub railed_firings: u32,
    /// Firings whose gyros showed no response to a clearly predicted acceleration: not fitted.
    pub unresponsive_firings: u32,
    /// Sample periods without a sample (telemetry gaps).
    pub gap_ticks: u64,
}

impl<S: Scalar> Pipeline<S> {
    /// A pipeline for `params` (terms derived once here).
    pub fn new(params: &SatelliteParams, cfg: PipelineConfig<S>) -> Result<Self, ModelError> {
        let terms = params.terms::<S>()?;
        let firing_terms = terms.firing_terms(0);
        let gyro = match cfg.gyro_bias_counts {
            Some(bias) => Some(Gyroscopic::new(params, bias)?),
            None => None,
        };
        Ok(Pipeline {
            cfg,
            terms,
            filter: GyroLowPass::new(LowPassCoefs::design(GYRO_FILTER_HZ, cfg.kf.dt_s)),
            gyro,
            filtered: [0; 3],
            accel_before: [S::ZERO; 3],
            lag_counts: core::array::from_fn(|a| {
                let g = cfg.kf.counts_per_rad_s.get(a).copied().unwrap_or(0.0);
                S::from_f32((cfg.kf.delay_ticks * cfg.kf.dt_s * g) as f32)
            }),
            half_dt_counts: core::array::from_fn(|a| {
                let g = cfg.kf.counts_per_rad_s.get(a).copied().unwrap_or(0.0);
                S::from_f32((0.5 * cfg.kf.dt_s * g) as f32)
            }),
            gyro_integral_q12: [0; 3],
            gyro_prev: [S::ZERO; 3],
            gyro_step_ticks: 0,
            kf: OmegaDotKf::new(&cfg.kf),
            mass: MassId::new(cfg.rls, terms.theta_inertia_nominal),
            word: 0,
            firing_terms,
            firings: 0,
            firings_with_data: 0,
            firing_has_data: false,
            last: None,
            last_estimate: None,
            deferred: None,
            fold: FiringFold::new(Measurement::zero(), 0, true, false),
            ended: EndedFiring::empty(firing_terms),
            status: PipelineStatus::Idle,
            ticks: 0,
            firing_excites: [false; N_TERMS],
            excitation: Excitation::new(params, cfg.min_excitation_updates),
            validity: Validity::new(params, &terms.theta_inertia_nominal),
            invalid: None,
            firing_railed: false,
            trusted_theta: terms.theta_inertia_nominal,
            counters: DataCounters::default(),
        })
    }

    /// One sample period with a gyro sample and the commanded thruster word (bit i = thruster i+1).
    pub fn tick(&mut self, gyro_counts: [u16; 3], thrusters: u16) -> TickReport {
        self.step(Some(gyro_counts), thrusters & 0x0fff)
    }

    /// One sample period without a sample (telemetry gap): time advances, the word is unchanged.
    pub fn tick_gap(&mut self) -> TickReport {
        self.counters.gap_ticks = self.counters.gap_ticks.saturating_add(1);
        self.step(None, self.word)
    }

    /// `periods` sample periods without a sample, in O(1) whatever the count: exactly what
    /// `periods` calls of [`Pipeline::tick_gap`] leave behind (the pending end-of-firing work
    /// is run at once, the Kalman filter's clock jumps), in one call. The returned event is
    /// `Solved` if a pending solve completed.
    pub fn tick_gaps(&mut self, periods: u64) -> TickReport {
        if periods == 0 {
            return TickReport {
                event: TickEvent::Coasting,
                status: self.status,
            };
        }
        let solved = self.catch_up();
        self.ticks = self.ticks.saturating_add(periods);
        self.counters.gap_ticks = self.counters.gap_ticks.saturating_add(periods);
        if self.word != 0 {
            self.gyro_step_ticks = self
                .gyro_step_ticks
                .saturating_add(u32::try_from(periods).unwrap_or(u32::MAX));
            self.kf.skip(periods);
        }
        let event = if solved {
            TickEvent::Solved
        } else {
            TickEvent::Coasting
        };
        TickReport {
            event,
            status: self.status,
        }
    }

    /// Counters of the data the pipeline did not use (rails, unresponsive firings, gaps).
    pub fn data_counters(&self) -> DataCounters {
        self.counters
    }

    fn step(&mut self, gyro: Option<[u16; 3]>, word: u16) -> TickReport {
        self.ticks = self.ticks.saturating_add(1);
        let mut solved = self.run_deferred();
        let railed = gyro.is_some_and(|c| c.iter().any(|&v| v == 0 || v >= RAIL_COUNT));
        if railed {
            self.counters.railed_samples = self.counters.railed_samples.saturating_add(1);
        }
        let filtered = gyro.map(|c| self.filter.step(c));
        if let Some(f) = filtered {
            self.filtered = f;
        }
        let mut changed = false;
        if word != self.word {
            // A fold the previous firing left unfinished is completed here; its solve is
            // this tick's event.
            solved |= self.end_firing();
            self.word = word;
            if word != 0 {
                changed = true;
                self.firings = self.firings.saturating_add(1);
                self.firing_has_data = false;
                self.firing_railed = false;
                self.firing_terms = self.terms.firing_terms(word);
                self.firing_excites = self.excitation.excited_by(&self.firing_terms);
                let prior = self.nominal_omega_dot();
                // Extrapolate the lagging filtered rate by the previous firing's acceleration.
                let offset: [i32; 3] = core::array::from_fn(|a| {
                    let acc = self.accel_before.get(a).copied().unwrap_or(S::ZERO);
                    let lag = self.lag_counts.get(a).copied().unwrap_or(S::ZERO);
                    let q = acc
                        .times(lag)
                        .floor_times(1 << COUNT_FRAC_BITS)
                        .unwrap_or(0);
                    i32::try_from(q).unwrap_or(0)
                });
                self.kf.reset_with_offset(prior, offset);
                self.accel_before = [S::ZERO; 3];
                self.gyro_integral_q12 = [0; 3];
                self.gyro_step_ticks = 0;
                self.last = None;
                self.last_estimate = None;
                if self.status == PipelineStatus::Idle {
                    self.status = PipelineStatus::Batch;
                }
            }
        }
        let event = if self.word == 0 {
            self.accel_before = [S::ZERO; 3];
            TickEvent::Coasting
        } else if railed || self.firing_railed {
            // A railed sample and everything after it in this firing stay out of the filter
            // (the low-pass filter carries the rail value for a while): the firing is cut here.
            if !self.firing_railed {
                self.firing_railed = true;
                self.counters.railed_firings = self.counters.railed_firings.saturating_add(1);
            }
            TickEvent::Railed
        } else {
            self.gyro_step_ticks = self.gyro_step_ticks.saturating_add(1);
            let measured = filtered.map(|f| self.remove_gyroscopic(f, changed));
            match self.kf.update(measured) {
                KfStatus::Skipping => TickEvent::Transient,
                KfStatus::Anchored | KfStatus::Missing => TickEvent::Coasting,
                KfStatus::Saturated => TickEvent::FiringTooLong,
                KfStatus::Updated => self.after_kf_update(),
            }
        };
        let event = if solved { TickEvent::Solved } else { event };
        TickReport {
            event,
            status: self.status,
        }
    }

    /// The Kalman state is the thrust-induced acceleration `I^-1 tau`, constant during a
    /// firing as eq. 3.12 assumes; the gyroscopic part `-I^-1 (omega x I omega)` grows with
    /// the rate, so its integral since the change (nominal inertia, trapezoid, kept in Q12
    /// counts) is taken off the measured rate (as the f64 reference does). Without the
    /// gyroscopic option the measurement is the filtered rate itself.
    fn remove_gyroscopic(&mut self, filtered: [i32; 3], first: bool) -> [i32; 3] {
        let Some(g) = &self.gyro else { return filtered };
        let gt = g.torque_cnm(&filtered);
        let accel = mat_vec(
            &self.terms.theta_inertia_matrix,
            &[gt[0].negate(), gt[1].negate(), gt[2].negate()],
        );
        if !first {
            let steps = self.gyro_step_ticks.max(1);
            for a in 0..3 {
                let (Some(prev), Some(now), Some(c), Some(acc)) = (
                    self.gyro_prev.get(a).copied(),
                    accel.get(a).copied(),
                    self.half_dt_counts.get(a).copied(),
                    self.gyro_integral_q12.get_mut(a),
                ) else {
                    continue;
                };
                // (prev + now)/2 dt g counts, rounded to the nearest Q12 step.
                let twice = prev
                    .plus(now)
                    .times(c)
                    .floor_times(steps.saturating_mul(2 << COUNT_FRAC_BITS))
                    .unwrap_or(0);
                let inc = twice.saturating_add(1).div_euclid(2);
                *acc = acc.saturating_add(i32::try_from(inc).unwrap_or(0));
            }
        }
        self.gyro_prev = accel;
        self.gyro_step_ticks = 0;
        core::array::from_fn(|a| {
            filtered
                .get(a)
                .copied()
                .unwrap_or(0)
                .saturating_sub(self.gyro_integral_q12.get(a).copied().unwrap_or(0))
        })
    }

    /// Nominal torque of the current word, cN m (the regressors are taken at zero rate: the
    /// Kalman estimate is the thrust-induced acceleration).
    fn effective_torque_cnm(&self) -> [S; 3] {
        self.firing_terms.torque_cnm
    }

    fn nominal_omega_dot(&self) -> [S; 3] {
        mat_vec(
            &self.terms.theta_inertia_matrix,
            &self.effective_torque_cnm(),
        )
    }

    fn after_kf_update(&mut self) -> TickEvent {
        // Per sample only the Kalman filter's integer sums move (in `OmegaDotKf::update`):
        // the firing's per-sample RLS measurements are folded in, in aggregate, when it ends.
        if !self.firing_has_data {
            self.firing_has_data = true;
            self.firings_with_data = self.firings_with_data.saturating_add(1);
        }
        TickEvent::Updated
    }

    /// Folds the ending firing in (its stages run on the next ticks, [`Pipeline::run_deferred`]);
    /// an earlier firing's fold still pending is completed first. Returns true if that
    /// completed a solve.
    fn end_firing(&mut self) -> bool {
        if self.word == 0 || !self.firing_has_data {
            return false;
        }
        let solved = self.catch_up();
        // Only what the next firing's reset needs is computed now: the acceleration to
        // extrapolate the lagging filtered rate. The rest works on a copy of the filter.
        if let Some(x) = self.kf.omega_dot() {
            self.accel_before = x;
        }
        let n = self.firings_with_data;
        self.ended.kf = self.kf.snapshot();
        self.ended.terms = self.firing_terms;
        self.ended.excites = self.firing_excites;
        self.ended.batch = n <= self.cfg.batch_firings;
        self.ended.batch_complete = n == self.cfg.batch_firings;
        self.deferred = Some(Pending::Measure);
        solved
    }

    /// Runs one stage of a firing's deferred work per tick ([`DeferredStage`]: final estimate,
    /// aggregate, CoM add, inverse-inertia add planned and applied, change test in two parts,
    /// merges with the CoM solve, inverse-inertia factorisation and solve), so no tick carries
    /// more than one of them. At 1 kHz a firing with data spans at least 12 ticks (anchor
    /// sample, 10 ms transient, one update): room for the 11 stages of an RLS firing with the
    /// change detector (9 without it, 8 for a batch firing); if the next one ends earlier (slower
    /// sampling has no transient skip, or at `finish`), the stages are caught up at once.
    /// Returns true when a solve completed.
    fn run_deferred(&mut self) -> bool {
        let Some(stage) = self.deferred else {
            return false;
        };
        // The stage's data stays in `self.ended` (fixed slots: a stage moves no large value).
        let e = &mut self.ended;
        let mut next = None;
        let mut solved = false;
        match stage {
            Pending::Measure => {
                // The firing's final estimate (detector measurement, telemetry) ...
                if let Some(est) = self.kf.estimate_of(&e.kf) {
                    self.last_estimate = Some(est);
                    let torque_firing = e.excites.iter().skip(3).any(|x| *x);
                    if torque_firing && unresponsive(&e.terms.omega_dot_nominal, &est) {
                        // The gyros did not move although the model predicts a clear
                        // acceleration (a dead gyro, a disconnected valve): fitting this
                        // firing would drive the inertia towards infinity. Not fitted; counted.
                        self.counters.unresponsive_firings =
                            self.counters.unresponsive_firings.saturating_add(1);
                        self.firings_with_data = self.firings_with_data.saturating_sub(1);
                    } else {
                        if self.mass.in_control() {
                            self.trusted_theta = self.mass.theta_inertia;
                        }
                        let (theta, a_com) = coupled(&e.terms, &self.trusted_theta);
                        e.theta = theta;
                        e.last = measurement_for(&theta, &e.terms, &a_com, &est);
                        next = Some(Pending::Aggregate);
                    }
                }
            }
            Pending::Aggregate => {
                // ... and its per-sample measurements in aggregate (exact: every sample of the
                // firing has the same regressor).
                if let Some((weight, mean)) = self.kf.aggregate_of(&e.kf) {
                    let pred = mat_vec(&e.theta, &e.terms.torque_cnm);
                    let one = Scaled::from_i64(1);
                    let variance = weight.map(|w| one.over(w).unwrap_or(one));
                    let agg = Measurement {
                        b_com: [
                            mean[0].minus(pred[0]),
                            mean[1].minus(pred[1]),
                            mean[2].minus(pred[2]),
                        ],
                        b_inertia: mean,
                        weight,
                        variance,
                        ..e.last
                    };
                    // The firing counts into the observability, then the terms it leaves
                    // unexcited are held in the fold's solves.
                    self.excitation.add(&e.excites, e.kf.sums.n);
                    let (c, i) = self.excitation.unobservable();
                    self.mass.hold_unexcited(c, i);
                    self.fold = FiringFold::new(agg, e.kf.sums.n, e.batch, e.batch_complete);
                    next = Some(Pending::Fold);
                }
            }
            Pending::Fold => match self.step_fold() {
                FoldStep::Pending => next = Some(Pending::Fold),
                FoldStep::Done(Some(solved_fold)) => {
                    self.status = self.accept(solved_fold.status, &solved_fold.before);
                    solved = true;
                }
                FoldStep::Done(None) => {}
            },
        }
        self.deferred = next;
        solved
    }

    /// One stage of the fold. A detected change (a covariance reset) also restarts the
    /// observability count: what the flight excited before the change says nothing about the
    /// new mass properties, so every term is held at the model, with the prior's uncertainty,
    /// until the flight has excited it again (instead of keeping a pre-change value under a
    /// standard error that only data about the new configuration could justify).
    fn step_fold(&mut self) -> FoldStep<S> {
        let resets = self.mass.resets;
        let step = self.fold.step(&mut self.mass);
        if self.mass.resets != resets {
            self.excitation.restart();
            let (c, i) = self.excitation.unobservable();
            self.mass.hold_unexcited(c, i);
        }
        step
    }

    /// The status after a solve with result `s`; a solved estimate that is not physical
    /// ([`crate::validity`]) is replaced by `before` (the estimate the solve started from).
    fn accept(&mut self, s: RlsStatus, before: &crate::rls::EstimateState<S>) -> PipelineStatus {
        if matches!(s, RlsStatus::Ok | RlsStatus::PartlyUnobservable) {
            if let Err(why) = self
                .validity
                .check(&self.mass.theta_inertia, &self.mass.delta_com_m)
            {
                self.mass.restore(before);
                self.invalid = Some(why);
                return PipelineStatus::Implausible;
            }
            self.invalid = None;
        }
        self.status_after(s)
    }

    /// The pipeline status after a solve with result `s` (no data: unchanged).
    fn status_after(&self, s: RlsStatus) -> PipelineStatus {
        match s {
            RlsStatus::Ok => PipelineStatus::Ok,
            RlsStatus::PartlyUnobservable => PipelineStatus::PartlyUnobservable,
            RlsStatus::Singular => PipelineStatus::Singular,
            RlsStatus::Overflow => PipelineStatus::Overflow,
            RlsStatus::NoData => self.status,
        }
    }

    /// Runs every pending stage now.
    fn catch_up(&mut self) -> bool {
        let mut solved = false;
        for _ in 0..DEFERRED_STAGES {
            if self.deferred.is_none() {
                break;
            }
            solved |= self.run_deferred();
        }
        solved
    }

    /// Ends the current firing (if any) as if the thrusters had turned off, e.g. at the end
    /// of a recording, so its data is folded in.
    pub fn finish(&mut self) -> PipelineStatus {
        let mut solved = self.catch_up();
        solved |= self.end_firing();
        solved |= self.catch_up();
        if !solved && self.firings_with_data > 0 && self.firings_with_data < self.cfg.batch_firings
        {
            // Fewer firings than the batch needs: the batch so far is the estimate.
            let before = self.mass.estimate();
            let s = self.mass.solve();
            self.status = self.accept(s, &before);
        }
        self.word = 0;
        self.firing_has_data = false;
        self.status
    }

    /// The current estimates (in kernel units).
    pub fn estimates(&self) -> Estimates<S> {
        Estimates {
            delta_com_m: self.mass.delta_com_m,
            theta_inertia: self.mass.theta_inertia,
            unobservable_com: self.mass.unobservable_com,
            unobservable_inertia: self.mass.unobservable_inertia,
            status: self.status,
            updates: self.mass.updates,
            firings: self.firings,
            resets: self.mass.resets,
            invalid: self.invalid,
            data: self.counters,
        }
    }

    /// The latest angular-acceleration estimate of the current firing.
    pub fn omega_dot(&self) -> Option<OmegaDotEstimate<S>> {
        if self.word != 0 && self.kf.updates() > 0 {
            self.kf.estimate()
        } else {
            self.last_estimate
        }
    }

    /// The deferred end-of-firing stage the next tick will run, if any (telemetry: the
    /// fold's own stage once it has started).
    pub fn pending_stage(&self) -> Option<DeferredStage> {
        match self.deferred? {
            Pending::Measure => Some(DeferredStage::Measure),
            Pending::Aggregate => Some(DeferredStage::Aggregate),
            Pending::Fold => self.fold.stage(),
        }
    }

    /// The angular-acceleration Kalman filter (its exact sums, for tests and range analysis).
    pub fn kalman(&self) -> &OmegaDotKf<S> {
        &self.kf
    }

    /// The identification state (covariances, information).
    pub fn mass_id(&self) -> &MassId<S> {
        &self.mass
    }

    /// The derived model terms.
    pub fn model_terms(&self) -> &ModelTerms<S> {
        &self.terms
    }
}

/// Gyro counts at or above this (or at 0) are at a rail (12-bit ADC).
pub const RAIL_COUNT: u16 = 4095;

/// True when a firing's final estimate `est` shows no response to its nominal acceleration
/// (asked only of firings whose torque excites an inertia term, so the prediction is at
/// least half a single thruster's)
/// `nominal`: the prediction is clear (its squared size over the estimate's variance, summed
/// over the axes, above 100: 10 sigma) and the measured acceleration along it is below an
/// eighth of it (so a model up to 8 times off in inertia still identifies).
fn unresponsive<S: Scalar>(nominal: &[S; 3], est: &OmegaDotEstimate<S>) -> bool {
    let mut significance = Scaled::zero();
    let mut along = S::ZERO;
    let mut size = S::ZERO;
    for ((p, x), info) in nominal
        .iter()
        .zip(est.omega_dot.iter())
        .zip(est.information.iter())
    {
        let ps = Scaled { m: *p, e: 0 }.normalized();
        significance = significance.plus(ps.times(ps).times(*info));
        along = along.mul_add(*p, *x);
        size = size.mul_add(*p, *p);
    }
    // Compared in block floating point: the significance can be far beyond the format.
    let clear = S::ZERO.lt(significance.minus(Scaled::from_i64(100)).m);
    clear && along.lt(size.mul_pow2(-3))
}

/// A firing's CoM rows at the current inverse-inertia estimate `theta`: `J [F]x` instead of
/// the seed's `I_nom^-1 [F]x` (eq. 3.7). With the model's inertia, a CoM shift that comes with
/// more inertia (the demo's proof mass: +7-9 %) was estimated short by that ratio (-3.97 mm
/// for a -4.47 mm shift); with the estimate, -4.45 mm. The inverse-inertia rows keep the
/// torque about the model's CoM: taking it about the estimated CoM was tried and made the
/// translations' inertia rows borrow their information from the CoM estimate itself (Izz
/// 1.8 % off and the CoM 0.15 mm past the shift on the demo). Returns the inverse inertia as
/// a matrix (rad/s^2 per cN m) and the CoM rows (rad/s^2 per m).
fn coupled<S: Scalar>(ft: &FiringTerms<S>, theta: &[S; 6]) -> ([[S; 3]; 3], [[S; 3]; 3]) {
    let [xx, yy, zz, xy, xz, yz] = *theta;
    let j = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
    let [fx, fy, fz] = ft.force_n;
    let hundred = S::from_int_pow2(100, 0);
    // J is per cN m: J [F]x per m is 100 J [F]x.
    let cx = [
        [S::ZERO, fz.negate(), fy],
        [fz, S::ZERO, fx.negate()],
        [fy.negate(), fx, S::ZERO],
    ];
    let mut a_com = [[S::ZERO; 3]; 3];
    for (out_row, j_row) in a_com.iter_mut().zip(j.iter()) {
        for (col, out) in out_row.iter_mut().enumerate() {
            let acc = j_row
                .iter()
                .zip(cx.iter())
                .fold(S::ZERO, |acc, (jv, cx_row)| {
                    acc.mul_add(*jv, cx_row.get(col).copied().unwrap_or(S::ZERO))
                });
            *out = acc.times(hundred);
        }
    }
    (j, a_com)
}

/// The measurement of one angular-acceleration estimate for a firing's regressors
/// (seed eqs 3.5-3.8; rows at zero rate, see `Pipeline::remove_gyroscopic`).
fn measurement_for<S: Scalar>(
    theta: &[[S; 3]; 3],
    ft: &FiringTerms<S>,
    a_com: &[[S; 3]; 3],
    est: &OmegaDotEstimate<S>,
) -> Measurement<S> {
    let pred = mat_vec(theta, &ft.torque_cnm);
    let mut b_com = [S::ZERO; 3];
    for ((b, w), n) in b_com.iter_mut().zip(est.omega_dot.iter()).zip(pred.iter()) {
        *b = w.minus(*n);
    }
    Measurement {
        a_com: *a_com,
        b_com,
        a_inertia: inertia_rows(&ft.torque_cnm),
        b_inertia: est.omega_dot,
        weight: est.information,
        variance: est.variance,
    }
}

/// How many end-of-firing stages there are (the most [`Pipeline::run_deferred`] can have pending).
const DEFERRED_STAGES: usize = 2 + crate::rls::STAGES;

/// The end-of-firing work still to run: the firing's final estimate, its aggregate, then its
/// [`FiringFold`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pending {
    Measure,
    Aggregate,
    Fold,
}

/// The ended firing's data that its pre-fold stages read and write.
#[derive(Clone, Copy, Debug)]
struct EndedFiring<S> {
    /// Snapshot of the firing's Kalman sums.
    kf: KfSnapshot<S>,
    /// Its model terms.
    terms: FiringTerms<S>,
    /// The terms its word excites.
    excites: [bool; N_TERMS],
    /// The inverse inertia its measurement was formed with (the estimate at its end).
    theta: [[S; 3]; 3],
    /// Its final estimate as a measurement (the aggregate takes its regressors).
    last: Measurement<S>,
    /// One of the batch firings.
    batch: bool,
    /// The last batch firing.
    batch_complete: bool,
}

impl<S: Scalar> EndedFiring<S> {
    fn empty(terms: FiringTerms<S>) -> Self {
        let m = Measurement::zero();
        EndedFiring {
            kf: KfSnapshot {
                prior: [S::ZERO; 3],
                sums: Default::default(),
                second: Default::default(),
            },
            terms,
            excites: [false; N_TERMS],
            theta: [[S::ZERO; 3]; 3],
            last: m,
            batch: false,
            batch_complete: false,
        }
    }
}

/// The gyroscopic torque `omega x (I_nom omega)` from filtered gyro counts.
#[derive(Clone, Copy, Debug)]
struct Gyroscopic<S> {
    /// Zero-rate counts in Q12.
    bias_q12: [i32; 3],
    /// rad/s per 2^11 counts (counts are scaled by 2^-11 first so they fit every format).
    rad_s_per_2k_counts: [S; 3],
    /// Nominal inertia in cN m per rad/s^2 (i.e. kg m^2 * 100).
    inertia_c: [[S; 3]; 3],
}

impl<S: Scalar> Gyroscopic<S> {
    fn new(params: &SatelliteParams, bias: [f32; 3]) -> Result<Self, ModelError> {
        if !bias
            .iter()
            .chain(params.gyro_counts_per_rad_s.iter())
            .all(|v| v.is_finite())
        {
            return Err(ModelError::NotFinite);
        }
        let q = (1u32 << COUNT_FRAC_BITS) as f32;
        let [xx, yy, zz, xy, xz, yz] = params.inertia_kgm2.map(|v| S::from_f32(v * 100.0));
        Ok(Gyroscopic {
            bias_q12: bias.map(|b| (b * q) as i32),
            rad_s_per_2k_counts: params
                .gyro_counts_per_rad_s
                .map(|g| S::from_f32(if g != 0.0 { 2048.0 / g } else { 0.0 })),
            inertia_c: [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]],
        })
    }

    fn omega(&self, filtered_q12: &[i32; 3]) -> [S; 3] {
        core::array::from_fn(|a| {
            let c = filtered_q12.get(a).copied().unwrap_or(0);
            let b = self.bias_q12.get(a).copied().unwrap_or(0);
            let d = c.saturating_sub(b);
            // counts / 2048 (Q12 counts: a further 2^-12)
            let scaled = S::from_int_pow2(d, -23); // 2^-12 (Q12) * 2^-11
            scaled.times(self.rad_s_per_2k_counts.get(a).copied().unwrap_or(S::ZERO))
        })
    }

    fn torque_cnm(&self, filtered_q12: &[i32; 3]) -> [S; 3] {
        let w = self.omega(filtered_q12);
        let h = mat_vec(&self.inertia_c, &w);
        [
            w[1].times(h[2]).minus(w[2].times(h[1])),
            w[2].times(h[0]).minus(w[0].times(h[2])),
            w[0].times(h[1]).minus(w[1].times(h[0])),
        ]
    }
}

/// Estimates in kernel units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimates<S> {
    /// CoM offset from the model's CoM, m.
    pub delta_com_m: [S; 3],
    /// Inverse-inertia parameters xx yy zz xy xz yz, 1/(kg m^2)/100.
    pub theta_inertia: [S; 6],
    /// CoM terms held at the model (unobservable so far).
    pub unobservable_com: [bool; 3],
    /// Inverse-inertia terms held at the model.
    pub unobservable_inertia: [bool; 6],
    /// Pipeline status.
    pub status: PipelineStatus,
    /// Measurement updates folded in.
    pub updates: u32,
    /// Firings seen.
    pub firings: u32,
    /// Covariance resets by the change detector.
    pub resets: u32,
    /// Why the last solve was rejected (status [`PipelineStatus::Implausible`]).
    pub invalid: Option<Invalid>,
    /// Data left out: railed samples and firings, unresponsive firings, gap ticks.
    pub data: DataCounters,
}

impl<S: Scalar> Estimates<S> {
    /// CoM offset in mm (reporting).
    pub fn com_offset_mm(&self) -> [f64; 3] {
        self.delta_com_m.map(|v| f64::from(v.to_f32()) * 1e3)
    }

    /// Inverse inertia matrix, 1/(kg m^2) (reporting).
    pub fn inertia_inverse(&self) -> [[f64; 3]; 3] {
        let t = self.theta_inertia.map(|v| f64::from(v.to_f32()) * 100.0);
        let [xx, yy, zz, xy, xz, yz] = t;
        [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
    }

    /// Inertia xx yy zz xy xz yz, kg m^2 (reporting; `None` if the inverse is singular).
    pub fn inertia_kgm2(&self) -> Option<[f64; 6]> {
        let j = self.inertia_inverse();
        let p = SatelliteParams {
            inertia_kgm2: [j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]].map(|v| v as f32),
            ..crate::model::SPH2
        };
        // Reuse the adjugate inverse (f64) on the f32-rounded parameters: exact enough for reports.
        let _ = p;
        invert3(&j).map(|m| [m[0][0], m[1][1], m[2][2], m[0][1], m[0][2], m[1][2]])
    }
}

/// 3x3 inverse by the adjugate (f64, reporting only).
pub fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    let c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    let c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    let det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if !det.is_finite() || det == 0.0 {
        return None;
    }
    let c10 = m[0][2] * m[2][1] - m[0][1] * m[2][2];
    let c11 = m[0][0] * m[2][2] - m[0][2] * m[2][0];
    let c12 = m[0][1] * m[2][0] - m[0][0] * m[2][1];
    let c20 = m[0][1] * m[1][2] - m[0][2] * m[1][1];
    let c21 = m[0][2] * m[1][0] - m[0][0] * m[1][2];
    let c22 = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    Some([
        [c00 / det, c10 / det, c20 / det],
        [c01 / det, c11 / det, c21 / det],
        [c02 / det, c12 / det, c22 / det],
    ])
}
