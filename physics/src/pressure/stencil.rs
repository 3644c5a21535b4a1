//! The 5-point (7-point in 3D) pressure operator stored per cell, shared by the multigrid
//! levels and the sparse Cholesky solver.
//!
//! Row (i, j): `d_ij p_ij − Σ_faces a_f p_neighbour = b_ij` with `d = Σ a_f + e_ij`.
//! `ax[i + j (nx+1)]` couples cells (i−1, j) and (i, j); the faces i = 0 and i = nx hold
//! the wrap coupling on a periodic axis and zero otherwise (walls and Dirichlet sides have
//! no neighbour). `e` holds the Dirichlet ghost terms `2 c_f`. Storing the boundary this
//! way makes every coarse level inherit the same treatment by plain averaging.
//!
//! The kernels go line by line: a line is the cells of one (j) in 2D, of one (j, k) in 3D,
//! along x (line r = j + ny k). In 3D the z neighbours are added after the 2D terms of a
//! row, so the 2D compile keeps its expression trees.

use multifield_core::exact::{lanes_dot, reduce, row_groups, Sums, GROUP};
use multifield_core::grid::Lattice;
use multifield_core::math::{Index, Real, DIM, SIDES};
use multifield_core::part::{Part, RowGroups};
use multifield_core::poisson::PoissonProblem;
use rayon::prelude::*;

/// Rows below this many cells are processed on one thread (the result is the same).
pub(crate) const PARALLEL_CELLS: usize = 16_384;

/// A 5-point (7-point) operator on an `nx × ny (× nz)` cell grid.
#[derive(Clone, Debug, Default)]
pub struct Stencil {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Cells along z.
    #[cfg(feature = "dim3")]
    pub nz: usize,
    /// Periodic along each axis.
    pub periodic: [bool; DIM],
    /// Dirichlet sides (left, right, bottom, top, back, front).
    pub dirichlet: [bool; SIDES],
    /// Couplings across x-faces, `(nx + 1) × ny (× nz)`.
    pub ax: Vec<Real>,
    /// Couplings across y-faces, `nx × (ny + 1) (× nz)`.
    pub ay: Vec<Real>,
    /// Couplings across z-faces, `nx × ny × (nz + 1)`.
    #[cfg(feature = "dim3")]
    pub az: Vec<Real>,
    /// Dirichlet ghost terms per cell.
    pub extra: Vec<Real>,
    /// Diagonal per cell.
    pub diag: Vec<Real>,
    /// 1 / diagonal, or 0 where a cell is cut off from everything (diagonal 0).
    pub inv_diag: Vec<Real>,
    /// On a rank's block of a decomposed domain ([`Stencil::assign`] from its problem): its
    /// part and owned cells, over which [`Stencil::apply_dot`] sums. `None`: every cell.
    pub owned: Option<(Part, RowGroups)>,
}

