//! How long a case will run on this machine, estimated before it starts (`check`).
//!
//! The number of steps is the run's own: [`Simulation::planned_steps`] walks the clock from
//! t = 0 to `time.end` with the Δt the run would choose ([`Simulation::choose_dt`], landing
//! on the exact output times and on the end) if the stable Δt stayed that of the initial
//! state (the CFL limit of the initial velocity, the explicit viscous limit, gravity's,
//! `max_dt`, every model's). A flow that speeds up takes more steps; one that slows down,
//! fewer (down to `max_dt`'s).
//!
//! The time of a step is measured, not modelled: [`calibrate`] builds the case on a coarser
//! grid ([`calibration_cells`]: at most [`CALIBRATION_CELLS`], the same physics, no output),
//! times a few of its steps after a first one (which sets up the solvers' state) and takes
//! the median step, its pressure solves timed apart (a wrapper of the solver). [`per_step`] scales the step to the
//! case's grid: the cells' ratio for the whole step, and for the pressure solves' share
//! also the growth of their iterations, measured between the calibration grid and one of
//! half its cells along each axis (`k` iterations growing as `n^p` with the cells `n`
//! along an axis: p ≈ 0 for multigrid, ≈ 1 for Jacobi-PCG).

use super::DIM;
use crate::case::Case;
use crate::error::{Error, Result};
use crate::math::Real;
use crate::plugin::PressureSolver;
use crate::poisson::{PoissonProblem, SolveStats};
use crate::simulation::Simulation;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Most cells of the grid a case is calibrated on: 64² in 2D, 16³ in 3D (the same count).
pub const CALIBRATION_CELLS: u64 = 4096;

/// Steps the calibration times (after the first), unless its budget runs out first.
pub const CALIBRATION_STEPS: usize = 7;

/// Steps [`Simulation::planned_steps`] walks one by one; beyond, whole steps of the stable Δt.
pub const WALKED_STEPS: u64 = 1_000_000;

/// The cells of the calibration grid of a grid of `cells`: each divided by the smallest
/// whole `k` that brings their product to at most [`CALIBRATION_CELLS`] (rounded up, at
/// least 2), and `k` (1: the grid itself).
pub fn calibration_cells(cells: [usize; DIM]) -> ([usize; DIM], usize) {
    let total = cells.iter().fold(1u64, |a, &n| a.saturating_mul(n as u64));
    // the smallest k with k^DIM × the cap ≥ the cells, then up while the rounding leaves more
    let mut k = 1usize;
    while (k as u64).saturating_pow(DIM as u32).saturating_mul(CALIBRATION_CELLS) < total {
        k += 1;
    }
    loop {
        let coarse = cells.map(|n| n.div_ceil(k).max(2));
        if k == 1 || coarse.iter().map(|&n| n as u64).product::<u64>() <= CALIBRATION_CELLS {
            return (coarse, k);
        }
        k += 1;
    }
}

/// The case on `cells` (its cells divided by `k`, rounded up): the domain keeps its size
/// when the cells keep their proportions (the cells stay cubes), else it grows to `cells ×
/// h k` along the axes `k` does not divide (what lies in the domain stays in it); the
/// output, the monitors and the stop conditions are left out, and the end moved far away
/// (the calibration steps it, nothing else).
pub fn coarsened(case: &Case, cells: [usize; DIM], k: usize) -> Case {
    let mut c = case.clone();
    let n = case.cells();
    let proportional = (0..DIM).all(|a| cells[a] * n[0] == cells[0] * n[a]);
    if !proportional {
        let h = case.domain.size[0] / n[0] as Real * k as Real;
        for a in 0..DIM {
            if cells[a] * k != n[a] {
                c.domain.size[a] = cells[a] as Real * h;
            }
        }
    }
    let divided = |m: usize| m.div_ceil(k).max(2);
    if case.cells() == case.domain.cells {
        c.domain.cells = cells;
        c.domain.point_cells = case.domain.point_cells.map(|p| p.map(divided));
    } else {
        // the grid is the mass points' (`domain.point_cells`)
        c.domain.point_cells = Some(cells);
        c.domain.cells = case.domain.cells.map(divided);
    }
    c.output = Default::default();
    c.output.charts = false;
    c.monitors.clear();
    c.stop.clear();
    c.time.end = (case.time.end * 1e6).min(Real::MAX);
    c.time.max_steps = Some(u64::MAX);
    c
}

/// Steps of a case timed on one grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// The grid's cells.
    pub cells: [usize; DIM],
    /// Steps timed (after the first, untimed).
    pub steps: usize,
    /// Wall time of a step (s): the median of the timed steps (on a shared machine some
    /// are delayed).
    pub seconds_per_step: f64,
    /// The share of the median step's time in its pressure solves (0 without a pressure
    /// solver).
    pub pressure_share: f64,
    /// Pressure iterations of a step, the mean over the timed steps.
    pub iterations: f64,
}

impl Calibration {
    /// Cells of its grid.
    pub fn cell_count(&self) -> u64 {
        self.cells.iter().map(|&n| n as u64).product()
    }
}

/// A pressure solver that adds the wall time of its solves to a counter.
struct Timed {
    inner: Box<dyn PressureSolver>,
    nanos: Arc<AtomicU64>,
}

impl PressureSolver for Timed {
    fn model(&self) -> &'static str {
        self.inner.model()
    }
    fn params(&self) -> serde_json::Value {
        self.inner.params()
    }
    fn solve(&mut self, problem: &PoissonProblem, pressure: &mut [Real]) -> Result<SolveStats> {
        let start = Instant::now();
        let out = self.inner.solve(problem, pressure);
        self.nanos.fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
        out
    }
}

