//! The time loop: one step is a readable sequence of named phases (docs/method.md §3).
//!
//! Phases, in the order [`Simulation::step_with`] runs them, with the design's numbers
//! (docs/method.md §3): (1) particles to grid, (2) volume fractions, (2b) the direct
//! forcing's lagged marker forces, (3) predictor, (4) exchange, (8a) contact forces,
//! (4b) immersed boundaries, (5–6) pressure and corrector, (7) grid to particles (with 8b,
//! the bodies' rigid projection and contact impulse), (9) advection. Plugins attach to
//! phases through their traits; nothing depends on registration order.

use crate::boundary::Boundaries;
use crate::case::{BodyShape, Case, Integration, Motion, PluginSpec, Region, Representation, MAX_FIELDS};
use crate::error::{Error, Result};
use crate::exchange::{self, Coefficients, Local};
use crate::field::FieldState;
use crate::grid::Grid;
use crate::math::{vector, Real, Vector};
use crate::plugin::{
    BodyState, BodyStep, ContactContext, ContactModel, DragLaw, ExchangeContext, ExchangeModel, Frame, FrameContext,
    FrameFigures, ImmersedBoundary, InitContext, Partner, PressureSolver, StressModel, TimeStepContext,
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
    kx: Vec<Real>,
    ky: Vec<Real>,
}

/// A direct-forcing coupling of a fluid with a field of rigid bodies.
struct ForcedPair {
    /// Index of the fluid.
    fluid: usize,
    /// Index of the bodies' field.
    bodies: usize,
    /// The forcing's options.
    forcing: ImmersedBoundary,
    /// The last step's marker forces per body, per marker (per unit mass), lagged into
    /// the next step ([`crate::immersed::couple`]).
    lag: Vec<Vec<Vector>>,
}

/// What a [`Simulation`] carries from one step to the next ([`Simulation::save_state`]):
/// borrowed when saved, owned when loaded.
#[derive(Serialize, Deserialize)]
struct SimulationState<'a> {
    time: Real,
    steps: u64,
    initial_energy: Real,
    pressure: Cow<'a, [Real]>,
    last: Cow<'a, StepDiagnostics>,
    body_forces: Cow<'a, [Vec<(Vector, Real)>]>,
    fields: Vec<FieldCheckpoint<'a>>,
    /// Per direct forcing, the lagged marker forces ([`ForcedPair::lag`]).
    marker_forces: Vec<Cow<'a, [Vec<Vector>]>>,
}

/// One field in a [`SimulationState`]: its name and frame (checked on loading), its grid
/// state and its frame's own state ([`Frame::save_state`], opaque to the core).
#[derive(Serialize, Deserialize)]
struct FieldCheckpoint<'a> {
    name: Cow<'a, str>,
    model: Cow<'a, str>,
    grid: Cow<'a, FieldState>,
    frame: Cow<'a, [u8]>,
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
}

impl Status {
    /// "completed", "unstable" or "failed".
    pub fn label(&self) -> &'static str {
        match self {
            Status::Completed => "completed",
            Status::Unstable(_) => "unstable",
            Status::Failed(_) => "failed",
        }
    }
    /// The reason (empty when completed).
    pub fn reason(&self) -> &str {
        match self {
            Status::Completed => "",
            Status::Unstable(r) | Status::Failed(r) => r,
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
    /// Contact force and torque on each body of each field (phase 8).
    pub body_forces: Vec<Vec<(Vector, Real)>>,
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
    /// The case's only field steps alone ([`Frame::steps_alone`]).
    alone: bool,
    /// The fields' grid state is older than their frames' (a field that steps alone does
    /// not write it): [`Simulation::refresh_grid_state`] before reading it.
    grid_state_stale: bool,
}

/// Fraction of each cell covered by `region`, by 8×8 sub-sampling.
pub fn region_fraction(region: &Region, grid: &Grid) -> Vec<Real> {
    const S: usize = 8;
    let mut out = vec![0.0; grid.n_cells()];
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let mut inside = 0;
            for b in 0..S {
                for a in 0..S {
                    let x = grid.origin.x + (i as Real + (a as Real + 0.5) / S as Real) * grid.h;
                    let y = grid.origin.y + (j as Real + (b as Real + 0.5) / S as Real) * grid.h;
                    inside += usize::from(region.contains(x, y));
                }
            }
            out[grid.cell(i, j)] = inside as Real / (S * S) as Real;
        }
    }
    out
}

