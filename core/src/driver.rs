//! The run loop: a [`Driver`] advances a [`Simulation`] to `time.end` with the output
//! [`Writer`]s and the [`StopCheck`]s it holds, and reports how the run ended.
//!
//! After every step the driver
//! 1. updates the run's totals ([`RunState`]: largest divergence and |Σθ − 1|, pressure
//!    iterations, smallest Δt);
//! 2. asks every stop check whether the solution blew up (the first to answer stops the
//!    run as [`Status::Unstable`] after this step's output);
//! 3. decides whether a row of the tables is due (every `output.interval` of simulated
//!    time, every step when it is 0, and always the run's last step);
//! 4. samples the case's monitors and evaluates its stop conditions ([`crate::monitor`];
//!    the first met makes this step the last, and the run completed with its reason);
//! 5. brings the fields' grid state up to date if a writer needs it, and calls every
//!    writer in the order they were added;
//! 6. calls the progress callback.
//!
//! The run ends at `time.end` (the last step shortened to land on it), at `time.max_steps`
//! (completed, with the reason), when a check fires (unstable), when Δt falls below
//! `time.min_dt` (unstable), when a step fails or a model panics (failed), or when the
//! flag of [`Driver::stop_on`] is set, by a signal handler (interrupted, after the step). The writers
//! are then finished ([`Writer::finish`]): the tables get the last step's row if it was
//! not a regular one, a checkpoint closes a completed run.
//!
//! A library user runs a case in a few lines:
//!
//! ```no_run
//! # fn main() -> multifield_core::error::Result<()> {
//! use multifield_core::case::Case;
//! use multifield_core::driver::{DiagnosticsCsv, Driver};
//! use multifield_core::simulation::Simulation;
//! let case = Case::load(std::path::Path::new("examples/lid_driven_cavity.ron"), &[])?;
//! let mut driver = Driver::new(Simulation::new(&case)?);
//! driver.add_writer(DiagnosticsCsv::create("out/diagnostics.csv".into())?);
//! let end = driver.run()?;
//! println!("{}: {} steps, t = {}", end.status.label(), driver.sim.steps, driver.sim.time);
//! # Ok(())
//! # }
//! ```
//!
//! (plugins must be linked first: `multifield::link_all()` in the application crate.)

use crate::boundary::{Boundary, Side};
use crate::case::{BodyShape, Region};
use crate::error::{Error, Result};
use crate::math::Real;
use crate::monitor::Monitors;
use crate::neighbours::{pairs_within, SearchDomain, VerletPairs};
use crate::plugin::BodyState;
use crate::simulation::{Simulation, Status, StepDiagnostics};
use crate::table::{self, Table};
use std::collections::HashSet;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Mechanical energy (kinetic + strain) above this multiple of the reference energy
/// ([`reference_energy`]) is a blow-up.
pub const ENERGY_GROWTH: Real = 1e6;

/// Mechanical energy that falls by more than this factor in one step has collapsed
/// ([`EnergyCollapse`]).
pub const ENERGY_COLLAPSE: Real = 1e6;

/// Bodies closer than this fraction of the sum of their radii (or of the radius to a wall)
/// overlap: the run stops as unstable ([`body_overlap`]).
pub const OVERLAP_FRACTION: Real = 0.5;

/// The run's totals and the schedule of its table rows, as a checkpoint carries them.
#[derive(Clone, Debug)]
pub struct RunState {
    /// Kinetic energy after the last step (the initial one before any).
    pub final_kinetic_energy: Real,
    /// Largest constraint residual max |∇·(Σθu) − β(Σθ−1)/Δt| so far.
    pub max_divergence: Real,
    /// Largest max |Σθ − 1| so far (NaN when a field steps alone and Σθ is not computed).
    pub max_volume_fraction_error: Real,
    /// Pressure iterations so far.
    pub pressure_iterations_total: u64,
    /// Smallest Δt so far (infinite before the first step).
    pub min_dt: Real,
    /// What limited the last step.
    pub last_dt_limit: String,
    /// Simulated time of the next regular table row (`output.interval`).
    pub next_row: Real,
    /// Whether the last step had a regular row (not only the one every run writes for its
    /// last step).
    pub last_row_written: bool,
    /// Table rows so far.
    pub rows: u64,
}

impl RunState {
    /// The state of a run that starts now: the first row after one `output.interval`.
    pub fn new(sim: &Simulation) -> Self {
        Self {
            final_kinetic_energy: if sim.steps > 0 { sim.last.kinetic_energy } else { sim.initial_energy },
            max_divergence: 0.0,
            max_volume_fraction_error: 0.0,
            pressure_iterations_total: 0,
            min_dt: Real::INFINITY,
            last_dt_limit: String::new(),
            next_row: sim.case.output.interval,
            last_row_written: true,
            rows: 0,
        }
    }

