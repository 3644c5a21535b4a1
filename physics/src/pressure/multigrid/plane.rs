//! The level kernels of the V-cycle in 2D: the f32 operator, red-black Gauss–Seidel with the
//! two colours fused in one pass over the rows, and the bilinear operator-dependent
//! transfers with the residual restricted row by row (see [`super`]).

use super::{children, outside, parents, to_f32, weights, F};
use crate::pressure::stencil::{Stencil, PARALLEL_CELLS};
use multifield_core::math::Index;
use rayon::prelude::*;

/// A level operator in f32 (from the f64 [`Stencil`]): couplings, diagonal, 1/diagonal.
#[derive(Clone, Debug, Default)]
pub(super) struct Op32 {
    nx: usize,
    ny: usize,
    periodic: [bool; 2],
    ax: Vec<F>,
    ay: Vec<F>,
    diag: Vec<F>,
    inv: Vec<F>,
}

impl Op32 {
    pub(super) fn assign(&mut self, op: &Stencil) {
        (self.nx, self.ny, self.periodic) = (op.nx, op.ny, op.periodic);
        to_f32(&op.ax, &mut self.ax);
        to_f32(&op.ay, &mut self.ay);
        to_f32(&op.diag, &mut self.diag);
        to_f32(&op.inv_diag, &mut self.inv);
    }
    fn len(&self) -> usize {
        self.nx * self.ny
    }
    /// Cells along x (the row length of the reductions).
    pub(super) fn nx(&self) -> usize {
        self.nx
    }
    #[inline(always)]
    fn south(&self, j: usize) -> usize {
        crate::pressure::stencil::previous(j, self.ny, self.periodic[1])
    }
    #[inline(always)]
    fn north(&self, j: usize) -> usize {
        crate::pressure::stencil::next(j, self.ny, self.periodic[1])
    }
    #[inline(always)]
    fn west_east(&self) -> (usize, usize) {
        if self.periodic[0] {
            (self.nx - 1, 0)
        } else {
            (0, self.nx - 1)
        }
    }

    /// out = b − A x on row `j`.
    #[inline]
    fn residual_row(&self, j: usize, x: &[F], b: &[F], out: &mut [F]) {
        let nx = self.nx;
        let row = j * nx;
        let (s, n) = (self.south(j) * nx, self.north(j) * nx);
        let aw = &self.ax[j * (nx + 1)..(j + 1) * (nx + 1)];
        let (a_s, a_n) = (&self.ay[row..row + nx], &self.ay[row + nx..row + 2 * nx]);
        let (xc, xs, xn) = (&x[row..row + nx], &x[s..s + nx], &x[n..n + nx]);
        let (d, b) = (&self.diag[row..row + nx], &b[row..row + nx]);
        let out = &mut out[..nx];
        for (o, ((((a_s, a_n), xs), xn), (b, (d, xc)))) in
            out.iter_mut().zip(a_s.iter().zip(a_n).zip(xs).zip(xn).zip(b.iter().zip(d.iter().zip(xc))))
        {
            *o = (b - d * xc) + (a_s * xs + a_n * xn);
        }
        // every cell adds its west neighbour, then its east one (cell 0 too: a rank's block,
        // where the domain's column 0 may be inside, adds them in that order)
        let (w, e) = self.west_east();
        for (o, (a, x)) in out[1..].iter_mut().zip(aw[1..nx].iter().zip(&xc[..nx - 1])) {
            *o += a * x;
        }
        out[0] += aw[0] * xc[w];
        for (o, (a, x)) in out[..nx - 1].iter_mut().zip(aw[1..nx].iter().zip(&xc[1..])) {
            *o += a * x;
        }
        out[nx - 1] += aw[nx] * xc[e];
    }
}

/// A raw pointer shared by the threads of a smoothing sweep: each writes only cells that no
/// other thread reads or writes at the same time (see [`sweep`]).
#[derive(Clone, Copy)]
struct Shared(*mut F);
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

