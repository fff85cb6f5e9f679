//! The one place where ground code meets the onboard kernel: a ground [`Satellite`] becomes
//! the kernel's plain-array [`SatelliteParams`], a [`Recording`] becomes ticks (a telemetry
//! gap is one [`Pipeline::tick_gaps`] call, O(1) whatever its length, after the declared rate
//! was checked against the time steps), and the kernel's estimates become the estimate
//! contract's [`Estimate`] (status, unobservable terms, standard errors with the kernel's
//! variance factor). The CLI's `estimate` and `demo` and the tests all go through here.

pub mod craft;
pub mod flight_id;

use massid_kernel::model::SatelliteParams;
use massid_kernel::validity::Invalid;
use massid_kernel::{Pipeline, PipelineConfig, PipelineStatus, Scalar, TickReport};
use reference_f64::mass_id::{inertia_from_inverse, sym_to_vec6, COM_TERMS, INERTIA_TERMS};
use reference_f64::pipeline::Estimate;
use reference_f64::recording::{Recording, RecordingError};
use reference_f64::satellite::Satellite;

/// Why a recording could not be run through the kernel.
#[derive(Debug, thiserror::Error)]
pub enum HostError {
    /// The recording contradicts itself (e.g. its declared rate and its time steps).
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The kernel's identification gave no estimate.
    #[error("{0}")]
    Fit(String),
    /// The kernel rejects the model.
    #[error("satellite {name}: the kernel rejects the model ({why})")]
    Model {
        /// The model's name.
        name: String,
        /// The kernel's reason.
        why: String,
    },
}

/// The kernel's plain-array parameters (f32) from a ground model. The kernel flies the
/// 3-D, 12-thruster SPHERES layout: any other model is refused here, rather than padded
/// or truncated, and a planar craft is refused because the kernel's 3-D RLS would report
/// terms a planar craft cannot identify.
pub fn params(sat: &Satellite) -> Result<SatelliteParams, HostError> {
    let refuse = |why: String| HostError::Model {
        name: sat.name.clone(),
        why,
    };
    if sat.planar {
        return Err(refuse(
            "a planar craft: the kernel identifies 3-D mass properties only".into(),
        ));
    }
    let n = sat.n_thrusters();
    let twelve = |v: &[[f64; 3]]| -> Result<[[f32; 3]; 12], HostError> {
        let a: &[[f64; 3]; 12] = v.try_into().map_err(|_| {
            refuse(format!(
                "{n} thrusters: the kernel is built for 12 (model.rs N_THRUSTERS)"
            ))
        })?;
        Ok(a.map(|p| p.map(|v| v as f32)))
    };
    let thrust_n: &[f64; 12] = sat.thrust_n.as_slice().try_into().map_err(|_| {
        refuse(format!(
            "{n} thrusters: the kernel is built for 12 (model.rs N_THRUSTERS)"
        ))
    })?;
    Ok(SatelliteParams {
        thruster_pos_m: twelve(&sat.thruster_pos_m)?,
        thrust_dir: twelve(&sat.thrust_dir)?,
        thrust_n: thrust_n.map(|v| v as f32),
        inertia_kgm2: sat.inertia_kgm2.map(|v| v as f32),
        com_offset_mm: sat.com_offset_mm.map(|v| v as f32),
        gyro_counts_per_rad_s: sat.gyro_counts_per_rad_s.map(|v| v as f32),
        pressure_drop_n_per_extra: sat.pressure_drop_n_per_extra as f32,
    })
}

/// The configuration the reference's online form corresponds to: the seed's settings at
/// `period_ms` with the gyroscopic terms at the model's gyro bias.
pub fn config<S: Scalar>(period_ms: u64, sat: &Satellite) -> PipelineConfig<S> {
    let dt = u32::try_from(period_ms.max(1)).unwrap_or(u32::MAX);
    PipelineConfig::with_gyroscopic(dt, sat.gyro_bias_counts.map(|v| v as f32))
}

/// A pipeline for `sat` with `cfg`.
pub fn pipeline<S: Scalar>(
    sat: &Satellite,
    cfg: PipelineConfig<S>,
) -> Result<Pipeline<S>, HostError> {
    Pipeline::new(&params(sat)?, cfg).map_err(|e| HostError::Model {
        name: sat.name.clone(),
        why: format!("{e:?}"),
    })
}

