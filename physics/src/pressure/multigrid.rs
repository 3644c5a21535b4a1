//! Geometric multigrid V-cycle for the 5-point (7-point in 3D) pressure operator: the
//! `"multigrid"` preconditioner of `pcg`, and the `multigrid` solver (V-cycles to tolerance).
//!
//! * Levels: 2:1 coarsening of cells while every axis is even and at least 4; the
//!   coarsest level (an axis odd or ≤ 3) is solved by sparse Cholesky.
//! * Coarse operators by coefficient averaging, `A_c = ½ Pᵀ_const A P_const` (see
//!   [`Stencil::coarsen_from`]): walls keep zero couplings, Dirichlet ghost terms and
//!   periodic wrap faces carry over, so every level sees the boundary of the finest one.
//! * Transfers: cell-centred, operator-dependent prolongation P: bilinear (9/16, 3/16, 3/16,
//!   1/16) for constant coefficients, with each 1D weight the conductance of the path to the
//!   coarse centre so that corrections do not leak across coefficient jumps (in the spirit of
//!   Alcouffe, Brandt, Dendy & Painter 1981; Khalil & Wesseling 1992); ghost values mirror the
//!   boundary (equal at a wall, opposite at a Dirichlet side, wrapped on a periodic axis).
//!   Restriction R = Pᵀ.
//! * Smoother: red-black Gauss–Seidel, ν sweeps red→black before the coarse correction and
//!   ν sweeps black→red after (cells of one colour do not touch): the V-cycle is a symmetric
//!   operator, as conjugate gradients needs (Tatebe 1993, "The multigrid preconditioned
//!   conjugate gradient method").
//! * Pure Neumann: the restricted residual is projected to zero mean on every coarse level;
//!   the coarsest solve pins one cell and shifts to zero mean.
//! * Precision: the cycle runs in f32 (operators, weights, residuals, corrections; the
//!   coarsest solve in f64): a preconditioner need not be exact, and f32 halves the bytes
//!   moved. The outer iteration (CG in `pcg`, the residual of the `multigrid` solver) is
//!   f64, so the tolerance is met in f64. Memory traffic is kept low by fusing passes: the
//!   two colours of a sweep go in one pass over the rows, the residual is restricted row by
//!   row without being stored, and each transfer keeps one weight per axis and cell.
//!
//! Every update is a per-cell map (a sweep gives each cell the same neighbour values in any
//! blocking of the rows) and every reduction follows the rule of docs/design/mpi.md §3 (row groups added exactly; on
//! level l the groups are 32/2^l cells wide, the images of the fine ones): the result is
//! the same to the bit for any number of threads.
//!
//! The level kernels (f32 operator, sweep, transfers) are per dimension: `plane.rs` (2D:
//! the two colours fused in one pass over the rows, the residual restricted row by row) and
//! `volume.rs` (3D: colour (i + j + k) mod 2, trilinear transfers as the product of the
//! three 1D weights, 8 parents per fine cell). The rest is shared.

use super::cholesky::SparseLlt;
use super::stencil::{Stencil, PARALLEL_CELLS};
use multifield_core::exact::{reduce, row_sums, GROUP};
use multifield_core::grid::Lattice;
use multifield_core::math::{Index, Real, DIM, SIDES};
use multifield_core::plugin::PressureSolver;
use multifield_core::poisson::{PoissonProblem, SolveStats};
use multifield_core::registry::{params_value, ParamDoc};
use multifield_core::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

#[cfg(feature = "dim2")]
mod blocks;
#[cfg(feature = "dim2")]
mod plane;
#[cfg(feature = "dim2")]
use plane::{sweep, Level, Op32};
#[cfg(feature = "dim3")]
mod volume;
#[cfg(feature = "dim3")]
use volume::{sweep, Level, Op32};

/// Along an axis of `n` cells, the two coarse parents of fine index i: its own aggregate
/// i/2 and the nearer neighbouring one (itself on a non-periodic side).
fn parents(n: usize, periodic: bool) -> Vec<[usize; 2]> {
    let nc = (n / 2) as isize;
    (0..n)
        .map(|i| {
            let me = (i / 2) as isize;
            let other = if i % 2 == 0 { me - 1 } else { me + 1 };
            let other = if (0..nc).contains(&other) {
                other
            } else if periodic {
                other.rem_euclid(nc)
            } else {
                me
            };
            [me as usize, other as usize]
        })
        .collect()
}

