//! The level kernels of the V-cycle in 3D: the f32 operator, red-black Gauss–Seidel with
//! colour (i + j + k) mod 2, and the trilinear operator-dependent transfers (each weight the
//! product of the three 1D weights of [`super::weights`], so 8 parents per fine cell).
//!
//! Every kernel goes by lines along x (line r = j + ny k) and is a per-cell map or a sum in
//! a fixed order: the result is the same to the bit for any number of threads.

use super::{children, outside, parents, to_f32, weights, F};
use crate::pressure::stencil::{next, previous, Stencil, PARALLEL_CELLS};
use multifield_core::math::Index;
use rayon::prelude::*;

/// A level operator in f32 (from the f64 [`Stencil`]): couplings per axis, diagonal,
/// 1/diagonal.
#[derive(Clone, Debug, Default)]
pub(super) struct Op32 {
    n: Index,
    periodic: [bool; 3],
    a: [Vec<F>; 3],
    diag: Vec<F>,
    inv: Vec<F>,
}

/// The neighbour lines and face offsets of line r: cells `r nx + i`; x-faces from
/// `r (nx + 1)`; y-faces below from `ys`, above `ys + nx`; z-faces behind from `r nx`, in
/// front `(r + ny) nx`; the lines south, north, back, front (the line itself at a wall,
/// where the coupling is 0).
#[derive(Clone, Copy)]
struct Line {
    cells: usize,
    xf: usize,
    ys: usize,
    zb: usize,
    zf: usize,
    south: usize,
    north: usize,
    back: usize,
    front: usize,
    /// The colour of cell i is (i + parity) mod 2.
    parity: usize,
}

impl Op32 {
    pub(super) fn assign(&mut self, op: &Stencil) {
        (self.n, self.periodic) = (op.n(), op.periodic);
        for a in 0..3 {
            to_f32(op.coupling(a), &mut self.a[a]);
        }
        to_f32(&op.diag, &mut self.diag);
        to_f32(&op.inv_diag, &mut self.inv);
    }

    fn len(&self) -> usize {
        self.n.iter().product()
    }

    /// Cells along x (the row length of the reductions).
    pub(super) fn nx(&self) -> usize {
        self.n[0]
    }

    fn lines(&self) -> usize {
        self.n[1] * self.n[2]
    }

    #[inline(always)]
    fn line(&self, r: usize) -> Line {
        let [nx, ny, nz] = self.n;
        let (j, k) = (r % ny, r / ny);
        let [_, py, pz] = self.periodic;
        Line {
            cells: r * nx,
            xf: r * (nx + 1),
            ys: nx * (j + (ny + 1) * k),
            zb: r * nx,
            zf: (r + ny) * nx,
            south: (previous(j, ny, py) + ny * k) * nx,
            north: (next(j, ny, py) + ny * k) * nx,
            back: (j + ny * previous(k, nz, pz)) * nx,
            front: (j + ny * next(k, nz, pz)) * nx,
            parity: (j + k) % 2,
        }
    }

    /// The west and east neighbours of the line's ends (wrapped, or the cell itself).
    #[inline(always)]
    fn west_east(&self) -> (usize, usize) {
        let nx = self.n[0];
        if self.periodic[0] {
            (nx - 1, 0)
        } else {
            (0, nx - 1)
        }
    }

    /// Σ_faces a_f x_neighbour of cell i of line `l` (x read through `x`).
    ///
    /// # Safety
    /// `x` points to `self.len()` values, none of which another thread writes meanwhile.
    #[inline(always)]
    unsafe fn neighbours(&self, l: &Line, i: usize, x: *const F) -> F {
        let nx = self.n[0];
        let (west, east) = self.west_east();
        let (wi, ei) = (if i > 0 { i - 1 } else { west }, if i + 1 < nx { i + 1 } else { east });
        let [ax, ay, az] = &self.a;
        // SAFETY: every index is a cell or face of the level (see `line`).
        unsafe {
            (ax.get_unchecked(l.xf + i) * *x.add(l.cells + wi) + ax.get_unchecked(l.xf + i + 1) * *x.add(l.cells + ei))
                + (ay.get_unchecked(l.ys + i) * *x.add(l.south + i)
                    + ay.get_unchecked(l.ys + nx + i) * *x.add(l.north + i))
                + (az.get_unchecked(l.zb + i) * *x.add(l.back + i) + az.get_unchecked(l.zf + i) * *x.add(l.front + i))
        }
    }

    /// out = b − A x on line `r`.
    fn residual_line(&self, r: usize, x: &[F], b: &[F], out: &mut [F]) {
        let l = self.line(r);
        for (i, o) in out.iter_mut().enumerate() {
            let c = l.cells + i;
            // SAFETY: x is borrowed shared, so nobody writes it.
            let s = unsafe { self.neighbours(&l, i, x.as_ptr()) };
            *o = (b[c] - self.diag[c] * x[c]) + s;
        }
    }
}

