//! Divergence: a long run (>= 10^6 ticks, 1 kHz) of the per-tick pipeline in Q8.24 and f32
//! on a simulated maneuver sequence, checking at every solve that
//! * the RLS estimate stays within the error budget of `reference_f64`'s batch least squares
//!   of the same measurements (`budget` row `rls.estimate`, norm-wise, times the information's
//!   condition number), i.e. no drift however long it runs;
//! * the information matrices stay symmetric positive definite (Cholesky of the mantissas)
//!   and never saturate;
//! and, separately, what the kernel does when they would not: with the gyros saturated or
//! a single-axis maneuver, a status (Overflow / KfOverflow / PartlyUnobservable with the
//! mask), never silently drifting numbers.

use massid_kernel::model::{inertia_rows, SatelliteParams, SPH2};
use massid_kernel::{Pipeline, PipelineConfig, PipelineStatus, Scalar, TickEvent, Q8_24};
use massid_proofs::budget::{fmt_of, Exact, Worst};
use massid_proofs::harness::rls::cholesky_ok;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use reference_f64::mass_id::{BatchLs, Observation};

/// xorshift64* uniform and a Box-Muller normal (deterministic, no dependency).
struct Rng(u64);
impl Rng {
    fn u(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        (-2.0 * self.u().ln()).sqrt() * (2.0 * std::f64::consts::PI * self.u()).cos()
    }
}

/// Truth: SPH2 with a proof mass (CoM moved, inertia raised), seen through the gyros.
struct Truth {
    inv_i: Matrix3<f64>,
    p: SatelliteParams,
    com_m: Vector3<f64>,
}

impl Truth {
    fn new() -> Self {
        let mut p = SPH2;
        p.com_offset_mm = [p.com_offset_mm[0] + 4.0, p.com_offset_mm[1] - 3.0, p.com_offset_mm[2] + 2.0];
        for k in 0..3 {
            p.inertia_kgm2[k] *= 1.08;
        }
        let i = p.inertia_inverse().expect("invertible");
        let inv_i = Matrix3::from_fn(|r, c| i[r][c]);
        let com_m = Vector3::from(p.com_offset_mm.map(|v| v as f64 * 1e-3));
        Truth { inv_i, p, com_m }
    }
    fn omega_dot(&self, word: u16) -> Vector3<f64> {
        let mut tau = Vector3::zeros();
        for i in 0..12 {
            if word & (1 << i) != 0 {
                let f = Vector3::from(self.p.thrust_dir[i].map(|v| v as f64)) * self.p.thrust_n[i] as f64;
                let r = Vector3::from(self.p.thruster_pos_m[i].map(|v| v as f64)) - self.com_m;
                tau += r.cross(&f);
            }
        }
        self.inv_i * tau
    }
}

/// Words that excite every term: the twelve single thrusters and the six torque couples.
fn maneuver_words() -> Vec<u16> {
    let mut w: Vec<u16> = (0..12).map(|i| 1 << i).collect();
    for (a, b) in [(0, 7), (1, 6), (2, 9), (3, 8), (4, 11), (5, 10)] {
        w.push((1 << a) | (1 << b));
    }
    w
}

struct RunFigures {
    ticks: u64,
    solves: u64,
    worst: Worst,
    statuses: [u64; 6],
    kf_overflow: u64,
}

