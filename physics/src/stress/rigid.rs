//! Rigid bodies: after the exchange and pressure update, every body of the field takes
//! the rigid motion with the same linear and angular momentum as its points received from
//! the grid, V = P/M, ω = L/I, v_p = V + ω × r_p, and its points move rigidly
//! (docs/method.md §4). No elastic wave limits the time step: a rigid disk costs the fluid's
//! CFL step only, about 100× fewer steps than a stiff elastic one.

use multifield_core::plugin::{StressKind, StressModel};
use multifield_core::registry::params_value;
use serde::{Deserialize, Serialize};

/// Rigid-body projection of each body of a Lagrangian field.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rigid {}

impl Rigid {
    /// Nothing to check.
    pub fn validate(&mut self) -> Result<(), String> {
        Ok(())
    }
}

multifield_core::register!(
    Stress,
    "rigid",
    Rigid,
    "rigid bodies: V = P/M, ω = L/I after the pressure update; points move rigidly (no wave limit)",
    &[]
);

impl StressModel for Rigid {
    fn model(&self) -> &'static str {
        "rigid"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // a function of each point's own state
        true
    }
    fn kind(&self) -> StressKind {
        StressKind::Rigid
    }
}
