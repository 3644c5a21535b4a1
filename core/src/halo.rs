//! The halo exchange: every rank's copy of the [`HALO`] layers of nodes its neighbours own
//! next to its block (docs/design/mpi.md §2).
//!
//! A lattice on a block is stored as the block's lattice padded by H = 2 nodes on every
//! side, x fastest (the layout of the Eulerian frame's padded arrays): storage node `l`
//! along axis a is global node `cells[a].start − H + l`. The owned nodes are
//! [`Block::owned_global`]; the halo is the padding on the sides that have a neighbour: H
//! nodes on the low side, and on the high side H (cells) or H + 1 (faces along their own
//! axis, which reach the far face of the last halo cell). Padding beyond a side of the
//! domain that is not periodic belongs to nobody and is left as it is (the boundary rules
//! fill it).
//!
//! [`exchange`] works axis by axis: along x the owned rows; along y the rows with their x
//! halo; along z with both, so edges and corners arrive through two or three messages. One
//! message a neighbour and axis carries every array of the call; its tag is its direction
//! (2 a to the low side, 2 a + 1 to the high side), so two ranks that are each other's
//! neighbour on both sides of a periodic axis, or a rank that is its own, tell them apart.

use crate::decomposition::{Block, HALO};
use crate::grid::Lattice;
use crate::math::{Index, Real, AXES, DIM};
use crate::parallel::{Comm, Tag};
use std::ops::Range;

/// The storage shape of a lattice on a block: its owned lattice padded by [`HALO`] nodes
/// on every side.
pub fn storage_shape(block: &Block, lattice: Lattice) -> Index {
    std::array::from_fn(|a| block.cells[a].len() + 2 * HALO + (lattice.axis() == Some(a)) as usize)
}

/// The owned nodes of a lattice on a block, as storage index ranges.
pub fn owned(block: &Block, lattice: Lattice) -> [Range<usize>; DIM] {
    std::array::from_fn(|a| HALO..HALO + block.owned_global(lattice, a).len())
}

