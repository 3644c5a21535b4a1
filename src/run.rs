//! Running a case and writing its output: the command line's assembly around the core's
//! driver ([`crate::core::driver`], which holds the time loop, the stop checks and the
//! writers' protocol). This module builds the simulation (or restores it from a
//! checkpoint), creates the writers the case asks for, draws the progress bar, and writes
//! `summary.json` and the charts when the driver returns.
//!
//! A run writes these files into its output directory:
//!
//! - `case.ron`: the case as run, every plugin default filled in (re-parseable);
//! - `diagnostics.csv`: one row every `output.interval` of simulated time (every step when
//!   it is 0) and always the last step, flushed row by row so a killed run leaves a
//!   readable file; columns [`CSV_HEADER`];
//! - with `monitors: [...]` in the case, `monitors/<name>.csv` for each monitor
//!   ([`crate::core::monitor`]): a row at t = 0, on the monitor's schedule and at the last
//!   step, flushed row by row; continued by a restart like `diagnostics.csv`;
//! - `summary.json`: how the run ended ([`Summary`]), written whatever happens once the
//!   directory exists;
//! - with `output.checkpoints`, `checkpoints/checkpoint_<step>.bin` ([`crate::checkpoint`]),
//!   from which [`RunOptions::restart`] continues the run bit for bit, keeping the rows of
//!   `diagnostics.csv` and `bodies.csv` up to the checkpoint's step and appending after them.
//!
//! `case.ron`, `summary.json` and the checkpoints are written under a temporary name and
//! renamed, so a killed run never leaves a half-written one.
//!
//! Every run watches for instability after each step and stops as `"unstable"` when
//! - the kinetic energy or the largest speed is not finite;
//! - the chosen Δt falls below `time.min_dt` (the last, shortened step that lands on
//!   `time.end` excepted);
//! - the mechanical energy (kinetic + the strain energy stored in material points,
//!   `diagnostics.csv`'s `strain_energy`) exceeds [`ENERGY_GROWTH`] × E_ref, with
//!   E_ref = max(E₀, ½ M |g| L, ½ M U_b², ½ M (L / t_end)²), where E₀ is the initial kinetic
//!   energy, M the total mass, L the longer side of the domain, U_b the fastest prescribed
//!   boundary velocity and t_end `time.end`. Each term is an energy the case can reach
//!   physically (the start, a fall across the domain, the driving walls, a flow crossing
//!   the domain once in the run); a million times the largest of them is a blow-up;
//! - the mechanical energy collapses: it falls by more than [`ENERGY_COLLAPSE`] in one step
//!   (from above 10⁻¹² E_ref), which no dissipation does within a stable step;
//! - Σθ drifts: max |Σθ − 1| over the cells exceeds `coupling.max_volume_fraction_error`
//!   (default 1: a cell may empty, as a Lagrangian fluid's points leave holes, but not hold
//!   more than twice its volume) in a case with a pressure solver (which enforces Σθ = 1);
//!   in a case without one (bodies or a free surface in vacuum, where Σθ < 1 is empty
//!   space), when max Σθ − 1 exceeds it: material packed into a cell beyond twice its room;
//! - bodies overlap: two disk bodies (one of them free) whose centres are closer than
//!   [`OVERLAP_FRACTION`] × the sum of their radii, or a free disk body whose centre is
//!   closer than [`OVERLAP_FRACTION`] × its radius to a wall (or outside the domain): the
//!   contact model let them pass through each other or the wall.
//!
//! An error of a solver or a model (or a panic inside one) ends the run as `"failed"`
//! with the message.

use crate::core::case::{Case, RankLayout};
use crate::core::driver::{BodiesCsv, DiagnosticsCsv, Driver, RunState};
use crate::core::error::Error;
use crate::core::math::{Real, DIM};
use crate::core::monitor::Monitors;
use crate::core::parallel::Comm;
use crate::core::simulation::{Simulation, Status};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

pub use crate::core::driver::{
    body_overlap, number, reference_energy, BODIES_HEADER, CSV_HEADER, ENERGY_COLLAPSE, ENERGY_GROWTH, OVERLAP_FRACTION,
};

/// The most worker threads a run (and the most runs at a time a study) may ask for:
/// `--threads` beyond it is refused (a typo such as 100000 would spawn threads until the
/// memory runs out).
pub const MAX_THREADS: usize = 1024;

