//! A rank's part of a decomposed domain (docs/design/mpi.md §2): its block of the rank
//! grid, the ranks' [`Comm`], and the three things every kernel of a step needs from them:
//! the halo exchange of its lattices, the owned nodes its reductions run over, and the
//! reductions across the ranks.
//!
//! A [`Grid`](crate::grid::Grid) carries its `Part`: the whole domain (one rank, no halo,
//! every node owned; every call below a copy or nothing, the serial code's bits), or one
//! block of P stored in the [`Layout::Local`] layout (H halo layers on the sides that face
//! another rank only). Kernels work on the block's storage as on a domain whose halo sides
//! are [`Boundary::Halo`](crate::boundary::Boundary::Halo); what they compute at halo nodes
//! is never read before the next exchange.

use crate::decomposition::{Block, RankGrid};
use crate::exact::{row_groups, ExactSum, Sums, EXPORTED_WORDS, GROUP};
use crate::grid::Lattice;
use crate::halo::{self, Layout};
use crate::math::{Index, Real, DIM};
use crate::parallel::{Comm, Serial};
use std::ops::Range;
use std::sync::Arc;

/// This rank's part of the domain (see the module's documentation).
#[derive(Clone, Default)]
pub struct Part(Option<Arc<Ranked>>);

/// A block of a decomposed domain and its ranks.
struct Ranked {
    comm: Arc<dyn Comm>,
    grid: RankGrid,
    block: Block,
}

static SERIAL: Serial = Serial;

impl Part {
    /// The whole domain on one rank.
    pub fn whole() -> Self {
        Self(None)
    }

    /// Rank `comm.rank()`'s block of `grid`.
    pub fn of(comm: Arc<dyn Comm>, grid: RankGrid) -> Self {
        let block = grid.block(comm.rank());
        Self(Some(Arc::new(Ranked { comm, grid, block })))
    }

    /// This rank's part of the domain coarsened 2:1 ([`RankGrid::coarsened`]: the next
    /// multigrid level's blocks), `None` for the whole domain or where the cuts are odd.
    pub fn coarsened(&self) -> Option<Self> {
        let r = self.0.as_ref()?;
        let grid = r.grid.coarsened()?;
        let block = grid.block(r.block.rank);
        Some(Self(Some(Arc::new(Ranked { comm: r.comm.clone(), grid, block }))))
    }

    /// Whether this is the whole domain on one rank.
    pub fn is_whole(&self) -> bool {
        self.0.is_none()
    }

    /// The ranks' communicator ([`Serial`] for the whole domain).
    pub fn comm(&self) -> &dyn Comm {
        match &self.0 {
            Some(r) => &*r.comm,
            None => &SERIAL,
        }
    }

    /// This rank (0 for the whole domain).
    pub fn rank(&self) -> usize {
        self.comm().rank()
    }

    /// The number of ranks.
    pub fn ranks(&self) -> usize {
        self.comm().size()
    }

    /// The rank grid and this rank's block (`None` for the whole domain).
    pub fn block(&self) -> Option<(&RankGrid, &Block)> {
        self.0.as_ref().map(|r| (&r.grid, &r.block))
    }

    /// The padding of the low and the high side of the storage along `axis`.
    pub fn pads(&self, axis: usize) -> [usize; 2] {
        match &self.0 {
            Some(r) => Layout::Local.pads(&r.block, axis),
            None => [0, 0],
        }
    }

    /// Fills the halo of every array (a lattice's storage on this part) with its owners'
    /// values. Every rank calls it with the same lattices in the same order; nothing to do
    /// for the whole domain.
    pub fn exchange<T: Word>(&self, arrays: &mut [(Lattice, &mut [T])]) {
        if let Some(r) = &self.0 {
            halo::exchange(&*r.comm, &r.block, Layout::Local, arrays);
        }
    }

