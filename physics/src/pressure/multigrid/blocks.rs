//! The V-cycle on a decomposed domain (docs/design/mpi.md §4): the finer levels on the
//! ranks' blocks, the coarser ones whole on every rank, each owned cell's arithmetic the
//! serial one.
//!
//! Level l lives on the rank grid coarsened l times ([`Part::coarsened`]: the cuts halved),
//! in its storage with the two-layer halo. A level is on the blocks while its cuts are
//! even (a coarse cell's four children are then one rank's: the restriction and the
//! prolongation are the serial per-cell maps) and the domain has a level below it; the
//! decomposition aligns the cuts so for its first L levels (docs/design/mpi.md §2). On a
//! block level each red-black sweep goes colour by colour with the halo exchanged before
//! each colour ([`relax_colour`]); the residual is restricted to the block's coarse cells,
//! which have one halo cell at a cut (half the fine halo): re-padded into the next level's
//! storage, its two halo layers exchanged; back up, the next level's correction is copied
//! back for the prolongation (its first halo layer, the one read, is the owners': the last
//! colour relaxed it from exchanged neighbours). Below the last block level the
//! restricted residual is gathered onto every rank, which all run the rest of the cycle
//! whole (the same small problem everywhere: each rank reads its block's part of the
//! correction, nothing is sent back).
//!
//! Set-up: each block level's operator is coarsened on the block from the one above, its
//! halo couplings and diagonal taken from their owners; the first whole level's couplings
//! are gathered. Pure Neumann: each block level's right-hand side loses its mean, summed
//! by the reduction rule over the owned cells (row groups 32/2^l cells wide, the serial
//! cycle's).

use super::{cycle, sum32, Hierarchy, Level, Op32, F};
use crate::pressure::multigrid::plane::relax_colour;
use crate::pressure::stencil::Stencil;
use multifield_core::decomposition::multigrid_levels;
use multifield_core::exact::GROUP;
use multifield_core::grid::Lattice;
use multifield_core::halo::{storage_shape, Layout};
use multifield_core::math::{Index, Real};
use multifield_core::part::{Part, Word};
use multifield_core::poisson::PoissonProblem;

/// One level of the V-cycle on a rank's block.
#[derive(Debug, Default)]
pub(super) struct BlockLevel {
    /// The level's part of the domain (the rank grid coarsened l times).
    part: Part,
    /// The level's operator on the block's storage, its halo the owners' (the levels below
    /// the finest; the finest's is the caller's).
    local: Stencil,
    /// The level's operator coarsened on the block (the next level's, on its coarse cells
    /// and one halo cell a cut).
    coarse: Stencil,
    op: Op32,
    level: Level,
    key: Option<(Index, [bool; 2])>,
    /// Right-hand side and solution on the part's storage (the levels below the finest).
    b: Vec<F>,
    x: Vec<F>,
}

/// The storage shape of a lattice on `part`'s block.
fn shape(part: &Part, lattice: Lattice) -> Index {
    storage_shape(part.block().expect("a rank's block").1, Layout::Local, lattice)
}

/// Where a block's coarse cells (its level's restriction: one halo cell on each exchanged
/// side) start in the next level's storage `coarse` (two halo cells there), along x and y.
fn offset(fine: &Part, coarse: &Part) -> [usize; 2] {
    [0, 1].map(|a| coarse.pads(a)[0] - fine.pads(a)[0] / 2)
}

/// Copies the rows of `from` (`from_x` values each) into the rows of `to` (`to_x` values
/// each) from `at` (values along x, rows along y).
fn widen<T: Copy>(from: &[T], from_x: usize, to: &mut [T], to_x: usize, at: [usize; 2]) {
    for (j, row) in from.chunks(from_x).enumerate() {
        let k = at[0] + (j + at[1]) * to_x;
        to[k..k + from_x].copy_from_slice(row);
    }
}

/// The inverse of [`widen`]: the rows of `to` (`to_x` values each) from those of `from`.
fn narrow<T: Copy>(from: &[T], from_x: usize, to: &mut [T], to_x: usize, at: [usize; 2]) {
    for (j, row) in to.chunks_mut(to_x).enumerate() {
        let k = at[0] + (j + at[1]) * from_x;
        row.copy_from_slice(&from[k..k + to_x]);
    }
}

