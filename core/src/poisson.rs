//! The pressure equation as a symmetric positive (semi-)definite 5-point (7-point in 3D)
//! system.
//!
//! `Σ_faces c_f (p_i − p_neighbour) = b_i`, the discrete form of −∇·(c∇p) = b, with
//! `c_f = Δt Σ_k θ_k w_k / h²` on each face. Walls have c = 0 (Neumann), an outflow side
//! fixes p through a ghost value (Dirichlet, `2 c_f (p_i − p_side)`), periodic sides wrap.
//! Without a Dirichlet side the constant is a null space: the right-hand side is projected
//! onto the compatible subspace and the solution shifted to zero mean.

use crate::boundary::{Boundaries, Boundary, Side};
use crate::grid::{FaceArrays, Grid, Lattice};
use crate::math::{Index, Real, AXES, DIM, SIDES};
use rayon::prelude::*;

/// A pressure problem handed to a [`crate::plugin::PressureSolver`].
#[derive(Clone, Debug)]
pub struct PoissonProblem {
    /// The grid.
    pub grid: Grid,
    /// Coefficients on the faces (entry `a` on the faces normal to axis `a`), already
    /// divided by h².
    pub c: FaceArrays,
    /// Right-hand side per cell, Dirichlet contributions included, compatible if singular.
    pub rhs: Vec<Real>,
    /// Periodic along each axis.
    pub periodic: [bool; DIM],
    /// Dirichlet sides, in the order of [`Side::ALL`] (left, right, bottom, top, back,
    /// front): whether the side fixes p.
    pub dirichlet: [bool; SIDES],
    /// |mean(b)| / rms(b) removed from a singular system (0 if nonsingular).
    pub incompatibility: Real,
    /// Whether no side of the domain fixes p (decided for the whole domain: on a rank of a
    /// decomposed run `dirichlet` has only its own block's sides).
    singular: bool,
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

/// Σ a b over cell arrays of rows of `nx` cells, by the reduction rule of
/// docs/design/mpi.md §3 ([`crate::exact::dot`]): row groups of 32 cells, their values
/// added exactly, one rounding. The same bits for any number of threads (and of ranks).
pub fn dot(a: &[Real], b: &[Real], nx: usize) -> Real {
    crate::exact::dot(a, b, nx, nx)
}

/// Σ a over a cell array of rows of `nx` cells, by the reduction rule (as [`dot`]).
pub fn sum(a: &[Real], nx: usize) -> Real {
    crate::exact::sum(a, nx, nx)
}

impl PoissonProblem {
    /// Assembles a problem from face coefficients `c` (not yet divided by h²) and the
    /// right-hand side `b`, with Dirichlet values from the outflow sides.
    pub fn new(grid: &Grid, boundaries: &Boundaries, mut c: FaceArrays, mut rhs: Vec<Real>) -> Self {
        let h2 = grid.h * grid.h;
        for a in AXES {
            c[a].iter_mut().for_each(|c| *c /= h2);
        }
        let mut dirichlet = [false; SIDES];
        let n = grid.n();
        for (k, side) in Side::ALL.iter().enumerate() {
            if let Boundary::Outflow { pressure } = boundaries.side(*side) {
                dirichlet[k] = true;
                let a = side.axis();
                let (cell_at, face_at) = if side.high() { (n[a] - 1, n[a]) } else { (0, 0) };
                for (cell, mut at) in grid.layer(Lattice::Cell, a, cell_at) {
                    at[a] = face_at;
                    rhs[cell] += 2.0 * c[a][grid.index(Lattice::face(a), at)] * pressure;
                }
            }
        }
        // every rank agrees: one whose block touches no outflow side must not think p free
        let singular = !grid.part.any(dirichlet.iter().any(|&d| d));
        let mut p = Self {
            grid: grid.clone(),
            c,
            rhs,
            periodic: boundaries.periodic_axes(),
            dirichlet,
            incompatibility: 0.0,
            singular,
        };
        p.make_compatible();
        p
    }

    /// The whole domain's problem, on every rank of a decomposed run (its coefficients and
    /// right-hand side gathered from every rank's owned nodes, its sides the domain's): for
    /// a solver that works on the whole domain (the multigrid V-cycle, so far). A copy on
    /// one rank.
    pub fn gathered(&self) -> PoissonProblem {
        let g = &self.grid;
        let part = &g.part;
        let Some((rank_grid, _)) = part.block() else {
            return self.clone();
        };
        let grid = Grid::from_cells(g.domain, g.h, g.origin);
        let mut c = FaceArrays::zeros(&grid);
        for a in AXES {
            let lattice = Lattice::face(a);
            c[a] = part.gather(lattice, g.shape(lattice), &self.c[a]);
        }
        let rhs = part.gather(Lattice::Cell, g.shape(Lattice::Cell), &self.rhs);
        // a side fixes p if it does on the rank whose block touches it
        let mut sides = self.dirichlet.map(|d| if d { 1.0 } else { 0.0 });
        part.max(&mut sides);
        Self {
            grid,
            c,
            rhs,
            periodic: rank_grid.periodic,
            dirichlet: sides.map(|d| d > 0.0),
            incompatibility: self.incompatibility,
            singular: self.singular,
        }
    }