/// Runs `ticks` ticks; every solve is compared with the reference batch LS of the same
/// measurements and the information is checked SPD.
fn long_run<S: Exact>(ticks: u64, seed: u64) -> RunFigures {
    let truth = Truth::new();
    let mut pl = Pipeline::<S>::new(&SPH2, PipelineConfig::seed(1)).expect("SPH2");
    let words = maneuver_words();
    let mut rng = Rng(seed);
    let g = 1412.79;
    let bias = [2077.0, 2070.0, 2058.0];
    let sigma_counts = [9.5661e-7f64, 2.7365e-7, 2.3044e-7].map(|r| r.sqrt() * g);
    let mut omega = Vector3::zeros();
    // Reference: the same weighted measurements into batch LS (negligible prior).
    let mut ref_com = BatchLs::<3>::with_prior(SVector::zeros(), SVector::repeat(1e6));
    let mut ref_inertia = BatchLs::<6>::with_prior(SVector::zeros(), SVector::repeat(1e6));
    let mut fig = RunFigures { ticks: 0, solves: 0, worst: Worst::new("rls.estimate"), statuses: [0; 6], kf_overflow: 0 };
    let mut firing_left = 0u64;
    let mut coast_left = 0u64;
    let mut word = 0u16;
    let mut last_obs: Option<(Observation<3>, Observation<6>)> = None;
    let mut firings = 0u32;
    let mut sign_word: usize = 0;
    while fig.ticks < ticks {
        if firing_left == 0 && coast_left == 0 {
            if word != 0 {
                coast_left = 20;
                word = 0;
            } else {
                // Next firing: cycle the words; its reverse follows to bring the rate back.
                let idx = sign_word % words.len();
                sign_word += 1;
                word = words[idx];
                firing_left = 150 + (rng.u() * 350.0) as u64;
            }
        }
        if firing_left > 0 {
            firing_left -= 1;
        } else {
            coast_left -= 1;
        }
        // Truth (the word acts over the tick), then the gyro sample.
        let od = if word != 0 { truth.omega_dot(word) } else { Vector3::zeros() };
        omega += od * 1e-3;
        // Keep the rate bounded: damp it while coasting (an attitude controller's job).
        if word == 0 {
            omega *= 0.9;
        }
        let counts = [0, 1, 2].map(|k| (bias[k] + omega[k] * g + sigma_counts[k] * rng.normal()).round().clamp(0.0, 4095.0) as u16);
        let prev_firings = pl.estimates().firings;
        let r = pl.tick(counts, word);
        fig.ticks += 1;
        let est_firings = pl.estimates().firings;
        if est_firings != prev_firings {
            firings = est_firings;
        }
        if r.event == TickEvent::KfOverflow {
            fig.kf_overflow += 1;
        }
        // Mirror the kernel's measurements into the reference.
        if r.event == TickEvent::Updated {
            if let Some(e) = pl.omega_dot() {
                let ft = pl.model_terms().firing_terms(word);
                let a1 = SMatrix::<f64, 3, 3>::from_fn(|i, j| ft.a_com[i][j].exact());
                let b1 = Vector3::from_fn(|i, _| e.omega_dot[i].exact() - ft.omega_dot_nominal[i].exact());
                let rows = inertia_rows(&ft.torque_cnm);
                let a2 = SMatrix::<f64, 3, 6>::from_fn(|i, j| rows[i][j].exact());
                let b2 = Vector3::from_fn(|i, _| e.omega_dot[i].exact());
                let var = Matrix3::from_diagonal(&Vector3::from_fn(|i, _| e.variance[i].m.exact() * (2.0f64).powi(e.variance[i].e)));
                let o1 = Observation { a: a1, b: b1, r: var };
                let o2 = Observation { a: a2, b: b2, r: var };
                if firings > 2 {
                    ref_com.add(&o1);
                    ref_inertia.add(&o2);
                }
                last_obs = Some((o1, o2));
            }
        }
        if r.event == TickEvent::Solved {
            // The firing that just ended: batch firings contribute their last measurement.
            if prev_firings <= 2 {
                if let Some((o1, o2)) = last_obs.take() {
                    ref_com.add(&o1);
                    ref_inertia.add(&o2);
                }
            }
            fig.solves += 1;
            let st = pl.estimates().status;
            fig.statuses[st as usize] += 1;
            check_solve(&pl, &ref_com, &ref_inertia, &mut fig.worst);
        }
        if word == 0 {
            last_obs = None;
        }
    }
    fig
}

