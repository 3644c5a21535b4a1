//! The staggered (MAC) grid shared by every field.
//!
//! Pressure, volume fractions and densities live at cell centres; the x velocity
//! component lives on the faces normal to x ("x-faces", `(nx + 1) × ny`), the y component
//! on the faces normal to y ("y-faces", `nx × (ny + 1)`), and in 3D the z component on the
//! faces normal to z ("z-faces", `nx × ny × (nz + 1)`). Cells are squares (cubes) of side
//! `h`. Every lattice is stored with x fastest, then y, then z: the index of node
//! `(i, j, k)` of a lattice of shape `s` is `i + s₀ (j + s₁ k)`, so a 2D index is the 3D
//! one with `k = 0`.

use crate::math::{Index, Real, Vector, AXES, DIM};
use crate::part::{Part, RowGroups};
use serde::{Deserialize, Serialize};

/// Which of the three staggered lattices a quantity lives on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lattice {
    /// Cell centres.
    Cell,
    /// Faces normal to x (x velocity component).
    XFace,
    /// Faces normal to y (y velocity component).
    YFace,
    /// Faces normal to z (z velocity component).
    #[cfg(feature = "dim3")]
    ZFace,
}

impl Lattice {
    /// The faces normal to `axis`.
    pub fn face(axis: usize) -> Lattice {
        match axis {
            0 => Lattice::XFace,
            1 => Lattice::YFace,
            #[cfg(feature = "dim3")]
            2 => Lattice::ZFace,
            _ => panic!("axis {axis} of a {DIM}D grid"),
        }
    }
    /// The axis a face lattice is normal to (`None` for cell centres).
    pub fn axis(self) -> Option<usize> {
        match self {
            Lattice::Cell => None,
            Lattice::XFace => Some(0),
            Lattice::YFace => Some(1),
            #[cfg(feature = "dim3")]
            Lattice::ZFace => Some(2),
        }
    }
}

/// A uniform MAC grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Cells along z.
    #[cfg(feature = "dim3")]
    pub nz: usize,
    /// Cell side (length).
    pub h: Real,
    /// Lower-left corner of the domain.
    pub origin: Vector,
    /// Global index of local cell 0 along each axis: 0 for the whole domain; a rank's
    /// block of a decomposed run (docs/design/mpi.md §2) starts where its storage starts in
    /// the domain's numbering (its halo included, so −2 at a periodic side's wrap).
    pub start: [isize; DIM],
    /// Cells of the whole domain along each axis (`n()` for the whole domain).
    pub domain: Index,
    /// The rank's part of a decomposed domain: its halo exchange, owned nodes and
    /// reductions ([`Part::whole`] on one rank).
    pub part: Part,
}

impl Default for Grid {
    /// No cells (a placeholder until a plugin is given its grid).
    fn default() -> Self {
        Self::from_cells([0; DIM], 0.0, Vector::zeros())
    }
}

