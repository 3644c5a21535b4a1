//! Momentum-exchange models between two fields.

pub mod constant;
pub mod no_slip;
