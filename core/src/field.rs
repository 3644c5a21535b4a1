//! A field's state on the grid: the scratch space every frame fills and reads back.

use crate::grid::{FaceArrays, FaceVelocity, Grid};
use crate::math::Real;
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