/// Feeds every sample of `rec` to `p` as flight code sees it: one tick per sample period,
/// a gap of `k` missing periods as one `tick_gaps(k)` (time advances without a sample).
/// `on_tick` sees the pipeline after each sample's tick with the sample's time.
pub fn drive<S: Scalar>(
    rec: &Recording,
    p: &mut Pipeline<S>,
    period_ms: u64,
    mut on_tick: impl FnMut(&Pipeline<S>, u64, TickReport),
) {
    let dt = period_ms.max(1);
    let mut prev: Option<u64> = None;
    for s in &rec.samples {
        if let Some(t0) = prev {
            let missing = (s.time_ms.saturating_sub(t0) / dt).saturating_sub(1);
            if missing > 0 {
                p.tick_gaps(missing);
            }
        }
        let r = p.tick(s.gyro, s.thrusters);
        on_tick(p, s.time_ms, r);
        prev = Some(s.time_ms);
    }
}

/// Runs a whole recording through a kernel pipeline (checked rate, gaps, end of the last
/// firing) and returns it.
pub fn run<S: Scalar>(rec: &Recording, sat: &Satellite) -> Result<Pipeline<S>, HostError> {
    let period = rec.checked_period_ms()?;
    let mut p = pipeline::<S>(sat, config(period, sat))?;
    drive(rec, &mut p, period, |_, _, _| {});
    p.finish();
    Ok(p)
}

/// The estimate contract's result for a recording, by the kernel in format `S`.
pub fn estimate<S: Scalar>(rec: &Recording, sat: &Satellite) -> Result<Estimate, HostError> {
    let p = run::<S>(rec, sat)?;
    Ok(to_estimate(&p, sat))
}

/// The contract's status string of a kernel's final state (see `contracts/estimate-output.md`
/// and the reference's statuses; the implausible ones name the failed check).
pub fn status_name<S: Scalar>(p: &Pipeline<S>, any_unobservable: bool) -> &'static str {
    let e = p.estimates();
    if e.updates == 0 {
        // Nothing was fitted: say why.
        return if e.data.unresponsive_firings > 0 {
            "no_gyro_response"
        } else if e.data.railed_firings > 0 {
            "gyro_saturated"
        } else {
            "no_firings"
        };
    }
    match e.status {
        PipelineStatus::Idle => "no_firings",
        PipelineStatus::Batch | PipelineStatus::Ok if !any_unobservable => "ok",
        PipelineStatus::Batch | PipelineStatus::Ok | PipelineStatus::PartlyUnobservable => {
            "unobservable_terms"
        }
        PipelineStatus::Singular => "singular_information",
        PipelineStatus::Overflow => "overflow",
        PipelineStatus::Implausible => match e.invalid {
            Some(Invalid::NotPositiveDefinite) | None => {
                "implausible_inertia_not_positive_definite"
            }
            Some(Invalid::TriangleInequality) => "implausible_inertia_triangle_inequality",
            Some(Invalid::ComOutsideEnvelope) => "implausible_com_outside_envelope",
        },
    }
}