/// Times the steps of `case` (already [`coarsened`]) in the current thread pool: one step
/// to start, then up to `steps` more, fewer when they have taken `budget` seconds (at least
/// one). Writes nothing. An error names the grid and why it could not step.
pub fn calibrate(case: &Case, steps: usize, budget: f64) -> Result<Calibration> {
    let cells = case.cells();
    let fail = |e: Error| Error::Model(format!("the calibration on {} cells: {e}", super::times(&cells)));
    case.validate().map_err(fail)?;
    let mut sim = Simulation::new(case).map_err(fail)?;
    let nanos = Arc::new(AtomicU64::new(0));
    if let Some(inner) = sim.pressure_solver.take() {
        sim.pressure_solver = Some(Box::new(Timed { inner, nanos: nanos.clone() }));
    }
    // a model that panics fails the calibration, as it fails a run (`Driver::run`)
    let step = |sim: &mut Simulation| match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| sim.step())) {
        Ok(stepped) => stepped.map_err(fail),
        Err(p) => Err(fail(Error::Model(format!("a model panicked: {}", crate::driver::panic_message(p))))),
    };
    step(&mut sim)?;
    let start = Instant::now();
    // each step's wall time and its pressure solves'
    let (mut times, mut iterations) = (Vec::new(), 0usize);
    while times.len() < steps.max(1) && (times.is_empty() || start.elapsed().as_secs_f64() < budget) {
        nanos.store(0, Ordering::Relaxed);
        let clock = Instant::now();
        let d = step(&mut sim)?;
        times.push((clock.elapsed().as_secs_f64(), nanos.load(Ordering::Relaxed) as f64 * 1e-9));
        iterations += d.pressure_iterations;
    }
    let done = times.len();
    // the median step (a shared machine delays some steps), its share in the pressure solve
    times.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (seconds, pressure) = times[done / 2];
    Ok(Calibration {
        cells,
        steps: done,
        seconds_per_step: seconds,
        pressure_share: if seconds > 0.0 { (pressure / seconds).min(1.0) } else { 0.0 },
        iterations: iterations as f64 / done as f64,
    })
}

/// The growth exponent p of the pressure iterations with the cells along an axis, k ∝ n^p,
/// between a calibration on a coarser grid and one on a finer: 0 when either has no
/// iterations or they fall; at most 2.
pub fn iteration_growth(coarser: &Calibration, finer: &Calibration) -> f64 {
    let ratio = (finer.cell_count() as f64 / coarser.cell_count() as f64).powf(1.0 / DIM as f64);
    if coarser.iterations <= 0.0 || finer.iterations <= 0.0 || ratio <= 1.0 {
        return 0.0;
    }
    ((finer.iterations / coarser.iterations).ln() / ratio.ln()).clamp(0.0, 2.0)
}

/// Seconds of a step on a grid of `cells` from a calibration: its time per step times the
/// cells' ratio r, the pressure solves' share f also times the growth of their iterations,
/// r^{p/DIM} (p of [`iteration_growth`]): t r ((1 − f) + f r^{p/DIM}).
pub fn per_step(c: &Calibration, growth: f64, cells: u64) -> f64 {
    let r = cells as f64 / c.cell_count() as f64;
    let f = c.pressure_share;
    c.seconds_per_step * r * ((1.0 - f) + f * r.powf(growth / DIM as f64))
}

/// How long a case runs on this machine: its steps and the time of each.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeEstimate {
    /// Steps to `time.end` ([`Simulation::planned_steps`]).
    pub steps: u64,
    /// The first Δt and what limits it.
    pub first_dt: (Real, String),
    /// The case's cells.
    pub cells: u64,
    /// The calibration the time of a step is scaled from.
    pub calibration: Calibration,
    /// The calibration on half its cells along each axis (for the iterations' growth),
    /// when the case has a pressure solver and its grid is coarsened.
    pub half: Option<Calibration>,
    /// Growth exponent of the pressure iterations ([`iteration_growth`]).
    pub growth: f64,
    /// Seconds of a step of the case ([`per_step`]).
    pub seconds_per_step: f64,
    /// Threads of the pool it was measured in.
    pub threads: usize,
}

impl TimeEstimate {
    /// Seconds of the whole run.
    pub fn seconds(&self) -> f64 {
        self.steps as f64 * self.seconds_per_step
    }
}

/// The time estimate of the case of `sim` (built, at t = 0), in the current thread pool:
/// its planned steps, and the calibration on a coarsened copy of the case (and on one
/// coarser still for the pressure iterations' growth), each given about `budget` seconds
/// of steps. The case's own grid is calibrated when it is no larger than
/// [`CALIBRATION_CELLS`].
pub fn time_estimate(sim: &Simulation, budget: f64) -> Result<TimeEstimate> {
    let case = &sim.case;
    let (steps, dt, limit) = sim.planned_steps(WALKED_STEPS);
    let n = case.cells();
    let cells = n.iter().map(|&m| m as u64).product();
    let (coarse, k) = calibration_cells(n);
    let calibration = calibrate(&coarsened(case, coarse, k), CALIBRATION_STEPS, budget)?;
    let half = if k > 1 && case.pressure.is_some() {
        let h = coarse.map(|m| (m / 2).max(2));
        // a grid that cannot be halved along every axis (2 cells) gives no growth
        (h != coarse).then(|| calibrate(&coarsened(case, h, 2 * k), CALIBRATION_STEPS, 0.25 * budget)).transpose()?
    } else {
        None
    };
    let growth = half.as_ref().map_or(0.0, |h| iteration_growth(h, &calibration));
    Ok(TimeEstimate {
        steps,
        first_dt: (dt, limit),
        cells,
        seconds_per_step: per_step(&calibration, growth, cells),
        calibration,
        half,
        growth,
        threads: rayon::current_num_threads(),
    })
}
