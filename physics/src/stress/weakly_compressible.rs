//! Weakly compressible fluid: a pressure from an equation of state in J = det F, and no
//! shear stress, for the material points of an MPM fluid that needs no pressure solve:
//!
//! ```text
//! J = det F = ρ⁰/ρ,   p = E (1/J − 1) = E (ρ/ρ⁰ − 1),   σ = −p I = E (J − 1)/J I
//! τ = J σ = E (J − 1) I            (Kirchhoff stress)
//! ψ(J) = E (J − 1 − ln J)          (per unit reference volume; σ = ψ'(J) I, ψ ≈ ½ E (J − 1)²)
//! ```
//!
//! E (the `stiffness`) is the bulk modulus at rest, K = −V dp/dV = E/J, so sound travels
//! at c = sqrt(E/ρ⁰); p = c² (ρ − ρ⁰) is the linear equation of state of weakly
//! compressible SPH. This is the fluid of the MLS-MPM paper (Hu, Fang, Ge, Qu, Zhu, Pradhana
//! & Jiang, "A moving least squares material point method with displacement discontinuity
//! and two-way rigid body coupling", ACM TOG 37(4), 2018) and of Taichi's 88-line example
//! `mpm88.py`, whose particle-to-grid transfer adds `stress = −Δt·4·E·p_vol·(J − 1)/dx²`,
//! i.e. −Δt V⁰ τ M⁻¹ with M⁻¹ = 4/dx² for the quadratic B-spline: the Kirchhoff stress
//! τ = E (J − 1) I times the *reference* volume V⁰. The Lagrangian frame computes the
//! internal force as −V σ ∇S with the *current* volume V = J V⁰, so the Cauchy stress
//! returned here is τ/J = E (J − 1)/J I, and V σ = V⁰ E (J − 1) is mpm88's force exactly
//! (to first order in J − 1 it is also σ = E (J − 1) I).
//!
//! The frame tracks F ← (I + Δt ∇v) F, so J ← det(I + Δt ∇v) J = (1 + Δt tr ∇v + Δt² det ∇v) J:
//! mpm88's `J *= 1 + dt·tr(C)` up to the Δt² term. Because this model is `volumetric_only`,
//! the Lagrangian frame keeps F = diag(J, 1) (F's shear would grow without bound in a long
//! run, exponentially where the flow stretches, until det F loses its precision), and on the
//! quadratic B-spline it takes ∇v = Σ u_i ∇S_ip of the new grid velocities in the same
//! gather that updates the points (one scatter and one gather per step, as mpm88) where
//! mpm88 takes C, its APIC matrix of those velocities; solids use the MUSL re-projection.
//!
//! Explicit MPM is stable for Δt ≤ C h / (c + |v|) with c = sqrt(E/ρ⁰); C is the `cfl`
//! parameter, 0.5 by default (mpm88 runs at C = 2e-4 · 20 · 128 = 0.51 at rest).

use super::elastic_dt;
use multifield_core::math::{Matrix, Real};
use multifield_core::plugin::{PointStressContext, StressKind, StressModel, TimeStepContext};
use multifield_core::registry::{params_value, ParamDoc};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Weakly compressible (equation-of-state) fluid.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeaklyCompressible {
    /// Stiffness E (stress: force/area), the bulk modulus at rest: p = E (1/J − 1).
    pub stiffness: Real,
    /// Courant number C of the acoustic limit Δt ≤ C h / (c + |v|) (dimensionless, default 0.5).
    #[serde(default = "default_cfl")]
    pub cfl: Real,
}

fn default_cfl() -> Real {
    0.5
}

impl WeaklyCompressible {
    /// A model of stiffness E with the default `cfl`.
    pub fn new(stiffness: Real) -> Result<Self, String> {
        let mut m = Self { stiffness, cfl: default_cfl() };
        m.validate()?;
        Ok(m)
    }

    /// Checks the parameters.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(self.stiffness > 0.0 && self.stiffness.is_finite()) {
            return Err(format!(
                "stiffness {}: must be a positive stress (force/area); the sound speed is sqrt(stiffness/density)",
                self.stiffness
            ));
        }
        if !(self.cfl > 0.0 && self.cfl <= 1.0) {
            return Err(format!("cfl {}: must lie in (0, 1]; 0.3–0.5 is usual", self.cfl));
        }
        Ok(())
    }

    /// Pressure p = E (1/J − 1) at J = det F.
    #[inline]
    pub fn pressure(&self, j: Real) -> Real {
        self.stiffness * (1.0 / j - 1.0)
    }

    /// Cauchy stress σ = E (J − 1)/J I.
    #[inline]
    pub fn stress(&self, f: &Matrix) -> Matrix {
        -self.pressure(f.determinant()) * Matrix::identity()
    }
}

multifield_core::register!(
    Stress,
    "weakly_compressible",
    WeaklyCompressible,
    "weakly compressible fluid σ = −pI, p = E (1/J − 1), J = det F (MLS-MPM / Taichi mpm88; Hu et al. 2018)",
    &[
        ParamDoc {
            name: "stiffness",
            unit: "force/area",
            default: "required",
            doc: "E: bulk modulus at rest, c = sqrt(E/ρ)"
        },
        ParamDoc { name: "cfl", unit: "-", default: "0.5", doc: "C in Δt ≤ C h / (c + |v|), c = sqrt(E/ρ)" },
    ]
);