    fn add(&mut self, d: &StepDiagnostics) {
        self.final_kinetic_energy = d.kinetic_energy;
        self.max_divergence = self.max_divergence.max(d.max_divergence);
        // NaN where Σθ is not computed (a field that steps alone): `null` in summary.json
        self.max_volume_fraction_error = if d.volume_fraction_error.is_nan() {
            Real::NAN
        } else {
            self.max_volume_fraction_error.max(d.volume_fraction_error)
        };
        self.pressure_iterations_total += d.pressure_iterations as u64;
        self.min_dt = self.min_dt.min(d.dt);
        self.last_dt_limit = d.dt_limit.clone();
    }
}

/// What a writer sees after a step.
pub struct Step<'a> {
    /// The simulation after the step.
    pub sim: &'a Simulation,
    /// The step's diagnostics.
    pub diagnostics: &'a StepDiagnostics,
    /// The run's final step, whatever ends it.
    pub last: bool,
    /// The run stops as unstable after this step.
    pub unstable: bool,
    /// A row of the tables is due (a regular one, or the unstable step's).
    pub row: bool,
    /// The totals and the rows' schedule after this step (this step's row counted).
    pub state: &'a RunState,
}

/// What a writer sees when the run has ended.
pub struct End<'a> {
    /// How the run ended.
    pub status: &'a Status,
    /// The last step needs its row: it was not a regular one (the run stopped between
    /// rows, or failed).
    pub row: bool,
    /// The totals and the rows' schedule after the last regular row (without the final
    /// row of `row`): a restart from a checkpoint written now continues from it.
    pub state: &'a RunState,
}

/// An output writer with its own schedule in simulated time.
pub trait Writer {
    /// The writer's name (`"diagnostics"`, `"bodies"`, `"snapshots"`, `"checkpoints"`, …).
    fn name(&self) -> &str;
    /// Whether [`Writer::start`] reads the fields' grid state (the driver brings it up to
    /// date first).
    fn needs_grid_state_at_start(&self) -> bool {
        false
    }
    /// Before the first step (t = 0, or the restart time).
    fn start(&mut self, _sim: &Simulation) -> Result<()> {
        Ok(())
    }
    /// Whether [`Writer::after_step`] will read the fields' grid state now: the driver
    /// then brings it up to date first ([`Simulation::refresh_grid_state`]).
    fn needs_grid_state(&self, _step: &Step) -> bool {
        false
    }
    /// After every step.
    fn after_step(&mut self, step: &Step) -> Result<()>;
    /// When the run has ended, before the driver returns.
    fn finish(&mut self, _sim: &mut Simulation, _end: &End) -> Result<()> {
        Ok(())
    }
    /// The last file this writer wrote, if it reports one (the last checkpoint).
    fn last_written(&self) -> Option<PathBuf> {
        None
    }
}

/// A check after every step that stops the run as unstable, with the reason.
pub trait StopCheck {
    /// The reason to stop after the step `d` of `sim`, if any.
    fn check(&mut self, sim: &Simulation, d: &StepDiagnostics) -> Option<String>;
}

/// The kinetic energy and the largest speed are finite.
pub struct FiniteSolution;

impl StopCheck for FiniteSolution {
    fn check(&mut self, sim: &Simulation, d: &StepDiagnostics) -> Option<String> {
        let strain = !sim.steps_alone() && !d.strain_energy.is_finite();
        (!d.kinetic_energy.is_finite() || !d.max_speed.is_finite() || strain).then(|| {
            format!(
                "non-finite solution at step {}, t = {}: kinetic energy {}, strain energy {}, largest speed {}",
                d.step, d.time, d.kinetic_energy, d.strain_energy, d.max_speed
            )
        })
    }
}

/// The mechanical energy (kinetic + strain) stays below a bound ([`ENERGY_GROWTH`] ×
/// [`reference_energy`] by default).
pub struct EnergyBound(pub Real);

impl StopCheck for EnergyBound {
    fn check(&mut self, sim: &Simulation, d: &StepDiagnostics) -> Option<String> {
        let bound = self.0;
        let energy = mechanical_energy(sim, d);
        (energy > bound).then(|| {
            format!(
                "mechanical energy {energy:e} (kinetic {:e}, strain {:e}) at step {}, t = {} exceeds the bound \
                 {bound:e} ({ENERGY_GROWTH:e} × the reference energy; see `multifield::run`): reduce time.cfl or \
                 time.fixed_dt",
                d.kinetic_energy, d.strain_energy, d.step, d.time
            )
        })
    }
}

/// The mechanical energy (kinetic + strain) does not fall by more than [`ENERGY_COLLAPSE`]
/// in one step. No physical dissipation (viscosity, drag, PIC damping, inelastic contact)
/// removes all but a millionth of the energy within one stable step: a state that drops
/// to rest that fast was destroyed by a step far beyond its stability limit. Energies
/// below `floor` (round-off of a flow at rest) are not judged.
pub struct EnergyCollapse {
    /// The energy after the previous step.
    pub previous: Real,
    /// The smallest previous energy judged.
    pub floor: Real,
}

impl EnergyCollapse {
    /// The check of `sim` from its current state, judging energies above 10⁻¹² × the
    /// [`reference_energy`].
    pub fn of(sim: &Simulation) -> Self {
        let previous = if sim.steps > 0 { mechanical_energy(sim, &sim.last) } else { sim.initial_energy };
        Self { previous, floor: 1e-12 * reference_energy(sim) }
    }
}

