//! The time loop: one step is a readable sequence of named phases (docs/method.md §3).
//!
//! Phases, in the order [`Simulation::step_with`] runs them, with the design's numbers
//! (docs/method.md §3): (1) particles to grid, (2) volume fractions, (2b) the direct
//! forcing's lagged marker forces, (3) predictor, (4) exchange, (8a) contact forces,
//! (4b) immersed boundaries, (5–6) pressure and corrector, (7) grid to particles (with 8b,
//! the bodies' rigid projection and contact impulse), (9) advection. Plugins attach to
//! phases through their traits; nothing depends on registration order.
//!
//! Where each part is:
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | the types ([`Simulation`], [`Field`], [`StepDiagnostics`], [`Status`]) and the read-only accessors |
//! | `build.rs` | [`Simulation::new`]: fields, frames, plugins and the initial state |
//! | `checks.rs` | the checks of a case's combination of fields, frames and couplings, made while building |
//! | `step.rs` | the time step's choice and [`Simulation::step_with`], the phases in order, and the light ones (1, 2, 2b, 3, 4b, 7, 8a, 9) |
//! | `momentum_exchange.rs` | phase 4, the implicit exchange on every face |
//! | `projection.rs` | phases 5–6, the pressure projection and the corrector |
//! | `checkpoint.rs` | [`Simulation::save_state`] and [`Simulation::load_state`] |

mod build;
mod checkpoint;
mod checks;
mod contact;
mod momentum_exchange;
mod projection;
mod step;
pub use contact::MAX_CONTACT_SUBSTEPS;
pub use step::OUTPUT_TIME;

pub use checks::MASS_POINT_FRAME;
use checks::*;
pub use projection::constraint_of;

use crate::boundary::Boundaries;
use crate::boundary::Side;
use crate::case::{BodyShape, Case, Integration, Motion, PluginSpec, Region, Representation, MAX_FIELDS};
use crate::error::{Error, Result};
use crate::exchange::{self, Coefficients, Local};
use crate::field::FieldState;
use crate::grid::{FaceArrays, Grid, Lattice};
use crate::math::{vector, Real, Vector, AXES, DIM};
use crate::plugin::{
    BodyContact, BodyState, BodyStep, ContactContext, ContactModel, DragLaw, ExchangeContext, ExchangeModel, Frame,
    FrameContext, FrameFigures, ImmersedBoundary, InitContext, Partner, PressureSolver, StressModel, TimeStepContext,
};
use crate::poisson::PoissonProblem;
use crate::registry;
use crate::state;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// One field of a running simulation.
pub struct Field {
    /// Name from the case.
    pub name: String,
    /// Material density ρ⁰.
    pub density: Real,
    /// Whether some of its bodies have their own density: the grid's θρ⁰ is then the mass
    /// its points put there, not θ times the field's ρ⁰.
    pub own_densities: bool,
    /// Whether it fills what the others leave (region `Rest`).
    pub fills_rest: bool,
    /// Its frame.
    pub frame: Box<dyn Frame>,
    /// Its stress models.
    pub stress: Vec<Box<dyn StressModel>>,
    /// Its grid state.
    pub state: FieldState,
}

/// One exchange entry of a running simulation.
pub struct Exchange {
    /// Indices of the two fields.
    pub fields: [usize; 2],
    /// The model.
    pub model: Box<dyn ExchangeModel>,
    /// Implicit or explicit.
    pub integration: Integration,
    /// K on every face lattice.
    k: FaceArrays,
}

/// A direct-forcing coupling of a fluid with a field of rigid bodies.
struct ForcedPair {
    /// Index of the fluid.
    fluid: usize,
    /// Index of the bodies' field.
    bodies: usize,
    /// The forcing's options (a 3D case has no bodies: never read there).
    #[cfg_attr(feature = "dim3", allow(dead_code))]
    forcing: ImmersedBoundary,
    /// The last step's marker forces per body, per marker (per unit mass), lagged into
    /// the next step ([`crate::immersed::couple`]).
    lag: Vec<Vec<Vector>>,
}

