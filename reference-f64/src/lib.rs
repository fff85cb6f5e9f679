//! The f64 reference: the seed thesis' algorithms in f64, written to read like its
//! equations. Every kernel output is differentially tested against this crate, so it
//! shares no numerical code with `massid-kernel`.
//!
//! Modules mirror the seed's chapters.
