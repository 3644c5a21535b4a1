//! Boundary conditions on the sides of the domain (four in 2D, six in 3D).
//!
//! On the MAC grid a side holds the faces normal to it (their velocity is the wall's
//! normal velocity, or free for an outflow) and sets ghost values for the tangential
//! component half a cell outside: `2 u_wall − u_inside` for a no-slip or moving wall,
//! `u_inside` for a free-slip wall or an outflow.

use crate::grid::{FaceVelocity, Grid};
use crate::math::{Index, Real, Vector, DIM, SIDES};
use serde::{Deserialize, Serialize};

/// One side of the rectangular domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// x = x_min.
    Left,
    /// x = x_max.
    Right,
    /// y = y_min.
    Bottom,
    /// y = y_max.
    Top,
    /// z = z_min.
    #[cfg(feature = "dim3")]
    Back,
    /// z = z_max.
    #[cfg(feature = "dim3")]
    Front,
}

/// Where along a side a point is: the fraction (0..1) of the way along each of the side's
/// tangential axes, in axis order (one number in 2D, two in 3D).
#[cfg(feature = "dim2")]
pub type Along = Real;
/// Where along a side a point is: the fraction (0..1) of the way along each of the side's
/// tangential axes, in axis order (one number in 2D, two in 3D).
#[cfg(feature = "dim3")]
pub type Along = [Real; 2];

/// The middle of a side.
#[cfg(feature = "dim2")]
pub const MIDDLE: Along = 0.5;
/// The middle of a side.
#[cfg(feature = "dim3")]
pub const MIDDLE: Along = [0.5, 0.5];

/// What lies across one side of a face in the stencils of a face lattice
/// ([`Boundaries::face_neighbour`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaceNeighbour {
    /// The face at this node of the same lattice (wrapped across a periodic side).
    Face(Index),
    /// Along the component at an open end (outflow): the face itself.
    Itself,
    /// Across the component at a wall or an inflow: the boundary's ghost value, at this
    /// position along the side ([`Boundaries::ghost`]).
    Ghost(Along),
}

/// The axes along a side normal to `axis`, in order.
pub fn tangential_axes(axis: usize) -> [usize; DIM - 1] {
    let mut t = [0; DIM - 1];
    for (k, a) in (0..DIM).filter(|&a| a != axis).enumerate() {
        t[k] = a;
    }
    t
}

/// An [`Along`] from the fractions along a side's tangential axes.
pub fn along(fractions: [Real; DIM - 1]) -> Along {
    #[cfg(feature = "dim2")]
    return fractions[0];
    #[cfg(feature = "dim3")]
    return fractions;
}

impl Side {
    /// All sides, axis by axis, the low side first.
    #[cfg(feature = "dim2")]
    pub const ALL: [Side; SIDES] = [Side::Left, Side::Right, Side::Bottom, Side::Top];
    /// All sides, axis by axis, the low side first.
    #[cfg(feature = "dim3")]
    pub const ALL: [Side; SIDES] = [Side::Left, Side::Right, Side::Bottom, Side::Top, Side::Back, Side::Front];
    /// The side of `axis` at its low (`high == false`) or high end.
    pub fn of(axis: usize, high: bool) -> Side {
        Side::ALL[2 * axis + high as usize]
    }
    /// The axis the side is normal to.
    pub fn axis(self) -> usize {
        self as usize / 2
    }
    /// Whether the side is at the high end of its axis.
    pub fn high(self) -> bool {
        self as usize % 2 == 1
    }
    /// The side's name in a case file.
    pub fn name(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
            Side::Bottom => "bottom",
            Side::Top => "top",
            #[cfg(feature = "dim3")]
            Side::Back => "back",
            #[cfg(feature = "dim3")]
            Side::Front => "front",
        }
    }
    /// The side across the domain.
    pub fn opposite(self) -> Side {
        Side::of(self.axis(), !self.high())
    }
}

/// Shape of a prescribed velocity along a side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Profile {
    /// The same velocity along the whole side.
    #[default]
    Uniform,
    /// A parabola vanishing at both ends of the side, equal to the given velocity at its
    /// middle (in 3D the product of the parabolas along the side's two axes).
    Parabolic,
}