/// `coarse` (a block's coarsened operator, one halo cell a cut) in the storage of the next
/// level's `part` (two), into `to`: couplings, Dirichlet terms, diagonal; the outer halo
/// layer is left for the exchange.
fn widen_stencil(coarse: &Stencil, at: [usize; 2], part: &Part, to: &mut Stencil) {
    let n = shape(part, Lattice::Cell);
    to.resize(n, coarse.periodic, coarse.dirichlet);
    let (cx, nx) = (coarse.nx, n[0]);
    widen(&coarse.ax, cx + 1, &mut to.ax, nx + 1, at);
    for (from, to) in [
        (&coarse.ay, &mut to.ay),
        (&coarse.extra, &mut to.extra),
        (&coarse.diag, &mut to.diag),
        (&coarse.inv_diag, &mut to.inv_diag),
    ] {
        widen(from, cx, to, nx, at);
    }
}

/// Takes the halo couplings, diagonal and inverse diagonal of a level's operator `st` on
/// `part`'s block from their owners.
fn owners_halo(part: &Part, st: &mut Stencil) {
    part.exchange(&mut [
        (Lattice::XFace, &mut st.ax),
        (Lattice::YFace, &mut st.ay),
        (Lattice::Cell, &mut st.diag),
        (Lattice::Cell, &mut st.inv_diag),
    ]);
}

impl Hierarchy {
    /// Sets up the V-cycle on a rank's block of `problem` ([`Hierarchy::setup_blocks`]) from
    /// `stencil`, the block's operator ([`Stencil::assign`]), once its halo couplings and
    /// diagonal are taken from their owners (the transfers' weights, the residual
    /// restricted from the cells next to the block and the coarse operator's faces at the
    /// cuts read them). `Ok(false)`: the levels cannot be on the blocks.
    pub fn setup_on_block(&mut self, problem: &PoissonProblem, stencil: &mut Stencil) -> Result<bool, String> {
        let g = &problem.grid;
        if g.part.coarsened().is_none() {
            return Ok(false);
        }
        owners_halo(&g.part, stencil);
        let mut dirichlet = problem.dirichlet.map(|d| d as u8 as Real);
        g.part.max(&mut dirichlet);
        self.setup_blocks(stencil, &g.part, g.domain, dirichlet.map(|d| d > 0.0))
    }

    /// Sets up the V-cycle of a decomposed domain of `domain` cells (its sides `dirichlet`)
    /// on rank `part`'s block: `fine` is the block's operator, its halo couplings and
    /// diagonal the owners'. Returns `Ok(false)` when no level can be on the blocks (the
    /// domain has no coarser level, or the cuts are odd): the caller gathers the problem.
    fn setup_blocks(
        &mut self,
        fine: &Stencil,
        part: &Part,
        domain: Index,
        dirichlet: [bool; 4],
    ) -> Result<bool, String> {
        let levels = multigrid_levels(domain);
        let mut parts = vec![part.clone()];
        let Some(mut below) = part.coarsened().filter(|_| levels >= 1) else {
            return Ok(false);
        };
        // level l is on the blocks while its cuts are even and it has a level below
        while parts.len() < levels {
            let Some(next) = below.coarsened() else { break };
            parts.push(std::mem::replace(&mut below, next));
        }
        if fine.n().iter().any(|&k| k % 2 != 0 || k < 4) {
            return Ok(false);
        }
        self.blocks.resize_with(parts.len(), Default::default);
        for (l, part) in parts.into_iter().enumerate() {
            let (above, rest) = self.blocks.split_at_mut(l);
            let bl = &mut rest[0];
            bl.part = part;
            if let Some(up) = above.last() {
                let at = offset(&up.part, &bl.part);
                widen_stencil(&up.coarse, at, &bl.part, &mut bl.local);
                owners_halo(&bl.part, &mut bl.local);
            }
            let op = if l == 0 { fine } else { &bl.local };
            let key = (op.n(), op.periodic);
            if bl.key != Some(key) {
                bl.level = Level::new(key.0, key.1);
                bl.key = Some(key);
            }
            bl.op.assign(op);
            bl.level.update_weights(op);
            bl.coarse.coarsen_from(op);
        }
        // the first whole level: every rank's owned couplings
        let last = self.blocks.last().expect("a level on the blocks");
        let n = shape(&below, Lattice::Cell);
        let mut wide = Stencil::default();
        widen_stencil(&last.coarse, offset(&last.part, &below), &below, &mut wide);
        let (rg, _) = below.block().expect("a rank's block");
        let mut whole = Stencil::default();
        whole.resize(rg.n, rg.periodic, dirichlet);
        whole.ax = below.gather(Lattice::XFace, [n[0] + 1, n[1]], &wide.ax);
        whole.ay = below.gather(Lattice::YFace, [n[0], n[1] + 1], &wide.ay);
        whole.extra = below.gather(Lattice::Cell, n, &wide.extra);
        whole.update_diagonal();
        let key = (rg.n, rg.periodic, dirichlet);
        if self.key != Some(key) {
            self.build(key.0, key.1, key.2);
        }
        self.ops[0] = whole;
        self.coarsen_below(0)?;
        Ok(true)
    }

