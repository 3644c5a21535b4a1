//! The plugin traits and the context structs they receive.
//!
//! Plugins work on a whole field at a time. A context struct carries everything a
//! plugin may need, so that adding an input later breaks no plugin.

use crate::boundary::Boundaries;
use crate::case::{InitialVelocity, Region, Representation};
use crate::field::FieldState;
use crate::grid::{FaceArrays, Grid};
use crate::math::{Matrix, Real, Vector, DIM};
use crate::poisson::{PoissonProblem, SolveStats};
use serde::{Deserialize, Serialize};
use std::any::Any;

/// What a frame needs to seed its initial state.
pub struct InitContext<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// Boundary conditions.
    pub boundaries: &'a Boundaries,
    /// The field's name.
    pub name: &'a str,
    /// Material density ρ⁰.
    pub density: Real,
    /// Where the field starts.
    pub region: &'a Region,
    /// Initial velocity.
    pub velocity: &'a InitialVelocity,
    /// Initial volume fraction per cell when the core computed it (region `Rest`).
    pub theta: Option<&'a [Real]>,
    /// The case's contact model, if any: its name and whether it keeps bodies off every
    /// side that is not periodic, open sides (inflows, outflows) included
    /// ([`ContactModel::keeps_bodies_off_sides`]).
    pub contact: Option<(&'a str, bool)>,
}

/// What a frame sees in a phase of a step.
pub struct FrameContext<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// Boundary conditions.
    pub boundaries: &'a Boundaries,
    /// Time step.
    pub dt: Real,
    /// Time at the start of the step.
    pub time: Real,
    /// Gravity.
    pub gravity: Vector,
    /// Material density ρ⁰ of the field.
    pub density: Real,
    /// The field's grid state.
    pub state: &'a mut FieldState,
    /// The field's stress models.
    pub stress: &'a [Box<dyn StressModel>],
    /// Contact force and torque on each of the field's bodies (phase 8), by body index,
    /// with the position correction of sub-stepped contact ([`BodyContact`]).
    pub body_forces: &'a [BodyContact],
    /// When a direct-forcing coupling ([`ExchangeModel::immersed_boundary`]) moves this
    /// field's bodies: each body's new velocity and the hydrodynamic force of this step, by
    /// body index. The field is then not on the grid (the core does not call
    /// [`Frame::to_grid`]); [`Frame::from_grid`] moves each body rigidly with these
    /// velocities instead of taking the grid's.
    pub forced_bodies: Option<&'a [BodyStep]>,
    /// The fluid this field exchanges momentum with through a drag law (the first field of
    /// an exchange whose model has [`ExchangeModel::drag_law`] and whose second field is
    /// this one), for the models that need it: the rotation torque and the Reynolds number
    /// of point particles.
    pub partner: Option<Partner<'a>>,
}

/// The fluid a dispersed field is coupled to by a drag law.
#[derive(Clone, Copy)]
pub struct Partner<'a> {
    /// The fluid's grid state (velocities of the current phase).
    pub state: &'a FieldState,
    /// The fluid's material density ρ_f.
    pub density: Real,
    /// The drag law.
    pub law: &'a DragLaw,
}

/// What a drag-law exchange tells the core and the frames about itself.
#[derive(Clone, Debug, PartialEq)]
pub struct DragLaw {
    /// The exchange model's name.
    pub model: &'static str,
    /// Particle diameter d.
    pub diameter: Real,
    /// Dynamic viscosity μ of the fluid.
    pub viscosity: Real,
    /// The Reynolds numbers Re = ρ_f |Δu| d / μ where the law holds (lower, upper).
    pub valid_re: (Real, Real),
    /// Added-mass coefficient C_A (0: none; 1 for a 2D disk, ½ for a sphere), solved
    /// implicitly in the exchange.
    pub added_mass: Real,
    /// Whether points feel the rotational torque 4πμa²(½∇×u_f − ω) (per unit length).
    pub rotation: bool,
}

/// What a direct-forcing coupling decided for one body in a step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyStep {
    /// The body's new velocity (of the centroid).
    pub velocity: Vector,
    /// Its new angular velocity.
    pub angular_velocity: Real,
    /// The hydrodynamic force of the step (buoyancy included).
    pub force: Vector,
    /// The hydrodynamic torque of the step.
    pub torque: Real,
}

