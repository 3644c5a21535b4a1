//! The halo exchange: every rank's copy of the [`HALO`] layers of nodes its neighbours own
//! next to its block (docs/design/mpi.md §2).
//!
//! A lattice on a block is stored as the block's lattice padded along each axis, x fastest,
//! in one of two [`Layout`]s: `Padded`, H = 2 nodes on every side (the layout of the
//! Eulerian frame's padded arrays), or `Local`, H nodes only on the sides that face another
//! rank (the local `Grid` of §2: a side of the domain, and a periodic axis with one block,
//! whose wrap stays within the rank as serially, have none). Storage node `l` along axis a
//! is global node `cells[a].start − pad + l` (pad: the low side's). The owned nodes are
//! [`Block::owned_global`]; the halo is the padding on the sides that are exchanged (those
//! with a neighbour, in `Padded` also the rank itself across a periodic axis it spans
//! alone): H nodes on the low side, and on the high side H (cells) or H + 1 (faces along
//! their own axis, which reach the far face of the last halo cell). Padding beyond a side
//! of the domain that is not periodic belongs to nobody and is left as it is (the boundary
//! rules fill it).
//!
//! [`exchange`] works axis by axis: along x the owned rows; along y the rows with their x
//! halo; along z with both, so edges and corners arrive through two or three messages. One
//! message a neighbour and axis carries every array of the call; its tag is its direction
//! (2 a to the low side, 2 a + 1 to the high side), so two ranks that are each other's
//! neighbour on both sides of a periodic axis, or a rank that is its own, tell them apart.

use crate::decomposition::{Block, HALO};
use crate::grid::Lattice;
use crate::math::{Index, AXES, DIM};
use crate::parallel::{Comm, Tag};
use crate::part::Word;
use std::ops::Range;

/// Which sides of a block's storage are padded (see the module's documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// [`HALO`] nodes on every side, as the Eulerian frame's padded arrays.
    Padded,
    /// [`HALO`] nodes on the sides that face another rank only (§2's local grid).
    Local,
}

impl Layout {
    /// Whether the side (`axis`, `high`) of `block` is exchanged.
    pub fn exchanged(self, block: &Block, axis: usize, high: bool) -> bool {
        match block.neighbours[2 * axis + high as usize] {
            None => false,
            // a rank is its own neighbour only across a periodic axis it spans alone
            Some(r) => self == Layout::Padded || r != block.rank,
        }
    }

    /// The padding of the low and the high side along `axis` (cells; a face lattice along
    /// `axis` has one node more, at the high end).
    pub fn pads(self, block: &Block, axis: usize) -> [usize; 2] {
        match self {
            Layout::Padded => [HALO; 2],
            Layout::Local => [false, true].map(|high| if self.exchanged(block, axis, high) { HALO } else { 0 }),
        }
    }
}

/// The storage shape of a lattice on a block: its block's lattice and the padding.
pub fn storage_shape(block: &Block, layout: Layout, lattice: Lattice) -> Index {
    std::array::from_fn(|a| {
        let [lo, hi] = layout.pads(block, a);
        block.cells[a].len() + lo + hi + (lattice.axis() == Some(a)) as usize
    })
}

/// The owned nodes of a lattice on a block, as storage index ranges.
pub fn owned(block: &Block, layout: Layout, lattice: Lattice) -> [Range<usize>; DIM] {
    std::array::from_fn(|a| {
        let lo = layout.pads(block, a)[0];
        lo..lo + block.owned_global(lattice, a).len()
    })
}

/// Whether storage node `at` of a lattice lies in the halo: in the padding of a side that
/// is exchanged (values there come from a neighbour, never from this rank's kernels).
pub fn in_halo(block: &Block, layout: Layout, lattice: Lattice, at: Index) -> bool {
    let own = owned(block, layout, lattice);
    AXES.iter().any(|&a| {
        (layout.exchanged(block, a, false) && at[a] < own[a].start)
            || (layout.exchanged(block, a, true) && at[a] >= own[a].end)
    })
}

/// The global node of storage node `at` (before any periodic wrap; see
/// [`crate::decomposition::wrap`]).
pub fn global(block: &Block, layout: Layout, at: Index) -> [isize; DIM] {
    std::array::from_fn(|a| (block.cells[a].start + at[a]) as isize - layout.pads(block, a)[0] as isize)
}

/// Position in storage of node `at` of a storage of shape `s` (x fastest).
fn index(s: Index, at: Index) -> usize {
    let mut i = at[DIM - 1];
    for a in (0..DIM - 1).rev() {
        i = at[a] + s[a] * i;
    }
    i
}

/// Calls `f` with the storage index of every node of the box `r`, x fastest.
pub fn for_each(s: Index, r: &[Range<usize>; DIM], mut f: impl FnMut(usize)) {
    if r.iter().any(|r| r.is_empty()) {
        return;
    }
    let mut at: Index = std::array::from_fn(|a| r[a].start);
    loop {
        let row = index(s, at);
        for i in 0..r[0].len() {
            f(row + i);
        }
        // the next row
        let mut a = 1;
        loop {
            if a == DIM {
                return;
            }
            at[a] += 1;
            if at[a] < r[a].end {
                break;
            }
            at[a] = r[a].start;
            a += 1;
        }
    }
}

