//! A field's state on the grid: the scratch space every frame fills and reads back.

use crate::grid::{FaceArrays, FaceVelocity, Grid, Lattice};
use crate::math::{Real, AXES};
use serde::{Deserialize, Serialize};

/// One field's quantities on the MAC grid for the current step.
///
/// A Lagrangian frame rebuilds it from its points every step; an Eulerian frame keeps
/// its state here. The core reads and updates it through the phases of a step.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct FieldState {
    /// Volume fraction θ at cell centres.
    pub theta: Vec<Real>,
    /// Volume fraction on the faces (mean of the two neighbouring cells), one array per
    /// face lattice.
    pub theta_face: FaceArrays,
    /// Mass in the control volume of each face (θρ⁰h² for a full face in 2D, θρ⁰h³ in 3D).
    pub mass_face: FaceArrays,
    /// Grid velocity: u^n after particles to grid, then provisional, then final.
    pub velocity: FaceVelocity,
    /// Velocity at the start of the step (for FLIP increments).
    pub velocity_old: FaceVelocity,
    /// Pressure acceleration −w∇p of the last corrector (for the Eulerian predictor).
    pub pressure_acceleration: FaceVelocity,
    /// Effective specific volume w of the last exchange solve, on faces (volume/mass).
    pub specific_volume: FaceVelocity,
    /// Force per unit mass of the immersed boundaries on this fluid in the last step
    /// (`multifield_core::immersed::couple`), lagged into the Eulerian predictor as the
    /// pressure acceleration is; zero for a field that no direct forcing acts on.
    pub body_force: FaceVelocity,
}

impl FieldState {
    /// Zeroed state for `grid`.
    pub fn new(grid: &Grid) -> Self {
        Self {
            theta: vec![0.0; grid.n_cells()],
            theta_face: FaceArrays::zeros(grid),
            mass_face: FaceArrays::zeros(grid),
            velocity: FaceVelocity::zeros(grid),
            velocity_old: FaceVelocity::zeros(grid),
            pressure_acceleration: FaceVelocity::zeros(grid),
            specific_volume: FaceVelocity::zeros(grid),
            body_force: FaceVelocity::zeros(grid),
        }
    }

    /// The whole domain's state from the blocks of a decomposed run (`grid`: this rank's
    /// block), every array gathered from the ranks' owned nodes, on every rank; a copy on
    /// one rank. Every rank calls it.
    pub fn gathered(&self, grid: &Grid) -> FieldState {
        let part = &grid.part;
        let faces = |f: &FaceArrays| {
            let mut out = FaceArrays::default();
            for a in AXES {
                let lattice = Lattice::face(a);
                out[a] = part.gather(lattice, grid.shape(lattice), &f[a]);
            }
            out
        };
        FieldState {
            theta: part.gather(Lattice::Cell, grid.shape(Lattice::Cell), &self.theta),
            theta_face: faces(&self.theta_face),
            mass_face: faces(&self.mass_face),
            velocity: faces(&self.velocity),
            velocity_old: faces(&self.velocity_old),
            pressure_acceleration: faces(&self.pressure_acceleration),
            specific_volume: faces(&self.specific_volume),
            body_force: faces(&self.body_force),
        }
    }

