//! The onboard kernel (f32 and Q8_24 fixed point) against the f64 reference and the
//! recordings' truth.
use massid_kernel::model::SatelliteParams;
use massid_kernel::{Pipeline, PipelineConfig, Scalar, Q8_24};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

/// The kernel's plain-array parameters from a reference model.
fn params(sat: &Satellite) -> SatelliteParams {
    SatelliteParams {
        thruster_pos_m: sat.thruster_pos_m.map(|p| p.map(|v| v as f32)),
        thrust_dir: sat.thrust_dir.map(|p| p.map(|v| v as f32)),
        thrust_n: sat.thrust_n.map(|v| v as f32),
        inertia_kgm2: sat.inertia_kgm2.map(|v| v as f32),
        com_offset_mm: sat.com_offset_mm.map(|v| v as f32),
        gyro_counts_per_rad_s: sat.gyro_counts_per_rad_s.map(|v| v as f32),
        pressure_drop_n_per_extra: sat.pressure_drop_n_per_extra as f32,
    }
}

/// Runs a recording through the kernel, one tick per sample period (gaps as gap ticks).
fn run<S: Scalar>(rec: &Recording, sat: &Satellite) -> massid_kernel::Estimates<S> {
    let dt = rec.sample_period_ms().max(1);
    let mut p = Pipeline::<S>::new(&params(sat), PipelineConfig::seed(dt as u32)).expect("model");
    let mut prev_t: Option<u64> = None;
    for s in &rec.samples {
        if let Some(t0) = prev_t {
            let missing = (s.time_ms.saturating_sub(t0) / dt).saturating_sub(1);
            for _ in 0..missing {
                p.tick_gap();
            }
        }
        p.tick(s.gyro, s.thrusters);
        prev_t = Some(s.time_ms);
    }
    p.finish();
    p.estimates()
}

fn open_recordings() -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(massid_tests::open_data_dir())
        .expect("open data dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    v.sort();
    v
}

#[test]
fn explore_open_recordings() {
    let sat = Satellite::builtin("sph2").expect("sph2");
    for path in open_recordings() {
        let rec = Recording::read(&path).expect("recording");
        let ef = run::<f32>(&rec, &sat);
        let eq = run::<Q8_24>(&rec, &sat);
        println!(
            "{}: f32 {:?} com {:?} I {:?}\n     fixed {:?} com {:?} I {:?}",
            path.file_name().unwrap().to_string_lossy(),
            ef.status,
            ef.com_offset_mm(),
            ef.inertia_kgm2(),
            eq.status,
            eq.com_offset_mm(),
            eq.inertia_kgm2()
        );
    }
}

