//! Phases 5–6: the pressure projection that makes all fields share one pressure, its
//! constraint and the corrector.

use super::*;
use rayon::prelude::*;

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
        // the divergence of a rank's last cells reads the faces at its high cut
        for f in &mut self.fields {
            self.grid.exchange_faces(&mut f.state.velocity);
        }
        let g = &self.grid;
        let bc = &self.boundaries;
        let mut c = FaceArrays::zeros(g);
        for f in &self.fields {
            let s = &f.state;
            for a in AXES {
                for (c, (t, w)) in c[a].iter_mut().zip(s.theta_face[a].iter().zip(&s.specific_volume[a])) {
                    *c += dt * t * w;
                }
            }
        }
        let n = g.n();
        for a in AXES {
            let lattice = Lattice::face(a);
            for i in [0, n[a]] {
                if bc.face_fixed(g, a, i) {
                    for (f, _) in g.layer(lattice, a, i) {
                        c[a][f] = 0.0;
                    }
                }
            }
        }
        let residual = constraint_of(g, &self.fields, self.case.coupling.volume_fraction_relaxation, dt);
        let rhs: Vec<Real> = residual.iter().map(|r| -r).collect();
        let problem = PoissonProblem::new(g, bc, c, rhs);
        let stats = solver.solve(&problem, &mut self.pressure)?;
        problem.fix_constant(&mut self.pressure);
        // the faces at a rank's low cut take the gradient from the cells below it
        g.exchange(&mut [(Lattice::Cell, &mut self.pressure)]);
        // corrector: u_k = ū_k − Δt w_k ∇p
        let p = &self.pressure;
        let outflow = |side| match bc.side(side) {
            crate::boundary::Boundary::Outflow { pressure } => Some(pressure),
            _ => None,
        };
        let mut gradient = FaceArrays::zeros(g);
        // storage strides of the cells (x fastest)
        let mut stride = [1; DIM];
        for d in 1..DIM {
            stride[d] = stride[d - 1] * n[d - 1];
        }
        for a in AXES {
            let (lo, hi) = (outflow(Side::of(a, false)), outflow(Side::of(a, true)));
            let periodic = bc.periodic(a);
            let lattice = Lattice::face(a);
            let row = g.shape(lattice)[0];
            // rows of faces along x, in parallel (each face on its own: the same bits)
            gradient[a].par_chunks_mut(row).enumerate().for_each(|(r, out)| {
                let at = g.node(lattice, r * row);
                // the cell (i along a) of the row's face x: `base(x) + i stride[a]`
                let b: usize = (1..DIM).filter(|&d| d != a).map(|d| at[d] * stride[d]).sum();
                for (x, out) in out.iter_mut().enumerate() {
                    let (i, base) = if a == 0 { (x, b) } else { (at[a], b + x) };
                    let cell = |i: usize| p[base + i * stride[a]];
                    *out = if i > 0 && i < n[a] {
                        (cell(i) - cell(i - 1)) / g.h
                    } else if periodic {
                        (cell(0) - cell(n[a] - 1)) / g.h
                    } else if i == 0 {
                        lo.map_or(0.0, |pd| 2.0 * (cell(0) - pd) / g.h)
                    } else {
                        hi.map_or(0.0, |pd| 2.0 * (pd - cell(n[a] - 1)) / g.h)
                    };
                }
            });
        }
        for f in &mut self.fields {
            let s = &mut f.state;
            for a in AXES {
                for (k, g) in gradient[a].iter().enumerate() {
                    let acceleration = -s.specific_volume[a][k] * g;
                    s.pressure_acceleration[a][k] = acceleration;
                    s.velocity[a][k] += dt * acceleration;
                }
            }
            bc.enforce(g, &mut s.velocity);
            // the halo as the owners': read by the divergence, the advection and the next step
            g.exchange_faces(&mut s.velocity);
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
        // (the domain's sides: a rank's block may not touch the outflow)
        let closed = !self.case.boundaries.has_dirichlet_pressure();
        let g = &self.grid;
        if closed && !c.is_empty() {
            // by the reduction rule (docs/design/mpi.md §3), as the solvers' sums
            let mean = g.sum(Lattice::Cell, &c) / g.domain_cells() as Real;
            c.iter_mut().for_each(|x| *x -= mean);
        }
        g.part.max_abs(Lattice::Cell, g.n(), &c)
    }
}

/// Volume flux Σθu on the faces.
fn mixture_flux(grid: &Grid, fields: &[Field]) -> FaceArrays {
    let mut flux = FaceArrays::zeros(grid);
    for f in fields {
        let s = &f.state;
        for a in AXES {
            for (o, (t, u)) in flux[a].iter_mut().zip(s.theta_face[a].iter().zip(&s.velocity[a])) {
                *o += t * u;
            }
        }
    }
    flux
}

/// ∇·(Σθu) − β(Σθ − 1)/Δt per cell: the residual of the constraint the pressure enforces.
pub fn constraint_of(g: &Grid, fields: &[Field], beta: Real, dt: Real) -> Vec<Real> {
    let flux = mixture_flux(g, fields);
    let mut out = vec![0.0; g.n_cells()];
    for (c, at) in g.nodes(Lattice::Cell) {
        // (low, high) face flux along axis a
        let faces = |a: usize| {
            let mut face = at;
            let lo = flux[a][g.index(Lattice::face(a), face)];
            face[a] += 1;
            (lo, flux[a][g.index(Lattice::face(a), face)])
        };
        // ((x_hi − x_lo) + y_hi) − y_lo (+ z_hi − z_lo): the 2D expression's order
        let (lo, hi) = faces(0);
        let mut div = hi - lo;
        for a in 1..DIM {
            let (lo, hi) = faces(a);
            div = div + hi - lo;
        }
        let div = div / g.h;
        let sum: Real = fields.iter().map(|f| f.state.theta[c]).sum();
        out[c] = div - beta * (sum - 1.0) / dt;
    }
    out
}
