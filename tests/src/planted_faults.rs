//! The faults the consistency tests are shown on, one list for the reference's test
//! (`tests/identification_consistency.rs`) and the kernel's example (`kernel_consistency`):
//! effects a rigid model with the nominal thrusters leaves out.
use massid_sim::effects::{Effect, ThrustRise, ThrustScale, ThrusterLatency};

/// The thruster made 10 % weak (thruster 5: one of the RGA's rotation pair about x).
pub const WEAK: usize = 4;

/// A 6 ms valve latency, thruster 5 at 0.9 of its thrust, and a 10 ms thrust rise, for a craft
/// of `n` thrusters.
pub fn planted_faults(n: usize) -> Vec<(&'static str, Vec<Effect>)> {
    let mut one_weak = vec![1.0; n];
    if let Some(s) = one_weak.get_mut(WEAK) {
        *s = 0.9;
    }
    vec![
        (
            "latency 6/6 ms",
            vec![Effect::ThrusterLatency(ThrusterLatency {
                open_ms: 6.0,
                close_ms: 6.0,
            })],
        ),
        (
            "thruster 5 at 0.9",
            vec![Effect::ThrustScale(ThrustScale { scale: one_weak })],
        ),
        (
            "thrust rise 10 ms",
            vec![Effect::ThrustRise(ThrustRise { tau_ms: 10.0 })],
        ),
    ]
}
