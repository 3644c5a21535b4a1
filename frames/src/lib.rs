//! # multifield-frames
//!
//! Where a field's state lives. `eulerian`: on the grid, advected there (conservative,
//! limited, second order). `lagrangian`: on material points (FLIP for fluids, MPM for
//! solids) with the grid as scratch space rebuilt every step. `mass_point`: one point per
//! disk carrying its volume (`representation: MassPoint`). Each frame registers itself
//! with the core; call [`link`] once from a binary or test so the linker keeps this crate.
#![warn(missing_docs)]

// The 3D compile (`multifield-frames3d`) has the Eulerian frame (issue 17, P1); the
// Lagrangian frames and mass points come after it (docs/design/three-dimensions.md §5).
pub mod eulerian;
#[cfg(feature = "dim2")]
pub mod lagrangian;
#[cfg(feature = "dim2")]
pub mod mass_point;

/// The frame names this crate registers.
#[cfg(feature = "dim2")]
pub const SHIPPED: &[&str] = &["eulerian", "lagrangian", "mass_point"];
/// The frame names this crate registers.
#[cfg(feature = "dim3")]
pub const SHIPPED: &[&str] = &["eulerian"];

/// Keeps this crate's registrations in the final binary.
pub fn link() {
    std::hint::black_box(SHIPPED);
}