impl Grid {
    /// A grid of `nx × ny` square cells of side `h` starting at `origin`.
    #[cfg(feature = "dim2")]
    pub fn new(nx: usize, ny: usize, h: Real, origin: Vector) -> Self {
        Self::from_cells([nx, ny], h, origin)
    }
    /// A grid of `n[0] × n[1] (× n[2])` cells of side `h` starting at `origin`.
    pub fn from_cells(n: Index, h: Real, origin: Vector) -> Self {
        let (start, domain, part) = ([0; DIM], n, Part::whole());
        #[cfg(feature = "dim2")]
        return Self { nx: n[0], ny: n[1], h, origin, start, domain, part };
        #[cfg(feature = "dim3")]
        return Self { nx: n[0], ny: n[1], nz: n[2], h, origin, start, domain, part };
    }
    /// The storage of a block of this domain: `n` cells from global cell `start` (which may
    /// lie outside the domain by a halo's width at a periodic wrap). Its nodes' positions
    /// are the domain's at the same global index, bit for bit; its `size` and `contains`
    /// stay the domain's.
    pub fn block(&self, start: [isize; DIM], n: Index) -> Self {
        let mut g = Self::from_cells(n, self.h, self.origin);
        (g.start, g.domain) = (start, self.domain);
        g
    }
    /// The global index of local index `i` along `axis`.
    #[inline]
    pub fn global(&self, axis: usize, i: usize) -> Real {
        (i as isize + self.start[axis]) as Real
    }
    /// The storage of this rank's block of the domain `self` in a decomposed run: its
    /// owned cells with the halo on the sides that face another rank, and `part`.
    pub fn of_part(&self, part: Part) -> Self {
        let Some((_, block)) = part.block() else {
            return Self { part, ..self.clone() };
        };
        let pads: [[usize; 2]; DIM] = std::array::from_fn(|a| part.pads(a));
        let start = std::array::from_fn(|a| block.cells[a].start as isize - pads[a][0] as isize);
        let n = std::array::from_fn(|a| block.cells[a].len() + pads[a][0] + pads[a][1]);
        let mut g = self.block(start, n);
        g.part = part;
        g
    }
    /// The row groups of the reduction rule over the owned nodes of a lattice.
    pub fn groups(&self, lattice: Lattice) -> RowGroups {
        self.part.groups(lattice, self.shape(lattice), crate::exact::GROUP)
    }
    /// Σ a b over the owned nodes of a lattice (every rank's), by the reduction rule.
    pub fn dot(&self, lattice: Lattice, a: &[Real], b: &[Real]) -> Real {
        self.part.dot(lattice, self.shape(lattice), a, b)
    }
    /// Σ a over the owned nodes of a lattice (every rank's), by the reduction rule.
    pub fn sum(&self, lattice: Lattice, a: &[Real]) -> Real {
        self.part.sum(lattice, self.shape(lattice), a)
    }
    /// The domain's cells (every rank's).
    pub fn domain_cells(&self) -> usize {
        self.domain.iter().product()
    }
    /// Fills the halo of lattice arrays on this grid with their owners' values (nothing to
    /// do on one rank). Every rank calls it with the same lattices in the same order.
    pub fn exchange(&self, arrays: &mut [(Lattice, &mut [Real])]) {
        self.part.exchange(arrays)
    }
    /// [`Grid::exchange`] of face arrays (every component).
    pub fn exchange_faces(&self, faces: &mut FaceArrays) {
        if self.part.is_whole() {
            return;
        }
        #[cfg(feature = "dim2")]
        self.exchange(&mut [(Lattice::XFace, &mut faces.u), (Lattice::YFace, &mut faces.v)]);
        #[cfg(feature = "dim3")]
        self.exchange(&mut [
            (Lattice::XFace, &mut faces.u),
            (Lattice::YFace, &mut faces.v),
            (Lattice::ZFace, &mut faces.w),
        ]);
    }
    /// Cells along each axis.
    pub fn n(&self) -> Index {
        #[cfg(feature = "dim2")]
        return [self.nx, self.ny];
        #[cfg(feature = "dim3")]
        return [self.nx, self.ny, self.nz];
    }
    /// Number of cells.
    pub fn n_cells(&self) -> usize {
        self.n().iter().product()
    }
    /// Number of x-faces.
    pub fn n_xfaces(&self) -> usize {
        self.n_faces(0)
    }
    /// Number of y-faces.
    pub fn n_yfaces(&self) -> usize {
        self.n_faces(1)
    }
    /// Number of faces normal to `axis`.
    pub fn n_faces(&self, axis: usize) -> usize {
        self.shape(Lattice::face(axis)).iter().product()
    }
    /// Nodes of a lattice along each axis: the cells, plus one along a face lattice's axis.
    pub fn shape(&self, lattice: Lattice) -> Index {
        let mut n = self.n();
        if let Some(a) = lattice.axis() {
            n[a] += 1;
        }
        n
    }
    /// Position in storage of node `at` of a lattice (x fastest, then y, then z).
    #[inline]
    pub fn index(&self, lattice: Lattice, at: Index) -> usize {
        let s = self.shape(lattice);
        let mut index = at[DIM - 1];
        for a in (0..DIM - 1).rev() {
            index = at[a] + s[a] * index;
        }
        index
    }
    /// Node of a lattice at a position in storage (the inverse of [`Grid::index`]).
    #[inline]
    pub fn node(&self, lattice: Lattice, mut index: usize) -> Index {
        let s = self.shape(lattice);
        let mut at = [0; DIM];
        for a in AXES {
            at[a] = index % s[a];
            index /= s[a];
        }
        at
    }
    /// The nodes of a lattice in storage order, with their positions in storage:
    /// `(index, at)` (no division per node, unlike [`Grid::node`]).
    pub fn nodes(&self, lattice: Lattice) -> impl Iterator<Item = (usize, Index)> {
        let s = self.shape(lattice);
        let count: usize = s.iter().product();
        let mut at = [0; DIM];
        (0..count).map(move |index| {
            let here = at;
            for a in AXES {
                at[a] += 1;
                if at[a] < s[a] {
                    break;
                }
                at[a] = 0;
            }
            (index, here)
        })
    }
    /// The nodes of a lattice whose coordinate along `axis` is `i` (a layer one node
    /// thick, e.g. the faces on a side), in storage order, with their positions in storage.
    pub fn layer(&self, lattice: Lattice, axis: usize, i: usize) -> impl Iterator<Item = (usize, Index)> + '_ {
        let mut shape = self.shape(lattice);
        shape[axis] = 1;
        let count: usize = shape.iter().product();
        let mut at = [0; DIM];
        at[axis] = i;
        (0..count).map(move |_| {
            let here = at;
            for a in AXES.into_iter().filter(|&a| a != axis) {
                at[a] += 1;
                if at[a] < shape[a] {
                    break;
                }
                at[a] = 0;
            }
            (self.index(lattice, here), here)
        })
    }
    /// Volume (area in 2D) of one cell.
    pub fn cell_volume(&self) -> Real {
        #[cfg(feature = "dim2")]
        return self.h * self.h;
        #[cfg(feature = "dim3")]
        return self.h * self.h * self.h;
    }
    /// Position of node `at` of a lattice: cell centres at half-integer multiples of `h`,
    /// faces on integer multiples along their axis.
    pub fn position(&self, lattice: Lattice, at: Index) -> Vector {
        self.origin
            + Vector::from_fn(|a, _| {
                let offset = if lattice.axis() == Some(a) { 0.0 } else { 0.5 };
                (self.global(a, at[a]) + offset) * self.h
            })
    }
    /// Index of cell `(i, j)`.
    #[cfg(feature = "dim2")]
    #[inline]
    pub fn cell(&self, i: usize, j: usize) -> usize {
        i + j * self.nx
    }
    /// Index of x-face `(i, j)`: the face between cells `(i-1, j)` and `(i, j)`.
    #[cfg(feature = "dim2")]
    #[inline]
    pub fn xface(&self, i: usize, j: usize) -> usize {
        i + j * (self.nx + 1)
    }
    /// Index of y-face `(i, j)`: the face between cells `(i, j-1)` and `(i, j)`.
    #[cfg(feature = "dim2")]
    #[inline]
    pub fn yface(&self, i: usize, j: usize) -> usize {
        i + j * self.nx
    }
    /// Size of the domain.
    pub fn size(&self) -> Vector {
        let n = self.domain;
        Vector::from_fn(|a, _| n[a] as Real * self.h)
    }
    /// Shape `(columns, rows)` of a lattice.
    #[cfg(feature = "dim2")]
    pub fn lattice_shape(&self, lattice: Lattice) -> (usize, usize) {
        match lattice {
            Lattice::Cell => (self.nx, self.ny),
            Lattice::XFace => (self.nx + 1, self.ny),
            Lattice::YFace => (self.nx, self.ny + 1),
        }
    }
    /// Offset of a lattice's node `(0, 0)` from the origin, in cells.
    #[cfg(feature = "dim2")]
    pub fn lattice_offset(&self, lattice: Lattice) -> (Real, Real) {
        match lattice {
            Lattice::Cell => (0.5, 0.5),
            Lattice::XFace => (0.0, 0.5),
            Lattice::YFace => (0.5, 0.0),
        }
    }
    /// Position of node `(i, j)` of a lattice.
    #[cfg(feature = "dim2")]
    pub fn node_position(&self, lattice: Lattice, i: usize, j: usize) -> Vector {
        let (ox, oy) = self.lattice_offset(lattice);
        self.origin + Vector::new((self.global(0, i) + ox) * self.h, (self.global(1, j) + oy) * self.h)
    }
    /// Centre of cell `(i, j)`.
    #[cfg(feature = "dim2")]
    pub fn cell_center(&self, i: usize, j: usize) -> Vector {
        self.node_position(Lattice::Cell, i, j)
    }
    /// Whether a point lies inside the domain (boundary included).
    pub fn contains(&self, p: Vector) -> bool {
        let q = p - self.origin;
        let s = self.size();
        #[cfg(feature = "dim2")]
        return q.x >= 0.0 && q.y >= 0.0 && q.x <= s.x && q.y <= s.y;
        #[cfg(feature = "dim3")]
        return AXES.iter().all(|&a| q[a] >= 0.0 && q[a] <= s[a]);
    }
}