/// A raw pointer shared by the threads of a smoothing pass: each writes only cells of one
/// colour, which no thread reads in that pass (see [`sweep`]).
#[derive(Clone, Copy)]
struct Shared(*mut F);
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

/// Lines per parallel task of the kernels.
const LINES: usize = 16;

/// Gauss–Seidel on the cells of `colour` ((i + j + k) mod 2) of every line, from zero
/// (`zero`: x = b/d, neighbours not read).
fn relax(op: &Op32, b: &[F], x: &mut [F], colour: usize, zero: bool) {
    let nx = op.n[0];
    let ptr = Shared(x.as_mut_ptr());
    let body = |r: usize| {
        let l = op.line(r);
        let x = ptr;
        let mut i = (colour + l.parity) % 2;
        while i < nx {
            let c = l.cells + i;
            // SAFETY: this pass writes only cells of `colour` (each by one task) and reads
            // only cells of the other colour (the neighbours) and b, d of its own cells.
            unsafe {
                let s = if zero { 0.0 } else { op.neighbours(&l, i, x.0) };
                *x.0.add(c) = (b.get_unchecked(c) + s) * op.inv.get_unchecked(c);
            }
            i += 2;
        }
    };
    if op.len() >= PARALLEL_CELLS {
        (0..op.lines().div_ceil(LINES)).into_par_iter().for_each(|t| {
            (t * LINES..((t + 1) * LINES).min(op.lines())).for_each(body);
        });
    } else {
        (0..op.lines()).for_each(body);
    }
}

/// One red-black Gauss–Seidel sweep: colour `first` on every cell, then the other. Each
/// pass is a per-cell map of the other colour's values: the same bits for any thread count.
/// `zero`: x starts at 0 (its values are not read).
pub(super) fn sweep(op: &Op32, b: &[F], x: &mut [F], first: usize, zero: bool) {
    assert!(x.len() == op.len() && b.len() == op.len());
    relax(op, b, x, first, zero);
    relax(op, b, x, 1 - first, false);
}

/// One level of the hierarchy with its scratch and the transfers to the next coarser one.
#[derive(Clone, Debug, Default)]
pub(super) struct Level {
    /// Cells of the fine level.
    n: Index,
    periodic: [bool; 3],
    /// Right-hand side and solution of the next coarser level.
    pub(super) bc: Vec<F>,
    pub(super) xc: Vec<F>,
    /// Coarse parents of each fine index, and fine children of each coarse index, per axis.
    p: [Vec<[usize; 2]>; 3],
    k: [Vec<[(usize, usize); 4]>; 3],
    /// Interpolation weight of the own parent per fine cell, per axis (the other's is
    /// 1 − own, 0 on the outer side of a non-periodic axis).
    w: [Vec<F>; 3],
    /// The residual restricted along x (for the 4 (y, z) parent slots, per fine line), then
    /// along y (for the 2 z slots).
    u: Vec<F>,
    v: Vec<F>,
}

/// The weights (own, other) of fine index i along an axis of n cells from the own one.
#[inline(always)]
fn pair(own: F, n: usize, i: usize, periodic: bool) -> [F; 2] {
    [own, if outside(n, i, periodic) { 0.0 } else { 1.0 - own }]
}

impl Level {
    /// A level of `n` cells (every axis even and at least 4).
    pub(super) fn new(n: Index, periodic: [bool; 3]) -> Self {
        let cells: usize = n.iter().product();
        let p: [Vec<[usize; 2]>; 3] = std::array::from_fn(|a| parents(n[a], periodic[a]));
        let k = std::array::from_fn(|a| children(&p[a]));
        Level {
            n,
            periodic,
            bc: vec![0.0; cells / 8],
            xc: vec![0.0; cells / 8],
            p,
            k,
            w: std::array::from_fn(|_| vec![1.0; cells]),
            u: vec![0.0; 2 * cells],
            v: vec![0.0; cells / 2],
        }
    }

    /// Recomputes the operator-dependent interpolation weights from `op`.
    pub(super) fn update_weights(&mut self, op: &Stencil) {
        let [nx, ny, nz] = self.n;
        let (d, per) = (op.dirichlet, op.periodic);
        let [ax, ay, az] = [op.coupling(0), op.coupling(1), op.coupling(2)];
        let [wx, wy, wz] = &mut self.w;
        let lines = wx.par_chunks_mut(nx).zip(wy.par_chunks_mut(nx)).zip(wz.par_chunks_mut(nx));
        lines.enumerate().for_each(|(r, ((wx, wy), wz))| {
            let (j, k) = (r % ny, r / ny);
            for i in 0..nx {
                wx[i] = weights(|f| ax[f + (nx + 1) * r], nx, i, per[0], [d[0], d[1]])[0] as F;
                wy[i] = weights(|f| ay[i + nx * (f + (ny + 1) * k)], ny, j, per[1], [d[2], d[3]])[0] as F;
                wz[i] = weights(|f| az[i + nx * (j + ny * f)], nz, k, per[2], [d[4], d[5]])[0] as F;
            }
        });
    }

