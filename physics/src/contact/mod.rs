//! Contact models between bodies and walls.

pub mod repulsion;