impl StopCheck for EnergyCollapse {
    fn check(&mut self, sim: &Simulation, d: &StepDiagnostics) -> Option<String> {
        let (before, energy) = (self.previous, mechanical_energy(sim, d));
        self.previous = energy;
        (before > self.floor && energy * ENERGY_COLLAPSE < before).then(|| {
            format!(
                "mechanical energy (kinetic + strain) collapsed from {before:e} to {energy:e} in step {}, ending at \
                 t = {}: no dissipation removes more than all but 1/{ENERGY_COLLAPSE:e} of the energy in one stable \
                 step; the step (Δt = {:e}, limited by {}) destroyed the state: reduce time.cfl or time.fixed_dt",
                d.step, d.time, d.dt, d.dt_limit
            )
        })
    }
}

/// Kinetic + strain energy of the step `d` of `sim` (kinetic only where the only field
/// steps alone and computes no strain energy).
pub fn mechanical_energy(sim: &Simulation, d: &StepDiagnostics) -> Real {
    if sim.steps_alone() {
        d.kinetic_energy
    } else {
        d.kinetic_energy + d.strain_energy
    }
}

/// max |Σθ − 1| stays below `coupling.max_volume_fraction_error` (cases with a pressure
/// solver, which enforces Σθ = 1).
pub struct VolumeFractionDrift(pub Real);

impl StopCheck for VolumeFractionDrift {
    fn check(&mut self, _sim: &Simulation, d: &StepDiagnostics) -> Option<String> {
        let theta = self.0;
        (d.volume_fraction_error.is_nan() || d.volume_fraction_error > theta).then(|| {
            format!(
                "max |Σθ − 1| = {:.4e} at step {}, t = {} exceeds coupling.max_volume_fraction_error = {theta}: \
                 the fields no longer fill the space; reduce time.cfl, raise points_per_cell or \
                 coupling.volume_fraction_relaxation",
                d.volume_fraction_error, d.step, d.time
            )
        })
    }
}

/// max Σθ − 1 stays below `coupling.max_volume_fraction_error` (cases without a pressure
/// solver, where Σθ < 1 is empty space but Σθ far above 1 is material packed into a cell
/// beyond what it holds: points crowded by a step beyond the stability limit).
pub struct VolumeFractionPacking(pub Real);

impl StopCheck for VolumeFractionPacking {
    fn check(&mut self, _sim: &Simulation, d: &StepDiagnostics) -> Option<String> {
        let bound = self.0;
        (d.max_volume_fraction - 1.0 > bound).then(|| {
            format!(
                "max Σθ = {:.4e} at step {}, t = {}: a cell holds {:.3}× the material it has room for, and \
                 max Σθ − 1 exceeds coupling.max_volume_fraction_error = {bound}: the points crowded together (a \
                 step beyond the stability limit, or bodies passing through each other); reduce time.cfl or \
                 time.fixed_dt",
                d.max_volume_fraction, d.step, d.time, d.max_volume_fraction
            )
        })
    }
}

/// Disk bodies do not pass through each other or a wall ([`body_overlap`]). Which bodies
/// are disks is looked up by name once (a hash of every name each step cost a suspension
/// of 10,000 points about 1 % of its step), again only if the number of bodies changes.
/// The pairs come from a Verlet list kept from step to step (the same pairs as a fresh
/// search, [`VerletPairs`]; the bodies move a fraction of a radius per step).
pub struct BodyOverlap {
    /// The number of bodies and which of them are disks.
    disks: Option<(usize, Vec<bool>)>,
    /// The disks' pairs, reused while no disk has moved far.
    pairs: VerletPairs,
}

impl Default for BodyOverlap {
    fn default() -> Self {
        BodyOverlap { disks: None, pairs: VerletPairs::new(0.5) }
    }
}

impl StopCheck for BodyOverlap {
    fn check(&mut self, sim: &Simulation, _d: &StepDiagnostics) -> Option<String> {
        // the bodies of `Simulation::bodies` as the frames hold them (no name copied)
        let bodies: Vec<&BodyState> = sim.fields.iter().flat_map(|f| f.frame.body_states()).collect();
        let disks = match &self.disks {
            Some((n, mask)) if *n == bodies.len() => mask,
            _ => &self.disks.insert((bodies.len(), disk_mask(sim, &bodies))).1,
        };
        overlap_of(sim, bodies, disks, Some(&mut self.pairs))
    }
}