    /// b_c = Pᵀ (b − A x): the residual line by line (not stored), restricted along x for
    /// each (y, z) parent slot, then along y, then along z.
    pub(super) fn restrict_residual(&mut self, op: &Op32, x: &[F], b: &[F]) {
        let [nx, ny, nz] = self.n;
        let (ncx, ncy) = (nx / 2, ny / 2);
        let big = nx * ny * nz >= PARALLEL_CELLS;
        let (per, [kx, ky, kz], [wx, wy, wz]) = (self.periodic, &self.k, &self.w);
        // u[(4 r + s) ncx + ic], s = sy + 2 sz: Σ over the x-children of ic
        let along_x = |buf: &mut Vec<F>, (r, u): (usize, &mut [F])| {
            buf.resize(nx, 0.0);
            op.residual_line(r, x, b, buf);
            let (j, k) = (r % ny, r / ny);
            let row = r * nx;
            for (ic, kids) in kx.iter().enumerate() {
                let mut s = [0.0 as F; 4];
                for &(i, sx) in kids {
                    let c = row + i;
                    let res = buf[i] * pair(wx[c], nx, i, per[0])[sx];
                    let (yw, zw) = (pair(wy[c], ny, j, per[1]), pair(wz[c], nz, k, per[2]));
                    for (q, s) in s.iter_mut().enumerate() {
                        *s += res * yw[q % 2] * zw[q / 2];
                    }
                }
                for (q, s) in s.iter().enumerate() {
                    u[q * ncx + ic] = *s;
                }
            }
        };
        if big {
            self.u.par_chunks_mut(4 * ncx).enumerate().for_each_init(Vec::new, along_x);
        } else {
            let mut buf = Vec::new();
            self.u.chunks_mut(4 * ncx).enumerate().for_each(|line| along_x(&mut buf, line));
        }
        // v[(sz (ncy nz) + jc + ncy k) ncx + ic] = Σ over the y-children of jc
        let (u, plane_v) = (&self.u, ncx * ncy * nz);
        let along_y = |(q, out): (usize, &mut [F])| {
            let (sz, rest) = (q / (ncy * nz), q % (ncy * nz));
            let (jc, k) = (rest % ncy, rest / ncy);
            for (n, &(j, sy)) in ky[jc].iter().enumerate() {
                let src = &u[(4 * (j + ny * k) + sy + 2 * sz) * ncx..][..ncx];
                if n == 0 {
                    out.copy_from_slice(src);
                } else {
                    out.iter_mut().zip(src).for_each(|(o, s)| *o += s);
                }
            }
        };
        debug_assert_eq!(self.v.len(), 2 * plane_v);
        if big {
            self.v.par_chunks_mut(ncx).enumerate().for_each(along_y);
        } else {
            self.v.chunks_mut(ncx).enumerate().for_each(along_y);
        }
        // b_c = Σ over the z-children of kc
        let v = &self.v;
        let along_z = |(rc, out): (usize, &mut [F])| {
            let (jc, kc) = (rc % ncy, rc / ncy);
            for (n, &(k, sz)) in kz[kc].iter().enumerate() {
                let src = &v[sz * plane_v + (jc + ncy * k) * ncx..][..ncx];
                if n == 0 {
                    out.copy_from_slice(src);
                } else {
                    out.iter_mut().zip(src).for_each(|(o, s)| *o += s);
                }
            }
        };
        if big {
            self.bc.par_chunks_mut(ncx).enumerate().for_each(along_z);
        } else {
            self.bc.chunks_mut(ncx).enumerate().for_each(along_z);
        }
    }

    /// x += P x_c.
    pub(super) fn prolong_add(&self, x: &mut [F]) {
        let [nx, ny, nz] = self.n;
        let (ncx, ncy) = (nx / 2, ny / 2);
        let (per, [px, py, pz], [wx, wy, wz], xc) = (self.periodic, &self.p, &self.w, &self.xc);
        let body = |(r, row): (usize, &mut [F])| {
            let (j, k) = (r % ny, r / ny);
            let base = r * nx;
            for (i, v) in row.iter_mut().enumerate() {
                let c = base + i;
                let (xw, yw, zw) = (pair(wx[c], nx, i, per[0]), pair(wy[c], ny, j, per[1]), pair(wz[c], nz, k, per[2]));
                let mut s: F = 0.0;
                for (sz, &kc) in pz[k].iter().enumerate() {
                    let mut t: F = 0.0;
                    for (sy, &jc) in py[j].iter().enumerate() {
                        let line = &xc[(jc + ncy * kc) * ncx..][..ncx];
                        t += yw[sy] * (xw[0] * line[px[i][0]] + xw[1] * line[px[i][1]]);
                    }
                    s += zw[sz] * t;
                }
                *v += s;
            }
        };
        if nx * ny * nz >= PARALLEL_CELLS {
            x.par_chunks_mut(nx).enumerate().for_each(body);
        } else {
            x.chunks_mut(nx).enumerate().for_each(body);
        }
    }
}
