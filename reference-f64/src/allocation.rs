//! Non-negative thrust allocation for any thruster geometry: the duties `u >= 0` of smallest
//! norm whose wrench `B u` is the command `c`, or "out of reach" when no non-negative `u`
//! gives `c`.
//!
//! The seed's mixer (sec. 3.3) takes the pseudo-inverse `u = B^+ c` (the smallest-norm duties)
//! and then repairs negative duties by moving them to the opposite thruster of a pair. That
//! repair needs opposing pairs; a cubesat with canted thrusters or an air-bearing craft with
//! corner thrusters has none. Keeping the seed's smallest-norm rule and adding `u >= 0` as a
//! constraint gives the same firing as the pair rules when pairs are exactly opposite (one
//! side of each pair at the pair's net duty) and a well-defined one for every other layout:
//! the strictly convex problem
//!
//! ```text
//!   minimise |u|^2  subject to  B u = c,  u >= 0
//! ```
//!
//! has one solution whenever `c` is in the cone the thrusters span.
//!
//! This f64 reference solves it with the Clarabel interior-point QP solver, then polishes the
//! duties by the exact smallest-norm solve on the thrusters that fire: an algorithm and code
//! independent of the kernel's (a Newton method on the dual), so that the two check each
//! other. (A hand-written least-distance NNLS, Lawson & Hanson ch. 23, was tried first: on the
//! cubesat it cycled into a non-optimal firing with a negative duty, 1 % off the command.)
//! How far an unreachable command is from reach comes from Lawson-Hanson NNLS on `B` alone.

use nalgebra::{DMatrix, DVector, Vector6};

/// A command is out of reach when the best non-negative duties miss it by more than this
/// fraction of its size (in the row-scaled units).
pub const REACH_TOLERANCE: f64 = 1e-6;

/// Why no allocation exists.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AllocationError {
    /// No non-negative duties give the command: it points outside the cone of the thrusters'
    /// wrenches (e.g. a torque only one-sided thrusters would have to pull).
    #[error("out of reach: the thrusters cannot produce this force/torque direction (the best non-negative firing misses it by {relative_miss:.1e} of its size)")]
    OutOfReach { relative_miss: f64 },
    /// The QP solver stopped without an answer (iteration limit, numerical trouble).
    #[error("the allocation's QP solver stopped: {0}")]
    Solver(String),
}

/// Smallest-norm non-negative duties for the wrench `command` over the axes `rows` (indices
/// into `Fx Fy Fz Tx Ty Tz`), one duty per column of `columns`.
pub fn allocate(
    columns: &[Vector6<f64>],
    rows: &[usize],
    command: &Vector6<f64>,
) -> Result<Vec<f64>, AllocationError> {
    let n = columns.len();
    let m = rows.len();
    // Each axis scaled by its largest entry so that force and torque rows weigh alike, and
    // the command scaled to size 1 (the allocation is positively homogeneous).
    let scale: Vec<f64> = rows
        .iter()
        .map(|&r| {
            let s = columns.iter().map(|c| c[r].abs()).fold(0.0, f64::max);
            if s > 0.0 {
                s
            } else {
                1.0
            }
        })
        .collect();
    let c = DVector::from_iterator(m, rows.iter().zip(&scale).map(|(&r, s)| command[r] / s));
    let size = c.amax();
    if size == 0.0 {
        return Ok(vec![0.0; n]);
    }
    let c = c / size;
    let b = DMatrix::from_fn(m, n, |k, i| columns[i][rows[k]] / scale[k]);
    let (mut u, idle_multiplier) = match smallest_non_negative(&b, &c) {
        Ok(r) => r,
        Err(AllocationError::OutOfReach { .. }) => {
            // Say by how much: the closest non-negative firing (plain NNLS).
            let best = nnls(&b, &c);
            return Err(AllocationError::OutOfReach {
                relative_miss: (&b * best - &c).amax(),
            });
        }
        Err(e) => return Err(e),
    };
    // Polish: the smallest-norm exact solution on the thrusters that fire, kept when it stays
    // non-negative and exact. An interior-point duty never reaches 0 (1e-5 of the largest on
    // the cubesat), so which thrusters fire is decided first by strict complementarity (idle
    // where the bound's multiplier exceeds the duty), else by size (1e-9, then 1e-6 of the
    // largest duty); the first candidate set that gives an exact non-negative firing wins.
    // If none does, the solver's duties stand.
    let top = u.amax();
    let candidates: [Vec<usize>; 3] = [
        (0..n)
            .filter(|&i| u[i] > idle_multiplier[i] && u[i] > 1e-9 * top)
            .collect(),
        (0..n).filter(|&i| u[i] > 1e-9 * top).collect(),
        (0..n).filter(|&i| u[i] > 1e-6 * top).collect(),
    ];
    for support in candidates.iter().filter(|s| !s.is_empty()) {
        let bs = DMatrix::from_fn(m, support.len(), |k, j| b[(k, support[j])]);
        let Ok(pinv) = bs.clone().pseudo_inverse(1e-12) else {
            continue;
        };
        let us = pinv * &c;
        if (&bs * &us - &c).amax() <= 1e-12 && us.iter().all(|v| *v >= 0.0) {
            u.fill(0.0);
            for (j, &i) in support.iter().enumerate() {
                u[i] = us[j];
            }
            break;
        }
    }
    let miss = (&b * &u - &c).amax();
    if miss > REACH_TOLERANCE {
        return Err(AllocationError::OutOfReach {
            relative_miss: miss,
        });
    }
    Ok(u.iter().map(|v| v * size).collect())
}