/// For each coarse index c, the four (fine index, parent slot) with `parents[i][slot] == c`.
fn children(par: &[[usize; 2]]) -> Vec<[(usize, usize); 4]> {
    let mut out = vec![[(0, 0); 4]; par.len() / 2];
    let mut count = vec![0; out.len()];
    for (i, pair) in par.iter().enumerate() {
        for (slot, &c) in pair.iter().enumerate() {
            out[c][count[c]] = (i, slot);
            count[c] += 1;
        }
    }
    debug_assert!(count.iter().all(|&n| n == 4));
    out
}

/// Interpolation weights (own parent, other parent) of fine index i along a line of face
/// couplings `a(f)`, f = 0..=n: each weight is the conductance of the path from the coarse
/// centre to the fine centre (the own centre sits on face i or i+1, half a face away; the
/// other one a face and a half away). Constant coefficients give the bilinear 3/4, 1/4; a
/// weak face between a cell and a parent cuts that parent off, so no correction leaks
/// across a coefficient jump. Sides: wall (1, 0); Dirichlet (½, 0), the ghost being −own.
#[inline]
fn weights(a: impl Fn(usize) -> Real, n: usize, i: usize, periodic: bool, dirichlet: [bool; 2]) -> [Real; 2] {
    let odd = i % 2 == 1;
    let outside = if odd { i + 1 >= n } else { i == 0 };
    if outside && !periodic {
        return if dirichlet[usize::from(odd)] { [0.5, 0.0] } else { [1.0, 0.0] };
    }
    let face = |f: isize| a(if periodic { f.rem_euclid(n as isize) as usize } else { f as usize });
    let i = i as isize;
    let (own, full, half) = if odd { (i, i + 1, i + 2) } else { (i + 1, i, i - 1) };
    let g_own = 2.0 * face(own);
    let (ga, gb) = (face(full), 2.0 * face(half));
    let g_other = if ga > 0.0 && gb > 0.0 { ga * gb / (ga + gb) } else { 0.0 };
    let g = g_own + g_other;
    if g > 0.0 {
        [g_own / g, g_other / g]
    } else {
        [1.0, 0.0]
    }
}

/// Precision of the V-cycle: the preconditioner need not be exact, and f32 halves the bytes
/// it moves; the outer iteration (CG, or the residual of the stationary solver) stays f64.
pub(crate) type F = f32;

/// Values per chunk of the deterministic f32 sums (as [`sum`]).
pub(crate) const CHUNK: usize = 2048;

/// Σ a of f32 values in f64 over a level of rows of `nx` cells, by the reduction rule with
/// row groups `width` cells wide (the same bits for any thread count).
fn sum32(a: &[F], nx: usize, width: usize) -> Real {
    reduce(&row_sums(a.len(), nx, nx, width, |g| [a[g].iter().map(|&v| Real::from(v)).sum::<Real>()]))[0]
}

/// dst = src rounded to f32, in parallel for big arrays.
pub(crate) fn to_f32(src: &[Real], dst: &mut Vec<F>) {
    dst.resize(src.len(), 0.0);
    let body = |(d, s): (&mut [F], &[Real])| d.iter_mut().zip(s).for_each(|(d, &s)| *d = s as F);
    if src.len() >= PARALLEL_CELLS {
        dst.par_chunks_mut(CHUNK).zip(src.par_chunks(CHUNK)).for_each(body);
    } else {
        body((dst, src));
    }
}

/// Whether fine index i is on the outer side of a non-periodic axis of n cells (its other
/// parent would lie outside: its weight is 0).
#[inline]
fn outside(n: usize, i: usize, periodic: bool) -> bool {
    !periodic && if i % 2 == 1 { i + 1 >= n } else { i == 0 }
}

/// The multigrid hierarchy: level operators, transfers and scratch, kept across solves
/// (only the coefficients change from one step to the next).
#[derive(Debug, Default)]
pub struct Hierarchy {
    key: Option<(Index, [bool; DIM], [bool; SIDES])>,
    /// Operators, finest first.
    ops: Vec<Stencil>,
    cycle: Cycle,
    /// The levels on a rank's blocks, finest first (a decomposed domain: [`blocks`]); the
    /// levels above are then the domain's below them.
    #[cfg(feature = "dim2")]
    blocks: Vec<blocks::BlockLevel>,
}

