//! Deterministic parallel particles-to-grid scatter.
//!
//! Points are binned by cell row (a stable counting sort) into horizontal stripes. Each
//! stripe scatters into its own small buffer in parallel; the buffers are then added into
//! the grid row by row, always in stripe order. No atomics, no locks: the sums are the same
//! bits for any number of threads. Lattices are padded by two ghost nodes on each side;
//! ghost contributions are folded back (wrapped on periodic sides, mirrored at walls).
//!
//! On a rank's block of a decomposed domain (docs/design/mpi.md §5) the scatter computes a
//! window of the whole domain's padded lattices: the block's nodes and four more on each
//! side. Given the block's points and the ghost points within two cells of it, all in id
//! order (the serial order), the stripes are the serial stripes and every owned node gets
//! the serial terms in the serial order. The fold's contributions from across a periodic
//! wrap or a ghost node next to another rank's block come from the rank whose window holds
//! them complete ([`Scatter::run`] with a decomposed grid), added in the serial order.

use super::shape::{Shape, Weights1};
use multifield_core::boundary::Boundaries;
use multifield_core::grid::{Grid, Lattice};
use multifield_core::math::{Matrix, Real, Vector};
use multifield_core::parallel::Tag;
use multifield_core::part::Part;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Channels scattered in one pass.
pub const CHANNELS: usize = 7;
/// x-face mass.
pub const MASS_U: usize = 0;
/// x-face momentum.
pub const MOM_U: usize = 1;
/// x-face internal force.
pub const FORCE_U: usize = 2;
/// y-face mass.
pub const MASS_V: usize = 3;
/// y-face momentum.
pub const MOM_V: usize = 4;
/// y-face internal force.
pub const FORCE_V: usize = 5;
/// Cell volume.
pub const VOLUME: usize = 6;

const PAD: usize = 2;
/// Nodes of the window beyond a rank's block on each side: the stencils of its ghost points
/// (two cells out) and the ghost nodes of the fold.
const REACH: isize = 4;
/// The tag of the fold's messages.
const FOLD_TAG: Tag = 40;

/// Read-only view of the points for a scatter.
pub struct PointsIn<'a> {
    /// Positions.
    pub x: &'a [Vector],
    /// Velocities.
    pub v: &'a [Vector],
    /// Masses.
    pub m: &'a [Real],
    /// Current volumes.
    pub vol: &'a [Real],
    /// APIC affine rows (c_u, c_v), or `None` for PIC/FLIP.
    pub affine: Option<(&'a [Vector], &'a [Vector])>,
    /// Cauchy stress (+ nothing when absent).
    pub stress: Option<&'a [Matrix]>,
}

/// Scratch space of the scatter, kept between steps.
pub struct Scatter {
    /// The domain's cells.
    n: [usize; 2],
    /// The global node of the window's first column and row (−2 for the whole domain).
    lo: [isize; 2],
    nxp: usize,
    nyp: usize,
    rows_per_stripe: usize,
    /// The first stripe of the window and the number of its stripes.
    first_stripe: usize,
    stripes: usize,
    buffers: Vec<Vec<Real>>,
    /// The window of the padded global lattices, channel-major.
    pub padded: Vec<Real>,
    order: Vec<u32>,
    start: Vec<usize>,
    /// Per stripe, the columns [c0, c1) of its buffer that the last run wrote (all rows,
    /// all channels); the rest of the buffer is zero.
    dirty: Vec<(usize, usize)>,
}

/// The 1D weights of a point on the face and centre lattices.
#[derive(Clone, Copy)]
pub struct PointWeights {
    /// Along x at integer nodes (x-faces).
    pub xf: Weights1,
    /// Along x at half nodes (cells, y-faces).
    pub xc: Weights1,
    /// Along y at integer nodes (y-faces).
    pub yf: Weights1,
    /// Along y at half nodes (cells, x-faces).
    pub yc: Weights1,
    /// Position in cell units from the origin.
    pub xi: Vector,
}

