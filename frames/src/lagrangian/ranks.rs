//! A Lagrangian field's material points on the ranks of a decomposed domain
//! (docs/design/mpi.md §5): each rank holds the points whose cell its block owns, sorted by
//! id (the serial order); points that leave the block migrate to the rank that owns their
//! new cell with every array of [`Points`]; the scatter reads the block's points and copies
//! of the neighbours' points within two cells of it ([`Cloud`]); output and checkpoints
//! gather every point in id order ([`gathered`]), so they hold the serial arrays.

use super::scatter::PointsIn;
use super::Points;
use multifield_core::grid::{Grid, Lattice};
use multifield_core::math::{Matrix, Real, Vector};
use multifield_core::parallel::Tag;
use multifield_core::part::Part;
use std::ops::Range;

const MIGRATE_TAG: Tag = 41;
const GHOST_TAG: Tag = 42;
/// Cells around a block whose points its scatter reads: a point's stencil reaches the
/// nodes of its cell's neighbours and the face beyond (the quadratic B-spline: cells
/// c − 1 … c + 2), so a node of the block is reached from two cells out at most.
const GHOST_CELLS: isize = 2;

/// The global cell of position `x` (⌊·⌋ clamped into the domain, as the scatter's stripes).
pub fn cell_of(g: &Grid, x: Vector) -> [isize; 2] {
    let xi = (x - g.origin) / g.h;
    // `as usize` truncates toward zero and saturates below at 0: ⌊·⌋ clamped at 0
    [(xi.x as usize).min(g.domain[0] - 1) as isize, (xi.y as usize).min(g.domain[1] - 1) as isize]
}

/// The rank that owns the cell of `x`.
fn owner(part: &Part, g: &Grid, x: Vector) -> usize {
    let (rg, _) = part.block().expect("a decomposed grid");
    rg.owner(Lattice::Cell, cell_of(g, x)).expect("a cell of the domain")
}