    /// This rank's block (`grid`) of the whole domain's state `whole` (the inverse of
    /// [`FieldState::gathered`], halo included); `None` when `whole` is not of the domain's
    /// size.
    pub fn block_of(grid: &Grid, whole: &FieldState) -> Option<FieldState> {
        let part = &grid.part;
        let domain = Grid::from_cells(grid.domain, grid.h, grid.origin);
        let mut out = FieldState::new(grid);
        let cell = |local: &mut Vec<Real>, whole: &[Real]| {
            (whole.len() == domain.n_cells())
                .then(|| part.scatter(Lattice::Cell, grid.shape(Lattice::Cell), whole, local))
        };
        let faces = |local: &mut FaceArrays, whole: &FaceArrays| -> Option<()> {
            for a in AXES {
                let lattice = Lattice::face(a);
                if whole[a].len() != domain.n_faces(a) {
                    return None;
                }
                part.scatter(lattice, grid.shape(lattice), &whole[a], &mut local[a]);
            }
            Some(())
        };
        cell(&mut out.theta, &whole.theta)?;
        faces(&mut out.theta_face, &whole.theta_face)?;
        faces(&mut out.mass_face, &whole.mass_face)?;
        faces(&mut out.velocity, &whole.velocity)?;
        faces(&mut out.velocity_old, &whole.velocity_old)?;
        faces(&mut out.pressure_acceleration, &whole.pressure_acceleration)?;
        faces(&mut out.specific_volume, &whole.specific_volume)?;
        faces(&mut out.body_force, &whole.body_force)?;
        Some(out)
    }

    /// Face volume fractions from the cell ones: the mean of the two neighbours, the
    /// inside cell on a wall, the wrapped neighbour on a periodic side.
    #[cfg(feature = "dim2")]
    pub fn update_face_fractions(&mut self, grid: &Grid, periodic: [bool; crate::math::DIM]) {
        let (nx, ny) = (grid.nx, grid.ny);
        let [periodic_x, periodic_y] = periodic;
        for j in 0..ny {
            for i in 0..=nx {
                let l = if i > 0 {
                    Some(i - 1)
                } else if periodic_x {
                    Some(nx - 1)
                } else {
                    None
                };
                let r = if i < nx {
                    Some(i)
                } else if periodic_x {
                    Some(0)
                } else {
                    None
                };
                let t = match (l, r) {
                    (Some(l), Some(r)) => 0.5 * (self.theta[grid.cell(l, j)] + self.theta[grid.cell(r, j)]),
                    (Some(c), None) | (None, Some(c)) => self.theta[grid.cell(c, j)],
                    (None, None) => 0.0,
                };
                self.theta_face.u[grid.xface(i, j)] = t;
            }
        }
        for j in 0..=ny {
            for i in 0..nx {
                let b = if j > 0 {
                    Some(j - 1)
                } else if periodic_y {
                    Some(ny - 1)
                } else {
                    None
                };
                let t = if j < ny {
                    Some(j)
                } else if periodic_y {
                    Some(0)
                } else {
                    None
                };
                let th = match (b, t) {
                    (Some(b), Some(t)) => 0.5 * (self.theta[grid.cell(i, b)] + self.theta[grid.cell(i, t)]),
                    (Some(c), None) | (None, Some(c)) => self.theta[grid.cell(i, c)],
                    (None, None) => 0.0,
                };
                self.theta_face.v[grid.yface(i, j)] = th;
            }
        }
    }

    /// Face volume fractions from the cell ones: the mean of the two neighbours, the
    /// inside cell on a wall, the wrapped neighbour on a periodic side.
    #[cfg(feature = "dim3")]
    pub fn update_face_fractions(&mut self, grid: &Grid, periodic: [bool; crate::math::DIM]) {
        use crate::grid::Lattice;
        use crate::math::AXES;
        let n = grid.n();
        for a in AXES {
            let lattice = Lattice::face(a);
            for (f, at) in grid.nodes(lattice) {
                let side = |c: Option<usize>| {
                    c.map(|c| {
                        let mut cell = at;
                        cell[a] = c;
                        self.theta[grid.index(Lattice::Cell, cell)]
                    })
                };
                let i = at[a];
                let l = if i > 0 { Some(i - 1) } else { periodic[a].then_some(n[a] - 1) };
                let r = if i < n[a] { Some(i) } else { periodic[a].then_some(0) };
                self.theta_face[a][f] = match (side(l), side(r)) {
                    (Some(l), Some(r)) => 0.5 * (l + r),
                    (Some(c), None) | (None, Some(c)) => c,
                    (None, None) => 0.0,
                };
            }
        }
    }
}
