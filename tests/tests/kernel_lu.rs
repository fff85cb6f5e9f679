//! The kernel's LU: partial pivoting with a pivot threshold relative to the matrix scale
//! returns a status for (near-)singular matrices where a plain LU returns garbage.
use massid_kernel::lu::{solve, Lu, LuError};
use massid_kernel::{Scalar, Q8_24};

fn to<S: Scalar, const N: usize>(a: [[f64; N]; N]) -> [[S; N]; N] {
    a.map(|r| r.map(|v| S::from_f32(v as f32)))
}

/// The classic rank-2 matrix: nalgebra's LU finds a tiny non-zero rounding pivot and
/// "solves" it, returning an answer whose size is set by rounding noise; the kernel says
/// singular at its threshold.
#[test]
fn rank_deficient_matrix_gives_singular_where_nalgebra_returns_garbage() {
    let a = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 10.0 - 1.0]]; // row3 = 2 row2 - row1
    let b = [1.0, 1.0, 2.0]; // inconsistent with the rank: no solution exists
    let na = nalgebra::Matrix3::from_fn(|i, j| a[i][j]);
    let nb = nalgebra::Vector3::from(b);
    let x = na.lu().solve(&nb);
    // nalgebra (f64) gives a "solution" whose residual is of the order of b itself (or a
    // huge vector from dividing by a rounding residue); either way, not a status.
    if let Some(x) = x {
        let residual = (na * x - nb).norm();
        let size = x.norm();
        assert!(
            residual > 1e-3 || size > 1e12,
            "nalgebra unexpectedly accurate: x {x:?}"
        );
    }
    let tol_f32 = 2f32.powi(-20);
    assert!(matches!(
        solve::<f32, 3>(&to(a), &b.map(|v| v as f32), tol_f32),
        Err(LuError::Singular { column: 2 })
    ));
    let tol_q = Q8_24::from_int_pow2(1, -20);
    assert!(matches!(
        solve::<Q8_24, 3>(&to(a), &b.map(|v| Q8_24::from_f32(v as f32)), tol_q),
        Err(LuError::Singular { .. })
    ));
}

/// nalgebra's LU over the `fixed` types is the example: a near-singular matrix in
/// fixed point whose exact pivot rounds to a small non-zero value. The threshold relative to
/// the matrix scale catches it.
#[test]
fn near_singular_fixed_matrix_is_reported() {
    let eps = 2f64.powi(-22); // below the 2^-20 relative threshold, above Q8.24 resolution
    let a = [[1.0, 1.0], [1.0, 1.0 + eps]];
    let b = [Q8_24::from_f32(1.0), Q8_24::from_f32(2.0)];
    let r = solve::<Q8_24, 2>(&to(a), &b, Q8_24::from_int_pow2(1, -20));
    assert_eq!(r, Err(LuError::Singular { column: 1 }));
    // The same matrix scaled up is just as singular relative to its scale.
    let a8 = a.map(|r| r.map(|v| v * 8.0));
    let r8 = solve::<Q8_24, 2>(&to(a8), &b, Q8_24::from_int_pow2(1, -20));
    assert_eq!(r8, Err(LuError::Singular { column: 1 }));
}

#[test]
fn solution_that_does_not_fit_is_overflow_not_garbage() {
    // x2 = (2 - 1) / 2^-8 = 256 exceeds Q8.24's range: the kernel reports it.
    let a = [[1.0, 1.0], [1.0, 1.0 + 2f64.powi(-8)]];
    let b = [Q8_24::from_f32(1.0), Q8_24::from_f32(2.0)];
    assert_eq!(
        solve::<Q8_24, 2>(&to(a), &b, Q8_24::from_int_pow2(1, -20)),
        Err(LuError::Overflow)
    );
    // f32 has the range: exact answer x = (1 - 256, 256).
    let x = solve::<f32, 2>(&to(a), &[1.0, 2.0], 2f32.powi(-20)).expect("f32 fits");
    assert!(
        (x[1] - 256.0).abs() < 1e-3 && (x[0] + 255.0).abs() < 1e-3,
        "{x:?}"
    );
}

#[test]
fn zero_matrix_and_partial_pivoting() {
    let z = [[0.0; 3]; 3];
    assert!(matches!(
        Lu::<f32, 3>::factor(&to(z), 1e-6),
        Err(LuError::ZeroMatrix)
    ));
    // A zero leading entry needs a row swap; without pivoting this fails.
    let a = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]];
    let xt = [0.5, -1.25, 2.0];
    let b: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| a[i][j] * xt[j]).sum());
    for (got, want) in solve::<Q8_24, 3>(
        &to(a),
        &b.map(|v| Q8_24::from_f32(v as f32)),
        Q8_24::from_int_pow2(1, -20),
    )
    .expect("regular")
    .iter()
    .zip(xt)
    {
        assert!(
            (f64::from(got.to_f32()) - want).abs() < 1e-6,
            "{got:?} vs {want}"
        );
    }
}

/// Random well-conditioned 6x6 systems: the fixed solve agrees with f64 to the format's
/// resolution times the condition number.
#[test]
fn random_regular_systems_are_solved_accurately() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for _ in 0..500 {
        let a: [[f64; 6]; 6] = std::array::from_fn(|i| {
            std::array::from_fn(|j| rng.gen_range(-1.0..1.0) + if i == j { 3.0 } else { 0.0 })
        });
        let b: [f64; 6] = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
        let aq: [[Q8_24; 6]; 6] = to(a);
        let bq = b.map(|v| Q8_24::from_f32(v as f32));
        let xq = solve::<Q8_24, 6>(&aq, &bq, Q8_24::from_int_pow2(1, -20)).expect("regular");
        let na = nalgebra::Matrix6::from_fn(|i, j| f64::from(aq[i][j].to_f32()));
        let nb = nalgebra::Vector6::from_fn(|i, _| f64::from(bq[i].to_f32()));
        let x = na.lu().solve(&nb).expect("regular");
        let cond = na.norm() * na.try_inverse().expect("regular").norm();
        for k in 0..6 {
            let err = (f64::from(xq[k].to_f32()) - x[k]).abs();
            assert!(err < 64.0 * cond * 6e-8, "err {err:e} cond {cond}");
        }
    }
}