/// What a direct-forcing exchange tells the core ([`ExchangeModel::immersed_boundary`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImmersedBoundary {
    /// Forcing sweeps per step (multi-direct forcing), or `None` for the exact solve of
    /// the markers' forces (`multifield_core::immersed::exact_forcing`).
    pub sweeps: Option<usize>,
    /// Markers this many cells inside the solid from the surface.
    pub retraction: Real,
}

/// What phase 8a hands a body's frame: the contact force and torque to apply over the
/// step, and, with `time.contact_substeps`, where the contact's sub-steps put the body
/// against where moving with its end velocity for the whole step would (docs/method.md §5).
/// Without sub-steps the shift and the turn are exactly zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BodyContact {
    /// Contact force (with sub-steps, the mean over the step: impulse/Δt).
    pub force: Vector,
    /// Contact torque (with sub-steps, the mean over the step).
    pub torque: Real,
    /// Position correction s = X_substepped − (X₀ + Δt V_end): added to the centroid's
    /// move of the step.
    pub shift: Vector,
    /// Rotation correction φ = θ_substepped − Δt ω_end: added to the body's rotation of
    /// the step.
    pub turn: Real,
}

impl BodyState {
    /// A copy without the name (empty, so nothing is allocated): what the contact models
    /// read every (sub-)step, which never report a body by name.
    pub fn unnamed(&self) -> BodyState {
        BodyState { name: String::new(), ..*self }
    }
}

impl BodyContact {
    /// A force and torque alone, with no position correction.
    pub fn force(force: Vector, torque: Real) -> Self {
        Self { force, torque, shift: Vector::zeros(), turn: 0.0 }
    }
    /// Whether it corrects the position or the rotation (never without sub-steps).
    pub fn moves(&self) -> bool {
        self.shift != Vector::zeros() || self.turn != 0.0
    }
}

/// The state of one body of a field, as frames report it (and checkpoint it).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BodyState {
    /// Name from the case.
    pub name: String,
    /// Mass.
    pub mass: Real,
    /// Moment of inertia about the centroid (per unit depth).
    pub inertia: Real,
    /// Volume (area in 2D).
    pub volume: Real,
    /// Radius of the disk (or of the disk of equal area).
    pub radius: Real,
    /// Centroid.
    pub position: Vector,
    /// Velocity of the centroid.
    pub velocity: Vector,
    /// Angular velocity (counter-clockwise positive).
    pub angular_velocity: Real,
    /// Hydrodynamic force of the last step: dP/dt − M g − contact.
    pub force: Vector,
    /// Hydrodynamic torque of the last step.
    pub torque: Real,
    /// Whether contact forces move it (free bodies).
    pub free: bool,
}

/// The figures of a step of a frame that steps alone ([`Frame::step_alone`]), summed in
/// its pass over the points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameFigures {
    /// Kinetic energy at the end of the step.
    pub kinetic_energy: Real,
    /// Linear momentum.
    pub momentum: Vector,
    /// Mass.
    pub mass: Real,
    /// Largest speed.
    pub max_speed: Real,
}

