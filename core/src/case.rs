//! The case file: everything a run needs, in RON.
//!
//! A case reads top to bottom: domain, boundaries, gravity, time control, fields (each
//! with its frame, density, initial region and velocity, and stress models), the exchange
//! between fields, the pressure solver, and output. Plugins are named by `model` with
//! their own `params`; the registries turn them into typed models.

use crate::boundary::{Boundaries, Side};
use crate::error::{Error, Result};
use crate::math::{Real, Vector, DIM};

/// An angular velocity in a case file: counter-clockwise positive in 2D, `(ωx, ωy, ωz)`
/// in 3D.
#[cfg(feature = "dim2")]
pub type AngularVelocity = Real;
/// An angular velocity in a case file: counter-clockwise positive in 2D, `(ωx, ωy, ωz)`
/// in 3D.
#[cfg(feature = "dim3")]
pub type AngularVelocity = [Real; 3];
use crate::monitor::{MonitorSpec, StopSpec};
use crate::quantity::Place;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A plugin chosen by name, with its parameters (checked by the plugin itself).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PluginSpec {
    /// Registered name, e.g. `"newtonian"`.
    pub model: String,
    /// The model's parameters, e.g. `(viscosity: 0.01)`. Omitted: all defaults.
    #[serde(default = "empty_params", deserialize_with = "crate::finite::finite_json")]
    pub params: serde_json::Value,
}

fn empty_params() -> serde_json::Value {
    serde_json::Value::Object(Default::default())
}

impl PluginSpec {
    /// A spec with default parameters.
    pub fn new(model: &str) -> Self {
        Self { model: model.to_string(), params: empty_params() }
    }
    /// A spec with the given parameters.
    pub fn with(model: &str, params: serde_json::Value) -> Self {
        Self { model: model.to_string(), params }
    }
}

/// The rectangular domain and its grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// Lower-left corner (length).
    #[serde(default)]
    pub origin: [Real; DIM],
    /// Width and height (and depth in 3D) (length).
    pub size: [Real; DIM],
    /// Cells along x and y (and z); cells must be square (cubes).
    pub cells: [usize; DIM],
    /// The cells instead of `cells` when every field of bodies is represented by mass
    /// points ([`Case::cells`]): the grid of the mass points' own scale (d ≲ h), so that one
    /// entry (`representation`) switches a scene from resolved bodies to mass points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_cells: Option<[usize; DIM]>,
    /// The rank grid of a run on several processes (`mpirun -np N`, issue 19): ranks along
    /// x and y (and z), whose product must be N. Default: the grid of least halo surface
    /// for the domain's shape. A run on one process ignores it (its results are the same
    /// bits on any rank grid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ranks: Option<[usize; DIM]>,
}

/// Time control.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeControl {
    /// Simulated time at which the run ends (time).
    pub end: Real,
    /// Courant number: Δt ≤ cfl · h / max|u|. Between 0 and 1; 0.25–0.5 is usual.
    #[serde(default = "default_cfl")]
    pub cfl: Real,
    /// Largest time step (time).
    pub max_dt: Real,
    /// Use this time step exactly instead of the adaptive one (time). The run still
    /// reports when it exceeds a model's stable limit.
    #[serde(default)]
    pub fixed_dt: Option<Real>,
    /// Smallest acceptable time step (time): below it the run stops as unstable.
    #[serde(default = "default_min_dt")]
    pub min_dt: Real,
    /// Stop after this many steps even if `end` is not reached.
    #[serde(default)]
    pub max_steps: Option<u64>,
    /// Integrate the bodies' contact in sub-steps inside each fluid step, so that the
    /// contact's stiffness limits only the sub-steps, not the fluid's Δt (docs/method.md §5).
    #[serde(default, skip_serializing_if = "is_false")]
    pub contact_substeps: bool,
}

fn one() -> Real {
    1.0
}

fn default_cfl() -> Real {
    0.4
}
fn default_min_dt() -> Real {
    1e-12
}

/// Where a field is present at the start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Region {
    /// The whole domain.
    All,
    /// What the other fields leave free (θ = 1 − Σ others); only for an Eulerian field.
    Rest,
    /// An axis-aligned rectangle.
    Rectangle {
        /// Lower-left corner.
        min: [Real; 2],
        /// Upper-right corner.
        max: [Real; 2],
    },
    /// A disk.
    Disk {
        /// Centre.
        center: [Real; 2],
        /// Radius.
        radius: Real,
    },
    /// An axis-aligned box (3D).
    #[cfg(feature = "dim3")]
    Box {
        /// Lower corner.
        min: [Real; 3],
        /// Upper corner.
        max: [Real; 3],
    },
    /// A sphere (3D).
    #[cfg(feature = "dim3")]
    Sphere {
        /// Centre.
        center: [Real; 3],
        /// Radius.
        radius: Real,
    },
    /// Named bodies, each tracked on its own (centroid, velocity, rotation, force in
    /// `bodies.csv`); only for a Lagrangian field.
    Bodies(Vec<BodySpec>),
}

/// The shape of a body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum BodyShape {
    /// A disk.
    Disk {
        /// Centre.
        center: [Real; 2],
        /// Radius.
        radius: Real,
    },
    /// An axis-aligned rectangle.
    Rectangle {
        /// Lower-left corner.
        min: [Real; 2],
        /// Upper-right corner.
        max: [Real; 2],
    },
    /// The ring between two concentric circles: with `motion: Fixed` and an outer radius
    /// beyond the domain's corners, the outside of a circle (a cylinder that holds a flow,
    /// as in circular Couette flow).
    Annulus {
        /// Centre.
        center: [Real; 2],
        /// Inner radius (the fluid's side).
        inner_radius: Real,
        /// Outer radius.
        outer_radius: Real,
    },
}

impl BodyShape {
    /// Whether `(x, y)` lies in the shape.
    pub fn contains(&self, x: Real, y: Real) -> bool {
        match self {
            BodyShape::Disk { center, radius } => (x - center[0]).powi(2) + (y - center[1]).powi(2) <= radius * radius,
            BodyShape::Rectangle { min, max } => x >= min[0] && x <= max[0] && y >= min[1] && y <= max[1],
            BodyShape::Annulus { center, inner_radius, outer_radius } => {
                let r2 = (x - center[0]).powi(2) + (y - center[1]).powi(2);
                r2 >= inner_radius * inner_radius && r2 <= outer_radius * outer_radius
            }
        }
    }
    /// How far `(x, y)` lies inside the shape, from its nearest edge: positive inside,
    /// zero on the edge, negative outside (the distance to the edge for disks and annuli;
    /// for a rectangle inside, the distance to its nearest side).
    pub fn depth(&self, x: Real, y: Real) -> Real {
        match self {
            BodyShape::Disk { center, radius } => radius - (x - center[0]).hypot(y - center[1]),
            BodyShape::Rectangle { min, max } => (x - min[0]).min(max[0] - x).min(y - min[1]).min(max[1] - y),
            BodyShape::Annulus { center, inner_radius, outer_radius } => {
                let r = (x - center[0]).hypot(y - center[1]);
                (r - inner_radius).min(outer_radius - r)
            }
        }
    }

    /// Bounding box (min, max).
    pub fn bounds(&self) -> ([Real; 2], [Real; 2]) {
        match self {
            BodyShape::Disk { center, radius } | BodyShape::Annulus { center, outer_radius: radius, .. } => {
                ([center[0] - radius, center[1] - radius], [center[0] + radius, center[1] + radius])
            }
            BodyShape::Rectangle { min, max } => (*min, *max),
        }
    }
}

/// How a body moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Motion {
    /// Moves under the forces on it.
    #[default]
    Free,
    /// Held at rest.
    Fixed,
    /// Moves with a given velocity and angular velocity.
    Prescribed {
        /// Velocity of the centroid (length/time).
        velocity: [Real; 2],
        /// Angular velocity (1/time), counter-clockwise positive.
        #[serde(default)]
        angular_velocity: Real,
    },
}

/// A named body of a Lagrangian field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name (the `body` column of `bodies.csv`).
    pub name: String,
    /// Its shape at the start.
    pub shape: BodyShape,
    /// Free (default), fixed, or prescribed.
    #[serde(default)]
    pub motion: Motion,
    /// Initial velocity of the centroid.
    #[serde(default)]
    pub velocity: [Real; 2],
    /// Initial angular velocity (1/time).
    #[serde(default)]
    pub angular_velocity: Real,
    /// The body's own material density, e.g. `Some(1.25)`; default (`None`): the field's.
    /// Bodies of different density can then share one field and one exchange entry.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<Real>,
}

impl BodySpec {
    /// The body's material density: its own, or the field's `field_density`.
    pub fn density_or(&self, field_density: Real) -> Real {
        self.density.unwrap_or(field_density)
    }