/// The checks every run makes (`multifield::run`'s module doc): a finite solution, the
/// energy bound and no energy collapse, Σθ (|Σθ − 1| in a case with a pressure solver,
/// Σθ − 1 without one), and disk bodies that do not overlap.
pub fn default_checks(sim: &Simulation) -> Vec<Box<dyn StopCheck>> {
    let mut checks: Vec<Box<dyn StopCheck>> = vec![
        Box::new(FiniteSolution),
        Box::new(EnergyBound(ENERGY_GROWTH * reference_energy(sim))),
        Box::new(EnergyCollapse::of(sim)),
    ];
    let bound = sim.case.coupling.max_volume_fraction_error;
    if sim.case.pressure.is_some() {
        checks.push(Box::new(VolumeFractionDrift(bound)));
    } else {
        checks.push(Box::new(VolumeFractionPacking(bound)));
    }
    let has_disks =
        sim.case.fields.iter().any(
            |f| matches!(&f.region, Region::Bodies(b) if b.iter().any(|b| matches!(b.shape, BodyShape::Disk { .. }))),
        );
    if has_disks {
        checks.push(Box::new(BodyOverlap::default()));
    }
    checks
}

/// Energy scale E_ref of the instability bound: max(E₀, ½ M |g| L, ½ M U_b², ½ M (L / t_end)²),
/// E₀ the initial kinetic energy, M the total mass, L the longest side of the domain, U_b the
/// fastest prescribed boundary velocity and t_end `time.end`. Each term is an energy the
/// case can reach physically (the start, a fall across the domain, the driving walls, a
/// flow crossing the domain once in the run); a million times the largest is a blow-up.
pub fn reference_energy(sim: &Simulation) -> Real {
    let case = &sim.case;
    let mass: Real = sim.fields.iter().map(|f| f.frame.mass()).sum();
    let length = case.domain.size.iter().fold(0.0, |m: Real, &s| m.max(s));
    // (a sum from −0.0 of the squares: the bits of g₀² + g₁² in 2D)
    let norm = |v: &[Real]| v.iter().map(|x| x.powi(2)).sum::<Real>().sqrt();
    let g = norm(&case.gravity);
    let wall = Side::ALL
        .iter()
        .map(|&s| match case.boundaries.side(s) {
            Boundary::Velocity { velocity, .. } => norm(&velocity),
            _ => 0.0,
        })
        .fold(0.0, Real::max);
    let crossing = length / case.time.end;
    [sim.initial_energy, 0.5 * mass * g * length, 0.5 * mass * wall * wall, 0.5 * mass * crossing * crossing]
        .into_iter()
        .fold(0.0, Real::max)
}

/// Why the bodies of `sim` overlap each other or a wall, if they do: two disk bodies (one
/// of them free) whose centres are closer than [`OVERLAP_FRACTION`] × the sum of their
/// radii (the minimum image across periodic sides), or a free disk body whose centre is
/// closer than [`OVERLAP_FRACTION`] × its radius to a wall (or outside the domain). Only
/// disk bodies (by their shape in the case) are checked, with the radius of the body's
/// state. The pairs come from the cell-list search ([`crate::neighbours::pairs_within`]):
/// O(N) in the number of bodies, where a double loop made a suspension of 10,000 mass
/// points spend most of each step here. Of several overlaps, the one reported is the
/// first in body order: body k's pairs with the bodies before it, then its walls.
pub fn body_overlap(sim: &Simulation) -> Option<String> {
    let bodies: Vec<&BodyState> = sim.fields.iter().flat_map(|f| f.frame.body_states()).collect();
    let disks = disk_mask(sim, &bodies);
    overlap_of(sim, bodies, &disks, None)
}

/// Which of `bodies` (the simulation's, in order) are disks by their shape in the case.
fn disk_mask(sim: &Simulation, bodies: &[&BodyState]) -> Vec<bool> {
    let disks: HashSet<&str> = sim
        .case
        .fields
        .iter()
        .flat_map(|f| match &f.region {
            Region::Bodies(b) => {
                b.iter().filter(|b| matches!(b.shape, BodyShape::Disk { .. })).map(|b| b.name.as_str()).collect()
            }
            _ => Vec::new(),
        })
        .collect();
    bodies.iter().map(|b| disks.contains(b.name.as_str())).collect()
}