/// Figures of one step, written to `diagnostics.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepDiagnostics {
    /// Step number (1 for the first step).
    pub step: u64,
    /// Time at the end of the step.
    pub time: Real,
    /// The step's Δt.
    pub dt: Real,
    /// What limited Δt.
    pub dt_limit: String,
    /// Total kinetic energy.
    pub kinetic_energy: Real,
    /// Elastic energy stored in the material points, Σ_p V⁰_p ψ(F_p), of the stress models
    /// that define a strain-energy density ψ (0 when none does; NaN when the only field
    /// steps alone: its fast path does not compute it, as it computes no Σθ).
    pub strain_energy: Real,
    /// Total linear momentum.
    pub momentum: Vector,
    /// Total mass.
    pub mass: Real,
    /// Largest speed.
    pub max_speed: Real,
    /// max |∇·(Σθu) − β(Σθ−1)/Δt| after the projection (1/time); in a closed domain (no
    /// outflow side) less its mean, which the pure-Neumann pressure equation cannot remove.
    pub max_divergence: Real,
    /// max |Σθ − 1| over the cells.
    pub volume_fraction_error: Real,
    /// max Σθ over the cells: above 1 where material is packed beyond what a cell holds
    /// (NaN when the only field steps alone and Σθ is not computed).
    pub max_volume_fraction: Real,
    /// Iterations of the pressure solve.
    pub pressure_iterations: usize,
    /// Relative residual of the pressure solve.
    pub pressure_residual: Real,
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Reached the end time.
    Completed,
    /// Stopped because the solution blew up; the reason says how.
    Unstable(String),
    /// Stopped by an error.
    Failed(String),
    /// Stopped on request (an interrupt or termination signal) after a whole step, its
    /// output written: a restart from its last checkpoint continues it.
    Interrupted(String),
}

impl Status {
    /// "completed", "unstable", "failed" or "interrupted".
    pub fn label(&self) -> &'static str {
        match self {
            Status::Completed => "completed",
            Status::Unstable(_) => "unstable",
            Status::Failed(_) => "failed",
            Status::Interrupted(_) => "interrupted",
        }
    }
    /// The reason (empty when completed).
    pub fn reason(&self) -> &str {
        match self {
            Status::Completed => "",
            Status::Unstable(r) | Status::Failed(r) | Status::Interrupted(r) => r,
        }
    }
}

/// A running simulation.
pub struct Simulation {
    /// The case as run (plugin defaults filled in).
    pub case: Case,
    /// The grid.
    pub grid: Grid,
    /// Boundary conditions.
    pub boundaries: Boundaries,
    /// Gravity.
    pub gravity: Vector,
    /// The fields.
    pub fields: Vec<Field>,
    /// The exchanges.
    pub exchanges: Vec<Exchange>,
    /// The pressure solver, if the case has one.
    pub pressure_solver: Option<Box<dyn PressureSolver>>,
    /// The contact model, if the case has one.
    pub contact: Option<Box<dyn ContactModel>>,
    /// Contact force and torque on each body of each field, with the position correction
    /// of sub-stepped contact (phase 8).
    pub body_forces: Vec<Vec<BodyContact>>,
    /// Per field, the fluid it is coupled to by a drag law, and the law.
    partners: Vec<Option<(usize, DragLaw)>>,
    /// The direct-forcing couplings (exchanges with [`ExchangeModel::immersed_boundary`]).
    forcings: Vec<ForcedPair>,
    /// Per field of bodies moved by a direct forcing, what it decided in this step.
    body_steps: Vec<Vec<BodyStep>>,
    /// Pressure at cell centres.
    pub pressure: Vec<Real>,
    /// Simulated time.
    pub time: Real,
    /// Steps taken.
    pub steps: u64,
    /// Figures of the last step.
    pub last: StepDiagnostics,
    /// Kinetic energy at the start.
    pub initial_energy: Real,
    /// The running time averages of the case's `TimeAverage` monitors, which the monitors
    /// update ([`crate::monitor::Monitors`]), snapshots write and checkpoints keep (empty
    /// without such monitors).
    pub averages: Vec<crate::monitor::TimeAverage>,
    /// The case's only field steps alone ([`Frame::steps_alone`]).
    alone: bool,
    /// The fields' grid state is older than their frames' (a field that steps alone does
    /// not write it): [`Simulation::refresh_grid_state`] before reading it.
    grid_state_stale: bool,
}

