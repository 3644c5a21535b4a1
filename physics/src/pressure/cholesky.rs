//! Sparse Cholesky factorization A = L Lᵀ of the 5-point (7-point in 3D) pressure
//! operator (faer, with an approximate-minimum-degree ordering).
//!
//! The factor fills in: about n (8 + 2 log₂ n) nonzeros for n cells in 2D, but about
//! 2 n^{3/2} in 3D ([`factor_bytes`]); a grid whose factor would not fit in the memory
//! available is refused with the number before anything is allocated. The factorization
//! and the solves run on one thread: faer's parallel supernodal kernels sum in an order
//! that depends on the thread count (at 512² in 2D, 178,880 of the 262,144 values changed
//! between 1 and 2 threads; at 32³, 32,553 of 32,768), and on this 2-core machine they
//! bought nothing measurable (1024², factor and solve: 3.2–3.6 s on 1 thread, 3.8–3.9 s on
//! 2, under load).
//!
//! The symbolic factorization depends only on the grid size and the periodic axes, so it is
//! kept while they do not change; each solve refactors the values. A singular (pure-Neumann)
//! operator is made definite by pinning one cell to zero (deleting its row and column);
//! the solution is then shifted to zero mean. Cells cut off from every neighbour (all face
//! coefficients zero, e.g. inside a rigid body) get the identity row and pressure 0.
//! The warm start enters through iterative refinement: p ← p + A⁻¹(b − A p), repeated
//! until the relative residual reaches the tolerance.

use super::stencil::Stencil;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LltRef, SymbolicCholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use multifield_core::grid::{Grid, Lattice};
use multifield_core::limits::{bytes_text, MemoryLimit};
use multifield_core::math::{Index, Real, Vector, AXES, DIM};
use multifield_core::plugin::PressureSolver;
use multifield_core::poisson::{dot, PoissonProblem, SolveStats};
use multifield_core::registry::{params_value, ParamDoc};
use multifield_core::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

const NONE: usize = usize::MAX;

/// Bytes of a factor of `nonzeros` entries: a value and a row index each.
const BYTES_PER_NONZERO: u64 = 16;

/// The estimated bytes of the sparse Cholesky factor of the operator on `n` cells (its
/// values and row indices), before any factorization: n (8 + 2 log₂ n) nonzeros in 2D (as
/// the memory estimate of a case counts them), 2 n^{3/2} in 3D (faer's AMD ordering on
/// the 7-point operator of a cube: 1.50, 1.59, 1.79, 1.64, 1.83 n^{3/2} at 16³, 24³,
/// 32³, 40³, 48³; nested dissection would reach n^{4/3}, but AMD grows faster).
pub fn factor_bytes(n: Index) -> u64 {
    let cells = n.iter().fold(1u64, |a, &k| a.saturating_mul(k as u64));
    #[cfg(feature = "dim2")]
    let nonzeros = {
        let log = 64 - cells.max(2).leading_zeros() as u64;
        cells.saturating_mul(8 + 2 * log)
    };
    #[cfg(feature = "dim3")]
    let nonzeros = (2.0 * cells as Real * (cells as Real).sqrt()).min(u64::MAX as Real) as u64;
    nonzeros.saturating_mul(BYTES_PER_NONZERO)
}

/// Cells as "64 × 64 × 64".
fn times(n: Index) -> String {
    n.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(" × ")
}

/// The refusal of a factor of `bytes` bytes (`what`: estimated or counted) above `limit`.
fn refuse(n: Index, bytes: u64, what: &str, limit: &MemoryLimit) -> String {
    format!(
        "cholesky: the factor of the pressure operator on {} cells needs about {} ({what}), more than \
         {}: use the solver pcg (its default multigrid preconditioner needs a few arrays per cell) \
         or a coarser grid",
        times(n),
        bytes_text(bytes),
        limit.describe()
    )
}