/// [`body_overlap`] of `bodies` (the simulation's, in order), of which the disks are those
/// `disks` marks; the pairs from `list` when given (the same as a fresh search).
fn overlap_of(
    sim: &Simulation,
    bodies: Vec<&BodyState>,
    disks: &[bool],
    list: Option<&mut VerletPairs>,
) -> Option<String> {
    let case = &sim.case;
    if !disks.contains(&true) {
        return None;
    }
    let bodies: Vec<&BodyState> = bodies.into_iter().zip(disks).filter(|(_, d)| **d).map(|(b, _)| b).collect();
    let centres: Vec<_> = bodies.iter().map(|b| b.position).collect();
    let radii: Vec<Real> = bodies.iter().map(|b| b.radius).collect();
    let domain = SearchDomain::of(&case.domain, &case.boundaries);
    // the first overlapping pair by (higher index, lower index)
    let pairs = match list {
        Some(list) => list.pairs_within(&centres, &radii, 0.0, &domain),
        None => pairs_within(&centres, &radii, 0.0, &domain),
    };
    let pair = pairs
        .into_iter()
        .filter(|p| (bodies[p.i].free || bodies[p.j].free) && p.distance < OVERLAP_FRACTION * (radii[p.i] + radii[p.j]))
        .min_by_key(|p| (p.j, p.i));
    let (o, size) = (case.domain.origin, case.domain.size);
    // the first free body across a wall, with its side and gap
    let wall = bodies.iter().enumerate().filter(|(_, a)| a.free).find_map(|(k, a)| {
        [
            (Side::Left, a.position.x - o[0]),
            (Side::Right, o[0] + size[0] - a.position.x),
            (Side::Bottom, a.position.y - o[1]),
            (Side::Top, o[1] + size[1] - a.position.y),
        ]
        .into_iter()
        .filter(|(side, _)| !matches!(case.boundaries.side(*side), Boundary::Periodic))
        .find(|(_, gap)| gap.is_nan() || *gap < OVERLAP_FRACTION * a.radius)
        .map(|(side, gap)| (k, side, gap))
    });
    match (pair, wall) {
        (Some(p), w) if w.is_none_or(|(k, _, _)| p.j <= k) => {
            let (a, b) = (&bodies[p.j], &bodies[p.i]);
            let (d, contact) = (p.distance, radii[p.i] + radii[p.j]);
            Some(format!(
                "bodies `{}` and `{}` overlap at step {}, t = {}: centres {d:.4e} apart, below \
                 {OVERLAP_FRACTION} × the sum of the radii {contact:.4e}; strengthen the contact \
                 (contact.params) or reduce time.cfl",
                b.name, a.name, sim.steps, sim.time
            ))
        }
        (_, Some((k, side, gap))) => {
            let a = &bodies[k];
            Some(format!(
                "body `{}` crosses the {side:?} wall at step {}, t = {}: its centre is {gap:.4e} from the wall, \
                 below {OVERLAP_FRACTION} × its radius {:.4e}; add or strengthen the contact model or reduce time.cfl",
                a.name, sim.steps, sim.time, a.radius
            ))
        }
        _ => None,
    }
}

/// How a run ended.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Completed, unstable or failed, with the reason.
    pub status: Status,
    /// What bounded a completed run short of `time.end` (`time.max_steps`, or the stop
    /// condition that was met, with its figures), else empty.
    pub reason: String,
    /// Wall-clock time of the time loop, seconds.
    pub wall_seconds: f64,
}

/// The progress callback: the simulation after a step, and the steps per second of
/// wall-clock time since the driver started.
pub type Progress = Box<dyn FnMut(&Simulation, f64)>;

/// Advances a simulation to `time.end` with writers and stop checks.
pub struct Driver {
    /// The simulation it advances.
    pub sim: Simulation,
    /// The totals and the rows' schedule.
    pub state: RunState,
    writers: Vec<Box<dyn Writer>>,
    checks: Vec<Box<dyn StopCheck>>,
    progress: Option<Progress>,
    interrupt: Option<Arc<AtomicBool>>,
    monitors: Option<Monitors>,
}

impl Driver {
    /// A driver of `sim` with the [`default_checks`] and no writers, its rows' schedule
    /// starting now.
    pub fn new(sim: Simulation) -> Self {
        let state = RunState::new(&sim);
        Self::resume(sim, state)
    }

    /// A driver of `sim` that continues a run whose totals and rows' schedule were `state`
    /// (a restart).
    pub fn resume(sim: Simulation, state: RunState) -> Self {
        let checks = default_checks(&sim);
        Self { sim, state, writers: Vec::new(), checks, progress: None, interrupt: None, monitors: None }
    }

    /// Adds a writer, called after the ones added before it.
    pub fn add_writer(&mut self, writer: impl Writer + 'static) -> &mut Self {
        self.writers.push(Box::new(writer));
        self
    }

    /// Adds a boxed writer.
    pub fn add_boxed_writer(&mut self, writer: Box<dyn Writer>) -> &mut Self {
        self.writers.push(writer);
        self
    }

    /// Adds a stop check, asked after the ones before it.
    pub fn add_check(&mut self, check: impl StopCheck + 'static) -> &mut Self {
        self.checks.push(Box::new(check));
        self
    }

    /// Removes every stop check (the default ones too).
    pub fn clear_checks(&mut self) -> &mut Self {
        self.checks.clear();
        self
    }

    /// Stops the run as [`Status::Interrupted`] once `flag` is set (by a signal handler):
    /// after the step under way, which is then the run's last (its rows, snapshot and
    /// checkpoint written), or before the first step if it is set already.
    pub fn stop_on(&mut self, flag: Arc<AtomicBool>) -> &mut Self {
        self.interrupt = Some(flag);
        self
    }

    /// Samples `monitors` and evaluates their stop conditions after every step, before the
    /// writers ([`crate::monitor`]): a stop condition that is met makes the step the last.
    pub fn set_monitors(&mut self, monitors: Monitors) -> &mut Self {
        self.monitors = Some(monitors);
        self
    }

    /// The monitors, if set.
    pub fn monitors(&self) -> Option<&Monitors> {
        self.monitors.as_ref()
    }

    /// Calls `progress` after every step.
    pub fn on_progress(&mut self, progress: impl FnMut(&Simulation, f64) + 'static) -> &mut Self {
        self.progress = Some(Box::new(progress));
        self
    }

