//! What the identification reads from a recording: sample times, measured rates, the command
//! held from each sample to the next, and the runs of samples the fit uses (what each interval
//! between two samples delivered is [`super::intervals`]). Format-independent: v1 (gyro
//! counts) and v2 (rad/s) both land here, stored compactly (a few tens of bytes a sample).
use crate::rate_recording::{Commands, RateRecording};
use crate::recording::Recording;
use crate::satellite::Satellite;
use std::cell::Cell;

/// One sample's command, held until the next sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Thruster word, bit i = thruster i+1 open.
    Word(u16),
    /// Body force (N) and torque about the model's CoM (N m).
    Wrench { force: [f64; 3], torque: [f64; 3] },
}

/// The command of every sample, stored once per run of equal commands: a recording holds each
/// command over many samples (a 1 kHz recording of 5-50 Hz control), so this is a few bytes a
/// sample where a `Vec<Command>` was 56 (560 MB at 10^7 samples).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CommandLog {
    /// First sample of each run.
    starts: Vec<usize>,
    /// Each run's command.
    runs: Vec<Command>,
    len: usize,
}

impl CommandLog {
    /// Appends the next sample's command.
    pub fn push(&mut self, c: Command) {
        if self.runs.last() != Some(&c) {
            self.starts.push(self.len);
            self.runs.push(c);
        }
        self.len += 1;
    }

    /// Samples.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if no sample has a command.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Sample `i`'s command.
    pub fn get(&self, i: usize) -> Option<&Command> {
        if i >= self.len {
            return None;
        }
        let run = self.starts.partition_point(|&s| s <= i).checked_sub(1)?;
        self.runs.get(run)
    }

    /// Sample `i`'s command, starting the search at run `hint` (updated): sequential reads
    /// cost no search.
    pub fn get_near(&self, i: usize, hint: &Cell<usize>) -> Option<&Command> {
        if i >= self.len {
            return None;
        }
        let covers = |r: usize| {
            self.starts.get(r).is_some_and(|&s| s <= i)
                && self.starts.get(r + 1).is_none_or(|&e| i < e)
        };
        let h = hint.get();
        let run = if covers(h) {
            h
        } else if covers(h + 1) {
            h + 1
        } else {
            self.starts.partition_point(|&s| s <= i).checked_sub(1)?
        };
        hint.set(run);
        self.runs.get(run)
    }

    /// Every sample's command, in order.
    pub fn iter(&self) -> impl Iterator<Item = &Command> + '_ {
        self.runs.iter().enumerate().flat_map(move |(r, c)| {
            let end = self.starts.get(r + 1).copied().unwrap_or(self.len);
            std::iter::repeat_n(c, end - self.starts[r])
        })
    }
}

impl FromIterator<Command> for CommandLog {
    fn from_iter<I: IntoIterator<Item = Command>>(iter: I) -> Self {
        let mut log = CommandLog::default();
        for c in iter {
            log.push(c);
        }
        log
    }
}

impl From<Vec<Command>> for CommandLog {
    fn from(v: Vec<Command>) -> Self {
        v.into_iter().collect()
    }
}

impl<'a> IntoIterator for &'a CommandLog {
    type Item = &'a Command;
    type IntoIter = Box<dyn Iterator<Item = &'a Command> + 'a>;
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

/// The measured rate of every sample, rad/s (NaN where missing or unmeasured). A v1
/// recording's gyro counts stay counts, 6 bytes a sample instead of 24, and are converted when
/// read, through a table of the model's conversion for each of the 4,096 counts (the values
/// [`Satellite::gyro_counts_to_rad_s`] gives; 0 and 4,095 are saturated, so missing).
#[derive(Clone, Debug)]
pub enum Rates {
    RadS(Vec<[f64; 3]>),
    Counts {
        counts: Vec<[u16; 3]>,
        table: Box<[[f64; COUNTS]; 3]>,
    },
}

/// Gyro counts of a 12-bit converter.
const COUNTS: usize = crate::recording::MAX_COUNT as usize + 1;

impl Rates {
    /// Samples.
    pub fn len(&self) -> usize {
        match self {
            Rates::RadS(v) => v.len(),
            Rates::Counts { counts, .. } => counts.len(),
        }
    }

