//! # multifield-frames
//!
//! Where a field's state lives. `eulerian`: on the grid, advected there (conservative,
//! limited, second order). `lagrangian`: on material points (FLIP for fluids, MPM for
//! solids) with the grid as scratch space rebuilt every step. `mass_point`: one point per
//! disk carrying its volume (`representation: MassPoint`). Each frame registers itself
//! with the core; call [`link`] once from a binary or test so the linker keeps this crate.
#![warn(missing_docs)]

pub mod eulerian;
pub mod lagrangian;
pub mod mass_point;

/// The frame names this crate registers.
pub const SHIPPED: &[&str] = &["eulerian", "lagrangian", "mass_point"];

/// Keeps this crate's registrations in the final binary.
pub fn link() {
    std::hint::black_box(SHIPPED);
}
