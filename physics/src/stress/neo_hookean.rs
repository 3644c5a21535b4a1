//! Compressible neo-Hookean elasticity in plane strain (F₃₃ = 1), for the material points
//! of an MPM solid with large deformations and rotations:
//!
//! ```text
//! J = det F,   σ = (μ/J)(F Fᵀ − I) + (λ ln J / J) I
//! ψ = ½ μ (tr(FᵀF) − 2) − μ ln J + ½ λ (ln J)²
//! λ = E ν / ((1 + ν)(1 − 2ν)),   μ = E / (2 (1 + ν))
//! ```
//!
//! (Bonet & Wood, *Nonlinear Continuum Mechanics for Finite Element Analysis*, 2nd ed.
//! 2008, §6.4.3; the MPM form of Sulsky, Zhou & Schreyer, Comput. Phys. Commun. 87, 1995.)
//! It is frame-indifferent and reduces to `linear_elastic` to first order in the strain.
//! σ = (1/J) (∂ψ/∂F) Fᵀ exactly, so the frame's internal work V σ : ∇v equals V⁰ dψ/dt.
//!
//! Explicit MPM is stable for Δt ≤ C h / (c + |v|) with the dilatational wave speed
//! c = sqrt((K + 4G/3)/ρ) = sqrt((λ + 2μ)/ρ) at F = I (plane strain); C is the `cfl`
//! parameter, 0.4 by default. A point whose J reaches 0 has been crushed: its stress is
//! not finite, and the run stops as unstable.

use super::{check_elastic, elastic_dt, lame};
use multifield_core::math::{Matrix, Real};
use multifield_core::plugin::{PointStressContext, StressKind, StressModel, TimeStepContext};
use multifield_core::registry::{params_value, ParamDoc};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Compressible neo-Hookean solid (plane strain).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NeoHookean {
    /// Young's modulus E (stress: force/area, e.g. dyn/cm² = g/(cm·s²)), at small strain.
    pub young_modulus: Real,
    /// Poisson's ratio ν (dimensionless, −1 < ν < 0.5), at small strain.
    pub poisson_ratio: Real,
    /// Courant number C of the elastic limit Δt ≤ C h / (c + |v|) (dimensionless, default 0.4).
    #[serde(default = "default_cfl")]
    pub cfl: Real,
    /// Lamé's first parameter λ (derived in `validate`).
    #[serde(skip)]
    pub lambda: Real,
    /// Shear modulus μ = G (derived in `validate`).
    #[serde(skip)]
    pub mu: Real,
    /// Bulk modulus K = λ + 2μ/3 (derived in `validate`).
    #[serde(skip)]
    pub bulk_modulus: Real,
}

fn default_cfl() -> Real {
    0.4
}

impl NeoHookean {
    /// A model from Young's modulus and Poisson's ratio, with the default `cfl`.
    pub fn new(young_modulus: Real, poisson_ratio: Real) -> Result<Self, String> {
        let mut m = Self { young_modulus, poisson_ratio, cfl: default_cfl(), lambda: 0.0, mu: 0.0, bulk_modulus: 0.0 };
        m.validate()?;
        Ok(m)
    }

    /// Checks the parameters and derives λ, μ and K.
    pub fn validate(&mut self) -> Result<(), String> {
        check_elastic(self.young_modulus, self.poisson_ratio, self.cfl)?;
        (self.lambda, self.mu) = lame(self.young_modulus, self.poisson_ratio);
        self.bulk_modulus = self.lambda + 2.0 * self.mu / 3.0;
        Ok(())
    }

    /// Cauchy stress σ = (μ/J)(F Fᵀ − I) + (λ ln J / J) I.
    #[inline]
    pub fn stress(&self, f: &Matrix) -> Matrix {
        let j = f.determinant();
        (self.mu / j) * (f * f.transpose() - Matrix::identity()) + (self.lambda * j.ln() / j) * Matrix::identity()
    }
}

multifield_core::register!(
    Stress,
    "neo_hookean",
    NeoHookean,
    "compressible neo-Hookean σ = (μ/J)(FFᵀ − I) + (λ ln J/J) I (plane strain; Bonet & Wood 2008)",
    &[
        ParamDoc { name: "young_modulus", unit: "force/area", default: "required", doc: "Young's modulus E" },
        ParamDoc { name: "poisson_ratio", unit: "-", default: "required", doc: "Poisson's ratio ν, in (−1, 0.5)" },
        ParamDoc {
            name: "cfl", unit: "-", default: "0.4", doc: "C in Δt ≤ C h / (c + |v|), c = sqrt((λ + 2μ)/ρ)"
        },
    ]
);

