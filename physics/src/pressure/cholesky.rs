//! Sparse Cholesky factorization A = L Lᵀ of the 5-point pressure operator (faer, with
//! an approximate-minimum-degree ordering).
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
use multifield_core::math::Real;
use multifield_core::plugin::PressureSolver;
use multifield_core::poisson::{dot, sum, PoissonProblem, SolveStats};
use multifield_core::registry::{params_value, ParamDoc};
use multifield_core::{Error, Result};
use serde::{Deserialize, Serialize};

const NONE: usize = usize::MAX;

/// A reusable sparse LLᵀ of a [`Stencil`]: symbolic part cached per pattern.
#[derive(Default)]
pub struct SparseLlt {
    key: Option<(usize, usize, [bool; 2])>,
    symbolic: Option<SymbolicCholesky<usize>>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<Real>,
    /// Value slot of each cell's diagonal.
    diag_slot: Vec<usize>,
    /// Value slot of each x-face coupling (NONE on a non-periodic side).
    x_slot: Vec<usize>,
    /// Value slot of each y-face coupling.
    y_slot: Vec<usize>,
    l_values: Vec<Real>,
    factor_stack: Option<MemBuffer>,
    solve_stack: Option<MemBuffer>,
    pin: Option<usize>,
    singular: bool,
    /// Cells with no coupling at all (diagonal 0): identity rows.
    dead: Vec<bool>,
    par: Option<Par>,
}

impl std::fmt::Debug for SparseLlt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLlt").field("key", &self.key).field("nnz_l", &self.l_values.len()).finish()
    }
}

impl SparseLlt {
    /// A factorization that runs on one thread (bit-identical whatever the pool size).
    pub fn sequential() -> Self {
        Self { par: Some(Par::Seq), ..Self::default() }
    }

    fn parallelism(&self) -> Par {
        self.par.unwrap_or_else(|| {
            let n = rayon::current_num_threads();
            if n > 1 {
                Par::rayon(n)
            } else {
                Par::Seq
            }
        })
    }

    /// Number of nonzeros of L (0 before the first factorization).
    pub fn factor_nonzeros(&self) -> usize {
        self.l_values.len()
    }

    fn analyze(&mut self, s: &Stencil) -> std::result::Result<(), String> {
        let (nx, ny) = (s.nx, s.ny);
        let n = nx * ny;
        let [px, py] = s.periodic;
        // lower-triangle entries (row, column) of every coupling, per column
        let mut cols: Vec<Vec<usize>> = (0..n).map(|k| vec![k]).collect();
        let mut couple = |a: usize, b: usize| {
            let (r, c) = (a.max(b), a.min(b));
            if r != c && !cols[c].contains(&r) {
                cols[c].push(r);
            }
        };
        for j in 0..ny {
            for i in 0..=nx {
                if (i > 0 && i < nx) || (px && i == 0) {
                    couple(s.west(i % nx) + j * nx, i % nx + j * nx);
                }
            }
        }
        for j in 0..=ny {
            for i in 0..nx {
                if (j > 0 && j < ny) || (py && j == 0) {
                    couple(i + s.south(j % ny) * nx, i + (j % ny) * nx);
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
        let slot = |cp: &[usize], ri: &[usize], a: usize, b: usize| {
            let (r, c) = (a.max(b), a.min(b));
            cp[c] + ri[cp[c]..cp[c + 1]].binary_search(&r).expect("entry in pattern")
        };
        self.diag_slot = (0..n).map(|k| slot(&self.col_ptr, &self.row_idx, k, k)).collect();
        self.x_slot = vec![NONE; (nx + 1) * ny];
        for j in 0..ny {
            for i in 0..nx {
                if i > 0 || px {
                    let (a, b) = (s.west(i) + j * nx, i + j * nx);
                    if a != b {
                        self.x_slot[i + j * (nx + 1)] = slot(&self.col_ptr, &self.row_idx, a, b);
                    }
                }
            }
            if px {
                self.x_slot[nx + j * (nx + 1)] = NONE; // the wrap face is counted once, at i = 0
            }
        }
        self.y_slot = vec![NONE; nx * (ny + 1)];
        for j in 0..ny {
            for i in 0..nx {
                if j > 0 || py {
                    let (a, b) = (i + s.south(j) * nx, i + j * nx);
                    if a != b {
                        self.y_slot[i + j * nx] = slot(&self.col_ptr, &self.row_idx, a, b);
                    }
                }
            }
        }
        self.values = vec![0.0; self.row_idx.len()];
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, Default::default(), Default::default())
            .map_err(|e| format!("symbolic Cholesky factorization failed: {e:?}"))?;
        self.l_values = vec![0.0; symbolic.len_val()];
        self.symbolic = Some(symbolic);
        self.factor_stack = None;
        self.solve_stack = None;
        self.key = Some((nx, ny, s.periodic));
        Ok(())
    }

    /// Factors the operator `s` (refactoring the values only when the pattern is unchanged).
    pub fn factor(&mut self, s: &Stencil) -> std::result::Result<(), String> {
        if self.key != Some((s.nx, s.ny, s.periodic)) {
            self.analyze(s)?;
        }
        let (nx, n) = (s.nx, s.len());
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
        for j in 0..s.ny {
            for i in 0..nx {
                let b = i + j * nx;
                let f = i + j * (nx + 1);
                if self.x_slot[f] != NONE {
                    let a = s.west(i) + j * nx;
                    if !off(a) && !off(b) {
                        values[self.x_slot[f]] -= s.ax[f];
                    }
                }
                let f = i + j * nx;
                if self.y_slot[f] != NONE {
                    let a = i + s.south(j) * nx;
                    if !off(a) && !off(b) {
                        values[self.y_slot[f]] -= s.ay[f];
                    }
                }
            }
        }
        let par = self.parallelism();
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
        let par = self.parallelism();
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
    fn solve(&mut self, problem: &PoissonProblem, x: &mut [Real]) -> Result<SolveStats> {
        let stats =
            |iterations, residual| SolveStats { iterations, residual, incompatibility: problem.incompatibility };
        let b = &problem.rhs;
        let bnorm = dot(b, b).sqrt();
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
            let rel = dot(&r, &r).sqrt() / bnorm;
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