/// What a V-cycle writes: transfers and scratch of every level but the coarsest, and the
/// coarsest level's factorization.
#[derive(Debug, Default)]
struct Cycle {
    levels: Vec<Level>,
    /// The smoothed levels' operators in f32 (all but the coarsest).
    ops: Vec<Op32>,
    coarse: SparseLlt,
    /// Right-hand side and solution of the coarsest level in f64.
    coarse_x: Vec<Real>,
    /// The finest level's right-hand side and solution in f32.
    b: Vec<F>,
    x: Vec<F>,
    /// The finest level has cells with no coupling (set to 0 in the output).
    has_dead: bool,
    sweeps: usize,
}

impl Clone for Hierarchy {
    /// The hierarchy is a cache: a clone starts empty.
    fn clone(&self) -> Self {
        Self::new(self.cycle.sweeps)
    }
}

impl Hierarchy {
    /// An empty hierarchy with `sweeps` smoothing sweeps.
    pub fn new(sweeps: usize) -> Self {
        Self { cycle: Cycle { sweeps, coarse: SparseLlt::default(), ..Cycle::default() }, ..Self::default() }
    }

    /// Red-black sweeps before and after each coarse correction.
    pub fn set_sweeps(&mut self, sweeps: usize) {
        self.cycle.sweeps = sweeps;
    }

    /// Cells along each axis of the levels, finest first.
    pub fn level_sizes(&self) -> Vec<Index> {
        self.ops.iter().map(|op| op.n()).collect()
    }

    fn build(&mut self, n: Index, periodic: [bool; DIM], dirichlet: [bool; SIDES]) {
        self.ops.clear();
        self.cycle.levels.clear();
        self.cycle.ops.clear();
        let mut n = n;
        loop {
            let mut op = Stencil::default();
            op.resize(n, periodic, dirichlet);
            self.ops.push(op);
            if !n.iter().all(|&k| k % 2 == 0 && k >= 4) {
                break;
            }
            self.cycle.ops.push(Op32::default());
            self.cycle.levels.push(Level::new(n, periodic));
            n = n.map(|k| k / 2);
        }
        self.key = Some((self.ops[0].n(), periodic, dirichlet));
    }

    /// Fills the level operators for `problem` and factors the coarsest one.
    pub fn setup(&mut self, problem: &PoissonProblem) -> std::result::Result<(), String> {
        let g = &problem.grid;
        let key = (g.n(), problem.periodic, problem.dirichlet);
        if self.key != Some(key) {
            self.build(key.0, key.1, key.2);
        }
        self.ops[0].assign(problem);
        self.cycle.has_dead = self.ops[0].diag.iter().any(|&d| d <= 0.0);
        self.coarsen_below(0)
    }

    /// The transfers from level `first` down and the operators below it, each from the one
    /// above, and the coarsest level factored.
    fn coarsen_below(&mut self, first: usize) -> std::result::Result<(), String> {
        for l in first + 1..self.ops.len() {
            let (fine, coarse) = self.ops.split_at_mut(l);
            self.cycle.levels[l - 1].update_weights(&fine[l - 1]);
            self.cycle.ops[l - 1].assign(&fine[l - 1]);
            coarse[0].coarsen_from(&fine[l - 1]);
        }
        self.cycle.coarse.factor(self.ops.last().expect("at least one level"))
    }

    /// z = M r: one V-cycle from z = 0 (a symmetric positive definite approximation of A⁻¹).
    pub fn precondition(&mut self, r: &[Real], z: &mut [Real]) {
        self.cycle.run(&self.ops, r, z);
    }

    /// The finest operator and the preconditioner in f32 (`z = M r`, one V-cycle from 0),
    /// to use side by side. Cells with no coupling come out 0: the last sweep sets them to
    /// (b + 0)·0.
    pub(crate) fn split32(&mut self) -> (&Stencil, impl FnMut(&[F], &mut [F]) + '_) {
        let (ops, cycle) = (&self.ops, &mut self.cycle);
        (&ops[0], move |r: &[F], z: &mut [F]| cycle.run32(ops, r, z))
    }

    /// The finest operator and the preconditioner, to use side by side.
    pub fn split(&mut self) -> (&Stencil, impl FnMut(&[Real], &mut [Real]) + '_) {
        let (ops, cycle) = (&self.ops, &mut self.cycle);
        (&ops[0], move |r: &[Real], z: &mut [Real]| cycle.run(ops, r, z))
    }
}

