//! Running a case and writing its output.
//!
//! A run writes three files into its output directory:
//!
//! - `case.ron`: the case as run, every plugin default filled in (re-parseable);
//! - `diagnostics.csv`: one row every `output.interval` of simulated time (every step when
//!   it is 0) and always the last step, flushed row by row so a killed run leaves a
//!   readable file; columns [`CSV_HEADER`];
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
//! - the kinetic energy exceeds [`ENERGY_GROWTH`] × E_ref, with
//!   E_ref = max(E₀, ½ M |g| L, ½ M U_b², ½ M (L / t_end)²), where E₀ is the initial kinetic
//!   energy, M the total mass, L the longer side of the domain, U_b the fastest prescribed
//!   boundary velocity and t_end `time.end`. Each term is an energy the case can reach
//!   physically (the start, a fall across the domain, the driving walls, a flow crossing
//!   the domain once in the run); a million times the largest of them is a blow-up;
//! - Σθ drifts: max |Σθ − 1| over the cells exceeds `coupling.max_volume_fraction_error`
//!   (default 1: a cell may empty, as a Lagrangian fluid's points leave holes, but not hold
//!   more than twice its volume) in a case with a pressure solver (which enforces Σθ = 1;
//!   cases without one, bodies or a free surface in vacuum, are not checked);
//! - bodies overlap: two disk bodies (one of them free) whose centres are closer than
//!   [`OVERLAP_FRACTION`] × the sum of their radii, or a free disk body whose centre is
//!   closer than [`OVERLAP_FRACTION`] × its radius to a wall (or outside the domain): the
//!   contact model let them pass through each other or the wall.
//!
//! An error of a solver or a model (or a panic inside one) ends the run as `"failed"`
//! with the message.

use crate::core::boundary::{Boundary, Side};
use crate::core::case::Case;
use crate::core::error::Error;
use crate::core::math::Real;
use crate::core::simulation::{Simulation, Status, StepDiagnostics};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The columns of `diagnostics.csv`, in order.
pub const CSV_HEADER: &str = "step,time,dt,dt_limit,kinetic_energy,momentum_x,momentum_y,mass,max_speed,\
max_divergence,volume_fraction_error,pressure_iterations,pressure_residual";

/// Kinetic energy above this multiple of the reference energy (module doc) is a blow-up.
pub const ENERGY_GROWTH: Real = 1e6;

/// Bodies closer than this fraction of the sum of their radii (or of the radius to a wall)
/// overlap: the run stops as unstable (module doc).
pub const OVERLAP_FRACTION: Real = 0.5;

/// Why the bodies of `sim` overlap each other or a wall (module doc), if they do. Only disk
/// bodies (by their shape in the case) are checked, with the radius of the body's state.
pub fn body_overlap(sim: &Simulation) -> Option<String> {
    let case = &sim.case;
    let disks: Vec<&str> = case
        .fields
        .iter()
        .flat_map(|f| match &f.region {
            crate::core::case::Region::Bodies(b) => b
                .iter()
                .filter(|b| matches!(b.shape, crate::core::case::BodyShape::Disk { .. }))
                .map(|b| b.name.as_str())
                .collect(),
            _ => Vec::new(),
        })
        .collect();
    if disks.is_empty() {
        return None;
    }
    let bodies: Vec<_> =
        sim.bodies().into_iter().map(|(_, b)| b).filter(|b| disks.contains(&b.name.as_str())).collect();
    for (k, a) in bodies.iter().enumerate() {
        for b in &bodies[..k] {
            let d = (a.position - b.position).norm();
            let contact = a.radius + b.radius;
            if (a.free || b.free) && d < OVERLAP_FRACTION * contact {
                return Some(format!(
                    "bodies `{}` and `{}` overlap at step {}, t = {}: centres {d:.4e} apart, below \
                     {OVERLAP_FRACTION} × the sum of the radii {contact:.4e}; strengthen the contact \
                     (contact.params) or reduce time.cfl",
                    b.name, a.name, sim.steps, sim.time
                ));
            }
        }
        if !a.free {
            continue;
        }
        let (o, size) = (case.domain.origin, case.domain.size);
        let walls = [
            (Side::Left, a.position.x - o[0]),
            (Side::Right, o[0] + size[0] - a.position.x),
            (Side::Bottom, a.position.y - o[1]),
            (Side::Top, o[1] + size[1] - a.position.y),
        ];
        for (side, gap) in walls {
            if matches!(case.boundaries.side(side), Boundary::Periodic) {
                continue;
            }
            if gap.is_nan() || gap < OVERLAP_FRACTION * a.radius {
                return Some(format!(
                    "body `{}` crosses the {side:?} wall at step {}, t = {}: its centre is {gap:.4e} from the wall, \
                     below {OVERLAP_FRACTION} × its radius {:.4e}; add or strengthen the contact model or reduce time.cfl",
                    a.name, sim.steps, sim.time, a.radius
                ));
            }
        }
    }
    None
}