/// How to run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Worker threads; 0 lets rayon choose (all cores, or `RAYON_NUM_THREADS`); at most
    /// [`MAX_THREADS`].
    pub threads: usize,
    /// No progress bar.
    pub quiet: bool,
    /// Continue from this checkpoint ([`crate::checkpoint`]) instead of starting at t = 0.
    pub restart: Option<PathBuf>,
    /// The case file, named in the messages of a case that cannot start (else `<case>`).
    pub case_file: Option<PathBuf>,
    /// The ranks of a decomposed run (`mpirun`; docs/design/mpi.md), `None` for one
    /// process. Rank 0 writes the output; the others write nothing.
    pub ranks: Option<Ranks>,
}

/// The communicator of a decomposed run's ranks, counting their traffic.
#[derive(Clone)]
pub struct Ranks(pub Arc<crate::core::parallel::Counted>);

impl Ranks {
    /// This process's rank.
    pub fn rank(&self) -> usize {
        self.0.rank()
    }
}

impl std::fmt::Debug for Ranks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "rank {} of {}", self.0.rank(), self.0.size())
    }
}

impl RunOptions {
    /// Default threads, no progress bar (for tests and scripts).
    pub fn quiet() -> Self {
        Self { threads: 0, quiet: true, restart: None, case_file: None, ranks: None }
    }
}

/// What `summary.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// `"completed"`, `"unstable"` or `"failed"`.
    pub status: String,
    /// Why the run stopped early, or what bounded it (empty when it reached `time.end`).
    pub reason: String,
    /// Name of the case.
    pub case: String,
    /// Steps taken.
    pub steps: u64,
    /// Simulated time reached.
    pub simulated_time: Real,
    /// `time.end` of the case.
    pub end_time: Real,
    /// Wall-clock time of the time loop (seconds; of a restarted run, since the restart).
    pub wall_seconds: f64,
    /// Worker threads used.
    pub threads: usize,
    /// Kinetic energy at the start.
    pub initial_kinetic_energy: Real,
    /// Kinetic energy after the last step.
    pub final_kinetic_energy: Real,
    /// Energy above which the run is declared unstable (module doc).
    pub kinetic_energy_bound: Real,
    /// Largest constraint residual max |∇·(Σθu) − β(Σθ−1)/Δt| seen over the run.
    pub max_divergence: Real,
    /// Largest max |Σθ − 1| seen over the run.
    pub max_volume_fraction_error: Real,
    /// Pressure iterations summed over all steps.
    pub pressure_iterations_total: u64,
    /// Smallest Δt taken.
    pub min_dt: Real,
    /// What limited the last step.
    pub last_dt_limit: String,
    /// Rows written to `diagnostics.csv`.
    pub diagnostics_rows: u64,
    /// The checkpoint the run continued from (`null` when it started at t = 0).
    pub restarted_from: Option<String>,
    /// The last checkpoint written (`null` when none).
    pub last_checkpoint: Option<String>,
    /// A decomposed run's ranks and what they sent (absent on one process).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub communication: Option<Communication>,
    /// Where the run left its models' range of validity: point particles larger than a
    /// cell, Reynolds numbers outside a drag law's range (one sentence each, with the
    /// ratio; empty when none). Also printed at the end of the run.
    pub warnings: Vec<String>,
}

/// The result of [`run`]: the summary as written, and the output directory.
#[derive(Debug)]
pub struct Outcome {
    /// How the run ended.
    pub status: Status,
    /// What was written to `summary.json`.
    pub summary: Summary,
    /// Where the files are.
    pub output_dir: PathBuf,
}

/// A name usable as a directory: letters, digits, `-`, `_` and `.`; anything else becomes `_`.
pub fn directory_name(case_name: &str) -> String {
    let s: String =
        case_name.chars().map(|c| if c.is_ascii_alphanumeric() || "-_.".contains(c) { c } else { '_' }).collect();
    if s.is_empty() || s.chars().all(|c| c == '.') {
        "case".into()
    } else {
        s
    }
}

fn write_file(path: &Path, text: &str) -> Result<(), Error> {
    crate::output::write_atomically(path, text.as_bytes())
}

