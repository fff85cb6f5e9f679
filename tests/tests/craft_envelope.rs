//! A craft's envelope against the kernel's fixed format (issue 23 item 3,
//! `massid_proofs::craft_envelope`): the example craft fit Q8.24; a craft with thrusters too
//! strong (a wrench beyond the format) or too weak (a format step a visible duty error) is
//! refused with the quantity named, and the mixer measured against the reference agrees; the
//! interval run encloses every concrete craft drawn from the envelope.

use massid_kernel::craft::Craft;
use massid_kernel::{Scalar, Q8_24};
use massid_kernel_host::craft::{axis_probes, mixer_deviation, thrusters, MIXER_BUDGET_Q8_24};
use massid_proofs::craft_envelope::{check, CraftEnvelope, CraftFit};
use massid_proofs::interval::Format;
use massid_sim::model_file::ModelFile;
use rand::{Rng, SeedableRng};
use reference_f64::mixer::DEFAULT_PERIOD_MS;
use reference_f64::satellite::Satellite;
use std::path::PathBuf;

fn model(name: &str) -> Satellite {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    ModelFile::read(&root.join(format!("examples/models/{name}.toml")))
        .expect("example model")
        .satellite
}

fn envelope(sat: &Satellite) -> CraftEnvelope {
    let com = sat.com_m();
    CraftEnvelope::new(
        &thrusters(sat).expect("1-16 thrusters"),
        &sat.thrust_sigma_n,
        sat.pressure_drop_n_per_extra,
        [com.x, com.y, com.z],
        sat.planar,
    )
}

fn fit(sat: &Satellite, format: Format) -> CraftFit {
    check(&envelope(sat), format, MIXER_BUDGET_Q8_24).expect("a table")
}

fn with_thrust(mut sat: Satellite, thrust_n: f64) -> Satellite {
    for t in sat.thrust_n.iter_mut() {
        *t = thrust_n;
    }
    sat
}

#[test]
fn the_example_craft_fit_q8_24() {
    for name in ["sph2", "cubesat8", "freeflyer16", "airbearing-mpc"] {
        let f = fit(&model(name), Format::Q8_24);
        println!(
            "{name}: largest {:?}, resolution {:.1e} on {}",
            f.largest().map(|v| (&v.name, v.range.mag())),
            f.duty_resolution,
            f.resolution_component
        );
        assert_eq!(f.refusal(), None, "{name}:\n{}", f.ranges.table());
    }
}

#[test]
fn a_craft_too_strong_for_the_format_is_refused_naming_the_wrench() {
    // The cubesat with 40 N thrusters: four of them push Fz to ~150 N, past Q8.24's 128.
    let sat = with_thrust(model("cubesat8"), 40.0);
    let why = fit(&sat, Format::Q8_24).refusal().expect("refused");
    println!("{why}");
    assert!(why.contains("wrench Fz"), "{why}");
    // The nominal cubesat fits; the same craft in a format eight times narrower does not.
    let narrow = fit(&with_thrust(model("cubesat8"), 5.0), Format::Q4_28);
    assert!(narrow.refusal().is_some(), "{}", narrow.ranges.table());
    assert_eq!(
        fit(&with_thrust(model("cubesat8"), 5.0), Format::Q8_24).refusal(),
        None
    );
}

#[test]
fn a_craft_too_weak_for_the_format_is_refused_and_the_mixer_agrees() {
    // The cubesat with 1 mN thrusters: half a Q8.24 step on a torque command is a duty error
    // above the mixer's budget; the kernel mixer measured on the pure-axis commands misses
    // the budget too.
    let sat = with_thrust(model("cubesat8"), 0.001);
    let why = fit(&sat, Format::Q8_24).refusal().expect("refused");
    println!("{why}");
    assert!(why.contains("resolution"), "{why}");
    let probes = axis_probes(&sat, DEFAULT_PERIOD_MS);
    let measured = mixer_deviation::<Q8_24>(&sat, &probes, DEFAULT_PERIOD_MS)
        .map(|(d, _)| d)
        .unwrap_or(f64::INFINITY);
    assert!(measured > MIXER_BUDGET_Q8_24, "measured {measured:.1e}");
    // At the example's 50 mN the bound is far below the budget.
    let nominal = fit(&model("cubesat8"), Format::Q8_24);
    assert!(nominal.duty_resolution < MIXER_BUDGET_Q8_24 / 2.0);
}

/// `sat` with a pressure drop and a stated thrust uncertainty (the example models have
/// neither), so that the enclosure test covers both terms of the envelope.
fn with_drop_and_sigma(mut sat: Satellite) -> Satellite {
    sat.pressure_drop_n_per_extra = 0.1 * sat.thrust_n[0] / sat.n_thrusters() as f64;
    sat.thrust_sigma_n = sat.thrust_n.iter().map(|t| 0.08 * t).collect();
    sat
}