impl Simulation {
    /// Builds every model from the registries and seeds the initial state.
    pub fn new(case: &Case) -> Result<Simulation> {
        case.validate()?;
        let mut case = case.clone();
        let d = &case.domain;
        let h = d.size[0] / d.cells[0] as Real;
        let grid = Grid::new(d.cells[0], d.cells[1], h, vector(d.origin));
        let boundaries = case.boundaries;
        let mut fields = Vec::new();
        for (k, spec) in case.fields.iter_mut().enumerate() {
            let path = format!("fields.{}", spec.name);
            let mut frame = registry::build_frame(&spec.frame.model, &spec.frame.params, &format!("{path}.frame"))?;
            spec.frame.params = frame.params();
            if frame.representation() == Representation::MassPoint && spec.representation != Representation::MassPoint {
                return Err(Error::invalid(
                    format!("{path}.frame.model"),
                    format!(
                        "`{}` is the frame of `representation: MassPoint`: set that entry instead \
                         (and keep the resolved frame, e.g. `(model: \"lagrangian\")`, for switching back)",
                        spec.frame.model
                    ),
                ));
            }
            if spec.representation == Representation::MassPoint {
                // the resolved frame's options stay in the case, so that switching back is
                // one entry; the points are the `mass_point` frame's
                frame = registry::build_frame(
                    MASS_POINT_FRAME,
                    &serde_json::Value::Object(Default::default()),
                    &format!("{path}.representation"),
                )?;
                if frame.representation() != Representation::MassPoint {
                    return Err(Error::invalid(
                        format!("{path}.representation"),
                        format!(
                            "the frame registered as `{MASS_POINT_FRAME}` is not a mass-point frame (its \
                             Frame::representation is {:?}): another crate registered that name",
                            frame.representation()
                        ),
                    ));
                }
            }
            let mut stress = Vec::new();
            for (s, st) in spec.stress.iter_mut().enumerate() {
                let m = registry::build_stress(&st.model, &st.params, &format!("{path}.stress.{s}"))?;
                st.params = m.params();
                stress.push(m);
            }
            let fills_rest = spec.region == Region::Rest;
            if fills_rest && frame.is_lagrangian() {
                return Err(Error::invalid(
                    format!("{path}.region"),
                    "region `Rest` is only for an Eulerian field (its volume fraction is what the \
                     others leave); give a Lagrangian field an explicit region",
                ));
            }
            let _ = k;
            fields.push(Field {
                name: spec.name.clone(),
                density: spec.density,
                fills_rest,
                frame,
                stress,
                state: FieldState::new(&grid),
            });
        }
        let mut exchanges = Vec::new();
        let mut forcings: Vec<ForcedPair> = Vec::new();
        let mut forced_entries = Vec::new();
        let mut partners: Vec<Option<(usize, DragLaw)>> = vec![None; fields.len()];
        for (k, e) in case.exchange.iter_mut().enumerate() {
            let idx = |n: &String| case_index(&fields, n);
            let (fa, fb) = (idx(&e.between[0]), idx(&e.between[1]));
            let spec_b = &case.fields[fb];
            let model = if spec_b.representation == Representation::MassPoint {
                let path = format!("exchange.{k}.mass_point");
                let alt = e.mass_point.clone().unwrap_or_else(|| PluginSpec::with(&e.model, e.params.clone()));
                let params = point_drag_params(&alt, &case.fields[fa], spec_b, &path)?;
                let model = registry::build_exchange(&alt.model, &params, &path)?;
                if e.mass_point.is_none() && !model.couples_mass_points() {
                    return Err(Error::invalid(
                        path,
                        format!(
                            "field `{}` is represented by mass points, which need a drag law, but this \
                             exchange is `{}` and names no `mass_point` model; add e.g. \
                             `mass_point: Some((model: \"cylinder\", params: (added_mass: 1.0)))` to \
                             the exchange (or set `representation: Resolved`)",
                            spec_b.name, e.model
                        ),
                    ));
                }
                let law = model.drag_law();
                if let Some(law) = &law {
                    check_point_diameters(law, spec_b, &path)?;
                }
                e.mass_point = Some(PluginSpec::with(&alt.model, model.params()));
                model
            } else {
                let model = registry::build_exchange(&e.model, &e.params, &format!("exchange.{k}"))?;
                e.params = model.params();
                model
            };
            if let Some(law) = model.drag_law() {
                partners[fb] = Some((fa, law));
            }
            if let Some(forcing) = model.immersed_boundary() {
                forced_entries.push(k);
                forcings.push(ForcedPair { fluid: fa, bodies: fb, forcing, lag: Vec::new() });
                continue;
            }
            exchanges.push(Exchange {
                fields: [idx(&e.between[0]), idx(&e.between[1])],
                model,
                integration: e.integration,
                kx: vec![0.0; grid.n_xfaces()],
                ky: vec![0.0; grid.n_yfaces()],
            });
        }
        for (k, p) in forced_entries.iter().zip(&forcings) {
            check_forcing(&case, &fields, *k, p.fluid, p.bodies)?;
        }
        let pressure_solver = match &mut case.pressure {
            Some(p) => {
                let s = registry::build_pressure(&p.model, &p.params, "pressure")?;
                p.params = s.params();
                Some(s)
            }
            None => None,
        };
        let contact = match &mut case.contact {
            Some(c) => {
                let m = registry::build_contact(&c.model, &c.params, "contact")?;
                c.params = m.params();
                Some(m)
            }
            None => None,
        };
        // seed: fields with their own region first, then the one that fills the rest
        let mut occupied = vec![0.0; grid.n_cells()];
        for (k, f) in fields.iter_mut().enumerate() {
            if f.fills_rest {
                continue;
            }
            let forced = forcings.iter().any(|p| p.bodies == k);
            let spec = &case.fields[k];
            let theta: Vec<Real> = if spec.representation == Representation::MassPoint {
                mass_point_fraction(&spec.region, &grid, [boundaries.periodic_x(), boundaries.periodic_y()])
            } else {
                region_fraction(&spec.region, &grid).into_iter().map(|t| t * spec.volume_fraction).collect()
            };
            // bodies under a direct forcing take no volume on the grid: the fluid fills them
            if !forced {
                for (o, t) in occupied.iter_mut().zip(&theta) {
                    *o += t;
                }
            }
            if spec.volume_fraction != 1.0 && f.frame.is_lagrangian() {
                return Err(Error::invalid(
                    format!("fields.{}.volume_fraction", f.name),
                    "a Lagrangian field fills its region (its points carry the volume); \
                     use an Eulerian field for a partial volume fraction",
                ));
            }
            f.frame
                .initialize(&InitContext {
                    grid: &grid,
                    boundaries: &boundaries,
                    name: &f.name,
                    density: f.density,
                    region: &spec.region,
                    velocity: &spec.velocity,
                    theta: (!f.frame.is_lagrangian()).then_some(&theta[..]),
                })
                .map_err(|m| Error::invalid(format!("fields.{}", f.name), m))?;
        }
        let rest: Vec<Real> = occupied.iter().map(|o| (1.0 - o).max(0.0)).collect();
        for (k, f) in fields.iter_mut().enumerate() {
            if !f.fills_rest {
                continue;
            }
            let spec = &case.fields[k];
            f.frame
                .initialize(&InitContext {
                    grid: &grid,
                    boundaries: &boundaries,
                    name: &f.name,
                    density: f.density,
                    region: &spec.region,
                    velocity: &spec.velocity,
                    theta: Some(&rest),
                })
                .map_err(|m| Error::invalid(format!("fields.{}", f.name), m))?;
        }
        let initial_energy = fields.iter().map(|f| f.frame.kinetic_energy()).sum();
        let n_fields = fields.len();
        let alone = fields.iter().any(|f| f.frame.steps_alone());
        if alone {
            check_alone(&case, &fields, pressure_solver.is_some())?;
        }
        Ok(Simulation {
            gravity: vector(case.gravity),
            pressure: vec![0.0; grid.n_cells()],
            case,
            grid,
            boundaries,
            fields,
            exchanges,
            pressure_solver,
            contact,
            body_forces: vec![Vec::new(); n_fields],
            partners,
            forcings,
            body_steps: vec![Vec::new(); n_fields],
            time: 0.0,
            steps: 0,
            last: StepDiagnostics::default(),
            initial_energy,
            alone,
            grid_state_stale: false,
        })
    }

