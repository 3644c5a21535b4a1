//! Contact models between bodies and walls.

pub mod dem;
pub mod repulsion;
