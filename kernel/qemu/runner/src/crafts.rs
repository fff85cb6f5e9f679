//! The craft the QEMU run mixes for besides SPHERES (issue 23 item 5): the real air-bearing
//! craft (`examples/models/airbearing-mpc.toml`, planar, 8 thrusters) and a 16-thruster 3-D
//! free-flyer (`examples/models/freeflyer16.toml`), as compiled-in tables (the firmware reads
//! no files; `tests/tests/kernel_mixer_any_craft.rs` checks them against the model files).
use massid_kernel::craft::Thruster;

/// `airbearing-mpc`: thrusters.
pub const AIRBEARING: [Thruster; 8] = [
    Thruster {
        pos_m: [0.145, 0.06, 0.0],
        dir: [-1.0, 0.0, 0.0],
        thrust_n: 0.44145,
    },
    Thruster {
        pos_m: [0.145, -0.06, 0.0],
        dir: [-1.0, 0.0, 0.0],
        thrust_n: 0.430659,
    },
    Thruster {
        pos_m: [0.06, -0.145, 0.0],
        dir: [0.0, 1.0, 0.0],
        thrust_n: 0.427716,
    },
    Thruster {
        pos_m: [-0.06, -0.145, 0.0],
        dir: [0.0, 1.0, 0.0],
        thrust_n: 0.438017,
    },
    Thruster {
        pos_m: [-0.145, -0.06, 0.0],
        dir: [1.0, 0.0, 0.0],
        thrust_n: 0.468918,
    },
    Thruster {
        pos_m: [-0.145, 0.06, 0.0],
        dir: [1.0, 0.0, 0.0],
        thrust_n: 0.446846,
    },
    Thruster {
        pos_m: [-0.06, 0.145, 0.0],
        dir: [0.0, -1.0, 0.0],
        thrust_n: 0.466956,
    },
    Thruster {
        pos_m: [0.06, 0.145, 0.0],
        dir: [0.0, -1.0, 0.0],
        thrust_n: 0.484124,
    },
];
/// `airbearing-mpc`: inertia, kg m^2 (xx yy zz xy xz yz; planar: only zz is identified).
pub const AIRBEARING_INERTIA_KGM2: [f32; 6] = [0.3237, 0.3237, 0.3237, 0.0, 0.0, 0.0];
/// `airbearing-mpc`: CoM from the geometric centre, m.
pub const AIRBEARING_COM_M: [f32; 3] = [0.00555, 0.0007800000000000001, 0.0];

/// `freeflyer16`: thrusters.
pub const FREEFLYER16: [Thruster; 16] = [
    Thruster {
        pos_m: [0.15, 0.15, 0.15],
        dir: [-0.866025, 0.0, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, 0.15, 0.15],
        dir: [0.0, -0.866025, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, 0.15, -0.15],
        dir: [-0.866025, 0.0, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, 0.15, -0.15],
        dir: [0.0, -0.866025, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, -0.15, 0.15],
        dir: [-0.866025, 0.0, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, -0.15, 0.15],
        dir: [0.0, 0.866025, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, -0.15, -0.15],
        dir: [-0.866025, 0.0, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [0.15, -0.15, -0.15],
        dir: [0.0, 0.866025, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, 0.15, 0.15],
        dir: [0.866025, 0.0, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, 0.15, 0.15],
        dir: [0.0, -0.866025, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, 0.15, -0.15],
        dir: [0.866025, 0.0, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, 0.15, -0.15],
        dir: [0.0, -0.866025, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, -0.15, 0.15],
        dir: [0.866025, 0.0, -0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, -0.15, 0.15],
        dir: [0.0, 0.866025, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, -0.15, -0.15],
        dir: [0.866025, 0.0, 0.5],
        thrust_n: 0.6,
    },
    Thruster {
        pos_m: [-0.15, -0.15, -0.15],
        dir: [0.0, 0.866025, -0.5],
        thrust_n: 0.6,
    },
];
/// `freeflyer16`: inertia, kg m^2 (xx yy zz xy xz yz).
pub const FREEFLYER16_INERTIA_KGM2: [f32; 6] = [0.135, 0.14, 0.13, 0.001, -0.0008, 0.0005];
/// `freeflyer16`: CoM from the geometric centre, m.
pub const FREEFLYER16_COM_M: [f32; 3] = [0.002, -0.0015, 0.003];
