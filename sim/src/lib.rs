//! The simulator: rigid body, effects, sensors, maneuvers.