#[test]
fn the_interval_run_encloses_every_craft_drawn_from_the_envelope() {
    // Concrete Q8.24 tables (the model's path: f32 operations, then the format) drawn from
    // the envelope, their wrench for a random word inside the Q8.24 interval run's hull.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23_003);
    for name in ["cubesat8", "freeflyer16", "airbearing-mpc", "sph2"] {
        for sat in [model(name), with_drop_and_sigma(model(name))] {
            let env = envelope(&sat);
            let f = check(&env, Format::Q8_24, MIXER_BUDGET_Q8_24).expect("a table");
            let hull: Vec<(f64, f64)> = f
                .ranges
                .vars
                .iter()
                .filter(|v| v.name.starts_with("wrench "))
                .map(|v| (v.range.lo(), v.range.hi()))
                .collect();
            assert_eq!(hull.len(), 6);
            for draw in 0..300 {
                let mut ts = env.thrusters.clone();
                for (t, r) in ts.iter_mut().zip(&env.thrust_n) {
                    t.thrust_n = rng.gen_range(r.0.max(1e-6)..=r.1) as f32;
                }
                // Every other draw at a corner of the CoM box (the extremes of the lever).
                let com: [f32; 3] = env.com_m.map(|c| {
                    if draw % 2 == 0 {
                        if rng.gen_bool(0.5) {
                            c.0
                        } else {
                            c.1
                        }
                    } else {
                        rng.gen_range(c.0..=c.1)
                    }
                } as f32);
                let drop = rng.gen_range(env.pressure_drop_n.0..=env.pressure_drop_n.1) as f32;
                let craft: Craft<Q8_24> = Craft::new(&ts, com, drop).expect("craft");
                let word = rng.gen_range(0..(1u32 << ts.len())) as u16;
                for (k, (w, (lo, hi))) in craft.wrench(word).iter().zip(&hull).enumerate() {
                    // to_f32 of a Q8.24 value below 128 is exact.
                    let w = f64::from(w.to_f32());
                    assert!(
                        w >= *lo && w <= *hi,
                        "{name}: word {word:#x} component {k}: {w} outside [{lo}, {hi}]"
                    );
                }
            }
        }
    }
}

#[test]
fn the_com_box_holds_the_models_com_and_a_planar_craft_is_judged_on_its_axes() {
    // All thrusters on one face, far from the model's CoM: the lever arms about the CoM (not
    // about the thrusters' flat box) decide the torque range.
    // Eight 20 N thrusters pushing sideways (+-x, +-y) from a face 3 m below the CoM: two
    // of them give 75 N m of Tx each (3 m x 25 N with the margin), past Q8.24's 128 together,
    // while every force stays inside it.
    let mut sat = with_thrust(model("cubesat8"), 20.0);
    let sideways = [
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
    ];
    for (i, (p, d)) in sat
        .thruster_pos_m
        .iter_mut()
        .zip(sat.thrust_dir.iter_mut())
        .enumerate()
    {
        p[2] = -3.0;
        *d = sideways[i % 4];
    }
    let why = fit(&sat, Format::Q8_24).refusal().expect("refused");
    println!("{why}");
    assert!(
        why.contains("mixer command T") || why.contains("wrench T"),
        "{why}"
    );
    // A planar craft whose CoM sits off the thrusters' plane is never commanded in Tx or Ty:
    // its resolution is judged on Fx, Fy and Tz only.
    let mut planar = model("airbearing-mpc");
    planar.com_offset_mm[2] = 0.5;
    let f = fit(&planar, Format::Q8_24);
    assert_eq!(f.refusal(), None, "{}", f.ranges.table());
    assert!(matches!(f.resolution_component, "Fx" | "Fy" | "Tz"));
}

#[test]
fn a_shrunken_hull_is_caught_by_the_enclosure_check() {
    // The planted fault for the enclosure test: the same draw against a hull shrunk to 90 %
    // finds a wrench outside it.
    let sat = model("cubesat8");
    let env = envelope(&sat);
    let f = check(&env, Format::F32, MIXER_BUDGET_Q8_24).expect("a table");
    let fz = f
        .ranges
        .vars
        .iter()
        .find(|v| v.name.starts_with("wrench Fz"))
        .expect("Fz");
    let mut ts = env.thrusters.clone();
    for (t, r) in ts.iter_mut().zip(&env.thrust_n) {
        t.thrust_n = r.1 as f32;
    }
    let craft: Craft<f64> = Craft::new(&ts, [0.0; 3], 0.0).expect("craft");
    let most = (0..(1u32 << ts.len()))
        .map(|w| craft.wrench(w as u16)[5])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(most <= fz.range.hi() * (1.0 + 1e-6));
    assert!(
        most > 0.9 * fz.range.hi(),
        "the hull is not tight: {most} vs {}",
        fz.range.hi()
    );
}