    /// The row groups of the owned nodes of a lattice of storage shape `shape` (the
    /// reduction rule, docs/design/mpi.md §3), `width` nodes wide.
    pub fn groups(&self, lattice: Lattice, shape: Index, width: usize) -> RowGroups {
        match &self.0 {
            Some(r) => {
                let owned = halo::owned(&r.block, Layout::Local, lattice);
                debug_assert_eq!(shape, halo::storage_shape(&r.block, Layout::Local, lattice));
                RowGroups { shape, cells_x: r.block.cells[0].len(), owned, width }
            }
            None => RowGroups::whole(lattice, shape, width),
        }
    }

    /// Stage 3 of the reduction rule across the ranks: every rank's sums added as integers
    /// (one collective for the `K` sums), rounded once. The same bits on every rank, and as
    /// the serial sum of the same groups.
    pub fn reduce<const K: usize>(&self, sums: Sums<K>) -> [f64; K] {
        match &self.0 {
            None => crate::exact::reduce(&sums),
            Some(r) => {
                let mut words: Vec<i64> = sums.0.iter().flat_map(|s| s.words()).collect();
                r.comm.sum_words(&mut words);
                std::array::from_fn(|k| {
                    let w: &[i64; EXPORTED_WORDS] =
                        words[k * EXPORTED_WORDS..(k + 1) * EXPORTED_WORDS].try_into().expect("the words of a sum");
                    ExactSum::from_words(w).round()
                })
            }
        }
    }

    /// Σ a b over the owned nodes of a lattice stored as `shape`, by the reduction rule.
    pub fn dot(&self, lattice: Lattice, shape: Index, a: &[Real], b: &[Real]) -> Real {
        let g = self.groups(lattice, shape, GROUP);
        self.reduce(g.sums(|r| [crate::exact::lanes_dot(&a[r.clone()], &b[r])]))[0]
    }

    /// Σ a over the owned nodes of a lattice stored as `shape`, by the reduction rule.
    pub fn sum(&self, lattice: Lattice, shape: Index, a: &[Real]) -> Real {
        let g = self.groups(lattice, shape, GROUP);
        self.reduce(g.sums(|r| [a[r].iter().sum()]))[0]
    }

    /// Element-wise maxima over the ranks (folded in rank order with `f64::max`).
    pub fn max(&self, values: &mut [f64]) {
        if let Some(r) = &self.0 {
            r.comm.max(values);
        }
    }

    /// Names the phase of the step that the next exchanges and reductions belong to (the
    /// traffic counters' [`Comm::phase`]).
    pub fn phase(&self, name: &'static str) {
        if let Some(r) = &self.0 {
            r.comm.phase(name);
        }
    }

    /// Whether `flag` holds on any rank.
    pub fn any(&self, flag: bool) -> bool {
        match &self.0 {
            Some(r) => r.comm.any(flag),
            None => flag,
        }
    }

    /// The largest |x| over the owned nodes of a lattice stored as `shape`, on every rank.
    pub fn max_abs(&self, lattice: Lattice, shape: Index, a: &[Real]) -> Real {
        let mut m = [self.local_max_abs(lattice, shape, a)];
        self.max(&mut m);
        m[0]
    }

    /// The largest |x| over this rank's owned nodes of a lattice stored as `shape` (to
    /// gather with others' in one [`Part::max`]).
    pub fn local_max_abs(&self, lattice: Lattice, shape: Index, a: &[Real]) -> Real {
        let g = self.groups(lattice, shape, GROUP);
        g.rows().flat_map(|r| a[r].iter()).fold(0.0, |m: Real, x| m.max(x.abs()))
    }
}

/// A value the ranks gather and scatter as bytes (`f64`, `f32`).
pub trait Word: Copy + Default + Send + Sync {
    /// Its size in bytes.
    const SIZE: usize;
    /// Appends its little-endian bytes.
    fn put(self, out: &mut Vec<u8>);
    /// Reads it from its little-endian bytes.
    fn get(bytes: &[u8]) -> Self;
}

