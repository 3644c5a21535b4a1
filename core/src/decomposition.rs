//! The domain cut into blocks, one per rank (docs/design/mpi.md §2).
//!
//! P ranks form a Cartesian rank grid `p` (p₀ × p₁ (× p₂) = P); the cells along axis a are
//! cut at `cuts[a]` into p_a blocks. The cuts obey two alignments: along x they fall on
//! multiples of [`ROW_GROUP`] = 32 cells (the exact sums' row groups never straddle a cut,
//! §3), and every cut falls on a multiple of 2^L for the largest L (at most the multigrid's
//! number of coarsenings) that keeps each block at least 2^(L+1) cells wide and the blocks
//! no further from the mean than the unaligned split or 15 % (§4: the first L levels of the
//! multigrid are then distributed with whole coarse cells on each rank). Every block is at
//! least [`MIN_BLOCK`] = 2 H cells wide along every axis. Unless the rank grid is given,
//! it is the factorization of P with the least halo surface per rank,
//! Σ_a Π_{b≠a} (largest block along b), ties going to more cuts along the slowest axis.
//!
//! Ownership: a cell belongs to the block that contains it; a face to the cell on its high
//! side, so a block owns the faces at its low cut and not those at its high cut, but for
//! face n of an axis that is not periodic, which the last block owns (on a periodic axis
//! face n is face 0's copy, never owned).

use crate::grid::Lattice;
use crate::math::{Index, AXES, DIM, SIDES};
use std::ops::Range;

/// Halo layers on each side of a block that faces another rank.
pub const HALO: usize = 2;
/// Width along x of the exact sums' row groups: x-cuts fall on its multiples.
pub const ROW_GROUP: usize = 32;
/// The narrowest block along any axis (2 H cells).
pub const MIN_BLOCK: usize = 2 * HALO;

/// The rank grid and its cuts (see the module's documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RankGrid {
    /// The domain's cells along each axis.
    pub n: Index,
    /// Whether each axis is periodic.
    pub periodic: [bool; DIM],
    /// Ranks along each axis.
    pub p: Index,
    /// Cuts along each axis: p_a + 1 cell indices from 0 to n_a; block c along a has the
    /// cells `cuts[a][c]..cuts[a][c + 1]`.
    pub cuts: [Vec<usize>; DIM],
    /// Every cut is a multiple of 2^levels.
    pub levels: usize,
}

/// The number of coarsenings of the multigrid hierarchy on n cells (each axis halved while
/// every axis is even and at least 4, as `Hierarchy::build` of the pressure solver does).
pub fn multigrid_levels(n: Index) -> usize {
    let mut n = n;
    let mut levels = 0;
    while n.iter().all(|&k| k.is_multiple_of(2) && k >= 4) {
        n = n.map(|k| k / 2);
        levels += 1;
    }
    levels
}

/// n cells cut into p blocks on multiples of `unit`, as evenly as possible: the cut k at
/// the multiple of `unit` nearest to k n / p. `None` when two cuts coincide or a block is
/// narrower than [`MIN_BLOCK`].
fn split(n: usize, p: usize, unit: usize) -> Option<Vec<usize>> {
    let mut cuts = vec![0];
    for k in 1..p {
        // round(k n / (p unit)), halves up, in integers
        cuts.push(unit * ((2 * k * n + p * unit) / (2 * p * unit)));
    }
    cuts.push(n);
    cuts.windows(2).all(|w| w[1] >= w[0] + MIN_BLOCK).then_some(cuts)
}

/// The largest distance of a block's width from the mean, times p (an integer).
fn imbalance(cuts: &[usize], n: usize) -> usize {
    let p = cuts.len() - 1;
    cuts.windows(2).map(|w| ((w[1] - w[0]) * p).abs_diff(n)).max().unwrap_or(0)
}

/// The alignment of cuts along `axis` for 2^levels: x also on multiples of [`ROW_GROUP`].
fn unit(axis: usize, levels: usize) -> usize {
    let base = if axis == 0 { ROW_GROUP } else { 1 };
    base.max(1 << levels)
}

