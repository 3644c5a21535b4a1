//! Power-law (Ostwald–de Waele) fluid, a generalised Newtonian viscosity:
//!
//!   σ = 2 μ(γ̇) D,   μ(γ̇) = min(k γ̇ⁿ⁻¹, μ_max),   γ̇ = √(2 D:D),
//!
//! with consistency k, flow index n (n < 1 shear-thinning, n = 1 Newtonian with μ = k,
//! n > 1 shear-thickening) and a cap μ_max that keeps μ finite where γ̇ → 0 for n < 1
//! (Bird, Armstrong & Hassager, *Dynamics of Polymeric Liquids* vol. 1, 1987, §4.2).
//!
//! Discretisation on the MAC grid, explicit in time: the strain rates ∂u/∂x, ∂v/∂y live at
//! cell centres and the shear ∂u/∂y + ∂v/∂x at cell corners; μ is evaluated at cell centres
//! (γ̇ with the mean of the four corner shears) and averaged to the corners; then
//!
//!   u ← u + (Δt/ρ⁰) [∂x(2μ ∂u/∂x) + ∂y(μ (∂u/∂y + ∂v/∂x))],
//!   v ← v + (Δt/ρ⁰) [∂x(μ (∂u/∂y + ∂v/∂x)) + ∂y(2μ ∂v/∂y)].
//!
//! Ghost values outside walls come from the boundary conditions, as for `newtonian`.
//! Stable for Δt ≤ h² ρ⁰ / (4 μ_max): the cap bounds the time step.

use multifield_core::boundary::Side;
use multifield_core::math::Real;
use multifield_core::plugin::{GridStressContext, StressKind, StressModel, TimeStepContext};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Serialize};

/// Power-law viscous stress.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowerLaw {
    /// Consistency k (mass·timeⁿ⁻²/length): the viscosity at γ̇ = 1/time.
    pub consistency: Real,
    /// Flow index n (dimensionless): < 1 shear-thinning, 1 Newtonian, > 1 shear-thickening.
    #[serde(default = "default_index")]
    pub index: Real,
    /// Cap μ_max on the effective viscosity (mass/(length·time)); it sets the time step.
    pub max_viscosity: Real,
    /// Fraction of the explicit stability limit h²ρ⁰/(4μ_max) used as the time-step bound.
    #[serde(default = "default_safety")]
    pub safety: Real,
}

fn default_index() -> Real {
    1.0
}
fn default_safety() -> Real {
    0.9
}

impl PowerLaw {
    /// Checks the parameters.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(self.consistency > 0.0 && self.consistency.is_finite()) {
            return Err(format!("consistency {}: must be positive, e.g. 0.1", self.consistency));
        }
        if !(self.index > 0.0 && self.index.is_finite()) {
            return Err(format!(
                "index {}: must be positive (0.5 shear-thinning, 1 Newtonian, 1.5 shear-thickening)",
                self.index
            ));
        }
        if !(self.max_viscosity > 0.0 && self.max_viscosity.is_finite()) {
            return Err(format!(
                "max_viscosity {}: must be positive; it caps k γ̇ⁿ⁻¹ and sets the time step h²ρ/(4 μ_max)",
                self.max_viscosity
            ));
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return Err(format!("safety {}: must lie in (0, 1]", self.safety));
        }
        Ok(())
    }

    /// Effective viscosity min(k γ̇ⁿ⁻¹, μ_max) at shear rate `gamma` (1/time).
    pub fn viscosity(&self, gamma: Real) -> Real {
        if self.index == 1.0 {
            return self.consistency.min(self.max_viscosity);
        }
        (self.consistency * gamma.powf(self.index - 1.0)).min(self.max_viscosity)
    }
}