macro_rules! word {
    ($t:ty) => {
        impl Word for $t {
            const SIZE: usize = std::mem::size_of::<$t>();
            fn put(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
            fn get(bytes: &[u8]) -> Self {
                <$t>::from_le_bytes(bytes.try_into().expect("a word's bytes"))
            }
        }
    };
}
word!(f64);
word!(f32);

impl Part {
    /// The domain's array of a lattice from every rank's owned nodes, on every rank (in the
    /// domain's storage; face n of a periodic axis holds face 0's value). `local` is this
    /// rank's storage of shape `shape`. For the whole domain: a copy.
    pub fn gather<T: Word>(&self, lattice: Lattice, shape: Index, local: &[T]) -> Vec<T> {
        self.gather_per(lattice, shape, local, 1)
    }

    /// [`Part::gather`] of an array of `per` consecutive values a node (a vector quantity).
    pub fn gather_per<T: Word>(&self, lattice: Lattice, shape: Index, local: &[T], per: usize) -> Vec<T> {
        let Some(r) = &self.0 else {
            return local.to_vec();
        };
        let mut mine = Vec::new();
        for rows in self.groups(lattice, shape, GROUP).rows() {
            for v in &local[rows.start * per..rows.end * per] {
                v.put(&mut mine);
            }
        }
        let all = r.comm.gather_all(&mine);
        let n = r.grid.n;
        let domain: Index = std::array::from_fn(|a| n[a] + (lattice.axis() == Some(a)) as usize);
        let mut out = vec![T::default(); domain.iter().product::<usize>() * per];
        for (rank, bytes) in all.iter().enumerate() {
            let block = r.grid.block(rank);
            let owned: [Range<usize>; DIM] = std::array::from_fn(|a| block.owned_global(lattice, a));
            let mut words = bytes.chunks_exact(T::SIZE);
            crate::halo::for_each(domain, &owned, |g| {
                for v in &mut out[g * per..(g + 1) * per] {
                    *v = T::get(words.next().expect("a rank's owned nodes"));
                }
            });
        }
        // face n of a periodic axis: face 0's copy, as serially
        if let Some(a) = lattice.axis().filter(|&a| r.grid.periodic[a]) {
            let mut low: [Range<usize>; DIM] = domain.map(|k| 0..k);
            let mut high = low.clone();
            (low[a], high[a]) = (0..1, n[a]..n[a] + 1);
            let mut sources = Vec::new();
            crate::halo::for_each(domain, &low, |g| sources.extend_from_slice(&out[g * per..(g + 1) * per]));
            let mut it = sources.into_iter();
            crate::halo::for_each(domain, &high, |g| {
                for v in &mut out[g * per..(g + 1) * per] {
                    *v = it.next().expect("a face 0 for each face n");
                }
            });
        }
        out
    }

    /// Fills every node of this rank's storage (shape `shape`) of a lattice whose global
    /// node lies in the domain, halo included, from the domain's array `global` (the
    /// inverse of [`Part::gather`]). For the whole domain: a copy.
    pub fn scatter<T: Word>(&self, lattice: Lattice, shape: Index, global: &[T], local: &mut [T]) {
        let Some(r) = &self.0 else {
            local.copy_from_slice(global);
            return;
        };
        let n = r.grid.n;
        let domain: Index = std::array::from_fn(|a| n[a] + (lattice.axis() == Some(a)) as usize);
        let pads: [usize; DIM] = std::array::from_fn(|a| self.pads(a)[0]);
        let mut at = [0usize; DIM];
        for v in local.iter_mut() {
            let mut g = 0;
            let mut stride = 1;
            let mut inside = true;
            for a in 0..DIM {
                let x = (r.block.cells[a].start + at[a]) as isize - pads[a] as isize;
                match crate::decomposition::wrap(x, n[a], r.grid.periodic[a], lattice.axis() == Some(a)) {
                    Some(x) => g += x * stride,
                    None => inside = false,
                }
                stride *= domain[a];
            }
            if inside {
                *v = global[g];
            }
            for a in 0..DIM {
                at[a] += 1;
                if at[a] < shape[a] {
                    break;
                }
                at[a] = 0;
            }
        }
    }
}

impl PartialEq for Part {
    fn eq(&self, other: &Self) -> bool {
        match (&self.0, &other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => a.block == b.block && a.grid == b.grid,
            _ => false,
        }
    }
}

impl std::fmt::Debug for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            None => write!(f, "Part::whole"),
            Some(r) => write!(f, "Part({:?} of {:?})", r.block, r.grid.p),
        }
    }
}