/// The cuts of n cells on the rank grid p, and their level alignment; `None` if p does not fit.
fn cuts_for(n: Index, p: Index) -> Option<([Vec<usize>; DIM], usize)> {
    let plain: Vec<Vec<usize>> = AXES.iter().map(|&a| split(n[a], p[a], unit(a, 0))).collect::<Option<_>>()?;
    for levels in (1..=multigrid_levels(n)).rev() {
        let aligned: Option<Vec<Vec<usize>>> = AXES
            .iter()
            .map(|&a| {
                let cuts = split(n[a], p[a], unit(a, levels))?;
                let wide = p[a] == 1 || cuts.windows(2).all(|w| w[1] - w[0] >= 2 << levels);
                // within 15 % of the mean, or no worse than the split without the levels
                let limit = imbalance(&plain[a], n[a]).max(3 * n[a] / 20);
                (wide && imbalance(&cuts, n[a]) <= limit).then_some(cuts)
            })
            .collect();
        if let Some(cuts) = aligned {
            return Some((to_array(cuts), levels));
        }
    }
    Some((to_array(plain), 0))
}

fn to_array(v: Vec<Vec<usize>>) -> [Vec<usize>; DIM] {
    v.try_into().expect("one entry per axis")
}

/// The halo surface per rank of a rank grid: Σ_a Π_{b≠a} (largest block along b).
fn surface(cuts: &[Vec<usize>; DIM]) -> usize {
    let widest: Vec<usize> = cuts.iter().map(|c| c.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0)).collect();
    AXES.iter().map(|&a| AXES.iter().filter(|&&b| b != a).map(|&b| widest[b]).product::<usize>()).sum()
}

/// Every rank grid of `ranks` ranks (ordered factorizations), the slowest axis's count
/// largest first.
fn factorizations(ranks: usize) -> Vec<Index> {
    fn rec(left: usize, axis: usize, at: &mut Index, out: &mut Vec<Index>) {
        if axis == DIM - 1 {
            at[axis] = left;
            out.push(*at);
            return;
        }
        for d in (1..=left).filter(|&d| left.is_multiple_of(d)) {
            at[axis] = d;
            rec(left / d, axis + 1, at, out);
        }
    }
    let mut out = Vec::new();
    rec(ranks, 0, &mut [1; DIM], &mut out);
    // the preferred order among equal surfaces: more cuts along z, then y, then x
    out.sort_by(|a, b| b.iter().rev().cmp(a.iter().rev()));
    out
}

/// `a × b (× c)`.
pub fn dims_text(v: Index) -> String {
    v.map(|k| k.to_string()).join(" × ")
}

impl RankGrid {
    /// The rank grid of `ranks` ranks on a domain of `n` cells: `given` (its product must
    /// be `ranks`) or the one of least halo surface. An error says why the ranks do not
    /// fit and how many would.
    pub fn new(n: Index, periodic: [bool; DIM], ranks: usize, given: Option<Index>) -> Result<Self, String> {
        if ranks == 0 {
            return Err("a run needs at least one rank".into());
        }
        if let Some(p) = given {
            let product: usize = p.iter().product();
            if product != ranks {
                return Err(format!(
                    "the rank grid {} has {product} ranks but the run has {ranks}: give a rank grid whose product \
                     is {ranks}, or run on {product} ranks",
                    dims_text(p)
                ));
            }
            return match cuts_for(n, p) {
                Some((cuts, levels)) => Ok(Self { n, periodic, p, cuts, levels }),
                None => {
                    let axis = AXES.into_iter().find(|&a| split(n[a], p[a], unit(a, 0)).is_none()).expect("an axis");
                    Err(format!(
                        "the rank grid {} does not fit {} cells: {} blocks along {} leave a block narrower than {} \
                         cells{}; use at most {} ranks along {}",
                        dims_text(p),
                        dims_text(n),
                        p[axis],
                        crate::math::axis_name(axis),
                        MIN_BLOCK,
                        if axis == 0 { " or a cut off the multiples of 32 cells" } else { "" },
                        most_along(n[axis], axis),
                        crate::math::axis_name(axis)
                    ))
                }
            };
        }
        match Self::best(n, periodic, ranks) {
            Some(g) => Ok(g),
            None => {
                if n.iter().any(|&k| k < MIN_BLOCK) {
                    return Err(format!(
                        "{} cells: a block needs at least {MIN_BLOCK} cells along each axis (its halo is {HALO} \
                         layers): give at least {MIN_BLOCK} cells along each axis",
                        dims_text(n)
                    ));
                }
                let most = (1..ranks).rev().find(|&r| Self::best(n, periodic, r).is_some()).unwrap_or(1);
                Err(format!(
                    "{ranks} ranks do not fit {} cells: every block needs at least {MIN_BLOCK} cells along each axis, \
                     and cuts along x fall on multiples of {ROW_GROUP} cells; use at most {most} rank{}",
                    dims_text(n),
                    if most == 1 { "" } else { "s" }
                ))
            }
        }
    }