    /// Solves with `solve` on the whole domain: on one rank the problem itself; on a rank of
    /// a decomposed run the [`PoissonProblem::gathered`] one from the gathered initial
    /// guess, the same on every rank (so are its errors), and this rank's block of the
    /// solution taken back, halo included: a direct or whole-domain solver on ranks, with
    /// the serial bits (not faster with more ranks).
    pub fn solve_whole<E>(
        &self,
        x: &mut [Real],
        solve: impl FnOnce(&PoissonProblem, &mut [Real]) -> Result<SolveStats, E>,
    ) -> Result<SolveStats, E> {
        let part = &self.grid.part;
        if part.is_whole() {
            return solve(self, x);
        }
        let whole = self.gathered();
        let shape = self.grid.shape(Lattice::Cell);
        let mut xw = part.gather(Lattice::Cell, shape, x);
        let stats = solve(&whole, &mut xw)?;
        part.scatter(Lattice::Cell, shape, &xw, x);
        Ok(stats)
    }

    /// Whether the operator has the constant null space.
    pub fn is_singular(&self) -> bool {
        self.singular
    }

    /// Projects the right-hand side onto the range of a singular operator.
    pub fn make_compatible(&mut self) {
        if !self.is_singular() {
            return;
        }
        // the domain's cells, over every rank
        let n = self.grid.domain_cells() as Real;
        let rhs = &self.rhs;
        let g = &self.grid;
        let [total, squares] = g.part.reduce(g.groups(Lattice::Cell).sums(|g| {
            let b = &rhs[g];
            [b.iter().sum(), crate::exact::lanes_dot(b, b)]
        }));
        let mean = total / n;
        let rms = (squares / n).sqrt();
        self.incompatibility = if rms > 0.0 { mean.abs() / rms } else { 0.0 };
        self.rhs.par_iter_mut().for_each(|b| *b -= mean);
    }

    /// The coefficient of the face of cell `at` on `side` and the index of the cell
    /// across it: the neighbour, the wrapped one on a periodic side, or none on the
    /// boundary (coefficient `2 c` on a Dirichlet side, 0 on a wall).
    #[inline]
    fn neighbour(&self, at: Index, side: Side) -> (Real, Option<usize>) {
        let g = &self.grid;
        let a = side.axis();
        let n = g.n()[a];
        let face = |i: usize| {
            let mut f = at;
            f[a] = i;
            self.c[a][g.index(Lattice::face(a), f)]
        };
        let cell = |i: usize| {
            let mut f = at;
            f[a] = i;
            Some(g.index(Lattice::Cell, f))
        };
        let i = at[a];
        if !side.high() {
            let c = face(i);
            if i > 0 {
                (c, cell(i - 1))
            } else if self.periodic[a] {
                (c, cell(n - 1))
            } else {
                (if self.dirichlet[side as usize] { 2.0 * c } else { 0.0 }, None)
            }
        } else if i + 1 < n {
            (face(i + 1), cell(i + 1))
        } else if self.periodic[a] {
            (face(0), cell(0))
        } else {
            (if self.dirichlet[side as usize] { 2.0 * face(n) } else { 0.0 }, None)
        }
    }

    /// The stencil entries of row `at` (five in 2D, seven in 3D): (diagonal,
    /// [(coefficient, neighbour)] in the order of [`Side::ALL`]).
    #[inline]
    pub fn row(&self, at: Index) -> (Real, [(Real, Option<usize>); SIDES]) {
        let nb = Side::ALL.map(|side| self.neighbour(at, side));
        let diag = nb.iter().map(|(c, _)| c).sum();
        (diag, nb)
    }

    /// The diagonal of the operator.
    pub fn diagonal(&self) -> Vec<Real> {
        let g = &self.grid;
        g.nodes(Lattice::Cell).map(|(_, at)| self.row(at).0).collect()
    }

    /// y = A x.
    pub fn apply(&self, x: &[Real], y: &mut [Real]) {
        let nx = self.grid.nx;
        y.par_chunks_mut(nx).enumerate().for_each(|(r, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                let (diag, nb) = self.row(self.grid.node(Lattice::Cell, i + r * nx));
                let mut s = diag * x[i + r * nx];
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
        let grid = &self.grid;
        let [bb, rr] = grid.part.reduce(grid.groups(Lattice::Cell).sums(|g| {
            let (b, r) = (&self.rhs[g.clone()], &r[g]);
            [crate::exact::lanes_dot(b, b), crate::exact::lanes_dot(r, r)]
        }));
        let (nb, nr) = (bb.sqrt(), rr.sqrt());
        if nb > 0.0 {
            nr / nb
        } else {
            nr
        }
    }

    /// Shifts a solution of a singular problem to zero mean.
    pub fn fix_constant(&self, p: &mut [Real]) {
        if self.is_singular() {
            let mean = self.grid.sum(Lattice::Cell, p) / self.grid.domain_cells() as Real;
            p.par_iter_mut().for_each(|x| *x -= mean);
        }
    }
}
