//! Effects that give the same rates on a recording: the contract's equivalence classes. The
//! diagnosis names one member (the selection never fits two together: `select::combinable`
//! for the timing class, the exchange's backward step for the rest) and lists the others,
//! with the parameters that make them equal, under `equivalent_to`.
//!
//! The classes follow from the equations of motion, not from the recording at hand:
//! - a `measurement_delay` d is an equal `thruster_latency` (open = close = d) on every edge,
//!   as long as no effect with a time of its own is named (a mass-property change or a
//!   blowdown: the delay shifts its time, a latency does not);
//! - a uniform `thrust_scale` s is the `inertia` divided by s (I^-1 s tau = (I/s)^-1 tau, and
//!   the gyroscopic term I^-1 (w x I w) is unchanged), as long as no other torque is named
//!   (a disturbance, damping, slosh, pressure drop or mass change would have to be rescaled
//!   too: then nothing is listed);
//! - on a planar craft (yaw only) a `com_offset` changes each thruster's yaw torque alone, so
//!   it is a per-thruster `thrust_scale`;
//! - on a planar craft a yaw `gyro_scale` s is the `inertia` with Izz / s (the sensor reads
//!   s w, whose rate of change is s tau / Izz = tau / (Izz / s) for every torque; a planar
//!   craft has no gyroscopic term, which on a 3-D craft would scale by 1 / s instead), and the
//!   uniform `thrust_scale` s when no other torque is named, as long as nothing that acts on
//!   the rate itself or on the inertia is named with it (damping, a mass change, slosh, or
//!   the inertia or thrust scale that would stand for the same thing). On random planar craft
//!   a 10 % inertia change was named a gyro scale, and a 3 % gyro scale an inertia, on half
//!   the flights with nothing listed (`diagnose_random_craft`);
//! - a `thruster_misalignment` that tilts the force toward the thruster's lever arm only (the
//!   first tilt angle within its error of 0) keeps the torque's direction and changes its
//!   size: a rate sensor sees that thruster's `thrust_scale` (the force is not measured), as
//!   long as no effect moving the CoM or scaling thrusts is named with it. On craft whose
//!   thrusters are canted toward their arms (most but SPHERES) a weak thruster was named as
//!   an 18 degree tilt with no scale listed (`diagnose_random_craft`).
//!
//! A member is listed only when the fitted values lie in the class within their errors (a
//! latency with open and close equal, an inertia proportional to the model's, scales equal);
//! the test is a chi-square at 1 % (Wilson-Hilferty quantile). Mechanisms the equations do
//! not make equal but one recording cannot tell apart (a thrust rise and a latency in noisy
//! rates) are listed from the data instead: `diagnosis/indistinct.rs`.

use massid_sim::effects as contract;
use serde_json::Value;

use crate::effects::{contract_json, Context, Describe, Kind};
use crate::model::{Plant, NT};

/// Chi-square quantile at 99 % for `k` degrees of freedom (Wilson-Hilferty).
fn chi2_99(k: usize) -> f64 {
    let k = k.max(1) as f64;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + 2.326 * a.sqrt()).powi(3)
}

/// Effects whose torques would have to be rescaled with a thrust scale or an inertia for
/// the two to stay equal: with one of them named the simple equivalence does not hold.
const SCALE_BREAKERS: [Kind; 5] = [
    Kind::DisturbanceTorque,
    Kind::RateDamping,
    Kind::MassPropertyChange,
    Kind::FuelSlosh,
    Kind::PressureDrop,
];

/// Effects that move the CoM, scale thrusts or take a pressure drop off them (a drop is
/// subtracted from the force, not a factor of it), or refit the inertia the scale would stand
/// for: with one of them named, a tilt toward the lever arm is no longer one thruster's scale.
const TILT_BREAKERS: [Kind; 5] = [
    Kind::ComOffset,
    Kind::MassPropertyChange,
    Kind::ThrustScale,
    Kind::Inertia,
    Kind::PressureDrop,
];