    /// Initial velocity at `(x, y)`: rigid motion about the shape's centre.
    pub fn velocity_at(&self, x: Real, y: Real) -> [Real; 2] {
        let (lo, hi) = self.shape.bounds();
        let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let (v, w) = match self.motion {
            Motion::Prescribed { velocity, angular_velocity } => (velocity, angular_velocity),
            Motion::Fixed => ([0.0, 0.0], 0.0),
            Motion::Free => (self.velocity, self.angular_velocity),
        };
        [v[0] - w * (y - c[1]), v[1] + w * (x - c[0])]
    }
}

/// The refusal of a 2D region in a 3D case, with the 3D shapes as the fix.
#[cfg(feature = "dim3")]
const REGIONS_2D_IN_3D: &str = "`Rectangle` and `Disk` are 2D regions; a 3D case takes `All`, `Rest`, \
     `Box(min: (x, y, z), max: (x, y, z))` or `Sphere(center: (x, y, z), radius: r)`";

impl Region {
    /// Whether the point `(x, y)` lies in the region (`Rest` and `All` contain everything);
    /// in 3D a box or a sphere contains no point of the plane (use
    /// [`Region::contains_point`]).
    pub fn contains(&self, x: Real, y: Real) -> bool {
        match self {
            Region::All | Region::Rest => true,
            #[cfg(feature = "dim3")]
            Region::Box { .. } | Region::Sphere { .. } => {
                let _ = (x, y);
                false
            }
            Region::Rectangle { min, max } => x >= min[0] && x <= max[0] && y >= min[1] && y <= max[1],
            Region::Disk { center, radius } => (x - center[0]).powi(2) + (y - center[1]).powi(2) <= radius * radius,
            Region::Bodies(bodies) => bodies.iter().any(|b| b.shape.contains(x, y)),
        }
    }

    /// Whether the point `p` lies in the region: [`Region::contains`] in 2D; in 3D the box
    /// (faces included) or the sphere (surface included).
    pub fn contains_point(&self, p: Vector) -> bool {
        match self {
            #[cfg(feature = "dim3")]
            Region::Box { min, max } => (0..3).all(|a| p[a] >= min[a] && p[a] <= max[a]),
            #[cfg(feature = "dim3")]
            Region::Sphere { center, radius } => {
                let (x, y, z) = (p[0] - center[0], p[1] - center[1], p[2] - center[2]);
                x * x + y * y + z * z <= radius * radius
            }
            _ => self.contains(p[0], p[1]),
        }
    }

    /// Index (from 1) of the body containing `(x, y)`, 0 if none or no bodies.
    pub fn body_at(&self, x: Real, y: Real) -> u32 {
        match self {
            Region::Bodies(bodies) => bodies.iter().position(|b| b.shape.contains(x, y)).map_or(0, |k| k as u32 + 1),
            _ => 0,
        }
    }
}

/// Initial velocity of a field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum InitialVelocity {
    /// The same velocity everywhere.
    Uniform([Real; DIM]),
    /// Taylor–Green vortex u = A sin x cos y, v = −A cos x sin y (x, y from the origin);
    /// in 3D u = A sin x cos y cos z, v = −A cos x sin y cos z, w = 0.
    TaylorGreen {
        /// Amplitude A (length/time).
        amplitude: Real,
    },
    /// Rigid rotation about a centre.
    RigidRotation {
        /// Centre of rotation.
        center: [Real; DIM],
        /// Angular velocity (1/time): counter-clockwise positive in 2D, the vector
        /// `(ωx, ωy, ωz)` in 3D (u = ω × (x − c)).
        angular_velocity: AngularVelocity,
    },
    /// A sine along x, u = A sin(k (x − x₀)), v = 0, with x₀ the domain origin: the first
    /// mode of a bar fixed at x₀ for k = π/(2L) (Bardenhagen's vibrating bar).
    SineX {
        /// Amplitude A (length/time).
        amplitude: Real,
        /// Wavenumber k (1/length).
        wavenumber: Real,
    },
    /// The inflow side's profile (a `Velocity` boundary whose velocity points into the
    /// domain, e.g. `Parabolic`) carried across the whole domain: a channel starts developed.
    /// Refused when no side, or more than one, is an inflow.
    FromInflow,
    /// Another run's result, mapped onto this grid (OpenFOAM's `mapFields`): the velocity of
    /// the field `field` in the snapshot `file` (`<run dir>/snapshots/snapshot_NNNNNN.h5`,
    /// relative to the directory the program runs in), interpolated bilinearly onto this
    /// grid's faces (from the snapshot's face velocities when it has them, else from its
    /// cell centres; [`crate::mapping`]). The snapshot's domain must cover this one; its grid
    /// may differ. Bodies and the other fields start as the case says.
    FromSnapshot {
        /// The snapshot file.
        file: std::path::PathBuf,
        /// The field of the snapshot whose velocity is taken (e.g. this field's name).
        field: String,
        /// The velocity read (by [`InitialVelocity::resolved`]); not in case files.
        #[serde(skip)]
        sampled: Option<std::sync::Arc<crate::mapping::SampledVelocity>>,
    },
    /// `FromInflow` resolved by the core ([`InitialVelocity::resolved`]): the velocity of
    /// `side` at the fraction `(coordinate − origin)/size` along its tangential axes. Not
    /// in case files.
    #[serde(skip)]
    Inflow {
        /// The case's boundaries.
        boundaries: Boundaries,
        /// The inflow side.
        side: Side,
        /// The domain's origin.
        origin: [Real; DIM],
        /// The domain's size.
        size: [Real; DIM],
    },
}

impl Default for InitialVelocity {
    fn default() -> Self {
        InitialVelocity::Uniform([0.0; DIM])
    }
}

impl InitialVelocity {
    /// Velocity at the point `p` given the domain origin.
    pub fn at(&self, p: [Real; DIM], origin: [Real; DIM]) -> [Real; DIM] {
        match *self {
            InitialVelocity::FromSnapshot { ref sampled, .. } => sampled.as_ref().map_or([0.0; DIM], |s| s.at(p)),
            InitialVelocity::Uniform(u) => u,
            #[cfg(feature = "dim2")]
            InitialVelocity::TaylorGreen { amplitude } => {
                let (x, y) = (p[0] - origin[0], p[1] - origin[1]);
                [amplitude * x.sin() * y.cos(), -amplitude * x.cos() * y.sin()]
            }
            #[cfg(feature = "dim3")]
            InitialVelocity::TaylorGreen { amplitude } => {
                let (x, y, z) = (p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]);
                [amplitude * x.sin() * y.cos() * z.cos(), -amplitude * x.cos() * y.sin() * z.cos(), 0.0]
            }
            #[cfg(feature = "dim2")]
            InitialVelocity::RigidRotation { center, angular_velocity } => {
                [-angular_velocity * (p[1] - center[1]), angular_velocity * (p[0] - center[0])]
            }
            #[cfg(feature = "dim3")]
            InitialVelocity::RigidRotation { center, angular_velocity } => {
                let r = crate::math::vector(p) - crate::math::vector(center);
                crate::math::vector(angular_velocity).cross(&r).into()
            }
            InitialVelocity::SineX { amplitude, wavenumber } => {
                let mut u = [0.0; DIM];
                u[0] = amplitude * (wavenumber * (p[0] - origin[0])).sin();
                u
            }
            // resolved before the fields start (`resolved`): unresolved it has no inflow
            InitialVelocity::FromInflow => [0.0; DIM],
            InitialVelocity::Inflow { boundaries, side, origin, size } => {
                let along = crate::boundary::along(
                    crate::boundary::tangential_axes(side.axis()).map(|a| (p[a] - origin[a]) / size[a]),
                );
                boundaries.wall_velocity(side, along).into()
            }
        }
    }

    /// This initial velocity with `FromInflow` made the profile of the inflow side of
    /// `boundaries` in `domain`; an error (the fix, without the entry's path) when no side,
    /// or more than one, is an inflow.
    pub fn resolved(&self, boundaries: &Boundaries, domain: &Domain) -> std::result::Result<InitialVelocity, String> {
        if let InitialVelocity::FromSnapshot { file, field, sampled } = self {
            let sampled = match sampled {
                Some(s) => {
                    s.check_covers(domain)?;
                    s.clone()
                }
                None => std::sync::Arc::new(crate::mapping::read(file, field, domain)?),
            };
            return Ok(InitialVelocity::FromSnapshot {
                file: file.clone(),
                field: field.clone(),
                sampled: Some(sampled),
            });
        }
        if *self != InitialVelocity::FromInflow {
            return Ok(self.clone());
        }
        let inflows: Vec<Side> = Side::ALL.into_iter().filter(|&s| boundaries.is_inflow(s)).collect();
        let side = match inflows[..] {
            [side] => side,
            [] => {
                return Err("`FromInflow` takes the profile of the inflow side, but no side is an inflow \
                            (a `Velocity` boundary pointing into the domain, e.g. \
                            `left: Velocity(velocity: (1.0, 0.0), profile: Parabolic)`); give one, or another \
                            initial velocity such as `Uniform((1.0, 0.0))`"
                    .into())
            }
            _ => {
                let names: Vec<&str> = inflows.iter().map(|s| s.name()).collect();
                return Err(format!(
                    "`FromInflow` takes the profile of one inflow side, but {} are inflows; \
                     give another initial velocity such as `Uniform(...)`",
                    names.join(" and ")
                ));
            }
        };
        Ok(InitialVelocity::Inflow { boundaries: *boundaries, side, origin: domain.origin, size: domain.size })
    }
}

