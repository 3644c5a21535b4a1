//! Short-range repulsion between bodies and between bodies and walls
//! (Glowinski et al., J. Comput. Phys. 169, 2001; Wan & Turek, Int. J. Numer. Meth. Fluids
//! 51, 2006). The grid cannot resolve the lubrication film of two disks that kiss; this
//! force keeps them apart:
//!
//!   F_ij = (c_ij / ε) ((R_i + R_j + ρ − d_ij)/ρ)² (X_i − X_j)/d_ij   for d_ij ≤ R_i + R_j + ρ,
//!
//! zero beyond; c_ij = ½ (W_i + W_j), W = (M − ρ_f V) |g| the buoyant weight (docs/method.md §4;
//! the full weight when there is no ambient fluid, `force_scale` when there is no gravity
//! or the bodies are neutrally buoyant), ρ = min(`range_cells` · h, `max_range` · min(R_i, R_j)),
//! ε = `stiffness`. The cap keeps the range a fraction of the bodies' size where the grid is
//! coarse against them (point particles with d ≈ h), where 2h would push disks apart a
//! diameter away; bodies resolved with 4 or more cells per radius never reach it. A wall acts through the mirror image
//! of the body; every side that is not periodic is a wall for the bodies, an inflow or an
//! outflow of the fluid included (this keeps the bodies of a fluidized bed in the domain). Its stiffness k = 2c/(ερ) limits the step while bodies are in range:
//! Δt ≤ `dt_factor` · sqrt(M/k) (docs/method.md §5).

use multifield_core::boundary::{Boundary, Side};
use multifield_core::math::{Real, Vector};
use multifield_core::neighbours::{pairs_within, SearchDomain};
use multifield_core::plugin::{BodyState, ContactContext, ContactModel};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Serialize};

/// Glowinski / Wan–Turek repulsion.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Repulsion {
    /// Range ρ of the force, in cells.
    #[serde(default = "default_range")]
    pub range_cells: Real,
    /// ε: the force at full range overlap is the buoyant weight divided by ε (dimensionless).
    #[serde(default = "default_stiffness")]
    pub stiffness: Real,
    /// Force scale c when the buoyant weight is zero (no gravity, or neutrally buoyant
    /// bodies), force per unit depth.
    #[serde(default)]
    pub force_scale: Real,
    /// Whether the sides repel bodies (every non-periodic one, inflows and outflows included).
    #[serde(default = "default_walls")]
    pub walls: bool,
    /// Fraction of sqrt(M/k) allowed as a time step while bodies are in range.
    #[serde(default = "default_dt_factor")]
    pub dt_factor: Real,
    /// Largest range, as a fraction of the smaller radius of the pair.
    #[serde(default = "default_max_range")]
    pub max_range: Real,
}

fn default_max_range() -> Real {
    0.5
}

fn default_range() -> Real {
    2.0
}
fn default_stiffness() -> Real {
    1e-2
}
fn default_walls() -> bool {
    true
}
fn default_dt_factor() -> Real {
    0.1
}