/// The other ranks whose blocks touch this rank's block (edges and corners, across
/// periodic wraps too), ascending.
pub fn neighbours(part: &Part) -> Vec<usize> {
    let (rg, block) = part.block().expect("a decomposed grid");
    let mut out = Vec::new();
    for dy in -1..=1isize {
        for dx in -1..=1isize {
            let c = [block.coords[0] as isize + dx, block.coords[1] as isize + dy];
            let inside = |a: usize| (0..rg.p[a] as isize).contains(&c[a]) || rg.periodic[a];
            if (dx, dy) == (0, 0) || !(inside(0) && inside(1)) {
                continue;
            }
            let r = rg.rank_at(std::array::from_fn(|a| c[a].rem_euclid(rg.p[a] as isize) as usize));
            if r != block.rank {
                out.push(r);
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Sends `messages` (one per neighbour, in the order of `peers`) and returns the
/// neighbours' messages to this rank, in the same order.
fn swap(part: &Part, peers: &[usize], tag: Tag, messages: &[Vec<Real>]) -> Vec<Vec<Real>> {
    let sends: Vec<(usize, Tag, &[Real])> = peers.iter().zip(messages).map(|(&r, m)| (r, tag, &m[..])).collect();
    let receives: Vec<(usize, Tag)> = peers.iter().map(|&r| (r, tag)).collect();
    part.comm().exchange_f64(&sends, &receives)
}

impl Points {
    /// The values of one point in a message (see [`Points::pack`]).
    fn record_len(&self) -> usize {
        // id, x, v, m, V⁰, F, ∇v, σ, c_u, c_v, body, and the models' state
        1 + 2 + 2 + 1 + 1 + 4 + 4 + 4 + 2 + 2 + 1 + self.widths.iter().sum::<usize>()
    }

    /// Appends every value of point `p` to `out` (the id and the body index by their bits).
    fn pack(&self, p: usize, out: &mut Vec<Real>) {
        out.push(Real::from_bits(self.id[p]));
        out.extend_from_slice(self.x[p].as_slice());
        out.extend_from_slice(self.v[p].as_slice());
        out.push(self.m[p]);
        out.push(self.vol0[p]);
        for m in [&self.f[p], &self.grad_v[p], &self.stress[p]] {
            out.extend_from_slice(m.as_slice());
        }
        out.extend_from_slice(self.c_u[p].as_slice());
        out.extend_from_slice(self.c_v[p].as_slice());
        out.push(Real::from_bits(self.body[p] as u64));
        for (state, &w) in self.model_state.iter().zip(&self.widths) {
            out.extend_from_slice(&state[w * p..w * (p + 1)]);
        }
    }

    /// Appends the point packed in `r` by [`Points::pack`].
    fn unpack(&mut self, r: &[Real]) {
        let vector = |k: usize| Vector::new(r[k], r[k + 1]);
        let matrix = |k: usize| Matrix::from_column_slice(&r[k..k + 4]);
        self.id.push(r[0].to_bits());
        self.x.push(vector(1));
        self.v.push(vector(3));
        self.m.push(r[5]);
        self.vol0.push(r[6]);
        self.f.push(matrix(7));
        self.grad_v.push(matrix(11));
        self.stress.push(matrix(15));
        self.c_u.push(vector(19));
        self.c_v.push(vector(21));
        self.body.push(r[23].to_bits() as u32);
        let mut k = 24;
        for (state, &w) in self.model_state.iter_mut().zip(&self.widths) {
            state.extend_from_slice(&r[k..k + w]);
            k += w;
        }
    }

    /// Empty arrays with the same stress models' state.
    fn emptied(&self) -> Points {
        Points {
            model_state: vec![Vec::new(); self.model_state.len()],
            widths: self.widths.clone(),
            ..Points::default()
        }
    }

    /// The points for which `keep(p)` holds, in their order.
    pub(super) fn select(&self, keep: impl Fn(usize) -> bool) -> Points {
        let mut out = self.emptied();
        let mut r = Vec::with_capacity(self.record_len());
        for p in (0..self.len()).filter(|&p| keep(p)) {
            r.clear();
            self.pack(p, &mut r);
            out.unpack(&r);
        }
        out
    }
}

/// Moves every point whose cell another rank owns to that rank, and takes the points the
/// neighbours send; the points stay sorted by id. Every rank calls it. An error (on every
/// rank) when a point went beyond the neighbouring blocks in one step.
pub fn migrate(points: &mut Points, g: &Grid) -> Result<(), String> {
    let part = &g.part;
    let peers = neighbours(part);
    let me = part.rank();
    let dest: Vec<usize> = points.x.iter().map(|&x| owner(part, g, x)).collect();
    let far = dest.iter().position(|&r| r != me && peers.binary_search(&r).is_err());
    if part.any(far.is_some()) {
        return Err(match far {
            Some(p) => format!(
                "point {} moved from rank {me}'s block to rank {}'s, beyond the neighbouring blocks, in one step: \
                 lower the time step (`time.cfl`, `time.max_dt`) or use fewer ranks",
                points.id[p], dest[p]
            ),
            None => "a point moved beyond the neighbouring blocks in one step on another rank (that rank names it): \
                     lower the time step (`time.cfl`, `time.max_dt`) or use fewer ranks"
                .into(),
        });
    }
    let mut out = vec![Vec::new(); peers.len()];
    for (p, &r) in dest.iter().enumerate().filter(|(_, &r)| r != me) {
        let k = peers.binary_search(&r).expect("a neighbour");
        points.pack(p, &mut out[k]);
    }
    let got = swap(part, &peers, MIGRATE_TAG, &out);
    if out.iter().all(|m| m.is_empty()) && got.iter().all(|m| m.is_empty()) {
        return Ok(());
    }
    let width = points.record_len();
    let mut arriving: Vec<&[Real]> = got.iter().flat_map(|m| m.chunks_exact(width)).collect();
    arriving.sort_unstable_by_key(|r| r[0].to_bits());
    let mut merged = points.emptied();
    let mut r = Vec::with_capacity(width);
    let mut next = arriving.into_iter().peekable();
    for p in (0..points.len()).filter(|&p| dest[p] == me) {
        while let Some(a) = next.next_if(|a| a[0].to_bits() < points.id[p]) {
            merged.unpack(a);
        }
        r.clear();
        points.pack(p, &mut r);
        merged.unpack(&r);
    }
    next.for_each(|a| merged.unpack(a));
    *points = merged;
    Ok(())
}

/// Every rank's points in id order (the serial arrays), on every rank. Every rank calls it.
pub fn gathered(points: &Points, part: &Part) -> Points {
    let width = points.record_len();
    let mut mine = Vec::with_capacity(points.len() * width);
    for p in 0..points.len() {
        points.pack(p, &mut mine);
    }
    let all = part.comm().gather_all_f64(&mine);
    let mut records: Vec<&[Real]> = all.iter().flat_map(|m| m.chunks_exact(width)).collect();
    records.sort_unstable_by_key(|r| r[0].to_bits());
    let mut out = points.emptied();
    records.into_iter().for_each(|r| out.unpack(r));
    out
}

/// A rank's points and copies of the points within two cells of its block that other ranks
/// hold, merged in id order: what the rank's scatter reads.
#[derive(Default)]
pub struct Cloud {
    id: Vec<u64>,
    x: Vec<Vector>,
    v: Vec<Vector>,
    m: Vec<Real>,
    vol: Vec<Real>,
    c_u: Vec<Vector>,
    c_v: Vec<Vector>,
    stress: Vec<Matrix>,
    affine: bool,
    with_stress: bool,
}

impl Cloud {
    /// The view the scatter reads.
    pub fn view(&self) -> PointsIn<'_> {
        PointsIn {
            x: &self.x,
            v: &self.v,
            m: &self.m,
            vol: &self.vol,
            affine: self.affine.then_some((&self.c_u[..], &self.c_v[..])),
            stress: self.with_stress.then_some(&self.stress[..]),
        }
    }

    /// The values of one point in a message: id, x, v, m, V, and c_u, c_v and σ when the
    /// scatter reads them.
    fn record_len(&self) -> usize {
        7 + if self.affine { 4 } else { 0 } + if self.with_stress { 4 } else { 0 }
    }

    fn clear(&mut self) {
        self.id.clear();
        self.x.clear();
        self.v.clear();
        self.m.clear();
        self.vol.clear();
        self.c_u.clear();
        self.c_v.clear();
        self.stress.clear();
    }

    fn push(&mut self, id: u64, pts: &PointsIn, p: usize) {
        self.id.push(id);
        self.x.push(pts.x[p]);
        self.v.push(pts.v[p]);
        self.m.push(pts.m[p]);
        self.vol.push(pts.vol[p]);
        if let Some((cu, cv)) = pts.affine {
            self.c_u.push(cu[p]);
            self.c_v.push(cv[p]);
        }
        if let Some(s) = pts.stress {
            self.stress.push(s[p]);
        }
    }

    fn push_record(&mut self, r: &[Real]) {
        self.id.push(r[0].to_bits());
        self.x.push(Vector::new(r[1], r[2]));
        self.v.push(Vector::new(r[3], r[4]));
        self.m.push(r[5]);
        self.vol.push(r[6]);
        let mut k = 7;
        if self.affine {
            self.c_u.push(Vector::new(r[k], r[k + 1]));
            self.c_v.push(Vector::new(r[k + 2], r[k + 3]));
            k += 4;
        }
        if self.with_stress {
            self.stress.push(Matrix::from_column_slice(&r[k..k + 4]));
        }
    }

    /// Fills the cloud with this rank's points `pts` (ids `id`, ascending) and the
    /// neighbours' points within two cells of its block. Every rank calls it.
    pub fn fill(&mut self, g: &Grid, pts: &PointsIn, id: &[u64]) {
        let part = &g.part;
        let (rg, block) = part.block().expect("a decomposed grid");
        let peers = neighbours(part);
        (self.affine, self.with_stress) = (pts.affine.is_some(), pts.stress.is_some());
        // each neighbour's cells widened by two, without wrapping: a point across a
        // periodic wrap reaches the neighbour's nodes through the scatter's fold
        let reach = |r: usize| -> [Range<isize>; 2] {
            let c = rg.block(r).cells;
            std::array::from_fn(|a| c[a].start as isize - GHOST_CELLS..c[a].end as isize + GHOST_CELLS)
        };
        let near: Vec<[Range<isize>; 2]> = peers.iter().map(|&r| reach(r)).collect();
        let inner: [Range<isize>; 2] = std::array::from_fn(|a| {
            block.cells[a].start as isize + GHOST_CELLS..block.cells[a].end as isize - GHOST_CELLS
        });
        let mut out = vec![Vec::new(); peers.len()];
        for p in 0..pts.x.len() {
            let c = cell_of(g, pts.x[p]);
            if inner[0].contains(&c[0]) && inner[1].contains(&c[1]) {
                continue;
            }
            for (k, n) in near.iter().enumerate() {
                if n[0].contains(&c[0]) && n[1].contains(&c[1]) {
                    let o = &mut out[k];
                    o.push(Real::from_bits(id[p]));
                    o.extend_from_slice(pts.x[p].as_slice());
                    o.extend_from_slice(pts.v[p].as_slice());
                    o.push(pts.m[p]);
                    o.push(pts.vol[p]);
                    if let Some((cu, cv)) = pts.affine {
                        o.extend_from_slice(cu[p].as_slice());
                        o.extend_from_slice(cv[p].as_slice());
                    }
                    if let Some(s) = pts.stress {
                        o.extend_from_slice(s[p].as_slice());
                    }
                }
            }
        }
        let got = swap(part, &peers, GHOST_TAG, &out);
        let width = self.record_len();
        let mut ghosts: Vec<&[Real]> = got.iter().flat_map(|m| m.chunks_exact(width)).collect();
        ghosts.sort_unstable_by_key(|r| r[0].to_bits());
        self.clear();
        let mut next = ghosts.into_iter().peekable();
        for (p, &i) in id.iter().enumerate() {
            while let Some(r) = next.next_if(|r| r[0].to_bits() < i) {
                self.push_record(r);
            }
            self.push(i, pts, p);
        }
        next.for_each(|r| self.push_record(r));
    }
}
