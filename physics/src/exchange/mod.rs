//! Momentum-exchange models between two fields.

pub mod constant;
// disks: the cylinder law and the direct forcing of resolved bodies stay 2D (issue 17)
#[cfg(feature = "dim2")]
pub mod cylinder;
#[cfg(feature = "dim2")]
pub mod direct_forcing;
pub mod drag;
pub mod no_slip;
pub mod schiller_naumann;
pub mod stokes;