#[test]
#[ignore]
fn debug_firings() {
    let sat = Satellite::builtin("sph2").expect("sph2");
    let rec = Recording::read(&massid_tests::open_data_dir().join("o09_nominal_artefacts_combo.csv")).unwrap();
    let mut p = Pipeline::<f32>::new(&params(&sat), PipelineConfig::seed(1)).expect("model");
    let mut last_word = 0;
    let mut last_est = None;
    let mut n = 0;
    let mut lam = [[0.0f64; 6]; 6];
    let mut eta = [0.0f64; 6];
    let mut lam2 = [[0.0f64; 6]; 6];
    let mut direct = massid_kernel::rls::InfoLs::<f32, 6>::new();
    let mut eta2 = [0.0f64; 6];
    for s in &rec.samples {
        if s.thrusters != last_word {
            if let Some(e) = last_est.take() {
                let e: massid_kernel::omega_dot::OmegaDotEstimate<f32> = e;
                let ft = p.model_terms().firing_terms(last_word);
                if n < 5 { println!("word {:4} upd {:3} est {:?} nom {:?}", last_word, e.updates, e.omega_dot, ft.omega_dot_nominal); }
                n += 1;
                if last_word != 0 && e.updates > 0 {
                    let a = ft.torque_cnm;
                    let rows = massid_kernel::model::inertia_rows(&a);
                    let w: Vec<f64> = e.information.iter().map(|v| v.to_f64()).collect();
                    for i in 0..3 { for j in 0..6 { for k in 0..6 { lam[j][k] += w[i] * rows[i][j] as f64 * rows[i][k] as f64; } eta[j] += w[i]*rows[i][j] as f64 * e.omega_dot[i] as f64; } }
                }
            }
            last_word = s.thrusters;
        }
        let r = p.tick(s.gyro, s.thrusters);
        if let Some(e) = p.omega_dot() { last_est = Some(e); }
        if r.event == massid_kernel::TickEvent::Updated {
            let e = p.omega_dot().unwrap();
            let ft = p.model_terms().firing_terms(s.thrusters);
            let rows = massid_kernel::model::inertia_rows(&ft.torque_cnm);
            let w: Vec<f64> = e.information.iter().map(|v| v.to_f64()).collect();
            direct.add(&rows, &e.omega_dot, &e.information);
            for i in 0..3 { for j in 0..6 { for k in 0..6 { lam2[j][k] += w[i] * rows[i][j] as f64 * rows[i][k] as f64; } eta2[j] += w[i]*rows[i][j] as f64 * e.omega_dot[i] as f64; } }
        }
    }
    let _ = n;
    let l = nalgebra::Matrix6::from_fn(|i, j| lam[i][j]);
    let e = nalgebra::Vector6::from_fn(|i, _| eta[i]);
    let x = l.lu().solve(&e).unwrap() * 100.0;
    let m = nalgebra::Matrix3::new(x[0], x[3], x[4], x[3], x[1], x[5], x[4], x[5], x[2]);
    println!("per-firing LS: I = {}", m.try_inverse().unwrap());
    let l = nalgebra::Matrix6::from_fn(|i, j| lam2[i][j]);
    let e = nalgebra::Vector6::from_fn(|i, _| eta2[i]);
    let x = l.lu().solve(&e).unwrap() * 100.0;
    let m = nalgebra::Matrix3::new(x[0], x[3], x[4], x[3], x[1], x[5], x[4], x[5], x[2]);
    println!("per-tick LS: I = {}", m.try_inverse().unwrap());
    let sol = direct.solve(&[0.0;6], 1e-6, 1e-7).unwrap();
    println!("direct InfoLs x {:?} exp {} lam {:?}", sol.x, direct.exponent(), direct.information());
    println!("f64 x {:?}", x/100.0);
    p.finish();
    let (_, pi) = p.mass_id().problems();
    println!("pipeline InfoLs exp {} lam {:?} eta {:?} sat {}", pi.exponent(), pi.information(), pi.info_vector(), pi.is_saturated());
    println!("direct eta {:?}", direct.info_vector());
    println!("kernel: {:?}", p.estimates().inertia_kgm2());
}

#[test]
#[ignore]
fn debug_fixed() {
    let sat = Satellite::builtin("sph2").expect("sph2");
    let rec = Recording::read(&massid_tests::open_data_dir().join("o01_nominal_rga12.csv")).unwrap();
    let mut p = Pipeline::<Q8_24>::new(&params(&sat), PipelineConfig::seed(1)).expect("model");
    for s in &rec.samples {
        let r = p.tick(s.gyro, s.thrusters);
        if r.event == massid_kernel::TickEvent::Solved || r.event == massid_kernel::TickEvent::KfOverflow {
            let (pc, pi) = p.mass_id().problems();
            let cs = pc.solve(&[Q8_24::ZERO; 3], Q8_24::from_f32(1.0/16384.0), Q8_24::from_f32(1e-6)).map(|s| s.x);
            let is = pi.solve(&[Q8_24::ZERO; 6], Q8_24::from_f32(1.0/16384.0), Q8_24::from_f32(1e-6)).map(|s| s.x);
            println!("   com {:?}\n   inertia {:?}\n   inertia lam {:?} eta {:?}", cs, is, pi.information(), pi.info_vector());
            println!("t {} {:?} com exp {} sat {} diag {:?} eta {:?} | inertia exp {} sat {}", s.time_ms, r, pc.exponent(), pc.is_saturated(),
                pc.information(), pc.info_vector(), pi.exponent(), pi.is_saturated());
        }
    }
}