/// The owned nodes of a lattice's storage as row groups of the reduction rule: each
/// storage row (along x) whose coordinates along the other axes are owned contributes the
/// groups of its owned x-range, which starts at a global multiple of the width.
#[derive(Clone, Debug)]
pub struct RowGroups {
    shape: Index,
    /// Owned cells along x (the owned x-range has one node more on the high face of a
    /// face lattice along x that is not periodic).
    cells_x: usize,
    owned: [Range<usize>; DIM],
    width: usize,
}

impl RowGroups {
    /// Every node of `rows` storage rows of `len` nodes each, `cells_x` cells along x.
    pub fn rows_of(len: usize, rows: usize, cells_x: usize, width: usize) -> Self {
        let mut shape = [1; DIM];
        (shape[0], shape[1]) = (len, rows);
        Self { shape, cells_x, owned: shape.map(|s| 0..s), width }
    }

    /// Every node of a lattice stored as `shape` (the whole domain).
    pub fn whole(lattice: Lattice, shape: Index, width: usize) -> Self {
        let cells_x = shape[0] - (lattice.axis() == Some(0)) as usize;
        Self { shape, cells_x, owned: shape.map(|s| 0..s), width }
    }

    /// The storage rows.
    pub fn row_count(&self) -> usize {
        self.shape[1..].iter().product()
    }

    /// Nodes of a storage row.
    pub fn row_len(&self) -> usize {
        self.shape[0]
    }

    /// The groups of storage row `r`, as ranges within the row (none if the row is not owned).
    pub fn of_row(&self, r: usize) -> impl Iterator<Item = Range<usize>> + Clone {
        let mut rest = r;
        let mut owned = true;
        for a in 1..DIM {
            owned &= self.owned[a].contains(&(rest % self.shape[a]));
            rest /= self.shape[a];
        }
        let x = self.owned[0].clone();
        let len = if owned { x.len() } else { 0 };
        row_groups(len, self.cells_x.min(len), self.width).map(move |g| x.start + g.start..x.start + g.end)
    }

    /// The owned nodes of every owned row, as flat storage ranges.
    pub fn rows(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        let len = self.row_len();
        (0..self.row_count()).filter_map(move |r| {
            let mut g = self.of_row(r);
            let first = g.next()?;
            let last = g.last().unwrap_or(first.clone());
            Some(r * len + first.start..r * len + last.end)
        })
    }

    /// The reduction rule's sums over the owned nodes: `group(range)` gives the `K` values
    /// of the group at the flat storage indices `range`, summed in its own fixed order; the
    /// group values are added exactly (rows in parallel for big lattices).
    pub fn sums<const K: usize>(&self, group: impl Fn(Range<usize>) -> [f64; K] + Sync + Send) -> Sums<K> {
        use rayon::prelude::*;
        let len = self.row_len();
        let rows = self.row_count();
        let row = |s: &mut Sums<K>, r: usize| {
            let o = r * len;
            for g in self.of_row(r) {
                s.add(group(o + g.start..o + g.end));
            }
        };
        if len * rows >= crate::exact::PARALLEL_NODES {
            let min_rows = (4096 / len.max(1)).max(1);
            *(0..rows)
                .into_par_iter()
                .with_min_len(min_rows)
                .fold(Sums::boxed, |mut s, r| {
                    row(&mut s, r);
                    s
                })
                .reduce(Sums::boxed, Sums::merge_boxed)
        } else {
            let mut s = Sums::new();
            for r in 0..rows {
                row(&mut s, r);
            }
            s
        }
    }
}