    /// The rank grid of least surface, if any fits.
    fn best(n: Index, periodic: [bool; DIM], ranks: usize) -> Option<Self> {
        let mut best: Option<(usize, Self)> = None;
        for p in factorizations(ranks) {
            if let Some((cuts, levels)) = cuts_for(n, p) {
                let s = surface(&cuts);
                // strictly less: among equals the first in the preferred order stays
                if best.as_ref().is_none_or(|(b, _)| s < *b) {
                    best = Some((s, Self { n, periodic, p, cuts, levels }));
                }
            }
        }
        best.map(|(_, g)| g)
    }

    /// The number of ranks.
    pub fn size(&self) -> usize {
        self.p.iter().product()
    }

    /// The rank of the block at rank-grid coordinates `c` (x fastest).
    pub fn rank_at(&self, c: Index) -> usize {
        let mut r = c[DIM - 1];
        for a in (0..DIM - 1).rev() {
            r = c[a] + self.p[a] * r;
        }
        r
    }

    /// The rank-grid coordinates of `rank`.
    pub fn coords(&self, rank: usize) -> Index {
        let mut r = rank;
        let mut c = [0; DIM];
        for a in AXES {
            c[a] = r % self.p[a];
            r /= self.p[a];
        }
        c
    }

    /// The rank grid of the domain coarsened 2:1 along every axis (the next multigrid
    /// level's): the cuts halved, one alignment level fewer; `None` when the cuts are not
    /// all even (`levels` is 0).
    pub fn coarsened(&self) -> Option<Self> {
        (self.levels >= 1 && self.n.iter().all(|&k| k % 2 == 0)).then(|| Self {
            n: self.n.map(|k| k / 2),
            periodic: self.periodic,
            p: self.p,
            cuts: self.cuts.clone().map(|c| c.into_iter().map(|k| k / 2).collect()),
            levels: self.levels - 1,
        })
    }

    /// The halo surface per rank that chose this grid (see the module's documentation).
    pub fn surface(&self) -> usize {
        surface(&self.cuts)
    }

    /// The block of `rank`.
    pub fn block(&self, rank: usize) -> Block {
        let c = self.coords(rank);
        let cells = std::array::from_fn(|a| self.cuts[a][c[a]]..self.cuts[a][c[a] + 1]);
        let mut neighbours = [None; SIDES];
        for a in AXES {
            for high in [false, true] {
                let next = if high { c[a] + 1 } else { c[a].wrapping_sub(1) };
                let next = if next < self.p[a] {
                    Some(next)
                } else if self.periodic[a] {
                    Some(if high { 0 } else { self.p[a] - 1 })
                } else {
                    None
                };
                neighbours[2 * a + high as usize] = next.map(|k| {
                    let mut d = c;
                    d[a] = k;
                    self.rank_at(d)
                });
            }
        }
        Block {
            rank,
            coords: c,
            n: self.n,
            periodic: self.periodic,
            last: std::array::from_fn(|a| c[a] + 1 == self.p[a]),
            cells,
            neighbours,
        }
    }

    /// The rank that owns node `at` (global) of a lattice, `None` for a node outside the
    /// domain; on a periodic axis an index beyond the domain wraps.
    pub fn owner(&self, lattice: Lattice, at: [isize; DIM]) -> Option<usize> {
        let mut c = [0; DIM];
        for a in AXES {
            let g = wrap(at[a], self.n[a], self.periodic[a], lattice.axis() == Some(a))?;
            // the block with cuts[c] ≤ g < cuts[c + 1]; face n (not periodic) is the last block's
            c[a] = self.cuts[a][1..].partition_point(|&cut| cut <= g).min(self.p[a] - 1);
        }
        Some(self.rank_at(c))
    }
}

/// A global index along one axis brought into the domain: wrapped on a periodic axis
/// (faces: n is face 0), `None` beyond a side that is not periodic.
pub fn wrap(g: isize, n: usize, periodic: bool, face: bool) -> Option<usize> {
    let n = n as isize;
    if periodic {
        Some(g.rem_euclid(n) as usize)
    } else if g >= 0 && (g < n || (face && g == n)) {
        Some(g as usize)
    } else {
        None
    }
}

/// The most blocks n cells take along an axis.
fn most_along(n: usize, axis: usize) -> usize {
    (1..=n).rev().find(|&p| split(n, p, unit(axis, 0)).is_some()).unwrap_or(1)
}