/// Effects that act on the rate itself (damping, in proportion to it), move the inertia
/// (a mass change, slosh) or stand for the same scaling (an inertia, a thrust scale, a gyro
/// scale): with one of them named, a planar craft's gyro scale is no longer an inertia.
const GYRO_SCALE_BREAKERS: [Kind; 6] = [
    Kind::RateDamping,
    Kind::MassPropertyChange,
    Kind::FuelSlosh,
    Kind::Inertia,
    Kind::ThrustScale,
    Kind::GyroScale,
];

/// Effects with a time of their own on the body's clock (a change, a blowdown start): a
/// measurement delay shifts them too, a valve latency does not, so with one of them named
/// a delay and an equal latency no longer give the same rates.
const TIMING_BREAKERS: [Kind; 2] = [Kind::MassPropertyChange, Kind::Blowdown];

/// Weight 1/se^2 of a term; 0 for an unidentifiable one (NaN or infinite error).
fn weight(se: f64) -> f64 {
    if se.is_finite() && se > 0.0 {
        1.0 / (se * se)
    } else {
        0.0
    }
}

/// The other members of `kind`'s class that give the same rates as its fitted `theta`
/// (standard errors `se`, covariance `cov`: NaN where not known), each as
/// `{"effect": name, "params": {...}}`. `others`: the other effects named with it (some
/// break an equivalence that holds alone).
pub fn equivalents(
    kind: Kind,
    theta: &[f64],
    se: &dyn Fn(usize) -> f64,
    cov: &dyn Fn(usize, usize) -> f64,
    others: &[Kind],
    plant: &Plant,
    cx: &Context,
) -> Vec<Value> {
    let named = |k: Kind| others.contains(&k);
    let scale_breaks = SCALE_BREAKERS.iter().any(|&k| named(k));
    let gyro_scale_holds = plant.planar && !GYRO_SCALE_BREAKERS.iter().any(|&k| named(k));
    let timing_breaks = TIMING_BREAKERS.iter().any(|&k| named(k));
    let fired_idx: Vec<usize> = (0..cx.n_thrusters.min(NT))
        .filter(|&i| cx.fired[i])
        .collect();
    let per_thruster = |fired_values: &[f64]| -> Vec<f64> {
        let mut v = vec![1.0; cx.n_thrusters.min(NT)];
        for (&i, &s) in fired_idx.iter().zip(fired_values) {
            v[i] = s;
        }
        v
    };
    match kind {
        Kind::ThrusterLatency if !timing_breaks => {
            let (o, c) = (theta[0], theta[1]);
            // the difference's variance: open and close move together when the sensor sees
            // mostly their sum (a 40 / 20 ms latency was listed as a 30 ms delay)
            let shared = cov(0, 1);
            // (rounding can take the variance of equal, fully correlated terms just below 0)
            let var = (se(0).powi(2) + se(1).powi(2)
                - if shared.is_finite() {
                    2.0 * shared
                } else {
                    0.0
                })
            .max(0.0);
            if var.is_finite() && (o - c).powi(2) <= chi2_99(1) * var {
                let d = 0.5 * (o + c);
                vec![contract_json(&contract::Effect::MeasurementDelay(
                    contract::MeasurementDelay { delay_ms: d },
                ))]
            } else {
                vec![]
            }
        }
        Kind::MeasurementDelay if !timing_breaks => vec![contract_json(
            &contract::Effect::ThrusterLatency(contract::ThrusterLatency {
                open_ms: theta[0],
                close_ms: theta[0],
            }),
        )],
        Kind::Inertia if (!scale_breaks && !named(Kind::ThrustScale)) || gyro_scale_holds => {
            // the fitted inertia as r times the model's: identifiable terms only (yaw on a
            // planar craft)
            let i0 = cx.nominal_inertia;
            let terms: Vec<usize> = if plant.planar {
                vec![2]
            } else {
                (0..6).collect()
            };
            // a term held at the model's (`effects::HELD`, NaN error) is left out too: the
            // BIC found the rates do not need it moved, so r times the model's fits them as
            // well, and a uniform thrust scale is not to be hidden behind it
            let live: Vec<usize> = terms.into_iter().filter(|&i| weight(se(i)) > 0.0).collect();
            let den: f64 = live.iter().map(|&i| weight(se(i)) * i0[i] * i0[i]).sum();
            if live.is_empty() || den <= 0.0 || !den.is_finite() {
                return vec![];
            }
            let r = live
                .iter()
                .map(|&i| weight(se(i)) * theta[i] * i0[i])
                .sum::<f64>()
                / den;
            let chi2: f64 = live
                .iter()
                .map(|&i| weight(se(i)) * (theta[i] - r * i0[i]).powi(2))
                .sum();
            if r > 0.0 && chi2 <= chi2_99(live.len().saturating_sub(1)) {
                let mut out = vec![];
                if !scale_breaks && !named(Kind::ThrustScale) {
                    // every thruster of the model at 1/r (one that never fired could be anything)
                    let s = vec![1.0 / r; cx.n_thrusters.min(NT)];
                    out.push(contract_json(&contract::Effect::ThrustScale(
                        contract::ThrustScale { scale: s },
                    )));
                }
                if gyro_scale_holds {
                    out.extend(yaw_gyro_scale(1.0 / r, cx));
                }
                out
            } else {
                vec![]
            }
        }
        Kind::GyroScale if gyro_scale_holds && weight(se(2)) > 0.0 && theta[2] > 0.0 => {
            let s = theta[2];
            let mut inertia_kgm2 = cx.nominal_inertia;
            inertia_kgm2[2] /= s;
            let mut out = vec![contract_json(&contract::Effect::Inertia(
                contract::Inertia { inertia_kgm2 },
            ))];
            if !scale_breaks {
                out.push(contract_json(&contract::Effect::ThrustScale(
                    contract::ThrustScale {
                        scale: vec![s; cx.n_thrusters.min(NT)],
                    },
                )));
            }
            out
        }
        Kind::ThrustScale => {
            let mut out = vec![];
            if !scale_breaks && !named(Kind::Inertia) {
                if let Some((inertia, mean)) = uniform_scale_as_inertia(theta, se, cx) {
                    out.push(inertia);
                    if gyro_scale_holds {
                        out.extend(yaw_gyro_scale(mean, cx));
                    }
                }
            }
            if plant.planar
                && !named(Kind::ComOffset)
                && !named(Kind::MassPropertyChange)
                && !named(Kind::PressureDrop)
            {
                out.extend(planar_scales_as_com_offset(theta, se, plant, &fired_idx));
            }
            out
        }
        Kind::ThrusterMisalignment if !TILT_BREAKERS.iter().any(|&k| named(k)) => {
            let k = theta[0].round().clamp(0.0, (NT - 1) as f64) as usize;
            let (a, b) = (theta[1], theta[2]);
            let e = se(1);
            let n = cx.n_thrusters.min(NT);
            let before = plant.tilted_torque(k, [0.0; 2]);
            let size = before.norm_squared();
            if k >= n
                || !cx.fired[k]
                || !e.is_finite()
                || a * a > chi2_99(1) * e * e
                || size < 1e-18 * plant.thrust_n(k).powi(2).max(1e-300)
            {
                return vec![];
            }
            let mut scale = vec![1.0; n];
            scale[k] = plant.tilted_torque(k, [0.0, b]).dot(&before) / size;
            vec![contract_json(&contract::Effect::ThrustScale(
                contract::ThrustScale { scale },
            ))]
        }
        Kind::ComOffset if plant.planar && !named(Kind::ThrustScale) => {
            let off = [theta[0], theta[1], theta[2]];
            let mut s = vec![];
            for &i in &fired_idx {
                let before = plant.torque_about(i, &[0.0; 3])[2];
                let after = plant.torque_about(i, &off)[2];
                if before.abs() < 1e-9 * plant.thrust_n(i).max(1e-12) {
                    // a thruster with no yaw arm: its scale cannot stand in for the offset
                    return vec![];
                }
                s.push(after / before);
            }
            vec![contract_json(&contract::Effect::ThrustScale(
                contract::ThrustScale {
                    scale: per_thruster(&s),
                },
            ))]
        }
        _ => vec![],
    }
}

