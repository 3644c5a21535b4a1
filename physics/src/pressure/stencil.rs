//! The 5-point pressure operator stored per cell, shared by the multigrid levels and the
//! sparse Cholesky solver.
//!
//! Row (i, j): `d_ij p_ij − Σ_faces a_f p_neighbour = b_ij` with `d = Σ a_f + e_ij`.
//! `ax[i + j (nx+1)]` couples cells (i−1, j) and (i, j); the faces i = 0 and i = nx hold
//! the wrap coupling on a periodic axis and zero otherwise (walls and Dirichlet sides have
//! no neighbour). `e` holds the Dirichlet ghost terms `2 c_f`. Storing the boundary this
//! way makes every coarse level inherit the same treatment by plain averaging.

use multifield_core::math::Real;
use multifield_core::poisson::PoissonProblem;
use rayon::prelude::*;

/// Rows below this many cells are processed on one thread (the result is the same).
pub(crate) const PARALLEL_CELLS: usize = 16_384;

/// a · b with eight partial sums (vectorisable; a fixed order, so deterministic).
#[inline]
pub(crate) fn dot_lanes(a: &[Real], b: &[Real]) -> Real {
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: Real = ca.remainder().iter().zip(cb.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += x[l] * y[l];
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])) + tail
}

/// A 5-point operator on an `nx × ny` cell grid.
#[derive(Clone, Debug, Default)]
pub struct Stencil {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Periodic along (x, y).
    pub periodic: [bool; 2],
    /// Dirichlet sides (left, right, bottom, top).
    pub dirichlet: [bool; 4],
    /// Couplings across x-faces, `(nx + 1) × ny`.
    pub ax: Vec<Real>,
    /// Couplings across y-faces, `nx × (ny + 1)`.
    pub ay: Vec<Real>,
    /// Dirichlet ghost terms per cell.
    pub extra: Vec<Real>,
    /// Diagonal per cell.
    pub diag: Vec<Real>,
    /// 1 / diagonal, or 0 where a cell is cut off from everything (diagonal 0).
    pub inv_diag: Vec<Real>,
}

impl Stencil {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether constants are in the null space (no Dirichlet side).
    pub fn is_singular(&self) -> bool {
        !self.dirichlet.iter().any(|&d| d)
    }

    /// Resizes the arrays for an `nx × ny` grid (no reallocation when the size is unchanged).
    pub fn resize(&mut self, nx: usize, ny: usize, periodic: [bool; 2], dirichlet: [bool; 4]) {
        self.nx = nx;
        self.ny = ny;
        self.periodic = periodic;
        self.dirichlet = dirichlet;
        self.ax.resize((nx + 1) * ny, 0.0);
        self.ay.resize(nx * (ny + 1), 0.0);
        self.extra.resize(nx * ny, 0.0);
        self.diag.resize(nx * ny, 0.0);
        self.inv_diag.resize(nx * ny, 0.0);
    }