    /// The writer named `name`, if one was added.
    pub fn writer(&self, name: &str) -> Option<&dyn Writer> {
        self.writers.iter().find(|w| w.name() == name).map(|w| w.as_ref())
    }

    /// Runs to `time.end` (or until a stop), then finishes the writers. `Err` only when a
    /// writer fails (a file that cannot be written); instabilities and failed steps end in
    /// an [`Outcome`] that says so.
    pub fn run(&mut self) -> Result<Outcome> {
        let Self { sim, state, writers, checks, progress, interrupt, monitors } = self;
        // a signal reaches the ranks of a decomposed run at different times: they agree
        let part = sim.grid.part.clone();
        let interrupted = || part.any(interrupt.as_ref().is_some_and(|f| f.load(Ordering::SeqCst)));
        let stop = |sim: &Simulation| {
            Status::Interrupted(format!("interrupted by a signal after step {}, t = {}", sim.steps, sim.time))
        };
        if writers.iter().any(|w| w.needs_grid_state_at_start()) {
            sim.refresh_grid_state()?;
        }
        // the monitors first: a time average from t = 0 is in the first snapshot
        if let Some(m) = monitors.as_mut() {
            m.start(sim)?;
        }
        for w in writers.iter_mut() {
            w.start(sim)?;
        }
        let time = sim.case.time.clone();
        let interval = sim.case.output.interval;
        let start = Instant::now();
        let steps_at_start = sim.steps;
        let mut status = Status::Completed;
        let mut reason = String::new();
        let done = |t: Real| reached_end(t, time.end);
        while !done(sim.time) {
            if interrupted() {
                status = stop(sim);
                break;
            }
            if let Some(max) = time.max_steps {
                if sim.steps >= max {
                    reason = format!("stopped by time.max_steps = {max} at t = {} (time.end = {})", sim.time, time.end);
                    break;
                }
            }
            let (dt, limit) = sim.choose_dt();
            // a step shortened to land on time.end or on an output time may be short
            let last_step = dt >= (time.end - sim.time) * (1.0 - 1e-9);
            let landing = limit == crate::simulation::OUTPUT_TIME;
            if (dt < time.min_dt || dt.is_nan()) && !last_step && !landing {
                status = Status::Unstable(format!(
                    "Δt = {dt:e} (limited by {limit}) fell below time.min_dt = {:e} at step {}, t = {}",
                    time.min_dt,
                    sim.steps + 1,
                    sim.time
                ));
                break;
            }
            if sim.time + dt == sim.time {
                status = Status::Failed(format!(
                    "the clock stopped: t + Δt = t at step {}, t = {}, Δt = {dt:e} (limited by {limit}): Δt is below \
                     the resolution of t; shorten time.end",
                    sim.steps + 1,
                    sim.time
                ));
                break;
            }
            let stepped = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| sim.step_with(dt, limit)));
            let d = match stepped {
                Ok(Ok(d)) => d,
                Ok(Err(e)) => {
                    status = Status::Failed(format!("step {}, t = {}: {e}", sim.steps + 1, sim.time));
                    break;
                }
                Err(p) => {
                    status = Status::Failed(format!(
                        "step {}, t = {}: a model panicked: {}",
                        sim.steps + 1,
                        sim.time,
                        panic_message(p)
                    ));
                    break;
                }
            };
            state.add(&d);
            let unstable = checks.iter_mut().find_map(|c| c.check(sim, &d));
            let row = interval <= 0.0 || d.time >= state.next_row * (1.0 - 1e-9) || unstable.is_some() || done(d.time);
            if row {
                state.rows += 1;
                if interval > 0.0 {
                    state.next_row = schedule_past(state.next_row, d.time * (1.0 + 1e-9), interval);
                }
            }
            state.last_row_written = row;
            let signalled = interrupted();
            let mut last =
                unstable.is_some() || signalled || done(d.time) || time.max_steps.is_some_and(|m| sim.steps >= m);
            // the monitors sample this step before the stop conditions are evaluated on it
            let stopped = match monitors.as_mut() {
                Some(m) => m.after_step(sim, last, unstable.is_some())?,
                None => None,
            };
            if stopped.is_some() {
                last = true;
            }
            let needs_grid = {
                let step = Step { sim, diagnostics: &d, last, unstable: unstable.is_some(), row, state };
                writers.iter().any(|w| w.needs_grid_state(&step))
            };
            if needs_grid && sim.grid_state_stale() {
                sim.refresh_grid_state()?;
            }
            let step = Step { sim, diagnostics: &d, last, unstable: unstable.is_some(), row, state };
            for w in writers.iter_mut() {
                w.after_step(&step)?;
            }
            if let Some(reason) = unstable {
                status = Status::Unstable(reason);
                break;
            }
            if let Some(why) = stopped {
                reason = why;
                break;
            }
            if signalled {
                status = stop(sim);
                break;
            }
            if let Some(p) = progress.as_mut() {
                let rate = (sim.steps - steps_at_start) as f64 / start.elapsed().as_secs_f64().max(1e-9);
                p(sim, rate);
            }
        }
        let final_row = !state.last_row_written && sim.steps > 0;
        let before = state.clone();
        let end = End { status: &status, row: final_row, state: &before };
        for w in writers.iter_mut() {
            w.finish(sim, &end)?;
        }
        if final_row {
            state.rows += 1;
        }
        Ok(Outcome { status, reason, wall_seconds: start.elapsed().as_secs_f64() })
    }
}

