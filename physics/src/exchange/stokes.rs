//! Stokes drag on a dispersed field of spheres of diameter d in a continuous fluid; how a
//! drag law becomes the exchange coefficient K is in [`super::drag`].
//!
//! **Stokes** (Stokes 1851): F = 3π μ d Δu, i.e. C_D = 24/Re, G = 24:
//!
//! ```text
//!     K = 18 μ / (d² θ_f)
//! ```
//!
//! independent of the slip (a constant-K exchange when θ_f is uniform). It is the sphere
//! law only; a 2D cylinder at low Re follows Lamb's law (model `cylinder`).
//!

use multifield_core::math::Real;
use multifield_core::plugin::{DragLaw, ExchangeContext, ExchangeModel};
use multifield_core::registry::params_value;
use serde::{Deserialize, Serialize};

use super::drag::{validate_particle, THETA_FLOOR};

/// Stokes drag on spheres.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stokes {
    /// Particle diameter d (length).
    pub diameter: Real,
    /// Dynamic viscosity μ of the fluid (the first field of `between`).
    pub viscosity: Real,
    /// Added-mass coefficient C_A (implicit; 0 = none).
    #[serde(default)]
    pub added_mass: Real,
    /// Rotational torque on mass points.
    #[serde(default)]
    pub rotation: bool,
}

impl Stokes {
    /// Diameter and viscosity must be positive.
    pub fn validate(&mut self) -> Result<(), String> {
        validate_particle(self.diameter, self.viscosity)?;
        super::drag::validate_added_mass(self.added_mass)
    }
    /// K at a fluid volume fraction θ_f.
    pub fn coefficient(&self, theta_f: Real) -> Real {
        18.0 * self.viscosity / (self.diameter * self.diameter * theta_f.max(THETA_FLOOR))
    }
}

multifield_core::register!(
    Exchange,
    "stokes",
    Stokes,
    "Stokes drag on spheres (fluid = first field): K = 18μ/(d²θf)",
    &[
        super::drag::PARTICLE_PARAMS[0],
        super::drag::PARTICLE_PARAMS[1],
        super::drag::POINT_PARAMS[0],
        super::drag::POINT_PARAMS[1],
    ]
);

impl ExchangeModel for Stokes {
    fn model(&self) -> &'static str {
        "stokes"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn drag_law(&self) -> Option<DragLaw> {
        Some(super::drag::law("stokes", self.diameter, self.viscosity, (0.0, 1.0), self.added_mass, self.rotation))
    }
    fn coefficients(&self, ctx: &ExchangeContext, kx: &mut [Real], ky: &mut [Real]) {
        for (k, t) in kx.iter_mut().zip(&ctx.a.theta_u) {
            *k = self.coefficient(*t);
        }
        for (k, t) in ky.iter_mut().zip(&ctx.a.theta_v) {
            *k = self.coefficient(*t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::drag::drag_coefficient;
    use super::*;

    #[test]
    fn stokes_k_matches_three_pi_mu_d() {
        let s = Stokes { diameter: 0.1, viscosity: 0.01, added_mass: 0.0, rotation: false };
        // F = 3πμdΔu, V_p = πd³/6: K = F/(V_p θ_f Δu) = 18μ/(d²θ_f)
        let theta_f = 0.8;
        let by_hand = 3.0 * std::f64::consts::PI * 0.01 * 0.1 / (std::f64::consts::PI * 0.001 / 6.0 * theta_f);
        assert!((s.coefficient(theta_f) - by_hand).abs() < 1e-12 * by_hand);
        assert!((s.coefficient(1.0) - 18.0).abs() < 1e-12);
        // the general sphere formula with G = 24 agrees at any slip
        for slip in [0.0, 1e-3, 1.0, 1e3] {
            let k = drag_coefficient(0.75, |_| 24.0, 0.1, 0.01, 1.3, theta_f, slip, false);
            assert!((k - s.coefficient(theta_f)).abs() < 1e-12 * k);
        }
    }

    #[test]
    fn validation_rejects_non_positive_inputs() {
        for (d, mu) in [(0.0, 1.0), (-1.0, 1.0), (1.0, 0.0), (1.0, -2.0), (Real::NAN, 1.0), (1.0, Real::INFINITY)] {
            let e = Stokes { diameter: d, viscosity: mu, added_mass: 0.0, rotation: false }.validate().unwrap_err();
            assert!(e.contains("must be finite and > 0"), "{e}");
        }
        assert!(Stokes { diameter: 1.0, viscosity: 1.0, added_mass: 0.0, rotation: false }.validate().is_ok());
    }
}
