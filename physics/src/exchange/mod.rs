//! Momentum-exchange models between two fields.

pub mod constant;
pub mod cylinder;
pub mod direct_forcing;
pub mod drag;
pub mod no_slip;
pub mod schiller_naumann;
pub mod stokes;