/// A reusable sparse LLᵀ of a [`Stencil`]: symbolic part cached per pattern.
#[derive(Default)]
pub struct SparseLlt {
    key: Option<(Index, [bool; DIM])>,
    symbolic: Option<SymbolicCholesky<usize>>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<Real>,
    /// Value slot of each cell's diagonal.
    diag_slot: Vec<usize>,
    /// Value slot of the coupling across each face, per axis (NONE on a non-periodic side).
    slots: [Vec<usize>; DIM],
    l_values: Vec<Real>,
    factor_stack: Option<MemBuffer>,
    solve_stack: Option<MemBuffer>,
    pin: Option<usize>,
    singular: bool,
    /// Cells with no coupling at all (diagonal 0): identity rows.
    dead: Vec<bool>,
    /// The memory the factor may use (bytes); `None`: [`MemoryLimit::resolve`]'s.
    memory_limit: Option<u64>,
}

impl std::fmt::Debug for SparseLlt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLlt").field("key", &self.key).field("nnz_l", &self.l_values.len()).finish()
    }
}

impl SparseLlt {
    /// Caps the memory of the factor at `bytes` (instead of the machine's available memory
    /// or `MULTIFIELD_MAX_MEMORY`).
    pub fn set_memory_limit(&mut self, bytes: u64) {
        self.memory_limit = Some(bytes);
    }

    fn limit(&self) -> std::result::Result<MemoryLimit, String> {
        match self.memory_limit {
            Some(bytes) => MemoryLimit::resolve(Some(bytes)),
            None => MemoryLimit::resolve(None),
        }
    }

    /// Number of nonzeros of L (0 before the first factorization).
    pub fn factor_nonzeros(&self) -> usize {
        self.l_values.len()
    }

    fn analyze(&mut self, s: &Stencil) -> std::result::Result<(), String> {
        let shape = s.n();
        let n = s.len();
        let limit = self.limit()?;
        let estimate = factor_bytes(shape);
        if estimate > limit.bytes {
            return Err(refuse(shape, estimate, "estimated", &limit));
        }
        // lower-triangle entries (row, column) of every coupling, per column: each cell
        // with the cell before it along each axis (wrapped on a periodic axis)
        let mut cols: Vec<Vec<usize>> = (0..n).map(|k| vec![k]).collect();
        for a in AXES {
            for (b, at) in cells(shape) {
                if let Some(o) = before(shape, s.periodic, a, at) {
                    let (r, c) = (o.max(b), o.min(b));
                    if r != c && !cols[c].contains(&r) {
                        cols[c].push(r);
                    }
                }
            }
        }
        self.col_ptr.clear();
        self.row_idx.clear();
        self.col_ptr.push(0);
        for c in cols.iter_mut() {
            c.sort_unstable();
            self.row_idx.extend_from_slice(c);
            self.col_ptr.push(self.row_idx.len());
        }
        drop(cols);
        let slot = |cp: &[usize], ri: &[usize], a: usize, b: usize| {
            let (r, c) = (a.max(b), a.min(b));
            cp[c] + ri[cp[c]..cp[c + 1]].binary_search(&r).expect("entry in pattern")
        };
        self.diag_slot = (0..n).map(|k| slot(&self.col_ptr, &self.row_idx, k, k)).collect();
        for a in AXES {
            // the low face of each cell; the wrap face is counted once, at 0
            let mut slots = vec![NONE; s.coupling(a).len()];
            for (b, at) in cells(shape) {
                if let Some(o) = before(shape, s.periodic, a, at) {
                    if o != b {
                        slots[face(shape, a, at)] = slot(&self.col_ptr, &self.row_idx, o, b);
                    }
                }
            }
            self.slots[a] = slots;
        }
        self.values = vec![0.0; self.row_idx.len()];
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, Default::default(), Default::default())
            .map_err(|e| format!("symbolic Cholesky factorization failed: {e:?}"))?;
        let bytes = (symbolic.len_val() as u64).saturating_mul(BYTES_PER_NONZERO);
        if bytes > limit.bytes {
            self.key = None;
            return Err(refuse(shape, bytes, &format!("{} nonzeros", symbolic.len_val()), &limit));
        }
        self.l_values = vec![0.0; symbolic.len_val()];
        self.symbolic = Some(symbolic);
        self.factor_stack = None;
        self.solve_stack = None;
        self.key = Some((shape, s.periodic));
        Ok(())
    }

    /// Factors the operator `s` (refactoring the values only when the pattern is unchanged).
    pub fn factor(&mut self, s: &Stencil) -> std::result::Result<(), String> {
        if self.key != Some((s.n(), s.periodic)) {
            self.analyze(s)?;
        }
        let (shape, n) = (s.n(), s.len());
        self.singular = s.is_singular();
        self.dead.clear();
        self.dead.extend(s.diag.iter().map(|&d| d <= 0.0));
        self.pin = if self.singular { (0..n).find(|&k| !self.dead[k]) } else { None };
        let off = |k: usize| self.dead[k] || self.pin == Some(k);
        let values = &mut self.values;
        values.fill(0.0);
        for k in 0..n {
            values[self.diag_slot[k]] = if off(k) { 1.0 } else { s.diag[k] };
        }
        for (b, at) in cells(shape) {
            for a in AXES {
                let f = face(shape, a, at);
                if self.slots[a][f] != NONE {
                    let o = before(shape, s.periodic, a, at).expect("a coupled face");
                    if !off(o) && !off(b) {
                        values[self.slots[a][f]] -= s.coupling(a)[f];
                    }
                }
            }
        }
        let par = Par::Seq; // bit-identical whatever the pool (see the module's note)
        let symbolic = self.symbolic.as_ref().expect("analyzed");
        let stack = self.factor_stack.get_or_insert_with(|| {
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<Real>(par, Default::default()))
        });
        let a = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx),
            &self.values,
        );
        symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                par,
                MemStack::new(stack),
                Default::default(),
            )
            .map_err(|e| {
                format!(
                    "Cholesky factorization failed ({e:?}): the operator is not positive definite \
                     (a region cut off from every Dirichlet side other than the whole domain?)"
                )
            })?;
        Ok(())
    }

    /// Solves A x = b in place (b in, x out). For a singular operator b is projected to zero
    /// mean first and x shifted to zero mean after, which keeps the solve symmetric.
    pub fn solve(&mut self, x: &mut [Real]) {
        let n = x.len();
        if self.singular {
            let mean = sum(x) / n as Real;
            x.iter_mut().for_each(|v| *v -= mean);
        }
        for (v, &d) in x.iter_mut().zip(&self.dead) {
            if d {
                *v = 0.0;
            }
        }
        if let Some(p) = self.pin {
            x[p] = 0.0;
        }
        let par = Par::Seq; // bit-identical whatever the pool (see the module's note)
        let symbolic = self.symbolic.as_ref().expect("factored");
        let stack =
            self.solve_stack.get_or_insert_with(|| MemBuffer::new(symbolic.solve_in_place_scratch::<Real>(1, par)));
        LltRef::new(symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, 1),
            par,
            MemStack::new(stack),
        );
        if self.singular {
            let mean = sum(x) / n as Real;
            x.iter_mut().for_each(|v| *v -= mean);
        }
    }
}