/// A field's frame: where its state lives (grid or material points) and how it is
/// carried to and from the grid. Implementations live in `multifield-frames`.
pub trait Frame: Send + Sync {
    /// Registered name.
    fn model(&self) -> &'static str;
    /// Parameters with defaults filled in (written to `case.ron`).
    fn params(&self) -> serde_json::Value;
    /// Whether it runs on a rank's block of a decomposed domain (docs/design/mpi.md): every
    /// neighbour it reads through the grid's halo exchange (`Grid::exchange`), every sum over
    /// the domain through `Grid::dot`/`Grid::sum` or `Part::reduce`. A run on several ranks
    /// refuses, before step 0, a plugin that does not (the default).
    fn decomposed(&self) -> bool {
        false
    }
    /// Whether the state lives on material points.
    fn is_lagrangian(&self) -> bool;
    /// How this frame represents a field of bodies: [`Representation::Resolved`] (the
    /// default: many points or cells per body) or [`Representation::MassPoint`] (one point
    /// per disk). The core builds the frame registered as
    /// [`crate::simulation::MASS_POINT_FRAME`] for a field with `representation:
    /// MassPoint`, checks that it says so, and refuses a frame that says so in a field
    /// that does not.
    fn representation(&self) -> Representation {
        Representation::Resolved
    }
    /// Seeds the initial state.
    fn initialize(&mut self, ctx: &InitContext) -> Result<(), String>;
    /// Step 1–2: mass, velocity, volume fraction (and internal forces of point stresses)
    /// onto the grid state; must also set `state.velocity_old`.
    fn to_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String>;
    /// Step 3: the frame's predictor: its own terms (advection for an Eulerian field) and
    /// the field's grid stresses ([`StressModel::apply_on_grid`]), in the frame's own time
    /// discretisation; the core adds Δt g afterwards. Default: the grid stresses applied
    /// once to the provisional velocity ([`apply_grid_stresses`]).
    fn predict(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        apply_grid_stresses(ctx, ctx.dt)
    }
    /// Step 7: take the corrected grid velocity back (grid to particles, point stresses).
    #[allow(clippy::wrong_self_convention)]
    fn from_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String>;
    /// Step 9: transport of the field's volume with the corrected velocity.
    fn advect(&mut self, _ctx: &mut FrameContext) -> Result<(), String> {
        Ok(())
    }
    /// Whether this frame advances itself in one pass ([`Frame::step_alone`]) in place of
    /// the multifield phases. The core then requires the field to be the case's only one,
    /// with no pressure solve, exchange or contact, and no stress model acting on the grid
    /// ([`StressKind::Grid`]). Default: false.
    fn steps_alone(&self) -> bool {
        false
    }
    /// One whole step of a frame that [`Frame::steps_alone`]; `ctx.state` is not written
    /// (see [`Frame::refresh_grid_state`]). Returns the step's figures.
    fn step_alone(&mut self, _ctx: &mut FrameContext) -> Result<FrameFigures, String> {
        Err(format!("frame `{}` does not step alone", self.model()))
    }
    /// Writes the field's grid state (θ, face masses and velocities) from the frame's own
    /// state, for output after [`Frame::step_alone`], which leaves it unwritten. Default:
    /// nothing.
    fn refresh_grid_state(&mut self, _ctx: &mut FrameContext) -> Result<(), String> {
        Ok(())
    }
    /// The largest diffusion number νΔt/h² of these stress models' viscosity when the frame
    /// integrates it implicitly (the Eulerian frame's Crank–Nicolson), which replaces their
    /// explicit Δt limits ([`TimeStepContext::implicit_viscosity`]); `None` (the default):
    /// the frame leaves them explicit.
    fn implicit_diffusion_number(&self, _stress: &[Box<dyn StressModel>]) -> Option<Real> {
        None
    }
    /// Largest speed, for the CFL limit.
    fn max_speed(&self) -> Real;
    /// Kinetic energy.
    fn kinetic_energy(&self) -> Real;
    /// Elastic energy its points store under the field's stress models (those that define
    /// [`StressModel::strain_energy_density`]); 0 for frames without a deformation gradient.
    fn strain_energy(&self, _stress: &[Box<dyn StressModel>]) -> Real {
        0.0
    }
    /// Linear momentum.
    fn momentum(&self) -> Vector;
    /// Total mass.
    fn mass(&self) -> Real;
    /// The field's bodies (empty when its region has none): copies of [`Frame::body_states`].
    fn bodies(&self) -> Vec<BodyState> {
        self.body_states().into_iter().cloned().collect()
    }
    /// The field's bodies as the frame holds them, in the order of [`Frame::bodies`]: for
    /// the readers of every step (the contact, the overlap check), which then copy no names
    /// (a suspension of 10,000 points cloned 10,000 strings per copy). Default: none.
    fn body_states(&self) -> Vec<&BodyState> {
        Vec::new()
    }
    /// Where the run left the frame's model's range of validity (for the run summary),
    /// one sentence each, naming the body and the ratio; empty when it did not.
    fn warnings(&self, _grid: &Grid) -> Vec<String> {
        Vec::new()
    }
    /// The field's points, for output ([`crate::quantity`]): material points, or one per
    /// body of a mass-point field. Default: None (a frame without points).
    fn points(&self) -> Option<crate::quantity::PointSet> {
        None
    }
    /// The points rank `rank` writes to its own snapshot file (`layout: PerRank`): those it
    /// holds. Default: every point on rank 0 and none on the others (a frame on the whole
    /// domain, or one whose points every rank holds); a frame whose points migrate
    /// between the ranks returns its own.
    fn local_points(&self, rank: usize) -> Option<crate::quantity::PointSet> {
        let all = self.points()?;
        Some(if rank == 0 { all } else { crate::quantity::PointSet { bodies: all.bodies, ..Default::default() } })
    }
    /// This rank's own state for a checkpoint written per rank (`output.checkpoints.layout:
    /// PerRank`): its block's storage and the points it holds, nothing gathered;
    /// [`Frame::load_rank_state`] on the same rank of the same rank grid continues bit for
    /// bit. Default: [`Frame::save_state`] (a frame on the whole domain, or one whose state
    /// every rank holds alike).
    fn save_rank_state(&self) -> Result<Vec<u8>, String> {
        self.save_state()
    }
    /// Restores what [`Frame::save_rank_state`] wrote. Default: [`Frame::load_state`].
    fn load_rank_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.load_state(bytes)
    }
    /// Downcasting, for checkpoints and tests.
    fn as_any(&self) -> &dyn Any;
    /// Mutable downcasting, for checkpoints and tests.
    fn as_any_mut(&mut self) -> &mut dyn Any;
    /// The frame's state that carries over from one step to the next (for checkpoints):
    /// everything [`Frame::load_state`] needs to continue bit for bit, on a frame built
    /// and initialized from the same case. Scratch space rebuilt every step need not be
    /// in it. Encode a `#[derive(Serialize)]` struct of it with [`crate::state::encode`].
    fn save_state(&self) -> Result<Vec<u8>, String> {
        Err(format!("frame `{}` cannot be checkpointed (it does not implement Frame::save_state)", self.model()))
    }
    /// Restores what [`Frame::save_state`] wrote, into a frame built and initialized from
    /// the same case. Decode the frame's struct with [`crate::state::decode`].
    fn load_state(&mut self, _bytes: &[u8]) -> Result<(), String> {
        Err(format!(
            "frame `{}` cannot be restored from a checkpoint (it does not implement Frame::load_state)",
            self.model()
        ))
    }
}