pub(crate) fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "panic".into())
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so
/// that `path` is either the old file or the complete new one. A write that fails (a
/// full disk) removes its temporary file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path)).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}

/// A number as it round-trips, in plain notation for moderate magnitudes and in
/// scientific notation otherwise (`1.5e-16`, not 0.000000000000000150…).
pub fn number(x: Real) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The columns of `diagnostics.csv`, in order.
#[cfg(feature = "dim2")]
pub const CSV_HEADER: &str = "step,time,dt,dt_limit,kinetic_energy,momentum_x,momentum_y,mass,max_speed,\
max_divergence,volume_fraction_error,pressure_iterations,pressure_residual,strain_energy,max_volume_fraction";
/// The columns of `diagnostics.csv`, in order: the 2D ones, then `momentum_z`.
#[cfg(feature = "dim3")]
pub const CSV_HEADER: &str = "step,time,dt,dt_limit,kinetic_energy,momentum_x,momentum_y,mass,max_speed,\
max_divergence,volume_fraction_error,pressure_iterations,pressure_residual,strain_energy,max_volume_fraction,momentum_z";

/// Header of `bodies.csv` (one row per body per output time).
pub const BODIES_HEADER: &str =
    "step,time,body,x,y,vx,vy,omega,fx,fy,torque,fx_pressure,fy_pressure,fx_viscous,fy_viscous";

/// `diagnostics.csv`: a row of [`CSV_HEADER`] per table row of the run (and the last
/// step's), flushed row by row so that a killed run leaves a readable file.
pub struct DiagnosticsCsv {
    file: csv::Writer<File>,
    path: PathBuf,
}

impl DiagnosticsCsv {
    /// A new file at `path` (replaced if it exists), with its header.
    pub fn create(path: PathBuf) -> Result<Self> {
        let file = create_csv(&path, CSV_HEADER)?;
        Ok(Self { file, path })
    }

    /// Continues `path` after a restart ([`resume_csv`]).
    pub fn resume(path: PathBuf, source: Option<&Path>, keep: impl Fn(u64) -> bool) -> Result<Self> {
        let (file, _) = resume_csv(&path, source, CSV_HEADER, keep)?;
        Ok(Self { file, path })
    }

    fn write(&mut self, d: &StepDiagnostics) -> Result<()> {
        let x = number;
        let row = [
            d.step.to_string(),
            x(d.time),
            x(d.dt),
            d.dt_limit.clone(),
            x(d.kinetic_energy),
            x(d.momentum.x),
            x(d.momentum.y),
            x(d.mass),
            x(d.max_speed),
            x(d.max_divergence),
            x(d.volume_fraction_error),
            d.pressure_iterations.to_string(),
            x(d.pressure_residual),
            x(d.strain_energy),
            x(d.max_volume_fraction),
            #[cfg(feature = "dim3")]
            x(d.momentum.z),
        ];
        write_row(&mut self.file, &self.path, &row)?;
        flush(&mut self.file, &self.path)
    }
}

impl Writer for DiagnosticsCsv {
    fn name(&self) -> &str {
        "diagnostics"
    }
    fn after_step(&mut self, step: &Step) -> Result<()> {
        if step.row {
            self.write(step.diagnostics)?;
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, end: &End) -> Result<()> {
        if end.row {
            self.write(&sim.last)?;
        }
        Ok(())
    }
}

/// `bodies.csv`: centroid, velocity, angular velocity, hydrodynamic force and torque of
/// every body at every table row (and at the start of a new run), and the force's pressure
/// and viscous parts where the coupling gives them ([`Simulation::pressure_forces`]; empty
/// cells elsewhere), flushed row by row.
pub struct BodiesCsv {
    file: csv::Writer<File>,
    path: PathBuf,
    resumed: bool,
}

impl BodiesCsv {
    /// A new file at `path` (replaced if it exists), with its header; the bodies at the
    /// start are its first rows.
    pub fn create(path: PathBuf) -> Result<Self> {
        let file = create_csv(&path, BODIES_HEADER)?;
        Ok(Self { file, path, resumed: false })
    }

    /// Continues `path` after a restart ([`resume_csv`]).
    pub fn resume(path: PathBuf, source: Option<&Path>, keep: impl Fn(u64) -> bool) -> Result<Self> {
        let (file, _) = resume_csv(&path, source, BODIES_HEADER, keep)?;
        Ok(Self { file, path, resumed: true })
    }

