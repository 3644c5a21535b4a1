//! Deterministic parallel particles-to-grid scatter.
//!
//! Points are binned by cell row (a stable counting sort) into horizontal stripes. Each
//! stripe scatters into its own small buffer in parallel; the buffers are then added into
//! the grid row by row, always in stripe order. No atomics, no locks: the sums are the same
//! bits for any number of threads. Lattices are padded by two ghost nodes on each side;
//! ghost contributions are folded back (wrapped on periodic sides, mirrored at walls).

use super::shape::{Shape, Weights1};
use multifield_core::boundary::Boundaries;
use multifield_core::grid::Grid;
use multifield_core::math::{Matrix, Real, Vector};
use rayon::prelude::*;

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
    nxp: usize,
    nyp: usize,
    rows_per_stripe: usize,
    stripes: usize,
    buffers: Vec<Vec<Real>>,
    /// The padded global lattices, channel-major.
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
    /// Scratch for `grid`.
    pub fn new(grid: &Grid) -> Self {
        let rows_per_stripe = 4;
        let stripes = grid.ny.div_ceil(rows_per_stripe);
        let nxp = grid.nx + 1 + 2 * PAD;
        let nyp = grid.ny + 1 + 2 * PAD;
        Self {
            nxp,
            nyp,
            rows_per_stripe,
            stripes,
            buffers: vec![vec![0.0; CHANNELS * (rows_per_stripe + 2 * PAD) * nxp]; stripes],
            padded: vec![0.0; CHANNELS * nxp * nyp],
            order: Vec::new(),
            start: vec![0; stripes + 1],
            dirty: vec![(0, 0); stripes],
        }
    }

    /// Value of channel `c` at lattice node (i, j) (both may be ghosts down to −2).
    #[inline]
    pub fn at(&self, c: usize, i: isize, j: isize) -> Real {
        self.padded[c * self.nxp * self.nyp + (i + PAD as isize) as usize + (j + PAD as isize) as usize * self.nxp]
    }
    /// Channel `c` on lattice row `j` (≥ 0), nodes i = 0..`len`.
    #[inline]
    pub fn row(&self, c: usize, j: usize, len: usize) -> &[Real] {
        let start = c * self.nxp * self.nyp + PAD + (j + PAD) * self.nxp;
        &self.padded[start..start + len]
    }
    #[inline]
    fn at_mut(&mut self, c: usize, i: isize, j: isize) -> &mut Real {
        &mut self.padded[c * self.nxp * self.nyp + (i + PAD as isize) as usize + (j + PAD as isize) as usize * self.nxp]
    }

    /// Scatters mass, momentum, internal force and volume of all points.
    pub fn run(&mut self, grid: &Grid, bc: &Boundaries, shape: Shape, pts: &PointsIn) {
        let n = pts.x.len();
        // stable counting sort by stripe
        let h = grid.h;
        let stripe_of = |x: &Vector| {
            // `as usize` truncates toward zero and saturates below at 0: ⌊·⌋ clamped at 0
            let j = (((x.y - grid.origin.y) / h) as usize).min(grid.ny - 1);
            j / self.rows_per_stripe
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
            let row0 = s as isize * rps - PAD as isize; // lattice row of buffer row 0
            let (mut lo, mut hi) = (usize::MAX, 0);
            for &p in pts_s {
                let (l, r) = match shape {
                    Shape::Linear => scatter_point::<2>(buf, plane, nxp, row0, h, grid, shape, pts, p as usize),
                    Shape::Quadratic => scatter_point::<3>(buf, plane, nxp, row0, h, grid, shape, pts, p as usize),
                };
                lo = lo.min(l);
                hi = hi.max(r);
            }
            *dirty = (lo, hi);
        });
        // reduce stripe buffers into the padded lattices, row by row in stripe order
        let nyp = self.nyp;
        let (buffers, dirty) = (&self.buffers, &self.dirty);
        let stripes = self.stripes;
        self.padded.par_chunks_mut(nxp).enumerate().for_each(|(k, row)| {
            let (c, jp) = (k / nyp, k % nyp);
            let j = jp as isize - PAD as isize;
            row.iter_mut().for_each(|r| *r = 0.0);
            for (s, buf) in buffers.iter().enumerate().take(stripes) {
                let row0 = s as isize * rps - PAD as isize;
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
    /// (the normal momentum changes sign in its mirror image).
    fn fold(&mut self, grid: &Grid, bc: &Boundaries) {
        let (px, py) = (bc.periodic(0), bc.periodic(1));
        let (nx, ny) = (grid.nx as isize, grid.ny as isize);
        // per channel: (nodes along x are faces?, nodes along y are faces?, normal axis for sign)
        let layout = |c: usize| -> (bool, bool, Option<usize>) {
            match c {
                MASS_U | FORCE_U => (true, false, None),
                MOM_U => (true, false, Some(0)),
                MASS_V | FORCE_V => (false, true, None),
                MOM_V => (false, true, Some(1)),
                _ => (false, false, None),
            }
        };
        for c in 0..CHANNELS {
            let (fx, fy, normal) = layout(c);
            let (ni, nj) = (if fx { nx + 1 } else { nx }, if fy { ny + 1 } else { ny });
            let pad = PAD as isize;
            for jg in -pad..(ny + 1 + pad) {
                let row_outside = jg < 0 || jg >= nj;
                // a ghost row whole, else its ghost columns only (in the same order)
                let (left, right) = if row_outside { (nx + 1 + pad, nx + 1 + pad) } else { (0, ni) };
                for ig in (-pad..left).chain(right..(nx + 1 + pad)) {
                    let val = self.at(c, ig, jg);
                    if val == 0.0 {
                        continue;
                    }
                    let (i, sx) = map_axis(ig, grid.nx, fx, px);
                    let (j, sy) = map_axis(jg, grid.ny, fy, py);
                    let sign = match normal {
                        Some(0) if sx => -1.0,
                        Some(1) if sy => -1.0,
                        _ => 1.0,
                    };
                    *self.at_mut(c, ig, jg) = 0.0;
                    *self.at_mut(c, i, j) += sign * val;
                }
            }
            // a periodic face lattice: node n is node 0
            if fx && px {
                for j in 0..nj {
                    let v = self.at(c, nx, j);
                    *self.at_mut(c, 0, j) += v;
                    *self.at_mut(c, nx, j) = self.at(c, 0, j);
                }
            }
            if fy && py {
                for i in 0..ni {
                    let v = self.at(c, i, ny);
                    *self.at_mut(c, i, 0) += v;
                    *self.at_mut(c, i, ny) = self.at(c, i, 0);
                }
            }
        }
    }
}

/// Scatters point `p` into the stripe buffer `buf` (channel planes of `plane` values, rows of
/// `nxp`, lattice row `row0` at buffer row 0), with a shape of `NS` nodes. Every stencil lies
/// in the buffer (two ghost columns and rows on each side): direct row-wise indexing.
/// Returns the buffer columns [c0, c1) written.
#[allow(clippy::too_many_arguments)]
#[allow(clippy::needless_range_loop)] // indexes weights and buffer rows by the same node
#[inline(always)]
fn scatter_point<const NS: usize>(
    buf: &mut [Real],
    plane: usize,
    nxp: usize,
    row0: isize,
    h: Real,
    grid: &Grid,
    shape: Shape,
    pts: &PointsIn,
    p: usize,
) -> (usize, usize) {
    let w = point_weights(shape, grid, pts.x[p]);
    let (m, v, vol) = (pts.m[p], pts.v[p], pts.vol[p]);
    let (cu, cv) = pts.affine.map_or((Vector::zeros(), Vector::zeros()), |(cu, cv)| (cu[p], cv[p]));
    let sigma = pts.stress.map(|s| s[p]);
    let col = |i: isize| (i + PAD as isize) as usize;
    let brow = |j: isize| (j - row0) as usize * nxp;
    let lay = Layout { plane, nxp, row0, h, xi: w.xi, m };
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
        let o = (j - lay.row0) as usize * lay.nxp + (wx.base + PAD as isize) as usize;
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