impl StressModel for NeoHookean {
    fn model(&self) -> &'static str {
        "neo_hookean"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // a function of each point's own state
        true
    }
    fn kind(&self) -> StressKind {
        StressKind::Points { volumetric_only: false, velocity_gradient: false }
    }
    fn point_stress(&self, ctx: &mut PointStressContext) {
        ctx.stress.par_iter_mut().zip(ctx.deformation_gradient.par_iter()).for_each(|(s, f)| *s += self.stress(f));
    }
    fn stable_dt(&self, ctx: &TimeStepContext) -> Option<Real> {
        Some(elastic_dt(self.cfl, ctx.grid.h, self.lambda + 2.0 * self.mu, ctx.density, ctx.max_speed))
    }
    fn strain_energy_density(&self, f: &Matrix) -> Option<Real> {
        let lnj = f.determinant().ln();
        Some(0.5 * self.mu * (f.norm_squared() - 2.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stress::linear_elastic::LinearElastic;
    use multifield_core::grid::Grid;
    use multifield_core::math::Vector;

    fn model() -> NeoHookean {
        NeoHookean::new(1000.0, 0.3).unwrap()
    }

    #[test]
    fn stress_and_energy_vanish_at_identity() {
        let m = model();
        assert!(m.stress(&Matrix::identity()).norm() < 1e-14);
        assert!(m.strain_energy_density(&Matrix::identity()).unwrap().abs() < 1e-14);
    }

    #[test]
    fn reduces_to_linear_elasticity_at_small_strain() {
        let (m, lin) = (model(), LinearElastic::new(1000.0, 0.3).unwrap());
        let g = Matrix::new(0.7, 0.4, -0.2, -0.5); // a displacement gradient direction
        let mut errors = vec![];
        for eps in [1e-2, 1e-3, 1e-4] {
            let f = Matrix::identity() + eps * g;
            let err = (m.stress(&f) - lin.stress(&f)).norm() / (lin.stress(&f)).norm();
            let de = (m.strain_energy_density(&f).unwrap() - lin.strain_energy_density(&f).unwrap()).abs()
                / lin.strain_energy_density(&f).unwrap();
            errors.push((eps, err, de));
        }
        // the difference is O(ε²) in the stress, i.e. relative O(ε): it drops tenfold with ε
        for w in errors.windows(2) {
            let ratio = w[0].1 / w[1].1;
            assert!((8.0..12.5).contains(&ratio), "{errors:?}");
            assert!(w[0].2 / w[1].2 > 8.0, "{errors:?}");
        }
        assert!(errors[2].1 < 1e-3, "{errors:?}");
    }

    #[test]
    fn objective_under_rotation() {
        let m = model();
        let u = Matrix::new(1.02, 0.01, 0.01, 0.97);
        let a: Real = 0.7;
        let r = Matrix::new(a.cos(), -a.sin(), a.sin(), a.cos());
        let rotated = m.stress(&(r * u));
        assert!((rotated - r * m.stress(&u) * r.transpose()).norm() < 1e-10);
        let (e0, e1) = (m.strain_energy_density(&u).unwrap(), m.strain_energy_density(&(r * u)).unwrap());
        assert!((e0 - e1).abs() < 1e-12 * e0);
    }

    #[test]
    fn stress_is_the_derivative_of_the_energy() {
        // σ = (1/J) (∂ψ/∂F) Fᵀ, with ∂ψ/∂F by central differences
        let m = model();
        let f = Matrix::new(1.1, 0.05, -0.03, 0.92);
        let d = 1e-6;
        let mut p = Matrix::zeros();
        for i in 0..2 {
            for j in 0..2 {
                let mut fp = f;
                fp[(i, j)] += d;
                let mut fm = f;
                fm[(i, j)] -= d;
                p[(i, j)] = (m.strain_energy_density(&fp).unwrap() - m.strain_energy_density(&fm).unwrap()) / (2.0 * d);
            }
        }
        let sigma = p * f.transpose() / f.determinant();
        assert!((sigma - m.stress(&f)).norm() < 1e-6 * m.stress(&f).norm(), "{sigma} vs {}", m.stress(&f));
    }

    #[test]
    fn stable_dt_is_the_wave_speed_limit() {
        let m = model();
        let grid = Grid::new(20, 20, 0.05, Vector::zeros());
        let dt = m
            .stable_dt(&TimeStepContext { grid: &grid, density: 1000.0, max_speed: 0.0, implicit_viscosity: None })
            .unwrap();
        let c = ((m.bulk_modulus + 4.0 * m.mu / 3.0) / 1000.0).sqrt();
        assert!((dt - 0.4 * 0.05 / c).abs() < 1e-15);
    }
}
