//! The numbers behind the kernel's number formats (kernel/README.md, "Range analysis"),
//! measured on the open recording o01 (1 s firings at 1 kHz) with the fixed-point kernel.
//! `cargo test -p massid-tests --test kernel_range -- --nocapture` prints them.
use massid_kernel::model::{SPH2, SPH2_GYRO_BIAS_COUNTS};
use massid_kernel::omega_dot::KfConfig;
use massid_kernel::{Pipeline, PipelineConfig, Scalar, TickEvent, Q8_24};
use reference_f64::recording::Recording;

#[test]
fn kalman_and_rls_ranges_on_a_1s_firing() {
    let rec =
        Recording::read(&massid_tests::open_data_dir().join("o01_nominal_rga12.csv")).expect("o01");
    let cfg = PipelineConfig::<Q8_24>::with_gyroscopic(1, SPH2_GYRO_BIAS_COUNTS);
    let kf = KfConfig::seed(1);
    let mut p = Pipeline::<Q8_24>::new(&SPH2, cfg).expect("model");
    let (mut max_info, mut min_var, mut max_sk2, mut max_skz) = (0.0f64, f64::INFINITY, 0u64, 0i64);
    let mut worst_rel = 0.0f64;
    let (mut exp_lo, mut exp_hi) = (i32::MAX, i32::MIN);
    let mut max_mantissa = 0.0f64;
    for s in &rec.samples {
        let r = p.tick(s.gyro, s.thrusters);
        if r.event != TickEvent::Updated {
            continue;
        }
        let e = p.omega_dot().expect("estimate");
        let sums = p.kalman().sums();
        max_sk2 = max_sk2.max(sums.sk2);
        max_skz = max_skz.max(sums.skz.iter().map(|v| v.abs()).max().unwrap_or(0));
        for a in 0..3 {
            let info = e.information[a].to_f64();
            let var = e.variance[a].to_f64();
            max_info = max_info.max(info);
            min_var = min_var.min(var);
            // The same closed form in f64 from the exact integer sums.
            let kappa = kf.delay_ticks;
            let n = sums.n as f64;
            let s2 = sums.sk2 as f64 - 2.0 * kappa * sums.sk as f64 + kappa * kappa * n;
            let r = kf.r_rad2_s2[a];
            let dt = kf.dt_s;
            let info64 = 1.0 / kf.p0 + dt * dt * s2 / r;
            worst_rel = worst_rel
                .max((info - info64).abs() / info64)
                .max((var * info64 - 1.0).abs());
        }
        let (c, i) = p.mass_id().problems();
        for e in [c.exponent(), i.exponent()] {
            exp_lo = exp_lo.min(e);
            exp_hi = exp_hi.max(e);
        }
        for v in i
            .information()
            .iter()
            .flatten()
            .chain(i.info_vector().iter())
            .chain(c.information().iter().flatten())
        {
            max_mantissa = max_mantissa.max(f64::from(v.to_f32().abs()));
        }
    }
    println!("Kalman information max {max_info:.3e} (rad/s^2)^-2, variance min {min_var:.3e} (rad/s^2)^2");
    println!("integer sums: sum k^2 max {max_sk2} ({} bits), |sum k z| max {max_skz} ({} bits, Q12 counts)",
        64 - max_sk2.leading_zeros(), 64 - max_skz.unsigned_abs().leading_zeros());
    println!("block-float information/variance vs f64 of the same sums: worst relative error {worst_rel:.2e}");
    println!("RLS information exponents {exp_lo}..{exp_hi}, largest mantissa {max_mantissa:.3}");
    // The numbers: ~3e9 and ~3e-10 after a 1 s firing at 1 kHz ...
    assert!(max_info > 1e9 && max_info < 1e10, "{max_info}");
    assert!(min_var > 1e-10 && min_var < 1e-9, "{min_var}");
    // ... far outside any 32-bit fixed format (Q16.16 holds 3.3e4 down to 1.5e-5) ...
    assert!(max_info > 32768.0 && min_var < 2f64.powi(-16));
    // ... carried exactly as integers (well inside i64) and as block floating point to the
    // format's precision.
    assert!(max_sk2 < 1 << 40 && max_skz < 1 << 50);
    assert!(worst_rel < 1e-6, "{worst_rel}");
    // RLS mantissas stay O(1) (below 2^5) whatever the exponent does.
    assert!(max_mantissa < 32.0, "{max_mantissa}");
}