impl StressModel for WeaklyCompressible {
    fn model(&self) -> &'static str {
        "weakly_compressible"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // a function of each point's own state
        true
    }
    fn kind(&self) -> StressKind {
        StressKind::Points { volumetric_only: true, velocity_gradient: false }
    }
    fn point_stress(&self, ctx: &mut PointStressContext) {
        ctx.stress.par_iter_mut().zip(ctx.deformation_gradient.par_iter()).for_each(|(s, f)| {
            let p = self.pressure(f.determinant());
            s[(0, 0)] -= p;
            s[(1, 1)] -= p;
        });
    }
    fn stable_dt(&self, ctx: &TimeStepContext) -> Option<Real> {
        Some(elastic_dt(self.cfl, ctx.grid.h, self.stiffness, ctx.density, ctx.max_speed))
    }
    fn strain_energy_density(&self, f: &Matrix) -> Option<Real> {
        let j = f.determinant();
        Some(self.stiffness * (j - 1.0 - j.ln()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::grid::Grid;
    use multifield_core::math::Vector;

    fn model() -> WeaklyCompressible {
        WeaklyCompressible::new(400.0).unwrap()
    }

    #[test]
    fn stress_and_energy_vanish_at_identity() {
        let m = model();
        assert_eq!(m.stress(&Matrix::identity()), Matrix::zeros());
        assert_eq!(m.strain_energy_density(&Matrix::identity()), Some(0.0));
    }

    #[test]
    fn uniform_dilation_gives_the_equation_of_state() {
        let m = model();
        for s in [0.9, 0.99, 1.0, 1.01, 1.2] {
            let f = s * Matrix::identity();
            let j = s * s;
            let sigma = m.stress(&f);
            // Kirchhoff τ = J σ = E (J − 1) I: mpm88's stress on the reference volume
            assert!((j * sigma - 400.0 * (j - 1.0) * Matrix::identity()).norm() < 1e-12, "s = {s}");
            assert!((sigma - 400.0 * (j - 1.0) / j * Matrix::identity()).norm() < 1e-12, "s = {s}");
            assert!((m.pressure(j) - 400.0 * (1.0 / j - 1.0)).abs() < 1e-12);
        }
        // compressed: positive pressure, pushes outward
        assert!(m.stress(&(0.99 * Matrix::identity()))[(0, 0)] < 0.0);
    }

    #[test]
    fn shear_carries_no_stress() {
        let m = model();
        // simple shear and a rotation: J = 1
        assert!(m.stress(&Matrix::new(1.0, 0.7, 0.0, 1.0)).norm() < 1e-12);
        let a: Real = 0.4;
        let r = Matrix::new(a.cos(), -a.sin(), a.sin(), a.cos());
        assert!(m.stress(&r).norm() < 1e-12);
        // J ≠ 1 with shear: still isotropic
        let s = m.stress(&Matrix::new(1.1, 0.3, -0.2, 0.95));
        assert_eq!(s[(0, 1)], 0.0);
        assert_eq!(s[(1, 0)], 0.0);
        assert_eq!(s[(0, 0)], s[(1, 1)]);
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
                let (mut fp, mut fm) = (f, f);
                fp[(i, j)] += d;
                fm[(i, j)] -= d;
                p[(i, j)] = (m.strain_energy_density(&fp).unwrap() - m.strain_energy_density(&fm).unwrap()) / (2.0 * d);
            }
        }
        let sigma = p * f.transpose() / f.determinant();
        assert!((sigma - m.stress(&f)).norm() < 1e-6 * m.stress(&f).norm(), "{sigma} vs {}", m.stress(&f));
        // ψ ≈ ½ E (J − 1)² near J = 1
        let f = 1.001 * Matrix::identity();
        let j = f.determinant();
        let psi = m.strain_energy_density(&f).unwrap();
        assert!((psi / (0.5 * 400.0 * (j - 1.0).powi(2)) - 1.0).abs() < 2e-3);
    }

    #[test]
    fn point_stress_adds_to_every_point() {
        let m = model();
        let f = vec![Matrix::identity(), 0.99 * Matrix::identity()];
        let l = vec![Matrix::zeros(); 2];
        let mut s = vec![Matrix::new(1.0, 2.0, 3.0, 4.0); 2];
        m.point_stress(&mut PointStressContext {
            dt: 2e-4,
            density: 1.0,
            deformation_gradient: &f,
            velocity_gradient: &l,
            stress: &mut s,
            state: &mut [],
        });
        assert_eq!(s[0], Matrix::new(1.0, 2.0, 3.0, 4.0));
        assert!((s[1] - Matrix::new(1.0, 2.0, 3.0, 4.0) - m.stress(&f[1])).norm() < 1e-12);
    }

    #[test]
    fn stable_dt_is_the_sound_speed_limit() {
        let m = model();
        let grid = Grid::new(128, 128, 1.0 / 128.0, Vector::zeros());
        let dt = m
            .stable_dt(&TimeStepContext { grid: &grid, density: 1.0, max_speed: 0.0, implicit_viscosity: None })
            .unwrap();
        // c = sqrt(400/1) = 20: Δt = 0.5 h / 20
        assert!((dt - 0.5 / 128.0 / 20.0).abs() < 1e-15);
        let dt = m
            .stable_dt(&TimeStepContext { grid: &grid, density: 4.0, max_speed: 3.0, implicit_viscosity: None })
            .unwrap();
        assert!((dt - 0.5 / 128.0 / (10.0 + 3.0)).abs() < 1e-15);
    }

    #[test]
    fn rejects_bad_parameters() {
        for e in [0.0, -1.0, Real::NAN, Real::INFINITY] {
            let err = WeaklyCompressible::new(e).unwrap_err();
            assert!(err.starts_with("stiffness "), "{err}");
        }
        let mut m = model();
        m.cfl = 0.0;
        assert!(m.validate().is_err());
        m.cfl = Real::NAN;
        assert!(m.validate().is_err());
    }
}
