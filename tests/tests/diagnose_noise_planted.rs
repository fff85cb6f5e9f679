//! Issue 24 item 3, the planted fault: the noise model is what keeps a nominal flight with
//! differenced-attitude rates from being flagged. Forced to the white model (as before
//! issue 24, `MASSID_NOISE_KIND=white`), the same nominal flights of `diagnose_noise.rs`
//! are reported "unexplained: not white". One test in its own binary, since it sets an
//! environment variable the diagnosis reads.

#[allow(dead_code)]
mod noise_flights;

use noise_flights::{diagnose, Flight, Sensor};

#[test]
fn forcing_the_white_model_flags_nominal_differenced_attitude_flights() {
    std::env::set_var(massid_diagnose::noise::FORCE_KIND_ENV, "white");
    for (model, rate_hz, seconds) in [
        ("cubesat8.toml", 100.0, 30.0),
        ("airbearing-mpc.toml", 50.0, 60.0),
    ] {
        let f = Flight {
            model,
            rate_hz,
            sensor: Sensor::Differenced,
            level: 1.0,
            seconds,
            seed: 3,
            excess: 1.0,
        };
        let out = diagnose(&f);
        let u = out.unexplained.as_ref().map(|u| u.note.clone());
        eprintln!("{model}: forced white: unexplained {u:?}");
        assert!(
            u.as_deref().is_some_and(|n| n.contains("not white")),
            "{model}: the white model must flag differenced-attitude noise: {u:?}"
        );
    }
    std::env::remove_var(massid_diagnose::noise::FORCE_KIND_ENV);
}