/// One rank's block (see the module's documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    /// Its rank.
    pub rank: usize,
    /// Its coordinates in the rank grid.
    pub coords: Index,
    /// The domain's cells.
    pub n: Index,
    /// Whether each axis is periodic.
    pub periodic: [bool; DIM],
    /// Whether it is the last block along each axis.
    pub last: [bool; DIM],
    /// The global cells it owns along each axis.
    pub cells: [Range<usize>; DIM],
    /// The rank across each side (`Side::of(axis, high)` order), itself on a periodic axis
    /// with one block; `None` at a side of the domain that is not periodic.
    pub neighbours: [Option<usize>; SIDES],
}

impl Block {
    /// Owned nodes of a lattice along `axis`, global indices: the cells' range, and on the
    /// axis of a face lattice the face at the high cut too when it is face n of an axis
    /// that is not periodic.
    pub fn owned_global(&self, lattice: Lattice, axis: usize) -> Range<usize> {
        let r = self.cells[axis].clone();
        if lattice.axis() == Some(axis) && self.last[axis] && !self.periodic[axis] {
            r.start..r.end + 1
        } else {
            r
        }
    }

    /// The number of owned nodes of a lattice.
    pub fn owned_count(&self, lattice: Lattice) -> usize {
        AXES.iter().map(|&a| self.owned_global(lattice, a).len()).product()
    }
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;

    fn check_cover(g: &RankGrid) {
        // every cell of the domain in exactly one block
        let mut count = vec![0u32; g.n.iter().product()];
        for r in 0..g.size() {
            let b = g.block(r);
            assert_eq!(b.rank, r);
            for j in b.cells[1].clone() {
                for i in b.cells[0].clone() {
                    count[i + g.n[0] * j] += 1;
                    assert_eq!(g.owner(Lattice::Cell, [i as isize, j as isize]), Some(r));
                }
            }
        }
        assert!(count.iter().all(|&c| c == 1), "{g:?}");
        for a in AXES {
            assert_eq!(g.cuts[a].len(), g.p[a] + 1);
            assert_eq!((g.cuts[a][0], *g.cuts[a].last().unwrap()), (0, g.n[a]));
            for w in g.cuts[a].windows(2) {
                assert!(w[1] - w[0] >= MIN_BLOCK, "{g:?}");
            }
            for &c in &g.cuts[a][1..g.p[a]] {
                assert_eq!(c % (1 << g.levels), 0, "{g:?}");
                if a == 0 {
                    assert_eq!(c % ROW_GROUP, 0, "x-cut off the row groups: {g:?}");
                }
            }
        }
        assert!(g.levels <= multigrid_levels(g.n));
    }