/// Applies every grid stress of the field ([`StressModel::apply_on_grid`]), in order, to
/// `ctx.state.velocity` for a step of `dt`; an error names the model.
pub fn apply_grid_stresses(ctx: &mut FrameContext, dt: Real) -> Result<(), String> {
    for m in ctx.stress {
        let mut sc = GridStressContext {
            grid: ctx.grid,
            boundaries: ctx.boundaries,
            dt,
            density: ctx.density,
            state: &mut *ctx.state,
        };
        m.apply_on_grid(&mut sc).map_err(|e| format!("stress `{}`: {e}", m.model()))?;
    }
    Ok(())
}

/// Data a stress model needs to say its stable time step.
pub struct TimeStepContext<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// Material density ρ⁰ of the field.
    pub density: Real,
    /// Largest speed in the field.
    pub max_speed: Real,
    /// When the field's frame integrates a Newtonian viscosity implicitly, the largest
    /// diffusion number νΔt/h² it takes ([`Frame::implicit_diffusion_number`]), in place
    /// of the explicit viscous limit.
    pub implicit_viscosity: Option<Real>,
}

/// A grid-level stress evaluation (viscosity on face velocities).
pub struct GridStressContext<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// Boundary conditions.
    pub boundaries: &'a Boundaries,
    /// Time step.
    pub dt: Real,
    /// Material density ρ⁰.
    pub density: Real,
    /// The field's grid state; the model updates `state.velocity`.
    pub state: &'a mut FieldState,
}

/// A point-level stress evaluation (MPM constitutive models).
pub struct PointStressContext<'a> {
    /// Time step.
    pub dt: Real,
    /// Material density ρ⁰.
    pub density: Real,
    /// Deformation gradient F of each point.
    pub deformation_gradient: &'a [Matrix],
    /// Velocity gradient ∇v of each point.
    pub velocity_gradient: &'a [Matrix],
    /// Cauchy stress of each point, to be written (the model adds to it).
    pub stress: &'a mut [Matrix],
    /// This model's state at every point ([`StressModel::point_state`]): k values per
    /// point, point p's at `state[k p .. k (p + 1)]` (empty when k = 0), zero at the start,
    /// kept by the frame with the points (in checkpoints too). The model updates it for a
    /// step of `dt`, and must leave it as it is when `dt` is 0: a frame may evaluate the
    /// stress again with Δt = 0 (for output).
    pub state: &'a mut [Real],
}