/// Weights of a point at `x`.
#[inline(always)]
pub fn point_weights(shape: Shape, grid: &Grid, x: Vector) -> PointWeights {
    let xi = (x - grid.origin) / grid.h;
    PointWeights {
        xf: shape.weights(xi.x),
        xc: shape.weights(xi.x - 0.5),
        yf: shape.weights(xi.y),
        yc: shape.weights(xi.y - 0.5),
        xi,
    }
}

impl Scatter {
    /// Scratch for `grid`: the whole domain's padded lattices, or on a rank's block of a
    /// decomposed domain the window of them around the block (see the module's
    /// documentation).
    pub fn new(grid: &Grid) -> Self {
        let n = [grid.domain[0], grid.domain[1]];
        let window = |a: usize| -> (isize, isize) {
            let whole = (-(PAD as isize), (n[a] + 1 + PAD) as isize);
            match grid.part.block() {
                None => whole,
                Some((_, b)) => {
                    let c = &b.cells[a];
                    ((c.start as isize - REACH).max(whole.0), (c.end as isize + REACH + 1).min(whole.1))
                }
            }
        };
        let ((x0, x1), (y0, y1)) = (window(0), window(1));
        let rows_per_stripe = 4;
        // the stripes whose buffer rows [4 s − 2, 4 s + 6) meet the window's rows
        let all = n[1].div_ceil(rows_per_stripe);
        let reaches = |s: usize| {
            let r0 = (s * rows_per_stripe) as isize - PAD as isize;
            r0 < y1 && r0 + (rows_per_stripe + 2 * PAD) as isize > y0
        };
        let first_stripe = (0..all).find(|&s| reaches(s)).unwrap_or(all);
        let stripes = (first_stripe..all).take_while(|&s| reaches(s)).count();
        let (nxp, nyp) = ((x1 - x0) as usize, (y1 - y0) as usize);
        Self {
            n,
            lo: [x0, y0],
            nxp,
            nyp,
            rows_per_stripe,
            first_stripe,
            stripes,
            buffers: vec![vec![0.0; CHANNELS * (rows_per_stripe + 2 * PAD) * nxp]; stripes],
            padded: vec![0.0; CHANNELS * nxp * nyp],
            order: Vec::new(),
            start: vec![0; stripes + 1],
            dirty: vec![(0, 0); stripes],
        }
    }

    #[inline]
    fn offset(&self, c: usize, i: isize, j: isize) -> usize {
        c * self.nxp * self.nyp + (i - self.lo[0]) as usize + (j - self.lo[1]) as usize * self.nxp
    }
    /// Value of channel `c` at global lattice node (i, j) (ghosts down to −2; on a rank's
    /// block, a node of its window).
    #[inline]
    pub fn at(&self, c: usize, i: isize, j: isize) -> Real {
        self.padded[self.offset(c, i, j)]
    }
    /// Channel `c` on global lattice row `j`, `len` nodes from node `i0`.
    #[inline]
    pub fn row(&self, c: usize, i0: isize, j: isize, len: usize) -> &[Real] {
        let start = self.offset(c, i0, j);
        &self.padded[start..start + len]
    }
    #[inline]
    fn at_mut(&mut self, c: usize, i: isize, j: isize) -> &mut Real {
        let k = self.offset(c, i, j);
        &mut self.padded[k]
    }