/// Fraction of each cell covered by `region`, by 8×8 sub-sampling.
///
/// A list of bodies is rasterised body by body over the cells of its bounding box (and one
/// more cell around it): O(cells + bodies × the cells each covers), not O(cells × bodies).
/// Each sub-sample is the same point, tested by the same [`BodyShape::contains`], as in
/// the plain loop, and a cell's fraction is the count of the sub-samples inside any body
/// over 64: the same bits in any order.
#[cfg(feature = "dim2")]
pub fn region_fraction(region: &Region, grid: &Grid) -> Vec<Real> {
    const S: usize = 8;
    let sample = |i: usize, j: usize, a: usize, b: usize| {
        // (a rank's cells by their global index: the same points as the domain's)
        let x = grid.origin.x + (grid.global(0, i) + (a as Real + 0.5) / S as Real) * grid.h;
        let y = grid.origin.y + (grid.global(1, j) + (b as Real + 0.5) / S as Real) * grid.h;
        (x, y)
    };
    if let Region::Bodies(bodies) = region {
        // bit a + S b of a cell's mask: sub-sample (a, b) lies in some body
        let mut masks = vec![0u64; grid.n_cells()];
        for body in bodies {
            let (lo, hi) = body.shape.bounds();
            let range = |lo: Real, hi: Real, origin: Real, n: usize, start: isize| {
                // one cell of margin: a sample on the rounded edge of a disk may lie a few
                // ulps outside its bounding box (local cells: less a rank's start)
                let first = ((lo - origin) / grid.h).floor() - 1.0 - start as Real;
                let last = ((hi - origin) / grid.h).floor() + 1.0 - start as Real;
                let clamp = |c: Real| if c.is_nan() { 0 } else { c.clamp(0.0, (n - 1) as Real) as usize };
                (clamp(first), clamp(last))
            };
            let (i0, i1) = range(lo[0], hi[0], grid.origin.x, grid.nx, grid.start[0]);
            let (j0, j1) = range(lo[1], hi[1], grid.origin.y, grid.ny, grid.start[1]);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let mask = &mut masks[grid.cell(i, j)];
                    if *mask == u64::MAX {
                        continue;
                    }
                    for b in 0..S {
                        for a in 0..S {
                            let bit = 1u64 << (a + S * b);
                            if *mask & bit == 0 {
                                let (x, y) = sample(i, j, a, b);
                                if body.shape.contains(x, y) {
                                    *mask |= bit;
                                }
                            }
                        }
                    }
                }
            }
        }
        return masks.into_iter().map(|m| m.count_ones() as Real / (S * S) as Real).collect();
    }
    let mut out = vec![0.0; grid.n_cells()];
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let mut inside = 0;
            for b in 0..S {
                for a in 0..S {
                    let (x, y) = sample(i, j, a, b);
                    inside += usize::from(region.contains(x, y));
                }
            }
            out[grid.cell(i, j)] = inside as Real / (S * S) as Real;
        }
    }
    out
}

/// Fraction of each cell covered by `region` (3D): the share of its 4 × 4 × 4 sub-samples
/// (at the centres of the sub-cells) inside the region, a fixed sampling, so the same bits
/// in any order. The case's validation refuses the 2D shapes and bodies in 3D.
#[cfg(feature = "dim3")]
pub fn region_fraction(region: &Region, grid: &Grid) -> Vec<Real> {
    const S: usize = 4;
    if matches!(region, Region::All | Region::Rest) {
        return vec![1.0; grid.n_cells()];
    }
    grid.nodes(Lattice::Cell)
        .map(|(_, at)| {
            let mut inside = 0;
            for c in 0..S {
                for b in 0..S {
                    for a in 0..S {
                        let sub = [a, b, c];
                        let p = grid.origin
                            + Vector::from_fn(|d, _| {
                                (grid.global(d, at[d]) + (sub[d] as Real + 0.5) / S as Real) * grid.h
                            });
                        inside += usize::from(region.contains_point(p));
                    }
                }
            }
            inside as Real / (S * S * S) as Real
        })
        .collect()
}

/// [`Simulation::fluid_viscosity`] of these fields.
pub(crate) fn ambient_viscosity(fields: &[Field]) -> Option<Real> {
    let f = fields.iter().find(|f| f.fills_rest)?;
    let mut grid = f.stress.iter().filter(|s| s.kind().acts_on_grid()).peekable();
    grid.peek()?;
    grid.map(|s| s.kind().newtonian_viscosity()).sum()
}

impl Simulation {
    /// Index of the field named `name`.
    pub fn field_index(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }

    /// Material density of the field that fills what the others leave (the ambient
    /// fluid of bodies), 0 when no field does.
    pub fn fluid_density(&self) -> Real {
        self.fields.iter().find(|f| f.fills_rest).map_or(0.0, |f| f.density)
    }