/// Σ a in fixed chunks of 2048, the chunks' sums added in order: the same bits for any
/// number of threads. The factored system is solved whole on one process (the coarsest
/// multigrid level is replicated on every rank, docs/design/mpi.md §4), so this sum needs
/// no reduction rule.
fn sum(a: &[Real]) -> Real {
    let partial: Vec<Real> = a.par_chunks(2048).map(|x| x.iter().sum::<Real>()).collect();
    partial.iter().sum()
}

/// The grid of `n` cells (its spacing and origin unused): its lattices' storage order is
/// the operator's.
fn grid(n: Index) -> Grid {
    Grid::from_cells(n, 1.0, Vector::zeros())
}

/// The cells of an `n` grid in storage order (x fastest), with their positions.
fn cells(n: Index) -> impl Iterator<Item = (usize, Index)> {
    grid(n).nodes(Lattice::Cell)
}

/// Index of the face below cell `at` along axis `a`.
#[inline]
fn face(n: Index, a: usize, at: Index) -> usize {
    grid(n).index(Lattice::face(a), at)
}

/// The cell before `at` along axis `a` (wrapped on a periodic axis), if any.
#[inline]
fn before(n: Index, periodic: [bool; DIM], a: usize, mut at: Index) -> Option<usize> {
    if at[a] > 0 {
        at[a] -= 1;
    } else if periodic[a] {
        at[a] = n[a] - 1;
    } else {
        return None;
    }
    Some(grid(n).index(Lattice::Cell, at))
}