/// Gauss–Seidel on the cells of `colour` ((i + j) mod 2) in row `j`; from zero (`zero`) the
/// neighbours are not read: x = b / d.
///
/// # Safety
/// `x` points to `op.len()` values; no other thread writes a cell this row reads or writes.
#[inline]
unsafe fn relax_row(op: &Op32, b: &[F], x: Shared, colour: usize, j: usize, zero: bool) {
    let nx = op.nx;
    let row = j * nx;
    let (inv, b) = (&op.inv[row..row + nx], &b[row..row + nx]);
    let xc = unsafe { x.0.add(row) };
    let mut i = (colour + j) % 2;
    if zero {
        while i < nx {
            // SAFETY: i < nx.
            unsafe { *xc.add(i) = b.get_unchecked(i) * inv.get_unchecked(i) };
            i += 2;
        }
        return;
    }
    let aw = &op.ax[j * (nx + 1)..(j + 1) * (nx + 1)];
    let (a_s, a_n) = (&op.ay[row..row + nx], &op.ay[row + nx..row + 2 * nx]);
    let (xs, xn) = unsafe { (x.0.add(op.south(j) * nx), x.0.add(op.north(j) * nx)) };
    let (west, east) = op.west_east();
    let cell = |i: usize, wi: usize, ei: usize| {
        // SAFETY: i, wi, ei < nx; the rows are rows of x (see `sweep`).
        unsafe {
            let s = aw.get_unchecked(i) * *xc.add(wi)
                + aw.get_unchecked(i + 1) * *xc.add(ei)
                + a_s.get_unchecked(i) * *xs.add(i)
                + a_n.get_unchecked(i) * *xn.add(i);
            *xc.add(i) = (b.get_unchecked(i) + s) * inv.get_unchecked(i);
        }
    };
    if i == 0 {
        cell(0, west, if nx > 1 { 1 } else { east });
        i = 2;
    }
    while i + 1 < nx {
        cell(i, i - 1, i + 1);
        i += 2;
    }
    if i + 1 == nx {
        cell(i, i - 1, east);
    }
}

/// Gauss–Seidel on the cells of `colour` in row `j`, vectorisable: the update of every cell
/// of the row into `t` (those of the other colour are dropped), then the colour's cells
/// copied to x. Each cell gets the same arithmetic, in the same order, as in [`relax_row`],
/// so the two give the same bits.
///
/// # Safety
/// `x` points to `op.len()` values; no other thread writes rows j − 1, j, j + 1 meanwhile.
#[inline(always)]
unsafe fn relax_row_vec(op: &Op32, b: &[F], x: Shared, colour: usize, j: usize, zero: bool, t: &mut [F]) {
    let nx = op.nx;
    let row = j * nx;
    let (inv, b, t) = (&op.inv[row..row + nx], &b[row..row + nx], &mut t[..nx]);
    if zero {
        t.iter_mut().zip(b.iter().zip(inv)).for_each(|(t, (b, d))| *t = b * d);
    } else {
        // SAFETY: rows of x that nobody writes while these slices live (see above).
        let (xc, xs, xn) = unsafe {
            (
                std::slice::from_raw_parts(x.0.add(row), nx),
                std::slice::from_raw_parts(x.0.add(op.south(j) * nx), nx),
                std::slice::from_raw_parts(x.0.add(op.north(j) * nx), nx),
            )
        };
        let aw = &op.ax[j * (nx + 1)..(j + 1) * (nx + 1)];
        let (a_s, a_n) = (&op.ay[row..row + nx], &op.ay[row + nx..row + 2 * nx]);
        let (west, east) = op.west_east();
        let cell = |i: usize, wi: usize, ei: usize| {
            let s = aw[i] * xc[wi] + aw[i + 1] * xc[ei] + a_s[i] * xs[i] + a_n[i] * xn[i];
            (b[i] + s) * inv[i]
        };
        t[0] = cell(0, west, 1);
        t[nx - 1] = cell(nx - 1, nx - 2, east);
        let m = nx - 2;
        let (tt, ww, we, xw, xe) = (&mut t[1..nx - 1], &aw[1..nx - 1], &aw[2..nx], &xc[..m], &xc[2..]);
        let (a_s, xs, a_n, xn, b, inv) =
            (&a_s[1..][..m], &xs[1..][..m], &a_n[1..][..m], &xn[1..][..m], &b[1..][..m], &inv[1..][..m]);
        let (tt, ww, we, xw, xe) = (&mut tt[..m], &ww[..m], &we[..m], &xw[..m], &xe[..m]);
        for k in 0..m {
            let s = ww[k] * xw[k] + we[k] * xe[k] + a_s[k] * xs[k] + a_n[k] * xn[k];
            tt[k] = (b[k] + s) * inv[k];
        }
    }
    // SAFETY: row j of x (see above); the slices above are gone.
    let xc = unsafe { std::slice::from_raw_parts_mut(x.0.add(row), nx) };
    let p = (colour + j) % 2;
    for (x, t) in xc.chunks_exact_mut(2).zip(t.chunks_exact(2)) {
        x[p] = t[p];
    }
}

