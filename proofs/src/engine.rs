//! One harness body, two engines.
//!
//! Every proof harness in this crate is a plain `fn()` written only against [`any_in`],
//! [`any_f64_in`], [`any_bool`], [`assume`] and [`cover!`](crate::cover). Under `cargo kani` (cfg `kani`)
//! those map onto `kani::any`, `kani::assume` and `kani::cover!`, and the harness is a
//! symbolic proof over every input. Here (no Kani: its bundle cannot be downloaded) the same
//! body is run by [`check`], which executes it many times drawing inputs from
//!
//! * [`Mode::Random`]: a seeded ChaCha stream, with the range ends and zero drawn often, and
//! * [`Mode::Exhaustive`]: a depth-first odometer over the sequence of choices the body makes,
//!   so a body whose draws are all integer ranges is run on *every* input combination; float
//!   draws enumerate a fixed grid over their range (ends, zero, quarter points).
//!
//! [`check`] fails when the body panics on an accepted input, when no draw satisfied the
//! assumptions (vacuity), or when a declared cover point was never reached.

#[cfg(not(kani))]
use std::cell::RefCell;
#[cfg(not(kani))]
use std::collections::BTreeMap;

/// Which inputs the shim engine feeds a harness.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// `runs` draws from a ChaCha8 stream seeded with `seed`.
    Random { runs: u64, seed: u64 },
    /// Every choice sequence (integer ranges in full, floats on a grid), stopping with an
    /// error if there are more than `limit`.
    Exhaustive { limit: u64 },
}

/// What one [`check`] saw: how many draws ran, how many the assumptions accepted, and each
/// cover point's hit count. Printed by the tests and quoted in the README.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub name: String,
    pub draws: u64,
    pub accepted: u64,
    pub covers: Vec<(String, u64)>,
}