/// The condition on one side.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Boundary {
    /// Wall at rest; fluid sticks to it.
    NoSlip,
    /// Wall at rest; fluid slides along it without friction.
    FreeSlip,
    /// The domain repeats across this side; the opposite side must be periodic too.
    Periodic,
    /// Prescribed velocity (length/time): a moving wall when the normal component is zero,
    /// an inflow when it points into the domain.
    Velocity {
        /// Velocity `(u, v)` (or `(u, v, w)`) at the side (at its middle for a parabolic
        /// profile).
        velocity: [Real; DIM],
        /// How the velocity varies along the side.
        #[serde(default)]
        profile: Profile,
    },
    /// Open side at a fixed pressure (force/length in 2D, force/area in 3D).
    Outflow {
        /// Pressure at the side.
        #[serde(default)]
        pressure: Real,
    },
    /// Not a side of the domain: a rank's block of a decomposed run (docs/design/mpi.md
    /// §2) ends here and its halo holds the neighbouring rank's values. Nothing is imposed
    /// (the normal velocity is free and ghost rules copy the nearest value); what the
    /// kernels compute at the halo nodes is never read before the next exchange. Never in
    /// a case file (`Boundaries::local` makes it).
    #[serde(skip)]
    Halo,
}

/// The conditions on all sides.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Boundaries {
    /// x = x_min.
    pub left: Boundary,
    /// x = x_max.
    pub right: Boundary,
    /// y = y_min.
    pub bottom: Boundary,
    /// y = y_max.
    pub top: Boundary,
    /// z = z_min.
    #[cfg(feature = "dim3")]
    pub back: Boundary,
    /// z = z_max.
    #[cfg(feature = "dim3")]
    pub front: Boundary,
}

impl Default for Boundaries {
    fn default() -> Self {
        Self {
            left: Boundary::NoSlip,
            right: Boundary::NoSlip,
            bottom: Boundary::NoSlip,
            top: Boundary::NoSlip,
            #[cfg(feature = "dim3")]
            back: Boundary::NoSlip,
            #[cfg(feature = "dim3")]
            front: Boundary::NoSlip,
        }
    }
}

impl Boundaries {
    /// The condition on `side`.
    pub fn side(&self, side: Side) -> Boundary {
        match side {
            Side::Left => self.left,
            Side::Right => self.right,
            Side::Bottom => self.bottom,
            Side::Top => self.top,
            #[cfg(feature = "dim3")]
            Side::Back => self.back,
            #[cfg(feature = "dim3")]
            Side::Front => self.front,
        }
    }
    /// The sides of rank's block (`part` of a decomposed domain): [`Boundary::Halo`] where
    /// the storage has a halo (a side facing another rank), the domain's elsewhere (a side
    /// of the domain, and a periodic axis the rank spans alone, which wraps within it).
    pub fn local(&self, part: &crate::part::Part) -> Self {
        let mut b = *self;
        for side in Side::ALL {
            if part.pads(side.axis())[side.high() as usize] > 0 {
                *b.side_mut(side) = Boundary::Halo;
            }
        }
        b
    }
    /// The condition on `side`, to change.
    fn side_mut(&mut self, side: Side) -> &mut Boundary {
        match side {
            Side::Left => &mut self.left,
            Side::Right => &mut self.right,
            Side::Bottom => &mut self.bottom,
            Side::Top => &mut self.top,
            #[cfg(feature = "dim3")]
            Side::Back => &mut self.back,
            #[cfg(feature = "dim3")]
            Side::Front => &mut self.front,
        }
    }
    /// Periodic along `axis`.
    pub fn periodic(&self, axis: usize) -> bool {
        self.side(Side::of(axis, false)) == Boundary::Periodic
    }
    /// Periodic along each axis.
    pub fn periodic_axes(&self) -> [bool; DIM] {
        std::array::from_fn(|a| self.periodic(a))
    }
    /// Whether any side fixes the pressure (otherwise it is defined up to a constant).
    pub fn has_dirichlet_pressure(&self) -> bool {
        Side::ALL.iter().any(|&s| matches!(self.side(s), Boundary::Outflow { .. }))
    }
    /// Checks that periodic sides come in pairs.
    pub fn validate(&self) -> Result<(), String> {
        for s in (0..DIM).map(|a| Side::of(a, false)) {
            let a = self.side(s) == Boundary::Periodic;
            let b = self.side(s.opposite()) == Boundary::Periodic;
            if a != b {
                let (p, o) = if a { (s, s.opposite()) } else { (s.opposite(), s) };
                return Err(format!(
                    "boundaries.{} is Periodic but boundaries.{} is {:?}: periodic sides come in pairs; \
                     make both Periodic or neither",
                    p.name(),
                    o.name(),
                    self.side(o)
                ));
            }
        }
        Ok(())
    }