/// One array per face lattice: entry `a` on the faces normal to axis `a` (a velocity's
/// component `a`, or a face volume fraction or mass). Named (`u`, `v`, `w`) and indexed by
/// axis (`arrays[a]`) alike.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FaceArrays {
    /// x component on x-faces.
    pub u: Vec<Real>,
    /// y component on y-faces.
    pub v: Vec<Real>,
    /// z component on z-faces.
    #[cfg(feature = "dim3")]
    pub w: Vec<Real>,
}

/// Velocity components on the face lattices.
pub type FaceVelocity = FaceArrays;

impl FaceArrays {
    /// Zeros on `grid`.
    pub fn zeros(grid: &Grid) -> Self {
        Self {
            u: vec![0.0; grid.n_xfaces()],
            v: vec![0.0; grid.n_yfaces()],
            #[cfg(feature = "dim3")]
            w: vec![0.0; grid.n_faces(2)],
        }
    }
    /// Largest absolute face component.
    pub fn max_abs(&self) -> Real {
        let m = self.u.iter().chain(self.v.iter()).fold(0.0, |m: Real, x| m.max(x.abs()));
        #[cfg(feature = "dim3")]
        let m = self.w.iter().fold(m, |m, x| m.max(x.abs()));
        m
    }
}

impl std::ops::Index<usize> for FaceArrays {
    type Output = Vec<Real>;
    #[inline]
    fn index(&self, axis: usize) -> &Vec<Real> {
        match axis {
            0 => &self.u,
            1 => &self.v,
            #[cfg(feature = "dim3")]
            2 => &self.w,
            _ => panic!("component {axis} of a {DIM}D face velocity"),
        }
    }
}

