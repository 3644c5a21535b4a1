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

use super::drag::{Drag, DragCorrelation, Shape};
use multifield_core::math::Real;

/// Stokes' law, C_D = 24/Re.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stokes;

impl DragCorrelation for Stokes {
    const NAME: &'static str = "stokes";
    const SUMMARY: &'static str = "Stokes drag on spheres (fluid = first field): K = 18μ/(d²θf)";
    const CITATION: &'static str = "Stokes (1851), Trans. Camb. Phil. Soc. 9, 8";
    const SHAPE: Shape = Shape::Sphere;
    const VALID_RE: (Real, Real) = (0.0, 1.0);
    const DI_FELICE: bool = false;
    const CONSTANT_CD_RE: Option<Real> = Some(24.0);
    fn cd_re(_re: Real, _theta_f: Real) -> Real {
        24.0
    }
}

multifield_core::register!(Exchange, "stokes", Drag<Stokes>, Stokes::SUMMARY, Drag::<Stokes>::PARAMS);

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::super::drag::drag_coefficient;
    use super::*;

    fn stokes(diameter: Real, viscosity: Real) -> Drag<Stokes> {
        Drag::new(diameter, viscosity)
    }

    #[test]
    fn stokes_k_matches_three_pi_mu_d() {
        let s = stokes(0.1, 0.01);
        // F = 3πμdΔu, V_p = πd³/6: K = F/(V_p θ_f Δu) = 18μ/(d²θ_f)
        let theta_f = 0.8;
        let by_hand = 3.0 * std::f64::consts::PI * 0.01 * 0.1 / (std::f64::consts::PI * 0.001 / 6.0 * theta_f);
        assert!((s.coefficient(0.0, 1.3, theta_f) - by_hand).abs() < 1e-12 * by_hand);
        assert!((s.coefficient(0.0, 1.3, 1.0) - 18.0).abs() < 1e-12);
        // the general sphere formula with G = 24 agrees at any slip
        for slip in [0.0, 1e-3, 1.0, 1e3] {
            let k = drag_coefficient(0.75, |_, _| 24.0, 0.1, 0.01, 1.3, theta_f, slip, false);
            assert!((k - s.coefficient(0.0, 1.3, theta_f)).abs() < 1e-12 * k);
        }
    }

    #[test]
    fn validation_rejects_non_positive_inputs() {
        for (d, mu) in [(0.0, 1.0), (-1.0, 1.0), (1.0, 0.0), (1.0, -2.0), (Real::NAN, 1.0), (1.0, Real::INFINITY)] {
            let e = stokes(d, mu).validate().unwrap_err();
            assert!(e.contains("must be finite and > 0"), "{e}");
        }
        assert!(stokes(1.0, 1.0).validate().is_ok());
    }
}
