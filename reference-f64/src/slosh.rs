//! (owned by the reference-mixer/characterization work; being written)
