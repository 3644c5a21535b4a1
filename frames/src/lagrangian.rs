//! Lagrangian frame (being written).
