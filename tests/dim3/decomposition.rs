//! The rank grid and the halo exchange in 3D (docs/design/mpi.md §2; the 2D unit tests are
//! in core/src/decomposition.rs and core/src/halo.rs), on in-process fake ranks.

use multifield_core3d::decomposition::{wrap, RankGrid, HALO, MIN_BLOCK, ROW_GROUP};
use multifield_core3d::grid::Lattice;
use multifield_core3d::halo::{exchange, global, in_halo, storage_shape, Layout};
use multifield_core3d::math::{Index, Real, AXES};
use multifield_core3d::parallel::{fake, Comm};

const LATTICES: [Lattice; 4] = [Lattice::Cell, Lattice::XFace, Lattice::YFace, Lattice::ZFace];

/// Cuts cover every cell once on 1–27 ranks of odd and even boxes, with x-cuts on the row
/// groups, blocks of at least 2 H cells, and the grid of least surface of every p₀ p₁ p₂ = P
/// that fits (brute force with the given grids).
#[test]
fn cuts_cover_every_cell_once_with_the_least_surface() {
    for n in [[64, 32, 32], [96, 13, 20], [33, 40, 8]] {
        for ranks in 1..=27 {
            let Ok(g) = RankGrid::new(n, [true, false, true], ranks, None) else {
                continue;
            };
            let mut count = vec![0u8; n.iter().product()];
            for r in 0..ranks {
                let b = g.block(r);
                for k in b.cells[2].clone() {
                    for j in b.cells[1].clone() {
                        for i in b.cells[0].clone() {
                            count[i + n[0] * (j + n[1] * k)] += 1;
                        }
                    }
                }
            }
            assert!(count.iter().all(|&c| c == 1), "{n:?} on {ranks}: {g:?}");
            for a in AXES {
                assert!(g.cuts[a].windows(2).all(|w| w[1] - w[0] >= MIN_BLOCK));
            }
            assert!(g.cuts[0][1..g.p[0]].iter().all(|c| c % ROW_GROUP == 0));
            let mut least = usize::MAX;
            for p0 in (1..=ranks).filter(|&d| ranks.is_multiple_of(d)) {
                for p1 in (1..=ranks / p0).filter(|&d| (ranks / p0).is_multiple_of(d)) {
                    if let Ok(h) = RankGrid::new(n, [true, false, true], ranks, Some([p0, p1, ranks / p0 / p1])) {
                        least = least.min(h.surface());
                    }
                }
            }
            assert_eq!(g.surface(), least, "{n:?} on {ranks}");
        }
    }
    // 64³ on 8: 2 × 2 × 2 blocks of 32, aligned to 2⁴
    let g = RankGrid::new([64; 3], [false; 3], 8, None).unwrap();
    assert_eq!((g.p, g.levels), ([2, 2, 2], 4));
}

fn value(l: usize, g: Index) -> Real {
    (1 + l + 10 * g[0] + 1000 * g[1] + 100_000 * g[2]) as Real
}

/// 2 × 2 × 2, 1 × 1 × 2 and 1 × 2 × 2 (and one rank, its own neighbour) ranks, periodic or
/// not, in both layouts: four lattices exchanged in one call; every storage node some rank
/// owns holds the owner's value after the exchange (edges and corners included), and the
/// padding beyond a wall keeps the NaN it started with, as does the halo before the exchange.
#[test]
fn every_halo_node_gets_its_owners_value() {
    let n = [64, 12, 10];
    for layout in [Layout::Padded, Layout::Local] {
        for p in [[2, 2, 2], [1, 1, 2], [1, 2, 2], [1, 1, 1]] {
            for periodic in [[false; 3], [true, false, true], [true; 3]] {
                let ranks: usize = p.iter().product();
                let g = RankGrid::new(n, periodic, ranks, Some(p)).unwrap();
                let halos = fake::run(ranks, |comm| {
                    let block = g.block(comm.rank());
                    let node = |s: Index, i: usize| [i % s[0], (i / s[0]) % s[1], i / (s[0] * s[1])];
                    let wrapped = |lattice: Lattice, at: Index| -> Option<Index> {
                        let gl = global(&block, layout, at);
                        let w: Option<Vec<usize>> =
                            AXES.iter().map(|&a| wrap(gl[a], n[a], periodic[a], lattice.axis() == Some(a))).collect();
                        w.map(|w| [w[0], w[1], w[2]])
                    };
                    let mut arrays: Vec<Vec<Real>> = LATTICES
                        .iter()
                        .enumerate()
                        .map(|(l, &lattice)| {
                            let s = storage_shape(&block, layout, lattice);
                            (0..s.iter().product())
                                .map(|i| match wrapped(lattice, node(s, i)) {
                                    Some(w) if !in_halo(&block, layout, lattice, node(s, i)) => value(l, w),
                                    _ => Real::NAN,
                                })
                                .collect()
                        })
                        .collect();
                    let mut views: Vec<(Lattice, &mut [Real])> =
                        LATTICES.iter().zip(arrays.iter_mut()).map(|(&l, a)| (l, a.as_mut_slice())).collect();
                    exchange(comm, &block, layout, &mut views);
                    let (mut filled, mut padding) = (0, 0);
                    for (l, &lattice) in LATTICES.iter().enumerate() {
                        let s = storage_shape(&block, layout, lattice);
                        padding += s.iter().product::<usize>() - block.owned_count(lattice);
                        for (i, &v) in arrays[l].iter().enumerate() {
                            let at = node(s, i);
                            match wrapped(lattice, at) {
                                Some(w) => {
                                    assert_eq!(v, value(l, w), "{layout:?} {p:?} {periodic:?} {lattice:?} {at:?}");
                                    filled += in_halo(&block, layout, lattice, at) as usize;
                                }
                                None => assert!(v.is_nan(), "{lattice:?} at {at:?} beyond a wall was written"),
                            }
                        }
                    }
                    (filled, padding)
                });
                let (filled, padding) = halos.iter().fold((0, 0), |(f, p), h| (f + h.0, p + h.1));
                // with every axis periodic, the whole padding of Padded is halo
                if periodic == [true; 3] && layout == Layout::Padded {
                    assert_eq!(filled, padding);
                    assert!(filled > 0 && HALO == 2);
                }
                if ranks > 1 {
                    assert!(filled > 0);
                }
            }
        }
    }
}