impl Case {
    /// This case with the snapshot of every `FromSnapshot` initial velocity read
    /// ([`crate::mapping`]); an error names the entry, what is wrong and the fix.
    pub fn with_snapshots_read(&self) -> crate::Result<Case> {
        let mut case = self.clone();
        for f in &mut case.fields {
            if matches!(f.velocity, InitialVelocity::FromSnapshot { sampled: None, .. }) {
                f.velocity = f
                    .velocity
                    .resolved(&self.boundaries, &self.domain)
                    .map_err(|m| crate::Error::invalid(format!("fields.{}.velocity", f.name), m))?;
            }
        }
        Ok(case)
    }
}

/// One field (phase, material).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldSpec {
    /// Unique name, used by exchange entries and output.
    pub name: String,
    /// Material density ρ⁰ (mass/length² in 2D, e.g. g/cm² per unit depth; CGS g/cm³ by convention).
    pub density: Real,
    /// The frame: `(model: "eulerian")` or `(model: "lagrangian", params: (...))`.
    pub frame: PluginSpec,
    /// Where the field is at the start.
    pub region: Region,
    /// Fraction of its region's volume the field fills at the start (Eulerian fields;
    /// e.g. 0.5 for two interpenetrating fields in one box). Default 1.
    #[serde(default = "one")]
    pub volume_fraction: Real,
    /// Initial velocity.
    #[serde(default)]
    pub velocity: InitialVelocity,
    /// Stress models (viscosity, elasticity, …), applied in order.
    #[serde(default)]
    pub stress: Vec<PluginSpec>,
    /// How a field of bodies is represented: `Resolved` (default; many material points per
    /// body, the frame above) or `MassPoint` (one point per disk carrying its mass, volume
    /// and diameter, spread over the cells by exact disk ∩ cell areas; docs/method.md §4). The
    /// one switch between fully resolved and point-particle bodies: the rest of the case
    /// stays the same (an exchange entry may name the drag law the points feel in its
    /// `mass_point` model).
    #[serde(default)]
    pub representation: Representation,
    /// Disks generated from a seed (random packing or lattice; [`crate::generate`]),
    /// appended to the field's `region: Bodies([...])` before the run is built; none by
    /// default.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub generate: Vec<crate::generate::GeneratorSpec>,
}

/// How a field of bodies is represented.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Representation {
    /// Many material points per body (the field's frame).
    #[default]
    Resolved,
    /// One material point per disk (frame `mass_point`), its volume spread exactly.
    MassPoint,
}

/// How an exchange term is integrated in time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Integration {
    /// Solved per location with the other fields (stable for any Δt; docs/method.md §3 step 4).
    #[default]
    Implicit,
    /// Forward Euler from the provisional velocities (stable only for Δt < ρ/(θK)).
    Explicit,
}

/// Momentum exchange between two fields.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExchangeSpec {
    /// The two field names.
    pub between: [String; 2],
    /// Registered exchange model name, e.g. `"no_slip"`, `"constant"`.
    pub model: String,
    /// The model's parameters.
    #[serde(default = "empty_params", deserialize_with = "crate::finite::finite_json")]
    pub params: serde_json::Value,
    /// Implicit (default) or explicit.
    #[serde(default)]
    pub integration: Integration,
    /// The model used instead when the second field of `between` is represented by mass
    /// points (`representation: MassPoint`): the drag law a point feels, e.g.
    /// `Some((model: "cylinder", params: (added_mass: 1.0, rotation: true)))`. A drag law's
    /// `diameter` defaults to the bodies' and its `viscosity` to the first field's
    /// `newtonian` viscosity. Ignored for resolved bodies.
    #[serde(default)]
    pub mass_point: Option<PluginSpec>,
}

/// Options of the pressure coupling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Coupling {
    /// β in the pressure equation's volume-fraction drift term −β (Σθ − 1)/Δt, 0 ≤ β ≤ 1.
    /// The correcting velocity is about β h (Σθ − 1)/Δt: keep β small (default 0.1) or
    /// it injects noise into a Lagrangian fluid whose θ fluctuates from point to point.
    #[serde(default = "default_relaxation")]
    pub volume_fraction_relaxation: Real,
    /// Largest max |Σθ − 1| a run with a pressure solver accepts: above it the fields no
    /// longer fill the space and the run stops as unstable. The default 1 lets a cell empty
    /// (a Lagrangian fluid's points leave holes: taylor_green_flip.ron reaches 0.97 at t = 2)
    /// but not hold more than twice its volume. Cases without a pressure solver (bodies or
    /// a free surface in vacuum) are not checked.
    #[serde(default = "default_max_volume_fraction_error")]
    pub max_volume_fraction_error: Real,
}

fn default_relaxation() -> Real {
    0.1
}

fn default_max_volume_fraction_error() -> Real {
    1.0
}

impl Default for Coupling {
    fn default() -> Self {
        Self {
            volume_fraction_relaxation: default_relaxation(),
            max_volume_fraction_error: default_max_volume_fraction_error(),
        }
    }
}

/// What the run writes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Simulated time between rows of `diagnostics.csv` and `bodies.csv` (0: every step).
    #[serde(default)]
    pub interval: Real,
    /// HDF5 snapshots of every field (`snapshots/`, with an XDMF sidecar for ParaView).
    #[serde(default)]
    pub snapshots: Option<SnapshotSpec>,
    /// PNG pictures of the flow (`frames/`).
    #[serde(default)]
    pub pictures: Option<PictureSpec>,
    /// Checkpoints to continue the run from with `--restart` (`checkpoints/`).
    #[serde(default)]
    pub checkpoints: Option<Schedule>,
    /// Charts of the diagnostics and body trajectories at the end of the run (`charts/`,
    /// PNG and SVG).
    #[serde(default = "yes")]
    pub charts: bool,
}

fn yes() -> bool {
    true
}

fn is_zero(x: &Real) -> bool {
    *x == 0.0
}

/// Entries (parent path, key) left out of the written case when they hold their default
/// (so that cases written before them stay byte-identical), which `--set` may still set.
const OMITTED_AT_DEFAULT: &[(&str, &str)] =
    &[("time", "contact_substeps"), ("domain", "point_cells"), ("domain", "ranks")];

fn is_false(b: &bool) -> bool {
    !*b
}

/// Whether the output time `moment` has been reached at simulated time `t` (to round-off:
/// a step that landed on it may stop a few ulps short).
pub fn moment_reached(moment: Real, t: Real) -> bool {
    t >= moment - 1e-12 * moment.abs()
}

/// The first of the increasing `times` not yet reached at `t` ([`moment_reached`]).
pub fn first_pending(times: &[Real], t: Real) -> usize {
    times.partition_point(|&m| moment_reached(m, t))
}

impl OutputSpec {
    /// The next exact output time (`times` of the snapshots or pictures) not yet reached at
    /// `t`, on which the time step lands.
    pub fn next_moment(&self, t: Real) -> Option<Real> {
        let s = self.snapshots.as_ref().map(|s| s.times.as_slice()).unwrap_or_default();
        let p = self.pictures.as_ref().map(|p| p.times.as_slice()).unwrap_or_default();
        [s, p].into_iter().filter_map(|v| v.get(first_pending(v, t)).copied()).reduce(Real::min)
    }
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self { interval: 0.0, snapshots: None, pictures: None, checkpoints: None, charts: true }
    }
}

/// A schedule in simulated time: the first write at t = 0 (snapshots, pictures) or at
/// t = `interval` (checkpoints), then every `interval`, and always at the end of the run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Schedule {
    /// Simulated time between writes (time).
    pub interval: Real,
    /// How a run on several ranks writes each checkpoint (`mpirun`; one process writes one
    /// file either way). Default `Gathered`.
    #[serde(default, skip_serializing_if = "is_gathered")]
    pub layout: RankLayout,
}