    /// Whether `side` is an inflow: a `Velocity` boundary whose velocity points into the
    /// domain.
    pub fn is_inflow(&self, side: Side) -> bool {
        match self.side(side) {
            Boundary::Velocity { velocity, .. } => {
                let normal = velocity[side.axis()];
                if side.high() {
                    normal < 0.0
                } else {
                    normal > 0.0
                }
            }
            _ => false,
        }
    }

    /// Prescribed velocity of `side` at `s`, the fraction (0..1) of the way along it.
    pub fn wall_velocity(&self, side: Side, s: Along) -> Vector {
        match self.side(side) {
            Boundary::Velocity { velocity, profile } => {
                #[cfg(feature = "dim2")]
                let scale = match profile {
                    Profile::Uniform => 1.0,
                    Profile::Parabolic => 4.0 * s * (1.0 - s),
                };
                #[cfg(feature = "dim3")]
                let scale = match profile {
                    Profile::Uniform => 1.0,
                    Profile::Parabolic => 4.0 * s[0] * (1.0 - s[0]) * (4.0 * s[1] * (1.0 - s[1])),
                };
                Vector::from(velocity) * scale
            }
            _ => Vector::zeros(),
        }
    }

    /// Ghost value of the tangential component half a cell outside `side`,
    /// given the value just inside and the fraction `s` along the side.
    #[cfg(feature = "dim2")]
    #[inline]
    pub fn tangential_ghost(&self, side: Side, inside: Real, s: Along) -> Real {
        self.ghost(side, tangential_axes(side.axis())[0], inside, s)
    }

    /// Ghost value of the tangential velocity component `component` half a cell outside
    /// `side`, given the value just inside and the position `s` along the side.
    #[inline]
    pub fn ghost(&self, side: Side, component: usize, inside: Real, s: Along) -> Real {
        match self.side(side) {
            Boundary::NoSlip => -inside,
            Boundary::FreeSlip | Boundary::Outflow { .. } | Boundary::Periodic | Boundary::Halo => inside,
            Boundary::Velocity { .. } => 2.0 * self.wall_velocity(side, s)[component] - inside,
        }
    }

    /// Normal velocity imposed on the faces of `side`, or `None` where it is free
    /// (outflow) or periodic.
    #[inline]
    pub fn normal_velocity(&self, side: Side, s: Along) -> Option<Real> {
        match self.side(side) {
            Boundary::NoSlip | Boundary::FreeSlip => Some(0.0),
            Boundary::Velocity { .. } => Some(self.wall_velocity(side, s)[side.axis()]),
            Boundary::Periodic | Boundary::Outflow { .. } | Boundary::Halo => None,
        }
    }

    /// Sets the faces on the domain boundary: imposed normal velocities, and the copy of
    /// face 0 onto face n on periodic sides.
    #[cfg(feature = "dim2")]
    pub fn enforce(&self, grid: &Grid, vel: &mut FaceVelocity) {
        let (nx, ny) = (grid.nx, grid.ny);
        for j in 0..ny {
            // the fraction along the side in the domain's numbering (a block's cells are not
            // the domain's: docs/design/mpi.md §2)
            let s = (grid.global(1, j) + 0.5) / grid.domain[1] as Real;
            if self.periodic(0) {
                vel.u[grid.xface(nx, j)] = vel.u[grid.xface(0, j)];
            } else {
                if let Some(w) = self.normal_velocity(Side::Left, s) {
                    vel.u[grid.xface(0, j)] = w;
                }
                if let Some(w) = self.normal_velocity(Side::Right, s) {
                    vel.u[grid.xface(nx, j)] = w;
                }
            }
        }
        for i in 0..nx {
            let s = (grid.global(0, i) + 0.5) / grid.domain[0] as Real;
            if self.periodic(1) {
                vel.v[grid.yface(i, ny)] = vel.v[grid.yface(i, 0)];
            } else {
                if let Some(w) = self.normal_velocity(Side::Bottom, s) {
                    vel.v[grid.yface(i, 0)] = w;
                }
                if let Some(w) = self.normal_velocity(Side::Top, s) {
                    vel.v[grid.yface(i, ny)] = w;
                }
            }
        }
    }