/// What a stress model is, in one value ([`StressModel::kind`]): the frames and the core
/// read every capability from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StressKind {
    /// Makes the field's bodies move rigidly (after the pressure update); no stress, no
    /// time-step limit of its own.
    Rigid,
    /// Acts on the grid's velocities ([`StressModel::apply_on_grid`]): a viscosity. Such a
    /// model needs the staggered grid state, which a frame that steps alone does not write.
    Grid {
        /// The dynamic viscosity μ of a Newtonian stress σ = 2μD, whose `apply_on_grid` is
        /// `u ← u + Δt (μ/ρ⁰) ∇²u`: a frame may integrate it implicitly instead
        /// ([`Frame::implicit_diffusion_number`]). `None`: not Newtonian.
        newtonian_viscosity: Option<Real>,
    },
    /// A Cauchy stress at the material points ([`StressModel::point_stress`], MPM).
    Points {
        /// The stress depends on F only through J = det F (the equation of state of a
        /// fluid). When every point-stress model of a field says so, the Lagrangian frame
        /// keeps F = diag(J, 1) after each update: a flowing fluid stretches F without
        /// bound (exponentially at stagnation points and in chaotic flow, until det F has
        /// lost all precision) while J stays near 1.
        volumetric_only: bool,
        /// The stress reads the points' velocity gradient
        /// ([`PointStressContext::velocity_gradient`]; a rate-dependent stress). A frame may
        /// leave ∇v at the points unwritten when no point-stress model of the field reads
        /// it (the collocated grid does: a quarter of the bytes its gather stores).
        velocity_gradient: bool,
    },
}

impl StressKind {
    /// A stress at the points.
    pub fn acts_on_points(self) -> bool {
        matches!(self, Self::Points { .. })
    }
    /// A stress on the grid's velocities.
    pub fn acts_on_grid(self) -> bool {
        matches!(self, Self::Grid { .. })
    }
    /// Rigid bodies.
    pub fn is_rigid(self) -> bool {
        self == Self::Rigid
    }
    /// A point stress that depends on F only through J.
    pub fn volumetric_only(self) -> bool {
        matches!(self, Self::Points { volumetric_only: true, .. })
    }
    /// A point stress that reads the points' velocity gradient.
    pub fn uses_velocity_gradient(self) -> bool {
        matches!(self, Self::Points { velocity_gradient: true, .. })
    }
    /// μ of a Newtonian grid stress.
    pub fn newtonian_viscosity(self) -> Option<Real> {
        match self {
            Self::Grid { newtonian_viscosity } => newtonian_viscosity,
            _ => None,
        }
    }
}

/// A stress (constitutive) model of one field.
pub trait StressModel: Send + Sync {
    /// Registered name.
    fn model(&self) -> &'static str;
    /// Parameters with defaults filled in.
    fn params(&self) -> serde_json::Value;
    /// Whether it runs on a rank's block of a decomposed domain (docs/design/mpi.md): every
    /// neighbour it reads through the grid's halo exchange (`Grid::exchange`), every sum over
    /// the domain through `Grid::dot`/`Grid::sum` or `Part::reduce`. A run on several ranks
    /// refuses, before step 0, a plugin that does not (the default).
    fn decomposed(&self) -> bool {
        false
    }
    /// Updates grid velocities with this stress (e.g. viscous diffusion). Default: nothing.
    fn apply_on_grid(&self, _ctx: &mut GridStressContext) -> Result<(), String> {
        Ok(())
    }
    /// What this model is: which part of the field it acts on and what it needs from the
    /// frame ([`StressKind`]). Every model says it: there is no default to be wrong.
    fn kind(&self) -> StressKind;
    /// Adds this model's Cauchy stress at every point (a [`StressKind::Points`] model).
    /// Default: nothing.
    fn point_stress(&self, _ctx: &mut PointStressContext) {}
    /// The names of this model's state components at each point (a [`StressKind::Points`]
    /// model: plastic strain, damage, …), one value each per point, which the frame keeps
    /// with the points and hands to [`StressModel::point_stress`] as
    /// [`PointStressContext::state`]. Snapshots write each component under
    /// `<model>_<component>` with the points (`/fields/<f>/points/`). Default:
    /// none.
    fn point_state(&self) -> &'static [&'static str] {
        &[]
    }
    /// Largest stable time step of this model, or `None` if it sets none.
    fn stable_dt(&self, _ctx: &TimeStepContext) -> Option<Real> {
        None
    }
    /// Stored (strain) energy per unit reference volume ψ(F), for energy checks;
    /// `None` for a model that stores none (viscosity, rigidity).
    fn strain_energy_density(&self, _f: &Matrix) -> Option<Real> {
        None
    }
}