    /// Scatters mass, momentum, internal force and volume of all points. On a rank's
    /// block of a decomposed domain: `pts` are its points and the ghost points within two
    /// cells of its block, in id order, and every rank calls it (the fold exchanges the
    /// ghost nodes' sums); the block's nodes get the serial bits, its halo nothing useful.
    pub fn run(&mut self, grid: &Grid, bc: &Boundaries, shape: Shape, pts: &PointsIn) {
        let n = pts.x.len();
        // stable counting sort by stripe (the window's)
        let h = grid.h;
        let (ny, first) = (self.n[1], self.first_stripe);
        let stripe_of = |x: &Vector| {
            // `as usize` truncates toward zero and saturates below at 0: ⌊·⌋ clamped at 0
            let j = (((x.y - grid.origin.y) / h) as usize).min(ny - 1);
            j / self.rows_per_stripe - first
        };
        self.start.iter_mut().for_each(|s| *s = 0);
        for x in pts.x {
            self.start[stripe_of(x) + 1] += 1;
        }
        for s in 0..self.stripes {
            self.start[s + 1] += self.start[s];
        }
        self.order.resize(n, 0);
        let mut fill = self.start.clone();
        for (p, x) in pts.x.iter().enumerate() {
            let s = stripe_of(x);
            self.order[fill[s]] = p as u32;
            fill[s] += 1;
        }
        let (nxp, rows) = (self.nxp, self.rows_per_stripe + 2 * PAD);
        let (order, start) = (&self.order, &self.start);
        let rps = self.rows_per_stripe as isize;
        let plane = rows * nxp;
        let lo_x = self.lo[0];
        self.buffers.par_iter_mut().zip(self.dirty.par_iter_mut()).enumerate().for_each(|(s, (buf, dirty))| {
            // zero only the columns the last run wrote
            let (c0, c1) = *dirty;
            if c1 > c0 {
                for row in buf.chunks_exact_mut(nxp) {
                    row[c0..c1].iter_mut().for_each(|b| *b = 0.0);
                }
            }
            let pts_s = &order[start[s]..start[s + 1]];
            *dirty = (0, 0);
            if pts_s.is_empty() {
                return;
            }
            let row0 = (first + s) as isize * rps - PAD as isize; // lattice row of buffer row 0
            let at = Place { plane, nxp, row0, lo_x, h };
            let (mut lo, mut hi) = (usize::MAX, 0);
            for &p in pts_s {
                let (l, r) = match shape {
                    Shape::Linear => scatter_point::<2>(buf, &at, grid, shape, pts, p as usize),
                    Shape::Quadratic => scatter_point::<3>(buf, &at, grid, shape, pts, p as usize),
                };
                lo = lo.min(l);
                hi = hi.max(r);
            }
            *dirty = (lo, hi);
        });
        // reduce stripe buffers into the padded lattices, row by row in stripe order
        let (nyp, lo_y) = (self.nyp, self.lo[1]);
        let (buffers, dirty) = (&self.buffers, &self.dirty);
        let stripes = self.stripes;
        self.padded.par_chunks_mut(nxp).enumerate().for_each(|(k, row)| {
            let (c, jp) = (k / nyp, k % nyp);
            let j = jp as isize + lo_y;
            row.iter_mut().for_each(|r| *r = 0.0);
            for (s, buf) in buffers.iter().enumerate().take(stripes) {
                let row0 = (first + s) as isize * rps - PAD as isize;
                let (c0, c1) = dirty[s];
                if j < row0 || j >= row0 + rows as isize || c1 <= c0 {
                    continue;
                }
                let off = c * rows * nxp + (j - row0) as usize * nxp;
                for (r, b) in row[c0..c1].iter_mut().zip(&buf[off + c0..off + c1]) {
                    *r += b;
                }
            }
        });
        self.fold(grid, bc);
    }

    /// Folds ghost contributions into the domain: wrap on periodic sides, mirror at walls
    /// (the normal momentum changes sign in its mirror image), in the order of [`fold_plan`].
    fn fold(&mut self, grid: &Grid, bc: &Boundaries) {
        match grid.part.block() {
            None => fold_plan(self.n, [bc.periodic(0), bc.periodic(1)], |e| self.apply(&e, None)),
            // (the block's boundaries have `Halo` sides at its cuts: the domain's axes)
            Some((rg, _)) => self.fold_ranks(&grid.part, [rg.periodic[0], rg.periodic[1]]),
        }
    }