    fn write(&mut self, sim: &Simulation) -> Result<()> {
        let x = number;
        let pressure = sim.pressure_forces();
        for ((_, b), p) in sim.bodies().into_iter().zip(pressure) {
            let mut row = vec![
                sim.steps.to_string(),
                x(sim.time),
                b.name.clone(),
                x(b.position.x),
                x(b.position.y),
                x(b.velocity.x),
                x(b.velocity.y),
                x(b.angular_velocity),
                x(b.force.x),
                x(b.force.y),
                x(b.torque),
            ];
            // the pressure and viscous parts where the coupling gives them, else empty
            match p {
                Some(p) => row.extend([x(p.x), x(p.y), x(b.force.x - p.x), x(b.force.y - p.y)]),
                None => row.extend(std::iter::repeat_n(String::new(), 4)),
            }
            write_row(&mut self.file, &self.path, &row)?;
        }
        flush(&mut self.file, &self.path)
    }
}

impl Writer for BodiesCsv {
    fn name(&self) -> &str {
        "bodies"
    }
    fn start(&mut self, sim: &Simulation) -> Result<()> {
        if !self.resumed {
            self.write(sim)?;
        }
        Ok(())
    }
    fn after_step(&mut self, step: &Step) -> Result<()> {
        if step.row {
            self.write(step.sim)?;
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, end: &End) -> Result<()> {
        if end.row {
            self.write(sim)?;
        }
        Ok(())
    }
}

pub(crate) fn csv_error(path: &Path, e: csv::Error) -> Error {
    match e.into_kind() {
        csv::ErrorKind::Io(source) => Error::Io { path: path.to_path_buf(), source },
        other => Error::Model(format!("{}: {other:?}", path.display())),
    }
}

fn write_row<S: AsRef<[u8]>>(file: &mut csv::Writer<File>, path: &Path, row: &[S]) -> Result<()> {
    file.write_record(row).map_err(|e| csv_error(path, e))
}

fn flush(file: &mut csv::Writer<File>, path: &Path) -> Result<()> {
    file.flush().map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// A CSV file open for writing, row by row.
pub type CsvWriter = csv::Writer<File>;

/// Writes `row` to the CSV file `path` and flushes it (a killed run keeps the row).
pub fn append_row<S: AsRef<[u8]>>(file: &mut csv::Writer<File>, path: &Path, row: &[S]) -> Result<()> {
    write_row(file, path, row)?;
    flush(file, path)
}

/// Creates the CSV file `path` with its `header` (comma-separated).
pub fn create_csv(path: &Path, header: &str) -> Result<csv::Writer<File>> {
    let mut file = table::writer(File::create(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?);
    write_row(&mut file, path, &header.split(',').collect::<Vec<_>>())?;
    flush(&mut file, path)?;
    Ok(file)
}

/// Continues the CSV file `path` after a restart: the header and the complete rows whose
/// step (first column) passes `keep`, taken from `source` (the same file in the
/// checkpoint's run directory) if it exists, else from `path` itself, are written to
/// `path` (atomically), which is then opened for appending. Returns it and the rows kept.
pub fn resume_csv(
    path: &Path,
    source: Option<&Path>,
    header: &str,
    keep: impl Fn(u64) -> bool,
) -> Result<(csv::Writer<File>, u64)> {
    let from = source.filter(|s| s.is_file()).unwrap_or(path);
    // complete rows only: a run killed while writing a row leaves part of it
    let rows: Vec<Vec<String>> = match Table::read(from)? {
        Some(old) => old
            .rows
            .iter()
            .filter(|r| r.get(0).and_then(|s| s.parse::<u64>().ok()).is_some_and(&keep))
            .map(|r| r.iter().map(str::to_string).collect())
            .collect(),
        None => Vec::new(),
    };
    let kept = rows.len() as u64;
    write_atomically(path, &table::to_text(&header.split(',').collect::<Vec<_>>(), rows)?)?;
    let file = std::fs::OpenOptions::new()
        .append(true)
        .open(path)
        .map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    Ok((table::writer(file), kept))
}

/// Whether a run at simulated time `t` has reached `end` (to round-off: the last step lands
/// on it): the run loop's condition to stop, which the planned steps
/// ([`crate::simulation::Simulation::planned_steps`]) share.
pub fn reached_end(t: Real, end: Real) -> bool {
    t >= end * (1.0 - 1e-12)
}

/// The next time of a schedule of `interval` that lies past `bound`, from `next`: `next`
/// plus as many intervals as it takes (the same sums as adding them one by one, for a
/// schedule a few intervals behind), in a bounded number of operations however small the
/// interval: beyond 64 intervals it jumps to the first multiple of `interval` past
/// `bound`, and when `interval` is below the spacing of the reals near `bound`, to the
/// next real after `bound` (the schedule then fires at every step).
pub fn schedule_past(mut next: Real, bound: Real, interval: Real) -> Real {
    for _ in 0..64 {
        if next > bound {
            return next;
        }
        next += interval;
    }
    let jumped = ((bound / interval).floor() + 1.0) * interval;
    if jumped.is_finite() && jumped > next {
        next = jumped;
    }
    for _ in 0..4 {
        if next > bound {
            return next;
        }
        next += interval;
    }
    if next > bound {
        next
    } else {
        bound.next_up()
    }
}