    /// Fills the stencil from a pressure problem (same rows as [`PoissonProblem::row`]).
    pub fn assign(&mut self, p: &PoissonProblem) {
        let (nx, ny) = (p.grid.nx, p.grid.ny);
        self.resize(nx, ny, p.periodic, p.dirichlet);
        let [px, py] = self.periodic;
        let d = p.dirichlet;
        self.ax.par_chunks_mut(nx + 1).enumerate().for_each(|(j, row)| {
            let src = &p.c.u[j * (nx + 1)..(j + 1) * (nx + 1)];
            row.copy_from_slice(src);
            row[0] = if px { src[0] } else { 0.0 };
            row[nx] = if px { src[0] } else { 0.0 };
        });
        self.ay.copy_from_slice(&p.c.v);
        for i in 0..nx {
            self.ay[i] = if py { p.c.v[i] } else { 0.0 };
            self.ay[i + ny * nx] = if py { p.c.v[i] } else { 0.0 };
        }
        self.extra.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            row.fill(0.0);
            if !px {
                if d[0] {
                    row[0] += 2.0 * p.c.u[j * (nx + 1)];
                }
                if d[1] {
                    row[nx - 1] += 2.0 * p.c.u[nx + j * (nx + 1)];
                }
            }
            if !py {
                for (i, e) in row.iter_mut().enumerate() {
                    if d[2] && j == 0 {
                        *e += 2.0 * p.c.v[i];
                    }
                    if d[3] && j == ny - 1 {
                        *e += 2.0 * p.c.v[i + ny * nx];
                    }
                }
            }
        });
        self.update_diagonal();
    }

    /// Fills this stencil as the 2:1 coarsening of `fine` (both dimensions even): a coarse
    /// face couples with the mean of the two fine faces it covers, a coarse Dirichlet term is
    /// half the sum of the fine ones; this is ½ Pᵀ A P for piecewise-constant P, which keeps
    /// the scale of Pᵀ (sum) restriction and every boundary condition of the fine level.
    pub fn coarsen_from(&mut self, fine: &Stencil) {
        let (nx, ny) = (fine.nx / 2, fine.ny / 2);
        self.resize(nx, ny, fine.periodic, fine.dirichlet);
        let fnx = fine.nx;
        self.ax.par_chunks_mut(nx + 1).enumerate().for_each(|(j, row)| {
            let (r0, r1) = (2 * j * (fnx + 1), (2 * j + 1) * (fnx + 1));
            for (i, a) in row.iter_mut().enumerate() {
                *a = 0.5 * (fine.ax[r0 + 2 * i] + fine.ax[r1 + 2 * i]);
            }
        });
        self.ay.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let r = 2 * j * fnx;
            for (i, a) in row.iter_mut().enumerate() {
                *a = 0.5 * (fine.ay[r + 2 * i] + fine.ay[r + 2 * i + 1]);
            }
        });
        self.extra.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let (r0, r1) = (2 * j * fnx, (2 * j + 1) * fnx);
            for (i, e) in row.iter_mut().enumerate() {
                let f = &fine.extra;
                *e = 0.5 * ((f[r0 + 2 * i] + f[r0 + 2 * i + 1]) + (f[r1 + 2 * i] + f[r1 + 2 * i + 1]));
            }
        });
        self.update_diagonal();
    }

    fn update_diagonal(&mut self) {
        let (nx, ax, ay, extra) = (self.nx, &self.ax, &self.ay, &self.extra);
        self.diag.par_chunks_mut(nx).zip(self.inv_diag.par_chunks_mut(nx)).enumerate().for_each(|(j, (d, inv))| {
            for i in 0..nx {
                let s = ax[i + j * (nx + 1)]
                    + ax[i + 1 + j * (nx + 1)]
                    + ay[i + j * nx]
                    + ay[i + (j + 1) * nx]
                    + extra[i + j * nx];
                d[i] = s;
                inv[i] = if s > 0.0 { 1.0 / s } else { 0.0 };
            }
        });
    }

    /// Index of the west neighbour of column `i` (itself when there is none; its coupling is 0).
    #[inline(always)]
    pub fn west(&self, i: usize) -> usize {
        previous(i, self.nx, self.periodic[0])
    }
    /// Index of the east neighbour of column `i`.
    #[inline(always)]
    pub fn east(&self, i: usize) -> usize {
        next(i, self.nx, self.periodic[0])
    }
    /// Row below row `j` (itself when there is none).
    #[inline(always)]
    pub fn south(&self, j: usize) -> usize {
        previous(j, self.ny, self.periodic[1])
    }
    /// Row above row `j`.
    #[inline(always)]
    pub fn north(&self, j: usize) -> usize {
        next(j, self.ny, self.periodic[1])
    }

    /// out\[i\] = Σ_faces a_f x_neighbour for the cells of row `j`.
    #[inline]
    pub fn offdiag_row(&self, j: usize, x: &[Real], out: &mut [Real]) {
        let nx = self.nx;
        let row = j * nx;
        let (s, n) = (self.south(j) * nx, self.north(j) * nx);
        let aw = &self.ax[j * (nx + 1)..(j + 1) * (nx + 1)];
        let (a_s, a_n) = (&self.ay[row..row + nx], &self.ay[row + nx..row + 2 * nx]);
        let (xc, xs, xn) = (&x[row..row + nx], &x[s..s + nx], &x[n..n + nx]);
        let out = &mut out[..nx];
        for (o, (((a_s, a_n), xs), xn)) in out.iter_mut().zip(a_s.iter().zip(a_n).zip(xs).zip(xn)) {
            *o = a_s * xs + a_n * xn;
        }
        for (o, (a, x)) in out[1..].iter_mut().zip(aw[1..nx].iter().zip(&xc[..nx - 1])) {
            *o += a * x;
        }
        for (o, (a, x)) in out[..nx - 1].iter_mut().zip(aw[1..nx].iter().zip(&xc[1..])) {
            *o += a * x;
        }
        out[0] += aw[0] * xc[self.west(0)];
        out[nx - 1] += aw[nx] * xc[self.east(nx - 1)];
    }

    /// r = b − A x.
    pub fn residual(&self, x: &[Real], b: &[Real], r: &mut [Real]) {
        let nx = self.nx;
        let body = |(j, row): (usize, &mut [Real])| {
            self.offdiag_row(j, x, row);
            let k = j * nx;
            for (((r, b), d), x) in row.iter_mut().zip(&b[k..k + nx]).zip(&self.diag[k..k + nx]).zip(&x[k..k + nx]) {
                *r += b - d * x;
            }
        };
        if self.len() >= PARALLEL_CELLS {
            r.par_chunks_mut(nx).enumerate().for_each(body);
        } else {
            r.chunks_mut(nx).enumerate().for_each(body);
        }
    }

    /// y = A x, and returns x · y (per-row partial sums added in row order: the same bits
    /// for any number of threads).
    pub fn apply_dot(&self, x: &[Real], y: &mut [Real]) -> Real {
        let nx = self.nx;
        let no_extra = self.dirichlet.iter().all(|&d| !d);
        let body = |(j, row): (usize, &mut [Real])| {
            self.offdiag_row(j, x, row);
            let k = j * nx;
            let x = &x[k..k + nx];
            if no_extra {
                // the diagonal from the couplings, added as in `update_diagonal` (the same
                // bits without the Dirichlet terms): one array less to read
                let (aw, ae) = (&self.ax[k + j..k + j + nx], &self.ax[k + j + 1..k + j + 1 + nx]);
                let (a_s, a_n) = (&self.ay[k..k + nx], &self.ay[k + nx..k + 2 * nx]);
                for (((y, x), (aw, ae)), (a_s, a_n)) in
                    row.iter_mut().zip(x).zip(aw.iter().zip(ae)).zip(a_s.iter().zip(a_n))
                {
                    *y = (aw + ae + a_s + a_n) * x - *y;
                }
            } else {
                for ((y, d), x) in row.iter_mut().zip(&self.diag[k..k + nx]).zip(x) {
                    *y = d * x - *y;
                }
            }
            dot_lanes(row, x)
        };
        let partial: Vec<Real> = if self.len() >= PARALLEL_CELLS {
            y.par_chunks_mut(nx).enumerate().map(body).collect()
        } else {
            y.chunks_mut(nx).enumerate().map(body).collect()
        };
        partial.iter().sum()
    }

    /// y = A x.
    pub fn apply(&self, x: &[Real], y: &mut [Real]) {
        let nx = self.nx;
        let body = |(j, row): (usize, &mut [Real])| {
            self.offdiag_row(j, x, row);
            let k = j * nx;
            for ((y, d), x) in row.iter_mut().zip(&self.diag[k..k + nx]).zip(&x[k..k + nx]) {
                *y = d * x - *y;
            }
        };
        if self.len() >= PARALLEL_CELLS {
            y.par_chunks_mut(nx).enumerate().for_each(body);
        } else {
            y.chunks_mut(nx).enumerate().for_each(body);
        }
    }
}