    /// Adds a ghost node's sum (`value`, else this window's) to its target.
    #[inline]
    fn apply(&mut self, e: &Fold, value: Option<Real>) {
        let val = value.unwrap_or_else(|| self.at(e.channel, e.ghost[0], e.ghost[1]));
        if e.copy {
            // face n of a periodic axis is face 0
            *self.at_mut(e.channel, e.target[0], e.target[1]) += val;
            if value.is_none() {
                *self.at_mut(e.channel, e.ghost[0], e.ghost[1]) = self.at(e.channel, e.target[0], e.target[1]);
            }
        } else if val != 0.0 {
            *self.at_mut(e.channel, e.target[0], e.target[1]) += e.sign * val;
        }
    }

    /// The fold on a rank's block: the steps of [`fold_plan`] whose target it owns, in
    /// order, each ghost node's sum read from the window of the rank that holds it
    /// complete ([`holder`]), sent in a first pass.
    fn fold_ranks(&mut self, part: &Part, periodic: [bool; 2]) {
        let (rg, _) = part.block().expect("a decomposed grid");
        let (me, n) = (part.rank(), self.n);
        let holder = |g: [isize; 2]| {
            let c = std::array::from_fn(|a| g[a].clamp(0, n[a] as isize - 1));
            rg.owner(Lattice::Cell, c).expect("a node of the domain")
        };
        let owner = |e: &Fold| rg.owner(channel_lattice(e.channel), e.target).expect("a node of the domain");
        let mut sends: BTreeMap<usize, Vec<Real>> = BTreeMap::new();
        let mut receives: BTreeMap<usize, usize> = BTreeMap::new();
        fold_plan(self.n, periodic, |e| {
            let (from, to) = (holder(e.ghost), owner(&e));
            if from == me && to != me {
                sends.entry(to).or_default().push(self.at(e.channel, e.ghost[0], e.ghost[1]));
            } else if to == me && from != me {
                *receives.entry(from).or_default() += 1;
            }
        });
        let out: Vec<(usize, Tag, &[Real])> = sends.iter().map(|(&r, v)| (r, FOLD_TAG, &v[..])).collect();
        let from: Vec<(usize, Tag)> = receives.keys().map(|&r| (r, FOLD_TAG)).collect();
        let got = part.comm().exchange_f64(&out, &from);
        let mut got: BTreeMap<usize, std::vec::IntoIter<Real>> =
            from.iter().zip(got).map(|(&(r, _), v)| (r, v.into_iter())).collect();
        fold_plan(self.n, periodic, |e| {
            if owner(&e) != me {
                return;
            }
            let from = holder(e.ghost);
            let value = (from != me).then(|| got.get_mut(&from).and_then(|v| v.next()).expect("the fold's message"));
            self.apply(&e, value);
        });
    }
}

/// One step of the fold: channel `channel` of ghost node `ghost` added to domain node
/// `target` with `sign`; or, `copy`, face n of a periodic axis (`ghost`) added to face 0
/// (`target`) and set to the sum.
struct Fold {
    channel: usize,
    ghost: [isize; 2],
    target: [isize; 2],
    sign: Real,
    copy: bool,
}

/// The lattice of a channel.
fn channel_lattice(c: usize) -> Lattice {
    match c {
        MASS_U | MOM_U | FORCE_U => Lattice::XFace,
        MASS_V | MOM_V | FORCE_V => Lattice::YFace,
        _ => Lattice::Cell,
    }
}