/// Rows per block of a parallel sweep (at least).
const BLOCK_ROWS: usize = 16;

/// The first stage of a sweep on the rows a..e (see [`sweep`]); `alone`: no other thread
/// runs meanwhile, so the edge rows may use the vector path too.
///
/// # Safety
/// As in [`sweep`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn block_body(op: &Op32, b: &[F], x: Shared, first: usize, a: usize, e: usize, zero: bool, alone: bool) {
    let mut t = vec![0.0; op.nx];
    for j in a..e {
        unsafe {
            if alone || (j > a && j + 1 < e) {
                relax_row_vec(op, b, x, first, j, zero, &mut t);
            } else {
                relax_row(op, b, x, first, j, zero);
            }
            if j >= a + 2 {
                relax_row_vec(op, b, x, 1 - first, j - 1, false, &mut t);
            }
        }
    }
    if alone {
        unsafe {
            relax_row_vec(op, b, x, 1 - first, a, false, &mut t);
            if e - 1 > a {
                relax_row_vec(op, b, x, 1 - first, e - 1, false, &mut t);
            }
        }
    }
}

/// [`block_body`] compiled for AVX2 (no FMA: the same bits as without).
///
/// # Safety
/// As in [`sweep`]; the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn block_body_avx2(op: &Op32, b: &[F], x: Shared, first: usize, a: usize, e: usize, zero: bool, alone: bool) {
    unsafe { block_body(op, b, x, first, a, e, zero, alone) }
}

/// [`block_body`] with the widest vectors the CPU has.
///
/// # Safety
/// As in [`sweep`].
#[allow(clippy::too_many_arguments)]
unsafe fn block(op: &Op32, b: &[F], x: Shared, first: usize, a: usize, e: usize, zero: bool, alone: bool) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        return unsafe { block_body_avx2(op, b, x, first, a, e, zero, alone) };
    }
    unsafe { block_body(op, b, x, first, a, e, zero, alone) }
}