impl Cycle {
    fn run(&mut self, ops: &[Stencil], r: &[Real], z: &mut [Real]) {
        let n = r.len();
        let (mut b, mut x) = (std::mem::take(&mut self.b), std::mem::take(&mut self.x));
        to_f32(r, &mut b);
        x.resize(n, 0.0);
        self.run32(ops, &b, &mut x);
        let inv = &ops[0].inv_diag;
        let dead = self.has_dead;
        let body = |((z, x), d): ((&mut [Real], &[F]), &[Real])| {
            for ((z, &x), &d) in z.iter_mut().zip(x).zip(d) {
                *z = if dead && d == 0.0 { 0.0 } else { Real::from(x) };
            }
        };
        if n >= PARALLEL_CELLS {
            z.par_chunks_mut(CHUNK).zip(x.par_chunks(CHUNK)).zip(inv.par_chunks(CHUNK)).for_each(body);
        } else {
            body(((z, &x), inv));
        }
        (self.b, self.x) = (b, x);
    }

    /// The V-cycle in f32 on the finest level: x = M b.
    fn run32(&mut self, ops: &[Stencil], b: &[F], x: &mut [F]) {
        cycle(
            &self.ops,
            &mut self.levels,
            &mut self.coarse,
            &mut self.coarse_x,
            ops[0].is_singular(),
            self.sweeps,
            GROUP,
            b,
            x,
        );
    }
}

/// The V-cycle on `ops` (finest first) for A x = b, from x = 0.
#[allow(clippy::too_many_arguments)]
fn cycle(
    ops: &[Op32],
    levels: &mut [Level],
    coarse: &mut SparseLlt,
    coarse_x: &mut Vec<Real>,
    singular: bool,
    sweeps: usize,
    width: usize,
    b: &[F],
    x: &mut [F],
) {
    let Some((level, rest)) = levels.split_first_mut() else {
        coarse_x.clear();
        coarse_x.extend(b.iter().map(|&v| Real::from(v)));
        coarse.solve(coarse_x);
        x.iter_mut().zip(coarse_x.iter()).for_each(|(x, &v)| *x = v as F);
        return;
    };
    let op = &ops[0];
    sweep(op, b, x, 0, true);
    for _ in 1..sweeps {
        sweep(op, b, x, 0, false);
    }
    level.restrict_residual(op, x, b);
    if singular {
        // the coarse level (nx/2 cells along x: levels halve every axis): row groups half
        // as wide as this level's
        let mean = (sum32(&level.bc, op.nx() / 2, width / 2) / level.bc.len() as Real) as F;
        level.bc.iter_mut().for_each(|v| *v -= mean);
    }
    cycle(&ops[1..], rest, coarse, coarse_x, singular, sweeps, width / 2, &level.bc, &mut level.xc);
    level.prolong_add(x);
    for _ in 0..sweeps {
        sweep(op, b, x, 1, false);
    }
}

/// Multigrid V-cycles to tolerance: p ← p + M (b − A p).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Multigrid {
    /// Relative residual |b − Ap|/|b| to reach.
    #[serde(default = "default_tol")]
    pub tolerance: Real,
    /// Cap on V-cycles.
    #[serde(default = "default_cycles")]
    pub max_iterations: usize,
    /// Red-black Gauss–Seidel sweeps before and after each coarse correction.
    #[serde(default = "default_sweeps")]
    pub smoothing_sweeps: usize,
    #[serde(skip)]
    hierarchy: Hierarchy,
    /// The operator on a rank's block (a decomposed domain), kept across solves.
    #[cfg(feature = "dim2")]
    #[serde(skip)]
    stencil: Stencil,
}

fn default_tol() -> Real {
    1e-9
}
fn default_cycles() -> usize {
    200
}
/// Default red-black sweeps per side of the V-cycle.
pub fn default_sweeps() -> usize {
    2
}

impl Multigrid {
    /// A solver with the given tolerance, cycle cap and smoothing sweeps.
    pub fn new(tolerance: Real, max_iterations: usize, smoothing_sweeps: usize) -> Self {
        Self {
            tolerance,
            max_iterations,
            smoothing_sweeps,
            hierarchy: Hierarchy::new(smoothing_sweeps),
            #[cfg(feature = "dim2")]
            stencil: Stencil::default(),
        }
    }

    /// Checks the parameters.
    pub fn validate(&mut self) -> std::result::Result<(), String> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(format!("tolerance {}: must lie in (0, 1), e.g. 1e-9", self.tolerance));
        }
        if self.max_iterations == 0 {
            return Err("max_iterations must be at least 1".into());
        }
        if self.smoothing_sweeps == 0 || self.smoothing_sweeps > 16 {
            return Err(format!("smoothing_sweeps {}: use 1 to 16, e.g. 2", self.smoothing_sweeps));
        }
        self.hierarchy = Hierarchy::new(self.smoothing_sweeps);
        Ok(())
    }
}