/// HDF5 snapshots: when, and which quantities ([`crate::quantity`]; `multifield
/// quantities` lists them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SnapshotSpec {
    /// Simulated time between snapshots (time): the first at t = 0, then every `interval`,
    /// and always the run's last step. 0 (or left out): none on an interval.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub interval: Real,
    /// Exact simulated times of further snapshots, increasing, in (0, `time.end`]: the step
    /// is shortened to land on each ([`OutputSpec::next_moment`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub times: Vec<Real>,
    /// A snapshot of the run's last step, whatever ended it (implied by an `interval`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub at_end: bool,
    /// Cell quantities of the mixture (`/<name>`). Default: pressure, velocity, vorticity.
    #[serde(default = "default_mixture_quantities", skip_serializing_if = "is_default_mixture")]
    pub mixture: Vec<QuantityName>,
    /// Cell quantities of every field (`/fields/<f>/<name>`). Default: theta, velocity,
    /// vorticity, density.
    #[serde(default = "default_field_quantities", skip_serializing_if = "is_default_fields")]
    pub fields: Vec<QuantityName>,
    /// Quantities on the points of every field that has points
    /// (`/fields/<f>/points/<name>`; the points' `body` is always written). Default:
    /// position, velocity, volume, stress.
    #[serde(default = "default_point_quantities", skip_serializing_if = "is_default_points")]
    pub points: Vec<QuantityName>,
    /// Also each Eulerian field's face velocities, the grid state itself
    /// (`/fields/<f>/faces/u` and `faces/v`): a run started from the snapshot
    /// (`velocity: FromSnapshot(...)`) maps them instead of the cell-centred means, and on
    /// the same grid takes them unchanged. Default false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub faces: bool,
    /// How a run on several ranks writes a snapshot (`mpirun`; one process writes one
    /// file either way). Default `Gathered`.
    #[serde(default, skip_serializing_if = "is_gathered")]
    pub layout: RankLayout,
}

/// How a decomposed run writes its snapshots and checkpoints (docs/design/mpi.md §6).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum RankLayout {
    /// Rank 0 writes the whole domain in one file, gathered from the ranks' blocks: the
    /// bytes of a run on one process (a checkpoint then restarts on any number of ranks).
    #[default]
    Gathered,
    /// Each rank writes its own part, no rank holds more than its block: a snapshot's
    /// block (its owned cells and faces, its points) to `snapshots/snapshot_<n>/rank_<r>.h5`,
    /// tied into one dataset per time by the XDMF; a checkpoint's state to
    /// `checkpoints/checkpoint_<step>/rank_<r>.bin`, which restarts on the same ranks.
    PerRank,
}

fn is_gathered(l: &RankLayout) -> bool {
    *l == RankLayout::Gathered
}

fn names(v: &[&str]) -> Vec<QuantityName> {
    v.iter().map(|s| QuantityName(s.to_string())).collect()
}
/// The mixture's quantities a snapshot holds by default.
pub const DEFAULT_MIXTURE_QUANTITIES: [&str; 3] = ["pressure", "velocity", "vorticity"];
/// Each field's quantities a snapshot holds by default.
pub const DEFAULT_FIELD_QUANTITIES: [&str; 4] = ["theta", "velocity", "vorticity", "density"];
/// The points' quantities a snapshot holds by default.
pub const DEFAULT_POINT_QUANTITIES: [&str; 4] = ["position", "velocity", "volume", "stress"];
fn default_mixture_quantities() -> Vec<QuantityName> {
    names(&DEFAULT_MIXTURE_QUANTITIES)
}
fn default_field_quantities() -> Vec<QuantityName> {
    names(&DEFAULT_FIELD_QUANTITIES)
}
fn default_point_quantities() -> Vec<QuantityName> {
    names(&DEFAULT_POINT_QUANTITIES)
}
fn is_default_mixture(v: &[QuantityName]) -> bool {
    v == default_mixture_quantities()
}
fn is_default_fields(v: &[QuantityName]) -> bool {
    v == default_field_quantities()
}
fn is_default_points(v: &[QuantityName]) -> bool {
    v == default_point_quantities()
}

impl SnapshotSpec {
    /// Snapshots every `interval` with the default quantities.
    pub fn every(interval: Real) -> Self {
        Self {
            interval,
            times: Vec::new(),
            at_end: false,
            mixture: default_mixture_quantities(),
            fields: default_field_quantities(),
            points: default_point_quantities(),
            faces: false,
            layout: RankLayout::Gathered,
        }
    }
}

/// The name of an output quantity ([`crate::quantity`]), e.g. `"vorticity"`. The
/// identifiers of the former closed list are still read: `Vorticity`, `Speed` (as
/// `"velocity"`, which a picture draws as |u|) and `VolumeFraction` (as `"theta"`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(transparent)]
pub struct QuantityName(pub String);

impl QuantityName {
    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for QuantityName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<'de> Deserialize<'de> for QuantityName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        // Untagged, so that RON gives a bare identifier (`Vorticity`) as its name too.
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Name {
            Name(String),
        }
        let Name::Name(s) = Name::deserialize(d).map_err(|_| {
            serde::de::Error::custom(
                "a quantity is named by a string, e.g. \"vorticity\" (`multifield quantities` lists them)",
            )
        })?;
        let legacy = match s.as_str() {
            "Vorticity" => "vorticity",
            "Speed" => "velocity",
            "VolumeFraction" => "theta",
            other => other,
        };
        Ok(QuantityName(legacy.to_string()))
    }
}

fn default_picture_quantity() -> QuantityName {
    QuantityName("vorticity".into())
}

/// PNG pictures of the flow.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PictureSpec {
    /// Simulated time between pictures (time): the first at t = 0, then every `interval`,
    /// and always the run's last step. 0 (or left out): none on an interval.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub interval: Real,
    /// Exact simulated times of further pictures, increasing, in (0, `time.end`]: the step
    /// is shortened to land on each ([`OutputSpec::next_moment`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub times: Vec<Real>,
    /// A picture of the run's last step, whatever ended it (implied by an `interval`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub at_end: bool,
    /// What the colours show: a cell quantity ([`crate::quantity`]). Default: vorticity.
    #[serde(default = "default_picture_quantity")]
    pub quantity: QuantityName,
    /// The field whose quantity is drawn. Default: the mixture's, or, for a quantity
    /// that only fields have (`theta`), the field that fills the rest (or the first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// Width of the picture in pixels (the height follows the domain's aspect).
    #[serde(default = "default_picture_width")]
    pub width: u32,
    /// The planes a 3D case is drawn in (3D only, where it is required): one,
    /// `slice: (axis: z, at: 0.5)`, or several, `slice: [(axis: z, at: 0.5), (axis: x,
    /// at: 1.0)]`, each drawn into its own folder `frames/<axis>_<at>/`. A 2D case is
    /// drawn whole and refuses it.
    #[serde(default, skip_serializing_if = "Vec::is_empty", deserialize_with = "one_or_more_slices")]
    pub slice: Vec<Slice>,
}

/// The plane of a 3D picture: the cells' plane normal to `axis` through the coordinate
/// `at`, a position in the domain's units (from `domain.origin[axis]` to `origin + size`,
/// both ends included). The plane's values are interpolated linearly between the two
/// layers of cell centres nearest `at` (exactly one layer's values when `at` is a cell
/// centre; between the outermost centre and a wall, the outermost layer's values; across
/// a periodic side, the layers on either side of it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Slice {
    /// The axis normal to the plane: `x`, `y` or `z`.
    pub axis: SliceAxis,
    /// Where the plane cuts that axis (length): a coordinate of the domain.
    pub at: Real,
}

impl Slice {
    /// The folder of its frames under `frames/`: `z_0.5` (the shortest text of `at` that
    /// reads back as it).
    pub fn folder(&self) -> String {
        format!("{}_{}", self.axis.name(), self.at)
    }
}

/// An axis of a slice.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SliceAxis {
    /// x.
    #[serde(rename = "x")]
    X,
    /// y.
    #[serde(rename = "y")]
    Y,
    /// z.
    #[serde(rename = "z")]
    Z,
}

impl SliceAxis {
    /// Its index (0, 1, 2).
    pub fn index(self) -> usize {
        self as usize
    }
    /// `x`, `y` or `z`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self as usize]
    }
}

/// `slice` of a picture: one slice, or a list of them.
fn one_or_more_slices<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Vec<Slice>, D::Error> {
    struct Slices;
    impl<'de> serde::de::Visitor<'de> for Slices {
        type Value = Vec<Slice>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a slice `(axis: z, at: 0.5)` or a list of them `[(axis: z, at: 0.5), (axis: x, at: 1.0)]`")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> std::result::Result<Self::Value, A::Error> {
            Slice::deserialize(serde::de::value::MapAccessDeserializer::new(map)).map(|s| vec![s])
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<Self::Value, A::Error> {
            let mut out = Vec::new();
            while let Some(s) = seq.next_element::<Slice>()? {
                out.push(s);
            }
            Ok(out)
        }
    }
    d.deserialize_any(Slices)
}

fn default_picture_width() -> u32 {
    640
}