/// The halo nodes on the high side along `axis` (H, or H + 1 for faces along it).
fn high_width(lattice: Lattice, axis: usize) -> usize {
    HALO + (lattice.axis() == Some(axis)) as usize
}

/// The box of storage exchanged along `axis` with its range along `axis` replaced by
/// `along`. Along the other axes: the storage without the padding beyond a side that is
/// not exchanged, and, along later axes, without the halo still to come.
fn slab(block: &Block, layout: Layout, lattice: Lattice, axis: usize, along: Range<usize>) -> [Range<usize>; DIM] {
    let own = owned(block, layout, lattice);
    let s = storage_shape(block, layout, lattice);
    std::array::from_fn(|b| {
        let [pad_lo, pad_hi] = layout.pads(block, b);
        let (low, high) = (layout.exchanged(block, b, false), layout.exchanged(block, b, true));
        if b == axis {
            along.clone()
        } else if b < axis {
            (if low { 0 } else { pad_lo })..(if high { s[b] } else { s[b] - pad_hi })
        } else {
            pad_lo..(if high { own[b].end } else { s[b] - pad_hi })
        }
    })
}

/// Fills the halo of every array (each a lattice's storage on `block` in `layout`, see the
/// module's documentation) with its owners' values. Every rank of `comm` calls it with the
/// same layout and lattices in the same order (of one word type: `f64`, or `f32` for the
/// multigrid's levels).
pub fn exchange<C: Comm + ?Sized, T: Word>(
    comm: &C,
    block: &Block,
    layout: Layout,
    arrays: &mut [(Lattice, &mut [T])],
) {
    for &(lattice, ref a) in arrays.iter() {
        let s = storage_shape(block, layout, lattice);
        assert_eq!(a.len(), s.iter().product::<usize>(), "an array of {lattice:?} on block {block:?}");
    }
    for axis in AXES {
        let low = layout.exchanged(block, axis, false).then(|| block.neighbours[2 * axis]).flatten();
        let high = layout.exchanged(block, axis, true).then(|| block.neighbours[2 * axis + 1]).flatten();
        if low.is_none() && high.is_none() {
            continue;
        }
        // what each neighbour's halo holds of ours: the last H owned nodes go up, the first
        // H (+ 1) down
        let pack = |up: bool| -> Vec<u8> {
            let mut bytes = Vec::new();
            for (lattice, a) in arrays.iter() {
                let own = owned(block, layout, *lattice)[axis].clone();
                let along =
                    if up { own.end - HALO..own.end } else { own.start..own.start + high_width(*lattice, axis) };
                let s = storage_shape(block, layout, *lattice);
                for_each(s, &slab(block, layout, *lattice, axis, along), |i| a[i].put(&mut bytes));
            }
            bytes
        };
        let to_high = high.map(|_| pack(true));
        let to_low = low.map(|_| pack(false));
        let (up, down) = ((2 * axis + 1) as Tag, (2 * axis) as Tag);
        let mut sends = Vec::new();
        if let (Some(peer), Some(b)) = (high, &to_high) {
            sends.push((peer, up, b.as_slice()));
        }
        if let (Some(peer), Some(b)) = (low, &to_low) {
            sends.push((peer, down, b.as_slice()));
        }
        // from the low neighbour its message upwards, from the high one its message downwards
        let receives: Vec<(usize, Tag)> = low.map(|p| (p, up)).into_iter().chain(high.map(|p| (p, down))).collect();
        let got = comm.exchange(&sends, &receives);
        let mut got = got.into_iter();
        for from_low in [true, false] {
            if (if from_low { low } else { high }).is_none() {
                continue;
            }
            let bytes = got.next().expect("one message a neighbour");
            let mut values = bytes.chunks_exact(T::SIZE).map(T::get);
            for (lattice, a) in arrays.iter_mut() {
                let own = owned(block, layout, *lattice)[axis].clone();
                let along = if from_low { 0..own.start } else { own.end..own.end + high_width(*lattice, axis) };
                let s = storage_shape(block, layout, *lattice);
                for_each(s, &slab(block, layout, *lattice, axis, along), |i| {
                    a[i] = values.next().expect("a message as long as the halo");
                });
            }
            assert!(values.next().is_none(), "a message longer than the halo");
        }
    }
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;
    use crate::decomposition::{wrap, RankGrid};
    use crate::math::Real;
    use crate::parallel::fake;

    const LATTICES: [Lattice; 3] = [Lattice::Cell, Lattice::XFace, Lattice::YFace];

    /// The value every rank writes at global node g of a lattice (exact in f64).
    fn value(l: usize, g: Index) -> Real {
        (1 + l + 10 * g[0] + 10_000 * g[1]) as Real
    }

    /// On 1 × 1, 2 × 2, 1 × 3, 3 × 1 (and 2 × 3) rank grids, periodic or not along each
    /// axis, in both layouts, three lattices exchanged in one call: after the exchange every
    /// storage node that some rank owns holds the owner's value, and the padding beyond a
    /// side that is not periodic keeps its NaN. The halo starts as NaN (everything else as
    /// the serial code would have it: the owned nodes, and in `Local` the copy of face 0 at
    /// face n of a periodic axis the rank spans alone), so a halo node that the exchange
    /// missed would fail the comparison.
    #[test]
    fn every_halo_node_gets_its_owners_value() {
        let n = [96, 24];
        for layout in [Layout::Padded, Layout::Local] {
            for p in [[1, 1], [2, 2], [1, 3], [3, 1], [2, 3]] {
                for periodic in [[false, false], [true, false], [false, true], [true, true]] {
                    let ranks = p[0] * p[1];
                    let g = RankGrid::new(n, periodic, ranks, Some(p)).unwrap();
                    let counts = fake::run(ranks, |comm| {
                        let block = g.block(comm.rank());
                        let wrapped = |lattice: Lattice, at: Index| -> Option<Index> {
                            let gl = global(&block, layout, at);
                            let w: Option<Vec<usize>> = AXES
                                .iter()
                                .map(|&a| wrap(gl[a], n[a], periodic[a], lattice.axis() == Some(a)))
                                .collect();
                            w.map(|w| [w[0], w[1]])
                        };
                        let mut arrays: Vec<Vec<Real>> = LATTICES
                            .iter()
                            .enumerate()
                            .map(|(l, &lattice)| {
                                let s = storage_shape(&block, layout, lattice);
                                (0..s[0] * s[1])
                                    .map(|i| {
                                        let at = [i % s[0], i / s[0]];
                                        match wrapped(lattice, at) {
                                            Some(w) if !in_halo(&block, layout, lattice, at) => value(l, w),
                                            _ => Real::NAN,
                                        }
                                    })
                                    .collect()
                            })
                            .collect();
                        let mut views: Vec<(Lattice, &mut [Real])> =
                            LATTICES.iter().zip(arrays.iter_mut()).map(|(&l, a)| (l, a.as_mut_slice())).collect();
                        exchange(comm, &block, layout, &mut views);
                        let (mut halo, mut padding) = (0, 0);
                        for (l, &lattice) in LATTICES.iter().enumerate() {
                            let s = storage_shape(&block, layout, lattice);
                            padding += s[0] * s[1] - block.owned_count(lattice);
                            for (i, &v) in arrays[l].iter().enumerate() {
                                let at = [i % s[0], i / s[0]];
                                let gl = global(&block, layout, at);
                                match wrapped(lattice, at) {
                                    Some(w) => {
                                        assert_eq!(
                                            v,
                                            value(l, w),
                                            "{layout:?} {p:?} {periodic:?} rank {} {lattice:?} at {gl:?}",
                                            comm.rank()
                                        );
                                        halo += in_halo(&block, layout, lattice, at) as usize;
                                    }
                                    None => assert!(v.is_nan(), "{lattice:?} at {gl:?} beyond a wall was written"),
                                }
                            }
                        }
                        (halo, padding)
                    });
                    let (halo, padding) = counts.iter().fold((0, 0), |(h, p), c| (h + c.0, p + c.1));
                    // in Padded with every axis periodic the whole padding is halo
                    if layout == Layout::Padded && periodic == [true, true] {
                        assert_eq!(halo, padding);
                    }
                    // a halo exists unless no rank has a side to exchange
                    let sides = layout == Layout::Padded && periodic != [false, false] || ranks > 1;
                    assert_eq!(halo > 0, sides, "{layout:?} {p:?} {periodic:?}");
                }
            }
        }
    }

    /// `Local` pads only the sides that face another rank: one rank has no padding, and a
    /// periodic axis it spans alone stays unpadded; `Padded` pads every side.
    #[test]
    fn local_layout_pads_only_the_sides_facing_other_ranks() {
        let g = RankGrid::new([96, 24], [true, false], 3, Some([1, 3])).unwrap();
        let middle = g.block(1);
        assert_eq!(storage_shape(&middle, Layout::Local, Lattice::XFace), [97, 8 + 4]);
        assert_eq!(storage_shape(&middle, Layout::Padded, Lattice::XFace), [97 + 4, 8 + 4]);
        let bottom = g.block(0);
        assert_eq!(storage_shape(&bottom, Layout::Local, Lattice::YFace), [96, 8 + 1 + 2]);
        assert_eq!(global(&bottom, Layout::Local, [0, 0]), [0, 0]);
        assert_eq!(global(&middle, Layout::Local, [0, 0]), [0, 6]);
        let one = RankGrid::new([96, 24], [true, true], 1, None).unwrap().block(0);
        assert_eq!(storage_shape(&one, Layout::Local, Lattice::Cell), [96, 24]);
    }
}