/// The index before `k` along an axis of `n` cells: `k − 1`, wrapped to `n − 1` on a periodic
/// axis, and `k` itself at a wall (where the operator's coupling is 0).
#[inline(always)]
pub(crate) fn previous(k: usize, n: usize, periodic: bool) -> usize {
    if k > 0 {
        k - 1
    } else if periodic {
        n - 1
    } else {
        k
    }
}

/// The index after `k` along an axis of `n` cells (see [`previous`]).
#[inline(always)]
pub(crate) fn next(k: usize, n: usize, periodic: bool) -> usize {
    if k + 1 < n {
        k + 1
    } else if periodic {
        0
    } else {
        k
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::boundary::{Boundaries, Boundary};
    use multifield_core::grid::{FaceArrays, Grid};
    use multifield_core::math::Vector;

    /// The stored stencil applies exactly the operator of `PoissonProblem` for walls,
    /// Dirichlet sides and periodic axes.
    #[test]
    fn stencil_matches_poisson_problem() {
        let cases = [
            Boundaries::default(),
            Boundaries { left: Boundary::Outflow { pressure: 1.0 }, ..Boundaries::default() },
            Boundaries {
                left: Boundary::Periodic,
                right: Boundary::Periodic,
                top: Boundary::Outflow { pressure: 0.0 },
                ..Boundaries::default()
            },
            Boundaries {
                left: Boundary::Periodic,
                right: Boundary::Periodic,
                bottom: Boundary::Periodic,
                top: Boundary::Periodic,
            },
        ];
        for bc in cases {
            let (nx, ny) = (7, 5);
            let g = Grid::new(nx, ny, 0.1, Vector::zeros());
            let cx: Vec<Real> = (0..g.n_xfaces()).map(|k| 1.0 + (k % 7) as Real * 0.3).collect();
            let cy: Vec<Real> = (0..g.n_yfaces()).map(|k| 2.0 + (k % 5) as Real * 0.7).collect();
            let prob = PoissonProblem::new(&g, &bc, FaceArrays { u: cx, v: cy }, vec![1.0; g.n_cells()]);
            let mut s = Stencil::default();
            s.assign(&prob);
            let x: Vec<Real> = (0..g.n_cells()).map(|k| ((k * 37) % 11) as Real - 3.0).collect();
            let (mut y0, mut y1) = (vec![0.0; x.len()], vec![0.0; x.len()]);
            prob.apply(&x, &mut y0);
            s.apply(&x, &mut y1);
            let err = y0.iter().zip(&y1).map(|(a, b)| (a - b).abs()).fold(0.0, Real::max);
            assert!(err < 1e-12, "{bc:?}: {err}");
        }
    }
}
