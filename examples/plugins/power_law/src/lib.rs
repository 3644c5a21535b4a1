//! # multifield-power-law
//!
//! An example of a physics plugin that lives outside multifield's own crates: a power-law
//! (generalised Newtonian) viscosity, registered as `"power_law"`, and the output quantity
//! it depends on, the shear rate, registered as `"shear_rate"`. The walk-through in
//! `docs/plugins.md` builds it step by step.
//!
//! A program that wants the plugin calls [`link`] once (inventory drops a crate nothing
//! references), then names `model: "power_law"` in a case.
#![warn(missing_docs)]

pub mod power_law;
pub mod shear_rate;

pub use power_law::PowerLaw;

/// The names this crate registers, by role.
pub const SHIPPED: &[(&str, &[&str])] = &[("stress", &["power_law"]), ("quantity", &["shear_rate"])];

/// Keeps this crate's registration in the final binary. Call it once at start-up.
pub fn link() {
    std::hint::black_box(SHIPPED);
}
