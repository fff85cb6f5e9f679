//! The onboard kernel: what flies. `no_std`, no allocation, no panics.
#![no_std]
