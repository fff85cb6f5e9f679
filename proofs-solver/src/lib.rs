//! Z3 proofs of the kernel's integer primitives on their real source.
//!
//! The kernel writes each integer primitive once over [`massid_kernel::int::Machine`] and
//! runs it on the native words. This crate instantiates the same functions with Z3
//! bit-vectors ([`z3_machine::Z3`]) and asks the solver whether any input of the envelope
//! violates the property ([`discharge::Obligation`]). A refutation comes back as the inputs,
//! which [`discharge::Discharge::replay`] runs on the compiled code ([`concrete::Concrete`]);
//! [`mutant::Mutant`] alters one operation to show that each proof can fail.

pub mod concrete;
pub mod discharge;
pub mod gyro;
pub mod interval;
pub mod mutant;
pub mod obligations;
pub mod prover;
pub mod z3_int;
pub mod z3_machine;