fn check_solve<S: Exact>(pl: &Pipeline<S>, ref_com: &BatchLs<3>, ref_inertia: &BatchLs<6>, worst: &mut Worst) {
    let est = pl.estimates();
    assert!(
        matches!(est.status, PipelineStatus::Ok | PipelineStatus::PartlyUnobservable),
        "nominal run: status {:?}",
        est.status
    );
    let (com, inertia) = pl.mass_id().problems();
    assert!(!com.is_saturated() && !inertia.is_saturated(), "information saturated");
    let c = com.information().map(|r| r.map(|v| v.exact()));
    let i = inertia.information().map(|r| r.map(|v| v.exact()));
    for m in [&c.iter().map(|r| r.to_vec()).collect::<Vec<_>>(), &i.iter().map(|r| r.to_vec()).collect::<Vec<_>>()] {
        for a in 0..m.len() {
            for b in 0..m.len() {
                assert_eq!(m[a][b], m[b][a], "information not symmetric");
            }
        }
    }
    assert!(cholesky_ok(&c) || est.unobservable_com.iter().any(|u| *u), "CoM information not positive definite");
    assert!(cholesky_ok(&i) || est.unobservable_inertia.iter().any(|u| *u), "inertia information not positive definite");
    let fmt = fmt_of::<S>();
    for (x, unobs, info, rhs) in [
        (est.delta_com_m.map(|v| v.exact()).to_vec(), est.unobservable_com.to_vec(), dm(&ref_com.info), ref_com.rhs.iter().copied().collect::<Vec<_>>()),
        (est.theta_inertia.map(|v| v.exact()).to_vec(), est.unobservable_inertia.to_vec(), dm(&ref_inertia.info), ref_inertia.rhs.iter().copied().collect::<Vec<_>>()),
    ] {
        if unobs.iter().any(|u| *u) {
            continue; // reduced problem: compared once every term is observable
        }
        let n = x.len();
        let info = nalgebra::DMatrix::from_row_slice(n, n, &info);
        let xr = info.clone().lu().solve(&nalgebra::DVector::from_vec(rhs)).expect("reference solvable");
        let ev = info.symmetric_eigen().eigenvalues;
        let cond = ev.max() / ev.min();
        let scale = cond * xr.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for k in 0..n {
            worst.record_normwise(fmt, x[k], xr[k], scale).unwrap_or_else(|e| panic!("term {k}: {e}"));
        }
    }
}

fn dm<const N: usize>(m: &SMatrix<f64, N, N>) -> Vec<f64> {
    (0..N).flat_map(|i| (0..N).map(move |j| m[(i, j)])).collect()
}

fn report(name: &str, f: &RunFigures) {
    println!(
        "{name}: {} ticks, {} solves, statuses [idle batch ok partly singular overflow] = {:?}, kf overflow ticks {}; {}",
        f.ticks, f.solves, f.statuses, f.kf_overflow, f.worst
    );
}

#[test]
fn a_million_ticks_q8_24_stay_in_budget_and_spd() {
    let f = long_run::<Q8_24>(1_000_000, 0x9e3779b97f4a7c15);
    report("Q8_24", &f);
    assert!(f.ticks >= 1_000_000 && f.solves > 1000 && f.worst.count > 0);
}

#[test]
fn a_million_ticks_f32_stay_in_budget_and_spd() {
    let f = long_run::<f32>(1_000_000, 0x243f6a8885a308d3);
    report("F32", &f);
    assert!(f.ticks >= 1_000_000 && f.solves > 1000 && f.worst.count > 0);
}

/// When the data would break the filter (gyros pinned at the rails while firing), the kernel
/// reports it: KF overflow events or an Overflow/Singular status, and the estimates it keeps
/// are the last valid ones, never invalid numbers under an Ok status.
fn saturated_run<S: Exact>() -> (u64, Vec<PipelineStatus>) {
    let mut pl = Pipeline::<S>::new(&SPH2, PipelineConfig::seed(1)).expect("SPH2");
    let words = maneuver_words();
    let mut overflow_events = 0;
    let mut statuses = Vec::new();
    for f in 0..30u32 {
        let word = words[f as usize % words.len()];
        for k in 0..200u32 {
            // Rails alternate every 3 ticks: a rate change far beyond any thruster's reach.
            let c = if (k / 3) % 2 == 0 { 0 } else { 4095 };
            let r = pl.tick([c; 3], word);
            if r.event == TickEvent::KfOverflow {
                overflow_events += 1;
            }
            let e = pl.estimates();
            if matches!(e.status, PipelineStatus::Ok | PipelineStatus::PartlyUnobservable) {
                assert!(e.delta_com_m.iter().chain(e.theta_inertia.iter()).all(|v| v.is_valid()));
            }
        }
        for _ in 0..20 {
            pl.tick([2070; 3], 0);
        }
        statuses.push(pl.estimates().status);
    }
    (overflow_events, statuses)
}

#[test]
fn saturated_gyros_give_a_status_not_silent_drift() {
    let (ev_q, st_q) = saturated_run::<Q8_24>();
    let (ev_f, st_f) = saturated_run::<f32>();
    println!("saturated gyros: Q8_24 {ev_q} KF-overflow ticks, statuses {st_q:?}");
    println!("saturated gyros: f32 {ev_f} KF-overflow ticks, statuses {st_f:?}");
    // Q8.24 cannot hold a 2900 rad/s^2 estimate: it must say so on those ticks.
    assert!(ev_q > 0, "Q8.24 accepted estimates beyond its range without a status");
}