/// A planar craft's yaw gyro scale `s` (x and y at the model's 1), if its own effect finds
/// it plausible.
fn yaw_gyro_scale(s: f64, cx: &Context) -> Option<Value> {
    let scale = [1.0, 1.0, s];
    Kind::GyroScale
        .effect()
        .implausible(&scale, &|_| false, cx)
        .is_none()
        .then(|| contract_json(&contract::Effect::GyroScale(contract::GyroScale { scale })))
}

/// A uniform thrust scale (the fired thrusters' scales equal within their errors) as the
/// inertia divided by it, with the scale.
fn uniform_scale_as_inertia(
    theta: &[f64],
    se: &dyn Fn(usize) -> f64,
    cx: &Context,
) -> Option<(Value, f64)> {
    let live: Vec<usize> = (0..theta.len()).filter(|&j| weight(se(j)) > 0.0).collect();
    let den: f64 = live.iter().map(|&j| weight(se(j))).sum();
    if live.is_empty() || !den.is_finite() || den <= 0.0 {
        return None;
    }
    let mean = live.iter().map(|&j| weight(se(j)) * theta[j]).sum::<f64>() / den;
    let chi2: f64 = live
        .iter()
        .map(|&j| weight(se(j)) * (theta[j] - mean).powi(2))
        .sum();
    (mean > 0.0 && chi2 <= chi2_99(live.len().saturating_sub(1))).then(|| {
        let inertia_kgm2 = cx.nominal_inertia.map(|v| v / mean);
        (
            contract_json(&contract::Effect::Inertia(contract::Inertia {
                inertia_kgm2,
            })),
            mean,
        )
    })
}