    /// Cuts cover every cell once, on the alignments, for 1–64 ranks on odd and even
    /// sizes; the grid chosen has the least surface of every rank grid that fits (brute
    /// force over all p₀ × p₁ = P, each with its cuts), and the ranks that do not fit are
    /// refused with the largest count that does.
    #[test]
    fn cuts_cover_every_cell_once_with_the_least_surface() {
        let sizes = [[64, 64], [67, 45], [129, 31], [40, 160], [256, 9], [33, 200], [100, 100], [512, 512]];
        for n in sizes {
            for ranks in 1..=64 {
                match RankGrid::new(n, [false, true], ranks, None) {
                    Ok(g) => {
                        check_cover(&g);
                        let mut least = usize::MAX;
                        for p0 in (1..=ranks).filter(|&d| ranks.is_multiple_of(d)) {
                            if let Some((aligned, _)) = cuts_for(n, [p0, ranks / p0]) {
                                least = least.min(surface(&aligned));
                            }
                        }
                        assert_eq!(g.surface(), least, "{n:?} on {ranks}");
                    }
                    Err(e) => {
                        // no factorization fits: the message's count fits, and every count above it up to P does not
                        let most: usize =
                            e.split("use at most ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
                        assert!(most < ranks && RankGrid::new(n, [false, true], most, None).is_ok(), "{e}");
                        for r in most + 1..=ranks {
                            for p0 in (1..=r).filter(|&d| r.is_multiple_of(d)) {
                                assert!(cuts_for(n, [p0, r / p0]).is_none(), "{n:?}: {r} ranks fit ({e})");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn alignment_to_the_multigrid_levels() {
        // 64² on 2 × 2: blocks of 32, L = log₂ 32 − 1 = 4 (the coarsest distributed level has blocks of 2 cells)
        let g = RankGrid::new([64, 64], [true, true], 4, Some([2, 2])).unwrap();
        assert_eq!((g.levels, g.cuts.clone()), (4, [vec![0, 32, 64], vec![0, 32, 64]]));
        // 512² on 4 × 4: blocks of 128, L = 6
        let g = RankGrid::new([512, 512], [false; 2], 16, None).unwrap();
        assert_eq!((g.p, g.levels), ([4, 4], 6));
        // 96 rows on 3: cuts at 32 and 64 (L = 4, blocks of 32 = 2⁵)
        let g = RankGrid::new([64, 96], [false; 2], 3, None).unwrap();
        assert_eq!((g.p, g.cuts[1].clone(), g.levels), ([1, 3], vec![0, 32, 64, 96], 4));
        // 100 rows on 3: cuts on multiples of 4 nearest to 33.3 and 66.7: 32 and 68 (within 15 % of 33.3)
        let g = RankGrid::new([64, 100], [false; 2], 3, Some([1, 3])).unwrap();
        assert_eq!((g.cuts[1].clone(), g.levels), (vec![0, 32, 68, 100], 2));
        // an odd size has no multigrid level to align to
        let g = RankGrid::new([67, 45], [false; 2], 3, Some([1, 3])).unwrap();
        assert_eq!((g.cuts[1].clone(), g.levels), (vec![0, 15, 30, 45], 0));
        // ties go to cuts along y (the DKT's 40 × 160 too)
        assert_eq!(RankGrid::new([128, 128], [false; 2], 2, None).unwrap().p, [1, 2]);
        assert_eq!(RankGrid::new([40, 160], [false; 2], 4, None).unwrap().p, [1, 4]);
    }

    #[test]
    fn refusals_name_the_fix() {
        let e = RankGrid::new([128, 16], [false; 2], 64, None).unwrap_err();
        // 128 cells: 4 blocks along x (cuts on multiples of 32); 16: 4 blocks of 4
        assert!(e.contains("64 ranks do not fit 128 × 16 cells") && e.contains("use at most 16 ranks"), "{e}");
        let e = RankGrid::new([64, 64], [false; 2], 4, Some([3, 1])).unwrap_err();
        assert!(e.contains("the rank grid 3 × 1 has 3 ranks but the run has 4"), "{e}");
        let e = RankGrid::new([64, 64], [false; 2], 3, Some([3, 1])).unwrap_err();
        assert!(e.contains("3 blocks along x") && e.contains("use at most 2 ranks along x"), "{e}");
        assert!(RankGrid::new([64, 64], [false; 2], 0, None).is_err());
        let e = RankGrid::new([64, 3], [false; 2], 1, None).unwrap_err();
        assert!(e.contains("64 × 3 cells: a block needs at least 4 cells along each axis"), "{e}");
    }

    #[test]
    fn neighbours_and_periodic_wraps() {
        let g = RankGrid::new([64, 12], [true, false], 6, Some([2, 3])).unwrap();
        // rank = cx + 2 cy
        let b = g.block(1); // (1, 0)
        assert_eq!(b.coords, [1, 0]);
        assert_eq!(b.neighbours, [Some(0), Some(0), None, Some(3)]);
        let b = g.block(4); // (0, 2)
        assert_eq!(b.neighbours, [Some(5), Some(5), Some(2), None]);
        // one block along a periodic axis is its own neighbour
        let g = RankGrid::new([64, 12], [true, true], 3, Some([1, 3])).unwrap();
        assert_eq!(g.block(0).neighbours, [Some(0), Some(0), Some(2), Some(1)]);
        // faces: n belongs to the last block unless periodic (then it is face 0, rank 0's)
        let g = RankGrid::new([64, 12], [false, true], 4, Some([2, 2])).unwrap();
        assert_eq!(g.owner(Lattice::XFace, [64, 0]), Some(1));
        assert_eq!(g.owner(Lattice::XFace, [32, 0]), Some(1));
        assert_eq!(g.owner(Lattice::XFace, [65, 0]), None);
        assert_eq!(g.owner(Lattice::YFace, [0, 12]), Some(0));
        assert_eq!(g.owner(Lattice::YFace, [0, -1]), Some(2));
        assert_eq!(g.block(3).owned_global(Lattice::XFace, 0), 32..65);
        assert_eq!(g.block(3).owned_global(Lattice::YFace, 1), 6..12);
    }
}
