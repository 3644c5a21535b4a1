//! The pressure equation as a symmetric positive (semi-)definite 5-point system.
//!
//! `Σ_faces c_f (p_i − p_neighbour) = b_i`, the discrete form of −∇·(c∇p) = b, with
//! `c_f = Δt Σ_k θ_k w_k / h²` on each face. Walls have c = 0 (Neumann), an outflow side
//! fixes p through a ghost value (Dirichlet, `2 c_f (p_i − p_side)`), periodic sides wrap.
//! Without a Dirichlet side the constant is a null space: the right-hand side is projected
//! onto the compatible subspace and the solution shifted to zero mean.

use crate::boundary::{Boundaries, Boundary, Side};
use crate::grid::Grid;
use crate::math::Real;
use rayon::prelude::*;

/// A pressure problem handed to a [`crate::plugin::PressureSolver`].
#[derive(Clone, Debug)]
pub struct PoissonProblem {
    /// The grid.
    pub grid: Grid,
    /// Coefficients on x-faces, already divided by h².
    pub cx: Vec<Real>,
    /// Coefficients on y-faces, already divided by h².
    pub cy: Vec<Real>,
    /// Right-hand side per cell, Dirichlet contributions included, compatible if singular.
    pub rhs: Vec<Real>,
    /// Periodic along x.
    pub periodic_x: bool,
    /// Periodic along y.
    pub periodic_y: bool,
    /// Dirichlet sides (left, right, bottom, top): whether the side fixes p.
    pub dirichlet: [bool; 4],
    /// |mean(b)| / rms(b) removed from a singular system (0 if nonsingular).
    pub incompatibility: Real,
}

/// What a solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Iterations (or 1 for a direct solve).
    pub iterations: usize,
    /// Final relative residual.
    pub residual: Real,
    /// Incompatibility of the right-hand side removed for a singular system.
    pub incompatibility: Real,
}

/// Rows per parallel task in reductions: fixed, so sums do not depend on the thread count.
const CHUNK: usize = 2048;

/// Deterministic dot product (the same bits for any number of threads).
pub fn dot(a: &[Real], b: &[Real]) -> Real {
    let partial: Vec<Real> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum::<Real>())
        .collect();
    partial.iter().sum()
}

/// Deterministic sum.
pub fn sum(a: &[Real]) -> Real {
    let partial: Vec<Real> = a.par_chunks(CHUNK).map(|x| x.iter().sum::<Real>()).collect();
    partial.iter().sum()
}

impl PoissonProblem {
    /// Assembles a problem from face coefficients `c` (not yet divided by h²) and the
    /// right-hand side `b`, with Dirichlet values from the outflow sides.
    pub fn new(grid: &Grid, boundaries: &Boundaries, cx: Vec<Real>, cy: Vec<Real>, mut rhs: Vec<Real>) -> Self {
        let h2 = grid.h * grid.h;
        let cx: Vec<Real> = cx.into_iter().map(|c| c / h2).collect();
        let cy: Vec<Real> = cy.into_iter().map(|c| c / h2).collect();
        let mut dirichlet = [false; 4];
        for (k, side) in Side::ALL.iter().enumerate() {
            if let Boundary::Outflow { pressure } = boundaries.side(*side) {
                dirichlet[k] = true;
                let (nx, ny) = (grid.nx, grid.ny);
                match side {
                    Side::Left => (0..ny).for_each(|j| rhs[grid.cell(0, j)] += 2.0 * cx[grid.xface(0, j)] * pressure),
                    Side::Right => {
                        (0..ny).for_each(|j| rhs[grid.cell(nx - 1, j)] += 2.0 * cx[grid.xface(nx, j)] * pressure)
                    }
                    Side::Bottom => (0..nx).for_each(|i| rhs[grid.cell(i, 0)] += 2.0 * cy[grid.yface(i, 0)] * pressure),
                    Side::Top => {
                        (0..nx).for_each(|i| rhs[grid.cell(i, ny - 1)] += 2.0 * cy[grid.yface(i, ny)] * pressure)
                    }
                }
            }
        }
        let mut p = Self {
            grid: grid.clone(),
            cx,
            cy,
            rhs,
            periodic_x: boundaries.periodic_x(),
            periodic_y: boundaries.periodic_y(),
            dirichlet,
            incompatibility: 0.0,
        };
        p.make_compatible();
        p
    }

    /// Whether the operator has the constant null space.
    pub fn is_singular(&self) -> bool {
        !self.dirichlet.iter().any(|&d| d)
    }

