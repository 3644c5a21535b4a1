//! No-slip coupling, K = ∞: the two fields move as one with their mass-weighted
//! velocity (exact; no large number enters the solve). This is how a fully resolved body
//! and the fluid around it share one velocity (docs/method.md §2).

use multifield_core::grid::FaceArrays;
use multifield_core::math::{Real, AXES};
use multifield_core::plugin::{ExchangeContext, ExchangeModel};
use multifield_core::registry::params_value;
use serde::{Deserialize, Serialize};

/// K = ∞ between two fields.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoSlip {}

impl NoSlip {
    /// Nothing to check.
    pub fn validate(&mut self) -> Result<(), String> {
        Ok(())
    }
}

multifield_core::register!(
    Exchange,
    "no_slip",
    NoSlip,
    "K = ∞: the two fields share one velocity (exact mass-weighted average)",
    &[]
);

impl ExchangeModel for NoSlip {
    fn model(&self) -> &'static str {
        "no_slip"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // face by face
        true
    }
    fn no_slip(&self) -> bool {
        true
    }
    fn coefficients(&self, _ctx: &ExchangeContext, k: &mut FaceArrays) {
        for a in AXES {
            k[a].fill(Real::INFINITY);
        }
    }
}