    /// Dynamic viscosity of the ambient fluid (the field that fills what the others
    /// leave): the sum of its grid stresses' Newtonian viscosities, `None` when no field
    /// fills the rest, it has no grid stress, or one of them is not Newtonian.
    pub fn fluid_viscosity(&self) -> Option<Real> {
        ambient_viscosity(&self.fields)
    }

    /// Every body of every field without its name ([`BodyState::unnamed`]: the contact
    /// models never report one) and, per body, whether its field resolves it on the grid
    /// (not a mass point), in the order of [`Simulation::bodies`], and the number of
    /// bodies of each field.
    pub(crate) fn contact_bodies(&self) -> (Vec<BodyState>, Vec<bool>, Vec<usize>) {
        let mut bodies = Vec::new();
        let mut resolved = Vec::new();
        let mut counts = Vec::with_capacity(self.fields.len());
        for f in &self.fields {
            let b = f.frame.body_states();
            resolved.extend(std::iter::repeat_n(f.frame.representation() == Representation::Resolved, b.len()));
            counts.push(b.len());
            bodies.extend(b.into_iter().map(BodyState::unnamed));
        }
        (bodies, resolved, counts)
    }

    /// Largest speed of any field.
    pub fn max_speed(&self) -> Real {
        if self.alone && self.steps > 0 {
            // the step's own figure (the same max |v| over the points, summed in its pass)
            return self.last.max_speed;
        }
        self.fields.iter().map(|f| f.frame.max_speed()).fold(0.0, Real::max)
    }

    /// Total kinetic energy.
    pub fn kinetic_energy(&self) -> Real {
        self.fields.iter().map(|f| f.frame.kinetic_energy()).sum()
    }

    /// Whether the only field steps alone (the collocated fast path): none of the
    /// multifield phases runs, and neither Σθ nor the strain energy is computed per step.
    pub fn steps_alone(&self) -> bool {
        self.alone
    }

    /// Elastic energy stored in the fields' material points ([`Frame::strain_energy`]).
    pub fn strain_energy(&self) -> Real {
        self.fields.iter().map(|f| f.frame.strain_energy(&f.stress)).sum()
    }

    /// Where the run left its models' range of validity (point particles larger than a
    /// cell, Reynolds numbers outside a drag law's range): one sentence each, prefixed with
    /// the field's name.
    pub fn warnings(&self) -> Vec<String> {
        self.fields
            .iter()
            .flat_map(|f| f.frame.warnings(&self.grid).into_iter().map(move |w| format!("field `{}`: {w}", f.name)))
            .collect()
    }

    /// Every body of every field with its field's name.
    pub fn bodies(&self) -> Vec<(String, BodyState)> {
        self.fields.iter().flat_map(|f| f.frame.bodies().into_iter().map(|b| (f.name.clone(), b))).collect()
    }

    /// The pressure part of the hydrodynamic force on every body, in the order of
    /// [`Simulation::bodies`]: `−∮ p n dS` over the surface of each disk a direct forcing
    /// holds ([`crate::immersed::disk_pressure_force`], the pressure of the last step on
    /// the body where it stands now), `None` for the others (bodies of other couplings,
    /// annuli, rectangles, or no pressure solve). The viscous part is the body's
    /// hydrodynamic force less it; a circle's pressure exerts no torque.
    pub fn pressure_forces(&self) -> Vec<Option<Vector>> {
        #[cfg(feature = "dim2")]
        let periodic = self.boundaries.periodic_axes();
        let mut out = Vec::new();
        for (k, f) in self.fields.iter().enumerate() {
            let n = f.frame.bodies().len();
            let forcing = self.forcings.iter().position(|p| p.bodies == k);
            match forcing.filter(|_| self.pressure_solver.is_some()) {
                #[cfg(feature = "dim2")]
                Some(i) => {
                    let retraction = self.forcings[i].forcing.retraction;
                    let bodies = self.forced_bodies(i);
                    // the forcing held the body where its markers stood (ForcedBody::held)
                    out.extend((0..n).map(|j| match bodies.get(j).map(|b| (&b.shape, b.clone().held().center)) {
                        Some((BodyShape::Disk { radius, .. }, center)) => Some(crate::immersed::disk_pressure_force(
                            &self.grid,
                            periodic,
                            &self.pressure,
                            center,
                            *radius,
                            retraction,
                        )),
                        _ => None,
                    }));
                }
                _ => out.extend(std::iter::repeat_n(None, n)),
            }
        }
        out
    }
}