    /// Projects the right-hand side onto the range of a singular operator.
    pub fn make_compatible(&mut self) {
        if !self.is_singular() {
            return;
        }
        let n = self.rhs.len() as Real;
        let mean = sum(&self.rhs) / n;
        let rms = (dot(&self.rhs, &self.rhs) / n).sqrt();
        self.incompatibility = if rms > 0.0 { mean.abs() / rms } else { 0.0 };
        self.rhs.par_iter_mut().for_each(|b| *b -= mean);
    }

    /// Coefficient of the face to the left of cell (i, j) and the index of the neighbour.
    #[inline]
    fn west(&self, i: usize, j: usize) -> (Real, Option<usize>) {
        let g = &self.grid;
        let c = self.cx[g.xface(i, j)];
        if i > 0 {
            (c, Some(g.cell(i - 1, j)))
        } else if self.periodic_x {
            (c, Some(g.cell(g.nx - 1, j)))
        } else {
            (if self.dirichlet[0] { 2.0 * c } else { 0.0 }, None)
        }
    }
    #[inline]
    fn east(&self, i: usize, j: usize) -> (Real, Option<usize>) {
        let g = &self.grid;
        if i + 1 < g.nx {
            (self.cx[g.xface(i + 1, j)], Some(g.cell(i + 1, j)))
        } else if self.periodic_x {
            (self.cx[g.xface(0, j)], Some(g.cell(0, j)))
        } else {
            (if self.dirichlet[1] { 2.0 * self.cx[g.xface(g.nx, j)] } else { 0.0 }, None)
        }
    }
    #[inline]
    fn south(&self, i: usize, j: usize) -> (Real, Option<usize>) {
        let g = &self.grid;
        let c = self.cy[g.yface(i, j)];
        if j > 0 {
            (c, Some(g.cell(i, j - 1)))
        } else if self.periodic_y {
            (c, Some(g.cell(i, g.ny - 1)))
        } else {
            (if self.dirichlet[2] { 2.0 * c } else { 0.0 }, None)
        }
    }
    #[inline]
    fn north(&self, i: usize, j: usize) -> (Real, Option<usize>) {
        let g = &self.grid;
        if j + 1 < g.ny {
            (self.cy[g.yface(i, j + 1)], Some(g.cell(i, j + 1)))
        } else if self.periodic_y {
            (self.cy[g.yface(i, 0)], Some(g.cell(i, 0)))
        } else {
            (if self.dirichlet[3] { 2.0 * self.cy[g.yface(i, g.ny)] } else { 0.0 }, None)
        }
    }

    /// The five stencil entries of row (i, j): (diagonal, [(coefficient, neighbour)]).
    #[inline]
    pub fn row(&self, i: usize, j: usize) -> (Real, [(Real, Option<usize>); 4]) {
        let nb = [self.west(i, j), self.east(i, j), self.south(i, j), self.north(i, j)];
        let diag = nb.iter().map(|(c, _)| c).sum();
        (diag, nb)
    }

    /// The diagonal of the operator.
    pub fn diagonal(&self) -> Vec<Real> {
        let g = &self.grid;
        (0..g.n_cells()).into_par_iter().map(|k| self.row(k % g.nx, k / g.nx).0).collect()
    }

    /// y = A x.
    pub fn apply(&self, x: &[Real], y: &mut [Real]) {
        let nx = self.grid.nx;
        y.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                let (diag, nb) = self.row(i, j);
                let mut s = diag * x[i + j * nx];
                for (c, n) in nb {
                    if let Some(n) = n {
                        s -= c * x[n];
                    }
                }
                *out = s;
            }
        });
    }

    /// Relative residual |b − A x| / |b| (|b − Ax| if b = 0).
    pub fn relative_residual(&self, x: &[Real]) -> Real {
        let mut r = vec![0.0; x.len()];
        self.apply(x, &mut r);
        r.par_iter_mut().zip(self.rhs.par_iter()).for_each(|(r, b)| *r = b - *r);
        let nb = dot(&self.rhs, &self.rhs).sqrt();
        let nr = dot(&r, &r).sqrt();
        if nb > 0.0 {
            nr / nb
        } else {
            nr
        }
    }

    /// Shifts a solution of a singular problem to zero mean.
    pub fn fix_constant(&self, p: &mut [Real]) {
        if self.is_singular() {
            let mean = sum(p) / p.len() as Real;
            p.par_iter_mut().for_each(|x| *x -= mean);
        }
    }
}