/// One red-black Gauss–Seidel sweep: colour `first` on every row, then the other colour.
/// The two colours go in one pass over memory: the second colour of row j − 1 right after
/// the first colour of row j (all its neighbours are then final). Rows are split in blocks
/// (in parallel for big levels); the second colour of a block's first and last rows, whose
/// neighbours belong to other blocks, is done after all blocks. Every cell sees the same
/// neighbour values as with two full colour passes, so the result is the same to the bit
/// for any blocking and thread count. `zero`: x starts at 0 (its values are not read).
pub(super) fn sweep(op: &Op32, b: &[F], x: &mut [F], first: usize, zero: bool) {
    let (nx, ny) = (op.nx, op.ny);
    assert!(x.len() == op.len() && b.len() == op.len() && nx & 1 == 0 && ny & 1 == 0 && nx >= 4);
    let ptr = Shared(x.as_mut_ptr());
    let second = 1 - first;
    let blocks =
        if op.len() >= PARALLEL_CELLS { (4 * rayon::current_num_threads()).min(ny / BLOCK_ROWS).max(1) } else { 1 };
    let range = |k: usize| (k * ny / blocks, (k + 1) * ny / blocks);
    // SAFETY: in the first stage a block writes its rows' first colour and the second colour
    // of its inner rows, reading its own rows and only the other colour of the neighbouring
    // blocks' edge rows (by `relax_row`), which no one writes in that stage. In the second
    // stage blocks write the second colour of their edge rows and read only the first colour.
    if blocks == 1 {
        unsafe { block(op, b, ptr, first, 0, ny, zero, true) };
        return;
    }
    (0..blocks).into_par_iter().for_each(|k| {
        let (a, e) = range(k);
        unsafe { block(op, b, ptr, first, a, e, zero, false) };
    });
    (0..blocks).into_par_iter().for_each(|k| {
        let (a, e) = range(k);
        unsafe { relax_row(op, b, ptr, second, a, false) };
        if e - 1 > a {
            unsafe { relax_row(op, b, ptr, second, e - 1, false) };
        }
    });
}

/// Gauss–Seidel on the cells of `colour` of every row (the first half of a [`sweep`],
/// each cell's arithmetic [`relax_row`]'s), rows in parallel for big levels: a rank's block
/// relaxes a colour, then takes the halo of its neighbours before the other colour
/// (docs/design/mpi.md §4). `zero`: x starts at 0.
pub(super) fn relax_colour(op: &Op32, b: &[F], x: &mut [F], colour: usize, zero: bool) {
    assert!(x.len() == op.len() && b.len() == op.len() && op.nx >= 2);
    let ptr = Shared(x.as_mut_ptr());
    // SAFETY: a row writes the cells of `colour` in it and reads the other colour only
    // (its own row's and its neighbours'), which nobody writes in this pass.
    let row = |j: usize| unsafe { relax_row(op, b, ptr, colour, j, zero) };
    if op.len() >= PARALLEL_CELLS {
        (0..op.ny).into_par_iter().with_min_len(BLOCK_ROWS).for_each(row);
    } else {
        (0..op.ny).for_each(row);
    }
}

/// Fine rows restricted along x kept by a block of coarse rows (at least the 4 children
/// of one coarse row plus the 2 it shares with the next one).
const SLOTS: usize = 6;

/// Coarse rows per parallel block of the restriction.
const COARSE_ROWS: usize = 16;

/// The last [`SLOTS`] fine rows restricted along x (for the own and the other y-parent),
/// oldest replaced first, and a scratch row.
#[derive(Debug)]
struct RowCache {
    rows: [usize; SLOTS],
    u: Vec<F>,
    next: usize,
    buf: Vec<F>,
}

impl Default for RowCache {
    fn default() -> Self {
        Self { rows: [usize::MAX; SLOTS], u: Vec::new(), next: 0, buf: Vec::new() }
    }
}

/// A row of x-weights and a row of y-weights.
type WeightRows<'a> = (&'a mut [F], &'a mut [F]);

/// One level of the hierarchy with its scratch and the transfers to the next coarser one.
#[derive(Clone, Debug, Default)]
pub(super) struct Level {
    /// Cells of the fine level.
    nx: usize,
    ny: usize,
    /// Right-hand side and solution of the next coarser level.
    pub(super) bc: Vec<F>,
    pub(super) xc: Vec<F>,
    /// Coarse parents along x and y of each fine column and row.
    px: Vec<[usize; 2]>,
    py: Vec<[usize; 2]>,
    /// Fine children of each coarse column and row (ascending; in position order across a
    /// periodic wrap, [`wrapped_children`]).
    kx: Vec<[(usize, usize); 4]>,
    ky: Vec<[(usize, usize); 4]>,
    /// Interpolation weight of the own parent per fine cell along x and y; the other
    /// parent's is 1 − own (0 on the outer side of a non-periodic axis, see [`Level::other`]).
    wx: Vec<F>,
    wy: Vec<F>,
    /// Periodic along (x, y).
    periodic: [bool; 2],
}

