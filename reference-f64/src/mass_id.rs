//! (owned by the reference-pipeline work; being written)