/// A whole case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Name of the case (used in output).
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Domain and grid.
    pub domain: Domain,
    /// Boundary conditions; default: no-slip walls on all sides.
    #[serde(default)]
    pub boundaries: Boundaries,
    /// Gravity (length/time²).
    #[serde(default)]
    pub gravity: [Real; DIM],
    /// Time control.
    pub time: TimeControl,
    /// The fields.
    pub fields: Vec<FieldSpec>,
    /// Momentum exchange between pairs of fields.
    #[serde(default)]
    pub exchange: Vec<ExchangeSpec>,
    /// Pressure solver; `None` for a case without incompressibility constraint
    /// (e.g. a weakly compressible fluid whose stress model gives the pressure).
    #[serde(default)]
    pub pressure: Option<PluginSpec>,
    /// Repulsion between bodies and walls (e.g. `(model: "repulsion")`); none by default.
    #[serde(default)]
    pub contact: Option<PluginSpec>,
    /// Pressure-coupling options.
    #[serde(default)]
    pub coupling: Coupling,
    /// Output options.
    #[serde(default)]
    pub output: OutputSpec,
    /// Monitors: forces, probes, lines, differences and averages sampled on their own
    /// schedules into `monitors/<name>.csv` ([`crate::monitor`]); none by default.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub monitors: Vec<MonitorSpec>,
    /// Conditions that end the run as completed before `time.end` (steady monitor, a body
    /// reaching a coordinate, wall time, steps; [`crate::monitor`]); none by default.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stop: Vec<StopSpec>,
}

/// The number of axes of a case: how many numbers its `domain.cells` has, in the text or
/// in the last `--set domain.cells=...` of `overrides`. `None` when the text does not
/// parse as far as that (reading the case then says where it fails). Dimension-free: the
/// `multifield` program reads it to choose the 2D or the 3D library.
pub fn dimension(text: &str, overrides: &[String]) -> Option<usize> {
    let set = overrides.iter().rev().find_map(|o| {
        let (path, value) = o.split_once('=')?;
        (path.trim() == "domain.cells").then(|| crate::ron_value::parse(value.trim()).ok())?
    });
    if let Some(value) = set {
        return value.as_array().map(|a| a.len());
    }
    #[derive(Deserialize)]
    struct DomainCells {
        cells: ron::Value,
    }
    #[derive(Deserialize)]
    struct CaseDomain {
        domain: DomainCells,
    }
    crate::input::check_nesting(text).ok()?;
    match ron_options().from_str::<CaseDomain>(text).ok()?.domain.cells {
        ron::Value::Seq(cells) => Some(cells.len()),
        _ => None,
    }
}

/// An error unless the case has this compile's number of axes ([`dimension`]): a 3D case
/// given to the 2D library, or the reverse, is named as such rather than failing to parse.
pub fn check_dimension(text: &str, overrides: &[String]) -> Result<()> {
    match dimension(text, overrides) {
        Some(d) if d == DIM => Ok(()),
        Some(d @ (2 | 3)) => Err(Error::invalid(
            "domain.cells",
            format!(
                "{d} numbers: this is a {d}D case, and this library is the {DIM}D one; the `multifield` program \
                 chooses by the case's dimension, and a program of your own loads a {d}D case with `{}`",
                if d == 3 { "multifield3d" } else { "multifield" }
            ),
        )),
        Some(d) => Err(Error::invalid(
            "domain.cells",
            format!("{d} numbers: give 2 (a 2D case, e.g. (64, 64)) or 3 (a 3D case, e.g. (32, 32, 32))"),
        )),
        None => Ok(()),
    }
}

/// Maximum number of fields in a case (the exchange solves an N×N system per face).
pub const MAX_FIELDS: usize = 8;

fn ron_options() -> ron::Options {
    crate::input::ron_options()
}

impl Case {
    /// Parses a case from RON text; `file` is only used in messages.
    pub fn from_ron(text: &str, file: &Path) -> Result<Case> {
        ron_options().from_str::<Case>(text).map_err(|e| Error::Syntax {
            file: file.to_path_buf(),
            line: e.span.start.line,
            column: e.span.start.col,
            message: explain_ron_error(&e.code),
        })
    }

    /// The grid's cells: `domain.point_cells` when it is given and every field of bodies
    /// (a `region: Bodies`) is represented by mass points, else `domain.cells`.
    pub fn cells(&self) -> [usize; DIM] {
        let mut bodies = self.fields.iter().filter(|f| matches!(f.region, Region::Bodies(_))).peekable();
        match self.domain.point_cells {
            Some(cells) if bodies.peek().is_some() && bodies.all(|f| f.representation == Representation::MassPoint) => {
                cells
            }
            _ => self.domain.cells,
        }
    }

    /// Reads, overrides (`--set path=value`) and validates a case file.
    pub fn load(file: &Path, overrides: &[String]) -> Result<Case> {
        let text = crate::input::read_text(file)?;
        check_dimension(&text, overrides).map_err(|e| e.in_file(file))?;
        let mut case = Case::from_ron(&text, file)?;
        case = case.with_overrides(overrides).map_err(|e| e.in_file(file))?;
        case.validate().map_err(|e| e.in_file(file))?;
        Ok(case)
    }

    /// The case as pretty RON (as written to `case.ron`).
    pub fn to_ron(&self) -> String {
        let pretty = ron::ser::PrettyConfig::new().depth_limit(6).struct_names(false);
        ron_options().to_string_pretty(self, pretty).unwrap_or_else(|e| format!("// {e}"))
    }