fn write_summary(dir: &Path, summary: &Summary) -> Result<(), Error> {
    let text = serde_json::to_string_pretty(summary).map_err(|e| Error::Model(e.to_string()))?;
    write_file(&dir.join("summary.json"), &(text + "\n"))
}

fn progress_bar(show: bool, end: Real) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    // position: simulated time in thousandths of time.end; drawn only once the run is long
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template("{bar:30.cyan/blue} {percent:>3}% {msg} ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(format!("t = 0 / {end}"));
    bar
}

/// The process's interrupt flag: set by [`catch_signals`]'s handler, watched by every run
/// ([`Driver::stop_on`]) and by a study between its runs.
pub fn interrupt_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| Arc::new(AtomicBool::new(false))).clone()
}

/// Whether the process was asked to stop ([`interrupt_flag`]).
pub fn interrupted() -> bool {
    interrupt_flag().load(Ordering::SeqCst)
}

/// Catches Ctrl-C (SIGINT), SIGTERM (a scheduler's time limit) and SIGHUP: the first
/// signal sets [`interrupt_flag`], so that the runs under way end after their current step
/// as `"interrupted"`, with their rows, last snapshot, checkpoint and `summary.json`
/// written; a second one ends the process at once (exit code 130), leaving every file
/// readable as a kill does. Call once, at start-up.
pub fn catch_signals() -> Result<(), Error> {
    let flag = interrupt_flag();
    ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: stopping at once");
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the step and writing the output (interrupt again to stop at once)");
    })
    .map_err(|e| Error::Model(format!("cannot catch interrupt signals: {e}")))
}

/// The ranks of a decomposed run and their traffic in its time loop.
#[derive(Clone, Debug, Serialize)]
pub struct Communication {
    /// Ranks.
    pub ranks: usize,
    /// The rank grid (ranks along each axis).
    pub rank_grid: Vec<usize>,
    /// Each rank's traffic per step of the time loop (the build's not counted), by rank.
    pub per_step: Vec<RankTraffic>,
    /// Rank 0's traffic per step by phase of the step (the phases numbered in their order;
    /// "9 …" holds the diagnostics after a step, the next Δt and the output).
    pub rank0_phases: Vec<PhaseTraffic>,
}

impl RankTraffic {
    /// From bytes, messages, exchanges, reductions, gathers and gathered bytes, in that order.
    fn of(v: &[Real]) -> Self {
        Self { bytes: v[0], messages: v[1], exchanges: v[2], reductions: v[3], gathers: v[4], gathered_bytes: v[5] }
    }
}

/// Rank 0's traffic per step in one phase of the step.
#[derive(Clone, Debug, Serialize)]
pub struct PhaseTraffic {
    /// The phase.
    pub phase: String,
    /// The traffic per step ([`RankTraffic`]'s figures).
    #[serde(flatten)]
    pub traffic: RankTraffic,
}

/// One rank's traffic per step ([`crate::core::parallel::Traffic`] over the steps).
#[derive(Clone, Debug, Serialize)]
pub struct RankTraffic {
    /// Bytes of the point-to-point messages it sent (the halo exchanges).
    pub bytes: Real,
    /// Messages it sent.
    pub messages: Real,
    /// Halo exchanges.
    pub exchanges: Real,
    /// Exact-sum reductions (and agreements).
    pub reductions: Real,
    /// Gathers (maxima; the residual of the multigrid V-cycle, which runs whole on every
    /// rank; points for output).
    pub gathers: Real,
    /// Bytes it contributed to those gathers.
    pub gathered_bytes: Real,
}

/// Runs `case` and writes its output into `output_dir` (created if needed).
///
/// Returns `Err` only when the case cannot start: a plugin that is not registered or
/// whose parameters are invalid (bad input; `summary.json` still says `"failed"`), or an
/// output file that cannot be written before step 0 or after the last (`summary.json`
/// says `"failed"` when it can be written). Instabilities, errors during the time loop and
/// output that cannot be written during it (a full disk) end in an [`Outcome`] whose
/// status says so.
pub fn run(case: &Case, output_dir: &Path, options: &RunOptions) -> Result<Outcome, Error> {
    if options.threads > MAX_THREADS {
        return Err(Error::Model(format!(
            "{} worker threads: at most {MAX_THREADS}; 0 uses every core",
            options.threads
        )));
    }
    std::fs::create_dir_all(output_dir).map_err(|source| Error::Io { path: output_dir.to_path_buf(), source })?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .build()
        .map_err(|e| Error::Model(format!("cannot start {} worker threads: {e}", options.threads)))?;
    let threads = pool.current_num_threads();
    pool.install(|| run_in_pool(case, output_dir, options, threads))
}