/// On a periodic axis of n fine cells, the four (fine index, parent slot) children of each
/// coarse index c in the order of their positions, 2c − 1, 2c, 2c + 1, 2c + 2, wrapped: the
/// order in which a rank's block, whose cut the wrap may be, adds them.
fn wrapped_children(n: usize) -> Vec<[(usize, usize); 4]> {
    (0..n / 2).map(|c| [((2 * c + n - 1) % n, 1), (2 * c, 0), (2 * c + 1, 0), ((2 * c + 2) % n, 1)]).collect()
}

impl Level {
    /// A level of `n` cells (both axes even and at least 4).
    pub(super) fn new(n: Index, periodic: [bool; 2]) -> Self {
        let [nx, ny] = n;
        let px = parents(nx, periodic[0]);
        let py = parents(ny, periodic[1]);
        Level {
            nx,
            ny,
            bc: vec![0.0; nx * ny / 4],
            xc: vec![0.0; nx * ny / 4],
            kx: children(&px),
            ky: if periodic[1] { wrapped_children(ny) } else { children(&py) },
            px,
            py,
            wx: vec![1.0; nx * ny],
            wy: vec![1.0; nx * ny],
            periodic,
        }
    }

    /// The weights (own, other) of fine index i along an axis of n cells from the own one.
    #[inline]
    fn pair(own: F, n: usize, i: usize, periodic: bool) -> [F; 2] {
        [own, if outside(n, i, periodic) { 0.0 } else { 1.0 - own }]
    }

    /// Recomputes the operator-dependent interpolation weights from `op`.
    pub(super) fn update_weights(&mut self, op: &Stencil) {
        let (nx, ny) = (op.nx, op.ny);
        let d = op.dirichlet;
        // the two weights add up to 1 but on the outer side of an axis, where the other is 0
        let body = |(j, (wx, wy)): (usize, WeightRows)| {
            let row = &op.ax[j * (nx + 1)..(j + 1) * (nx + 1)];
            for i in 0..nx {
                wx[i] = weights(|f| row[f], nx, i, op.periodic[0], [d[0], d[1]])[0] as F;
                wy[i] = weights(|f| op.ay[i + f * nx], ny, j, op.periodic[1], [d[2], d[3]])[0] as F;
            }
        };
        let rows = self.wx.par_chunks_mut(nx).zip(self.wy.par_chunks_mut(nx));
        rows.enumerate().for_each(body);
    }

