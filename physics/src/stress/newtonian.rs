//! Newtonian viscosity: σ = 2 μ D, applied to the field's face velocities as
//! `u ← u + Δt (μ/ρ⁰) ∇²u` (explicit), stable for Δt ≤ h² ρ⁰ / (4 μ) in 2D.
//!
//! The 5-point Laplacian takes its ghost values from the boundary conditions: −u on a
//! no-slip wall (zero at the wall), u on a free-slip wall or outflow, 2u_w − u on a moving wall.

use multifield_core::boundary::Side;
use multifield_core::math::Real;
use multifield_core::plugin::{GridStressContext, StressKind, StressModel, TimeStepContext};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Serialize};

/// Newtonian viscous stress.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Newtonian {
    /// Dynamic viscosity μ (mass/(length·time); water: 0.01 g/(cm·s)).
    pub viscosity: Real,
    /// Fraction of the explicit stability limit h²ρ⁰/(4μ) used as the time-step bound.
    #[serde(default = "default_safety")]
    pub safety: Real,
}

fn default_safety() -> Real {
    0.9
}

impl Newtonian {
    /// Checks the parameters.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(self.viscosity >= 0.0 && self.viscosity.is_finite()) {
            return Err(format!("viscosity {}: must be zero or positive", self.viscosity));
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return Err(format!("safety {}: must lie in (0, 1]", self.safety));
        }
        Ok(())
    }
}

multifield_core::register!(
    Stress,
    "newtonian",
    Newtonian,
    "Newtonian viscosity σ = 2μD, explicit on the grid, Δt ≤ h²ρ/(4μ)",
    &[
        ParamDoc { name: "viscosity", unit: "mass/(length·time)", default: "required", doc: "dynamic viscosity μ" },
        ParamDoc { name: "safety", unit: "-", default: "0.9", doc: "fraction of the explicit limit h²ρ/(4μ) used" },
    ]
);

impl StressModel for Newtonian {
    fn model(&self) -> &'static str {
        "newtonian"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn kind(&self) -> StressKind {
        StressKind::Grid { newtonian_viscosity: Some(self.viscosity) }
    }
    fn stable_dt(&self, ctx: &TimeStepContext) -> Option<Real> {
        let h2 = ctx.grid.h * ctx.grid.h;
        (self.viscosity > 0.0).then(|| match ctx.implicit_viscosity {
            Some(k) => k * h2 * ctx.density / self.viscosity,
            None => self.safety * h2 * ctx.density / (4.0 * self.viscosity),
        })
    }
    fn apply_on_grid(&self, ctx: &mut GridStressContext) -> Result<(), String> {
        if self.viscosity == 0.0 {
            return Ok(());
        }
        let g = ctx.grid;
        let bc = ctx.boundaries;
        let (nx, ny) = (g.nx, g.ny);
        let k = ctx.dt * self.viscosity / (ctx.density * g.h * g.h);
        let (px, py) = (bc.periodic(0), bc.periodic(1));
        // x component on x-faces: (nx+1) × ny
        let u = ctx.state.velocity.u.clone();
        for j in 0..ny {
            for i in 0..=nx {
                if bc.xface_fixed(g, i) || (px && i == nx) {
                    continue;
                }
                let c = u[g.xface(i, j)];
                let w = if i > 0 {
                    u[g.xface(i - 1, j)]
                } else if px {
                    u[g.xface(nx - 1, j)]
                } else {
                    c
                };
                let e = if i < nx { u[g.xface(i + 1, j)] } else { c };
                let sx = (i as Real) / nx as Real;
                let s = if j > 0 {
                    u[g.xface(i, j - 1)]
                } else if py {
                    u[g.xface(i, ny - 1)]
                } else {
                    bc.tangential_ghost(Side::Bottom, c, sx)
                };
                let n = if j + 1 < ny {
                    u[g.xface(i, j + 1)]
                } else if py {
                    u[g.xface(i, 0)]
                } else {
                    bc.tangential_ghost(Side::Top, c, sx)
                };
                ctx.state.velocity.u[g.xface(i, j)] = c + k * (w + e + s + n - 4.0 * c);
            }
        }
        let v = ctx.state.velocity.v.clone();
        for j in 0..=ny {
            if bc.yface_fixed(g, j) || (py && j == ny) {
                continue;
            }
            for i in 0..nx {
                let c = v[g.yface(i, j)];
                let s = if j > 0 {
                    v[g.yface(i, j - 1)]
                } else if py {
                    v[g.yface(i, ny - 1)]
                } else {
                    c
                };
                let n = if j < ny { v[g.yface(i, j + 1)] } else { c };
                let sy = (j as Real) / ny as Real;
                let w = if i > 0 {
                    v[g.yface(i - 1, j)]
                } else if px {
                    v[g.yface(nx - 1, j)]
                } else {
                    bc.tangential_ghost(Side::Left, c, sy)
                };
                let e = if i + 1 < nx {
                    v[g.yface(i + 1, j)]
                } else if px {
                    v[g.yface(0, j)]
                } else {
                    bc.tangential_ghost(Side::Right, c, sy)
                };
                ctx.state.velocity.v[g.yface(i, j)] = c + k * (w + e + s + n - 4.0 * c);
            }
        }
        bc.enforce(g, &mut ctx.state.velocity);
        Ok(())
    }
}