/// What an exchange model sees: the two fields on the faces.
pub struct ExchangeContext<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// First field's grid state.
    pub a: &'a FieldState,
    /// Second field's grid state.
    pub b: &'a FieldState,
    /// Material densities of the two fields.
    pub density: [Real; 2],
    /// Whether the grid's storage wraps around along each axis: the axis is periodic and
    /// this rank holds all of it (a rank whose block is cut along a periodic axis reads
    /// across the wrap through its halo instead). On one rank: the domain's periodic axes.
    pub periodic: [bool; DIM],
}

/// Momentum exchange between two fields: the coefficient K of
/// θ_a θ_b K (u_b − u_a) in the momentum equations (mass/(volume·time)).
pub trait ExchangeModel: Send + Sync {
    /// Registered name.
    fn model(&self) -> &'static str;
    /// Parameters with defaults filled in.
    fn params(&self) -> serde_json::Value;
    /// Whether it runs on a rank's block of a decomposed domain (docs/design/mpi.md): every
    /// neighbour it reads through the grid's halo exchange (`Grid::exchange`), every sum over
    /// the domain through `Grid::dot`/`Grid::sum` or `Part::reduce`. A run on several ranks
    /// refuses, before step 0, a plugin that does not (the default).
    fn decomposed(&self) -> bool {
        false
    }
    /// A drag law on particles (diameter, viscosity, valid Re, added mass, rotation), or
    /// `None` for other couplings.
    fn drag_law(&self) -> Option<DragLaw> {
        None
    }
    /// K = ∞: the two fields move as one (exact mass-weighted average).
    fn no_slip(&self) -> bool {
        false
    }
    /// Whether this model, as it stands, can couple a fluid with a field of mass points
    /// (`representation: MassPoint`), which need a coefficient K from the slip: true by
    /// default; false for a coupling of resolved bodies ([`ExchangeModel::no_slip`], a
    /// [`ExchangeModel::immersed_boundary`]), for which the exchange entry must name the
    /// points' drag law in its `mass_point` model.
    fn couples_mass_points(&self) -> bool {
        !self.no_slip() && self.immersed_boundary().is_none()
    }
    /// A sharp coupling of a fluid (the first field) with the rigid bodies of a Lagrangian
    /// field (the second) by direct forcing on their surfaces, in place of a coefficient K:
    /// the core then runs its phase "immersed boundaries" (`multifield_core::immersed`) for
    /// the pair and leaves them out of the exchange. Default: `None`.
    fn immersed_boundary(&self) -> Option<ImmersedBoundary> {
        None
    }
    /// Fills K on every face of every face lattice (`k[a]` on the faces normal to axis `a`:
    /// x-faces, y-faces and in 3D z-faces). K is read only where both fields are present
    /// (and, explicit, weighed with both θ): a model may leave 0 on faces where the second
    /// field has no mass and no θ.
    fn coefficients(&self, ctx: &ExchangeContext, k: &mut FaceArrays);
}

/// What a contact model sees.
pub struct ContactContext<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// Boundary conditions (walls repel bodies; periodic sides do not).
    pub boundaries: &'a Boundaries,
    /// Gravity.
    pub gravity: Vector,
    /// Material density of the ambient fluid (the field that fills the rest of the
    /// domain; 0 when there is none), for buoyant weights (m − ρ_f V) |g|.
    pub fluid_density: Real,
    /// Dynamic viscosity μ of the ambient fluid when its stress is Newtonian (σ = 2μD; the
    /// sum of its Newtonian grid stresses), `None` when there is no ambient fluid or its
    /// stress is not Newtonian: for lubrication ([`ContactModel::needs_fluid_viscosity`]).
    pub fluid_viscosity: Option<Real>,
    /// Every body of every field.
    pub bodies: &'a [BodyState],
    /// Per body (the order of `bodies`): whether its field resolves it on the grid
    /// ([`Representation::Resolved`]) rather than as a single mass point, whose drag law
    /// already represents the fluid. Empty: every body resolved.
    pub resolved: &'a [bool],
}