/// The kernel's final state as the contract's [`Estimate`]. Standard errors: the kernel's LS
/// variances times its variance factors (`MassId::variance_factors`); a term held at the
/// model gets the weak prior's standard error; inertia by the reference's first-order
/// propagation `dI = -I dJ I` (`J = 100 theta`), terms taken as independent. A standard error the kernel
/// could not form is NaN (`null` in JSON) and the status says `uncertainty_undefined`.
pub fn to_estimate<S: Scalar>(p: &Pipeline<S>, sat: &Satellite) -> Estimate {
    let e = p.estimates();
    let (var_c, var_i) = p.mass_id().variances();
    let mut unobservable: Vec<String> = Vec::new();
    for (n, u) in COM_TERMS.iter().zip(e.unobservable_com.iter()) {
        if *u {
            unobservable.push(n.to_string());
        }
    }
    for (n, u) in INERTIA_TERMS.iter().zip(e.unobservable_inertia.iter()) {
        if *u {
            unobservable.push(n.to_string());
        }
    }
    let idle = e.status == PipelineStatus::Idle || e.updates == 0;
    if idle {
        unobservable = COM_TERMS
            .iter()
            .chain(INERTIA_TERMS.iter())
            .map(|s| s.to_string())
            .collect();
    }
    let mut status = status_name(p, !unobservable.is_empty());
    let inertia = if idle {
        sat.inertia_kgm2
    } else {
        e.inertia_kgm2().unwrap_or(sat.inertia_kgm2)
    };
    // The weak priors the kernel starts from (`RlsConfig::default`): CoM 20 mm; inverse
    // inertia 100 % of the mean nominal diagonal.
    let cfg = massid_kernel::rls::RlsConfig::<S>::default();
    let prior_com_mm = f64::from(cfg.prior_com_std_m) * 1e3;
    let j_nom = e.inertia_inverse();
    let prior_j =
        f64::from(cfg.prior_inertia_rel_std) * (j_nom[0][0] + j_nom[1][1] + j_nom[2][2]) / 3.0;
    let com_held = if idle { [true; 3] } else { e.unobservable_com };
    let inertia_held = if idle {
        [true; 6]
    } else {
        e.unobservable_inertia
    };
    let com_stderr: [f64; 3] = core::array::from_fn(|j| {
        if com_held[j] {
            prior_com_mm
        } else {
            var_c[j]
                .map(|v| v.to_f64())
                .filter(|v| v.is_finite() && *v > 0.0)
                .map_or(f64::NAN, |v| v.sqrt() * 1e3)
        }
    });
    let var_j: [f64; 6] = core::array::from_fn(|j| {
        if inertia_held[j] {
            prior_j * prior_j
        } else {
            var_i[j]
                .map(|v| v.to_f64() * 1e4)
                .filter(|v| v.is_finite() && *v > 0.0)
                .unwrap_or(f64::NAN)
        }
    });
    // dI = -I dJ I (the reference's exact first-order propagation), terms independent.
    let inertia_stderr = {
        let [xx, yy, zz, xy, xz, yz] = inertia;
        let i = nalgebra::Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
        let j = i.try_inverse().map(|m| sym_to_vec6(&m));
        let cov = nalgebra::SMatrix::<f64, 6, 6>::from_diagonal(&nalgebra::SVector::from(var_j));
        j.and_then(|j| inertia_from_inverse(&j, &cov))
            .map(|(_, c)| [0, 1, 2, 3, 4, 5].map(|k| c[(k, k)].max(0.0).sqrt()))
            .unwrap_or([f64::NAN; 6])
    };
    if status == "ok"
        && com_stderr
            .iter()
            .chain(inertia_stderr.iter())
            .any(|v| !v.is_finite())
    {
        status = "uncertainty_undefined";
    }
    let vf = p.mass_id().variance_factors().map(|v| v.to_f64());
    Estimate {
        com_offset_mm: if idle { [0.0; 3] } else { e.com_offset_mm() },
        com_offset_stderr_mm: com_stderr,
        inertia_kgm2: inertia,
        inertia_stderr_kgm2: inertia_stderr,
        unobservable,
        updates: e.updates as usize,
        status: status.into(),
        history: Vec::new(),
        batch_all_com_offset_mm: e.com_offset_mm(),
        batch_all_inertia_kgm2: inertia,
        variance_factor: vf,
        detections_s: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_kernel_tables_equal_the_reference() {
        // The kernel carries its own SPHERES tables (no allocation, no parsing onboard):
        // they must be the reference's to f32 precision.
        let k = massid_kernel::model::SPH2;
        let r = params(&Satellite::builtin("sph2").expect("sph2")).expect("sph2 flies");
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0);
        for i in 0..massid_kernel::model::N_THRUSTERS {
            for a in 0..3 {
                assert!(
                    close(k.thruster_pos_m[i][a], r.thruster_pos_m[i][a]),
                    "thruster {i} pos"
                );
                assert!(
                    close(k.thrust_dir[i][a], r.thrust_dir[i][a]),
                    "thruster {i} dir"
                );
            }
            assert!(close(k.thrust_n[i], r.thrust_n[i]), "thruster {i} force");
        }
        for j in 0..6 {
            assert!(close(k.inertia_kgm2[j], r.inertia_kgm2[j]), "inertia {j}");
        }
        let bias = Satellite::builtin("sph2").expect("sph2").gyro_bias_counts;
        for a in 0..3 {
            assert!(close(k.com_offset_mm[a], r.com_offset_mm[a]), "com {a}");
            assert!(
                close(k.gyro_counts_per_rad_s[a], r.gyro_counts_per_rad_s[a]),
                "gyro scale {a}"
            );
            assert!(
                close(
                    massid_kernel::model::SPH2_GYRO_BIAS_COUNTS[a],
                    bias[a] as f32
                ),
                "gyro bias {a}"
            );
        }
    }
}