    /// z = M r on a rank's block (after [`Hierarchy::setup_blocks`]): one V-cycle from 0,
    /// the serial one's bits on the owned cells.
    pub fn precondition_block(&mut self, r: &[F], z: &mut [F]) {
        let singular = self.ops[0].is_singular();
        block_cycle(self, 0, singular, r, z);
    }
}

/// The V-cycle from block level `l` down for A x = b on its storage, from x = 0.
fn block_cycle(h: &mut Hierarchy, l: usize, singular: bool, b: &[F], x: &mut [F]) {
    let sweeps = h.cycle.sweeps;
    let (above, rest) = h.blocks.split_at_mut(l + 1);
    let BlockLevel { part, op, level, .. } = &mut above[l];
    let exchange = |z: &mut [F]| part.exchange(&mut [(Lattice::Cell, z)]);
    for k in 0..sweeps {
        if k > 0 {
            exchange(x);
        }
        relax_colour(op, b, x, 0, k == 0);
        // from zero colour 0 is b/d on every cell: below the finest level, where b's two
        // halo layers were exchanged (and 1/d at set-up), its halo is the owners' already
        if k > 0 || l == 0 {
            exchange(x);
        }
        relax_colour(op, b, x, 1, false);
    }
    exchange(x);
    level.restrict_residual(op, x, b);
    // the next level's row groups: 32/2^(l + 1) cells wide (the serial cycle's)
    let width = (GROUP >> (l + 1)).max(1);
    let local_n = [op.nx() / 2, level.bc.len() / (op.nx() / 2)];
    if let Some(next) = rest.first_mut() {
        let n = shape(&next.part, Lattice::Cell);
        let at = offset(part, &next.part);
        let (mut nb, mut nx) = (std::mem::take(&mut next.b), std::mem::take(&mut next.x));
        nb.resize(n[0] * n[1], 0.0);
        nx.resize(n[0] * n[1], 0.0);
        widen(&level.bc, local_n[0], &mut nb, n[0], at);
        next.part.exchange(&mut [(Lattice::Cell, &mut nb)]);
        if singular {
            let groups = next.part.groups(Lattice::Cell, n, width);
            let sum = next.part.reduce(groups.sums(|g| [nb[g].iter().map(|&v| Real::from(v)).sum::<Real>()]))[0];
            let cells: usize = next.part.block().expect("a rank's block").0.n.iter().product();
            let mean = (sum / cells as Real) as F;
            nb.iter_mut().for_each(|v| *v -= mean);
        }
        // (the correction's first halo layer needs no exchange: the last colour relaxed it
        // from its neighbours, owned or in the second layer, just exchanged: the owners' bits)
        block_cycle(h, l + 1, singular, &nb, &mut nx);
        let BlockLevel { level, .. } = &mut h.blocks[l];
        narrow(&nx, n[0], &mut level.xc, local_n[0], at);
        (h.blocks[l + 1].b, h.blocks[l + 1].x) = (nb, nx);
    } else {
        let whole_n = h.ops[0].n();
        let cells = whole_n[0] * whole_n[1];
        let c = &mut h.cycle;
        let (mut wb, mut wx) = (std::mem::take(&mut c.b), std::mem::take(&mut c.x));
        wb.resize(cells, 0.0);
        wx.resize(cells, 0.0);
        gather_coarse(part, whole_n, local_n, &level.bc, &mut wb);
        if singular {
            let mean = (sum32(&wb, whole_n[0], width) / cells as Real) as F;
            wb.iter_mut().for_each(|v| *v -= mean);
        }
        cycle(&c.ops, &mut c.levels, &mut c.coarse, &mut c.coarse_x, singular, sweeps, width, &wb, &mut wx);
        read_coarse(part, whole_n, local_n, &wx, &mut level.xc);
        (c.b, c.x) = (wb, wx);
    }
    let BlockLevel { part, op, level, .. } = &mut h.blocks[l];
    let exchange = |z: &mut [F]| part.exchange(&mut [(Lattice::Cell, z)]);
    level.prolong_add(x);
    for k in 0..sweeps {
        // the prolongation keeps the first halo layer the owners' (x there was exchanged
        // before the restriction, its parents and weights are the owners'), and the owned
        // cells of colour 1 read no further
        if k > 0 {
            exchange(x);
        }
        relax_colour(op, b, x, 1, false);
        exchange(x);
        relax_colour(op, b, x, 0, false);
    }
}