    /// Applies `path=value` overrides, e.g. `time.end=0.1`, `fields.water.density=1.5`,
    /// `fields.0.stress.0.params.viscosity=0.02`. Lists are indexed by position or, for
    /// lists of named entries, by name. The value is RON, enum variants included
    /// (`boundaries.left=FreeSlip`, `fields.0.region=Disk(center: (1, 1), radius: 0.2)`);
    /// anything that is not valid RON is taken as a string.
    pub fn with_overrides(&self, overrides: &[String]) -> Result<Case> {
        if overrides.is_empty() {
            return Ok(self.clone());
        }
        // JSON has no NaN or infinity: serde_json would turn them into `null`, and the
        // result would fail to read back, blamed on the override
        self.check_finite()?;
        let mut tree = serde_json::to_value(self).map_err(|e| Error::Model(e.to_string()))?;
        for assignment in overrides {
            let err = |message: String| Error::Override { assignment: shown(assignment), message };
            let (path, value) =
                assignment.split_once('=').ok_or_else(|| err("expected path=value, e.g. time.end=0.1".into()))?;
            crate::input::check_nesting(value.trim()).map_err(err)?;
            let value = match crate::ron_value::parse(value.trim()) {
                Ok(v) => v,
                // a number that is not one (`inf`, `1e400`, `1..2`) says so
                Err(m)
                    if value.trim().starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c))
                        || ["inf", "NaN"].contains(&value.trim()) =>
                {
                    return Err(err(m));
                }
                // anything else that is not RON is taken as a string
                Err(_) => serde_json::Value::String(value.trim().to_string()),
            };
            let mut node = &mut tree;
            let keys: Vec<&str> = path.trim().split('.').collect();
            for (depth, key) in keys.iter().enumerate() {
                let last = depth + 1 == keys.len();
                let here = keys[..depth].join(".");
                node = match node {
                    serde_json::Value::Object(map) => {
                        if !map.contains_key(*key) {
                            // entries the case leaves out when they hold their default
                            let omitted = OMITTED_AT_DEFAULT.iter().filter(|(p, _)| *p == here).map(|(_, k)| *k);
                            // plugin params may gain new keys; elsewhere the key must exist
                            if here.ends_with("params") || here == "params" || omitted.clone().any(|k| k == *key) {
                                map.insert(key.to_string(), serde_json::Value::Null);
                            } else {
                                let keys: Vec<&str> = map.keys().map(|s| s.as_str()).chain(omitted).collect();
                                return Err(err(format!(
                                    "`{key}` is not an entry of `{}`; its entries are: {}{}",
                                    if here.is_empty() { "the case" } else { &here },
                                    keys.join(", "),
                                    crate::error::did_you_mean(key, keys.iter().copied())
                                )));
                            }
                        }
                        map.get_mut(*key).expect("checked above")
                    }
                    serde_json::Value::Array(list) => {
                        let index = key
                            .parse::<usize>()
                            .ok()
                            .or_else(|| list.iter().position(|e| e.get("name").and_then(|n| n.as_str()) == Some(key)));
                        let n = list.len();
                        let names: Vec<String> = list
                            .iter()
                            .filter_map(|e| e.get("name").and_then(|n| n.as_str()).map(str::to_string))
                            .collect();
                        match index.and_then(|i| list.get_mut(i)) {
                            Some(e) => e,
                            None => {
                                let named = if names.is_empty() {
                                    String::new()
                                } else {
                                    format!(
                                        " ({}){}",
                                        names.join(", "),
                                        crate::error::did_you_mean(key, names.iter().map(String::as_str))
                                    )
                                };
                                return Err(err(format!(
                                    "`{here}` has {n} entries: use an index 0..{n} or an entry's name{named}, not `{key}`"
                                )));
                            }
                        }
                    }
                    _ => return Err(err(format!("`{here}` is a value, not a group: it has no entry `{key}`"))),
                };
                if last {
                    *node = value.clone();
                    break;
                }
            }
        }
        serde_json::from_value::<Case>(tree).map_err(|e| Error::Override {
            assignment: shown(&overrides.join(" ")),
            message: format!("the result is not a valid case: {e}"),
        })
    }

    /// Refuses the first real number of the case that is NaN or infinite, by its path.
    pub fn check_finite(&self) -> Result<()> {
        match crate::finite::first_non_finite(self) {
            None => Ok(()),
            Some((path, x)) => Err(Error::invalid(
                path,
                format!("{x} is not a finite number: every number of a case is finite; give a finite value"),
            )),
        }
    }

    /// Refuses, naming the entry, what a 3D case cannot have yet: bodies (listed,
    /// generated or as mass points), contact, the 2D regions and the monitors of bodies.
    #[cfg(feature = "dim3")]
    fn refuse_not_yet_3d(&self) -> Result<()> {
        let not_yet = |path: String, what: &str| {
            Err(Error::invalid(
                path,
                format!("{what} are not available in 3D yet (issue 17 brings Eulerian fields to 3D first)"),
            ))
        };
        for f in &self.fields {
            let path = |key: &str| format!("fields.{}.{key}", f.name);
            match f.region {
                Region::Bodies(_) => return not_yet(path("region"), "bodies (`Bodies([...])`)"),
                Region::Rectangle { .. } | Region::Disk { .. } => {
                    return Err(Error::invalid(path("region"), REGIONS_2D_IN_3D))
                }
                Region::All | Region::Rest | Region::Box { .. } | Region::Sphere { .. } => {}
            }
            if f.representation == Representation::MassPoint {
                return not_yet(path("representation"), "mass points");
            }
            if !f.generate.is_empty() {
                return not_yet(path("generate"), "generated bodies");
            }
        }
        if self.contact.is_some() {
            return not_yet("contact".into(), "contact models");
        }
        if self.domain.point_cells.is_some() {
            return not_yet("domain.point_cells".into(), "mass points (and their grid)");
        }
        for m in &self.monitors {
            if matches!(m.of, crate::monitor::Monitored::Suspension { .. } | crate::monitor::Monitored::Forces { .. }) {
                return not_yet(format!("monitors.{}.of", m.name), "the monitors of bodies (`Forces`, `Suspension`)");
            }
        }
        Ok(())
    }

    /// Refuses the slices of a picture that cannot be drawn: any in 2D (a 2D case is
    /// drawn whole), none in 3D, a coordinate outside the domain (with the valid range),
    /// the same slice twice.
    fn check_slices(&self, slices: &[Slice]) -> Result<()> {
        let path = "output.pictures.slice";
        let bad = |path: String, m: String| Err(Error::invalid(path, m));
        if DIM == 2 {
            if !slices.is_empty() {
                return bad(
                    path.into(),
                    "a 2D case is drawn whole: `slice` chooses the planes of a 3D case's pictures; leave it out".into(),
                );
            }
            return Ok(());
        }
        let d = &self.domain;
        let range = |a: usize| (d.origin[a], d.origin[a] + d.size[a]);
        if slices.is_empty() {
            let (lo, hi) = range(DIM - 1);
            return bad(
                path.into(),
                format!(
                    "a 3D picture is a plane of cells: give one, e.g. `slice: (axis: z, at: {})` (the middle of the \
                     domain's z range [{lo}, {hi}]), or several, `slice: [(axis: z, at: ...), (axis: x, at: ...)]`",
                    0.5 * (lo + hi)
                ),
            );
        }
        if slices.len() > crate::limits::MAX_LIST {
            return bad(path.into(), format!("{} slices; at most {}", slices.len(), crate::limits::MAX_LIST));
        }
        for (k, s) in slices.iter().enumerate() {
            let entry = if slices.len() == 1 { path.to_string() } else { format!("{path}.{k}") };
            let a = s.axis.index();
            let (lo, hi) = range(a);
            if !(s.at >= lo && s.at <= hi) {
                return bad(
                    entry,
                    format!(
                        "at = {}: outside the domain along {}; give a coordinate in [{lo}, {hi}] (a position in the \
                         domain's units, not a fraction)",
                        s.at,
                        s.axis.name()
                    ),
                );
            }
            if slices[..k].contains(s) {
                return bad(entry, format!("({}, at: {}) is listed twice", s.axis.name(), s.at));
            }
        }
        Ok(())
    }

    /// Rejects impossible values before step 0, saying how to fix them.
    pub fn validate(&self) -> Result<()> {
        self.check_finite()?;
        let bad = |path: &str, message: String| Err(Error::invalid(path, message));
        let d = &self.domain;
        if !d.size.iter().all(|&s| s > 0.0 && s.is_finite()) {
            let every = if DIM == 2 { "both sides" } else { "all three sides" };
            return bad("domain.size", format!("{:?}: {every} must be positive lengths", d.size));
        }
        if let Some(r) = d.ranks.filter(|r| r.contains(&0)) {
            return bad("domain.ranks", format!("{r:?}: at least 1 rank along each axis"));
        }
        for (path, cells) in
            std::iter::once(("domain.cells", d.cells)).chain(d.point_cells.map(|c| ("domain.point_cells", c)))
        {
            if cells.iter().any(|&n| n < 2) {
                return bad(path, format!("{cells:?}: at least 2 cells in each direction"));
            }
            #[cfg(feature = "dim3")]
            {
                let h: Vec<Real> = (0..DIM).map(|a| d.size[a] / cells[a] as Real).collect();
                if h.iter().any(|x| ((h[0] - x) / h[0]).abs() > 1e-9) {
                    let suggestion: Vec<String> =
                        (0..DIM).map(|a| ((d.size[a] / h[0]).round() as usize).to_string()).collect();
                    return bad(
                        path,
                        format!(
                            "cells must be cubes, but size {:?} with cells {cells:?} gives {} × {} × {}; use cells \
                             proportional to the size, e.g. ({})",
                            d.size,
                            h[0],
                            h[1],
                            h[2],
                            suggestion.join(", ")
                        ),
                    );
                }
            }
            #[cfg(feature = "dim2")]
            let (hx, hy) = (d.size[0] / cells[0] as Real, d.size[1] / cells[1] as Real);
            #[cfg(feature = "dim2")]
            if ((hx - hy) / hx).abs() > 1e-9 {
                return bad(
                    path,
                    format!(
                        "cells must be square, but size {:?} with cells {cells:?} gives {hx} × {hy}; \
                         use cells proportional to the size, e.g. ({}, {})",
                        d.size,
                        cells[0],
                        (d.size[1] / hx).round() as usize
                    ),
                );
            }
        }
        self.boundaries.validate().map_err(|m| Error::invalid("boundaries", m))?;
        #[cfg(feature = "dim3")]
        self.refuse_not_yet_3d()?;
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return bad("gravity", "must be finite".into());
        }
        let t = &self.time;
        if !(t.end > 0.0) {
            return bad("time.end", format!("{}: the end time must be positive", t.end));
        }
        if !(t.cfl > 0.0 && t.cfl <= 1.0) {
            return bad("time.cfl", format!("{}: the CFL number must lie in (0, 1]; 0.25–0.5 is usual", t.cfl));
        }
        if !(t.max_dt > 0.0) {
            return bad("time.max_dt", format!("{}: must be positive", t.max_dt));
        }
        if let Some(dt) = t.fixed_dt {
            if !(dt > 0.0) {
                return bad("time.fixed_dt", format!("{dt}: must be positive, or omit it for an adaptive step"));
            }
        }
        if !(t.min_dt >= 0.0) {
            return bad("time.min_dt", format!("{}: must be zero or positive", t.min_dt));
        }
        if self.fields.is_empty() {
            return bad("fields", "a case needs at least one field".into());
        }
        if self.fields.len() > MAX_FIELDS {
            return bad("fields", format!("{} fields; at most {MAX_FIELDS}", self.fields.len()));
        }
        let (x0, y0) = (d.origin[0], d.origin[1]);
        let (x1, y1) = (x0 + d.size[0], y0 + d.size[1]);
        let mut rest = 0;
        for (k, f) in self.fields.iter().enumerate() {
            let p = |what: &str| format!("fields.{}.{what}", f.name);
            if f.name.is_empty() {
                return bad(&format!("fields.{k}.name"), "a field needs a name".into());
            }
            if self.fields[..k].iter().any(|g| g.name == f.name) {
                return bad(&p("name"), format!("two fields are named `{}`; names must be unique", f.name));
            }
            if !(f.density > 0.0 && f.density.is_finite()) {
                return bad(&p("density"), format!("{}: the material density must be positive", f.density));
            }
            if let Err(m) = f.velocity.resolved(&self.boundaries, &self.domain) {
                return bad(&p("velocity"), m);
            }
            if matches!(f.velocity, InitialVelocity::Inflow { .. }) {
                return bad(&p("velocity"), "`Inflow` is internal: write `FromInflow`".into());
            }
            if !(f.volume_fraction > 0.0 && f.volume_fraction <= 1.0) {
                return bad(&p("volume_fraction"), format!("{}: must lie in (0, 1]", f.volume_fraction));
            }
            match &f.region {
                Region::Rest => rest += 1,
                Region::All => {}
                #[cfg(feature = "dim3")]
                Region::Rectangle { .. } | Region::Disk { .. } => {
                    return bad(&p("region"), REGIONS_2D_IN_3D.into());
                }
                #[cfg(feature = "dim3")]
                Region::Box { min, max } => {
                    let (lo, hi) = (d.origin, std::array::from_fn::<Real, 3, _>(|a| d.origin[a] + d.size[a]));
                    if !(0..3).all(|a| min[a] < max[a]) {
                        return bad(&p("region"), format!("box min {min:?} must lie below max {max:?} on every axis"));
                    }
                    if (0..3).any(|a| min[a] < lo[a] - 1e-12 || max[a] > hi[a] + 1e-12) {
                        return bad(
                            &p("region"),
                            format!("box {min:?}–{max:?} reaches outside the domain {lo:?}–{hi:?}; move it inside"),
                        );
                    }
                }
                #[cfg(feature = "dim3")]
                Region::Sphere { center, radius } => {
                    let (lo, hi) = (d.origin, std::array::from_fn::<Real, 3, _>(|a| d.origin[a] + d.size[a]));
                    if !(*radius > 0.0) {
                        return bad(&p("region"), format!("sphere radius {radius}: must be positive"));
                    }
                    if (0..3).any(|a| center[a] - radius < lo[a] - 1e-12 || center[a] + radius > hi[a] + 1e-12) {
                        return bad(&p("region"), format!(
                            "sphere at {center:?} with radius {radius} reaches outside the domain {lo:?}–{hi:?}; move it inside or make it smaller"
                        ));
                    }
                }
                #[cfg(feature = "dim2")]
                Region::Rectangle { min, max } => {
                    if !(min[0] < max[0] && min[1] < max[1]) {
                        return bad(
                            &p("region"),
                            format!("rectangle min {min:?} must lie below and left of max {max:?}"),
                        );
                    }
                    if min[0] < x0 - 1e-12 || min[1] < y0 - 1e-12 || max[0] > x1 + 1e-12 || max[1] > y1 + 1e-12 {
                        return bad(&p("region"), format!(
                            "rectangle {min:?}–{max:?} reaches outside the domain [{x0}, {x1}] × [{y0}, {y1}]; move it inside"
                        ));
                    }
                }
                Region::Bodies(bodies) => {
                    if bodies.is_empty() && f.generate.is_empty() {
                        return bad(&p("region"), "an empty list of bodies: give at least one".into());
                    }
                    // the pairwise checks in O(n log n), found in the order of the plain loops
                    let mut names = std::collections::HashSet::with_capacity(bodies.len());
                    let overlaps = first_disk_overlaps(bodies);
                    for (b, body) in bodies.iter().enumerate() {
                        let bp = format!("fields.{}.region.{}", f.name, body.name);
                        if !names.insert(body.name.as_str()) {
                            return bad(&bp, format!("two bodies are named `{}`; names must be unique", body.name));
                        }
                        if let Some(rho) = body.density {
                            if !(rho > 0.0 && rho.is_finite()) {
                                return bad(
                                    &format!("{bp}.density"),
                                    format!(
                                        "{rho}: the material density of body `{}` must be positive and finite \
                                         (omit it for the field's, {})",
                                        body.name, f.density
                                    ),
                                );
                            }
                        }
                        let (mut lo, mut hi) = body.shape.bounds();
                        if let BodyShape::Disk { radius, .. } = body.shape {
                            if !(radius > 0.0) {
                                return bad(&bp, format!("disk radius {radius}: must be positive"));
                            }
                        }
                        if let BodyShape::Annulus { center, inner_radius: r1, outer_radius: r2 } = body.shape {
                            if !(r1 > 0.0 && r2 > r1) {
                                return bad(
                                    &bp,
                                    format!("annulus radii {r1} and {r2}: need 0 < inner_radius < outer_radius"),
                                );
                            }
                            // the ring may reach beyond the domain (the outside of a circle); its
                            // inner circle, where the fluid is, must lie inside
                            (lo, hi) = ([center[0] - r1, center[1] - r1], [center[0] + r1, center[1] + r1]);
                        }
                        if !(lo[0] < hi[0] && lo[1] < hi[1]) {
                            return bad(&bp, format!("rectangle min {lo:?} must lie below and left of max {hi:?}"));
                        }
                        if lo[0] < x0 - 1e-12 || lo[1] < y0 - 1e-12 || hi[0] > x1 + 1e-12 || hi[1] > y1 + 1e-12 {
                            return bad(&bp, format!(
                                "body `{}` spans [{}, {}] × [{}, {}], outside the domain [{x0}, {x1}] × [{y0}, {y1}]; move it inside",
                                body.name, lo[0], hi[0], lo[1], hi[1]
                            ));
                        }
                        if let Some(o) = overlaps[b] {
                            let other = &bodies[o];
                            if let (
                                BodyShape::Disk { center: c1, radius: r1 },
                                BodyShape::Disk { center: c2, radius: r2 },
                            ) = (&body.shape, &other.shape)
                            {
                                let d = disk_distance(c1, c2);
                                return bad(&bp, format!(
                                    "body `{}` overlaps body `{}` (centres {d} apart, radii {r1} + {r2}); move them apart",
                                    body.name, other.name
                                ));
                            }
                        }
                    }
                }
                #[cfg(feature = "dim2")]
                Region::Disk { center, radius } => {
                    if !(*radius > 0.0) {
                        return bad(&p("region"), format!("disk radius {radius}: must be positive"));
                    }
                    if center[0] - radius < x0 - 1e-12
                        || center[0] + radius > x1 + 1e-12
                        || center[1] - radius < y0 - 1e-12
                        || center[1] + radius > y1 + 1e-12
                    {
                        return bad(&p("region"), format!(
                            "disk at {center:?} with radius {radius} reaches outside the domain [{x0}, {x1}] × [{y0}, {y1}]; move it inside or make it smaller"
                        ));
                    }
                }
            }
        }
        for f in &self.fields {
            if f.generate.is_empty() {
                continue;
            }
            if !matches!(f.region, Region::Bodies(_)) {
                return bad(
                    &format!("fields.{}.region", f.name),
                    "generated bodies go into a list of bodies: write `region: Bodies([])` (or list bodies there \
                     to place beside the generated ones)"
                        .into(),
                );
            }
            if f.generate.len() > crate::limits::MAX_LIST {
                return bad(
                    &format!("fields.{}.generate", f.name),
                    format!("{} entries; at most {}", f.generate.len(), crate::limits::MAX_LIST),
                );
            }
            for (k, g) in f.generate.iter().enumerate() {
                g.check(&format!("fields.{}.generate.{k}", f.name), &self.domain)?;
            }
        }
        if rest > 1 {
            return bad("fields", "only one field can take region `Rest` (what the others leave free)".into());
        }
        for f in &self.fields {
            if f.representation != Representation::MassPoint {
                continue;
            }
            let path = format!("fields.{}.representation", f.name);
            let Region::Bodies(bodies) = &f.region else {
                return bad(
                    &path,
                    "`MassPoint` represents a list of bodies: give the field `region: Bodies([...])` of disks, \
                     or use `Resolved`"
                        .into(),
                );
            };
            if let Some(b) = bodies.iter().find(|b| !matches!(b.shape, BodyShape::Disk { .. })) {
                return bad(
                    &path,
                    format!(
                        "body `{}` is not a disk: a mass point stands for a disk (its volume is spread as a disk); \
                         use `Resolved` for other shapes",
                        b.name
                    ),
                );
            }
        }
        for (k, e) in self.exchange.iter().enumerate() {
            for name in &e.between {
                if !self.fields.iter().any(|f| &f.name == name) {
                    let names: Vec<&str> = self.fields.iter().map(|f| f.name.as_str()).collect();
                    return bad(
                        &format!("exchange.{k}.between"),
                        format!(
                            "no field is named `{name}`; fields: {}{}",
                            names.join(", "),
                            crate::error::did_you_mean(name, names.iter().copied())
                        ),
                    );
                }
            }
            if e.between[0] == e.between[1] {
                return bad(&format!("exchange.{k}.between"), "an exchange couples two different fields".into());
            }
        }
        let beta = self.coupling.volume_fraction_relaxation;
        if !(0.0..=1.0).contains(&beta) {
            return bad("coupling.volume_fraction_relaxation", format!("{beta}: must lie in [0, 1]"));
        }
        let bound = self.coupling.max_volume_fraction_error;
        if !(bound > 0.0) {
            return bad(
                "coupling.max_volume_fraction_error",
                format!("{bound}: must be positive (default 1; a large value such as 1e9 turns the check off)"),
            );
        }
        if !(self.output.interval >= 0.0) {
            return bad("output.interval", format!("{}: must be zero (every step) or positive", self.output.interval));
        }
        if let Some(c) = self.output.checkpoints {
            if !(c.interval > 0.0 && c.interval.is_finite()) {
                return bad(
                    "output.checkpoints.interval",
                    format!("{}: must be a positive time (or leave the entry out)", c.interval),
                );
            }
        }
        let moments = [
            ("output.snapshots", self.output.snapshots.as_ref().map(|s| (s.interval, &s.times, s.at_end))),
            ("output.pictures", self.output.pictures.as_ref().map(|p| (p.interval, &p.times, p.at_end))),
        ];
        for (path, spec) in moments {
            let Some((interval, times, at_end)) = spec else { continue };
            if !(interval >= 0.0 && interval.is_finite()) {
                return bad(
                    &format!("{path}.interval"),
                    format!("{interval}: must be a positive time (or 0 / left out for none on an interval)"),
                );
            }
            if interval == 0.0 && times.is_empty() && !at_end {
                return bad(
                    path,
                    "nothing to write: give an `interval`, `times: [...]` or `at_end: true` (or leave the entry out)"
                        .into(),
                );
            }
            if times.len() > crate::limits::MAX_LIST {
                return bad(
                    &format!("{path}.times"),
                    format!("{} times; at most {}", times.len(), crate::limits::MAX_LIST),
                );
            }
            for (k, &t) in times.iter().enumerate() {
                if !(t > 0.0 && t.is_finite() && t <= self.time.end) {
                    return bad(
                        &format!("{path}.times.{k}"),
                        format!("{t}: must be a finite time in (0, time.end = {}]", self.time.end),
                    );
                }
                if k > 0 && !(t > times[k - 1]) {
                    return bad(
                        &format!("{path}.times.{k}"),
                        format!("{t}: the times must increase (the one before is {})", times[k - 1]),
                    );
                }
            }
        }
        if let Some(p) = &self.output.pictures {
            if !(16..=8192).contains(&p.width) {
                return bad("output.pictures.width", format!("{}: must lie in 16..=8192 pixels", p.width));
            }
            let place = match &p.field {
                Some(f) => {
                    if !self.fields.iter().any(|s| &s.name == f) {
                        let names: Vec<&str> = self.fields.iter().map(|s| s.name.as_str()).collect();
                        return bad(
                            "output.pictures.field",
                            format!("no field `{f}`; the fields are: {}", names.join(", ")),
                        );
                    }
                    Place::Field
                }
                None => match crate::quantity::find(p.quantity.as_str(), Place::Mixture) {
                    Ok(_) => Place::Mixture,
                    Err(m) if crate::quantity::find(p.quantity.as_str(), Place::Field).is_err() => {
                        return bad("output.pictures.quantity", m);
                    }
                    Err(_) => Place::Field,
                },
            };
            if let Err(m) = crate::quantity::find(p.quantity.as_str(), place) {
                return bad("output.pictures.quantity", m);
            }
            self.check_slices(&p.slice)?;
        }
        if let Some(s) = &self.output.snapshots {
            for (path, list, place) in [
                ("output.snapshots.mixture", &s.mixture, Place::Mixture),
                ("output.snapshots.fields", &s.fields, Place::Field),
                ("output.snapshots.points", &s.points, Place::Points),
            ] {
                for (k, q) in list.iter().enumerate() {
                    if let Err(m) = crate::quantity::find(q.as_str(), place) {
                        return bad(path, m);
                    }
                    if list[..k].contains(q) {
                        return bad(path, format!("`{q}` is listed twice"));
                    }
                }
            }
        }
        crate::monitor::validate(self)
    }
}