    /// True if there is no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `k`'s rate (NaN on every axis past the end).
    pub fn at(&self, k: usize) -> [f64; 3] {
        match self {
            Rates::RadS(v) => v.get(k).copied().unwrap_or([f64::NAN; 3]),
            Rates::Counts { counts, table } => counts.get(k).map_or([f64::NAN; 3], |c| {
                std::array::from_fn(|a| {
                    table[a].get(usize::from(c[a])).copied().unwrap_or(f64::NAN)
                })
            }),
        }
    }

    /// Every sample's rate, in order.
    pub fn iter(&self) -> impl Iterator<Item = [f64; 3]> + '_ {
        (0..self.len()).map(|k| self.at(k))
    }

    /// The rates in rad/s, as a new vector.
    pub fn to_rad_s(&self) -> Vec<[f64; 3]> {
        self.iter().collect()
    }

    /// The rates to change in place, if they are held in rad/s (None for gyro counts: assign
    /// `to_rad_s()` changed instead).
    pub fn rad_s_mut(&mut self) -> Option<&mut Vec<[f64; 3]>> {
        match self {
            Rates::RadS(v) => Some(v),
            Rates::Counts { .. } => None,
        }
    }
}

impl From<Vec<[f64; 3]>> for Rates {
    fn from(v: Vec<[f64; 3]>) -> Self {
        Rates::RadS(v)
    }
}

/// A v2 recording's commands as the identification reads them: a wrench's absent components
/// are zero.
fn command_log(commands: &Commands) -> CommandLog {
    match commands {
        Commands::Thrusters { words, .. } => words.iter().map(|&w| Command::Word(w)).collect(),
        Commands::Wrench { values, .. } => values
            .iter()
            .map(|v| {
                let z = |x: f64| if x.is_finite() { x } else { 0.0 };
                Command::Wrench {
                    force: [z(v[0]), z(v[1]), z(v[2])],
                    torque: [z(v[3]), z(v[4]), z(v[5])],
                }
            })
            .collect(),
    }
}

/// A flight as the identification sees it.
#[derive(Clone, Debug)]
pub struct Flight {
    /// Sample times, s, strictly increasing.
    pub time_s: Vec<f64>,
    /// Measured rates, rad/s; NaN where missing (or on an unmeasured axis).
    pub rate: Rates,
    /// Which axes are measured.
    pub axes: [bool; 3],
    /// Command of each sample.
    pub commands: CommandLog,
    /// Nominal sample period, s (a step over 1.5 of it is a gap).
    pub period_s: f64,
    /// Whether the rates are 12-bit gyro counts converted (v1), which fixes the sensor
    /// response to a point sample.
    pub from_gyro_counts: bool,
}

/// Why a recording cannot be identified (before any fitting).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FlightError {
    #[error("{0}")]
    Invalid(String),
}

impl Flight {
    /// A v1 recording: counts to rad/s with the model's bias and scale; saturated counts (0 or
    /// 4095) are missing samples.
    pub fn from_v1(rec: &Recording, sat: &Satellite) -> Flight {
        let table = Box::new(std::array::from_fn(|a| {
            std::array::from_fn(|c| {
                if c == 0 || c >= usize::from(crate::recording::MAX_COUNT) {
                    f64::NAN
                } else {
                    sat.gyro_counts_to_rad_s(a, c as f64)
                }
            })
        }));
        let rate = Rates::Counts {
            counts: rec.samples.iter().map(|s| s.gyro).collect(),
            table,
        };
        Flight {
            time_s: rec
                .samples
                .iter()
                .map(|s| s.time_ms as f64 * 1e-3)
                .collect(),
            rate,
            axes: [true; 3],
            commands: rec
                .samples
                .iter()
                .map(|s| Command::Word(s.thrusters))
                .collect(),
            period_s: rec.sample_period_ms() as f64 * 1e-3,
            from_gyro_counts: true,
        }
    }

    /// A v2 recording (rates in rad/s). A wrench's absent components are zero.
    pub fn from_v2(rec: &RateRecording) -> Flight {
        let commands = command_log(&rec.commands);
        Flight {
            time_s: rec.time_ms.iter().map(|&t| t as f64 * 1e-3).collect(),
            rate: rec.rate.clone().into(),
            axes: rec.axes,
            commands,
            period_s: 1.0 / rec.sample_rate_hz(),
            from_gyro_counts: false,
        }
    }

