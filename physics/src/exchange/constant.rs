//! A constant exchange coefficient K: the force per volume on field a is
//! θ_a θ_b K (u_b − u_a). Two fields in one cell relax to a common velocity with the time
//! constant τ = 1 / (θ_aθ_b K (1/ρ_a + 1/ρ_b)), ρ the bulk densities.

use multifield_core::grid::FaceArrays;
use multifield_core::math::{Real, AXES};
use multifield_core::plugin::{ExchangeContext, ExchangeModel};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Serialize};

/// Constant K.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Constant {
    /// Exchange coefficient K (mass/(volume·time)).
    pub coefficient: Real,
}

impl Constant {
    /// K must be a non-negative finite number.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(self.coefficient >= 0.0 && self.coefficient.is_finite()) {
            return Err(format!(
                "coefficient {}: must be finite and ≥ 0 (use model \"no_slip\" for K = ∞)",
                self.coefficient
            ));
        }
        Ok(())
    }
}

multifield_core::register!(
    Exchange,
    "constant",
    Constant,
    "constant exchange coefficient: force θaθbK(ub − ua)",
    &[ParamDoc { name: "coefficient", unit: "mass/(volume·time)", default: "required", doc: "K" }]
);

impl ExchangeModel for Constant {
    fn model(&self) -> &'static str {
        "constant"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // one coefficient per face, from nothing around it
        true
    }
    fn coefficients(&self, _ctx: &ExchangeContext, k: &mut FaceArrays) {
        for a in AXES {
            k[a].fill(self.coefficient);
        }
    }
}
