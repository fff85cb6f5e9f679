//! The effect vocabulary as fittable families: each mechanism maps its parameter vector
//! onto the model [`Params`] (on top of the effects already accepted), says where to
//! start and how to report its parameters in the contract's names and units.

use crate::model::{Params, NT};
use crate::series::Series;

/// Effects of the vocabulary (contract names).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    ThrusterLatency,
    PressureDrop,
    Blowdown,
    ThrustScale,
    ComOffset,
    Inertia,
    MassPropertyChange,
    FuelSlosh,
    GyroBias,
    GyroScale,
    GyroRinging,
    DisturbanceTorque,
}

impl Kind {
    pub const ALL: [Kind; 12] = [
        Kind::ThrusterLatency,
        Kind::PressureDrop,
        Kind::Blowdown,
        Kind::ThrustScale,
        Kind::ComOffset,
        Kind::Inertia,
        Kind::MassPropertyChange,
        Kind::FuelSlosh,
        Kind::GyroBias,
        Kind::GyroScale,
        Kind::GyroRinging,
        Kind::DisturbanceTorque,
    ];

    /// Contract name.
    pub fn name(self) -> &'static str {
        match self {
            Kind::ThrusterLatency => "thruster_latency",
            Kind::PressureDrop => "pressure_drop",
            Kind::Blowdown => "blowdown",
            Kind::ThrustScale => "thrust_scale",
            Kind::ComOffset => "com_offset",
            Kind::Inertia => "inertia",
            Kind::MassPropertyChange => "mass_property_change",
            Kind::FuelSlosh => "fuel_slosh",
            Kind::GyroBias => "gyro_bias",
            Kind::GyroScale => "gyro_scale",
            Kind::GyroRinging => "gyro_ringing",
            Kind::DisturbanceTorque => "disturbance_torque",
        }
    }

    pub fn from_name(s: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.name() == s)
    }
}

/// Which thrusters are ever commanded open (others cannot be fitted).
pub fn fired_thrusters(series: &Series) -> [bool; NT] {
    let mut any = 0u16;
    for &w in &series.word_ms {
        any |= w;
    }
    std::array::from_fn(|i| any & (1 << i) != 0)
}

/// Number of effect parameters (without the 3 initial-rate nuisances) of `kind`.
pub fn n_params(kind: Kind, fired: &[bool; NT]) -> usize {
    match kind {
        Kind::ThrusterLatency => 2,
        Kind::PressureDrop => 1,
        Kind::Blowdown => 2,
        Kind::ThrustScale => fired.iter().filter(|&&f| f).count(),
        Kind::ComOffset | Kind::GyroBias | Kind::GyroScale | Kind::DisturbanceTorque => 3,
        Kind::Inertia => 6,
        Kind::MassPropertyChange => 10,
        Kind::FuelSlosh => 5,
        Kind::GyroRinging => 5,
    }
}

/// Writes the effect parameters `th` of `kind` into `p`.
pub fn apply(kind: Kind, th: &[f64], fired: &[bool; NT], p: &mut Params) {
    match kind {
        Kind::ThrusterLatency => {
            p.open_ms = th[0];
            p.close_ms = th[1];
        }
        Kind::PressureDrop => p.pressure_drop = th[0],
        Kind::Blowdown => p.blowdown = Some((th[0], 1.0 / th[1].max(1e-9))),
        Kind::ThrustScale => {
            let mut j = 0;
            for i in 0..NT {
                if fired[i] {
                    p.thrust_scale[i] = th[j];
                    j += 1;
                }
            }
        }
        Kind::ComOffset => p.com_offset_mm = [th[0], th[1], th[2]],
        Kind::Inertia => p.inertia = Some(std::array::from_fn(|i| th[i])),
        Kind::MassPropertyChange => {
            p.mass_change = Some((
                th[0],
                [th[1], th[2], th[3]],
                std::array::from_fn(|i| th[4 + i]),
            ))
        }
        Kind::FuelSlosh => p.slosh = Some((th[0], th[1], [th[2], th[3], th[4]])),
        Kind::GyroBias => p.gyro_bias_counts = [th[0], th[1], th[2]],
        Kind::GyroScale => p.gyro_scale = [th[0], th[1], th[2]],
        Kind::DisturbanceTorque => p.disturbance_nm = [th[0], th[1], th[2]],
        // additive with a random phase per edge: see ringing.rs
        Kind::GyroRinging => {}
    }
}