    /// [`Flight::from_v2`], taking the recording over: its rates are moved, not copied, and
    /// its rows freed as they are converted (a 10^7-row recording is 240 MB of rates).
    pub fn from_v2_owned(rec: RateRecording) -> Flight {
        let period_s = 1.0 / rec.sample_rate_hz();
        let RateRecording {
            time_ms,
            rate,
            axes,
            commands,
            ..
        } = rec;
        let time_s: Vec<f64> = time_ms.iter().map(|&t| t as f64 * 1e-3).collect();
        drop(time_ms);
        let commands = command_log(&commands);
        Flight {
            time_s,
            rate: rate.into(),
            axes,
            commands,
            period_s,
            from_gyro_counts: false,
        }
    }

    /// Checks the flight against the model: lengths agree, times increase, thruster words
    /// name only the model's thrusters.
    pub fn check(&self, sat: &Satellite) -> Result<(), FlightError> {
        let n = self.time_s.len();
        if self.rate.len() != n || self.commands.len() != n {
            return Err(FlightError::Invalid(format!(
                "{} times, {} rate rows and {} commands: lengths differ",
                n,
                self.rate.len(),
                self.commands.len()
            )));
        }
        if !(self.period_s.is_finite() && self.period_s > 0.0) {
            return Err(FlightError::Invalid(format!(
                "sample period {} s: must be positive",
                self.period_s
            )));
        }
        if let Some(k) = (1..n).find(|&k| self.time_s[k] <= self.time_s[k - 1]) {
            return Err(FlightError::Invalid(format!(
                "sample {k}: time does not increase"
            )));
        }
        let mask = sat.word_mask();
        if let Some((k, w)) = self.commands.iter().enumerate().find_map(|(k, c)| match c {
            Command::Word(w) if w & !mask != 0 => Some((k, *w)),
            _ => None,
        }) {
            return Err(FlightError::Invalid(format!(
                "sample {k}: thruster word {w:#x} names a thruster the {}-thruster model does not have",
                sat.n_thrusters()
            )));
        }
        Ok(())
    }
}

/// Runs of consecutive samples the fit uses: every measured axis present, steps within 1.5
/// nominal periods, and with `cut_at_changes` no command change inside (an interval whose
/// word changes ends a run; the next starts after it). Each run gets its own initial rate.
/// Runs shorter than `min_len` are dropped.
pub fn windows(flight: &Flight, min_len: usize, cut_at_changes: bool) -> Vec<(usize, usize)> {
    let n = flight.time_s.len();
    let valid = |k: usize| {
        let r = flight.rate.at(k);
        (0..3).all(|a| !flight.axes[a] || r[a].is_finite())
    };
    let joins = |k: usize| {
        flight.time_s[k] - flight.time_s[k - 1] <= 1.5 * flight.period_s
            && !(cut_at_changes && flight.commands.get(k) != flight.commands.get(k - 1))
    };
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for k in 0..=n {
        let keep = k < n && valid(k) && start.is_none_or(|_| joins(k));
        match (start, keep) {
            (None, true) => start = Some(k),
            (Some(s), false) => {
                if k - s >= min_len {
                    out.push((s, k));
                }
                start = if k < n && valid(k) { Some(k) } else { None };
            }
            _ => {}
        }
    }
    out
}