/// Direct solve by sparse Cholesky factorization.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cholesky {
    /// Relative residual |b − Ap|/|b| to reach (iterative refinement steps until then).
    #[serde(default = "default_tol")]
    pub tolerance: Real,
    /// Cap on the refinement steps.
    #[serde(default = "default_steps")]
    pub max_iterations: usize,
    #[serde(skip)]
    stencil: Stencil,
    #[serde(skip)]
    llt: SparseLlt,
}

impl Clone for Cholesky {
    /// The factorization is a cache: a clone starts without it.
    fn clone(&self) -> Self {
        Self::new(self.tolerance, self.max_iterations)
    }
}

fn default_tol() -> Real {
    1e-9
}
fn default_steps() -> usize {
    5
}

impl Cholesky {
    /// A solver with the given tolerance and cap on refinement steps.
    pub fn new(tolerance: Real, max_iterations: usize) -> Self {
        Self { tolerance, max_iterations, stencil: Stencil::default(), llt: SparseLlt::default() }
    }

    /// Checks the parameters.
    pub fn validate(&mut self) -> std::result::Result<(), String> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(format!("tolerance {}: must lie in (0, 1), e.g. 1e-9", self.tolerance));
        }
        if self.max_iterations == 0 {
            return Err("max_iterations must be at least 1".into());
        }
        Ok(())
    }

    /// Nonzeros of the last factor L.
    pub fn factor_nonzeros(&self) -> usize {
        self.llt.factor_nonzeros()
    }

    /// Caps the memory of the factor at `bytes` (see [`SparseLlt::set_memory_limit`]).
    pub fn set_memory_limit(&mut self, bytes: u64) {
        self.llt.set_memory_limit(bytes);
    }
}

multifield_core::register!(
    Pressure,
    "cholesky",
    Cholesky,
    "sparse Cholesky LLᵀ (faer, AMD ordering; symbolic part reused while the grid is fixed)",
    &[
        ParamDoc { name: "tolerance", unit: "-", default: "1e-9", doc: "relative residual |b − Ap|/|b| to reach" },
        ParamDoc {
            name: "max_iterations",
            unit: "-",
            default: "5",
            doc: "cap on iterative-refinement steps; beyond it the run fails with the residual history"
        },
    ]
);

impl PressureSolver for Cholesky {
    fn model(&self) -> &'static str {
        "cholesky"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn decomposed(&self) -> bool {
        // (the factorization of the whole domain's gathered problem, on every rank)
        true
    }
    fn solve(&mut self, problem: &PoissonProblem, x: &mut [Real]) -> Result<SolveStats> {
        problem.solve_whole(x, |problem, x| self.solve_on(problem, x))
    }
}

impl Cholesky {
    /// [`PressureSolver::solve`] on a whole domain.
    fn solve_on(&mut self, problem: &PoissonProblem, x: &mut [Real]) -> Result<SolveStats> {
        let stats =
            |iterations, residual| SolveStats { iterations, residual, incompatibility: problem.incompatibility };
        let b = &problem.rhs;
        let nx = problem.grid.nx;
        let bnorm = dot(b, b, nx).sqrt();
        if bnorm == 0.0 {
            x.fill(0.0);
            return Ok(stats(0, 0.0));
        }
        self.stencil.assign(problem);
        self.llt.factor(&self.stencil).map_err(Error::Model)?;
        let mut r = vec![0.0; x.len()];
        let mut history = vec![];
        for it in 0..=self.max_iterations {
            self.stencil.residual(x, b, &mut r);
            let rel = dot(&r, &r, nx).sqrt() / bnorm;
            history.push(rel);
            if rel <= self.tolerance {
                problem.fix_constant(x);
                return Ok(stats(it, rel));
            }
            if it == self.max_iterations {
                break;
            }
            self.llt.solve(&mut r);
            x.iter_mut().zip(&r).for_each(|(x, d)| *x += d);
        }
        Err(Error::SolverDiverged {
            solver: "cholesky".into(),
            tolerance: self.tolerance,
            iterations: history.len() - 1,
            residual: *history.last().unwrap_or(&Real::NAN),
            history: history.iter().map(|h| format!("{h:.2e}")).collect::<Vec<_>>().join(" "),
        })
    }
}