    /// b_c = Pᵀ (b − A x): the residual row by row (not stored), restricted along x (for
    /// each y-parent slot), then along y, a few rows at a time.
    pub(super) fn restrict_residual(&mut self, op: &Op32, x: &[F], b: &[F]) {
        let (nx, ncx) = (self.nx, self.nx / 2);
        let big = self.nx * self.ny >= PARALLEL_CELLS;
        let (kx, ky, wx, wy, [px_, py_]) = (&self.kx, &self.ky, &self.wx, &self.wy, self.periodic);
        let ny = self.ny;
        let along_x = |buf: &mut Vec<F>, (j, (u0, u1)): (usize, (&mut [F], &mut [F]))| {
            buf.resize(nx + 6 * ncx, 0.0);
            let (r, t) = buf.split_at_mut(nx);
            op.residual_row(j, x, b, r);
            let (po0, t) = t.split_at_mut(ncx);
            let (po1, t) = t.split_at_mut(ncx);
            let (tl0, t) = t.split_at_mut(ncx);
            let (tl1, t) = t.split_at_mut(ncx);
            let (tr0, tr1) = t.split_at_mut(ncx);
            let (tr1, u0, u1) = (&mut tr1[..ncx], &mut u0[..ncx], &mut u1[..ncx]);
            let (wx, wy) = (&wx[j * nx..(j + 1) * nx], &wy[j * nx..(j + 1) * nx]);
            let (wx2, wy2, r2) =
                (&wx.as_chunks::<2>().0[..ncx], &wy.as_chunks::<2>().0[..ncx], &r.as_chunks::<2>().0[..ncx]);
            let y_in: F = if outside(ny, j, py_) { 0.0 } else { 1.0 };
            // per pair of fine cells 2ic, 2ic + 1: the part for their own coarse column ic
            // (po), the part of 2ic for its other parent (tl: ic − 1, or ic at a wall) and the
            // part of 2ic + 1 for its other parent (tr: ic + 1, or ic), for both y-parent slots
            for ic in 0..ncx {
                let ([xo0, xo1], [yo0, yo1], [r0, r1]) = (wx2[ic], wy2[ic], r2[ic]);
                let (xt0, xt1, yt0, yt1) = (1.0 - xo0, 1.0 - xo1, (1.0 - yo0) * y_in, (1.0 - yo1) * y_in);
                let (a0, b0, a1, b1) = (r0 * yo0, r0 * yt0, r1 * yo1, r1 * yt1);
                po0[ic] = xo0 * a0 + xo1 * a1;
                po1[ic] = xo0 * b0 + xo1 * b1;
                tl0[ic] = xt0 * a0;
                tl1[ic] = xt0 * b0;
                tr0[ic] = xt1 * a1;
                tr1[ic] = xt1 * b1;
            }
            // the outer columns of a non-periodic axis have no other parent
            for i in [0, nx - 1] {
                if outside(nx, i, px_) {
                    let ic = i / 2;
                    if i % 2 == 0 {
                        (tl0[ic], tl1[ic]) = (0.0, 0.0);
                    } else {
                        (tr0[ic], tr1[ic]) = (0.0, 0.0);
                    }
                }
            }
            for ic in [0, ncx - 1] {
                if px_ {
                    // across the wrap as inside (a rank's block, whose cut this may be, adds them so)
                    let (l, r) = ((ic + 1) % ncx, (ic + ncx - 1) % ncx);
                    (u0[ic], u1[ic]) = ((tr0[r] + po0[ic]) + tl0[l], (tr1[r] + po1[ic]) + tl1[l]);
                    continue;
                }
                let (mut s0, mut s1) = (po0[ic], po1[ic]);
                for &(i, sx) in &kx[ic] {
                    if sx == 1 {
                        let (t0, t1) = if i % 2 == 0 { (tl0[i / 2], tl1[i / 2]) } else { (tr0[i / 2], tr1[i / 2]) };
                        s0 += t0;
                        s1 += t1;
                    }
                }
                (u0[ic], u1[ic]) = (s0, s1);
            }
            // inside: ic gathers 2ic − 1 (tr of ic − 1), its own pair and 2ic + 2 (tl of ic + 1)
            let m = ncx - 2;
            for (u, p, l, r) in
                [(&mut u0[1..], &po0[1..], &tl0[2..], &tr0[..]), (&mut u1[1..], &po1[1..], &tl1[2..], &tr1[..])]
            {
                for (((u, p), l), r) in u[..m].iter_mut().zip(&p[..m]).zip(&l[..m]).zip(&r[..m]) {
                    *u = (r + p) + l;
                }
            }
        };
        // coarse row jc gathers the rows restricted along x of its fine children in y
        // (ky[jc], ascending); a block of coarse rows keeps the last few of them, so each
        // is computed once per block (twice at block edges)
        let along_y = |cache: &mut RowCache, (block, out): (usize, &mut [F])| {
            for (k, row) in out.chunks_mut(ncx).enumerate() {
                let kids = ky[block * COARSE_ROWS + k];
                let mut at = [0; 4];
                for (n, &(j, _)) in kids.iter().enumerate() {
                    at[n] = match cache.rows.iter().position(|&r| r == j) {
                        Some(p) => p,
                        None => {
                            let p = cache.next;
                            cache.next = (p + 1) % SLOTS;
                            cache.rows[p] = j;
                            cache.u.resize(SLOTS * 2 * ncx, 0.0);
                            let (u0, u1) = cache.u[p * 2 * ncx..(p + 1) * 2 * ncx].split_at_mut(ncx);
                            along_x(&mut cache.buf, (j, (u0, u1)));
                            p
                        }
                    };
                }
                let u = |n: usize| &cache.u[(2 * at[n] + kids[n].1) * ncx..][..ncx];
                let (u0, u1, u2, u3) = (u(0), u(1), u(2), u(3));
                for ((((out, a), b), c), d) in row.iter_mut().zip(u0).zip(u1).zip(u2).zip(u3) {
                    *out = (a + b) + (c + d);
                }
            }
        };
        if big {
            self.bc.par_chunks_mut(ncx * COARSE_ROWS).enumerate().for_each_init(RowCache::default, along_y);
        } else {
            along_y(&mut RowCache::default(), (0, &mut self.bc));
        }
    }