/// How to run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Worker threads; 0 lets rayon choose (all cores, or `RAYON_NUM_THREADS`).
    pub threads: usize,
    /// No progress bar.
    pub quiet: bool,
    /// Continue from this checkpoint ([`crate::checkpoint`]) instead of starting at t = 0.
    pub restart: Option<PathBuf>,
}

impl RunOptions {
    /// Default threads, no progress bar (for tests and scripts).
    pub fn quiet() -> Self {
        Self { threads: 0, quiet: true, restart: None }
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

/// Energy scale E_ref of the instability bound (module doc).
pub fn reference_energy(sim: &Simulation) -> Real {
    let case = &sim.case;
    let mass: Real = sim.fields.iter().map(|f| f.frame.mass()).sum();
    let length = case.domain.size[0].max(case.domain.size[1]);
    let g = (case.gravity[0].powi(2) + case.gravity[1].powi(2)).sqrt();
    let wall = Side::ALL
        .iter()
        .map(|&s| match case.boundaries.side(s) {
            Boundary::Velocity { velocity, .. } => (velocity[0].powi(2) + velocity[1].powi(2)).sqrt(),
            _ => 0.0,
        })
        .fold(0.0, Real::max);
    let crossing = length / case.time.end;
    [sim.initial_energy, 0.5 * mass * g * length, 0.5 * mass * wall * wall, 0.5 * mass * crossing * crossing]
        .into_iter()
        .fold(0.0, Real::max)
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

/// `diagnostics.csv`, one flushed row at a time.
struct Diagnostics {
    file: BufWriter<File>,
    path: PathBuf,
    rows: u64,
}

impl Diagnostics {
    fn create(path: PathBuf) -> Result<Self, Error> {
        let io = |source| Error::Io { path: path.clone(), source };
        let mut file = BufWriter::new(File::create(&path).map_err(io)?);
        writeln!(file, "{CSV_HEADER}").and_then(|_| file.flush()).map_err(io)?;
        Ok(Self { file, path, rows: 0 })
    }
    fn resume(path: PathBuf, source: Option<&Path>, keep: impl Fn(u64) -> bool) -> Result<Self, Error> {
        let (file, rows) = resume_csv(&path, source, CSV_HEADER, keep)?;
        Ok(Self { file, path, rows })
    }
    fn write(&mut self, d: &StepDiagnostics) -> Result<(), Error> {
        let limit = d.dt_limit.replace([',', '"', '\n'], ";");
        let x = number;
        writeln!(
            self.file,
            "{},{},{},{limit},{},{},{},{},{},{},{},{},{}",
            d.step,
            x(d.time),
            x(d.dt),
            x(d.kinetic_energy),
            x(d.momentum.x),
            x(d.momentum.y),
            x(d.mass),
            x(d.max_speed),
            x(d.max_divergence),
            x(d.volume_fraction_error),
            d.pressure_iterations,
            x(d.pressure_residual)
        )
        .and_then(|_| self.file.flush())
        .map_err(|source| Error::Io { path: self.path.clone(), source })?;
        self.rows += 1;
        Ok(())
    }
}

/// Header of `bodies.csv` (one row per body per output time).
pub const BODIES_HEADER: &str =
    "step,time,body,x,y,vx,vy,omega,fx,fy,torque,fx_pressure,fy_pressure,fx_viscous,fy_viscous";

/// Writer of `bodies.csv`: centroid, velocity, angular velocity, hydrodynamic force and
/// torque of every body, and the force's pressure and viscous parts where the coupling
/// gives them ([`Simulation::pressure_forces`]; empty cells elsewhere), flushed row by row.
struct BodiesCsv {
    file: BufWriter<File>,
    path: PathBuf,
}

impl BodiesCsv {
    fn create(path: PathBuf) -> Result<Self, Error> {
        let io = |source| Error::Io { path: path.clone(), source };
        let mut file = BufWriter::new(File::create(&path).map_err(io)?);
        writeln!(file, "{BODIES_HEADER}").and_then(|_| file.flush()).map_err(io)?;
        Ok(Self { file, path })
    }
    fn resume(path: PathBuf, source: Option<&Path>, keep: impl Fn(u64) -> bool) -> Result<Self, Error> {
        let (file, _) = resume_csv(&path, source, BODIES_HEADER, keep)?;
        Ok(Self { file, path })
    }
    fn write(&mut self, sim: &Simulation) -> Result<(), Error> {
        let x = number;
        let pressure = sim.pressure_forces();
        for ((_, b), p) in sim.bodies().into_iter().zip(pressure) {
            let name = b.name.replace([',', '"', '\n'], ";");
            // the pressure and viscous parts where the coupling gives them, else empty
            let parts = p.map_or_else(
                || ",,,".to_string(),
                |p| format!("{},{},{},{}", x(p.x), x(p.y), x(b.force.x - p.x), x(b.force.y - p.y)),
            );
            writeln!(
                self.file,
                "{},{},{name},{},{},{},{},{},{},{},{},{parts}",
                sim.steps,
                x(sim.time),
                x(b.position.x),
                x(b.position.y),
                x(b.velocity.x),
                x(b.velocity.y),
                x(b.angular_velocity),
                x(b.force.x),
                x(b.force.y),
                x(b.torque)
            )
            .map_err(|source| Error::Io { path: self.path.clone(), source })?;
        }
        self.file.flush().map_err(|source| Error::Io { path: self.path.clone(), source })
    }
}

/// Continues the CSV file `path` after a restart: the header and the complete rows whose
/// step (first column) passes `keep`, taken from `source` (the same file in the
/// checkpoint's run directory) if it exists, else from `path` itself, are written to
/// `path` (atomically), which is then opened for appending. Returns it and the rows kept.
fn resume_csv(
    path: &Path,
    source: Option<&Path>,
    header: &str,
    keep: impl Fn(u64) -> bool,
) -> Result<(BufWriter<File>, u64), Error> {
    let from = source.filter(|s| s.is_file()).unwrap_or(path);
    let old = match std::fs::read_to_string(from) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(source) => return Err(Error::Io { path: from.to_path_buf(), source }),
    };
    let mut text = format!("{header}\n");
    let mut rows = 0;
    // complete lines only: a run killed while writing a row leaves part of it
    for line in old.split_inclusive('\n').skip(1).filter(|l| l.ends_with('\n')) {
        let step = line.split(',').next().and_then(|s| s.parse::<u64>().ok());
        if step.is_some_and(&keep) {
            text.push_str(line);
            rows += 1;
        }
    }
    crate::output::write_atomically(path, text.as_bytes())?;
    let file = std::fs::OpenOptions::new()
        .append(true)
        .open(path)
        .map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    Ok((BufWriter::new(file), rows))
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

fn write_file(path: &Path, text: &str) -> Result<(), Error> {
    crate::output::write_atomically(path, text.as_bytes())
}

fn write_summary(dir: &Path, summary: &Summary) -> Result<(), Error> {
    let text = serde_json::to_string_pretty(summary).map_err(|e| Error::Model(e.to_string()))?;
    write_file(&dir.join("summary.json"), &(text + "\n"))
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "panic".into())
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

/// Runs `case` and writes its output into `output_dir` (created if needed).
///
/// Returns `Err` only when the case cannot start: a plugin that is not registered or
/// whose parameters are invalid (bad input; `summary.json` still says `"failed"`), or an
/// output file that cannot be written. Instabilities and errors during the time loop end
/// in an [`Outcome`] whose status says so.
pub fn run(case: &Case, output_dir: &Path, options: &RunOptions) -> Result<Outcome, Error> {
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
    };
    // a bad checkpoint is refused before anything in the output directory is touched
    let (mut sim, resumed) = match &options.restart {
        Some(path) => {
            let (sim, checkpoint) = crate::checkpoint::restore(case, path)?;
            (sim, Some(checkpoint))
        }
        None => match Simulation::new(case) {
            Ok(sim) => (sim, None),
            Err(e) => {
                write_file(&dir.join("case.ron"), &case.to_ron())?;
                let status = Status::Failed(e.to_string());
                summary.status = status.label().into();
                summary.reason = status.reason().into();
                summary.min_dt = 0.0;
                write_summary(dir, &summary)?;
                return Err(e);
            }
        },
    };
    let interval = sim.case.output.interval;
    let mut next_output = interval;
    let mut last_row_written = true;
    if let Some(c) = &resumed {
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
        checkpoints = Some(crate::checkpoint::Checkpoints::create(dir, schedule, next, last)?);
    }
    write_file(&dir.join("case.ron"), &sim.case.to_ron())?;
    let has_bodies = !sim.bodies().is_empty();
    let (mut csv, mut bodies) = match &resumed {
        None => {
            let csv = Diagnostics::create(dir.join("diagnostics.csv"))?;
            let mut bodies = if has_bodies { Some(BodiesCsv::create(dir.join("bodies.csv"))?) } else { None };
            if let Some(b) = bodies.as_mut() {
                b.write(&sim)?;
            }
            (csv, bodies)
        }
        Some(c) => {
            let r = &c.runner;
            summary.restarted_from = Some(c.path.display().to_string());
            summary.steps = sim.steps;
            summary.simulated_time = sim.time;
            summary.max_divergence = r.max_divergence;
            summary.max_volume_fraction_error = r.max_volume_fraction_error;
            summary.pressure_iterations_total = r.pressure_iterations_total;
            summary.min_dt = r.min_dt;
            summary.last_dt_limit = r.last_dt_limit.clone();
            next_output = if c.case.output.interval == interval {
                r.next_output
            } else if interval > 0.0 {
                crate::checkpoint::next_after(sim.time, interval)
            } else {
                0.0
            };
            last_row_written = r.last_row_written;
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
            let csv = Diagnostics::resume(dir.join("diagnostics.csv"), source("diagnostics.csv").as_deref(), keep)?;
            let bodies = if has_bodies {
                Some(BodiesCsv::resume(dir.join("bodies.csv"), source("bodies.csv").as_deref(), keep)?)
            } else {
                None
            };
            (csv, bodies)
        }
    };
    let mut writers = crate::output::writers(&sim, dir)?;
    if !writers.is_empty() {
        sim.refresh_grid_state()?;
    }
    for w in &mut writers {
        w.start(&sim)?;
    }
    let bound = ENERGY_GROWTH * reference_energy(&sim);
    let theta_bound = sim.case.pressure.is_some().then_some(sim.case.coupling.max_volume_fraction_error);
    let has_disks = sim.case.fields.iter().any(|f| {
        matches!(&f.region, crate::core::case::Region::Bodies(b)
            if b.iter().any(|b| matches!(b.shape, crate::core::case::BodyShape::Disk { .. })))
    });
    summary.initial_kinetic_energy = sim.initial_energy;
    summary.final_kinetic_energy = if sim.steps > 0 { sim.last.kinetic_energy } else { sim.initial_energy };
    summary.kinetic_energy_bound = bound;

    let time = sim.case.time.clone();
    let show_bar = !options.quiet && std::io::stdout().is_terminal();
    let bar = progress_bar(show_bar, time.end);
    let start = Instant::now();
    let mut last_draw = start;
    let mut status = Status::Completed;
    let done = |t: Real| t >= time.end * (1.0 - 1e-12);
    let runner_state =
        |summary: &Summary, next_output: Real, last_row_written: bool, rows: u64| crate::checkpoint::RunnerState {
            next_output,
            last_row_written,
            diagnostics_rows: rows,
            max_divergence: summary.max_divergence,
            max_volume_fraction_error: summary.max_volume_fraction_error,
            pressure_iterations_total: summary.pressure_iterations_total,
            min_dt: summary.min_dt,
            last_dt_limit: summary.last_dt_limit.clone(),
            next_checkpoint: 0.0,
        };
    let steps_at_start = sim.steps;
    while !done(sim.time) {
        if let Some(max) = time.max_steps {
            if sim.steps >= max {
                summary.reason =
                    format!("stopped by time.max_steps = {max} at t = {} (time.end = {})", sim.time, time.end);
                break;
            }
        }
        let (dt, limit) = sim.choose_dt();
        let last_step = dt >= (time.end - sim.time) * (1.0 - 1e-9);
        if (dt < time.min_dt || dt.is_nan()) && !last_step {
            status = Status::Unstable(format!(
                "Δt = {dt:e} (limited by {limit}) fell below time.min_dt = {:e} at step {}, t = {}",
                time.min_dt,
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
        summary.steps = d.step;
        summary.simulated_time = d.time;
        summary.final_kinetic_energy = d.kinetic_energy;
        summary.max_divergence = summary.max_divergence.max(d.max_divergence);
        // NaN where Σθ is not computed (a field that steps alone): `null` in summary.json
        summary.max_volume_fraction_error = if d.volume_fraction_error.is_nan() {
            Real::NAN
        } else {
            summary.max_volume_fraction_error.max(d.volume_fraction_error)
        };
        summary.pressure_iterations_total += d.pressure_iterations as u64;
        summary.min_dt = summary.min_dt.min(d.dt);
        summary.last_dt_limit = d.dt_limit.clone();

        let unstable = if !d.kinetic_energy.is_finite() || !d.max_speed.is_finite() {
            Some(format!(
                "non-finite solution at step {}, t = {}: kinetic energy {}, largest speed {}",
                d.step, d.time, d.kinetic_energy, d.max_speed
            ))
        } else if d.kinetic_energy > bound {
            Some(format!(
                "kinetic energy {:e} at step {}, t = {} exceeds the bound {bound:e} \
                 ({ENERGY_GROWTH:e} × the reference energy; see `multifield::run`): reduce time.cfl or time.fixed_dt",
                d.kinetic_energy, d.step, d.time
            ))
        } else if let Some(theta) =
            theta_bound.filter(|&b| d.volume_fraction_error.is_nan() || d.volume_fraction_error > b)
        {
            Some(format!(
                "max |Σθ − 1| = {:.4e} at step {}, t = {} exceeds coupling.max_volume_fraction_error = {theta}: \
                 the fields no longer fill the space; reduce time.cfl, raise points_per_cell or \
                 coupling.volume_fraction_relaxation",
                d.volume_fraction_error, d.step, d.time
            ))
        } else if has_disks {
            body_overlap(&sim)
        } else {
            None
        };
        let due = interval <= 0.0 || d.time >= next_output * (1.0 - 1e-9) || unstable.is_some() || done(d.time);
        if due {
            csv.write(&d)?;
            if let Some(b) = bodies.as_mut() {
                b.write(&sim)?;
            }
            if interval > 0.0 {
                while next_output <= d.time * (1.0 + 1e-9) {
                    next_output += interval;
                }
            }
        }
        last_row_written = due;
        let last = unstable.is_some() || done(d.time) || time.max_steps.is_some_and(|m| sim.steps >= m);
        if sim.grid_state_stale() && writers.iter().any(|w| w.due(&sim, last)) {
            sim.refresh_grid_state()?;
        }
        for w in &mut writers {
            w.after_step(&sim, last)?;
        }
        if let Some(reason) = unstable {
            status = Status::Unstable(reason);
            break;
        }
        if let Some(c) = checkpoints.as_mut() {
            if c.due(sim.time) {
                // a checkpoint holds the grid state too: the same bits whenever it was written
                sim.refresh_grid_state()?;
                let state = runner_state(&summary, next_output, last_row_written, csv.rows);
                summary.last_checkpoint = Some(c.write(&sim, &state)?.display().to_string());
            }
        }
        let now = Instant::now();
        if now.duration_since(last_draw) > Duration::from_millis(200) {
            if show_bar && bar.is_hidden() && now.duration_since(start) > Duration::from_millis(500) {
                bar.set_draw_target(ProgressDrawTarget::stdout());
            }
            let rate = (sim.steps - steps_at_start) as f64 / now.duration_since(start).as_secs_f64();
            bar.set_position((1000.0 * (sim.time / time.end)).clamp(0.0, 1000.0) as u64);
            bar.set_message(format!("t = {:.4e} / {} | {rate:.0} steps/s", sim.time, time.end));
            last_draw = now;
        }
    }
    bar.finish_and_clear();
    let state = runner_state(&summary, next_output, last_row_written, csv.rows);
    if !last_row_written && sim.steps > 0 {
        // the last step is always in the file, whatever the interval or why the run stopped
        csv.write(&sim.last)?;
        if let Some(b) = bodies.as_mut() {
            b.write(&sim)?;
        }
    }
    // a run that completed (or stopped at time.max_steps) ends with a checkpoint, to be
    // extended with a later time.end; one that blew up keeps its last good one
    if let Some(c) = checkpoints.as_mut() {
        if status == Status::Completed && sim.steps > 0 && c.last_step() != Some(sim.steps) {
            sim.refresh_grid_state()?;
            summary.last_checkpoint = Some(c.write(&sim, &state)?.display().to_string());
        }
    }
    summary.wall_seconds = start.elapsed().as_secs_f64();
    summary.diagnostics_rows = csv.rows;
    if summary.steps == 0 {
        summary.min_dt = 0.0;
    }
    summary.status = status.label().into();
    if status != Status::Completed {
        summary.reason = status.reason().into();
    }
    summary.warnings = sim.warnings();
    if !options.quiet {
        for w in &summary.warnings {
            eprintln!("warning: {w}");
        }
    }
    write_summary(dir, &summary)?;
    if sim.case.output.charts {
        crate::charts::write(dir)?;
    }
    Ok(Outcome { status, summary, output_dir: dir.to_path_buf() })
}