/// Calls `f` with every step of the fold of a domain of `n` cells, in the serial order: per
/// channel, the ghost rows whole and the ghost columns of the other rows, row by row; then
/// the copies of face n of a periodic axis.
fn fold_plan(n: [usize; 2], periodic: [bool; 2], mut f: impl FnMut(Fold)) {
    let (nx, ny) = (n[0] as isize, n[1] as isize);
    let pad = PAD as isize;
    for c in 0..CHANNELS {
        let lattice = channel_lattice(c);
        let (fx, fy) = (lattice == Lattice::XFace, lattice == Lattice::YFace);
        // the component normal to the side it is mirrored across changes sign
        let normal = match c {
            MOM_U => Some(0),
            MOM_V => Some(1),
            _ => None,
        };
        let (ni, nj) = (if fx { nx + 1 } else { nx }, if fy { ny + 1 } else { ny });
        for jg in -pad..(ny + 1 + pad) {
            let row_outside = jg < 0 || jg >= nj;
            // a ghost row whole, else its ghost columns only (in the same order)
            let (left, right) = if row_outside { (nx + 1 + pad, nx + 1 + pad) } else { (0, ni) };
            for ig in (-pad..left).chain(right..(nx + 1 + pad)) {
                let (i, sx) = map_axis(ig, n[0], fx, periodic[0]);
                let (j, sy) = map_axis(jg, n[1], fy, periodic[1]);
                let sign = match normal {
                    Some(0) if sx => -1.0,
                    Some(1) if sy => -1.0,
                    _ => 1.0,
                };
                f(Fold { channel: c, ghost: [ig, jg], target: [i, j], sign, copy: false });
            }
        }
        if fx && periodic[0] {
            for j in 0..nj {
                f(Fold { channel: c, ghost: [nx, j], target: [0, j], sign: 1.0, copy: true });
            }
        }
        if fy && periodic[1] {
            for i in 0..ni {
                f(Fold { channel: c, ghost: [i, ny], target: [i, 0], sign: 1.0, copy: true });
            }
        }
    }
}

/// Where a stripe buffer lies: channel planes of `plane` values, rows of `nxp`, lattice row
/// `row0` at buffer row 0 and lattice column `lo_x` at buffer column 0; the cell side `h`.
#[derive(Clone, Copy)]
struct Place {
    plane: usize,
    nxp: usize,
    row0: isize,
    lo_x: isize,
    h: Real,
}

/// Scatters point `p` into the stripe buffer `buf` at `at`, with a shape of `NS` nodes.
/// Every stencil lies in the buffer (two ghost columns and rows on each side): direct
/// row-wise indexing. Returns the buffer columns [c0, c1) written.
#[allow(clippy::needless_range_loop)] // indexes weights and buffer rows by the same node
#[inline(always)]
fn scatter_point<const NS: usize>(
    buf: &mut [Real],
    at: &Place,
    grid: &Grid,
    shape: Shape,
    pts: &PointsIn,
    p: usize,
) -> (usize, usize) {
    let Place { plane, nxp, row0, lo_x, h } = *at;
    let w = point_weights(shape, grid, pts.x[p]);
    let (m, v, vol) = (pts.m[p], pts.v[p], pts.vol[p]);
    let (cu, cv) = pts.affine.map_or((Vector::zeros(), Vector::zeros()), |(cu, cv)| (cu[p], cv[p]));
    let sigma = pts.stress.map(|s| s[p]);
    let col = |i: isize| (i - lo_x) as usize;
    let brow = |j: isize| (j - row0) as usize * nxp;
    let lay = Layout { plane, nxp, row0, lo_x, h, xi: w.xi, m };
    // −V σ_k· ∇S with ∇S = (wx' wy, wx wy')/h: the factors V σ_k0/h, V σ_k1/h
    let force = |k: usize| sigma.map(|sg| (vol * sg[(k, 0)] / h, vol * sg[(k, 1)] / h));
    // x-faces: x at integer nodes, y at half nodes; y-faces: x at half nodes, y at integer nodes
    let (xo, yo) = (Vector::new(0.0, 0.5), Vector::new(0.5, 0.0));
    let (xc, yc) = ([MASS_U, MOM_U, FORCE_U], [MASS_V, MOM_V, FORCE_V]);
    match (force(0), force(1)) {
        (Some(fx), Some(fy)) => {
            scatter_lattice::<NS, true>(buf, &lay, &w.xf, &w.yc, xo, v.x, cu, xc, fx);
            scatter_lattice::<NS, true>(buf, &lay, &w.xc, &w.yf, yo, v.y, cv, yc, fy);
        }
        _ => {
            scatter_lattice::<NS, false>(buf, &lay, &w.xf, &w.yc, xo, v.x, cu, xc, (0.0, 0.0));
            scatter_lattice::<NS, false>(buf, &lay, &w.xc, &w.yf, yo, v.y, cv, yc, (0.0, 0.0));
        }
    }
    // cells
    for b in 0..NS {
        let o = VOLUME * plane + brow(w.yc.base + b as isize) + col(w.xc.base);
        let vw = vol * w.yc.w[b];
        let cell = &mut buf[o..o + NS];
        for a in 0..NS {
            cell[a] += vw * w.xc.w[a];
        }
    }
    let lo = col(w.xf.base.min(w.xc.base));
    (lo, col(w.xf.base.max(w.xc.base)) + NS)
}