impl Repulsion {
    /// Checks the parameters.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(self.range_cells > 0.0) {
            return Err(format!("range_cells {}: must be positive (about 2 cells)", self.range_cells));
        }
        if !(self.stiffness > 0.0) {
            return Err(format!("stiffness {}: must be positive (smaller is stiffer)", self.stiffness));
        }
        if !(self.force_scale >= 0.0) {
            return Err(format!("force_scale {}: must be zero or positive", self.force_scale));
        }
        if !(self.max_range > 0.0) {
            return Err(format!(
                "max_range {}: must be positive (a fraction of the smaller radius; 0.5 usual)",
                self.max_range
            ));
        }
        if !(self.dt_factor > 0.0 && self.dt_factor <= 1.0) {
            return Err(format!("dt_factor {}: must lie in (0, 1]", self.dt_factor));
        }
        Ok(())
    }

    /// c_ij: the mean buoyant weight of the pair (of the body alone against a wall).
    fn scale(&self, ctx: &ContactContext, a: &BodyState, b: Option<&BodyState>) -> Real {
        let buoyant = |s: &BodyState| (s.mass - ctx.fluid_density * s.volume).abs();
        let m = b.map_or(buoyant(a), |b| 0.5 * (buoyant(a) + buoyant(b)));
        let w = m * ctx.gravity.norm();
        if w > 0.0 || self.force_scale > 0.0 {
            if w > 0.0 {
                w
            } else {
                self.force_scale
            }
        } else {
            // neutrally buoyant under gravity and no scale given: the full weight
            b.map_or(a.mass, |b| 0.5 * (a.mass + b.mass)) * ctx.gravity.norm()
        }
    }

    /// Every interacting pair: (i, Some(j)) for bodies, (i, None) for walls (through the
    /// body's mirror image); returns (i, j, separation x_i − x_other, centre distance, sum of
    /// radii, range ρ), in the order of the double loop: i ascending, its partners j > i
    /// ascending, then its walls. The partners come from the cell list of
    /// `multifield_core::neighbours` (O(N)); across a periodic side a partner is at its
    /// nearest image (the minimum-image separation).
    fn pairs(&self, ctx: &ContactContext, mut f: impl FnMut(usize, Option<usize>, Vector, Real, Real, Real)) {
        let grid_range = self.range_cells * ctx.grid.h;
        let range = |r: Real| grid_range.min(self.max_range * r);
        let bodies = ctx.bodies;
        let centres: Vec<Vector> = bodies.iter().map(|b| b.position).collect();
        let radii: Vec<Real> = bodies.iter().map(|b| b.radius).collect();
        // 2ρ of any pair is at most 2 min(grid range, max_range · largest radius)
        let r_max = radii.iter().fold(0.0 as Real, |m, &r| m.max(r));
        let search = 2.0 * range(r_max);
        let domain = SearchDomain::of_grid(ctx.grid, ctx.boundaries);
        let candidates = pairs_within(&centres, &radii, search, &domain);
        let mut next = 0;
        for i in 0..bodies.len() {
            while next < candidates.len() && candidates[next].i == i {
                let p = candidates[next];
                next += 1;
                let j = p.j;
                let d = p.distance;
                let reach = bodies[i].radius + bodies[j].radius;
                let rho = range(bodies[i].radius.min(bodies[j].radius));
                if d <= reach + 2.0 * rho {
                    f(i, Some(j), p.separation, d, reach, rho);
                }
            }
            if !self.walls {
                continue;
            }
            let lo = ctx.grid.origin;
            let hi = lo + ctx.grid.size();
            let x = bodies[i].position;
            for side in Side::ALL {
                if ctx.boundaries.side(side) == Boundary::Periodic {
                    continue;
                }
                let image = match side {
                    Side::Left => Vector::new(2.0 * lo.x - x.x, x.y),
                    Side::Right => Vector::new(2.0 * hi.x - x.x, x.y),
                    Side::Bottom => Vector::new(x.x, 2.0 * lo.y - x.y),
                    Side::Top => Vector::new(x.x, 2.0 * hi.y - x.y),
                };
                let d = (x - image).norm();
                let reach = 2.0 * bodies[i].radius;
                let rho = range(bodies[i].radius);
                if d <= reach + 2.0 * rho {
                    f(i, None, x - image, d, reach, rho);
                }
            }
        }
    }
}

multifield_core::register!(
    Contact,
    "repulsion",
    Repulsion,
    "Glowinski/Wan–Turek short-range repulsion (c/ε)((Ri+Rj+ρ−d)/ρ)² between bodies and walls",
    &[
        ParamDoc { name: "range_cells", unit: "cells", default: "2.0", doc: "range ρ of the force" },
        ParamDoc {
            name: "stiffness", unit: "-", default: "1e-2", doc: "ε: force at full overlap = buoyant weight/ε"
        },
        ParamDoc { name: "force_scale", unit: "force/length", default: "0", doc: "c when the buoyant weight is zero" },
        ParamDoc {
            name: "walls",
            unit: "-",
            default: "true",
            doc: "whether the sides (every non-periodic one, inflows and outflows included) repel bodies",
        },
        ParamDoc { name: "dt_factor", unit: "-", default: "0.1", doc: "Δt ≤ dt_factor·sqrt(M/k) while in range" },
        ParamDoc {
            name: "max_range",
            unit: "radii",
            default: "0.5",
            doc: "ρ at most this fraction of the smaller radius (coarse grids, point particles)",
        },
    ]
);

