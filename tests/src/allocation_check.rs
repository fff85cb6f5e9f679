//! What makes a thrust allocation right, checked from first principles and independent of
//! any allocator: the duties are non-negative, their wrench is the command, and they are the
//! smallest such duties. The last is checked against the optimality conditions of
//! `min |u|^2 s.t. B u = c, u >= 0`: the solution is `u = max(0, B' l)` for the maximiser `l`
//! of the dual, which this module finds by its own Newton iteration (the reference allocates
//! by least-distance NNLS, the kernel by its own dual Newton in its scalar type).

use nalgebra::{DMatrix, DVector, Vector6};

/// The example craft every any-craft test flies (`examples/models/`): planar 8, 3-D 8 canted,
/// 3-D 16, and SPHERES.
pub const EXAMPLE_MODELS: [&str; 4] = ["airbearing-mpc", "cubesat8", "freeflyer16", "sph2"];

/// Path of an example model file.
pub fn example_model(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/models")
        .join(format!("{name}.toml"))
}

/// Checks `duty` against `command` for the wrench columns `columns` on the axes `rows`, with
/// tolerance `tol` relative to the largest column entry times the largest duty.
pub fn check_allocation(
    columns: &[Vector6<f64>],
    rows: &[usize],
    command: &Vector6<f64>,
    duty: &[f64],
    tol: f64,
) -> Result<(), String> {
    let n = columns.len();
    if duty.len() < n {
        return Err(format!("{} duties for {n} thrusters", duty.len()));
    }
    if let Some(i) = (0..n).find(|&i| duty[i].is_nan() || duty[i] < 0.0) {
        return Err(format!("thruster {}: duty {} is negative", i + 1, duty[i]));
    }
    let big = columns
        .iter()
        .flat_map(|c| rows.iter().map(move |&r| c[r].abs()))
        .fold(0.0, f64::max);
    let top = duty[..n].iter().cloned().fold(0.0, f64::max);
    let scale = big * top.max(1e-300);
    for &r in rows {
        let got: f64 = (0..n).map(|i| columns[i][r] * duty[i]).sum();
        if (got - command[r]).abs() > tol * scale.max(command[r].abs()) {
            return Err(format!(
                "axis {r}: wrench {got:.9e} misses the command {:.9e}",
                command[r]
            ));
        }
    }
    // Smallest: the optimum is u* = max(0, B' l*) with l* the maximiser of the concave dual
    // c'l - |max(0, B'l)|^2 / 2 (found here by damped Newton); the duties must be u*.
    let l = dual_optimum(columns, rows, command);
    for i in 0..n {
        let want = rows
            .iter()
            .enumerate()
            .map(|(k, &r)| columns[i][r] * l[k])
            .sum::<f64>()
            .max(0.0);
        if (duty[i] - want).abs() > tol.sqrt() * top.max(want) {
            return Err(format!(
                "not the smallest duties: thruster {} has {:.6e}, the smallest firing {want:.6e}",
                i + 1,
                duty[i]
            ));
        }
    }
    Ok(())
}

/// The dual maximiser `l` (one entry per axis in `rows`) by Newton steps with halving.
fn dual_optimum(columns: &[Vector6<f64>], rows: &[usize], command: &Vector6<f64>) -> DVector<f64> {
    let m = rows.len();
    let b: Vec<DVector<f64>> = columns
        .iter()
        .map(|c| DVector::from_iterator(m, rows.iter().map(|&r| c[r])))
        .collect();
    let c = DVector::from_iterator(m, rows.iter().map(|&r| command[r]));
    let dual = |l: &DVector<f64>| {
        c.dot(l) - 0.5 * b.iter().map(|bi| bi.dot(l).max(0.0).powi(2)).sum::<f64>()
    };
    let mut l = DVector::<f64>::zeros(m);
    for _ in 0..500 {
        let mut g = c.clone();
        let mut h = DMatrix::<f64>::identity(m, m) * 1e-14;
        for bi in &b {
            let s = bi.dot(&l);
            if s > 0.0 {
                g -= bi * s;
                h += bi * bi.transpose();
            }
        }
        let Some(d) = h.lu().solve(&g) else { break };
        let mut t = 1.0;
        while dual(&(&l + &d * t)) < dual(&l) && t > 1e-16 {
            t *= 0.5;
        }
        l += d * t;
    }
    l
}