    /// Sets the faces on the domain boundary: imposed normal velocities, and the copy of
    /// face 0 onto face n on periodic sides.
    #[cfg(feature = "dim3")]
    pub fn enforce(&self, grid: &Grid, vel: &mut FaceVelocity) {
        use crate::grid::Lattice;
        let n = grid.n();
        for a in 0..DIM {
            let lattice = Lattice::face(a);
            let [t0, t1] = tangential_axes(a);
            for q in 0..n[t1] {
                for p in 0..n[t0] {
                    let s = [
                        (grid.global(t0, p) + 0.5) / grid.domain[t0] as Real,
                        (grid.global(t1, q) + 0.5) / grid.domain[t1] as Real,
                    ];
                    let at = |i: usize| {
                        let mut at = [0; DIM];
                        (at[a], at[t0], at[t1]) = (i, p, q);
                        grid.index(lattice, at)
                    };
                    let (lo, hi) = (at(0), at(n[a]));
                    if self.periodic(a) {
                        vel[a][hi] = vel[a][lo];
                    } else {
                        if let Some(w) = self.normal_velocity(Side::of(a, false), s) {
                            vel[a][lo] = w;
                        }
                        if let Some(w) = self.normal_velocity(Side::of(a, true), s) {
                            vel[a][hi] = w;
                        }
                    }
                }
            }
        }
    }

    /// The neighbour across `side` of face `at` of the faces normal to `axis` (component
    /// `axis` of the velocity), on a grid of `n` cells: along the component the next face,
    /// or at an open end the face itself; across it the next face (wrapped when periodic)
    /// or the boundary's ghost, at the face's own coordinate along its axis and the cell
    /// centre's along the others (fractions of the domain's side: a rank's block gives its
    /// nodes' global coordinates). The 5-point (7-point) stencils of the viscous terms.
    pub fn face_neighbour(&self, grid: &Grid, axis: usize, at: Index, side: Side) -> FaceNeighbour {
        let n = grid.n();
        let (d, high) = (side.axis(), side.high());
        let mut m = at;
        if d == axis {
            if !high && at[axis] > 0 {
                m[axis] -= 1;
            } else if !high && self.periodic(axis) {
                m[axis] = n[axis] - 1;
            } else if high && at[axis] < n[axis] {
                m[axis] += 1;
            } else {
                return FaceNeighbour::Itself;
            }
        } else if !high && at[d] > 0 {
            m[d] -= 1;
        } else if high && at[d] + 1 < n[d] {
            m[d] += 1;
        } else if self.periodic(d) {
            m[d] = if high { 0 } else { n[d] - 1 };
        } else {
            let s = tangential_axes(d).map(|t| {
                if t == axis {
                    grid.global(axis, at[axis]) / grid.domain[axis] as Real
                } else {
                    (grid.global(t, at[t]) + 0.5) / grid.domain[t] as Real
                }
            });
            return FaceNeighbour::Ghost(along(s));
        }
        FaceNeighbour::Face(m)
    }

    /// Whether the faces normal to `axis` at position `i` along it have a fixed velocity
    /// (wall or inflow), so that no force or pressure gradient acts on them.
    #[inline]
    pub fn face_fixed(&self, grid: &Grid, axis: usize, i: usize) -> bool {
        (i == 0 && self.normal_velocity(Side::of(axis, false), MIDDLE).is_some())
            || (i == grid.n()[axis] && self.normal_velocity(Side::of(axis, true), MIDDLE).is_some())
    }

    /// Whether the x-face `(i, ·)` has a fixed velocity (wall or inflow), so that no force
    /// or pressure gradient acts on it.
    #[cfg(feature = "dim2")]
    #[inline]
    pub fn xface_fixed(&self, grid: &Grid, i: usize) -> bool {
        (i == 0 && self.normal_velocity(Side::Left, 0.5).is_some())
            || (i == grid.nx && self.normal_velocity(Side::Right, 0.5).is_some())
    }
    /// Whether the y-face `(·, j)` has a fixed velocity.
    #[cfg(feature = "dim2")]
    #[inline]
    pub fn yface_fixed(&self, grid: &Grid, j: usize) -> bool {
        (j == 0 && self.normal_velocity(Side::Bottom, 0.5).is_some())
            || (j == grid.ny && self.normal_velocity(Side::Top, 0.5).is_some())
    }
}