/// The global node of storage node `at` (before any periodic wrap; see
/// [`crate::decomposition::wrap`]).
pub fn global(block: &Block, at: Index) -> [isize; DIM] {
    std::array::from_fn(|a| (block.cells[a].start + at[a]) as isize - HALO as isize)
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
fn for_each(s: Index, r: &[Range<usize>; DIM], mut f: impl FnMut(usize)) {
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

/// The box of storage exchanged along `axis` with its range along `axis` replaced by `along`:
/// along earlier axes the owned range with the halo on the sides that have a neighbour
/// (exchanged already), along later axes the owned range.
fn slab(block: &Block, lattice: Lattice, axis: usize, along: Range<usize>) -> [Range<usize>; DIM] {
    let own = owned(block, lattice);
    std::array::from_fn(|b| {
        if b == axis {
            along.clone()
        } else if b < axis {
            let lo = if block.neighbours[2 * b].is_some() { 0 } else { HALO };
            let hi = own[b].end + if block.neighbours[2 * b + 1].is_some() { high_width(lattice, b) } else { 0 };
            lo..hi
        } else {
            own[b].clone()
        }
    })
}

/// Fills the halo of every array (each a lattice's storage on `block`, see the module's
/// documentation) with its owners' values. Every rank of `comm` calls it with the same
/// lattices in the same order.
pub fn exchange<C: Comm + ?Sized>(comm: &C, block: &Block, arrays: &mut [(Lattice, &mut [Real])]) {
    for &(lattice, ref a) in arrays.iter() {
        let s = storage_shape(block, lattice);
        assert_eq!(a.len(), s.iter().product::<usize>(), "an array of {lattice:?} on block {block:?}");
    }
    for axis in AXES {
        let (low, high) = (block.neighbours[2 * axis], block.neighbours[2 * axis + 1]);
        if low.is_none() && high.is_none() {
            continue;
        }
        // what each neighbour's halo holds of ours: the last H owned nodes go up, the first
        // H (+ 1) down
        let pack = |up: bool| -> Vec<u8> {
            let mut bytes = Vec::new();
            for (lattice, a) in arrays.iter() {
                let m = owned(block, *lattice)[axis].end;
                let along = if up { m - HALO..m } else { HALO..HALO + high_width(*lattice, axis) };
                let s = storage_shape(block, *lattice);
                for_each(s, &slab(block, *lattice, axis, along), |i| bytes.extend_from_slice(&a[i].to_le_bytes()));
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
            let mut values = bytes.chunks_exact(8).map(|c| Real::from_le_bytes(c.try_into().expect("8 bytes")));
            for (lattice, a) in arrays.iter_mut() {
                let m = owned(block, *lattice)[axis].end;
                let along = if from_low { 0..HALO } else { m..m + high_width(*lattice, axis) };
                let s = storage_shape(block, *lattice);
                for_each(s, &slab(block, *lattice, axis, along), |i| {
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
    use crate::parallel::fake;

    const LATTICES: [Lattice; 3] = [Lattice::Cell, Lattice::XFace, Lattice::YFace];

    /// The value every rank writes at global node g of a lattice (exact in f64).
    fn value(l: usize, g: Index) -> Real {
        (1 + l + 10 * g[0] + 10_000 * g[1]) as Real
    }

    /// On 1 × 1, 2 × 2, 1 × 3, 3 × 1 (and 2 × 3) rank grids, periodic or not along each
    /// axis, three lattices exchanged in one call: after the exchange every storage node
    /// that some rank owns holds the owner's value, every owned node is unchanged, and the
    /// padding beyond a side that is not periodic keeps its NaN. The halo starts as NaN, so
    /// a halo node that the exchange missed would fail the comparison.
    #[test]
    fn every_halo_node_gets_its_owners_value() {
        let n = [96, 24];
        for p in [[1, 1], [2, 2], [1, 3], [3, 1], [2, 3]] {
            for periodic in [[false, false], [true, false], [false, true], [true, true]] {
                let ranks = p[0] * p[1];
                let g = RankGrid::new(n, periodic, ranks, Some(p)).unwrap();
                let (mut filled, mut beyond) = (0, 0);
                let counts = fake::run(ranks, |comm| {
                    let block = g.block(comm.rank());
                    let mut arrays: Vec<Vec<Real>> = LATTICES
                        .iter()
                        .enumerate()
                        .map(|(l, &lattice)| {
                            let s = storage_shape(&block, lattice);
                            let own = owned(&block, lattice);
                            let mut a = vec![Real::NAN; s.iter().product()];
                            for_each(s, &own, |i| {
                                let at = [i % s[0], i / s[0]];
                                let gl = global(&block, at);
                                a[i] = value(l, [gl[0] as usize, gl[1] as usize]);
                            });
                            a
                        })
                        .collect();
                    let mut views: Vec<(Lattice, &mut [Real])> =
                        LATTICES.iter().zip(arrays.iter_mut()).map(|(&l, a)| (l, a.as_mut_slice())).collect();
                    exchange(comm, &block, &mut views);
                    let (mut filled, mut beyond) = (0, 0);
                    for (l, &lattice) in LATTICES.iter().enumerate() {
                        let s = storage_shape(&block, lattice);
                        let own = owned(&block, lattice);
                        for (i, &v) in arrays[l].iter().enumerate() {
                            let at = [i % s[0], i / s[0]];
                            let gl = global(&block, at);
                            let face = |a: usize| lattice.axis() == Some(a);
                            let wrapped: Option<Vec<usize>> =
                                AXES.iter().map(|&a| wrap(gl[a], n[a], periodic[a], face(a))).collect();
                            match wrapped {
                                Some(w) => {
                                    let owner = g.owner(lattice, gl).unwrap();
                                    assert_eq!(
                                        v,
                                        value(l, [w[0], w[1]]),
                                        "{p:?} {periodic:?} rank {} {lattice:?} at {gl:?} (owner {owner})",
                                        comm.rank()
                                    );
                                    if !AXES.iter().all(|&a| own[a].contains(&at[a])) {
                                        filled += 1;
                                    }
                                }
                                None => {
                                    assert!(v.is_nan(), "{lattice:?} at {gl:?} beyond a wall was written");
                                    beyond += 1;
                                }
                            }
                        }
                    }
                    (filled, beyond)
                });
                for (f, b) in counts {
                    filled += f;
                    beyond += b;
                }
                // every halo node: the padding less what lies beyond walls
                let padding: usize = (0..ranks)
                    .map(|r| {
                        let b = g.block(r);
                        LATTICES
                            .iter()
                            .map(|&l| storage_shape(&b, l).iter().product::<usize>() - b.owned_count(l))
                            .sum::<usize>()
                    })
                    .sum();
                assert_eq!(filled + beyond, padding);
                if periodic == [true, true] {
                    assert_eq!(beyond, 0);
                }
                // a halo exists unless one rank has only walls
                assert_eq!(filled > 0, ranks > 1 || periodic != [false, false]);
            }
        }
    }
}