impl Stencil {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.nx * self.lines()
    }

    /// Cells along each axis.
    pub fn n(&self) -> Index {
        #[cfg(feature = "dim2")]
        return [self.nx, self.ny];
        #[cfg(feature = "dim3")]
        return [self.nx, self.ny, self.nz];
    }

    /// Number of lines of cells along x (ny, or ny nz in 3D).
    #[inline(always)]
    pub fn lines(&self) -> usize {
        #[cfg(feature = "dim2")]
        return self.ny;
        #[cfg(feature = "dim3")]
        return self.ny * self.nz;
    }

    /// The couplings across the faces normal to `axis`.
    #[inline(always)]
    pub fn coupling(&self, axis: usize) -> &[Real] {
        match axis {
            0 => &self.ax,
            1 => &self.ay,
            #[cfg(feature = "dim3")]
            2 => &self.az,
            _ => unreachable!("axis {axis} of a {DIM}D stencil"),
        }
    }

    /// Index of the first y-face below line `r` (the faces above it follow `nx` later).
    #[inline(always)]
    fn yrow(&self, r: usize) -> usize {
        #[cfg(feature = "dim2")]
        return r * self.nx;
        #[cfg(feature = "dim3")]
        return self.nx * (r + r / self.ny);
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether constants are in the null space (no Dirichlet side).
    pub fn is_singular(&self) -> bool {
        !self.dirichlet.iter().any(|&d| d)
    }

    /// Resizes the arrays for an `n` grid (no reallocation when the size is unchanged).
    pub fn resize(&mut self, n: Index, periodic: [bool; DIM], dirichlet: [bool; SIDES]) {
        let (nx, ny) = (n[0], n[1]);
        self.nx = nx;
        self.ny = ny;
        self.periodic = periodic;
        self.dirichlet = dirichlet;
        #[cfg(feature = "dim2")]
        let nz = 1;
        #[cfg(feature = "dim3")]
        let nz = n[2];
        #[cfg(feature = "dim3")]
        {
            self.nz = nz;
            self.az.resize(nx * ny * (nz + 1), 0.0);
        }
        self.ax.resize((nx + 1) * ny * nz, 0.0);
        self.ay.resize(nx * (ny + 1) * nz, 0.0);
        self.extra.resize(nx * ny * nz, 0.0);
        self.diag.resize(nx * ny * nz, 0.0);
        self.inv_diag.resize(nx * ny * nz, 0.0);
    }

    /// Fills the stencil from a pressure problem (same rows as [`PoissonProblem::row`]).
    pub fn assign(&mut self, p: &PoissonProblem) {
        self.resize(p.grid.n(), p.periodic, p.dirichlet);
        self.owned = (!p.grid.part.is_whole()).then(|| (p.grid.part.clone(), p.grid.groups(Lattice::Cell)));
        #[cfg(feature = "dim2")]
        self.assign_couplings(p);
        #[cfg(feature = "dim3")]
        self.assign_couplings3(p);
        self.update_diagonal();
    }

    /// The couplings and Dirichlet terms of [`Stencil::assign`] in 2D.
    #[cfg(feature = "dim2")]
    fn assign_couplings(&mut self, p: &PoissonProblem) {
        let (nx, ny) = (p.grid.nx, p.grid.ny);
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
    }

    /// The couplings and Dirichlet terms of [`Stencil::assign`] in 3D: the faces of each
    /// axis copied, its end faces holding the wrap coupling (periodic) or 0; each cell's
    /// Dirichlet terms added in the order of the sides.
    #[cfg(feature = "dim3")]
    fn assign_couplings3(&mut self, p: &PoissonProblem) {
        let (nx, ny, nz) = (self.nx, self.ny, self.nz);
        let [px, py, pz] = self.periodic;
        let d = p.dirichlet;
        let c = &p.c;
        self.ax.par_chunks_mut(nx + 1).enumerate().for_each(|(r, row)| {
            let src = &c.u[r * (nx + 1)..(r + 1) * (nx + 1)];
            row.copy_from_slice(src);
            row[0] = if px { src[0] } else { 0.0 };
            row[nx] = if px { src[0] } else { 0.0 };
        });
        self.ay.par_chunks_mut(nx * (ny + 1)).enumerate().for_each(|(k, plane)| {
            let src = &c.v[k * nx * (ny + 1)..(k + 1) * nx * (ny + 1)];
            plane.copy_from_slice(src);
            for i in 0..nx {
                plane[i] = if py { src[i] } else { 0.0 };
                plane[i + ny * nx] = if py { src[i] } else { 0.0 };
            }
        });
        let plane = nx * ny;
        self.az.copy_from_slice(&c.w);
        for q in 0..plane {
            self.az[q] = if pz { c.w[q] } else { 0.0 };
            self.az[q + nz * plane] = if pz { c.w[q] } else { 0.0 };
        }
        self.extra.par_chunks_mut(nx).enumerate().for_each(|(r, row)| {
            let (j, k) = (r % ny, r / ny);
            row.fill(0.0);
            if !px {
                if d[0] {
                    row[0] += 2.0 * c.u[r * (nx + 1)];
                }
                if d[1] {
                    row[nx - 1] += 2.0 * c.u[nx + r * (nx + 1)];
                }
            }
            for (i, e) in row.iter_mut().enumerate() {
                if !py {
                    if d[2] && j == 0 {
                        *e += 2.0 * c.v[i + k * nx * (ny + 1)];
                    }
                    if d[3] && j == ny - 1 {
                        *e += 2.0 * c.v[i + nx * (ny + k * (ny + 1))];
                    }
                }
                if !pz {
                    if d[4] && k == 0 {
                        *e += 2.0 * c.w[i + nx * j];
                    }
                    if d[5] && k == nz - 1 {
                        *e += 2.0 * c.w[i + nx * (j + ny * nz)];
                    }
                }
            }
        });
    }

    /// Fills this stencil as the 2:1 coarsening of `fine` (both dimensions even): a coarse
    /// face couples with the mean of the two fine faces it covers, a coarse Dirichlet term is
    /// half the sum of the fine ones; this is ½ Pᵀ A P for piecewise-constant P, which keeps
    /// the scale of Pᵀ (sum) restriction and every boundary condition of the fine level.
    ///
    /// In 3D a coarse face covers four fine ones and couples with half their sum (twice
    /// their mean), a coarse Dirichlet term is half the sum of its eight children's: again
    /// ½ Pᵀ A P.
    pub fn coarsen_from(&mut self, fine: &Stencil) {
        self.resize(fine.n().map(|k| k / 2), fine.periodic, fine.dirichlet);
        #[cfg(feature = "dim3")]
        return self.coarsen_from3(fine);
        #[cfg(feature = "dim2")]
        self.coarsen_from2(fine);
    }

    #[cfg(feature = "dim2")]
    fn coarsen_from2(&mut self, fine: &Stencil) {
        let nx = self.nx;
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

    #[cfg(feature = "dim3")]
    fn coarsen_from3(&mut self, fine: &Stencil) {
        let (nx, ny) = (self.nx, self.ny);
        let (fnx, fny) = (fine.nx, fine.ny);
        // fine indices of the x-, y- and z-faces and cells at (i, j, k)
        let fx = |i: usize, j: usize, k: usize| i + (fnx + 1) * (j + fny * k);
        let fy = |i: usize, j: usize, k: usize| i + fnx * (j + (fny + 1) * k);
        let fc = |i: usize, j: usize, k: usize| i + fnx * (j + fny * k);
        self.ax.par_chunks_mut(nx + 1).enumerate().for_each(|(r, row)| {
            let (j, k) = (2 * (r % ny), 2 * (r / ny));
            let f = &fine.ax;
            for (i, a) in row.iter_mut().enumerate() {
                let i = 2 * i;
                *a = 0.5 * ((f[fx(i, j, k)] + f[fx(i, j + 1, k)]) + (f[fx(i, j, k + 1)] + f[fx(i, j + 1, k + 1)]));
            }
        });
        self.ay.par_chunks_mut(nx).enumerate().for_each(|(q, row)| {
            let (j, k) = (2 * (q % (ny + 1)), 2 * (q / (ny + 1)));
            let f = &fine.ay;
            for (i, a) in row.iter_mut().enumerate() {
                let i = 2 * i;
                *a = 0.5 * ((f[fy(i, j, k)] + f[fy(i + 1, j, k)]) + (f[fy(i, j, k + 1)] + f[fy(i + 1, j, k + 1)]));
            }
        });
        self.az.par_chunks_mut(nx).enumerate().for_each(|(q, row)| {
            let (j, k) = (2 * (q % ny), 2 * (q / ny));
            let f = &fine.az;
            for (i, a) in row.iter_mut().enumerate() {
                let i = 2 * i;
                *a = 0.5 * ((f[fc(i, j, k)] + f[fc(i + 1, j, k)]) + (f[fc(i, j + 1, k)] + f[fc(i + 1, j + 1, k)]));
            }
        });
        self.extra.par_chunks_mut(nx).enumerate().for_each(|(r, row)| {
            let (j, k) = (2 * (r % ny), 2 * (r / ny));
            let f = &fine.extra;
            for (i, e) in row.iter_mut().enumerate() {
                let i = 2 * i;
                let plane =
                    |k: usize| (f[fc(i, j, k)] + f[fc(i + 1, j, k)]) + (f[fc(i, j + 1, k)] + f[fc(i + 1, j + 1, k)]);
                *e = 0.5 * (plane(k) + plane(k + 1));
            }
        });
        self.update_diagonal();
    }

    pub(crate) fn update_diagonal(&mut self) {
        let (nx, ax, ay, extra) = (self.nx, &self.ax, &self.ay, &self.extra);
        #[cfg(feature = "dim3")]
        let (ny, az) = (self.ny, &self.az);
        self.diag.par_chunks_mut(nx).zip(self.inv_diag.par_chunks_mut(nx)).enumerate().for_each(|(j, (d, inv))| {
            // j: the line (j + ny k in 3D)
            #[cfg(feature = "dim2")]
            let yr = j * nx;
            #[cfg(feature = "dim3")]
            let yr = nx * (j + j / ny);
            for i in 0..nx {
                let s = ax[i + j * (nx + 1)] + ax[i + 1 + j * (nx + 1)] + ay[i + yr] + ay[i + yr + nx];
                #[cfg(feature = "dim3")]
                let s = s + az[i + j * nx] + az[i + (j + ny) * nx];
                let s = s + extra[i + j * nx];
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
    /// Plane behind plane `k` (itself when there is none).
    #[cfg(feature = "dim3")]
    #[inline(always)]
    pub fn back(&self, k: usize) -> usize {
        previous(k, self.nz, self.periodic[2])
    }
    /// Plane in front of plane `k`.
    #[cfg(feature = "dim3")]
    #[inline(always)]
    pub fn front(&self, k: usize) -> usize {
        next(k, self.nz, self.periodic[2])
    }
    /// The (j, k) of line `r` (k = 0 in 2D).
    #[inline(always)]
    pub fn line(&self, r: usize) -> (usize, usize) {
        #[cfg(feature = "dim2")]
        return (r, 0);
        #[cfg(feature = "dim3")]
        return (r % self.ny, r / self.ny);
    }

    /// out\[i\] = Σ_faces a_f x_neighbour for the cells of line `r` (row j = r in 2D).
    #[inline]
    pub fn offdiag_row(&self, r: usize, x: &[Real], out: &mut [Real]) {
        let nx = self.nx;
        let row = r * nx;
        let (j, k) = self.line(r);
        let ny = self.ny;
        let (s, n) = ((self.south(j) + ny * k) * nx, (self.north(j) + ny * k) * nx);
        let aw = &self.ax[r * (nx + 1)..(r + 1) * (nx + 1)];
        let yr = self.yrow(r);
        let (a_s, a_n) = (&self.ay[yr..yr + nx], &self.ay[yr + nx..yr + 2 * nx]);
        let (xc, xs, xn) = (&x[row..row + nx], &x[s..s + nx], &x[n..n + nx]);
        let out = &mut out[..nx];
        for (o, (((a_s, a_n), xs), xn)) in out.iter_mut().zip(a_s.iter().zip(a_n).zip(xs).zip(xn)) {
            *o = a_s * xs + a_n * xn;
        }
        // every cell adds its west term before its east term (the first cell's west wrap
        // too): a rank's cell next to a cut along x then adds as the serial one does
        out[0] += aw[0] * xc[self.west(0)];
        for (o, (a, x)) in out[1..].iter_mut().zip(aw[1..nx].iter().zip(&xc[..nx - 1])) {
            *o += a * x;
        }
        for (o, (a, x)) in out[..nx - 1].iter_mut().zip(aw[1..nx].iter().zip(&xc[1..])) {
            *o += a * x;
        }
        out[nx - 1] += aw[nx] * xc[self.east(nx - 1)];
        #[cfg(feature = "dim3")]
        {
            let (b, f) = ((j + ny * self.back(k)) * nx, (j + ny * self.front(k)) * nx);
            let (a_b, a_f) = (&self.az[row..row + nx], &self.az[row + nx * ny..row + nx * ny + nx]);
            let (xb, xf) = (&x[b..b + nx], &x[f..f + nx]);
            for (o, ((a_b, a_f), (xb, xf))) in out.iter_mut().zip(a_b.iter().zip(a_f).zip(xb.iter().zip(xf))) {
                *o += a_b * xb + a_f * xf;
            }
        }
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

    /// y = A x, and returns x · y by the reduction rule (row groups of 32 cells in
    /// [`lanes_dot`] order, added exactly: the same bits for any number of threads).
    pub fn apply_dot(&self, x: &[Real], y: &mut [Real]) -> Real {
        let nx = self.nx;
        let no_extra = self.dirichlet.iter().all(|&d| !d);
        let body = |sums: &mut Sums<1>, (j, row): (usize, &mut [Real])| {
            self.offdiag_row(j, x, row);
            let k = j * nx;
            let x = &x[k..k + nx];
            if no_extra {
                // the diagonal from the couplings, added as in `update_diagonal` (the same
                // bits without the Dirichlet terms): one array less to read
                let (aw, ae) = (&self.ax[k + j..k + j + nx], &self.ax[k + j + 1..k + j + 1 + nx]);
                let yr = self.yrow(j);
                let (a_s, a_n) = (&self.ay[yr..yr + nx], &self.ay[yr + nx..yr + 2 * nx]);
                #[cfg(feature = "dim2")]
                for (((y, x), (aw, ae)), (a_s, a_n)) in
                    row.iter_mut().zip(x).zip(aw.iter().zip(ae)).zip(a_s.iter().zip(a_n))
                {
                    *y = (aw + ae + a_s + a_n) * x - *y;
                }
                #[cfg(feature = "dim3")]
                {
                    let ny = self.ny;
                    let (a_b, a_f) = (&self.az[k..k + nx], &self.az[k + nx * ny..k + nx * ny + nx]);
                    for ((((y, x), (aw, ae)), (a_s, a_n)), (a_b, a_f)) in
                        row.iter_mut().zip(x).zip(aw.iter().zip(ae)).zip(a_s.iter().zip(a_n)).zip(a_b.iter().zip(a_f))
                    {
                        *y = (aw + ae + a_s + a_n + a_b + a_f) * x - *y;
                    }
                }
            } else {
                for ((y, d), x) in row.iter_mut().zip(&self.diag[k..k + nx]).zip(x) {
                    *y = d * x - *y;
                }
            }
            match &self.owned {
                Some((_, groups)) => {
                    for g in groups.of_row(j) {
                        sums.add([lanes_dot(&row[g.clone()], &x[g])]);
                    }
                }
                None => {
                    for g in row_groups(nx, nx, GROUP) {
                        sums.add([lanes_dot(&row[g.clone()], &x[g])]);
                    }
                }
            }
        };
        let sums = if self.len() >= PARALLEL_CELLS {
            *y.par_chunks_mut(nx)
                .enumerate()
                .fold(Sums::boxed, |mut sums, item| {
                    body(&mut sums, item);
                    sums
                })
                .reduce(Sums::boxed, Sums::merge_boxed)
        } else {
            let mut sums = Sums::new();
            for item in y.chunks_mut(nx).enumerate() {
                body(&mut sums, item);
            }
            sums
        };
        match &self.owned {
            Some((part, _)) => part.reduce(sums)[0],
            None => reduce(&sums)[0],
        }
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

#[cfg(all(test, feature = "dim2"))]
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