fn run_in_pool(case: &Case, dir: &Path, options: &RunOptions, threads: usize) -> Result<Outcome, Error> {
    let mut summary = Summary {
        status: String::new(),
        reason: String::new(),
        case: case.name.clone(),
        steps: 0,
        simulated_time: 0.0,
        end_time: case.time.end,
        wall_seconds: 0.0,
        threads,
        initial_kinetic_energy: 0.0,
        final_kinetic_energy: 0.0,
        kinetic_energy_bound: 0.0,
        max_divergence: 0.0,
        max_volume_fraction_error: 0.0,
        pressure_iterations_total: 0,
        min_dt: Real::INFINITY,
        last_dt_limit: String::new(),
        diagnostics_rows: 0,
        restarted_from: None,
        warnings: Vec::new(),
        last_checkpoint: None,
        communication: None,
    };
    // a bad checkpoint is refused before anything in the output directory is touched
    let (sim, resumed) = match &options.restart {
        Some(path) => {
            let comm = options.ranks.as_ref().map(|r| r.0.clone() as Arc<dyn Comm>);
            let (sim, checkpoint) = crate::checkpoint::restore_on(case, path, comm)?;
            (sim, Some(checkpoint))
        }
        None => match match &options.ranks {
            Some(r) => Simulation::with_comm(case, r.0.clone()),
            None => Simulation::new(case),
        } {
            Ok(sim) => (sim, None),
            Err(e) => {
                let e = match &options.case_file {
                    Some(file) => e.in_file(file),
                    None => e,
                };
                if writes_output(options) {
                    write_file(&dir.join("case.ron"), &case.to_ron())?;
                    let status = Status::Failed(e.to_string());
                    summary.status = status.label().into();
                    summary.reason = status.reason().into();
                    summary.min_dt = 0.0;
                    write_summary(dir, &summary)?;
                }
                return Err(e);
            }
        },
    };
    let result = run_simulation(sim, resumed, dir, options, &mut summary);
    if let Err(e) = &result {
        // an output that could not be written (a full disk), or a writer that could not
        // start: the summary says so, if it can still be written
        if summary.status.is_empty() {
            summary.status = Status::Failed(String::new()).label().into();
            summary.reason = e.to_string();
            if !summary.min_dt.is_finite() {
                summary.min_dt = 0.0;
            }
            if writes_output(options) {
                let _ = write_summary(dir, &summary);
            }
        }
    }
    result
}

/// Whether this process writes the run's output: one process, or rank 0 of several.
fn writes_output(options: &RunOptions) -> bool {
    options.ranks.as_ref().is_none_or(|r| r.rank() == 0)
}

/// The refusal, before step 0, of what a run on several ranks does not do yet (issue 19's
/// later phases): pictures and monitors. Every rank decides alike (from the case).
fn refuse_on_ranks(sim: &Simulation, options: &RunOptions) -> Result<(), Error> {
    let Some(r) = options.ranks.as_ref().filter(|r| r.0.size() > 1) else {
        return Ok(());
    };
    let ranks = r.0.size();
    let o = &sim.case.output;
    let refuse = |key: &str, what: &str, fix: &str| {
        Err(Error::invalid(
            key,
            format!(
                "{what}: not yet on several ranks, and this run has {ranks}; {fix} (a decomposed run writes \
                 diagnostics.csv, summary.json, the charts, snapshots and checkpoints so far), or run on one rank"
            ),
        ))
    };
    if !sim.case.monitors.is_empty() || !sim.case.stop.is_empty() {
        return refuse("monitors", "monitors and stop conditions", "remove `monitors` and `stop`");
    }
    if o.pictures.is_some() {
        return refuse("output.pictures", "pictures", "set `pictures: None`");
    }
    Ok(())
}