/// On a planar craft, per-thruster scales as a CoM offset: each thruster's yaw torque is
/// linear in the offset, `tau_j(d) = tau_j + g_j . d`, so scales `s_j = 1 + g_j . d / tau_j`
/// are an offset when a weighted least-squares `d` reproduces them within their errors and
/// lies within the craft's plausible CoM range (the reverse of the offset's listing above:
/// with only that direction, a planar CoM offset named as scales had no offset listed). Two
/// scales are always some offset, so the range is what refuses a pair no CoM could give. A
/// fired thruster with no yaw arm refuses the listing, as in the other direction: an offset
/// gives it a torque no scale can.
fn planar_scales_as_com_offset(
    theta: &[f64],
    se: &dyn Fn(usize) -> f64,
    plant: &Plant,
    fired_idx: &[usize],
) -> Option<Value> {
    // per live thruster: (1 - s_j, a_j = -g_j / tau_j, weight)
    let rows: Vec<(f64, [f64; 2], f64)> = fired_idx
        .iter()
        .enumerate()
        .filter_map(|(j, &i)| {
            let tau = plant.torque_about(i, &[0.0; 3])[2];
            let w = weight(se(j)) * tau * tau;
            if w.is_nan() || w <= 0.0 || j >= theta.len() {
                return None;
            }
            let gx = plant.torque_about(i, &[1.0, 0.0, 0.0])[2] - tau;
            let gy = plant.torque_about(i, &[0.0, 1.0, 0.0])[2] - tau;
            Some((1.0 - theta[j], [-gx / tau, -gy / tau], weight(se(j))))
        })
        .collect();
    let no_arm = fired_idx
        .iter()
        .any(|&i| plant.torque_about(i, &[0.0; 3])[2].abs() < 1e-9 * plant.thrust_n(i).max(1e-12));
    if rows.len() < 2 || no_arm {
        return None;
    }
    let (mut n, mut b) = (nalgebra::Matrix2::zeros(), nalgebra::Vector2::zeros());
    for (y, a, w) in &rows {
        let a = nalgebra::Vector2::from(*a);
        n += *w * a * a.transpose();
        b += *w * *y * a;
    }
    let d = n.try_inverse()? * b;
    let chi2: f64 = rows
        .iter()
        .map(|(y, a, w)| w * (y - a[0] * d[0] - a[1] * d[1]).powi(2))
        .sum();
    let limit = crate::effects::plausible_com_mm(plant);
    let plausible = d.iter().all(|v| v.is_finite() && v.abs() <= limit);
    (plausible && chi2 <= chi2_99(rows.len().saturating_sub(2))).then(|| {
        contract_json(&contract::Effect::ComOffset(contract::ComOffset {
            offset_mm: [d[0], d[1], 0.0],
        }))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use reference_f64::satellite::Satellite;

    /// No covariance known: the errors alone.
    fn no_cov(_: usize, _: usize) -> f64 {
        f64::NAN
    }

    fn cx<'a>(fired: &'a [bool; NT], sat: &Satellite, plant: &'a Plant) -> Context<'a> {
        Context {
            duration_s: 60.0,
            nominal_inertia: sat.inertia_kgm2,
            min_thrust_n: 0.1,
            n_thrusters: sat.n_thrusters(),
            fired,
            slosh_hint_hz: &[],
            sample_rate_hz: 1000.0,
            command_step_ms: 200.0,
            inertia_start: None,
            plant,
        }
    }

    /// The planar air-bearing craft's model, its plant and every thruster fired.
    fn airbearing() -> (Satellite, Plant, [bool; NT]) {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .unwrap();
        let sat = massid_sim::model_file::ModelFile::read(
            &root.join("examples/models/airbearing-mpc.toml"),
        )
        .unwrap()
        .satellite;
        let plant = Plant::new(&sat);
        let mut fired = [false; NT];
        fired[..sat.n_thrusters()]
            .iter_mut()
            .for_each(|f| *f = true);
        (sat, plant, fired)
    }

    #[test]
    fn equal_latencies_are_a_delay_and_unequal_ones_are_not() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let fired = [true; NT];
        let c = cx(&fired, &sat, &plant);
        let se = |_: usize| 0.1;
        let eq = equivalents(
            Kind::ThrusterLatency,
            &[6.0, 6.1],
            &se,
            &no_cov,
            &[],
            &plant,
            &c,
        );
        assert_eq!(eq.len(), 1);
        assert_eq!(eq[0]["effect"], "measurement_delay");
        assert!((eq[0]["params"]["delay_ms"].as_f64().unwrap() - 6.05).abs() < 1e-9);
        // planted fault: 6 and 8 ms differ by 14 sigma, no delay gives that
        assert!(equivalents(
            Kind::ThrusterLatency,
            &[6.0, 8.0],
            &se,
            &no_cov,
            &[],
            &plant,
            &c
        )
        .is_empty());
        let d = equivalents(
            Kind::MeasurementDelay,
            &[120.0],
            &se,
            &no_cov,
            &[],
            &plant,
            &c,
        );
        assert_eq!(d[0]["params"]["open_ms"], 120.0);
    }

    /// Open and close latencies that a slow sensor sees mostly as their sum have large,
    /// strongly correlated errors: 40 and 20 ms are each 1.4 sigma apart, but their
    /// difference is 7 sigma, and no delay gives it. Without the covariance it was listed.
    #[test]
    fn correlated_latencies_are_a_delay_only_when_their_difference_is_small() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let fired = [true; NT];
        let c = cx(&fired, &sat, &plant);
        let se = |_: usize| 14.2;
        // correlation 0.98: the difference's error is 2.8 ms
        let cov = |i: usize, j: usize| {
            if i == j {
                14.2 * 14.2
            } else {
                0.98 * 14.2 * 14.2
            }
        };
        let lat = |theta: &[f64], cov: &dyn Fn(usize, usize) -> f64| {
            equivalents(Kind::ThrusterLatency, theta, &se, cov, &[], &plant, &c)
        };
        assert!(lat(&[40.0, 20.0], &cov).is_empty());
        assert_eq!(lat(&[40.0, 36.0], &cov)[0]["effect"], "measurement_delay");
        // planted fault: the errors alone call 40 / 20 ms a delay
        assert_eq!(lat(&[40.0, 20.0], &no_cov).len(), 1);
    }

    /// On the planar air-bearing craft a yaw gyro scale is the inertia with Izz / s and the
    /// uniform thrust scale s, and each of those lists the gyro scale; not with damping named
    /// (it acts on the rate itself), nor beyond the gyro scale's own 20 %, nor on a 3-D craft
    /// (SPHERES), whose gyroscopic term tells them apart. Planted: the SPHERES case.
    #[test]
    fn a_planar_craft_s_gyro_scale_is_its_inertia_and_thrust_scale() {
        let (sat, plant, fired) = airbearing();
        let n = sat.n_thrusters();
        let c = cx(&fired, &sat, &plant);
        let se = |_: usize| 0.002;
        let names = |kind: Kind, theta: &[f64], others: &[Kind]| -> Vec<Value> {
            equivalents(kind, theta, &se, &no_cov, others, &plant, &c)
        };
        let g = names(Kind::GyroScale, &[1.0, 1.0, 1.04], &[]);
        assert_eq!(g.len(), 2, "{g:?}");
        assert_eq!(g[0]["effect"], "inertia");
        let izz = g[0]["params"]["inertia_kgm2"][2].as_f64().unwrap();
        assert!((izz - sat.inertia_kgm2[2] / 1.04).abs() < 1e-12, "{izz}");
        assert_eq!(g[1]["effect"], "thrust_scale");
        assert_eq!(g[1]["params"]["scale"][0].as_f64(), Some(1.04));
        // a disturbance breaks the thrust scale's equality, not the inertia's
        let with_torque = names(
            Kind::GyroScale,
            &[1.0, 1.0, 1.04],
            &[Kind::DisturbanceTorque],
        );
        assert_eq!(with_torque.len(), 1);
        assert_eq!(with_torque[0]["effect"], "inertia");
        assert!(names(Kind::GyroScale, &[1.0, 1.0, 1.04], &[Kind::RateDamping]).is_empty());
        // the inertia 10 % up is a gyro scale of 1 / 1.1; 30 % up is past the scale's 20 %
        let mut inertia = sat.inertia_kgm2;
        inertia[2] *= 1.1;
        let i = names(Kind::Inertia, &inertia, &[]);
        let gyro: Vec<&Value> = i.iter().filter(|e| e["effect"] == "gyro_scale").collect();
        assert_eq!(gyro.len(), 1, "{i:?}");
        let s = gyro[0]["params"]["scale"][2].as_f64().unwrap();
        assert!((s - 1.0 / 1.1).abs() < 1e-9, "{s}");
        inertia[2] = sat.inertia_kgm2[2] * 1.3;
        assert!(!names(Kind::Inertia, &inertia, &[])
            .iter()
            .any(|e| e["effect"] == "gyro_scale"));
        let t = names(Kind::ThrustScale, &vec![0.95; n], &[]);
        assert!(t.iter().any(|e| e["effect"] == "gyro_scale"
            && (e["params"]["scale"][2].as_f64().unwrap() - 0.95).abs() < 1e-9));
        // SPHERES: a gyro scale is not an inertia
        let sph = Satellite::builtin("sph2").unwrap();
        let sph_plant = Plant::new(&sph);
        let all = [true; NT];
        let sc = cx(&all, &sph, &sph_plant);
        assert!(equivalents(
            Kind::GyroScale,
            &[1.04; 3],
            &se,
            &no_cov,
            &[],
            &sph_plant,
            &sc
        )
        .is_empty());
    }

    /// On the planar air-bearing craft, the per-thruster scales a CoM offset makes are listed
    /// as that offset, and the offset as those scales; scales no offset gives are not.
    #[test]
    fn a_planar_craft_s_scales_and_com_offset_are_listed_both_ways() {
        let (sat, plant, fired) = airbearing();
        let n = sat.n_thrusters();
        let c = cx(&fired, &sat, &plant);
        let off = [12.0, -7.0, 0.0];
        let scales: Vec<f64> = (0..n)
            .map(|i| plant.torque_about(i, &off)[2] / plant.torque_about(i, &[0.0; 3])[2])
            .collect();
        let se = |_: usize| 0.002;
        let listed = |theta: &[f64]| {
            equivalents(Kind::ThrustScale, theta, &se, &no_cov, &[], &plant, &c)
                .into_iter()
                .find(|e| e["effect"] == "com_offset")
        };
        let e = listed(&scales).expect("an offset listed");
        for (k, want) in off.iter().enumerate() {
            let got = e["params"]["offset_mm"][k].as_f64().unwrap();
            assert!((got - want).abs() < 1e-9, "{k}: {got} {want}");
        }
        // and back: the offset lists the same scales
        let back = equivalents(Kind::ComOffset, &off, &se, &no_cov, &[], &plant, &c);
        let s0 = back[0]["params"]["scale"][0].as_f64().unwrap();
        assert!((s0 - scales[0]).abs() < 1e-12);
        // planted fault: one thruster 20 % weak is no CoM offset (it moves one torque alone)
        let mut weak = vec![1.0; n];
        weak[0] = 0.8;
        assert!(listed(&weak).is_none());
    }

    /// A tilt toward the thruster's lever arm (second angle) only scales its torque: the
    /// listed scale gives the same torque. A tilt about the first axis turns the torque: no
    /// scale gives that, and nothing is listed.
    #[test]
    fn a_tilt_toward_the_arm_is_that_thruster_s_scale() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let fired = [true; NT];
        let c = cx(&fired, &sat, &plant);
        let se = |_: usize| 0.01;
        let k = 3;
        let eq = equivalents(
            Kind::ThrusterMisalignment,
            &[k as f64, 0.0, 0.2],
            &se,
            &no_cov,
            &[],
            &plant,
            &c,
        );
        assert_eq!(eq.len(), 1, "{eq:?}");
        assert_eq!(eq[0]["effect"], "thrust_scale");
        let s: Vec<f64> = eq[0]["params"]["scale"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let tilted = plant.tilted_torque(k, [0.0, 0.2]);
        let scaled = plant.tilted_torque(k, [0.0; 2]) * s[k];
        assert!(
            (tilted - scaled).norm() < 1e-12 * tilted.norm(),
            "{tilted} {scaled}"
        );
        assert!(s.iter().enumerate().all(|(i, v)| i == k || *v == 1.0));
        // planted fault: a tilt that turns the torque (first angle 20 sigma) is not a scale
        let turned = [k as f64, 0.2, 0.2];
        assert!(equivalents(
            Kind::ThrusterMisalignment,
            &turned,
            &se,
            &no_cov,
            &[],
            &plant,
            &c
        )
        .is_empty());
        // nor is it one with a CoM offset named (the arm the tilt refers to has moved)
        let with_com = [Kind::ComOffset];
        let again = [k as f64, 0.0, 0.2];
        assert!(equivalents(
            Kind::ThrusterMisalignment,
            &again,
            &se,
            &no_cov,
            &with_com,
            &plant,
            &c
        )
        .is_empty());
    }

    /// The listing follows the physics: a delay and an equal latency predict the same rates
    /// (and are listed as equivalent) until a mass-property change is named, which the
    /// delay shifts and the latency does not (then they differ, and nothing is listed).
    #[test]
    fn a_delay_is_a_latency_only_without_a_timed_effect() {
        use crate::model::Params;
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let words: Vec<u16> = (0..3000)
            .map(|k| if k % 300 < 80 { 0b101 } else { 0 })
            .collect();
        let series = crate::model::tests::commanded(&sat, &words);
        let noise = crate::noise::NoiseModel::white([1e-6; 3]);
        let prob = crate::fit::Problem::new(&plant, &series, &noise);
        let mut after = sat.inertia_kgm2;
        after[0] *= 1.4;
        let change = Some((1.2, [3.0, 0.0, 0.0], after));
        let differ = |mass_change: Option<(f64, [f64; 3], [f64; 6])>| {
            let delay = prob.predict(&Params {
                delay_ms: 50.0,
                mass_change,
                ..Params::default()
            });
            let latency = prob.predict(&Params {
                open_ms: 50.0,
                close_ms: 50.0,
                mass_change,
                ..Params::default()
            });
            let (a, b) = (delay.unwrap(), latency.unwrap());
            a.iter()
                .zip(&b)
                .map(|(x, y)| (0..3).map(|i| (x[i] - y[i]).abs()).fold(0.0, f64::max))
                .fold(0.0, f64::max)
        };
        let fired = [true; NT];
        let c = cx(&fired, &sat, &plant);
        let se = |_: usize| 0.1;
        let listed = |others: &[Kind]| {
            !equivalents(
                Kind::MeasurementDelay,
                &[50.0],
                &se,
                &no_cov,
                others,
                &plant,
                &c,
            )
            .is_empty()
        };
        assert!(differ(None) < 1e-12, "{}", differ(None));
        assert!(listed(&[]));
        // a 50 ms shift of the change moves the rates by 3e-5 rad/s here: small, but far
        // from the rounding-level agreement without it
        assert!(differ(change) > 1e-6, "{}", differ(change));
        assert!(!listed(&[Kind::MassPropertyChange]));
        assert!(!listed(&[Kind::Blowdown]));
        let lat = equivalents(
            Kind::ThrusterLatency,
            &[50.0, 50.0],
            &se,
            &no_cov,
            &[Kind::MassPropertyChange],
            &plant,
            &c,
        );
        assert!(lat.is_empty());
    }

    #[test]
    fn a_uniform_scale_is_an_inertia_and_back() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = Plant::new(&sat);
        let fired = [true; NT];
        let c = cx(&fired, &sat, &plant);
        let n = sat.n_thrusters();
        let se = |_: usize| 0.002;
        let eq = equivalents(
            Kind::ThrustScale,
            &vec![0.8; n],
            &se,
            &no_cov,
            &[],
            &plant,
            &c,
        );
        assert_eq!(eq[0]["effect"], "inertia");
        let izz = eq[0]["params"]["inertia_kgm2"][2].as_f64().unwrap();
        assert!((izz - sat.inertia_kgm2[2] / 0.8).abs() < 1e-12);
        // one dead thruster is not a uniform scale
        let mut one = vec![1.0; n];
        one[4] = 0.0;
        assert!(equivalents(Kind::ThrustScale, &one, &se, &no_cov, &[], &plant, &c).is_empty());
        // an inertia 1.25x the model's is a uniform 0.8 scale; a changed product is not
        let i: Vec<f64> = sat.inertia_kgm2.iter().map(|v| v * 1.25).collect();
        let ise = |_: usize| 1e-5;
        let eq = equivalents(Kind::Inertia, &i, &ise, &no_cov, &[], &plant, &c);
        let s0 = eq[0]["params"]["scale"][0].as_f64().unwrap();
        assert!((s0 - 0.8).abs() < 1e-9, "{s0}");
        let mut j = i.clone();
        j[3] += 0.002;
        assert!(equivalents(Kind::Inertia, &j, &ise, &no_cov, &[], &plant, &c).is_empty());
        // with a disturbance torque named too, inertia / s is no longer the same rates
        let dist = [Kind::DisturbanceTorque];
        assert!(equivalents(Kind::Inertia, &i, &ise, &no_cov, &dist, &plant, &c).is_empty());
        // an unidentifiable term (NaN error) is left out, not allowed to hide the rest
        let nan_one = |k: usize| if k == 5 { f64::NAN } else { 1e-5 };
        assert_eq!(
            equivalents(Kind::Inertia, &i, &nan_one, &no_cov, &[], &plant, &c).len(),
            1
        );
    }
}