impl ContactModel for Repulsion {
    fn model(&self) -> &'static str {
        "repulsion"
    }
    fn decomposed(&self) -> bool {
        // replicated: every rank holds every body's state and computes every force (the
        // same inputs, the same bits), with the domain's boundaries
        true
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn forces(&mut self, ctx: &ContactContext, _dt: Real, out: &mut [(Vector, Real)]) {
        out.iter_mut().for_each(|o| *o = (Vector::zeros(), 0.0));
        self.pairs(ctx, |i, j, separation, d, reach, rho| {
            if d > reach + rho || d <= 0.0 {
                return;
            }
            let a = &ctx.bodies[i];
            let c = self.scale(ctx, a, j.map(|j| &ctx.bodies[j]));
            let magnitude = c / self.stiffness * ((reach + rho - d) / rho).powi(2);
            let n = separation / d;
            out[i].0 += magnitude * n;
            if let Some(j) = j {
                out[j].0 -= magnitude * n;
            }
        });
    }
    fn stable_dt(&self, ctx: &ContactContext) -> Option<Real> {
        let mut best: Option<Real> = None;
        self.pairs(ctx, |i, j, _, _, _, rho| {
            let a = &ctx.bodies[i];
            let c = self.scale(ctx, a, j.map(|j| &ctx.bodies[j]));
            if c <= 0.0 {
                return;
            }
            let m = j.map_or(a.mass, |j| a.mass.min(ctx.bodies[j].mass));
            let k = 2.0 * c / (self.stiffness * rho);
            let dt = self.dt_factor * (m / k).sqrt();
            best = Some(best.map_or(dt, |b: Real| b.min(dt)));
        });
        best
    }
    /// The step of [`ContactModel::stable_dt`] for the stiffest pair any two bodies (or a
    /// body and a wall) could form: the smallest mass and range against the largest force
    /// scale, dt_factor · sqrt(M_min ε ρ_min / (2 c_max)); equal to it for equal bodies.
    /// Every non-periodic side is a wall for the bodies, inflows and outflows included.
    fn keeps_bodies_off_sides(&self) -> bool {
        self.walls
    }
    fn substep_dt(&self, ctx: &ContactContext) -> Option<Real> {
        let bodies = ctx.bodies;
        if bodies.is_empty() || (bodies.len() == 1 && !self.walls) {
            return None;
        }
        let range = |r: Real| (self.range_cells * ctx.grid.h).min(self.max_range * r);
        let m = bodies.iter().map(|b| b.mass).fold(Real::INFINITY, Real::min);
        let rho = bodies.iter().map(|b| range(b.radius)).fold(Real::INFINITY, Real::min);
        // c_ij is at most the larger of the two bodies' own scales (a mean, or the same fallback)
        let c = bodies.iter().map(|b| self.scale(ctx, b, None)).fold(0.0, Real::max);
        (c > 0.0).then(|| self.dt_factor * (m * self.stiffness * rho / (2.0 * c)).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::boundary::Boundaries;
    use multifield_core::grid::Grid;

    #[test]
    fn force_follows_the_quadratic_law_and_is_equal_and_opposite() {
        let grid = Grid::new(10, 10, 0.1, Vector::zeros());
        let bc = Boundaries::default();
        let body =
            |x: Real, y: Real| BodyState { mass: 2.0, radius: 0.1, position: Vector::new(x, y), ..Default::default() };
        let mut rep = Repulsion {
            range_cells: 2.0,
            stiffness: 0.5,
            force_scale: 0.0,
            walls: false,
            dt_factor: 0.1,
            max_range: 10.0,
        };
        // ρ = 0.2, R_i + R_j = 0.2, d = 0.3: overlap (0.2 + 0.2 − 0.3)/0.2 = 0.5
        let bodies = [body(0.3, 0.5), body(0.6, 0.5)];
        let ctx = ContactContext {
            grid: &grid,
            boundaries: &bc,
            gravity: Vector::new(0.0, -10.0),
            fluid_density: 0.0,
            fluid_viscosity: None,
            bodies: &bodies,
            resolved: &[],
        };
        let mut out = vec![(Vector::zeros(), 0.0); 2];
        rep.forces(&ctx, 0.0, &mut out);
        let expected = 2.0 * 10.0 / 0.5 * 0.25;
        assert!((out[0].0.x + expected).abs() < 1e-12, "{:?}", out[0]);
        assert!((out[0].0 + out[1].0).norm() < 1e-12);
        // beyond the range: nothing
        let far = [body(0.2, 0.5), body(0.7, 0.5)];
        let ctx = ContactContext { bodies: &far, ..ctx };
        rep.forces(&ctx, 0.0, &mut out);
        assert_eq!(out[0].0.norm(), 0.0);
    }

    #[test]
    fn the_force_scales_with_the_buoyant_weight() {
        let grid = Grid::new(10, 10, 0.1, Vector::zeros());
        let bc = Boundaries::default();
        // m = 1.5 ρ_f V: buoyant weight (1.5 − 1) V |g| = m|g|/3
        let body = |x: Real| BodyState {
            mass: 1.5 * 0.04,
            volume: 0.04,
            radius: 0.1,
            position: Vector::new(x, 0.5),
            ..Default::default()
        };
        let mut rep = Repulsion {
            range_cells: 2.0,
            stiffness: 0.5,
            force_scale: 7.0,
            walls: false,
            dt_factor: 0.1,
            max_range: 10.0,
        };
        let bodies = [body(0.3), body(0.6)];
        let g = Vector::new(0.0, -10.0);
        let mut out = vec![(Vector::zeros(), 0.0); 2];
        let ctx = ContactContext {
            grid: &grid,
            boundaries: &bc,
            gravity: g,
            fluid_density: 1.0,
            fluid_viscosity: None,
            bodies: &bodies,
            resolved: &[],
        };
        rep.forces(&ctx, 0.0, &mut out);
        let expected = 0.5 * 0.04 * 10.0 / 0.5 * 0.25;
        assert!((out[0].0.x + expected).abs() < 1e-12, "{:?} against {expected}", out[0]);
        let dry = rep.stable_dt(&ContactContext { fluid_density: 0.0, ..ctx }).unwrap();
        let wet = rep.stable_dt(&ctx).unwrap();
        assert!((wet / dry - 3.0_f64.sqrt()).abs() < 1e-12, "step ratio {}", wet / dry);
        // neutrally buoyant: the given force scale
        let ctx = ContactContext { fluid_density: 1.5, ..ctx };
        rep.forces(&ctx, 0.0, &mut out);
        assert!((out[0].0.x + 7.0 / 0.5 * 0.25).abs() < 1e-12, "{:?}", out[0]);
    }

    #[test]
    fn wall_pushes_a_body_away_and_sets_a_step_limit() {
        let grid = Grid::new(10, 10, 0.1, Vector::zeros());
        let bc = Boundaries::default();
        let b = [BodyState { mass: 1.0, radius: 0.1, position: Vector::new(0.5, 0.15), ..Default::default() }];
        let mut rep = Repulsion {
            range_cells: 2.0,
            stiffness: 1e-2,
            force_scale: 0.0,
            walls: true,
            dt_factor: 0.1,
            max_range: 10.0,
        };
        let ctx = ContactContext {
            grid: &grid,
            boundaries: &bc,
            gravity: Vector::new(0.0, -10.0),
            fluid_density: 0.0,
            fluid_viscosity: None,
            bodies: &b,
            resolved: &[],
        };
        let mut out = vec![(Vector::zeros(), 0.0)];
        rep.forces(&ctx, 0.0, &mut out);
        // image at y = −0.15: d = 0.3, reach 0.2, ρ 0.2 → overlap 0.5
        assert!((out[0].0.y - 10.0 / 1e-2 * 0.25).abs() < 1e-9 && out[0].0.x == 0.0);
        let dt = rep.stable_dt(&ctx).unwrap();
        let k: Real = 2.0 * 10.0 / (1e-2 * 0.2);
        assert!((dt - 0.1 * (1.0 / k).sqrt()).abs() < 1e-15);
    }
}