/// The run of `sim` once it is built (or restored): the writers, the time loop and the
/// summary. On `Err`, `summary` holds what the run reached.
fn run_simulation(
    mut sim: Simulation,
    resumed: Option<crate::checkpoint::Checkpoint>,
    dir: &Path,
    options: &RunOptions,
    summary: &mut Summary,
) -> Result<Outcome, Error> {
    refuse_on_ranks(&sim, options)?;
    let interval = sim.case.output.interval;
    let writes = writes_output(options);
    if let (Some(c), true) = (&resumed, writes) {
        crate::checkpoint::discard_after(dir, c.step)?;
    }
    let mut checkpoints = None;
    if let Some(schedule) = sim.case.output.checkpoints {
        // a frame that cannot be checkpointed is refused now, not at the first checkpoint
        sim.save_state().map_err(|e| Error::Model(format!("output.checkpoints: {e}; remove output.checkpoints")))?;
        let next = match &resumed {
            Some(c) if c.case.output.checkpoints == Some(schedule) => c.runner.next_checkpoint,
            Some(_) => crate::checkpoint::next_after(sim.time, schedule.interval),
            None => schedule.interval,
        };
        let last = resumed.as_ref().map(|c| c.step);
        let per_rank = schedule.layout == RankLayout::PerRank && !sim.grid.part.is_whole();
        checkpoints = Some(crate::checkpoint::Checkpoints::create_on(dir, schedule, next, last, writes, per_rank)?);
    }
    if writes {
        write_file(&dir.join("case.ron"), &sim.case.to_ron())?;
    }
    let has_bodies = !sim.bodies().is_empty();
    let (state, csv, bodies, monitors) = match &resumed {
        None => {
            let monitors = Monitors::create(&mut sim, dir)?;
            let csv = if writes { Some(DiagnosticsCsv::create(dir.join("diagnostics.csv"))?) } else { None };
            let bodies = if has_bodies { Some(BodiesCsv::create(dir.join("bodies.csv"))?) } else { None };
            (RunState::new(&sim), csv, bodies, monitors)
        }
        Some(c) => {
            let r = &c.runner;
            summary.restarted_from = Some(c.path.display().to_string());
            let next_row = if c.case.output.interval == interval {
                r.next_output
            } else if interval > 0.0 {
                crate::checkpoint::next_after(sim.time, interval)
            } else {
                0.0
            };
            let state = r.run_state(&sim, next_row);
            // the rows up to the checkpoint's step; its own row only when it was a regular one
            let (step, with_last) = (c.step, r.last_row_written);
            let keep = move |s: u64| s < step || (s == step && with_last);
            // the rows come from the checkpoint's run directory (else from this one)
            let source_dir = c
                .path
                .parent()
                .filter(|p| p.file_name().is_some_and(|n| n == crate::checkpoint::FOLDER))
                .and_then(Path::parent);
            let source = |name: &str| source_dir.map(|d| d.join(name));
            let csv = if writes {
                Some(DiagnosticsCsv::resume(dir.join("diagnostics.csv"), source("diagnostics.csv").as_deref(), keep)?)
            } else {
                None
            };
            let bodies = if has_bodies {
                Some(BodiesCsv::resume(dir.join("bodies.csv"), source("bodies.csv").as_deref(), keep)?)
            } else {
                None
            };
            let monitors = Monitors::resume(&mut sim, dir, source_dir)?;
            (state, csv, bodies, monitors)
        }
    };
    let others = crate::output::writers(&sim, dir)?;
    summary.initial_kinetic_energy = sim.initial_energy;
    summary.kinetic_energy_bound = ENERGY_GROWTH * reference_energy(&sim);
    let end = sim.case.time.end;
    let sim_steps_at_start = sim.steps;
    let mut driver = Driver::resume(sim, state);
    // (the other ranks of a decomposed run: no file; the diagnostics are the same on each)
    if let Some(csv) = csv {
        driver.add_writer(csv);
    }
    if let Some(b) = bodies {
        driver.add_writer(b);
    }
    for w in others {
        driver.add_boxed_writer(w);
    }
    if let Some(c) = checkpoints {
        driver.add_writer(c);
    }
    if let Some(m) = monitors {
        driver.set_monitors(m);
    }
    let show_bar = writes && !options.quiet && std::io::stdout().is_terminal();
    let bar = progress_bar(show_bar, end);
    {
        let bar = bar.clone();
        let start = Instant::now();
        let mut last_draw = start;
        driver.on_progress(move |sim, rate| {
            let now = Instant::now();
            if now.duration_since(last_draw) > Duration::from_millis(200) {
                if show_bar && bar.is_hidden() && now.duration_since(start) > Duration::from_millis(500) {
                    bar.set_draw_target(ProgressDrawTarget::stdout());
                }
                bar.set_position((1000.0 * (sim.time / end)).clamp(0.0, 1000.0) as u64);
                bar.set_message(format!("t = {:.4e} / {end} | {rate:.0} steps/s", sim.time));
                last_draw = now;
            }
        });
    }
    driver.stop_on(interrupt_flag());
    let traffic_before = options.ranks.as_ref().map(|r| (r.0.traffic(), r.0.by_phase()));
    let started = Instant::now();
    let result = driver.run();
    if let (Some(r), Some((before, phases_before))) = (&options.ranks, traffic_before) {
        // every rank reaches this point after the same steps: gather what each sent
        let steps = (driver.sim.steps - sim_steps_at_start).max(1) as Real;
        let figures = |t: crate::core::parallel::Traffic| {
            [t.bytes, t.messages, t.exchanges, t.reductions, t.gathers, t.gathered_bytes].map(|v| v as Real / steps)
        };
        let per_step = |t| RankTraffic::of(&figures(t));
        let phases: Vec<PhaseTraffic> =
            r.0.by_phase()
                .into_iter()
                .map(|(phase, t)| {
                    let old = phases_before.iter().find(|(p, _)| *p == phase).map(|(_, t)| *t).unwrap_or_default();
                    PhaseTraffic { phase: phase.to_string(), traffic: per_step(t.since(&old)) }
                })
                .filter(|p| p.traffic.messages + p.traffic.reductions + p.traffic.gathers > 0.0)
                .collect();
        let all = r.0.gather_all_f64(&figures(r.0.traffic().since(&before)));
        summary.communication = Some(Communication {
            ranks: all.len(),
            rank_grid: driver.sim.grid.part.block().map(|(g, _)| g.p.to_vec()).unwrap_or_else(|| vec![1; DIM]),
            per_step: all.iter().map(|v| RankTraffic::of(v)).collect(),
            rank0_phases: phases,
        });
    }
    bar.finish_and_clear();
    let (sim, state) = (&driver.sim, &driver.state);
    summary.steps = sim.steps;
    summary.simulated_time = sim.time;
    summary.final_kinetic_energy = state.final_kinetic_energy;
    summary.max_divergence = state.max_divergence;
    summary.max_volume_fraction_error = state.max_volume_fraction_error;
    summary.pressure_iterations_total = state.pressure_iterations_total;
    summary.min_dt = if sim.steps == 0 { 0.0 } else { state.min_dt };
    summary.last_dt_limit = state.last_dt_limit.clone();
    summary.diagnostics_rows = state.rows;
    summary.last_checkpoint =
        driver.writer("checkpoints").and_then(|w| w.last_written()).map(|p| p.display().to_string());
    // an output that cannot be written mid-run (a full disk) ends the run as failed, with
    // its summary
    let outcome = result.unwrap_or_else(|e| crate::core::driver::Outcome {
        status: Status::Failed(format!("after step {}, t = {}: {e}", sim.steps, sim.time)),
        reason: String::new(),
        wall_seconds: started.elapsed().as_secs_f64(),
    });
    summary.wall_seconds = outcome.wall_seconds;
    let status = outcome.status;
    summary.status = status.label().into();
    summary.reason = if status == Status::Completed { outcome.reason } else { status.reason().into() };
    summary.warnings = sim.warnings();
    if !writes {
        return Ok(Outcome { status, summary: summary.clone(), output_dir: dir.to_path_buf() });
    }
    if !options.quiet {
        for w in &summary.warnings {
            eprintln!("warning: {w}");
        }
    }
    write_summary(dir, summary)?;
    if sim.case.output.charts {
        // charts are drawn from the run's own output: failing to draw them is an output
        // failure (`Error::Io` of the file, exit code 1), never bad input; a failed run
        // keeps its own reason
        let drawn = crate::charts::write(dir);
        if !matches!(status, Status::Failed(_)) {
            drawn?;
        }
    }
    Ok(Outcome { status, summary: summary.clone(), output_dir: dir.to_path_buf() })
}
