//! Runs every proof harness of `massid_proofs::harness::ALL` through the executing engine:
//! random draws always, exhaustive enumeration where the harness's domain allows, each with
//! its cover points and the vacuity check. Prints one line per run (draws, accepted, covers).

// Runs the harnesses through the executing engine, which does not exist under Kani (Kani runs
// each harness itself: `cargo kani -p massid-proofs --harness <name>`).
#![cfg(not(kani))]

use massid_proofs::engine::check;
use massid_proofs::harness::ALL;

fn run(name: &str) {
    let h = ALL
        .iter()
        .find(|h| h.name == name)
        .unwrap_or_else(|| panic!("no harness {name}"));
    for mode in h.modes(0x5eed_0000 ^ name.len() as u64) {
        match check(h.name, mode, h.covers, h.body) {
            Ok(r) => println!("{mode:?}: {r}"),
            Err(e) => panic!("{mode:?}: {e}"),
        }
    }
}

#[test]
fn every_harness_is_listed_once() {
    let mut names: Vec<_> = ALL.iter().map(|h| h.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), ALL.len());
}

macro_rules! harness_tests {
    ($($name:ident),* $(,)?) => {$(
        #[test]
        fn $name() {
            run(stringify!($name));
        }
    )*};
}

harness_tests!(
    rls_inertia_q8_24,
    mixer_q8_24,
    lu3_q8_24,
    lu6_q8_24,
    scaled_ops_full_q8_24,
    scaled_ops_full_f32,
    kf_any_sequence_q8_24,
    q8_24_add_sub,
    q8_24_mul,
    q8_24_div,
    q8_24_pow2,
    q8_24_order,
    scaled_ops_q8_24,
    scaled_ops_f32,
    scaled_from_i64_q8_24,
    scaled_from_i64_f32,
    gyro_filter_any_sequence,
    gyro_filter_rails,
    firing_terms_q8_24,
    firing_terms_f32,
    firing_terms_every_word_q8_24,
    firing_terms_every_word_f32,
    kf_ramp_q8_24,
    kf_ramp_f32,
    lu6_f32,
    rls_com_f32,
    mass_id_options_q8_24,
    mass_id_options_f32,
    pipeline_q8_24,
    pipeline_f32,
    mixer_f32,
    mixer_quantise_every_word_q8_24,
    c_abi_pipeline_fixed,
    c_abi_pipeline_f32,
    c_abi_mixer_fixed,
    c_abi_mixer_f32,
);

#[test]
fn every_listed_harness_has_a_test() {
    let tested = [
        "q8_24_add_sub",
        "q8_24_mul",
        "q8_24_div",
        "q8_24_pow2",
        "q8_24_order",
        "scaled_ops_q8_24",
        "scaled_ops_f32",
        "scaled_from_i64_q8_24",
        "scaled_from_i64_f32",
        "gyro_filter_any_sequence",
        "gyro_filter_rails",
        "scaled_ops_full_q8_24",
        "scaled_ops_full_f32",
        "firing_terms_q8_24",
        "firing_terms_f32",
        "firing_terms_every_word_q8_24",
        "firing_terms_every_word_f32",
        "kf_any_sequence_q8_24",
        "kf_ramp_q8_24",
        "kf_ramp_f32",
        "lu3_q8_24",
        "lu6_q8_24",
        "lu6_f32",
        "rls_inertia_q8_24",
        "rls_com_f32",
        "mass_id_options_q8_24",
        "mass_id_options_f32",
        "pipeline_q8_24",
        "pipeline_f32",
        "mixer_q8_24",
        "mixer_f32",
        "mixer_quantise_every_word_q8_24",
        "c_abi_pipeline_fixed",
        "c_abi_pipeline_f32",
        "c_abi_mixer_fixed",
        "c_abi_mixer_f32",
    ];
    for h in ALL {
        assert!(tested.contains(&h.name), "harness {} has no test", h.name);
    }
}