multifield_core::register!(
    Pressure,
    "multigrid",
    Multigrid,
    "geometric multigrid V-cycles (red-black Gauss–Seidel, averaged coarse coefficients) to tolerance",
    &[
        ParamDoc { name: "tolerance", unit: "-", default: "1e-9", doc: "relative residual |b − Ap|/|b| to reach" },
        ParamDoc {
            name: "max_iterations",
            unit: "-",
            default: "200",
            doc: "cap on V-cycles; beyond it the run fails with the residual history"
        },
        ParamDoc {
            name: "smoothing_sweeps",
            unit: "-",
            default: "2",
            doc: "red-black Gauss–Seidel sweeps before and after each coarse correction"
        },
    ]
);

impl PressureSolver for Multigrid {
    fn model(&self) -> &'static str {
        "multigrid"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // (the V-cycle's levels on the blocks while their cuts are even, as the PCG's)
        true
    }
    fn solve(&mut self, problem: &PoissonProblem, x: &mut [Real]) -> Result<SolveStats> {
        let (tol, cap) = (self.tolerance, self.max_iterations);
        self.hierarchy.set_sweeps(self.smoothing_sweeps);
        #[cfg(feature = "dim2")]
        if !problem.grid.part.is_whole() {
            self.stencil.assign(problem);
            if self.hierarchy.setup_on_block(problem, &mut self.stencil).map_err(Error::Model)? {
                let (h, op) = (&mut self.hierarchy, &self.stencil);
                let (mut r32, mut z32) = (Vec::new(), Vec::new());
                let precondition = |r: &[Real], z: &mut [Real]| {
                    to_f32(r, &mut r32);
                    z32.resize(r.len(), 0.0);
                    h.precondition_block(&r32, &mut z32);
                    // cells with no coupling come out 0, as `Cycle::run` leaves them
                    for ((z, &v), &d) in z.iter_mut().zip(&z32).zip(&op.inv_diag) {
                        *z = if d == 0.0 { 0.0 } else { Real::from(v) };
                    }
                };
                return v_cycles(problem, x, tol, cap, op, precondition);
            }
        }
        problem.solve_whole(x, |problem, x| {
            self.hierarchy.setup(problem).map_err(Error::Model)?;
            let (op, precondition) = self.hierarchy.split();
            v_cycles(problem, x, tol, cap, op, precondition)
        })
    }
}

/// V-cycles to tolerance on `problem`'s grid (a whole domain, or a rank's block: x's halo
/// exchanged before the residual, the sums over every rank's owned cells): p ← p + M (b −
/// A p) with the operator `op` and the V-cycle `precondition` (z = M r).
fn v_cycles(
    problem: &PoissonProblem,
    x: &mut [Real],
    tolerance: Real,
    max_iterations: usize,
    op: &Stencil,
    mut precondition: impl FnMut(&[Real], &mut [Real]),
) -> Result<SolveStats> {
    let stats = |iterations, residual| SolveStats { iterations, residual, incompatibility: problem.incompatibility };
    let grid = &problem.grid;
    let b = &problem.rhs;
    let bnorm = grid.dot(Lattice::Cell, b, b).sqrt();
    if bnorm == 0.0 {
        x.fill(0.0);
        return Ok(stats(0, 0.0));
    }
    let n = x.len();
    let (mut r, mut z) = (vec![0.0; n], vec![0.0; n]);
    let mut history = vec![];
    for it in 0..=max_iterations {
        grid.exchange(&mut [(Lattice::Cell, x)]);
        op.residual(x, b, &mut r);
        if problem.is_singular() {
            let mean = grid.sum(Lattice::Cell, &r) / grid.domain_cells() as Real;
            r.par_iter_mut().for_each(|v| *v -= mean);
        }
        let rel = grid.dot(Lattice::Cell, &r, &r).sqrt() / bnorm;
        history.push(rel);
        if rel <= tolerance {
            return Ok(stats(it, rel));
        }
        if it == max_iterations || !rel.is_finite() {
            break;
        }
        precondition(&r, &mut z);
        x.par_iter_mut().zip(z.par_iter()).for_each(|(x, z)| *x += z);
    }
    Err(Error::SolverDiverged {
        solver: "multigrid".into(),
        tolerance,
        iterations: history.len() - 1,
        residual: *history.last().unwrap_or(&Real::NAN),
        history: history.iter().step_by(10).map(|h| format!("{h:.2e}")).collect::<Vec<_>>().join(" "),
    })
}
