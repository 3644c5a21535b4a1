//! Phases 5–6: the pressure projection that makes all fields share one pressure, its
//! constraint and the corrector.

use super::*;

impl Simulation {
    /// −β(Σθ − 1)/Δt + ∇·(Σθu) per cell: the constraint residual.
    pub(super) fn constraint(&self, dt: Real) -> Vec<Real> {
        constraint_of(&self.grid, &self.fields, self.case.coupling.volume_fraction_relaxation, dt)
    }

    /// Phases 5–6: the pressure equation and the corrector. Returns (iterations, residual).
    pub(super) fn pressure_projection(&mut self, dt: Real) -> Result<(usize, Real)> {
        let Some(solver) = self.pressure_solver.as_mut() else {
            return Ok((0, 0.0));
        };
        let g = &self.grid;
        let bc = &self.boundaries;
        let mut cx = vec![0.0; g.n_xfaces()];
        let mut cy = vec![0.0; g.n_yfaces()];
        for f in &self.fields {
            let s = &f.state;
            for (c, (t, w)) in cx.iter_mut().zip(s.theta_u.iter().zip(&s.specific_volume.u)) {
                *c += dt * t * w;
            }
            for (c, (t, w)) in cy.iter_mut().zip(s.theta_v.iter().zip(&s.specific_volume.v)) {
                *c += dt * t * w;
            }
        }
        for j in 0..g.ny {
            for i in [0, g.nx] {
                if bc.xface_fixed(g, i) {
                    cx[g.xface(i, j)] = 0.0;
                }
            }
        }
        for j in [0, g.ny] {
            if bc.yface_fixed(g, j) {
                for i in 0..g.nx {
                    cy[g.yface(i, j)] = 0.0;
                }
            }
        }
        let residual = constraint_of(g, &self.fields, self.case.coupling.volume_fraction_relaxation, dt);
        let rhs: Vec<Real> = residual.iter().map(|r| -r).collect();
        let problem = PoissonProblem::new(g, bc, cx, cy, rhs);
        let stats = solver.solve(&problem, &mut self.pressure)?;
        problem.fix_constant(&mut self.pressure);
        // corrector: u_k = ū_k − Δt w_k ∇p
        let p = &self.pressure;
        let (nx, ny) = (g.nx, g.ny);
        let outflow = |side| match bc.side(side) {
            crate::boundary::Boundary::Outflow { pressure } => Some(pressure),
            _ => None,
        };
        let (pl, pr, pb, pt) = (
            outflow(crate::boundary::Side::Left),
            outflow(crate::boundary::Side::Right),
            outflow(crate::boundary::Side::Bottom),
            outflow(crate::boundary::Side::Top),
        );
        let mut gx = vec![0.0; g.n_xfaces()];
        let mut gy = vec![0.0; g.n_yfaces()];
        for j in 0..ny {
            for i in 0..=nx {
                let grad = if i > 0 && i < nx {
                    (p[g.cell(i, j)] - p[g.cell(i - 1, j)]) / g.h
                } else if bc.periodic_x() {
                    (p[g.cell(0, j)] - p[g.cell(nx - 1, j)]) / g.h
                } else if i == 0 {
                    pl.map_or(0.0, |pd| 2.0 * (p[g.cell(0, j)] - pd) / g.h)
                } else {
                    pr.map_or(0.0, |pd| 2.0 * (pd - p[g.cell(nx - 1, j)]) / g.h)
                };
                gx[g.xface(i, j)] = grad;
            }
        }
        for j in 0..=ny {
            for i in 0..nx {
                let grad = if j > 0 && j < ny {
                    (p[g.cell(i, j)] - p[g.cell(i, j - 1)]) / g.h
                } else if bc.periodic_y() {
                    (p[g.cell(i, 0)] - p[g.cell(i, ny - 1)]) / g.h
                } else if j == 0 {
                    pb.map_or(0.0, |pd| 2.0 * (p[g.cell(i, 0)] - pd) / g.h)
                } else {
                    pt.map_or(0.0, |pd| 2.0 * (pd - p[g.cell(i, ny - 1)]) / g.h)
                };
                gy[g.yface(i, j)] = grad;
            }
        }
        for f in &mut self.fields {
            let s = &mut f.state;
            for (k, g) in gx.iter().enumerate() {
                let a = -s.specific_volume.u[k] * g;
                s.pressure_acceleration.u[k] = a;
                s.velocity.u[k] += dt * a;
            }
            for (k, g) in gy.iter().enumerate() {
                let a = -s.specific_volume.v[k] * g;
                s.pressure_acceleration.v[k] = a;
                s.velocity.v[k] += dt * a;
            }
            bc.enforce(g, &mut s.velocity);
        }
        Ok((stats.iterations, stats.residual))
    }

    pub(super) fn max_divergence(&self, dt: Real) -> Real {
        if self.pressure_solver.is_none() {
            return 0.0;
        }
        let mut c = self.constraint(dt);
        // With no outflow side the pressure equation is pure Neumann: the mean of the
        // constraint (net inflow, and the mean Σθ drift term, which no pressure can change)
        // is projected out before the solve, so it is not the solver's error.
        let closed = !crate::boundary::Side::ALL
            .iter()
            .any(|s| matches!(self.boundaries.side(*s), crate::boundary::Boundary::Outflow { .. }));
        if closed && !c.is_empty() {
            let mean = c.iter().sum::<Real>() / c.len() as Real;
            c.iter_mut().for_each(|x| *x -= mean);
        }
        c.iter().fold(0.0, |m, x| m.max(x.abs()))
    }
}

/// Volume flux Σθu on x-faces and y-faces.
fn mixture_flux(grid: &Grid, fields: &[Field]) -> (Vec<Real>, Vec<Real>) {
    let mut fx = vec![0.0; grid.n_xfaces()];
    let mut fy = vec![0.0; grid.n_yfaces()];
    for f in fields {
        let s = &f.state;
        for (o, (t, u)) in fx.iter_mut().zip(s.theta_u.iter().zip(&s.velocity.u)) {
            *o += t * u;
        }
        for (o, (t, v)) in fy.iter_mut().zip(s.theta_v.iter().zip(&s.velocity.v)) {
            *o += t * v;
        }
    }
    (fx, fy)
}

/// ∇·(Σθu) − β(Σθ − 1)/Δt per cell: the residual of the constraint the pressure enforces.
pub fn constraint_of(g: &Grid, fields: &[Field], beta: Real, dt: Real) -> Vec<Real> {
    let (fx, fy) = mixture_flux(g, fields);
    let mut out = vec![0.0; g.n_cells()];
    for j in 0..g.ny {
        for i in 0..g.nx {
            let div = (fx[g.xface(i + 1, j)] - fx[g.xface(i, j)] + fy[g.yface(i, j + 1)] - fy[g.yface(i, j)]) / g.h;
            let c = g.cell(i, j);
            let sum: Real = fields.iter().map(|f| f.state.theta[c]).sum();
            out[c] = div - beta * (sum - 1.0) / dt;
        }
    }
    out
}
