//! Boundary conditions on the four sides of the domain.
//!
//! On the MAC grid a side holds the faces normal to it (their velocity is the wall's
//! normal velocity, or free for an outflow) and sets ghost values for the tangential
//! component half a cell outside: `2 u_wall − u_inside` for a no-slip or moving wall,
//! `u_inside` for a free-slip wall or an outflow.

use crate::grid::{FaceVelocity, Grid};
use crate::math::{Real, Vector};
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
}

impl Side {
    /// All four sides.
    pub const ALL: [Side; 4] = [Side::Left, Side::Right, Side::Bottom, Side::Top];
    /// The side's name in a case file.
    pub fn name(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
            Side::Bottom => "bottom",
            Side::Top => "top",
        }
    }
    /// The side across the domain.
    pub fn opposite(self) -> Side {
        match self {
            Side::Left => Side::Right,
            Side::Right => Side::Left,
            Side::Bottom => Side::Top,
            Side::Top => Side::Bottom,
        }
    }
}

/// Shape of a prescribed velocity along a side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Profile {
    /// The same velocity along the whole side.
    #[default]
    Uniform,
    /// A parabola vanishing at both ends of the side, equal to the given velocity at its middle.
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
        /// Velocity `(u, v)` at the side (at its middle for a parabolic profile).
        velocity: [Real; 2],
        /// How the velocity varies along the side.
        #[serde(default)]
        profile: Profile,
    },
    /// Open side at a fixed pressure (force/length in 2D).
    Outflow {
        /// Pressure at the side.
        #[serde(default)]
        pressure: Real,
    },
}

/// The conditions on all four sides.
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
}

impl Default for Boundaries {
    fn default() -> Self {
        Self { left: Boundary::NoSlip, right: Boundary::NoSlip, bottom: Boundary::NoSlip, top: Boundary::NoSlip }
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
        }
    }
    /// Periodic along x.
    pub fn periodic_x(&self) -> bool {
        self.left == Boundary::Periodic
    }
    /// Periodic along y.
    pub fn periodic_y(&self) -> bool {
        self.bottom == Boundary::Periodic
    }
    /// Whether any side fixes the pressure (otherwise it is defined up to a constant).
    pub fn has_dirichlet_pressure(&self) -> bool {
        Side::ALL.iter().any(|&s| matches!(self.side(s), Boundary::Outflow { .. }))
    }
    /// Checks that periodic sides come in pairs.
    pub fn validate(&self) -> Result<(), String> {
        for s in [Side::Left, Side::Bottom] {
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
            Boundary::Velocity { velocity, .. } => match side {
                Side::Left => velocity[0] > 0.0,
                Side::Right => velocity[0] < 0.0,
                Side::Bottom => velocity[1] > 0.0,
                Side::Top => velocity[1] < 0.0,
            },
            _ => false,
        }
    }

    /// Prescribed velocity of `side` at `s`, the fraction (0..1) of the way along it.
    pub fn wall_velocity(&self, side: Side, s: Real) -> Vector {
        match self.side(side) {
            Boundary::Velocity { velocity, profile } => {
                let scale = match profile {
                    Profile::Uniform => 1.0,
                    Profile::Parabolic => 4.0 * s * (1.0 - s),
                };
                Vector::new(velocity[0], velocity[1]) * scale
            }
            _ => Vector::zeros(),
        }
    }

    /// Ghost value of a tangential component half a cell outside `side`,
    /// given the value just inside and the fraction `s` along the side.
    #[inline]
    pub fn tangential_ghost(&self, side: Side, inside: Real, s: Real) -> Real {
        let tangential = |w: Vector| match side {
            Side::Left | Side::Right => w.y,
            Side::Bottom | Side::Top => w.x,
        };
        match self.side(side) {
            Boundary::NoSlip => -inside,
            Boundary::FreeSlip | Boundary::Outflow { .. } | Boundary::Periodic => inside,
            Boundary::Velocity { .. } => 2.0 * tangential(self.wall_velocity(side, s)) - inside,
        }
    }

    /// Normal velocity imposed on the faces of `side`, or `None` where it is free
    /// (outflow) or periodic.
    #[inline]
    pub fn normal_velocity(&self, side: Side, s: Real) -> Option<Real> {
        match self.side(side) {
            Boundary::NoSlip | Boundary::FreeSlip => Some(0.0),
            Boundary::Velocity { .. } => {
                let w = self.wall_velocity(side, s);
                Some(match side {
                    Side::Left | Side::Right => w.x,
                    Side::Bottom | Side::Top => w.y,
                })
            }
            Boundary::Periodic | Boundary::Outflow { .. } => None,
        }
    }

    /// Sets the faces on the domain boundary: imposed normal velocities, and the copy of
    /// face 0 onto face n on periodic sides.
    pub fn enforce(&self, grid: &Grid, vel: &mut FaceVelocity) {
        let (nx, ny) = (grid.nx, grid.ny);
        for j in 0..ny {
            let s = (j as Real + 0.5) / ny as Real;
            if self.periodic_x() {
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
            let s = (i as Real + 0.5) / nx as Real;
            if self.periodic_y() {
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

    /// Whether the x-face `(i, ·)` has a fixed velocity (wall or inflow), so that no force
    /// or pressure gradient acts on it.
    #[inline]
    pub fn xface_fixed(&self, grid: &Grid, i: usize) -> bool {
        (i == 0 && self.normal_velocity(Side::Left, 0.5).is_some())
            || (i == grid.nx && self.normal_velocity(Side::Right, 0.5).is_some())
    }
    /// Whether the y-face `(·, j)` has a fixed velocity.
    #[inline]
    pub fn yface_fixed(&self, grid: &Grid, j: usize) -> bool {
        (j == 0 && self.normal_velocity(Side::Bottom, 0.5).is_some())
            || (j == grid.ny && self.normal_velocity(Side::Top, 0.5).is_some())
    }
}
