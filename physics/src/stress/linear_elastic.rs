//! Small-strain (linear) isotropic elasticity in plane strain, for the material points of
//! an MPM solid:
//!
//! ```text
//! ε = ½ (F + Fᵀ) − I,    σ = λ tr(ε) I + 2 μ ε,    ψ = μ ε:ε + ½ λ tr(ε)²
//! λ = E ν / ((1 + ν)(1 − 2ν)),   μ = G = E / (2 (1 + ν))
//! ```
//!
//! with F the point's deformation gradient (the frame tracks F ← (I + Δt ∇v) F). The strain
//! is not objective: a rotation by an angle φ reads as a strain of order φ², so use
//! `neo_hookean` for bodies that rotate or strain by more than a few percent. It is the
//! material of the classic MPM tests (Sulsky, Chen & Schreyer, CMAME 118, 1994: two elastic
//! disks colliding; Bardenhagen, J. Pressure Vessel Technol. 2002: the vibrating bar).
//!
//! Explicit MPM is stable for Δt ≤ C h / (c + |v|) with the dilatational wave speed
//! c = sqrt((K + 4G/3)/ρ) = sqrt((λ + 2μ)/ρ) (plane strain); C is the `cfl` parameter,
//! 0.4 by default.

use super::{check_elastic, elastic_dt, lame};
use multifield_core::math::{Matrix, Real};
use multifield_core::plugin::{PointStressContext, StressKind, StressModel, TimeStepContext};
use multifield_core::registry::{params_value, ParamDoc};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Linear elastic solid (small strain, plane strain).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearElastic {
    /// Young's modulus E (stress: force/area, e.g. dyn/cm² = g/(cm·s²)).
    pub young_modulus: Real,
    /// Poisson's ratio ν (dimensionless, −1 < ν < 0.5).
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

impl LinearElastic {
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

    /// Small strain ε = sym(F) − I.
    #[inline]
    fn strain(f: &Matrix) -> Matrix {
        0.5 * (f + f.transpose()) - Matrix::identity()
    }

    /// Cauchy stress σ = λ tr(ε) I + 2 μ ε.
    #[inline]
    pub fn stress(&self, f: &Matrix) -> Matrix {
        let e = Self::strain(f);
        self.lambda * e.trace() * Matrix::identity() + 2.0 * self.mu * e
    }
}

multifield_core::register!(
    Stress,
    "linear_elastic",
    LinearElastic,
    "small-strain elasticity σ = λ tr(ε) I + 2μ ε, ε = sym(F) − I (plane strain; Sulsky et al. 1994)",
    &[
        ParamDoc { name: "young_modulus", unit: "force/area", default: "required", doc: "Young's modulus E" },
        ParamDoc { name: "poisson_ratio", unit: "-", default: "required", doc: "Poisson's ratio ν, in (−1, 0.5)" },
        ParamDoc {
            name: "cfl", unit: "-", default: "0.4", doc: "C in Δt ≤ C h / (c + |v|), c = sqrt((λ + 2μ)/ρ)"
        },
    ]
);

impl StressModel for LinearElastic {
    fn model(&self) -> &'static str {
        "linear_elastic"
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
        let e = Self::strain(f);
        Some(self.mu * e.norm_squared() + 0.5 * self.lambda * e.trace().powi(2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::grid::Grid;
    use multifield_core::math::Vector;

    fn model() -> LinearElastic {
        LinearElastic::new(1000.0, 0.3).unwrap()
    }

    #[test]
    fn stress_and_energy_vanish_at_identity() {
        let m = model();
        assert_eq!(m.stress(&Matrix::identity()), Matrix::zeros());
        assert_eq!(m.strain_energy_density(&Matrix::identity()), Some(0.0));
    }

    #[test]
    fn derived_constants() {
        let m = model();
        assert!((m.lambda - 300.0 / (1.3 * 0.4)).abs() < 1e-12);
        assert!((m.mu - 1000.0 / 2.6).abs() < 1e-12);
        assert!((m.bulk_modulus - (m.lambda + 2.0 * m.mu / 3.0)).abs() < 1e-12);
        // E = 9KG/(3K + G)
        let (k, g) = (m.bulk_modulus, m.mu);
        assert!((9.0 * k * g / (3.0 * k + g) - 1000.0).abs() < 1e-9);
    }

    #[test]
    fn uniaxial_strain_matches_hooke() {
        let m = model();
        let e = 1e-3;
        let s = m.stress(&Matrix::new(1.0 + e, 0.0, 0.0, 1.0));
        assert!((s[(0, 0)] - (m.lambda + 2.0 * m.mu) * e).abs() < 1e-12);
        assert!((s[(1, 1)] - m.lambda * e).abs() < 1e-12);
        assert_eq!(s[(0, 1)], 0.0);
        // simple shear γ: σxy = μ γ
        let s = m.stress(&Matrix::new(1.0, e, 0.0, 1.0));
        assert!((s[(0, 1)] - m.mu * e).abs() < 1e-12 && (s[(1, 0)] - m.mu * e).abs() < 1e-12);
        // ψ = ½ σ:ε
        let f = Matrix::new(1.0 + e, 0.3 * e, -0.2 * e, 1.0 - 0.5 * e);
        let eps = 0.5 * (f + f.transpose()) - Matrix::identity();
        let psi = m.strain_energy_density(&f).unwrap();
        assert!((psi - 0.5 * m.stress(&f).component_mul(&eps).sum()).abs() < 1e-12 * psi.abs().max(1.0));
    }

    #[test]
    fn point_stress_adds_to_every_point() {
        let m = model();
        let f = vec![Matrix::identity(), Matrix::new(1.01, 0.0, 0.0, 1.0)];
        let l = vec![Matrix::zeros(); 2];
        let mut s = vec![Matrix::identity(); 2];
        m.point_stress(&mut PointStressContext {
            dt: 1e-3,
            density: 1.0,
            deformation_gradient: &f,
            velocity_gradient: &l,
            stress: &mut s,
            state: &mut [],
        });
        assert_eq!(s[0], Matrix::identity());
        assert!((s[1] - Matrix::identity() - m.stress(&f[1])).norm() < 1e-12);
    }

    #[test]
    fn stable_dt_is_the_wave_speed_limit() {
        let m = model();
        let grid = Grid::new(20, 20, 0.05, Vector::zeros());
        let dt = m
            .stable_dt(&TimeStepContext { grid: &grid, density: 1000.0, max_speed: 0.2, implicit_viscosity: None })
            .unwrap();
        let c = ((m.bulk_modulus + 4.0 * m.mu / 3.0) / 1000.0).sqrt();
        assert!((dt - 0.4 * 0.05 / (c + 0.2)).abs() < 1e-15);
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(LinearElastic::new(-1.0, 0.3).is_err());
        assert!(LinearElastic::new(1.0, 0.5).is_err());
        let mut m = model();
        m.cfl = 0.0;
        assert!(m.validate().is_err());
    }
}
