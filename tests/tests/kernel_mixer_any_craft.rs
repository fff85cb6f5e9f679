//! The kernel's mixer for any craft (`massid_kernel::craft_mixer`) against the f64 reference
//! mixer, in f32 and Q8.24, on the example craft (planar 8, cubesat 8 canted, free-flyer 16,
//! SPHERES): pulse fractions within the error budget, integer times equal wherever the
//! reference's real on-time is farther than that budget from a rounding boundary, duties that
//! pass the allocation checker; unreachable and off-plane commands are errors, as in the
//! reference.
use massid_kernel::craft_mixer::CraftMixer;
use massid_kernel::mixer::MixerError;
use massid_kernel::scalar::{Scalar, Q8_24};
use massid_tests::allocation_check::{example_model, EXAMPLE_MODELS};
use nalgebra::{Vector3, Vector6};
use rand::{Rng, SeedableRng};
use reference_f64::mixer::{Mixer, DEFAULT_PERIOD_MS};
use reference_f64::satellite::Satellite;

fn satellite(name: &str) -> Satellite {
    massid_sim::model_file::ModelFile::read(&example_model(name))
        .unwrap()
        .satellite
}

/// Worst |kernel - reference| pulse fraction over the commands, and (equal, compared) times.
struct Agreement {
    max_dev: f64,
    equal: usize,
    decidable: usize,
    compared: usize,
}

fn compare<S: Scalar>(name: &str, budget: f64, seed: u64) -> Agreement {
    let sat = satellite(name);
    let r = Mixer::from_satellite(&sat, None, DEFAULT_PERIOD_MS).unwrap();
    let k: CraftMixer<S> = massid_kernel_host::craft::mixer(&sat, None, DEFAULT_PERIOD_MS).unwrap();
    assert_eq!(
        matches!(k, CraftMixer::OpposingPairs(_)),
        r.pinv().is_some(),
        "{name}: kernel and reference pick different rules"
    );
    let n = sat.n_thrusters();
    let cols: Vec<Vector6<f64>> = (0..n).map(|i| r.matrix().column(i).into()).collect();
    let axes = r.geometry().axes();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut a = Agreement {
        max_dev: 0.0,
        equal: 0,
        decidable: 0,
        compared: 0,
    };
    let p = f64::from(DEFAULT_PERIOD_MS);
    for _ in 0..300 {
        let mut c = Vector6::zeros();
        for col in &cols {
            if rng.gen_bool(0.6) {
                c += col * rng.gen_range(0.0..1.2);
            }
        }
        for k in 0..6 {
            if !axes.contains(&k) {
                c[k] = 0.0;
            }
        }
        let (f, t) = (
            Vector3::new(c[0], c[1], c[2]),
            Vector3::new(c[3], c[4], c[5]),
        );
        let tr = r
            .mix_traced(f, t)
            .unwrap_or_else(|e| panic!("{name}: reference {e} for {:?}", c.as_slice()));
        let fs = [c[0], c[1], c[2]].map(|v| S::from_f32(v as f32));
        let ts = [c[3], c[4], c[5]].map(|v| S::from_f32(v as f32));
        let frac = k
            .pulse_fractions(fs, ts)
            .unwrap_or_else(|e| panic!("{name}: {e:?} for {c:?}"));
        for i in 0..n {
            let dev = (f64::from(frac[i].to_f32()) - tr.corrected_ms[i] / p).abs();
            a.max_dev = a.max_dev.max(dev);
        }
        let firing = k.mix(fs, ts).unwrap();
        a.compared += 1;
        // Decidable: every real on-time is farther than the budget from a rounding edge
        // (half-millisecond boundaries, the deadband's 9.5 ms and the round-up's 190.5 ms).
        let near_edge = (0..n).any(|i| {
            let d = tr.corrected_ms[i];
            let frac_part = (d - d.floor() - 0.5).abs();
            frac_part < budget * p
                || (d - 9.5).abs() < budget * p
                || (d - (p - 9.5)).abs() < budget * p
        });
        if near_edge {
            continue;
        }
        a.decidable += 1;
        if firing.on_ms[..n] == tr.firing.on_ms[..n] && firing.off_ms[..n] == tr.firing.off_ms[..n]
        {
            a.equal += 1;
        } else {
            panic!(
                "{name}: kernel {:?}/{:?} vs reference {:?}/{:?} for {c:?}",
                &firing.on_ms[..n],
                &firing.off_ms[..n],
                &tr.firing.on_ms[..n],
                &tr.firing.off_ms[..n]
            );
        }
    }
    a
}

/// Pulse-fraction budgets (of the period), in the one place `massid model check` reads them.
const BUDGET_F32: f64 = massid_kernel_host::craft::MIXER_BUDGET_F32;
const BUDGET_Q8_24: f64 = massid_kernel_host::craft::MIXER_BUDGET_Q8_24;