/// An override as shown in a message: at most 100 characters of it.
fn shown(assignment: &str) -> String {
    let n = assignment.chars().count();
    if n <= 100 {
        return assignment.to_string();
    }
    let head: String = assignment.chars().take(80).collect();
    format!("{head}… ({n} characters)")
}

/// Distance between two disks' centres.
fn disk_distance(c1: &[Real; 2], c2: &[Real; 2]) -> Real {
    ((c1[0] - c2[0]).powi(2) + (c1[1] - c2[1]).powi(2)).sqrt()
}

/// For each body, the first earlier disk that its disk overlaps (centres closer than the
/// sum of the radii), as a loop over every earlier body finds it, but by a sweep along x:
/// only the pairs whose extents along x overlap are tested (O(n log n) for bodies spread
/// over the domain; issue 20 had 10,000 bodies).
fn first_disk_overlaps(bodies: &[BodySpec]) -> Vec<Option<usize>> {
    let disks: Vec<(usize, [Real; 2], Real)> = bodies
        .iter()
        .enumerate()
        .filter_map(|(k, b)| match b.shape {
            BodyShape::Disk { center, radius } => Some((k, center, radius)),
            _ => None,
        })
        .collect();
    let mut order: Vec<usize> = (0..disks.len()).collect();
    order.sort_by(|&a, &b| {
        let lo = |k: usize| disks[k].1[0] - disks[k].2;
        lo(a).total_cmp(&lo(b))
    });
    let mut first: Vec<Option<usize>> = vec![None; bodies.len()];
    // a NaN extent can overlap nothing: `d < r1 + r2` is false, as in the plain loop
    let mut active: Vec<usize> = Vec::new();
    for &k in &order {
        let (b, c, r) = disks[k];
        // (with a slack of 1e-9 relative: rounding must not drop a pair the loop would test)
        let lo = c[0] - r - 1e-9 * (1.0 + c[0].abs() + r.abs());
        active.retain(|&o| !(disks[o].1[0] + disks[o].2 < lo));
        for &o in &active {
            let (a, c2, r2) = disks[o];
            if disk_distance(&c, &c2) < r + r2 {
                let (late, early) = if a < b { (b, a) } else { (a, b) };
                if first[late].is_none_or(|e| early < e) {
                    first[late] = Some(early);
                }
            }
        }
        active.push(k);
    }
    first
}