impl core::fmt::Display for Report {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{}: {} draws, {} accepted",
            self.name, self.draws, self.accepted
        )?;
        for (c, n) in &self.covers {
            write!(f, ", cover `{c}` x{n}")?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// Kani mapping: the harness body becomes a symbolic proof.
// ---------------------------------------------------------------------------------------

/// An arbitrary integer in `lo..=hi`.
#[cfg(kani)]
pub fn any_in<T: kani::Arbitrary + PartialOrd + Copy>(lo: T, hi: T) -> T {
    let x: T = kani::any();
    kani::assume(lo <= x && x <= hi);
    x
}
/// An arbitrary finite f64 in `lo..=hi`.
#[cfg(kani)]
pub fn any_f64_in(lo: f64, hi: f64) -> f64 {
    let x: f64 = kani::any();
    kani::assume(lo <= x && x <= hi);
    x
}
/// An arbitrary bool.
#[cfg(kani)]
pub fn any_bool() -> bool {
    kani::any()
}
/// Restrict the inputs to those satisfying `cond`.
#[cfg(kani)]
pub fn assume(cond: bool) {
    kani::assume(cond)
}
/// Cover point: `cond` must be reachable (Kani checks satisfiability; the shim counts hits).
#[cfg(kani)]
#[macro_export]
macro_rules! cover {
    ($cond:expr, $name:literal) => {
        kani::cover!($cond, $name)
    };
}

// ---------------------------------------------------------------------------------------
// Shim engine: the harness body is executed.
// ---------------------------------------------------------------------------------------

/// A harness's draw was outside its assumptions: unwound out of the body, not a failure.
#[cfg(not(kani))]
struct Rejected;

#[cfg(not(kani))]
// One `Source` per harness run, never in a collection: boxing the generator buys nothing.
#[allow(clippy::large_enum_variant)]
enum Source {
    Random(rand_chacha::ChaCha8Rng),
    /// Odometer: (value, max) per choice position, reused across runs.
    Exhaustive {
        stack: Vec<(u64, u64)>,
        pos: usize,
    },
}

#[cfg(not(kani))]
impl Source {
    /// A choice in `0..=max`.
    fn choose(&mut self, max: u64) -> u64 {
        match self {
            Source::Random(rng) => {
                use rand::Rng;
                // Ends are where overflow lives: draw them one time in eight each.
                match rng.gen_range(0u32..8) {
                    0 => 0,
                    1 => max,
                    _ => {
                        if max == u64::MAX {
                            rng.gen()
                        } else {
                            rng.gen_range(0..=max)
                        }
                    }
                }
            }
            Source::Exhaustive { stack, pos } => {
                let v = if *pos < stack.len() {
                    stack[*pos].0
                } else {
                    stack.push((0, max));
                    0
                };
                *pos += 1;
                v
            }
        }
    }

    /// Advance the odometer to the next choice sequence; false when all were run.
    fn advance(&mut self) -> bool {
        match self {
            Source::Random(_) => true,
            Source::Exhaustive { stack, pos } => {
                stack.truncate(*pos);
                *pos = 0;
                while let Some(top) = stack.last_mut() {
                    if top.0 < top.1 {
                        top.0 += 1;
                        return true;
                    }
                    stack.pop();
                }
                false
            }
        }
    }

    fn is_random(&self) -> bool {
        matches!(self, Source::Random(_))
    }
}

#[cfg(not(kani))]
struct Ctx {
    source: Source,
    covers: BTreeMap<&'static str, u64>,
}

#[cfg(not(kani))]
thread_local! {
    static CTX: RefCell<Option<Ctx>> = const { RefCell::new(None) };
}

#[cfg(not(kani))]
fn with_source<R>(f: impl FnOnce(&mut Source) -> R) -> R {
    CTX.with(|c| {
        let mut c = c.borrow_mut();
        let ctx = c.as_mut().expect("engine draw outside `engine::check`");
        f(&mut ctx.source)
    })
}

/// True inside [`check`] (a draw source is available).
#[cfg(not(kani))]
pub fn active() -> bool {
    CTX.with(|c| c.borrow().is_some())
}
/// Under Kani every draw is symbolic.
#[cfg(kani)]
pub fn active() -> bool {
    true
}

/// Integers the shim can draw over a closed range.
#[cfg(not(kani))]
pub trait Drawable: Copy + PartialOrd {
    fn offset(lo: Self, hi: Self) -> u64;
    fn add(lo: Self, k: u64) -> Self;
    /// `-lo` as an offset when `lo < 0`.
    fn zero_offset_from(lo: Self) -> Option<u64>;
}

#[cfg(not(kani))]
macro_rules! drawable {
    ($($t:ty),*) => {$(
        impl Drawable for $t {
            fn offset(lo: Self, hi: Self) -> u64 { (hi as i128 - lo as i128) as u64 }
            fn add(lo: Self, k: u64) -> Self { (lo as i128 + k as i128) as $t }
            fn zero_offset_from(lo: Self) -> Option<u64> { ((lo as i128) < 0).then(|| (-(lo as i128)) as u64) }
        }
    )*};
}
#[cfg(not(kani))]
drawable!(u8, u16, u32, u64, usize, i8, i16, i32, i64);

/// An arbitrary integer in `lo..=hi` (Kani: symbolic; shim: drawn or enumerated).
#[cfg(not(kani))]
pub fn any_in<T: Drawable>(lo: T, hi: T) -> T {
    assert!(lo <= hi, "any_in: empty range");
    let span = T::offset(lo, hi);
    // Zero strictly inside a signed range is drawn one time in eight, like the ends.
    let zero = T::zero_offset_from(lo).filter(|&z| z < span);
    let k = with_source(|s| match zero {
        Some(z) if s.is_random() && s.choose(7) == 0 => z,
        _ => s.choose(span),
    });
    T::add(lo, k)
}

/// Grid the exhaustive engine walks for a float range: both ends, zero when inside, and the
/// quarter points.
#[cfg(not(kani))]
fn float_grid(lo: f64, hi: f64) -> Vec<f64> {
    let mut g = vec![lo, hi];
    for q in [0.25, 0.5, 0.75] {
        g.push(lo + (hi - lo) * q);
    }
    if lo < 0.0 && 0.0 < hi {
        g.push(0.0);
    }
    g.dedup();
    g
}

/// An arbitrary finite f64 in `lo..=hi` (shim: uniform with the ends and zero often;
/// exhaustive: the `float_grid` points).
#[cfg(not(kani))]
pub fn any_f64_in(lo: f64, hi: f64) -> f64 {
    assert!(lo <= hi, "any_f64_in: empty range");
    let grid = float_grid(lo, hi);
    with_source(|s| {
        if s.is_random() {
            // One draw in four from the grid (ends, zero), the rest uniform.
            let pick = s.choose(4 * grid.len() as u64 - 1) as usize;
            if pick < grid.len() {
                grid[pick]
            } else {
                let u = s.choose(u32::MAX as u64 - 1) as f64 / (u32::MAX as f64 - 1.0);
                (lo + (hi - lo) * u).clamp(lo, hi)
            }
        } else {
            grid[s.choose(grid.len() as u64 - 1) as usize]
        }
    })
}

/// An arbitrary bool.
#[cfg(not(kani))]
pub fn any_bool() -> bool {
    with_source(|s| s.choose(1) == 1)
}

/// Restrict the inputs to those satisfying `cond` (shim: abandon this draw).
#[cfg(not(kani))]
pub fn assume(cond: bool) {
    if !cond {
        std::panic::resume_unwind(Box::new(Rejected));
    }
}

/// Record a cover point hit (used by [`cover!`]).
#[cfg(not(kani))]
#[doc(hidden)]
pub fn cover_hit(name: &'static str, cond: bool) {
    CTX.with(|c| {
        if let Some(ctx) = c.borrow_mut().as_mut() {
            let n = ctx.covers.entry(name).or_insert(0);
            if cond {
                *n += 1;
            }
        }
    });
}

/// Cover point: `cond` must hold on at least one accepted draw.
#[cfg(not(kani))]
#[macro_export]
macro_rules! cover {
    ($cond:expr, $name:literal) => {
        $crate::engine::cover_hit($name, $cond)
    };
}

/// Run `body` under `mode`; `Err` names what failed (a panic with its input index, vacuity,
/// an unreached cover point among `covers`, or an exhaustive domain over its limit).
#[cfg(not(kani))]
pub fn check(
    name: &str,
    mode: Mode,
    covers: &[&'static str],
    body: fn(),
) -> Result<Report, String> {
    use rand::SeedableRng;
    let source = match mode {
        Mode::Random { seed, .. } => Source::Random(rand_chacha::ChaCha8Rng::seed_from_u64(seed)),
        Mode::Exhaustive { .. } => Source::Exhaustive {
            stack: Vec::new(),
            pos: 0,
        },
    };
    CTX.with(|c| {
        *c.borrow_mut() = Some(Ctx {
            source,
            covers: BTreeMap::new(),
        })
    });
    let mut report = Report {
        name: name.to_string(),
        ..Default::default()
    };
    let result = run_all(mode, body, &mut report);
    let ctx = CTX.with(|c| c.borrow_mut().take()).expect("engine context");
    result?;
    if report.accepted == 0 {
        return Err(format!(
            "{name}: vacuous: no draw of {} satisfied the assumptions",
            report.draws
        ));
    }
    for want in covers {
        if !ctx.covers.contains_key(want) {
            return Err(format!("{name}: cover point `{want}` was never evaluated"));
        }
    }
    for (c, n) in &ctx.covers {
        if *n == 0 {
            return Err(format!(
                "{name}: cover point `{c}` never satisfied in {} accepted draws",
                report.accepted
            ));
        }
        report.covers.push((c.to_string(), *n));
    }
    Ok(report)
}

#[cfg(not(kani))]
fn run_all(mode: Mode, body: fn(), report: &mut Report) -> Result<(), String> {
    let name = report.name.clone();
    // Silence the default hook for unwinds we expect; keep real panic messages.
    let limit = match mode {
        Mode::Random { runs, .. } => runs,
        Mode::Exhaustive { limit } => limit,
    };
    loop {
        if report.draws == limit {
            if let Mode::Exhaustive { .. } = mode {
                return Err(format!(
                    "{name}: exhaustive domain larger than the limit {limit}"
                ));
            }
            return Ok(());
        }
        report.draws += 1;
        match std::panic::catch_unwind(body) {
            Ok(()) => report.accepted += 1,
            Err(e) if e.is::<Rejected>() => {}
            Err(e) => {
                let msg = e
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "non-string panic".into());
                return Err(format!("{name}: draw #{} failed: {msg}", report.draws));
            }
        }
        let more = CTX.with(|c| {
            c.borrow_mut()
                .as_mut()
                .map(|ctx| ctx.source.advance())
                .unwrap_or(false)
        });
        if !more {
            return Ok(());
        }
    }
}

#[cfg(all(test, not(kani)))]
mod tests {
    use super::*;

    fn pairs_of_small() {
        let a = any_in(0u8, 3);
        let b = any_in(-2i8, 2);
        assume(a != 1);
        cover!(a == 3 && b == -2, "corner");
        COUNT.with(|c| c.set(c.get() + 1));
    }
    thread_local!(static COUNT: std::cell::Cell<u64> = const { std::cell::Cell::new(0) });

    #[test]
    fn exhaustive_enumerates_every_pair_once() {
        COUNT.with(|c| c.set(0));
        let r = check(
            "pairs",
            Mode::Exhaustive { limit: 1000 },
            &["corner"],
            pairs_of_small,
        )
        .unwrap();
        // a in 0..=3 (4 values) x b in -2..=2 (5 values) = 20 sequences, the 5 with a == 1
        // rejected.
        assert_eq!(r.draws, 20);
        assert_eq!(r.accepted, 15);
        assert_eq!(COUNT.with(|c| c.get()), 15);
        assert_eq!(r.covers, vec![("corner".to_string(), 1)]);
    }

    fn always_rejects() {
        let a = any_in(0u32, 10);
        assume(a > 10);
    }

    fn early_reject() {
        let a = any_in(0u8, 3);
        assume(a != 1);
        let _b = any_in(0u8, 4);
    }

    #[test]
    fn a_rejection_prunes_the_choices_after_it() {
        // a == 1 is rejected before b is drawn, so its 5 b values are one draw: 3*5 + 1.
        let r = check("prune", Mode::Exhaustive { limit: 1000 }, &[], early_reject).unwrap();
        assert_eq!((r.draws, r.accepted), (16, 15));
    }

    #[test]
    fn vacuous_assumptions_fail_the_check() {
        let e = check(
            "vacuous",
            Mode::Random { runs: 200, seed: 1 },
            &[],
            always_rejects,
        )
        .unwrap_err();
        assert!(e.contains("vacuous"), "{e}");
    }

    fn never_covered() {
        let a = any_in(0u32, 10);
        cover!(a > 10, "impossible");
    }

    #[test]
    fn unreached_cover_fails_the_check() {
        let e = check(
            "cover",
            Mode::Exhaustive { limit: 100 },
            &["impossible"],
            never_covered,
        )
        .unwrap_err();
        assert!(e.contains("impossible"), "{e}");
    }

    fn overflows_at_the_top() {
        let a = any_in(0u16, 4095);
        let _ = (a as u8).checked_add(200).expect("u8 overflow");
    }

    #[test]
    fn a_panic_on_an_accepted_input_fails_the_check() {
        assert!(check(
            "ovf",
            Mode::Exhaustive { limit: 5000 },
            &[],
            overflows_at_the_top
        )
        .is_err());
        assert!(check(
            "ovf",
            Mode::Random {
                runs: 2000,
                seed: 7
            },
            &[],
            overflows_at_the_top
        )
        .is_err());
    }

    fn floats() {
        let x = any_f64_in(-1.0, 2.0);
        assert!((-1.0..=2.0).contains(&x));
        cover!(x == 0.0, "zero");
        cover!(x == 2.0, "top");
    }

    #[test]
    fn float_draws_stay_in_range_and_hit_the_grid() {
        let r = check(
            "f",
            Mode::Exhaustive { limit: 100 },
            &["zero", "top"],
            floats,
        )
        .unwrap();
        assert_eq!(r.draws, 6);
        check(
            "f",
            Mode::Random { runs: 500, seed: 3 },
            &["zero", "top"],
            floats,
        )
        .unwrap();
    }

    fn big_domain() {
        let _ = any_in(0u32, 1000);
    }

    #[test]
    fn exhaustive_over_limit_is_an_error() {
        let e = check("big", Mode::Exhaustive { limit: 100 }, &[], big_domain).unwrap_err();
        assert!(e.contains("limit"), "{e}");
    }
}