/// Where a point's stencil goes in a stripe buffer, and the point's mass.
struct Layout {
    plane: usize,
    nxp: usize,
    row0: isize,
    lo_x: isize,
    h: Real,
    xi: Vector,
    m: Real,
}

/// One face lattice of a point's scatter (nodes at `off` + integers): mass, momentum with
/// the APIC term c·(x_i − x_p), and with `FORCE` the force −(f0 wx' wy + f1 wx wy'),
/// `force` = (f0, f1).
#[allow(clippy::too_many_arguments)]
#[allow(clippy::needless_range_loop)] // indexes weights and buffer rows by the same node
#[inline(always)]
fn scatter_lattice<const NS: usize, const FORCE: bool>(
    buf: &mut [Real],
    lay: &Layout,
    wx: &Weights1,
    wy: &Weights1,
    off: Vector,
    vel: Real,
    c: Vector,
    chans: [usize; 3],
    force: (Real, Real),
) {
    let (h, m) = (lay.h, lay.m);
    let dx: [Real; NS] = std::array::from_fn(|a| ((wx.base + a as isize) as Real + off.x - lay.xi.x) * h);
    let mx: [Real; NS] = std::array::from_fn(|a| m * wx.w[a]);
    let mxd: [Real; NS] = std::array::from_fn(|a| mx[a] * c.x * dx[a]);
    for b in 0..NS {
        let j = wy.base + b as isize;
        let o = (j - lay.row0) as usize * lay.nxp + (wx.base - lay.lo_x) as usize;
        let dy = (j as Real + off.y - lay.xi.y) * h;
        let mom0 = vel + c.y * dy;
        let wyb = wy.w[b];
        let mass = &mut buf[chans[0] * lay.plane + o..chans[0] * lay.plane + o + NS];
        for a in 0..NS {
            mass[a] += mx[a] * wyb;
        }
        let mom = &mut buf[chans[1] * lay.plane + o..chans[1] * lay.plane + o + NS];
        for a in 0..NS {
            mom[a] += wyb * (mx[a] * mom0 + mxd[a]);
        }
        if FORCE {
            let (s0, s1) = (force.0 * wyb, force.1 * wy.dw[b]);
            let f = &mut buf[chans[2] * lay.plane + o..chans[2] * lay.plane + o + NS];
            for a in 0..NS {
                f[a] -= s0 * wx.dw[a] + s1 * wx.w[a];
            }
        }
    }
}