    /// x += P x_c.
    pub(super) fn prolong_add(&self, x: &mut [F]) {
        let (nx, ncx) = (self.nx, self.nx / 2);
        let (xc, px, py, wx, wy) = (&self.xc, &self.px, &self.py, &self.wx, &self.wy);
        let (ny, [px_, py_]) = (self.ny, self.periodic);
        let body = |(j, row): (usize, &mut [F])| {
            let [js, jo] = py[j];
            let (rs, ro) = (&xc[js * ncx..(js + 1) * ncx], &xc[jo * ncx..(jo + 1) * ncx]);
            let (wx, wy) = (&wx[j * nx..(j + 1) * nx], &wy[j * nx..(j + 1) * nx]);
            let y_in: F = if outside(ny, j, py_) { 0.0 } else { 1.0 };
            let add = |v: &mut F, i: usize, [is, io]: [usize; 2]| {
                let ([ws, wo], [vs, vo]) = (Self::pair(wx[i], nx, i, px_), Self::pair(wy[i], ny, j, py_));
                *v += vs * (ws * rs[is] + wo * rs[io]) + vo * (ws * ro[is] + wo * ro[io]);
            };
            for i in [0, 1, nx - 2, nx - 1] {
                add(&mut row[i], i, px[i]);
            }
            // inside: the parents of 2ic are (ic, ic − 1), of 2ic + 1 (ic, ic + 1)
            let m = ncx - 2;
            let (row2, wx2, wy2) = (
                &mut row.as_chunks_mut::<2>().0[1..][..m],
                &wx.as_chunks::<2>().0[1..][..m],
                &wy.as_chunks::<2>().0[1..][..m],
            );
            for ((((v, [xo0, xo1]), [yo0, yo1]), s), o) in
                row2.iter_mut().zip(wx2).zip(wy2).zip(rs.windows(3)).zip(ro.windows(3))
            {
                let (xt0, xt1, yt0, yt1) = (1.0 - xo0, 1.0 - xo1, (1.0 - yo0) * y_in, (1.0 - yo1) * y_in);
                v[0] += yo0 * (xo0 * s[1] + xt0 * s[0]) + yt0 * (xo0 * o[1] + xt0 * o[0]);
                v[1] += yo1 * (xo1 * s[1] + xt1 * s[2]) + yt1 * (xo1 * o[1] + xt1 * o[2]);
            }
        };
        if self.nx * self.ny >= PARALLEL_CELLS {
            x.par_chunks_mut(nx).enumerate().for_each(body);
        } else {
            x.chunks_mut(nx).enumerate().for_each(body);
        }
    }
}
