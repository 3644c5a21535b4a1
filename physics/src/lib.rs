//! # multifield-physics
//!
//! The physics plugins of multifield, one model per file:
//! `stress/` (constitutive models), `exchange/` (inter-field momentum exchange),
//! `pressure/` (solvers of the pressure equation). Each registers itself with the core's
//! registries; call [`link`] once from a binary or test so the linker keeps this crate.
#![warn(missing_docs)]
// `!(x > 0.0)` is deliberate throughout validation: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// The 3D compile (`multifield-physics3d`) has the Newtonian stress and the exchange laws
// of particles (issue 17, P1) and the pressure solvers (P2); contact and the point stresses
// come after it (docs/design/three-dimensions.md §5).
#[cfg(feature = "dim2")]
pub mod contact;
pub mod exchange;
pub mod pressure;
pub mod stress;

/// The names this crate registers, by role: the test of the registry checks them.
#[cfg(feature = "dim3")]
pub const SHIPPED: &[(&str, &[&str])] = &[
    ("stress", &["newtonian"]),
    ("exchange", &["constant", "no_slip", "schiller_naumann", "stokes"]),
    ("pressure", &["cholesky", "multigrid", "pcg"]),
    ("contact", &[]),
];
/// The names this crate registers, by role: the test of the registry checks them.
#[cfg(feature = "dim2")]
pub const SHIPPED: &[(&str, &[&str])] = &[
    ("stress", &["linear_elastic", "neo_hookean", "newtonian", "rigid", "weakly_compressible"]),
    ("exchange", &["constant", "cylinder", "direct_forcing", "no_slip", "schiller_naumann", "stokes"]),
    ("pressure", &["cholesky", "multigrid", "pcg"]),
    ("contact", &["dem", "repulsion"]),
];

/// Keeps this crate's registrations in the final binary (inventory drops crates that
/// nothing references). Cheap; call it once at start-up.
pub fn link() {
    std::hint::black_box(SHIPPED);
}