    /// Everything the next steps depend on, for a checkpoint: time, steps, the pressure
    /// (the initial guess of the next solve), the last step's figures, the initial energy,
    /// the contact forces, every field's grid state and its frame's own state
    /// ([`Frame::save_state`]). [`Simulation::load_state`] on a simulation built from the
    /// same case continues bit for bit. The exchange coefficients are not in it (every step
    /// recomputes them), nor the pressure solvers' caches (multigrid hierarchy, symbolic
    /// and numeric factorizations), which every solve rebuilds from its problem: a solve
    /// depends only on the problem and the initial guess.
    pub fn save_state(&self) -> Result<Vec<u8>> {
        let mut fields = Vec::with_capacity(self.fields.len());
        for f in &self.fields {
            let frame = f.frame.save_state().map_err(|m| Error::Model(format!("field `{}`: {m}", f.name)))?;
            fields.push(FieldCheckpoint {
                name: Cow::Borrowed(&f.name),
                model: Cow::Borrowed(f.frame.model()),
                grid: Cow::Borrowed(&f.state),
                frame: Cow::Owned(frame),
            });
        }
        let saved = SimulationState {
            time: self.time,
            steps: self.steps,
            initial_energy: self.initial_energy,
            pressure: Cow::Borrowed(&self.pressure),
            last: Cow::Borrowed(&self.last),
            body_forces: Cow::Borrowed(&self.body_forces),
            fields,
            marker_forces: self.forcings.iter().map(|p| Cow::Borrowed(&p.lag[..])).collect(),
        };
        state::encode(&saved).map_err(Error::Model)
    }

