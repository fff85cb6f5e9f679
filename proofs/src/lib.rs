//! Proof harnesses and the envelope they assume.