/// `wins` with every window that turns the craft through more than `max_turn_rad` (the
/// integral of the measured rate's magnitude) split into runs of equal turn, each with its own
/// initial rate (the one interval between two runs is left out). An output-error fit
/// integrates a window from its initial rate; a 3-D craft's gyroscopic coupling turns a small
/// error of the model into a phase error that grows with the angle turned, until
/// Gauss-Newton's linearisation fails (measured in [`super::MAX_TURN_3D_RAD`]'s note).
/// No run is made shorter than `min_len` samples, and an interval that turns through several
/// runs' worth (a rate spike) makes one cut, not one per run.
pub fn split_turns(
    flight: &Flight,
    wins: &[(usize, usize)],
    max_turn_rad: f64,
    min_len: usize,
) -> Vec<(usize, usize)> {
    let turn_of = |k: usize| {
        let r = flight.rate.at(k);
        let dt = flight.time_s[k + 1] - flight.time_s[k];
        let w2: f64 = (0..3)
            .filter(|&a| flight.axes[a] && r[a].is_finite())
            .map(|a| r[a] * r[a])
            .sum();
        w2.sqrt() * dt
    };
    let mut out = Vec::with_capacity(wins.len());
    for &(s, e) in wins {
        let last = e.saturating_sub(1).max(s);
        let total: f64 = (s..last).map(turn_of).sum();
        // Each run's share of the turn, planned again after every cut (so a spike taken by
        // one run does not leave short runs behind it); infinite once the rest fits in one.
        let share_of = |rest: f64| {
            if rest > max_turn_rad && max_turn_rad > 0.0 {
                rest / (rest / max_turn_rad).ceil()
            } else {
                f64::INFINITY
            }
        };
        let mut share = share_of(total);
        let mut start = s;
        let mut turned = 0.0;
        let mut at_start = 0.0;
        for k in s..last {
            turned += turn_of(k);
            if turned - at_start >= share && k + 1 - start >= min_len && e - (k + 1) >= min_len {
                // Sample k + 1 starts the next run; interval k -> k + 1 is left out.
                out.push((start, k + 1));
                start = k + 1;
                at_start = turned;
                share = share_of(total - turned);
            }
        }
        if e > start {
            out.push((start, e));
        }
    }
    out
}

/// Flights for the tests of this module and of [`super::intervals`].
#[cfg(test)]
pub(crate) mod samples {
    use super::*;