impl ContactContext<'_> {
    /// Whether body `i` is resolved on the grid ([`ContactContext::resolved`]).
    pub fn is_resolved(&self, i: usize) -> bool {
        self.resolved.get(i).copied().unwrap_or(true)
    }
}

/// Contact between bodies and between bodies and walls (`repulsion`, `dem`).
pub trait ContactModel: Send + Sync {
    /// Registered name.
    fn model(&self) -> &'static str;
    /// Parameters with defaults filled in.
    fn params(&self) -> serde_json::Value;
    /// Whether it runs on a rank's block of a decomposed domain (docs/design/mpi.md): every
    /// neighbour it reads through the grid's halo exchange (`Grid::exchange`), every sum over
    /// the domain through `Grid::dot`/`Grid::sum` or `Part::reduce`. A run on several ranks
    /// refuses, before step 0, a plugin that does not (the default).
    fn decomposed(&self) -> bool {
        false
    }
    /// Force and torque on each body (same order as `ctx.bodies`) at the given states. `dt` is
    /// the (sub-)step these forces will act over: a model with history (tangential springs)
    /// advances it by `dt`.
    fn forces(&mut self, ctx: &ContactContext, dt: Real, out: &mut [(Vector, Real)]);
    /// Largest stable time step while bodies are in range, `None` otherwise.
    fn stable_dt(&self, _ctx: &ContactContext) -> Option<Real> {
        None
    }
    /// The model's history (e.g. tangential spring displacements per touching pair), for
    /// checkpoints; empty for a model without history.
    fn history(&self) -> Vec<u8> {
        Vec::new()
    }
    /// Restores `history()` from a checkpoint; refuses (with a message) what it cannot read.
    fn restore_history(&mut self, _bytes: &[u8]) -> Result<(), String> {
        Ok(())
    }
    /// The contact sub-step (`time.contact_substeps`): the largest stable step of the
    /// contact integration whenever any bodies may touch (wherever they stand now: a fluid
    /// step may carry them into range), `None` if none can. The default is
    /// [`ContactModel::stable_dt`], which sees only the bodies in range now.
    fn substep_dt(&self, ctx: &ContactContext) -> Option<Real> {
        self.stable_dt(ctx)
    }
    /// Whether the model reads [`ContactContext::fluid_viscosity`] (lubrication): the core
    /// then refuses a case whose ambient fluid has no Newtonian viscosity. Default: false.
    fn needs_fluid_viscosity(&self) -> bool {
        false
    }
    /// Whether the model treats every side that is not periodic as a wall for the bodies,
    /// open sides (inflows and outflows) included, so that no body reaches an open side
    /// (a field of bodies may then face one). False by default.
    fn keeps_bodies_off_sides(&self) -> bool {
        false
    }
    /// The gap from a wall (a side that is not periodic) within which the model carries
    /// the film between a resolved body and the wall (lubrication below the grid scale):
    /// a direct forcing then forces a free disk closer than this to a wall where it would
    /// stand at this gap ([`crate::immersed::ForcedBody::held`]), so that the grid's film
    /// stops at the gap where the model's takes over. 0 by default: the forcing follows the
    /// body to the wall. `h` is the grid spacing.
    fn wall_clearance(&self, _h: Real) -> Real {
        0.0
    }
}

/// A solver for the pressure equation.
pub trait PressureSolver: Send + Sync {
    /// Registered name.
    fn model(&self) -> &'static str;
    /// Parameters with defaults filled in.
    fn params(&self) -> serde_json::Value;
    /// Whether it runs on a rank's block of a decomposed domain (docs/design/mpi.md): every
    /// neighbour it reads through the grid's halo exchange (`Grid::exchange`), every sum over
    /// the domain through `Grid::dot`/`Grid::sum` or `Part::reduce`. A run on several ranks
    /// refuses, before step 0, a plugin that does not (the default).
    fn decomposed(&self) -> bool {
        false
    }
    /// Solves `problem` for `pressure` (which holds the initial guess).
    fn solve(&mut self, problem: &PoissonProblem, pressure: &mut [Real]) -> crate::Result<SolveStats>;
}