/// `min |u|^2` subject to `B u = c`, `u >= 0`, by Clarabel's interior-point method (a
/// maintained conic solver: the oracle's confidence does not rest on code written here).
/// Bounded by its iteration limit, not by time.
fn smallest_non_negative(
    b: &DMatrix<f64>,
    c: &DVector<f64>,
) -> Result<(DVector<f64>, Vec<f64>), AllocationError> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT,
    };
    let (m, n) = b.shape();
    let p = CscMatrix::identity(n);
    let q = vec![0.0; n];
    let rows: Vec<Vec<f64>> = (0..m + n)
        .map(|r| {
            (0..n)
                .map(|i| {
                    if r < m {
                        b[(r, i)]
                    } else if r - m == i {
                        -1.0
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let a = CscMatrix::from(rows.iter().map(|r| r.as_slice()));
    let rhs: Vec<f64> = (0..m + n).map(|r| if r < m { c[r] } else { 0.0 }).collect();
    let cones = [ZeroConeT(m), NonnegativeConeT(n)];
    let settings = DefaultSettings {
        verbose: false,
        tol_gap_abs: 1e-12,
        tol_gap_rel: 1e-12,
        tol_feas: 1e-12,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(&p, &q, &a, &rhs, &cones, settings)
        .map_err(|e| AllocationError::Solver(format!("{e:?}")))?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => Ok((
            DVector::from_column_slice(&solver.solution.x),
            solver.solution.z[m..].to_vec(),
        )),
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
            Err(AllocationError::OutOfReach {
                relative_miss: f64::NAN,
            })
        }
        other => Err(AllocationError::Solver(format!("{other:?}"))),
    }
}

/// Lawson-Hanson active-set NNLS: `argmin |A x - b|` over `x >= 0`, with the book's
/// `3 n` bound on outer steps kept as a hard cap (here only for the size of a miss).
fn nnls(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let n = a.ncols();
    let mut x = DVector::<f64>::zeros(n);
    let mut passive = vec![false; n];
    // An index whose own solve would put it at <= 0 cannot enter (rounding of a zero
    // multiplier); it is skipped until another index enters, else the method cycles on it.
    let mut skipped = vec![false; n];
    let tol = 1e-13 * a.norm() * b.norm().max(1.0);
    for _ in 0..3 * n.max(1) {
        let w = a.transpose() * (b - a * &x);
        let Some((j, wj)) = (0..n)
            .filter(|&i| !passive[i] && !skipped[i])
            .map(|i| (i, w[i]))
            .max_by(|p, q| p.1.total_cmp(&q.1))
        else {
            break;
        };
        if wj <= tol {
            break;
        }
        passive[j] = true;
        let mut z = solve_on(a, b, &passive);
        if z[j] <= 0.0 {
            passive[j] = false;
            skipped[j] = true;
            continue;
        }
        skipped.fill(false);
        // Inner loop: step back to feasibility while a component would turn non-positive
        // (each pass removes at least one index).
        for _ in 0..=n {
            if (0..n).filter(|&i| passive[i]).all(|i| z[i] > 0.0) {
                x = z;
                break;
            }
            let alpha = (0..n)
                .filter(|&i| passive[i] && z[i] <= 0.0)
                .map(|i| x[i] / (x[i] - z[i]))
                .fold(f64::INFINITY, f64::min);
            x += (&z - &x) * alpha;
            for i in 0..n {
                if passive[i] && x[i] <= 0.0 {
                    passive[i] = false;
                    x[i] = 0.0;
                }
            }
            z = solve_on(a, b, &passive);
        }
    }
    x
}

/// Least squares on the passive columns, zeros elsewhere.
fn solve_on(a: &DMatrix<f64>, b: &DVector<f64>, passive: &[bool]) -> DVector<f64> {
    let idx: Vec<usize> = (0..a.ncols()).filter(|&i| passive[i]).collect();
    let mut sub = DMatrix::<f64>::zeros(a.nrows(), idx.len());
    for (k, &i) in idx.iter().enumerate() {
        sub.set_column(k, &a.column(i));
    }
    let z_p = sub
        .svd(true, true)
        .solve(b, 1e-14)
        .unwrap_or_else(|_| DVector::zeros(idx.len()));
    let mut z = DVector::<f64>::zeros(a.ncols());
    for (k, &i) in idx.iter().enumerate() {
        z[i] = z_p[k];
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    fn col(v: [f64; 6]) -> Vector6<f64> {
        Vector6::from(v)
    }

    #[test]
    fn opposite_pair_fires_one_side() {
        // Two thrusters pushing +x and -x: a +x command fires only the first.
        let cols = [
            col([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            col([-1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ];
        let u = allocate(&cols, &[0], &col([0.3, 0.0, 0.0, 0.0, 0.0, 0.0])).unwrap();
        assert!((u[0] - 0.3).abs() < 1e-9 && u[1] == 0.0, "{u:?}");
    }

    #[test]
    fn redundant_thrusters_share_by_smallest_norm() {
        // Two identical +x thrusters share a +x command equally (smallest norm).
        let cols = [
            col([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            col([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ];
        let u = allocate(&cols, &[0], &col([0.4, 0.0, 0.0, 0.0, 0.0, 0.0])).unwrap();
        assert!(
            (u[0] - 0.2).abs() < 1e-9 && (u[1] - 0.2).abs() < 1e-9,
            "{u:?}"
        );
    }

    #[test]
    fn a_direction_outside_the_cone_is_out_of_reach() {
        let cols = [col([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])];
        let r = allocate(&cols, &[0], &col([-0.1, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert!(
            matches!(r, Err(AllocationError::OutOfReach { .. })),
            "{r:?}"
        );
    }
}