multifield_core::register!(
    Stress,
    "power_law",
    PowerLaw,
    "power-law fluid σ = 2μD, μ = min(k γ̇ⁿ⁻¹, μ_max), explicit on the grid, Δt ≤ h²ρ/(4μ_max)",
    &[
        ParamDoc {
            name: "consistency",
            unit: "mass·timeⁿ⁻²/length",
            default: "required",
            doc: "k: the viscosity at a shear rate of 1/time"
        },
        ParamDoc { name: "index", unit: "-", default: "1", doc: "n: < 1 shear-thinning, 1 Newtonian, > 1 thickening" },
        ParamDoc {
            name: "max_viscosity",
            unit: "mass/(length·time)",
            default: "required",
            doc: "cap μ_max on k γ̇ⁿ⁻¹; sets the time step"
        },
        ParamDoc {
            name: "safety", unit: "-", default: "0.9", doc: "fraction of the explicit limit h²ρ/(4μ_max) used"
        },
    ]
);

impl StressModel for PowerLaw {
    fn model(&self) -> &'static str {
        "power_law"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn kind(&self) -> StressKind {
        // a viscosity on the grid's velocities, not Newtonian (no implicit integration)
        StressKind::Grid { newtonian_viscosity: None }
    }
    fn stable_dt(&self, ctx: &TimeStepContext) -> Option<Real> {
        Some(self.safety * ctx.grid.h * ctx.grid.h * ctx.density / (4.0 * self.max_viscosity))
    }
    fn apply_on_grid(&self, ctx: &mut GridStressContext) -> Result<(), String> {
        let g = ctx.grid;
        let bc = ctx.boundaries;
        let (nx, ny, h) = (g.nx, g.ny, g.h);
        let (px, py) = (bc.periodic(0), bc.periodic(1));
        let u = ctx.state.velocity.u.clone();
        let v = ctx.state.velocity.v.clone();
        // shear ∂u/∂y + ∂v/∂x at the (nx+1) × (ny+1) corners
        let node = |i: usize, j: usize| j * (nx + 1) + i;
        let mut shear = vec![0.0; (nx + 1) * (ny + 1)];
        for j in 0..=ny {
            for i in 0..=nx {
                let (ui, vj) = (if px && i == nx { 0 } else { i }, if py && j == ny { 0 } else { j });
                // u on the x-faces above and below the corner
                let un = if vj < ny { Some(u[g.xface(i, vj)]) } else { None };
                let us = if vj > 0 {
                    Some(u[g.xface(i, vj - 1)])
                } else if py {
                    Some(u[g.xface(i, ny - 1)])
                } else {
                    None
                };
                let sx = i as Real / nx as Real;
                let (un, us) = match (un, us) {
                    (Some(n), Some(s)) => (n, s),
                    (None, Some(s)) => (bc.tangential_ghost(Side::Top, s, sx), s),
                    (Some(n), None) => (n, bc.tangential_ghost(Side::Bottom, n, sx)),
                    (None, None) => unreachable!("ny ≥ 2"),
                };
                let ve = if ui < nx { Some(v[g.yface(ui, j)]) } else { None };
                let vw = if ui > 0 {
                    Some(v[g.yface(ui - 1, j)])
                } else if px {
                    Some(v[g.yface(nx - 1, j)])
                } else {
                    None
                };
                let sy = j as Real / ny as Real;
                let (ve, vw) = match (ve, vw) {
                    (Some(e), Some(w)) => (e, w),
                    (None, Some(w)) => (bc.tangential_ghost(Side::Right, w, sy), w),
                    (Some(e), None) => (e, bc.tangential_ghost(Side::Left, e, sy)),
                    (None, None) => unreachable!("nx ≥ 2"),
                };
                shear[node(i, j)] = (un - us) / h + (ve - vw) / h;
            }
        }
        // normal stresses 2μ ∂u/∂x, 2μ ∂v/∂y and μ at cell centres
        let n_cells = g.n_cells();
        let (mut txx, mut tyy, mut mu) = (vec![0.0; n_cells], vec![0.0; n_cells], vec![0.0; n_cells]);
        for j in 0..ny {
            for i in 0..nx {
                let ux = (u[g.xface(i + 1, j)] - u[g.xface(i, j)]) / h;
                let vy = (v[g.yface(i, j + 1)] - v[g.yface(i, j)]) / h;
                let s2 = 0.25
                    * (shear[node(i, j)].powi(2)
                        + shear[node(i + 1, j)].powi(2)
                        + shear[node(i, j + 1)].powi(2)
                        + shear[node(i + 1, j + 1)].powi(2));
                let gamma = (2.0 * (ux * ux + vy * vy) + s2).sqrt();
                let c = g.cell(i, j);
                mu[c] = self.viscosity(gamma);
                txx[c] = 2.0 * mu[c] * ux;
                tyy[c] = 2.0 * mu[c] * vy;
            }
        }
        // shear stress μ (∂u/∂y + ∂v/∂x) at corners, μ the mean of the cells around the corner
        let mut txy = vec![0.0; shear.len()];
        for j in 0..=ny {
            for i in 0..=nx {
                let is: &[usize] = match (i, px) {
                    (0, true) => &[nx - 1, 0],
                    (0, false) => &[0],
                    (i, true) if i == nx => &[nx - 1, 0],
                    (i, false) if i == nx => &[nx - 1],
                    _ => &[i - 1, i],
                };
                let js: &[usize] = match (j, py) {
                    (0, true) => &[ny - 1, 0],
                    (0, false) => &[0],
                    (j, true) if j == ny => &[ny - 1, 0],
                    (j, false) if j == ny => &[ny - 1],
                    _ => &[j - 1, j],
                };
                let mut m = 0.0;
                for &jj in js {
                    for &ii in is {
                        m += mu[g.cell(ii, jj)];
                    }
                }
                txy[node(i, j)] = m / (is.len() * js.len()) as Real * shear[node(i, j)];
            }
        }
        let k = ctx.dt / (ctx.density * h);
        let vel = &mut ctx.state.velocity;
        for j in 0..ny {
            for i in 0..=nx {
                if bc.xface_fixed(g, i) || (px && i == nx) {
                    continue;
                }
                // outside a side that is neither periodic nor fixed (outflow): no normal stress
                let east = if i < nx { txx[g.cell(i, j)] } else { 0.0 };
                let west = if i > 0 {
                    txx[g.cell(i - 1, j)]
                } else if px {
                    txx[g.cell(nx - 1, j)]
                } else {
                    0.0
                };
                let f = east - west + txy[node(i, j + 1)] - txy[node(i, j)];
                vel.u[g.xface(i, j)] = u[g.xface(i, j)] + k * f;
            }
        }
        for j in 0..=ny {
            if bc.yface_fixed(g, j) || (py && j == ny) {
                continue;
            }
            for i in 0..nx {
                let north = if j < ny { tyy[g.cell(i, j)] } else { 0.0 };
                let south = if j > 0 {
                    tyy[g.cell(i, j - 1)]
                } else if py {
                    tyy[g.cell(i, ny - 1)]
                } else {
                    0.0
                };
                let f = north - south + txy[node(i + 1, j)] - txy[node(i, j)];
                vel.v[g.yface(i, j)] = v[g.yface(i, j)] + k * f;
            }
        }
        bc.enforce(g, vel);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viscosity_follows_the_power_law_and_its_cap() {
        let m = PowerLaw { consistency: 0.2, index: 0.5, max_viscosity: 1.0, safety: 0.9 };
        assert!((m.viscosity(4.0) - 0.1).abs() < 1e-15);
        assert_eq!(m.viscosity(0.0), 1.0);
        let newtonian = PowerLaw { index: 1.0, ..m.clone() };
        assert_eq!(newtonian.viscosity(0.0), 0.2);
        assert_eq!(newtonian.viscosity(123.0), 0.2);
    }

    #[test]
    fn bad_parameters_say_how_to_fix_them() {
        let mut m = PowerLaw { consistency: 0.2, index: -1.0, max_viscosity: 1.0, safety: 0.9 };
        assert!(m.validate().unwrap_err().contains("index -1: must be positive"));
        let mut m = PowerLaw { consistency: 0.2, index: 0.5, max_viscosity: 0.0, safety: 0.9 };
        assert!(m.validate().unwrap_err().contains("max_viscosity 0: must be positive"));
    }
}
