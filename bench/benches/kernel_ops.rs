//! Criterion benchmarks: each kernel operation and the whole per-tick pipeline in the f64
//! reference, kernel f32 and kernel fixed point, against the baseline
//! [`massid_bench::naive::NaiveSeedPipeline`] / plain nalgebra f64 (the first entry of each
//! group). `scripts/bench-report.sh` turns criterion's estimates into ratio tables.
use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion};
use massid_bench::naive::NaiveSeedPipeline;
use massid_bench::rga12_samples;
use massid_kernel::{lu, mixer, model, Pipeline, PipelineConfig, Scalar, Q8_24};
use nalgebra::{SMatrix, SVector, Vector3};
use reference_f64::pipeline::{OnlineEstimator, PipelineConfig as RefConfig};
use reference_f64::satellite::Satellite;

fn pipeline(c: &mut Criterion) {
    let samples = rga12_samples();
    let sat = Satellite::builtin("sph2").expect("built-in sph2");
    let mut g = c.benchmark_group("pipeline_rga12_28s");
    g.sample_size(10);
    g.bench_function("baseline_naive_f64", |b| {
        b.iter(|| {
            let mut p = NaiveSeedPipeline::new(&sat, 1000.0);
            for s in &samples {
                p.tick(s);
            }
            black_box(p.inv_inertia)
        })
    });
    g.bench_function("reference_f64", |b| {
        let cfg = RefConfig {
            keep_history: false,
            ..RefConfig::default()
        };
        b.iter(|| {
            let mut p = OnlineEstimator::new(&sat, &cfg, 1000.0);
            for s in &samples {
                black_box(p.push(s));
            }
            black_box(p.finish().inertia_kgm2)
        })
    });
    fn kernel<S: Scalar>(
        samples: &[reference_f64::recording::Sample],
    ) -> massid_kernel::Estimates<S> {
        let Ok(mut p) = Pipeline::<S>::new(&model::SPH2, PipelineConfig::seed(1)) else {
            panic!("kernel pipeline rejected SPH2")
        };
        for s in samples {
            black_box(p.tick(s.gyro, s.thrusters));
        }
        p.finish();
        p.estimates()
    }
    g.bench_function("kernel_f32", |b| {
        b.iter(|| black_box(kernel::<f32>(&samples)))
    });
    g.bench_function("kernel_fixed_q8_24", |b| {
        b.iter(|| black_box(kernel::<Q8_24>(&samples)))
    });
    g.finish();
}

/// A well-conditioned SPD 6x6 like the inverse-inertia information matrix.
fn spd6() -> ([[f64; 6]; 6], [f64; 6]) {
    let mut a = [[0.0; 6]; 6];
    for (i, row) in a.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = if i == j {
                4.0 + i as f64 * 0.5
            } else {
                1.0 / (1.0 + (i + j) as f64)
            };
        }
    }
    (a, [1.0, -0.5, 0.25, 2.0, -1.0, 0.5])
}

fn lu_solve(c: &mut Criterion) {
    let (a, b) = spd6();
    let mut g = c.benchmark_group("lu_solve_6x6");
    let am = SMatrix::<f64, 6, 6>::from_fn(|i, j| a[i][j]);
    let bv = SVector::<f64, 6>::from_column_slice(&b);
    g.bench_function("baseline_nalgebra_f64_inverse", |bch| {
        bch.iter(|| black_box(black_box(am).try_inverse().map(|inv| inv * bv)))
    });
    g.bench_function("nalgebra_f64_lu_solve", |bch| {
        bch.iter(|| black_box(black_box(am).lu().solve(&bv)))
    });
    fn conv<S: Scalar>(a: &[[f64; 6]; 6], b: &[f64; 6]) -> ([[S; 6]; 6], [S; 6]) {
        (
            a.map(|r| r.map(|v| S::from_f32(v as f32))),
            b.map(|v| S::from_f32(v as f32)),
        )
    }
    let (af, bf) = conv::<f32>(&a, &b);
    g.bench_function("kernel_f32", |bch| {
        bch.iter(|| black_box(lu::solve(black_box(&af), &bf, 1e-6f32)))
    });
    let (aq, bq) = conv::<Q8_24>(&a, &b);
    let tol = Q8_24::from_f32(1e-6);
    g.bench_function("kernel_fixed_q8_24", |bch| {
        bch.iter(|| black_box(lu::solve(black_box(&aq), &bq, tol)))
    });
    g.finish();
}

fn mix(c: &mut Criterion) {
    let sat = Satellite::builtin("sph2").expect("built-in sph2");
    let mut g = c.benchmark_group("mixer_command");
    let force = Vector3::new(0.05, -0.02, 0.01);
    let torque = Vector3::new(0.002, 0.001, -0.003);
    let rm = reference_f64::mixer::Mixer::from_satellite(&sat, None, 200).expect("reference mixer");
    g.bench_function("baseline_reference_f64", |b| {
        b.iter(|| black_box(rm.mix(black_box(force), torque)))
    });
    fn kmix<S: Scalar>() -> mixer::Mixer<S> {
        let cfg = mixer::MixerConfig {
            period_ms: 200,
            min_pulse_ms: 10,
            pressure_drop_n: S::from_f32(0.0),
        };
        match mixer::Mixer::new(&model::SPH2, [S::from_f32(0.0); 3], cfg) {
            Ok(m) => m,
            Err(e) => panic!("kernel mixer: {e:?}"),
        }
    }
    let f = |v: Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
    let mf = kmix::<f32>();
    g.bench_function("kernel_f32", |b| {
        b.iter(|| black_box(mf.mix(black_box(f(force)), f(torque))))
    });
    let mq = kmix::<Q8_24>();
    let q = |v: Vector3<f64>| f(v).map(Q8_24::from_f32);
    g.bench_function("kernel_fixed_q8_24", |b| {
        b.iter(|| black_box(mq.mix(black_box(q(force)), q(torque))))
    });
    g.bench_function("kernel_f32_rebuild_from_com", |b| {
        b.iter_batched(
            || [0.001f32, -0.002, 0.0005],
            |com| {
                black_box(mixer::Mixer::new(
                    &model::SPH2,
                    com,
                    mixer::MixerConfig {
                        period_ms: 200,
                        min_pulse_ms: 10,
                        pressure_drop_n: 0.0f32,
                    },
                ))
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, pipeline, lu_solve, mix);
criterion_main!(benches);
