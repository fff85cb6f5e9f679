//! Mismatch diagnosis between a recording and the nominal model.
