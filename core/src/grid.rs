//! The staggered (MAC) grid shared by every field.
//!
//! Pressure, volume fractions and densities live at cell centres; the x velocity
//! component lives on the faces normal to x ("x-faces", `(nx + 1) × ny`), the y component
//! on the faces normal to y ("y-faces", `nx × (ny + 1)`). Cells are square with side `h`.

use crate::math::{Real, Vector};
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
}

/// A uniform MAC grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Cell side (length).
    pub h: Real,
    /// Lower-left corner of the domain.
    pub origin: Vector,
}

impl Grid {
    /// A grid of `nx × ny` square cells of side `h` starting at `origin`.
    pub fn new(nx: usize, ny: usize, h: Real, origin: Vector) -> Self {
        Self { nx, ny, h, origin }
    }
    /// Number of cells.
    pub fn n_cells(&self) -> usize {
        self.nx * self.ny
    }
    /// Number of x-faces.
    pub fn n_xfaces(&self) -> usize {
        (self.nx + 1) * self.ny
    }
    /// Number of y-faces.
    pub fn n_yfaces(&self) -> usize {
        self.nx * (self.ny + 1)
    }
    /// Index of cell `(i, j)`.
    #[inline]
    pub fn cell(&self, i: usize, j: usize) -> usize {
        i + j * self.nx
    }
    /// Index of x-face `(i, j)`: the face between cells `(i-1, j)` and `(i, j)`.
    #[inline]
    pub fn xface(&self, i: usize, j: usize) -> usize {
        i + j * (self.nx + 1)
    }
    /// Index of y-face `(i, j)`: the face between cells `(i, j-1)` and `(i, j)`.
    #[inline]
    pub fn yface(&self, i: usize, j: usize) -> usize {
        i + j * self.nx
    }
    /// Size of the domain.
    pub fn size(&self) -> Vector {
        Vector::new(self.nx as Real * self.h, self.ny as Real * self.h)
    }
    /// Area of one cell.
    pub fn cell_area(&self) -> Real {
        self.h * self.h
    }
    /// Shape `(columns, rows)` of a lattice.
    pub fn lattice_shape(&self, lattice: Lattice) -> (usize, usize) {
        match lattice {
            Lattice::Cell => (self.nx, self.ny),
            Lattice::XFace => (self.nx + 1, self.ny),
            Lattice::YFace => (self.nx, self.ny + 1),
        }
    }
    /// Offset of a lattice's node `(0, 0)` from the origin, in cells.
    pub fn lattice_offset(&self, lattice: Lattice) -> (Real, Real) {
        match lattice {
            Lattice::Cell => (0.5, 0.5),
            Lattice::XFace => (0.0, 0.5),
            Lattice::YFace => (0.5, 0.0),
        }
    }
    /// Position of node `(i, j)` of a lattice.
    pub fn node_position(&self, lattice: Lattice, i: usize, j: usize) -> Vector {
        let (ox, oy) = self.lattice_offset(lattice);
        self.origin + Vector::new((i as Real + ox) * self.h, (j as Real + oy) * self.h)
    }
    /// Centre of cell `(i, j)`.
    pub fn cell_center(&self, i: usize, j: usize) -> Vector {
        self.node_position(Lattice::Cell, i, j)
    }
    /// Whether a point lies inside the domain (boundary included).
    pub fn contains(&self, p: Vector) -> bool {
        let q = p - self.origin;
        let s = self.size();
        q.x >= 0.0 && q.y >= 0.0 && q.x <= s.x && q.y <= s.y
    }
}

/// Velocity components on the two face lattices of a grid.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FaceVelocity {
    /// x component on x-faces.
    pub u: Vec<Real>,
    /// y component on y-faces.
    pub v: Vec<Real>,
}

impl FaceVelocity {
    /// Zero velocity on `grid`.
    pub fn zeros(grid: &Grid) -> Self {
        Self { u: vec![0.0; grid.n_xfaces()], v: vec![0.0; grid.n_yfaces()] }
    }
    /// Largest absolute face component.
    pub fn max_abs(&self) -> Real {
        self.u.iter().chain(self.v.iter()).fold(0.0, |m, x| m.max(x.abs()))
    }
}