    /// Restores what [`Simulation::save_state`] wrote, into a simulation built from the
    /// same case (same grid and fields; the time control and output may differ). The
    /// message of an error says which part does not fit.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        self.load_state_inner(bytes).map_err(Error::Model)?;
        self.grid_state_stale = self.alone;
        Ok(())
    }

    fn load_state_inner(&mut self, bytes: &[u8]) -> std::result::Result<(), String> {
        let saved: SimulationState = state::decode(bytes, "simulation state")?;
        let mut pressure = vec![0.0; self.grid.n_cells()];
        state::copy_into(&mut pressure, &saved.pressure, "pressure")?;
        let n = saved.body_forces.len();
        if n != self.fields.len() {
            return Err(format!("contact forces of {n} fields in the checkpoint, {} fields here", self.fields.len()));
        }
        let n = saved.fields.len();
        if n != self.fields.len() {
            return Err(format!("{n} fields in the checkpoint, {} here", self.fields.len()));
        }
        let n = saved.marker_forces.len();
        if n != self.forcings.len() {
            return Err(format!("{n} direct forcings in the checkpoint, {} here", self.forcings.len()));
        }
        for (f, c) in self.fields.iter_mut().zip(&saved.fields) {
            let (name, model) = (&c.name, &c.model);
            if *name != f.name || *model != f.frame.model() {
                return Err(format!(
                    "the checkpoint holds field `{name}` ({model} frame) where the case has `{}` ({} frame)",
                    f.name,
                    f.frame.model()
                ));
            }
            let what = |q: &str| format!("field `{name}`: {q}");
            let (s, g) = (&mut f.state, &c.grid);
            for (a, b, q) in [
                (&mut s.theta, &g.theta, "volume fraction"),
                (&mut s.theta_u, &g.theta_u, "x-face volume fraction"),
                (&mut s.theta_v, &g.theta_v, "y-face volume fraction"),
                (&mut s.mass_u, &g.mass_u, "x-face mass"),
                (&mut s.mass_v, &g.mass_v, "y-face mass"),
            ] {
                state::copy_into(a, b, &what(q))?;
            }
            for (v, w, q) in [
                (&mut s.velocity, &g.velocity, "velocity"),
                (&mut s.velocity_old, &g.velocity_old, "old velocity"),
                (&mut s.pressure_acceleration, &g.pressure_acceleration, "pressure acceleration"),
                (&mut s.specific_volume, &g.specific_volume, "specific volume"),
                (&mut s.body_force, &g.body_force, "immersed-boundary force"),
            ] {
                state::copy_into(&mut v.u, &w.u, &what(&format!("{q} on x-faces")))?;
                state::copy_into(&mut v.v, &w.v, &what(&format!("{q} on y-faces")))?;
            }
            f.frame.load_state(&c.frame).map_err(|m| format!("field `{name}`: {m}"))?;
        }
        for (p, lag) in self.forcings.iter_mut().zip(saved.marker_forces) {
            p.lag = lag.into_owned();
        }
        self.time = saved.time;
        self.steps = saved.steps;
        self.initial_energy = saved.initial_energy;
        self.pressure = pressure;
        self.last = saved.last.into_owned();
        self.body_forces = saved.body_forces.into_owned();
        Ok(())
    }

    /// Index of the field named `name`.
    pub fn field_index(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }

    /// Material density of the field that fills what the others leave (the ambient
    /// fluid of bodies), 0 when no field does.
    pub fn fluid_density(&self) -> Real {
        self.fields.iter().find(|f| f.fills_rest).map_or(0.0, |f| f.density)
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

    /// The next time step and what limits it.
    pub fn choose_dt(&self) -> (Real, String) {
        let t = &self.case.time;
        let remaining = t.end - self.time;
        if let Some(dt) = t.fixed_dt {
            // the adaptive choice says whether the fixed step exceeds a stable limit
            let mut adaptive = self.case.time.clone();
            adaptive.fixed_dt = None;
            adaptive.max_dt = Real::INFINITY;
            let (limit, by) = self.adaptive_dt(&adaptive, Real::INFINITY);
            let dt = dt.min(remaining.max(0.0)).max(0.0);
            let label = if dt > limit * (1.0 + 1e-9) {
                format!("fixed (exceeds the {by} limit {limit:.3e})")
            } else {
                "fixed".to_string()
            };
            return (dt, label);
        }
        self.adaptive_dt(t, remaining)
    }

    /// The adaptive Δt under `t` (CFL, `max_dt`, every model's limit) and what limits it,
    /// cut to `remaining`.
    fn adaptive_dt(&self, t: &crate::case::TimeControl, remaining: Real) -> (Real, String) {
        let h = self.grid.h;
        let umax = self.max_speed();
        let g = self.gravity.norm();
        // Δt (|u| + |g| Δt) ≤ C h: the step keeps the CFL bound even as gravity accelerates the flow
        let mut best = (t.max_dt, "max_dt".to_string());
        let cfl = if g > 0.0 {
            (-umax + (umax * umax + 4.0 * g * t.cfl * h).sqrt()) / (2.0 * g)
        } else if umax > 0.0 {
            t.cfl * h / umax
        } else {
            Real::INFINITY
        };
        if cfl < best.0 {
            best = (cfl, "cfl".into());
        }
        for f in &self.fields {
            let ctx = TimeStepContext {
                grid: &self.grid,
                density: f.density,
                max_speed: f.frame.max_speed(),
                implicit_viscosity: f.frame.implicit_diffusion_number(&f.stress),
            };
            for s in &f.stress {
                if let Some(dt) = s.stable_dt(&ctx) {
                    if dt < best.0 {
                        best = (dt, format!("{}({})", s.model(), f.name));
                    }
                }
            }
        }
        if let Some(c) = &self.contact {
            let bodies: Vec<BodyState> = self.fields.iter().flat_map(|f| f.frame.bodies()).collect();
            let ctx = ContactContext {
                grid: &self.grid,
                boundaries: &self.boundaries,
                gravity: self.gravity,
                fluid_density: self.fluid_density(),
                bodies: &bodies,
            };
            if let Some(dt) = c.stable_dt(&ctx) {
                if dt < best.0 {
                    best = (dt, format!("contact({})", c.model()));
                }
            }
        }
        if remaining < best.0 * (1.0 + 1e-9) {
            best = (remaining, "end".into());
        }
        best
    }

    /// Advances one step.
    pub fn step(&mut self) -> Result<StepDiagnostics> {
        let (dt, limit) = self.choose_dt();
        self.step_with(dt, limit)
    }

    /// Advances one step of the given Δt.
    pub fn step_with(&mut self, dt: Real, dt_limit: String) -> Result<StepDiagnostics> {
        if self.alone {
            return self.step_alone(dt, dt_limit);
        }
        self.particles_to_grid(dt)?;
        let volume_fraction_error = self.volume_fractions();
        self.carry_immersed_forces();
        self.predictor(dt)?;
        self.exchange(dt);
        self.contact_forces();
        self.immersed_boundaries(dt)?;
        let (iterations, residual) = self.pressure_projection(dt)?;
        let max_divergence = self.max_divergence(dt);
        self.grid_to_particles(dt)?;
        self.advection(dt)?;
        self.time += dt;
        self.steps += 1;
        let momentum = self.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
        self.last = StepDiagnostics {
            step: self.steps,
            time: self.time,
            dt,
            dt_limit,
            kinetic_energy: self.kinetic_energy(),
            momentum,
            mass: self.fields.iter().map(|f| f.frame.mass()).sum(),
            max_speed: self.max_speed(),
            max_divergence,
            volume_fraction_error,
            pressure_iterations: iterations,
            pressure_residual: residual,
        };
        Ok(self.last.clone())
    }

    /// A step of the only field, which steps alone: none of the multifield phases (volume
    /// fractions, exchange, pressure, contact) has anything to do. Σθ is not computed:
    /// `volume_fraction_error` is NaN.
    fn step_alone(&mut self, dt: Real, dt_limit: String) -> Result<StepDiagnostics> {
        let mut figures = FrameFigures::default();
        self.frame_phase(dt, "step", |fr, ctx| {
            figures = fr.step_alone(ctx)?;
            Ok(())
        })?;
        self.grid_state_stale = true;
        self.time += dt;
        self.steps += 1;
        self.last = StepDiagnostics {
            step: self.steps,
            time: self.time,
            dt,
            dt_limit,
            kinetic_energy: figures.kinetic_energy,
            momentum: figures.momentum,
            mass: figures.mass,
            max_speed: figures.max_speed,
            max_divergence: 0.0,
            volume_fraction_error: Real::NAN,
            pressure_iterations: 0,
            pressure_residual: 0.0,
        };
        Ok(self.last.clone())
    }

    /// Whether the fields' grid state is older than their frames' state (after a step of a
    /// field that steps alone, or a restart of one). Whatever reads the grid state (output
    /// writers, [`Simulation::save_state`]) should [`Simulation::refresh_grid_state`] first;
    /// the runner does.
    pub fn grid_state_stale(&self) -> bool {
        self.grid_state_stale
    }

    /// Brings the fields' grid state (θ, face masses and velocities) up to their frames'
    /// state when it is stale ([`Frame::refresh_grid_state`]); output writers read it.
    /// Changes nothing the next steps depend on.
    pub fn refresh_grid_state(&mut self) -> Result<()> {
        if self.grid_state_stale {
            self.frame_phase(0.0, "grid state for output", |fr, ctx| fr.refresh_grid_state(ctx))?;
            self.grid_state_stale = false;
        }
        Ok(())
    }

    fn frame_phase(
        &mut self,
        dt: Real,
        phase: &str,
        f: impl FnMut(&mut dyn Frame, &mut FrameContext) -> Result<(), String>,
    ) -> Result<()> {
        self.frame_phase_of(dt, phase, |_| true, f)
    }

    /// [`Simulation::frame_phase`] for the fields `k` with `include(k)`.
    fn frame_phase_of(
        &mut self,
        dt: Real,
        phase: &str,
        include: impl Fn(usize) -> bool,
        mut f: impl FnMut(&mut dyn Frame, &mut FrameContext) -> Result<(), String>,
    ) -> Result<()> {
        for k in 0..self.fields.len() {
            if !include(k) {
                continue;
            }
            let forced = self.forcings.iter().any(|p| p.bodies == k);
            // the field mutably, its drag partner (another field) immutably
            let (field, partner) = match &self.partners[k] {
                Some((p, law)) => {
                    let (field, other) = if *p > k {
                        let (lo, hi) = self.fields.split_at_mut(*p);
                        (&mut lo[k], &hi[0])
                    } else {
                        let (lo, hi) = self.fields.split_at_mut(k);
                        (&mut hi[0], &lo[*p])
                    };
                    (field, Some(Partner { state: &other.state, density: other.density, law }))
                }
                None => (&mut self.fields[k], None),
            };
            let mut ctx = FrameContext {
                grid: &self.grid,
                boundaries: &self.boundaries,
                dt,
                time: self.time,
                gravity: self.gravity,
                density: field.density,
                state: &mut field.state,
                stress: &field.stress,
                body_forces: &self.body_forces[k],
                forced_bodies: forced.then_some(&self.body_steps[k][..]),
                partner,
            };
            f(field.frame.as_mut(), &mut ctx)
                .map_err(|m| Error::Model(format!("{phase} of field `{}`: {m}", field.name)))?;
        }
        Ok(())
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

    /// Phase 1: every frame puts its state on the grid (but the bodies of a direct
    /// forcing, which take no room there).
    fn particles_to_grid(&mut self, dt: Real) -> Result<()> {
        let forced: Vec<usize> = self.forcings.iter().map(|p| p.bodies).collect();
        self.frame_phase_of(dt, "particles to grid", |k| !forced.contains(&k), |fr, ctx| fr.to_grid(ctx))
    }

    /// Phase 4b (after the exchange and the contact forces, before the pressure): every
    /// direct forcing moves its free bodies and forces its fluid towards the bodies' rigid
    /// motion on their surfaces ([`crate::immersed::couple`]).
    fn immersed_boundaries(&mut self, dt: Real) -> Result<()> {
        for k in 0..self.forcings.len() {
            let bodies = self.forced_bodies(k);
            let p = &mut self.forcings[k];
            let rho_f = self.fields[p.fluid].density;
            let name = self.fields[p.bodies].name.clone();
            let fluid = &mut self.fields[p.fluid].state;
            let steps = crate::immersed::couple(
                &self.grid,
                &self.boundaries,
                p.forcing.sweeps,
                p.forcing.retraction,
                dt,
                self.gravity,
                rho_f,
                fluid,
                &bodies,
                &mut p.lag,
                self.steps > 0,
            )
            .map_err(|m| Error::Model(format!("immersed boundaries of field `{name}`: {m}")))?;
            self.boundaries.enforce(&self.grid, &mut fluid.velocity);
            self.body_steps[p.bodies] = steps;
        }
        Ok(())
    }

    /// Phase 2b (before the predictors): every direct forcing's fluid takes the last
    /// step's marker forces spread from where its bodies' markers stand now
    /// ([`crate::immersed::spread_lagged`]), the lagged force its predictor sees.
    fn carry_immersed_forces(&mut self) {
        for k in 0..self.forcings.len() {
            let bodies = self.forced_bodies(k);
            let p = &self.forcings[k];
            let fluid = &mut self.fields[p.fluid].state;
            let (grid, bc) = (&self.grid, &self.boundaries);
            crate::immersed::spread_lagged(grid, bc, p.forcing.retraction, &bodies, &p.lag, &mut fluid.body_force);
        }
    }

    /// The bodies of direct forcing `k` as they stand now.
    fn forced_bodies(&self, k: usize) -> Vec<crate::immersed::ForcedBody> {
        let p = &self.forcings[k];
        let Region::Bodies(specs) = &self.case.fields[p.bodies].region else {
            return Vec::new();
        };
        let states = self.fields[p.bodies].frame.bodies();
        specs
            .iter()
            .zip(&states)
            .enumerate()
            .map(|(j, (spec, state))| crate::immersed::ForcedBody {
                shape: spec.shape.clone(),
                // a fixed body's centre is its shape's (the points' centroid carries the
                // round-off of its masses); a moving disk's is its centroid
                center: match (&spec.shape, spec.motion) {
                    (BodyShape::Annulus { center, .. } | BodyShape::Disk { center, .. }, Motion::Fixed)
                    | (BodyShape::Annulus { center, .. }, _) => vector(*center),
                    _ => state.position,
                },
                motion: spec.motion,
                velocity: state.velocity,
                angular_velocity: state.angular_velocity,
                density: self.fields[p.bodies].density,
                contact: self.body_forces[p.bodies].get(j).copied().unwrap_or((Vector::zeros(), 0.0)),
            })
            .collect()
    }

    /// Phase 2: volume fractions; the field of region `Rest` takes what the others leave.
    /// Returns max |Σθ − 1|.
    fn volume_fractions(&mut self) -> Real {
        let n = self.grid.n_cells();
        let mut others = vec![0.0; n];
        for f in self.fields.iter().filter(|f| !f.fills_rest) {
            for (o, t) in others.iter_mut().zip(&f.state.theta) {
                *o += t;
            }
        }
        let (px, py) = (self.boundaries.periodic_x(), self.boundaries.periodic_y());
        let area = self.grid.cell_area();
        for f in &mut self.fields {
            if f.fills_rest {
                for (t, o) in f.state.theta.iter_mut().zip(&others) {
                    *t = (1.0 - o).max(0.0);
                }
            }
            f.state.update_face_fractions(&self.grid, px, py);
            // An Eulerian field's face mass follows from θ; a Lagrangian field keeps the
            // mass its points put there, so that momentum is conserved between frames.
            if !f.frame.is_lagrangian() {
                let s = &mut f.state;
                for (m, t) in s.mass_u.iter_mut().zip(&s.theta_u) {
                    *m = t * f.density * area;
                }
                for (m, t) in s.mass_v.iter_mut().zip(&s.theta_v) {
                    *m = t * f.density * area;
                }
            }
        }
        let mut err: Real = 0.0;
        for c in 0..n {
            let s: Real = self.fields.iter().map(|f| f.state.theta[c]).sum();
            err = err.max((s - 1.0).abs());
        }
        err
    }

    /// Phase 3: frame predictors (advection and grid stresses, in each frame's own time
    /// discretisation), then gravity.
    fn predictor(&mut self, dt: Real) -> Result<()> {
        self.frame_phase(dt, "predictor", |fr, ctx| fr.predict(ctx))?;
        let g = self.gravity;
        for f in &mut self.fields {
            let s = &mut f.state;
            // gravity after the stresses: a viscous stencil must not act on the gravity
            // increment Δt g, which the pressure cancels at rest (hydrostatic box with walls)
            s.velocity.u.iter_mut().for_each(|u| *u += dt * g.x);
            s.velocity.v.iter_mut().for_each(|v| *v += dt * g.y);
            self.boundaries.enforce(&self.grid, &mut s.velocity);
        }
        Ok(())
    }

    /// Phase 4: implicit (or explicit) momentum exchange on every face.
    fn exchange(&mut self, dt: Real) {
        if self.exchanges.is_empty() {
            // no coupling: velocities stay; each field's w = θ/(θρ⁰) for the pressure
            if self.pressure_solver.is_some() {
                self.uncoupled_specific_volumes();
            }
            return;
        }
        let n = self.fields.len();
        let area = self.grid.cell_area();
        for e in &mut self.exchanges {
            let [a, b] = e.fields;
            let ctx = ExchangeContext {
                grid: &self.grid,
                a: &self.fields[a].state,
                b: &self.fields[b].state,
                density: [self.fields[a].density, self.fields[b].density],
            };
            if e.model.no_slip() {
                e.kx.fill(Real::INFINITY);
                e.ky.fill(Real::INFINITY);
            } else {
                e.model.coefficients(&ctx, &mut e.kx, &mut e.ky);
            }
        }
        let densities: Vec<Real> = self.fields.iter().map(|f| f.density).collect();
        // added mass C_A ρ_f θ_s per face, between the fluid a and the particles b
        let added: Vec<([usize; 2], Real)> = self
            .exchanges
            .iter()
            .filter_map(|e| {
                let law = e.model.drag_law()?;
                (law.added_mass > 0.0).then(|| (e.fields, law.added_mass * densities[e.fields[0]]))
            })
            .collect();
        for lattice in 0..2 {
            let nf = if lattice == 0 { self.grid.n_xfaces() } else { self.grid.n_yfaces() };
            for face in 0..nf {
                let mut loc = Local {
                    n,
                    rho: [0.0; MAX_FIELDS],
                    rho_w: [0.0; MAX_FIELDS],
                    theta: [0.0; MAX_FIELDS],
                    material_density: [1.0; MAX_FIELDS],
                    u: [0.0; MAX_FIELDS],
                    u_old: [0.0; MAX_FIELDS],
                    w: [0.0; MAX_FIELDS],
                };
                for (k, f) in self.fields.iter().enumerate() {
                    let s = &f.state;
                    let (m, t, u, u0) = if lattice == 0 {
                        (s.mass_u[face], s.theta_u[face], s.velocity.u[face], s.velocity_old.u[face])
                    } else {
                        (s.mass_v[face], s.theta_v[face], s.velocity.v[face], s.velocity_old.v[face])
                    };
                    loc.rho[k] = m / area;
                    loc.rho_w[k] = t * densities[k];
                    loc.theta[k] = t;
                    loc.u[k] = u;
                    loc.u_old[k] = u0;
                    loc.material_density[k] = densities[k];
                }

                let mut implicit: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                let mut explicit: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                let mut any_explicit = false;
                for e in &self.exchanges {
                    let kk = if lattice == 0 { e.kx[face] } else { e.ky[face] };
                    let [a, b] = e.fields;
                    let target = if e.integration == Integration::Explicit && !kk.is_infinite() {
                        any_explicit = true;
                        &mut explicit
                    } else {
                        &mut implicit
                    };
                    target[a][b] = kk;
                    target[b][a] = kk;
                }
                if any_explicit {
                    exchange::explicit(&mut loc, &explicit, dt);
                }
                if added.is_empty() {
                    exchange::solve(&mut loc, &implicit, dt);
                } else {
                    let mut added_mass: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                    for ([a, b], c) in &added {
                        let am = c * loc.theta[*b];
                        added_mass[*a][*b] = am;
                        added_mass[*b][*a] = am;
                    }
                    exchange::solve_with_added_mass(&mut loc, &implicit, &added_mass, dt);
                }
                for (k, f) in self.fields.iter_mut().enumerate() {
                    let s = &mut f.state;
                    if lattice == 0 {
                        s.velocity.u[face] = loc.u[k];
                        s.specific_volume.u[face] = loc.w[k];
                    } else {
                        s.velocity.v[face] = loc.u[k];
                        s.specific_volume.v[face] = loc.w[k];
                    }
                }
            }
        }
    }

    /// The specific volumes of fields that exchange nothing: what [`exchange::solve`] gives
    /// without coupling, face by face, without building its local system.
    fn uncoupled_specific_volumes(&mut self) {
        let area = self.grid.cell_area();
        for f in &mut self.fields {
            let rho0 = f.density;
            let s = &mut f.state;
            for (w, m, t) in
                [(&mut s.specific_volume.u, &s.mass_u, &s.theta_u), (&mut s.specific_volume.v, &s.mass_v, &s.theta_v)]
            {
                for ((w, m), t) in w.iter_mut().zip(m.iter()).zip(t.iter()) {
                    let rho = m / area;
                    let rho_w = t * rho0;
                    *w = if rho > 1e-10 * rho0 {
                        if rho_w > 0.0 {
                            t / rho_w
                        } else {
                            t / rho
                        }
                    } else {
                        1.0 / rho0
                    };
                }
            }
        }
    }

    /// −β(Σθ − 1)/Δt + ∇·(Σθu) per cell: the constraint residual.
    fn constraint(&self, dt: Real) -> Vec<Real> {
        constraint_of(&self.grid, &self.fields, self.case.coupling.volume_fraction_relaxation, dt)
    }

    /// Phases 5–6: the pressure equation and the corrector. Returns (iterations, residual).
    fn pressure_projection(&mut self, dt: Real) -> Result<(usize, Real)> {
        let Some(solver) = self.pressure_solver.as_mut() else {
            return Ok((0, 0.0));
        };
        let g = &self.grid;
        let bc = &self.boundaries;
        let mut cx = vec![0.0; g.n_xfaces()];
        let mut cy = vec![0.0; g.n_yfaces()];
        for f in &self.fields {
            let s = &f.state;
            for (c, (t, w)) in cx.iter_mut().zip(s.theta_u.iter().zip(&s.specific_volume.u)) {
                *c += dt * t * w;
            }
            for (c, (t, w)) in cy.iter_mut().zip(s.theta_v.iter().zip(&s.specific_volume.v)) {
                *c += dt * t * w;
            }
        }
        for j in 0..g.ny {
            for i in [0, g.nx] {
                if bc.xface_fixed(g, i) {
                    cx[g.xface(i, j)] = 0.0;
                }
            }
        }
        for j in [0, g.ny] {
            if bc.yface_fixed(g, j) {
                for i in 0..g.nx {
                    cy[g.yface(i, j)] = 0.0;
                }
            }
        }
        let residual = constraint_of(g, &self.fields, self.case.coupling.volume_fraction_relaxation, dt);
        let rhs: Vec<Real> = residual.iter().map(|r| -r).collect();
        let problem = PoissonProblem::new(g, bc, cx, cy, rhs);
        let stats = solver.solve(&problem, &mut self.pressure)?;
        problem.fix_constant(&mut self.pressure);
        // corrector: u_k = ū_k − Δt w_k ∇p
        let p = &self.pressure;
        let (nx, ny) = (g.nx, g.ny);
        let outflow = |side| match bc.side(side) {
            crate::boundary::Boundary::Outflow { pressure } => Some(pressure),
            _ => None,
        };
        let (pl, pr, pb, pt) = (
            outflow(crate::boundary::Side::Left),
            outflow(crate::boundary::Side::Right),
            outflow(crate::boundary::Side::Bottom),
            outflow(crate::boundary::Side::Top),
        );
        let mut gx = vec![0.0; g.n_xfaces()];
        let mut gy = vec![0.0; g.n_yfaces()];
        for j in 0..ny {
            for i in 0..=nx {
                let grad = if i > 0 && i < nx {
                    (p[g.cell(i, j)] - p[g.cell(i - 1, j)]) / g.h
                } else if bc.periodic_x() {
                    (p[g.cell(0, j)] - p[g.cell(nx - 1, j)]) / g.h
                } else if i == 0 {
                    pl.map_or(0.0, |pd| 2.0 * (p[g.cell(0, j)] - pd) / g.h)
                } else {
                    pr.map_or(0.0, |pd| 2.0 * (pd - p[g.cell(nx - 1, j)]) / g.h)
                };
                gx[g.xface(i, j)] = grad;
            }
        }
        for j in 0..=ny {
            for i in 0..nx {
                let grad = if j > 0 && j < ny {
                    (p[g.cell(i, j)] - p[g.cell(i, j - 1)]) / g.h
                } else if bc.periodic_y() {
                    (p[g.cell(i, 0)] - p[g.cell(i, ny - 1)]) / g.h
                } else if j == 0 {
                    pb.map_or(0.0, |pd| 2.0 * (p[g.cell(i, 0)] - pd) / g.h)
                } else {
                    pt.map_or(0.0, |pd| 2.0 * (pd - p[g.cell(i, ny - 1)]) / g.h)
                };
                gy[g.yface(i, j)] = grad;
            }
        }
        for f in &mut self.fields {
            let s = &mut f.state;
            for (k, g) in gx.iter().enumerate() {
                let a = -s.specific_volume.u[k] * g;
                s.pressure_acceleration.u[k] = a;
                s.velocity.u[k] += dt * a;
            }
            for (k, g) in gy.iter().enumerate() {
                let a = -s.specific_volume.v[k] * g;
                s.pressure_acceleration.v[k] = a;
                s.velocity.v[k] += dt * a;
            }
            bc.enforce(g, &mut s.velocity);
        }
        Ok((stats.iterations, stats.residual))
    }

    fn max_divergence(&self, dt: Real) -> Real {
        if self.pressure_solver.is_none() {
            return 0.0;
        }
        let mut c = self.constraint(dt);
        // With no outflow side the pressure equation is pure Neumann: the mean of the
        // constraint (net inflow, and the mean Σθ drift term, which no pressure can change)
        // is projected out before the solve, so it is not the solver's error.
        let closed = !crate::boundary::Side::ALL
            .iter()
            .any(|s| matches!(self.boundaries.side(*s), crate::boundary::Boundary::Outflow { .. }));
        if closed && !c.is_empty() {
            let mean = c.iter().sum::<Real>() / c.len() as Real;
            c.iter_mut().for_each(|x| *x -= mean);
        }
        c.iter().fold(0.0, |m, x| m.max(x.abs()))
    }

    /// Phase 8a (bodies, right after the exchange): contact forces from the positions at
    /// the start of the step; the frames apply them with the rigid projection in
    /// grid-to-particles (8b).
    fn contact_forces(&mut self) {
        let Some(c) = &self.contact else {
            return;
        };
        let per_field: Vec<Vec<BodyState>> = self.fields.iter().map(|f| f.frame.bodies()).collect();
        let all: Vec<BodyState> = per_field.iter().flatten().cloned().collect();
        if all.is_empty() {
            return;
        }
        let mut out = vec![(Vector::zeros(), 0.0); all.len()];
        let ctx = ContactContext {
            grid: &self.grid,
            boundaries: &self.boundaries,
            gravity: self.gravity,
            fluid_density: self.fluid_density(),
            bodies: &all,
        };
        c.forces(&ctx, &mut out);
        let mut k = 0;
        for (f, bodies) in per_field.iter().enumerate() {
            self.body_forces[f] = out[k..k + bodies.len()].to_vec();
            k += bodies.len();
        }
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
        let periodic = [self.boundaries.periodic_x(), self.boundaries.periodic_y()];
        let mut out = Vec::new();
        for (k, f) in self.fields.iter().enumerate() {
            let n = f.frame.bodies().len();
            let forcing = self.forcings.iter().position(|p| p.bodies == k);
            match forcing.filter(|_| self.pressure_solver.is_some()) {
                Some(i) => {
                    let retraction = self.forcings[i].forcing.retraction;
                    let bodies = self.forced_bodies(i);
                    out.extend((0..n).map(|j| match bodies.get(j).map(|b| (&b.shape, b.center)) {
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
                None => out.extend(std::iter::repeat_n(None, n)),
            }
        }
        out
    }

    /// Phase 7: every frame takes the corrected grid velocity back.
    fn grid_to_particles(&mut self, dt: Real) -> Result<()> {
        self.frame_phase(dt, "grid to particles", |fr, ctx| fr.from_grid(ctx))
    }

    /// Phase 9: Eulerian transport of volume fractions.
    fn advection(&mut self, dt: Real) -> Result<()> {
        self.frame_phase(dt, "advection", |fr, ctx| fr.advect(ctx))
    }
}

/// Volume flux Σθu on x-faces and y-faces.
fn mixture_flux(grid: &Grid, fields: &[Field]) -> (Vec<Real>, Vec<Real>) {
    let mut fx = vec![0.0; grid.n_xfaces()];
    let mut fy = vec![0.0; grid.n_yfaces()];
    for f in fields {
        let s = &f.state;
        for (o, (t, u)) in fx.iter_mut().zip(s.theta_u.iter().zip(&s.velocity.u)) {
            *o += t * u;
        }
        for (o, (t, v)) in fy.iter_mut().zip(s.theta_v.iter().zip(&s.velocity.v)) {
            *o += t * v;
        }
    }
    (fx, fy)
}

/// ∇·(Σθu) − β(Σθ − 1)/Δt per cell: the residual of the constraint the pressure enforces.
pub fn constraint_of(g: &Grid, fields: &[Field], beta: Real, dt: Real) -> Vec<Real> {
    let (fx, fy) = mixture_flux(g, fields);
    let mut out = vec![0.0; g.n_cells()];
    for j in 0..g.ny {
        for i in 0..g.nx {
            let div = (fx[g.xface(i + 1, j)] - fx[g.xface(i, j)] + fy[g.yface(i, j + 1)] - fy[g.yface(i, j)]) / g.h;
            let c = g.cell(i, j);
            let sum: Real = fields.iter().map(|f| f.state.theta[c]).sum();
            out[c] = div - beta * (sum - 1.0) / dt;
        }
    }
    out
}

/// A field that steps alone ([`Frame::steps_alone`]) must be the case's only one, with no
/// pressure solve, exchange or contact, and no stress model that acts on the grid.
fn check_alone(case: &Case, fields: &[Field], pressure: bool) -> Result<()> {
    let field = fields.iter().find(|f| f.frame.steps_alone()).expect("a field steps alone");
    let path = format!("fields.{}.frame", field.name);
    let fix = "or give the field its coupled grid (for the Lagrangian frame, grid: \"staggered\")";
    let why = |what: String| {
        Error::invalid(path.clone(), format!("this frame steps alone (grid \"collocated\"), {what}; {fix}"))
    };
    if fields.len() > 1 {
        let others: Vec<&str> = fields.iter().filter(|f| f.name != field.name).map(|f| f.name.as_str()).collect();
        return Err(why(format!(
            "but the case has other fields ({}): remove them",
            others.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
        )));
    }
    if pressure {
        return Err(why("but the case has a pressure solve: set `pressure: None`".into()));
    }
    if !case.exchange.is_empty() {
        return Err(why("but the case has exchanges: remove them".into()));
    }
    if case.contact.is_some() {
        return Err(why("but the case has a contact model: set `contact: None`".into()));
    }
    if let Some(m) = field.stress.iter().find(|m| m.kind().is_rigid()) {
        return Err(why(format!(
            "but its stress `{}` makes bodies rigid, and a field on this grid has none: remove it",
            m.model()
        )));
    }
    if let Some(m) = field.stress.iter().find(|m| m.kind().acts_on_grid()) {
        return Err(why(format!(
            "but its stress `{}` acts on the staggered grid: use a point stress (e.g. weakly_compressible)",
            m.model()
        )));
    }
    Ok(())
}

/// A direct forcing couples an Eulerian fluid (first) with a Lagrangian field of rigid disks
/// or annuli (second), which no other exchange or forcing names.
fn check_forcing(case: &Case, fields: &[Field], k: usize, fa: usize, fb: usize) -> Result<()> {
    let path = format!("exchange.{k}");
    let (a, b) = (&fields[fa], &fields[fb]);
    let model = &case.exchange[k].model;
    if a.frame.is_lagrangian() {
        return Err(Error::invalid(
            format!("{path}.between"),
            format!(
                "`{model}` forces a fluid on a grid towards its bodies' motion: its first field must be Eulerian, \
                 and `{}` is Lagrangian; name the Eulerian fluid first and the bodies second",
                a.name
            ),
        ));
    }
    let Region::Bodies(specs) = &case.fields[fb].region else {
        return Err(Error::invalid(
            format!("{path}.between"),
            format!(
                "`{model}` acts on the surfaces of bodies: its second field (`{}`) must be a Lagrangian field of \
                 `region: Bodies([...])`",
                b.name
            ),
        ));
    };
    if !b.frame.is_lagrangian() || !b.stress.iter().any(|m| m.kind().is_rigid()) {
        return Err(Error::invalid(
            format!("fields.{}.stress", b.name),
            format!(
                "`{model}` moves bodies rigidly: give field `{}` a Lagrangian frame and `stress: [(model: \"rigid\")]`",
                b.name
            ),
        ));
    }
    for spec in specs {
        let bp = format!("fields.{}.region.{}", b.name, spec.name);
        match (&spec.shape, spec.motion) {
            (BodyShape::Rectangle { .. }, _) => {
                return Err(Error::invalid(
                    bp,
                    format!("`{model}` places its markers on circles: a rectangle is not supported; use a Disk or an Annulus, or `no_slip`"),
                ))
            }
            (BodyShape::Annulus { .. }, Motion::Free) => {
                return Err(Error::invalid(
                    format!("{bp}.motion"),
                    "an annulus holds a flow: make it `Fixed` or `Prescribed` with a rotation about its centre",
                ))
            }
            (BodyShape::Annulus { .. }, Motion::Prescribed { velocity, .. }) if velocity != [0.0, 0.0] => {
                return Err(Error::invalid(
                    format!("{bp}.motion"),
                    "an annulus may rotate about its centre but not translate: set `velocity: (0, 0)`",
                ))
            }
            _ => {}
        }
    }
    let others: Vec<usize> = case
        .exchange
        .iter()
        .enumerate()
        .filter(|(j, e)| *j != k && e.between.iter().any(|n| n == &b.name))
        .map(|(j, _)| j)
        .collect();
    if let Some(j) = others.first() {
        return Err(Error::invalid(
            format!("exchange.{j}"),
            format!(
                "field `{}` is moved by the direct forcing of exchange {k}, which owns its coupling: remove this entry",
                b.name
            ),
        ));
    }
    Ok(())
}

fn case_index(fields: &[Field], name: &str) -> usize {
    fields.iter().position(|f| f.name == name).expect("validated: exchange names exist")
}

/// Name of the frame of fields with `representation: MassPoint`.
pub const MASS_POINT_FRAME: &str = "mass_point";

/// Volume fraction of a list of disks spread exactly (disk ∩ cell areas), as the
/// `mass_point` frame spreads it.
fn mass_point_fraction(region: &Region, grid: &Grid, periodic: [bool; 2]) -> Vec<Real> {
    let mut theta = vec![0.0; grid.n_cells()];
    if let Region::Bodies(bodies) = region {
        let mut cells = Vec::new();
        for b in bodies {
            if let BodyShape::Disk { center, radius } = b.shape {
                cells.clear();
                crate::geometry::disk_cell_fractions(grid, center, radius, periodic, &mut cells);
                for (c, t) in &cells {
                    theta[*c] += t;
                }
            }
        }
    }
    theta
}

/// The parameters of the drag law of mass points: a registered `diameter` defaults to the
/// bodies' (when they all have one), a `viscosity` to the fluid's `newtonian` viscosity.
fn point_drag_params(
    spec: &PluginSpec,
    fluid: &crate::case::FieldSpec,
    points: &crate::case::FieldSpec,
    path: &str,
) -> Result<serde_json::Value> {
    let entry = registry::find(registry::Role::Exchange, &spec.model, path)?;
    let mut params = match &spec.params {
        serde_json::Value::Object(m) => m.clone(),
        serde_json::Value::Null => Default::default(),
        other => {
            return Err(Error::invalid(format!("{path}.params"), format!("{other}: expected a map of parameters")))
        }
    };
    let has = |name: &str| entry.params.iter().any(|p| p.name == name);
    if has("diameter") && !params.contains_key("diameter") {
        let mut diameters = Vec::new();
        if let Region::Bodies(bodies) = &points.region {
            for b in bodies {
                if let BodyShape::Disk { radius, .. } = b.shape {
                    diameters.push(2.0 * radius);
                }
            }
        }
        if let Some(&d) = diameters.first() {
            if diameters.iter().all(|x| (x - d).abs() <= 1e-12 * d) {
                params.insert("diameter".into(), serde_json::json!(d));
            }
        }
    }
    if has("viscosity") && !params.contains_key("viscosity") {
        // the fluid's Newtonian viscosity, whichever model gives it (its kind says so)
        let mu = fluid.stress.iter().find_map(|s| {
            registry::build_stress(&s.model, &s.params, path).ok().and_then(|m| m.kind().newtonian_viscosity())
        });
        if let Some(mu) = mu {
            params.insert("viscosity".into(), serde_json::json!(mu));
        }
    }
    Ok(serde_json::Value::Object(params))
}

/// Every body of a mass-point field must have the drag law's diameter.
fn check_point_diameters(law: &DragLaw, points: &crate::case::FieldSpec, path: &str) -> Result<()> {
    if let Region::Bodies(bodies) = &points.region {
        for b in bodies {
            if let BodyShape::Disk { radius, .. } = b.shape {
                let d = 2.0 * radius;
                if (d - law.diameter).abs() > 1e-9 * d {
                    return Err(Error::invalid(
                        format!("{path}.params.diameter"),
                        format!(
                            "{}: body `{}` of field `{}` has diameter {d}; a drag law has one diameter, so \
                             give `diameter: {d}` (or leave it out to take the bodies'), or put bodies of \
                             another size in a field of their own",
                            law.diameter, b.name, points.name
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}