/// A rank's coarse storage: its block's coarse cells and, on the sides it shares with
/// another rank, one halo cell (half the fine halo); the first coarse cell's place in the
/// domain along each axis, before a periodic wrap.
fn coarse_start(part: &Part) -> [isize; 2] {
    let block = part.block().expect("a rank's block").1;
    [0, 1].map(|a| (block.cells[a].start / 2) as isize - (part.pads(a)[0] / 2) as isize)
}

/// The coarse cells a block owns, along each axis.
fn coarse_owned(cells: &[std::ops::Range<usize>]) -> [std::ops::Range<usize>; 2] {
    [0, 1].map(|a| cells[a].start / 2..cells[a].end / 2)
}

/// Every rank's owned coarse cells of its coarse storage `local` (`local_n` cells) into
/// the whole coarse level `whole` (`whole_n` cells), on every rank.
fn gather_coarse(part: &Part, whole_n: [usize; 2], local_n: [usize; 2], local: &[F], whole: &mut [F]) {
    let (rg, block) = part.block().expect("a rank's block");
    let start = coarse_start(part);
    let mut mine = Vec::new();
    let own = coarse_owned(&block.cells);
    for j in own[1].clone() {
        for i in own[0].clone() {
            let l = (i as isize - start[0]) as usize + (j as isize - start[1]) as usize * local_n[0];
            local[l].put(&mut mine);
        }
    }
    for (rank, bytes) in part.comm().gather_all(&mine).iter().enumerate() {
        let at = coarse_owned(&rg.block(rank).cells);
        let mut words = bytes.chunks_exact(F::SIZE);
        for j in at[1].clone() {
            for i in at[0].clone() {
                whole[i + j * whole_n[0]] = F::get(words.next().expect("a rank's coarse cells"));
            }
        }
    }
}

/// Every cell of a rank's coarse storage `local` (`local_n` cells) from the whole coarse
/// level `whole` (`whole_n` cells; the halo across a periodic wrap wrapped).
fn read_coarse(part: &Part, whole_n: [usize; 2], local_n: [usize; 2], whole: &[F], local: &mut [F]) {
    let start = coarse_start(part);
    let at = |a: usize, l: usize| (start[a] + l as isize).rem_euclid(whole_n[a] as isize) as usize;
    for (l, v) in local.iter_mut().enumerate() {
        *v = whole[at(0, l % local_n[0]) + at(1, l / local_n[0]) * whole_n[0]];
    }
}