/// Maps a ghost node index along one axis into the domain: `(index, mirrored)`.
/// `faces`: nodes at integer positions 0..=n (else at k + ½, k = 0..n−1).
#[inline]
pub fn map_axis(k: isize, n: usize, faces: bool, periodic: bool) -> (isize, bool) {
    let n = n as isize;
    if periodic {
        return (k.rem_euclid(n), false);
    }
    if faces {
        if k < 0 {
            (-k, true)
        } else if k > n {
            (2 * n - k, true)
        } else {
            (k, false)
        }
    } else if k < 0 {
        (-1 - k, true)
    } else if k >= n {
        (2 * n - 1 - k, true)
    } else {
        (k, false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::boundary::Boundary;

    /// Deterministic points in [lo, hi)² with velocities, masses, volumes, APIC rows and
    /// stresses from a small linear congruential generator.
    struct Cloud {
        x: Vec<Vector>,
        v: Vec<Vector>,
        m: Vec<Real>,
        vol: Vec<Real>,
        cu: Vec<Vector>,
        cv: Vec<Vector>,
        stress: Vec<Matrix>,
    }

    fn cloud(n: usize, seed: u64, lo: Vector, hi: Vector) -> Cloud {
        let mut s = seed;
        let mut r = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as Real / (1u64 << 53) as Real
        };
        let mut c = Cloud { x: vec![], v: vec![], m: vec![], vol: vec![], cu: vec![], cv: vec![], stress: vec![] };
        for _ in 0..n {
            c.x.push(Vector::new(lo.x + (hi.x - lo.x) * r(), lo.y + (hi.y - lo.y) * r()));
            c.v.push(Vector::new(r() - 0.5, r() - 0.5));
            c.m.push(0.5 + r());
            c.vol.push(0.5 + r());
            c.cu.push(Vector::new(r(), r()));
            c.cv.push(Vector::new(r(), r()));
            c.stress.push(Matrix::new(r(), r(), r(), r()));
        }
        c
    }

    fn run(s: &mut Scatter, g: &Grid, bc: &Boundaries, shape: Shape, c: &Cloud) -> Vec<Real> {
        s.run(
            g,
            bc,
            shape,
            &PointsIn { x: &c.x, v: &c.v, m: &c.m, vol: &c.vol, affine: Some((&c.cu, &c.cv)), stress: Some(&c.stress) },
        );
        s.padded.clone()
    }

    /// A scatter reused after a run over other points (other stripes, other columns, the
    /// ghost layers at walls and periodic sides) gives the same bits as a fresh one: the
    /// columns a stripe wrote last time are cleared, and nothing else was written.
    #[test]
    fn a_reused_scatter_matches_a_fresh_one_bit_for_bit() {
        let g = Grid::new(24, 20, 0.1, Vector::zeros());
        let walls = Boundaries::default();
        let periodic = Boundaries {
            left: Boundary::Periodic,
            right: Boundary::Periodic,
            bottom: Boundary::Periodic,
            top: Boundary::Periodic,
        };
        let (size, o) = (g.size(), Vector::zeros());
        for bc in [walls, periodic] {
            for shape in [Shape::Linear, Shape::Quadratic] {
                // first: points everywhere, hugging every side; then: a band in the middle
                // and a corner, so that most stripes and columns of the first run are empty
                let a = cloud(3000, 1, o, size);
                let b1 = cloud(200, 2, Vector::new(0.9, 0.7), Vector::new(1.3, 1.1));
                let b2 = cloud(50, 3, Vector::new(2.2, 1.8), size);
                let b = Cloud {
                    x: [b1.x, b2.x].concat(),
                    v: [b1.v, b2.v].concat(),
                    m: [b1.m, b2.m].concat(),
                    vol: [b1.vol, b2.vol].concat(),
                    cu: [b1.cu, b2.cu].concat(),
                    cv: [b1.cv, b2.cv].concat(),
                    stress: [b1.stress, b2.stress].concat(),
                };
                let mut reused = Scatter::new(&g);
                let first = run(&mut reused, &g, &bc, shape, &a);
                let again = run(&mut reused, &g, &bc, shape, &b);
                let fresh = run(&mut Scatter::new(&g), &g, &bc, shape, &b);
                assert!(first != fresh, "the two point sets must scatter differently");
                let same = again.iter().zip(&fresh).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "{shape:?}, periodic {}: the reused scatter differs", bc.periodic(0));
                // and the masses add up: Σ over the x-faces (the periodic copy at i = nx once)
                let faces = if bc.periodic(0) { g.nx } else { g.nx + 1 };
                let mut mass = 0.0;
                for j in 0..g.ny as isize {
                    for i in 0..faces as isize {
                        mass += reused.at(MASS_U, i, j);
                    }
                }
                let total: Real = b.m.iter().sum();
                assert!((mass - total).abs() < 1e-12 * total, "{shape:?}: x-face mass {mass} against {total}");
            }
        }
    }
}