/// Turns a RON error into a message that says how to fix it.
pub fn explain_ron_error(e: &ron::Error) -> String {
    match e {
        ron::Error::NoSuchStructField { expected, found, outer } => format!(
            "unknown key `{found}`{}; valid keys: {}{}",
            outer.as_ref().map(|o| format!(" in {o}")).unwrap_or_default(),
            expected.join(", "),
            crate::error::did_you_mean(found, expected.iter().copied())
        ),
        ron::Error::NoSuchEnumVariant { expected, found, outer } => format!(
            "unknown choice `{found}`{}; valid choices: {}{}",
            outer.as_ref().map(|o| format!(" for {o}")).unwrap_or_default(),
            expected.join(", "),
            crate::error::did_you_mean(found, expected.iter().copied())
        ),
        ron::Error::ExceededRecursionLimit => crate::input::nesting_message_here(),
        ron::Error::MissingStructField { field, outer } => format!(
            "missing key `{field}`{}: add `{field}: ...`",
            outer.as_ref().map(|o| format!(" in {o}")).unwrap_or_default()
        ),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sweep finds, for every body, the same first overlapping earlier disk as the
    /// plain loop over every earlier body (issue 20: that loop was O(n²)).
    #[test]
    fn the_sweep_finds_the_overlaps_of_the_plain_loop() {
        let mut bodies = Vec::new();
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as Real / (1u64 << 53) as Real
        };
        for k in 0..400 {
            let shape = if k % 7 == 3 {
                BodyShape::Rectangle { min: [next(), next()], max: [1.5, 1.5] }
            } else {
                BodyShape::Disk { center: [10.0 * next(), 10.0 * next()], radius: 0.05 + 0.3 * next() }
            };
            bodies.push(BodySpec {
                name: format!("b{k}"),
                shape,
                motion: Motion::Free,
                velocity: [0.0; 2],
                angular_velocity: 0.0,
                density: None,
            });
        }
        let plain: Vec<Option<usize>> = (0..bodies.len())
            .map(|b| {
                (0..b).find(|&o| match (&bodies[b].shape, &bodies[o].shape) {
                    (BodyShape::Disk { center: c1, radius: r1 }, BodyShape::Disk { center: c2, radius: r2 }) => {
                        disk_distance(c1, c2) < r1 + r2
                    }
                    _ => false,
                })
            })
            .collect();
        assert!(plain.iter().filter(|o| o.is_some()).count() > 50);
        assert_eq!(first_disk_overlaps(&bodies), plain);
    }
}
