//! Newtonian viscosity: σ = 2 μ D, applied to the field's face velocities as
//! `u ← u + Δt (μ/ρ⁰) ∇²u` (explicit), stable for Δt ≤ h² ρ⁰ / (2 DIM μ): h²ρ⁰/(4μ) in 2D,
//! h²ρ⁰/(6μ) in 3D.
//!
//! The 5-point (in 3D 7-point) Laplacian of each face lattice takes its ghost values from the boundary conditions: −u on a
//! no-slip wall (zero at the wall), u on a free-slip wall or outflow, 2u_w − u on a moving wall.

use multifield_core::boundary::{FaceNeighbour, Side};
use multifield_core::grid::Lattice;
use multifield_core::math::{Real, AXES, DIM};
use multifield_core::plugin::{GridStressContext, StressKind, StressModel, TimeStepContext};
use multifield_core::registry::{params_value, ParamDoc};
use rayon::prelude::*;
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
    fn decomposed(&self) -> bool {
        // its stencil reads the faces next to a face, the halo at a rank's cut
        true
    }
    fn kind(&self) -> StressKind {
        StressKind::Grid { newtonian_viscosity: Some(self.viscosity) }
    }
    fn stable_dt(&self, ctx: &TimeStepContext) -> Option<Real> {
        let h2 = ctx.grid.h * ctx.grid.h;
        (self.viscosity > 0.0).then(|| match ctx.implicit_viscosity {
            Some(k) => k * h2 * ctx.density / self.viscosity,
            None => self.safety * h2 * ctx.density / ((2 * DIM) as Real * self.viscosity),
        })
    }
    fn apply_on_grid(&self, ctx: &mut GridStressContext) -> Result<(), String> {
        if self.viscosity == 0.0 {
            return Ok(());
        }
        let g = ctx.grid;
        let bc = ctx.boundaries;
        let n = g.n();
        let k = ctx.dt * self.viscosity / (ctx.density * g.h * g.h);
        // the centre weight of the 5-point (7-point) Laplacian
        let centre = (2 * DIM) as Real;
        for a in AXES {
            let lattice = Lattice::face(a);
            let periodic = bc.periodic(a);
            let shape = g.shape(lattice);
            // storage strides of the lattice (x fastest)
            let mut stride = [1; DIM];
            for d in 1..DIM {
                stride[d] = stride[d - 1] * shape[d - 1];
            }
            // component a on the faces normal to a; each face reads only `u`, so the rows
            // run in parallel with the same bits
            let u = ctx.state.velocity[a].clone();
            let rows = ctx.state.velocity[a].par_chunks_mut(shape[0]).enumerate();
            rows.for_each(|(r, row)| {
                let mut at = g.node(lattice, r * shape[0]);
                for (i, out) in row.iter_mut().enumerate() {
                    at[0] = i;
                    if bc.face_fixed(g, a, at[a]) || (periodic && at[a] == n[a]) {
                        continue;
                    }
                    let f = r * shape[0] + i;
                    let c = u[f];
                    // every neighbour a face of the lattice at ± one stride: no boundary
                    let inside = AXES.into_iter().all(|d| at[d] > 0 && at[d] + 1 < shape[d]);
                    // Σ neighbours in side order (2D: w + e + s + n)
                    let sum = if inside {
                        let mut sum = u[f - stride[0]];
                        sum += u[f + stride[0]];
                        for d in 1..DIM {
                            sum += u[f - stride[d]];
                            sum += u[f + stride[d]];
                        }
                        sum
                    } else {
                        let neighbour = |side: Side| -> Real {
                            match bc.face_neighbour(g, a, at, side) {
                                FaceNeighbour::Face(m) => u[g.index(lattice, m)],
                                FaceNeighbour::Itself => c,
                                FaceNeighbour::Ghost(s) => bc.ghost(side, a, c, s),
                            }
                        };
                        let mut sum = neighbour(Side::ALL[0]);
                        for &side in &Side::ALL[1..] {
                            sum += neighbour(side);
                        }
                        sum
                    };
                    *out = c + k * (sum - centre * c);
                }
            });
        }
        bc.enforce(g, &mut ctx.state.velocity);
        Ok(())
    }
}
