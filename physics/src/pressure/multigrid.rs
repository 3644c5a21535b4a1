//! Geometric multigrid V-cycle for the 5-point pressure operator: the `"multigrid"`
//! preconditioner of `pcg`, and the `multigrid` solver (V-cycles to tolerance).
//!
//! * Levels: 2:1 coarsening of cells while both dimensions are even and at least 4; the
//!   coarsest level (a dimension odd or ≤ 3) is solved by sparse Cholesky.
//! * Coarse operators by coefficient averaging, `A_c = ½ Pᵀ_const A P_const` (5-point, see
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
//!
//! Every update is a per-cell map and every reduction goes through the fixed-chunk
//! [`dot`]/[`sum`]: the result is the same to the bit for any number of threads.

use super::cholesky::SparseLlt;
use super::stencil::{Stencil, PARALLEL_CELLS};
use multifield_core::math::Real;
use multifield_core::plugin::PressureSolver;
use multifield_core::poisson::{dot, sum, PoissonProblem, SolveStats};
use multifield_core::registry::{params_value, ParamDoc};
use multifield_core::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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

/// The fine indices with coarse index c among their parents (padded with `usize::MAX`).
fn children(par: &[[usize; 2]]) -> Vec<[usize; 4]> {
    let mut out = vec![[usize::MAX; 4]; par.len() / 2];
    for (i, pair) in par.iter().enumerate() {
        for &c in pair {
            if !out[c].contains(&i) {
                let slot = out[c].iter().position(|&v| v == usize::MAX).expect("at most 4 children");
                out[c][slot] = i;
            }
        }
    }
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

/// A raw pointer shared by the threads of a colour pass: each writes only cells of one
/// colour and reads only cells it or no other thread writes.
#[derive(Clone, Copy)]
struct Shared(*mut Real);
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

/// Gauss–Seidel on the cells of `colour` ((i + j) mod 2) in row `j`.
///
/// # Safety
/// `x` points to `op.len()` values; no other thread writes a cell this row reads.
unsafe fn relax_row(op: &Stencil, b: &[Real], x: Shared, colour: usize, j: usize) {
    let nx = op.nx;
    let get = |m: usize| unsafe { *x.0.add(m) };
    let update = |i: usize| {
        let k = i + j * nx;
        let v = (b[k] + op.offdiag(i, j, get)) * op.inv_diag[k];
        unsafe { *x.0.add(k) = v };
    };
    ((colour + j) % 2..nx).step_by(2).for_each(update);
}

/// One colour pass over the level, rows in parallel. Smoothed levels have even sizes (see
/// [`Hierarchy`]), so the red-black colouring holds across periodic wraps too.
fn relax(op: &Stencil, b: &[Real], x: &mut [Real], colour: usize) {
    assert!(x.len() == op.len() && op.nx % 2 == 0 && op.ny % 2 == 0);
    let ptr = Shared(x.as_mut_ptr());
    // SAFETY: a row updates only its own cells of `colour`; their neighbours have the other
    // colour, which nobody writes during this pass.
    let row = |j: usize| unsafe { relax_row(op, b, ptr, colour, j) };
    if op.len() >= PARALLEL_CELLS {
        (0..op.ny).into_par_iter().with_min_len(4).for_each(row);
    } else {
        (0..op.ny).for_each(row);
    }
}

/// One level of the hierarchy with its scratch and the transfers to the next coarser one.
#[derive(Clone, Debug, Default)]
struct Level {
    op: Stencil,
    r: Vec<Real>,
    /// Right-hand side and solution of the next coarser level.
    bc: Vec<Real>,
    xc: Vec<Real>,
    /// Coarse parents along x and y of each fine column and row.
    px: Vec<[usize; 2]>,
    py: Vec<[usize; 2]>,
    /// Fine children of each coarse column and row.
    kx: Vec<[usize; 4]>,
    ky: Vec<[usize; 4]>,
    /// Interpolation weights per fine cell along x and y: (own, other) parent.
    wx: Vec<[Real; 2]>,
    wy: Vec<[Real; 2]>,
}

impl Level {
    /// Recomputes the operator-dependent interpolation weights from `op`.
    fn update_weights(&mut self) {
        let op = &self.op;
        let (nx, ny) = (op.nx, op.ny);
        let d = op.dirichlet;
        let body = |(j, (wx, wy)): (usize, (&mut [[Real; 2]], &mut [[Real; 2]]))| {
            let row = &op.ax[j * (nx + 1)..(j + 1) * (nx + 1)];
            for i in 0..nx {
                wx[i] = weights(|f| row[f], nx, i, op.periodic[0], [d[0], d[1]]);
                wy[i] = weights(|f| op.ay[i + f * nx], ny, j, op.periodic[1], [d[2], d[3]]);
            }
        };
        let rows = self.wx.par_chunks_mut(nx).zip(self.wy.par_chunks_mut(nx));
        rows.enumerate().for_each(body);
    }

    /// b_c = Pᵀ r.
    fn restrict(&mut self) {
        let (nx, ncx) = (self.op.nx, self.op.nx / 2);
        let (r, px, py, kx, ky, wx, wy) = (&self.r, &self.px, &self.py, &self.kx, &self.ky, &self.wx, &self.wy);
        let share = |pair: [usize; 2], w: [Real; 2], c: usize| {
            (if pair[0] == c { w[0] } else { 0.0 }) + (if pair[1] == c { w[1] } else { 0.0 })
        };
        let body = |(jc, row): (usize, &mut [Real])| {
            for (ic, out) in row.iter_mut().enumerate() {
                let mut s = 0.0;
                for &j in ky[jc].iter().filter(|&&j| j != usize::MAX) {
                    for &i in kx[ic].iter().filter(|&&i| i != usize::MAX) {
                        let k = i + j * nx;
                        s += share(px[i], wx[k], ic) * share(py[j], wy[k], jc) * r[k];
                    }
                }
                *out = s;
            }
        };
        if self.op.len() >= PARALLEL_CELLS {
            self.bc.par_chunks_mut(ncx).enumerate().for_each(body);
        } else {
            self.bc.chunks_mut(ncx).enumerate().for_each(body);
        }
    }

    /// x += P x_c.
    fn prolong_add(&self, x: &mut [Real]) {
        let (nx, ncx) = (self.op.nx, self.op.nx / 2);
        let (xc, px, py, wx, wy) = (&self.xc, &self.px, &self.py, &self.wx, &self.wy);
        let body = |(j, row): (usize, &mut [Real])| {
            let [js, jo] = py[j];
            let (rs, ro) = (&xc[js * ncx..(js + 1) * ncx], &xc[jo * ncx..(jo + 1) * ncx]);
            for (i, v) in row.iter_mut().enumerate() {
                let ([is, io], [ws, wo], [vs, vo]) = (px[i], wx[i + j * nx], wy[i + j * nx]);
                *v += vs * (ws * rs[is] + wo * rs[io]) + vo * (ws * ro[is] + wo * ro[io]);
            }
        };
        if self.op.len() >= PARALLEL_CELLS {
            x.par_chunks_mut(nx).enumerate().for_each(body);
        } else {
            x.chunks_mut(nx).enumerate().for_each(body);
        }
    }
}

/// The multigrid hierarchy: level operators, transfers and scratch, kept across solves
/// (only the coefficients change from one step to the next).
#[derive(Debug, Default)]
pub struct Hierarchy {
    key: Option<(usize, usize, [bool; 2], [bool; 4])>,
    levels: Vec<Level>,
    coarse: SparseLlt,
    /// Level 0 has cells with no coupling (set to 0 in the output).
    has_dead: bool,
    /// Red-black sweeps before and after the coarse correction.
    pub sweeps: usize,
}

impl Clone for Hierarchy {
    /// The hierarchy is a cache: a clone starts empty.
    fn clone(&self) -> Self {
        Self::new(self.sweeps)
    }
}

impl Hierarchy {
    /// An empty hierarchy with `sweeps` smoothing sweeps.
    pub fn new(sweeps: usize) -> Self {
        Self { sweeps, coarse: SparseLlt::sequential(), ..Self::default() }
    }

    /// Sizes (nx, ny) of the levels, finest first.
    pub fn level_sizes(&self) -> Vec<(usize, usize)> {
        self.levels.iter().map(|l| (l.op.nx, l.op.ny)).collect()
    }

    fn build(&mut self, nx: usize, ny: usize, periodic: [bool; 2], dirichlet: [bool; 4]) {
        self.levels.clear();
        let (mut nx, mut ny) = (nx, ny);
        loop {
            let mut level = Level::default();
            level.op.resize(nx, ny, periodic, dirichlet);
            let coarsen = nx % 2 == 0 && ny % 2 == 0 && nx >= 4 && ny >= 4;
            if coarsen {
                level.r = vec![0.0; nx * ny];
                level.bc = vec![0.0; nx * ny / 4];
                level.xc = vec![0.0; nx * ny / 4];
                level.px = parents(nx, periodic[0]);
                level.py = parents(ny, periodic[1]);
                level.kx = children(&level.px);
                level.ky = children(&level.py);
                level.wx = vec![[1.0, 0.0]; nx * ny];
                level.wy = vec![[1.0, 0.0]; nx * ny];
            }
            self.levels.push(level);
            if !coarsen {
                break;
            }
            nx /= 2;
            ny /= 2;
        }
        self.key = Some((self.levels[0].op.nx, self.levels[0].op.ny, periodic, dirichlet));
    }

    /// Fills the level operators for `problem` and factors the coarsest one.
    pub fn setup(&mut self, problem: &PoissonProblem) -> std::result::Result<(), String> {
        let g = &problem.grid;
        let key = (g.nx, g.ny, [problem.periodic_x, problem.periodic_y], problem.dirichlet);
        if self.key != Some(key) {
            self.build(key.0, key.1, key.2, key.3);
        }
        self.levels[0].op.assign(problem);
        self.has_dead = self.levels[0].op.diag.iter().any(|&d| d <= 0.0);
        for l in 1..self.levels.len() {
            let (fine, coarse) = self.levels.split_at_mut(l);
            fine[l - 1].update_weights();
            coarse[0].op.coarsen_from(&fine[l - 1].op);
        }
        let last = &self.levels.last().expect("at least one level").op;
        self.coarse.factor(last)
    }

    /// z = M r: one V-cycle from z = 0 (a symmetric positive definite approximation of A⁻¹).
    pub fn precondition(&mut self, r: &[Real], z: &mut [Real]) {
        cycle(&mut self.levels, &mut self.coarse, self.sweeps, r, z);
        if self.has_dead {
            let inv = &self.levels[0].op.inv_diag;
            z.par_iter_mut().zip(inv.par_iter()).for_each(|(z, &d)| {
                if d == 0.0 {
                    *z = 0.0
                }
            });
        }
    }
}

/// The V-cycle on `levels` (finest first) for A x = b, from x = 0.
fn cycle(levels: &mut [Level], coarse: &mut SparseLlt, sweeps: usize, b: &[Real], x: &mut [Real]) {
    let (level, rest) = levels.split_first_mut().expect("a level");
    if rest.is_empty() {
        x.copy_from_slice(b);
        coarse.solve(x);
        return;
    }
    x.fill(0.0);
    for _ in 0..sweeps {
        relax(&level.op, b, x, 0);
        relax(&level.op, b, x, 1);
    }
    level.op.residual(x, b, &mut level.r);
    level.restrict();
    if level.op.is_singular() {
        let mean = sum(&level.bc) / level.bc.len() as Real;
        level.bc.iter_mut().for_each(|v| *v -= mean);
    }
    cycle(rest, coarse, sweeps, &level.bc, &mut level.xc);
    level.prolong_add(x);
    for _ in 0..sweeps {
        relax(&level.op, b, x, 1);
        relax(&level.op, b, x, 0);
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
        Self { tolerance, max_iterations, smoothing_sweeps, hierarchy: Hierarchy::new(smoothing_sweeps) }
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
    fn solve(&mut self, problem: &PoissonProblem, x: &mut [Real]) -> Result<SolveStats> {
        let stats = |iterations, residual| SolveStats { iterations, residual, incompatibility: problem.incompatibility };
        let b = &problem.rhs;
        let bnorm = dot(b, b).sqrt();
        if bnorm == 0.0 {
            x.fill(0.0);
            return Ok(stats(0, 0.0));
        }
        self.hierarchy.sweeps = self.smoothing_sweeps;
        self.hierarchy.setup(problem).map_err(Error::Model)?;
        let n = x.len();
        let (mut r, mut z) = (vec![0.0; n], vec![0.0; n]);
        let mut history = vec![];
        for it in 0..=self.max_iterations {
            self.hierarchy.levels[0].op.residual(x, b, &mut r);
            if problem.is_singular() {
                let mean = sum(&r) / n as Real;
                r.par_iter_mut().for_each(|v| *v -= mean);
            }
            let rel = dot(&r, &r).sqrt() / bnorm;
            history.push(rel);
            if rel <= self.tolerance {
                return Ok(stats(it, rel));
            }
            if it == self.max_iterations || !rel.is_finite() {
                break;
            }
            self.hierarchy.precondition(&r, &mut z);
            x.par_iter_mut().zip(z.par_iter()).for_each(|(x, z)| *x += z);
        }
        Err(Error::SolverDiverged {
            solver: "multigrid".into(),
            tolerance: self.tolerance,
            iterations: history.len() - 1,
            residual: *history.last().unwrap_or(&Real::NAN),
            history: history.iter().step_by(10).map(|h| format!("{h:.2e}")).collect::<Vec<_>>().join(" "),
        })
    }
}