    /// A flight whose commands change every few samples, words and (with `wrench`) wrenches,
    /// a NaN among them; times jittered.
    pub(crate) fn flight(n: usize, wrench: bool) -> Flight {
        let mut x = 11u64;
        let mut rnd = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) as u32
        };
        let mut commands = Vec::with_capacity(n);
        let mut c = Command::Word(0);
        for k in 0..n {
            if rnd() % 5 == 0 || k == n / 2 {
                c = if wrench {
                    let v = f64::from(rnd() % 7) - 3.0;
                    let v = if k == n / 2 { f64::NAN } else { v };
                    Command::Wrench {
                        force: [v, 0.0, 0.1],
                        torque: [0.0, v * 0.01, 0.0],
                    }
                } else {
                    Command::Word((rnd() & 0x0fff) as u16)
                };
            }
            commands.push(c);
        }
        let time_s = (0..n)
            .map(|k| k as f64 * 1e-3 + f64::from(rnd() % 100) * 1e-7)
            .collect();
        Flight {
            time_s,
            rate: vec![[0.0; 3]; n].into(),
            axes: [true; 3],
            commands: commands.into(),
            period_s: 1e-3,
            from_gyro_counts: !wrench,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Windows that turn the craft further than the limit are cut into runs of about equal
    /// turn, no sample lost and in order; windows under it pass untouched.
    #[test]
    fn long_turns_are_split_into_runs_within_the_limit() {
        let mut f = samples::flight(2000, false);
        // Turning at 2 rad/s about z, steps of about 1 ms.
        for r in f.rate.rad_s_mut().unwrap().iter_mut() {
            *r = [0.0, 0.0, 2.0];
        }
        let turn = |s: usize, e: usize| 2.0 * (f.time_s[e - 1] - f.time_s[s]);
        let wins = vec![(0, 50), (60, 1990)];
        let max = 0.6;
        let split = split_turns(&f, &wins, max, 20);
        assert_eq!(split[0], (0, 50), "a short window is kept whole");
        assert!(split.len() > 2, "{split:?}");
        for w in split.windows(2) {
            assert!(w[0].1 <= w[1].0, "ordered, disjoint: {split:?}");
        }
        let mut covered = 0;
        for &(s, e) in &split[1..] {
            assert!(e > s);
            assert!(turn(s, e) <= max * 1.01, "{} rad in ({s}, {e})", turn(s, e));
            covered += e - s;
        }
        assert_eq!(split[1].0, 60);
        assert_eq!(split.last().map(|w| w.1), Some(1990));
        assert_eq!(covered, 1990 - 60, "each cut drops an interval, no sample");
        // As few runs as the limit allows: ceil(total turn / limit), no more.
        let total = turn(60, 1990);
        assert_eq!(
            split.len() - 1,
            (total / max).ceil() as usize,
            "{total} rad: {split:?}"
        );
        assert_eq!(
            split_turns(&f, &wins, 1e9, 20),
            wins,
            "no split under the limit"
        );
    }

    /// A rate spike worth several runs makes one cut; no run is shorter than the minimum, and
    /// a NaN rate counts as no turn.
    #[test]
    fn a_rate_spike_makes_one_cut_and_no_short_runs() {
        let mut f = samples::flight(2000, false);
        for r in f.rate.rad_s_mut().unwrap().iter_mut() {
            *r = [0.0, 0.0, 2.0];
        }
        f.rate.rad_s_mut().unwrap()[500] = [0.0, 0.0, 5000.0];
        f.rate.rad_s_mut().unwrap()[900] = [0.0, 0.0, f64::NAN];
        let split = split_turns(&f, &[(60, 1990)], 0.6, 20);
        assert!(split.iter().all(|&(s, e)| e - s >= 20), "{split:?}");
        let cuts_near_spike = split.iter().filter(|w| (495..=525).contains(&w.0)).count();
        assert!(cuts_near_spike <= 1, "{split:?}");
        assert_eq!(split.first().map(|w| w.0), Some(60));
        assert_eq!(split.last().map(|w| w.1), Some(1990));
        // Windows too short to split pass untouched; an empty one is dropped.
        let short = [(0, 1), (1, 3), (3, 3), (4, 10)];
        assert_eq!(
            split_turns(&f, &short, 1e-9, 4),
            vec![(0, 1), (1, 3), (4, 10)]
        );
    }

    #[test]
    fn the_command_log_reads_back_every_sample() {
        for wrench in [false, true] {
            let f = samples::flight(2000, wrench);
            let plain: Vec<Command> = f.commands.iter().copied().collect();
            assert_eq!(plain.len(), 2000);
            // The fixture holds what it says: with wrenches, a NaN command.
            let has_nan =
                |c: &Command| matches!(c, Command::Wrench { force, .. } if force[0].is_nan());
            assert_eq!(plain.iter().any(has_nan), wrench);
            assert!(
                f.commands.runs.len() < 700,
                "{} runs",
                f.commands.runs.len()
            );
            let hint = Cell::new(0);
            for (i, c) in plain.iter().enumerate() {
                let bits = |c: &Command| format!("{c:?}");
                assert_eq!(f.commands.get(i).map(bits), Some(bits(c)));
                assert_eq!(f.commands.get_near(i, &hint).map(bits), Some(bits(c)));
            }
            // Backwards, so that the hint misses.
            for i in (0..2000).rev() {
                assert_eq!(
                    f.commands.get_near(i, &hint).map(|c| format!("{c:?}")),
                    Some(format!("{:?}", plain[i]))
                );
            }
            assert!(f.commands.get(2000).is_none());
        }
    }

    /// A v1 flight's rates, kept as counts, read back as the model's conversion of every
    /// count (bit for bit), NaN for the saturated 0 and 4,095 and for counts past them.
    #[test]
    fn counts_read_back_as_the_models_rates() {
        let sat = Satellite::builtin("sph2").unwrap();
        let samples: Vec<crate::recording::Sample> = (0..4200u16)
            .map(|c| crate::recording::Sample {
                time_ms: u64::from(c),
                gyro: [c, 4199 - c, c / 2],
                accel: [2048; 3],
                thrusters: 0,
            })
            .collect();
        let rec = Recording {
            source: "counts".into(),
            metadata: Vec::new(),
            samples,
            issues: Default::default(),
            rate_line: None,
        };
        let mut f = Flight::from_v1(&rec, &sat);
        assert!(matches!(f.rate, Rates::Counts { .. }));
        for (k, s) in rec.samples.iter().enumerate() {
            let r = f.rate.at(k);
            for a in 0..3 {
                let c = s.gyro[a];
                if c == 0 || c >= crate::recording::MAX_COUNT {
                    assert!(r[a].is_nan(), "count {c}");
                } else {
                    assert_eq!(
                        r[a].to_bits(),
                        sat.gyro_counts_to_rad_s(a, f64::from(c)).to_bits()
                    );
                }
            }
        }
        let read: Vec<[f64; 3]> = f.rate.iter().collect();
        let owned = f.rate.to_rad_s();
        assert!(f.rate.rad_s_mut().is_none());
        assert_eq!(format!("{read:?}"), format!("{owned:?}"));
        assert!(f.rate.at(4200)[0].is_nan());
    }
}