impl std::ops::IndexMut<usize> for FaceArrays {
    #[inline]
    fn index_mut(&mut self, axis: usize) -> &mut Vec<Real> {
        match axis {
            0 => &mut self.u,
            1 => &mut self.v,
            #[cfg(feature = "dim3")]
            2 => &mut self.w,
            _ => panic!("component {axis} of a {DIM}D face velocity"),
        }
    }
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;

    #[test]
    fn the_generic_index_is_the_2d_one() {
        let g = Grid::new(5, 3, 0.5, Vector::new(1.0, 2.0));
        for j in 0..3 {
            for i in 0..=5 {
                assert_eq!(g.index(Lattice::XFace, [i, j]), g.xface(i, j));
                assert_eq!(g.node(Lattice::XFace, g.xface(i, j)), [i, j]);
                assert_eq!(g.position(Lattice::XFace, [i, j]), g.node_position(Lattice::XFace, i, j));
            }
        }
        for j in 0..=3 {
            for i in 0..5 {
                assert_eq!(g.index(Lattice::YFace, [i, j]), g.yface(i, j));
                assert_eq!(g.position(Lattice::YFace, [i, j]), g.node_position(Lattice::YFace, i, j));
            }
        }
        assert_eq!((g.n_faces(0), g.n_faces(1), g.cell_volume()), (18, 20, 0.25));
        // a block of a domain, its storage starting two cells before the domain (a halo
        // across a periodic wrap): every node where the domain's node of the same global
        // index is, bit for bit, and the domain's extent
        let domain = Grid::new(40, 24, 0.37, Vector::new(-1.3, 2.1));
        let block = domain.block([-2, 9], [13, 7]);
        assert_eq!((block.n(), block.size(), block.contains(Vector::new(10.0, 9.0))), ([13, 7], domain.size(), true));
        for lattice in [Lattice::Cell, Lattice::XFace, Lattice::YFace] {
            for (_, at) in block.nodes(lattice) {
                let (gi, gj) = (at[0] as isize - 2, at[1] + 9);
                let global = if gi >= 0 {
                    domain.position(lattice, [gi as usize, gj])
                } else {
                    // beyond the low side: one period below the domain's node gi + 40
                    domain.position(lattice, [(gi + 40) as usize, gj]) - Vector::new(40.0 * 0.37, 0.0)
                };
                assert_eq!(block.position(lattice, at).y, global.y);
                if gi >= 0 {
                    assert_eq!(block.position(lattice, at), global);
                    assert_eq!(block.node_position(lattice, at[0], at[1]), global);
                } else {
                    assert!((block.position(lattice, at).x - global.x).abs() < 1e-13);
                }
            }
        }
        assert_eq!(g.position(Lattice::Cell, [1, 2]), g.cell_center(1, 2));
        for lattice in [Lattice::Cell, Lattice::XFace, Lattice::YFace] {
            for (axis, i) in [(0, 0), (0, 4), (1, 2)] {
                let layer: Vec<_> = g.layer(lattice, axis, i).collect();
                let expect: Vec<_> = g.nodes(lattice).filter(|(_, at)| at[axis] == i).collect();
                assert_eq!(layer, expect);
            }
            let nodes: Vec<_> = g.nodes(lattice).collect();
            assert_eq!(nodes.len(), g.shape(lattice).iter().product::<usize>());
            assert!(nodes.iter().all(|&(k, at)| g.node(lattice, k) == at && g.index(lattice, at) == k));
        }
    }
}