#[test]
fn kernel_mixers_agree_with_the_reference_on_every_example_craft() {
    for (i, name) in EXAMPLE_MODELS.iter().enumerate() {
        let f = compare::<f32>(name, BUDGET_F32, 40 + i as u64);
        let q = compare::<Q8_24>(name, BUDGET_Q8_24, 40 + i as u64);
        eprintln!(
            "{name:>15}: f32 max dev {:.1e} of the period, times equal {}/{} decidable of {}; Q8.24 {:.1e}, {}/{} of {}",
            f.max_dev, f.equal, f.decidable, f.compared, q.max_dev, q.equal, q.decidable, q.compared
        );
        assert!(f.max_dev <= BUDGET_F32, "{name} f32: {:.2e}", f.max_dev);
        assert!(q.max_dev <= BUDGET_Q8_24, "{name} Q8.24: {:.2e}", q.max_dev);
        assert!(
            f.decidable * 10 >= f.compared * 8,
            "{name}: too few decidable"
        );
        assert!(
            q.decidable * 10 >= q.compared * 5,
            "{name}: too few decidable"
        );
    }
}

#[test]
fn kernel_refuses_unreachable_and_off_plane_commands() {
    let mut sat = satellite("airbearing-mpc");
    let k: CraftMixer<f32> = massid_kernel_host::craft::mixer(&sat, None, 200).unwrap();
    assert_eq!(
        k.mix([0.0, 0.0, 0.1], [0.0; 3]).unwrap_err(),
        MixerError::OffPlane
    );
    sat.thruster_pos_m.truncate(2);
    sat.thrust_dir.truncate(2);
    sat.thrust_n.truncate(2);
    for fixed in [false, true] {
        let r = if fixed {
            let k: CraftMixer<Q8_24> = massid_kernel_host::craft::mixer(&sat, None, 200).unwrap();
            (
                k.mix(
                    [Q8_24::from_f32(0.1), Q8_24::ZERO, Q8_24::ZERO],
                    [Q8_24::ZERO; 3],
                )
                .unwrap_err(),
                k.mix(
                    [Q8_24::from_f32(-0.1), Q8_24::ZERO, Q8_24::ZERO],
                    [Q8_24::ZERO; 3],
                )
                .is_ok(),
            )
        } else {
            let k: CraftMixer<f32> = massid_kernel_host::craft::mixer(&sat, None, 200).unwrap();
            (
                k.mix([0.1, 0.0, 0.0], [0.0; 3]).unwrap_err(),
                k.mix([-0.1, 0.0, 0.0], [0.0; 3]).is_ok(),
            )
        };
        assert_eq!(r, (MixerError::OutOfReach, true), "fixed {fixed}");
    }
}

/// The QEMU run's compiled-in craft tables (`kernel/qemu/runner/src/crafts.rs`: the firmware
/// reads no files) are the example model files' thrusters and CoM.
#[test]
fn the_qemu_craft_tables_are_the_model_files() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../kernel/qemu/runner/src/crafts.rs"),
    )
    .unwrap();
    let numbers = |s: &str| -> Vec<f64> {
        s.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
            .filter_map(|t| t.parse().ok())
            .collect()
    };
    for (name, konst) in [
        ("airbearing-mpc", "AIRBEARING"),
        ("freeflyer16", "FREEFLYER16"),
    ] {
        let sat = satellite(name);
        let start = text.find(&format!("pub const {konst}:")).unwrap();
        let block = &text[start..];
        let body = &block[..block.find("];").unwrap()];
        let rows: Vec<Vec<f64>> = body.split("Thruster {").skip(1).map(numbers).collect();
        assert_eq!(rows.len(), sat.n_thrusters(), "{name}");
        for (i, r) in rows.iter().enumerate() {
            let want: Vec<f64> = sat.thruster_pos_m[i]
                .iter()
                .chain(sat.thrust_dir[i].iter())
                .copied()
                .chain([sat.thrust_n[i]])
                .collect();
            assert_eq!(r.len(), 7, "{name} thruster {i}: {r:?}");
            for (a, b) in r.iter().zip(&want) {
                assert!(
                    (a - b).abs() <= 1e-9 * b.abs().max(1.0),
                    "{name} thruster {i}: {r:?} vs {want:?}"
                );
            }
        }
        let com_line = text[start..]
            .lines()
            .find(|l| l.starts_with(&format!("pub const {konst}_COM_M")))
            .unwrap();
        let com: Vec<f64> = numbers(com_line.split('=').nth(1).unwrap());
        let want = sat.com_m();
        for k in 0..3 {
            assert!(
                (com[k] - want[k]).abs() < 1e-9,
                "{name} CoM {com:?} vs {want:?}"
            );
        }
    }
}
