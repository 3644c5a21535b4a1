//! The `multifield` command line: run, check and describe cases, list the plugins.
//!
//! Exit codes: 0 the run completed (or the check passed), 1 the run ended unstable or
//! failed, 2 bad input (the case file, an override, the command line).
//!
//! A program that links more plugins calls [`main`] after their `link()` functions and
//! gets the same command line with its plugins registered:
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     // my_plugins::link();
//!     multifield::cli::main()
//! }
//! ```

use crate::core::boundary::Side;
use crate::core::case::{Case, Region, Representation};
use crate::core::error::Error;
use crate::core::generate::Generated;
use crate::core::limits::{self, MemoryEstimate, MemoryLimit};
use crate::core::registry::{self, Role};
use crate::core::simulation::{Simulation, Status};
use crate::run::{self, RunOptions};
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Multifield (multiphase) flow: every field picks an Eulerian or Lagrangian frame;
/// stress, exchange and pressure are plugins. With no command, runs the built-in
/// drafting–kissing–tumbling of two disks (examples/dkt_seed.ron) into out/dkt_seed/.
#[derive(Parser)]
#[command(name = "multifield", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case; writes case.ron, diagnostics.csv and summary.json.
    Run {
        /// The case file (RON).
        case: PathBuf,
        /// Output directory [default: out/<case name>].
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Worker threads, at most 1024 [default: all cores].
        #[arg(long, short = 'j', default_value_t = 0, hide_default_value = true, value_parser = thread_count)]
        threads: usize,
        /// Override an entry: `--set time.end=0.5`, `--set fields.water.density=1.2`.
        #[arg(long = "set", value_name = "PATH=VALUE")]
        overrides: Vec<String>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
        /// Continue from a checkpoint (DIR/checkpoints/checkpoint_<step>.bin, written when the
        /// case has `output.checkpoints`) instead of starting at t = 0; the case may differ
        /// from the checkpoint's only in time.*, output.*, description, monitors and stop.
        #[arg(long, value_name = "FILE")]
        restart: Option<PathBuf>,
        /// The most memory the run may use, e.g. 8GB or 8GiB [default: $MULTIFIELD_MAX_MEMORY,
        /// else the memory available now]; a case estimated above it is refused.
        #[arg(long, value_name = "SIZE")]
        max_memory: Option<String>,
    },
    /// Parse, validate and build every plugin of a case without stepping; describe it, with
    /// its memory and an estimate of its run time (timed on a coarsened copy, which writes
    /// nothing).
    Check {
        /// The case file (RON).
        case: PathBuf,
        /// Override an entry, as for `run`.
        #[arg(long = "set", value_name = "PATH=VALUE")]
        overrides: Vec<String>,
        /// Worker threads the time estimate is measured on, as for `run` [default: all cores].
        #[arg(long, short = 'j', default_value_t = 0, hide_default_value = true, value_parser = thread_count)]
        threads: usize,
        /// The most memory a run may use, as for `run`.
        #[arg(long, value_name = "SIZE")]
        max_memory: Option<String>,
    },
    /// List every registered plugin by role, with its parameters, units and defaults.
    Plugins,
    /// List every output quantity that snapshots and pictures accept: where it is
    /// defined (the mixture's cells, a field's cells, points), its units and formula.
    Quantities,
    /// Run a scene with its bodies resolved and again as single mass points; report the
    /// kiss and tumble times, settling speeds, their differences and the cost of each, and
    /// overlay the trajectories (PNG and SVG).
    Compare {
        /// The case file (RON) with a body list.
        case: PathBuf,
        /// Override an entry of both runs, as for `run`.
        #[arg(long = "set", value_name = "PATH=VALUE")]
        overrides: Vec<String>,
        /// Override an entry of the point run only, e.g. a coarser grid:
        /// `--point-set 'domain.cells=(20, 80)'`.
        #[arg(long = "point-set", value_name = "PATH=VALUE")]
        point_overrides: Vec<String>,
        /// Output directory [default: out/compare_<case name>].
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Worker threads, at most 1024 [default: all cores].
        #[arg(long, short = 'j', default_value_t = 0, hide_default_value = true, value_parser = thread_count)]
        threads: usize,
        /// Folder of the reference curves, laid out as validation/reference/dkt-uhlmann2005
        /// [default: that folder's curves, built into multifield].
        #[arg(long, value_name = "DIR")]
        reference: Option<PathBuf>,
        /// The most memory a run may use, as for `run`.
        #[arg(long, value_name = "SIZE")]
        max_memory: Option<String>,
    },
    /// Drafting–kissing–tumbling analysis of finished two-disk runs: kiss and tumble
    /// times, RMS distance to Uhlmann (2005), and trajectory plots (PNG and SVG) against
    /// the published curves. One run: written into its directory. Several runs of one
    /// scene (a resolution study, resolved against point bodies): one table and one chart.
    Dkt {
        /// The runs' output directories (with case.ron and bodies.csv).
        #[arg(required = true)]
        runs: Vec<PathBuf>,
        /// Folder of the reference curves, laid out as validation/reference/dkt-uhlmann2005
        /// [default: that folder's curves, built into multifield].
        #[arg(long, value_name = "DIR")]
        reference: Option<PathBuf>,
        /// Where the charts of several runs go [default: out/dkt_compare].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Run a study (docs/studies.md): every combination of the study file's axes, in
    /// parallel, resumable; writes results.csv and the charts (PNG and SVG).
    Study {
        /// The study file (RON).
        study: PathBuf,
        /// Runs at a time, at most 1024 [default: cores / threads per run].
        #[arg(long, short = 'j', default_value_t = 0, hide_default_value = true, value_parser = thread_count)]
        jobs: usize,
        /// Output directory [default: out/studies/<study name>].
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Worker threads of each run, at most 1024.
        #[arg(long, default_value_t = 1, value_parser = thread_count)]
        threads_per_run: usize,
        /// Only the combinations with this label on this axis (repeatable; several labels
        /// of one axis: any of them), e.g. `--only representation=resolved`.
        #[arg(long, value_name = "AXIS=LABEL")]
        only: Vec<String>,
        /// No progress bar and no line per run.
        #[arg(long, short)]
        quiet: bool,
        /// The most runs the study may have (the product of its axes' lengths).
        #[arg(long, value_name = "N", default_value_t = crate::study::MAX_RUNS)]
        max_runs: u64,
        /// The most memory each run may use, as for `run`.
        #[arg(long, value_name = "SIZE")]
        max_memory: Option<String>,
        /// Slurm: where the runs go, and the parts of a study on a cluster.
        #[command(flatten)]
        cluster: crate::slurm::ClusterArgs,
    },
    /// Check the MPI setup for decomposed runs: run it under `mpirun -np N`. Cuts a grid
    /// into N blocks, exchanges and checks their halos, checks that an exact sum split
    /// across the ranks has the serial sum's bits; prints the rank grid and pass or fail
    /// (exit status 1 on fail).
    #[cfg(feature = "mpi")]
    MpiCheck {
        /// Cells of the grid: `64x64`, or `64x32x32` in 3D.
        #[arg(long, default_value = "64x64")]
        cells: String,
        /// The rank grid, e.g. `2x2` [default: the one of least halo surface].
        #[arg(long)]
        ranks: Option<String>,
        /// The periodic axes, comma-separated (`x,y`), or `none`.
        #[arg(long, default_value = "x")]
        periodic: String,
    },
}

/// The command's name on the command line.
#[cfg(all(feature = "mpi", feature = "dim2"))]
fn command_name(command: &Option<Command>) -> &'static str {
    match command {
        None => "multifield (the built-in case)",
        Some(Command::Run { .. }) => "run",
        Some(Command::Check { .. }) => "check",
        Some(Command::Plugins) => "plugins",
        Some(Command::Quantities) => "quantities",
        Some(Command::Compare { .. }) => "compare",
        Some(Command::Dkt { .. }) => "dkt",
        Some(Command::Study { .. }) => "study",
        Some(Command::MpiCheck { .. }) => "mpi-check",
    }
}

/// Under `mpirun -np N` with N > 1 every command but `mpi-check` and `run` of a 2D case is
/// refused before it reads anything (docs/design/mpi.md §7): rank 0 says why, every rank
/// exits with 2. (A 2D case that is not decomposed is refused by `Simulation::with_comm`.)
#[cfg(all(feature = "mpi", feature = "dim2"))]
fn refuse_on_ranks(cli: &Cli, ranks: usize) -> String {
    let command = &cli.command;
    match command {
        Some(Command::Run { .. }) => format!(
            "error: run: a 3D case on {ranks} ranks is not decomposed yet (issue 19: 2D cases with Eulerian fields \
             run on several ranks so far); run this case on one process (`multifield run`, or `mpirun -np 1`)"
        ),
        c => format!(
            "error: {}: runs on one process; under mpirun with {ranks} ranks every rank would run it whole: run it \
             without mpirun (or with `mpirun -np 1`); `multifield mpi-check` is the command to run on many ranks",
            command_name(c)
        ),
    }
}

/// A count of threads (or of runs at a time) from the command line: at most
/// [`run::MAX_THREADS`].
fn thread_count(text: &str) -> Result<usize, String> {
    let n: usize = text.trim().parse().map_err(|e| format!("`{text}` is not a count of threads: {e}"))?;
    if n > run::MAX_THREADS {
        return Err(format!(
            "{n} threads: at most {}; 0 uses every core (this machine has {})",
            run::MAX_THREADS,
            std::thread::available_parallelism().map_or(1, |n| n.get())
        ));
    }
    Ok(n)
}

/// Why the command stopped.
enum Failure {
    /// Bad input: exit code 2.
    Input(Error),
    /// The run or its output failed: exit code 1.
    Run(String),
    /// Interrupted by a signal, the output of the steps taken written: exit code 130
    /// (128 + SIGINT, as a shell reports it).
    Interrupted(String),
}

impl From<Error> for Failure {
    /// Errors of reading and checking a case are bad input.
    fn from(e: Error) -> Self {
        Failure::Input(e)
    }
}

/// Parses the command line and runs it; links the shipped frames and physics first.
pub fn main() -> ExitCode {
    // Output piped into `head` and closed early ends the program quietly, as any Unix
    // tool does, instead of a panic on the failed write.
    #[cfg(unix)]
    // SAFETY: restoring the default action of SIGPIPE at start-up, before any thread exists
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    // under MPI (cargo feature `mpi`): initialized once per process, before the 3D dispatch;
    // finalized when `mpi_session` drops at the end of `main`
    #[cfg(all(feature = "mpi", feature = "dim2"))]
    let mpi_session = match crate::mpi::start() {
        Ok(session) => session,
        Err(m) => {
            eprintln!("error: {m}");
            return ExitCode::from(1);
        }
    };
    #[cfg(all(feature = "mpi", feature = "dim2"))]
    {
        use crate::core::parallel::Comm;
        if let Some(Command::MpiCheck { cells, ranks, periodic }) = &cli.command {
            return crate::mpi::check_command(&mpi_session.comm, cells, ranks.as_deref(), periodic);
        }
        let size = mpi_session.comm.size();
        let decomposed = matches!(cli.command, Some(Command::Run { .. })) && dimension_of(&cli) != Some(3);
        if size > 1 && !decomposed {
            if mpi_session.comm.rank() == 0 {
                eprintln!("{}", refuse_on_ranks(&cli, size));
            }
            return ExitCode::from(2);
        }
    }
    // the ranks of a decomposed `run` (rank 0 writes the output and the messages)
    #[cfg(all(feature = "mpi", feature = "dim2"))]
    let ranks = {
        use crate::core::parallel::Comm;
        (mpi_session.comm.size() > 1)
            .then(|| run::Ranks(std::sync::Arc::new(crate::core::parallel::Counted::new(mpi_session.comm.clone()))))
    };
    #[cfg(not(all(feature = "mpi", feature = "dim2")))]
    let ranks: Option<run::Ranks> = None;
    let quiet_rank = ranks.as_ref().is_some_and(|r| r.rank() != 0);
    // a 3D case runs in the 3D compile of this library, which parses the same command line
    #[cfg(feature = "dim2")]
    if dimension_of(&cli) == Some(3) {
        return multifield3d::cli::main();
    }
    #[cfg(feature = "dim2")]
    if let Some(Command::Study { study, .. }) = &cli.command {
        if study_dimension(study) == Some(3) {
            eprintln!(
                "error: {}: its base case is a 3D case (domain.cells has 3 numbers); studies run 2D cases only so \
                 far: run the 3D cases with `multifield run`",
                study.display()
            );
            return ExitCode::from(2);
        }
    }
    crate::link_all();
    if let Err(e) = crate::run::catch_signals() {
        eprintln!("warning: {e}; an interrupt will end the process without a summary");
    }
    let result = match cli.command {
        None => {
            let file = Path::new(crate::DEFAULT_CASE_FILE);
            Case::from_ron(crate::DEFAULT_CASE, file)
                .and_then(|c| c.validate().map_err(|e| e.in_file(file)).map(|_| c))
                .map_err(Failure::from)
                .and_then(|case| {
                    println!("running the built-in case {} ({})", case.name, file.display());
                    let options = RunOptions { case_file: Some(file.to_path_buf()), ..RunOptions::default() };
                    run_case(&case, file, None, &options)?;
                    let dir = Path::new("out").join(run::directory_name(&case.name));
                    dkt(&[dir], None, None)
                })
        }
        Some(Command::Run { case, out, threads, overrides, quiet, restart, max_memory }) => load(&case, &overrides)
            .and_then(|(c, _)| {
                resources(&c, &case, &max_memory)?;
                let ranks = ranks.clone();
                run_case(&c, &case, out, &RunOptions { threads, quiet, restart, case_file: Some(case.clone()), ranks })
            }),
        Some(Command::Check { case, overrides, threads, max_memory }) => {
            load(&case, &overrides).and_then(|(c, generated)| check(&c, &generated, &case, threads, &max_memory))
        }
        Some(Command::Plugins) => {
            plugins();
            Ok(())
        }
        Some(Command::Quantities) => {
            quantities();
            Ok(())
        }
        Some(Command::Dkt { runs, reference, out }) => dkt(&runs, reference, out),
        Some(Command::Compare { case, overrides, point_overrides, out, threads, reference, max_memory }) => {
            load(&case, &overrides).and_then(|(c, _)| {
                resources(&c, &case, &max_memory)?;
                let options =
                    RunOptions { threads, quiet: true, restart: None, case_file: Some(case.clone()), ranks: None };
                compare(&c, &case, &point_overrides, out, &options, reference)
            })
        }
        Some(Command::Study { study, jobs, out, threads_per_run, only, quiet, max_runs, max_memory, cluster }) => {
            let options = crate::study::StudyOptions { jobs, threads_per_run, quiet };
            memory_limit(&max_memory).and_then(|memory| {
                let limits = crate::study::Limits { max_runs, memory };
                run_study(&study, out, &only, &options, &limits, &cluster, &max_memory)
            })
        }
        // handled with MPI's start in the 2D program, which dispatches a 3D grid itself
        #[cfg(feature = "mpi")]
        Some(Command::MpiCheck { .. }) => Err(Failure::Run("mpi-check is run by the 2D program's start-up".into())),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // every rank of a decomposed run ends alike; rank 0 says why
        Err(Failure::Input(_)) if quiet_rank => ExitCode::from(2),
        Err(Failure::Run(_)) if quiet_rank => ExitCode::from(1),
        Err(Failure::Interrupted(_)) if quiet_rank => ExitCode::from(130),
        Err(Failure::Input(e)) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
        Err(Failure::Run(m)) => {
            eprintln!("error: {m}");
            ExitCode::from(1)
        }
        Err(Failure::Interrupted(m)) => {
            eprintln!("{m}");
            ExitCode::from(130)
        }
    }
}

/// The dimension of the case a command runs or checks ([`case::dimension`]: the count of
/// its `domain.cells`, overrides included); `None` for the commands without a case, and
/// when the file cannot be read or parsed that far (the 2D library then says why).
#[cfg(feature = "dim2")]
fn dimension_of(cli: &Cli) -> Option<usize> {
    let (file, overrides) = match &cli.command {
        Some(Command::Run { case, overrides, .. })
        | Some(Command::Check { case, overrides, .. })
        | Some(Command::Compare { case, overrides, .. }) => (case, overrides),
        _ => return None,
    };
    let text = crate::core::input::read_text(file).ok()?;
    crate::core::case::dimension(&text, overrides)
}

/// The dimension of a study's base case (with the study's `set` overrides); `None` when
/// the study or its base cannot be read that far (the study's loading then says why).
#[cfg(feature = "dim2")]
fn study_dimension(file: &Path) -> Option<usize> {
    let text = crate::core::input::read_text(file).ok()?;
    let study = crate::study::Study::from_ron(&text, file).ok()?;
    let base = file.parent().unwrap_or(Path::new(".")).join(&study.base);
    crate::core::case::dimension(&crate::core::input::read_text(&base).ok()?, &study.set)
}

/// Reads, overrides and validates a case file, and turns its `generate` entries into
/// bodies (once: the run, its `case.ron` and its checkpoints hold the bodies).
fn load(file: &Path, overrides: &[String]) -> Result<(Case, Vec<Generated>), Failure> {
    let case = Case::load(file, overrides)?;
    if !case.has_generators() {
        return Ok((case, Vec::new()));
    }
    let (expanded, generated) = case.expand_generators().map_err(|e| Failure::Input(e.in_file(file)))?;
    Ok((expanded, generated))
}

/// The memory a case may use: `--max-memory`, else `MULTIFIELD_MAX_MEMORY`, else what the
/// machine has available.
fn memory_limit(option: &Option<String>) -> Result<MemoryLimit, Failure> {
    let bytes = option
        .as_deref()
        .map(|s| limits::parse_bytes(s).map_err(|m| Failure::Input(Error::Model(format!("--max-memory {s}: {m}")))))
        .transpose()?;
    MemoryLimit::resolve(bytes).map_err(|m| Failure::Input(Error::Model(m)))
}

/// Refuses a case beyond the caps or the memory limit, before anything is allocated.
fn resources(case: &Case, file: &Path, option: &Option<String>) -> Result<(MemoryEstimate, MemoryLimit), Failure> {
    let limit = memory_limit(option)?;
    let estimate = case.check_resources(&limit).map_err(|e| Failure::Input(e.in_file(file)))?;
    Ok((estimate, limit))
}

fn run_case(case: &Case, file: &Path, out: Option<PathBuf>, options: &RunOptions) -> Result<(), Failure> {
    let dir = out.unwrap_or_else(|| Path::new("out").join(run::directory_name(&case.name)));
    // a case that cannot start is bad input; an output file that cannot be written is not
    let outcome = run::run(case, &dir, options).map_err(|e| match e {
        Error::Io { .. } => Failure::Run(e.to_string()),
        e => Failure::Input(e.in_file(file)),
    })?;
    let s = &outcome.summary;
    let report = options.ranks.as_ref().is_none_or(|r| r.rank() == 0);
    if !report {
        // (the other ranks of a decomposed run: rank 0 reports, and their outcome is its)
        return status_result(outcome.status);
    }
    println!(
        "{}: {} steps to t = {} in {:.2} s on {} thread{} (final kinetic energy {:.6e}, max divergence {:.2e})",
        s.status,
        s.steps,
        s.simulated_time,
        s.wall_seconds,
        s.threads,
        if s.threads == 1 { "" } else { "s" },
        s.final_kinetic_energy,
        s.max_divergence
    );
    if let Some(from) = &s.restarted_from {
        println!("  continued from the checkpoint {from}");
    }
    if !s.reason.is_empty() {
        println!("  {}", s.reason);
    }
    if let Some(c) = &s.last_checkpoint {
        println!("  last checkpoint: {c} (continue with --restart {c})");
    }
    let files = [
        "case.ron",
        "diagnostics.csv",
        "summary.json",
        "bodies.csv",
        "monitors/",
        "snapshots/",
        "frames/",
        "checkpoints/",
    ];
    let written: Vec<&str> = files.into_iter().chain(["charts/"]).filter(|f| dir.join(f).exists()).collect();
    println!("output: {}/ ({})", dir.display(), written.join(", "));
    status_result(outcome.status)
}

/// A run's status as the command's result.
fn status_result(status: Status) -> Result<(), Failure> {
    match status {
        Status::Completed => Ok(()),
        Status::Unstable(r) => Err(Failure::Run(format!("the run became unstable: {r}"))),
        Status::Failed(r) => Err(Failure::Run(format!("the run failed: {r}"))),
        Status::Interrupted(r) => Err(Failure::Interrupted(format!("the run was {r}"))),
    }
}

fn region_text(r: &Region) -> String {
    match r {
        Region::All => "the whole domain".into(),
        Region::Rest => "what the other fields leave".into(),
        Region::Rectangle { min, max } => format!("rectangle {min:?}–{max:?}"),
        Region::Disk { center, radius } => format!("disk at {center:?}, radius {radius}"),
        #[cfg(feature = "dim3")]
        Region::Box { min, max } => format!("box {min:?}–{max:?}"),
        #[cfg(feature = "dim3")]
        Region::Sphere { center, radius } => format!("sphere at {center:?}, radius {radius}"),
        Region::Bodies(bodies) => format!(
            "{} bod{} ({}{})",
            bodies.len(),
            if bodies.len() == 1 { "y" } else { "ies" },
            bodies
                .iter()
                .take(SHOWN_BODIES)
                .map(|b| match b.density {
                    Some(rho) => format!("{} of density {rho}", b.name),
                    None => b.name.clone(),
                })
                .collect::<Vec<_>>()
                .join(", "),
            if bodies.len() > SHOWN_BODIES {
                format!(", … {} more", bodies.len() - SHOWN_BODIES)
            } else {
                String::new()
            }
        ),
    }
}

fn params_text(v: &serde_json::Value) -> String {
    match v.as_object() {
        Some(m) if m.is_empty() => String::new(),
        Some(m) => format!("({})", m.iter().map(|(k, v)| format!("{k}: {v}")).collect::<Vec<_>>().join(", ")),
        None if v.is_null() => String::new(),
        None => v.to_string(),
    }
}

/// Bodies named in `check`'s description of a region.
const SHOWN_BODIES: usize = 8;

/// Seconds of wall time the calibration of `check`'s time estimate steps for (the case's
/// calibration grid; the grid of half its cells gets a quarter of it).
pub const CALIBRATION_BUDGET: f64 = 0.5;

/// A duration for people: "0.8 s", "27 min", "3.2 h", "2.1 days".
pub fn duration_text(seconds: f64) -> String {
    if !seconds.is_finite() {
        "an unbounded time".into()
    } else if seconds < 0.1 {
        format!("{} ms", significant(seconds * 1e3))
    } else if seconds < 100.0 {
        format!("{} s", significant(seconds))
    } else if seconds < 6000.0 {
        format!("{} min", significant(seconds / 60.0))
    } else if seconds < 48.0 * 3600.0 {
        format!("{} h", significant(seconds / 3600.0))
    } else {
        format!("{} days", significant(seconds / 86400.0))
    }
}

/// Two significant digits (no exponent).
fn significant(x: f64) -> String {
    if x >= 10.0 {
        format!("{:.0}", x)
    } else if x >= 1.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.2}")
    }
}

/// `check`'s line of the time a run takes ([`limits::time_estimate`]).
pub fn time_text(e: &limits::TimeEstimate) -> String {
    let c = &e.calibration;
    let grid = |n: &[usize]| n.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(" × ");
    let scaled = e.cells as f64 / c.cell_count() as f64;
    let pressure = if c.pressure_share > 0.0 {
        let growth = match &e.half {
            Some(h) => format!(
                ", its iterations {:.1} there and {:.1} on {} cells: growing as n^{:.2} with the cells n along an axis",
                c.iterations,
                h.iterations,
                grid(&h.cells),
                e.growth
            ),
            None => format!(", {:.1} iterations", c.iterations),
        };
        format!(", {:.0} % of it in the pressure solve{growth}", 100.0 * c.pressure_share)
    } else {
        String::new()
    };
    format!(
        "about {} steps × {} ≈ {} on {} thread{} of this machine (a step timed on {} cells: {} over {} steps{pressure}; \
         scaled by the cells, × {}); the steps keep the first Δt {:.3e} ({}) to the end: the flow may change it",
        limits::group(e.steps),
        duration_text(e.seconds_per_step),
        duration_text(e.seconds()),
        e.threads,
        if e.threads == 1 { "" } else { "s" },
        grid(&c.cells),
        duration_text(c.seconds_per_step),
        c.steps,
        if scaled >= 10.0 { format!("{scaled:.0}") } else { format!("{scaled:.2}") },
        e.first_dt.0,
        e.first_dt.1
    )
}

fn check(
    case: &Case,
    generated: &[Generated],
    file: &Path,
    threads: usize,
    max_memory: &Option<String>,
) -> Result<(), Failure> {
    // the estimate and the caps before anything is allocated
    let (estimate, allowed) = resources(case, file, max_memory)?;
    let sim = Simulation::new(case).map_err(|e| Failure::Input(e.in_file(file)))?;
    let c = &sim.case;
    let g = &sim.grid;
    println!("{}: {} is valid", file.display(), c.name);
    if !c.description.is_empty() {
        println!("  {}", c.description.trim());
    }
    let times = |v: Vec<String>| v.join(" × ");
    println!(
        "domain   {} from {:?}, {} cells of h = {}",
        times(c.domain.size.iter().map(|s| s.to_string()).collect()),
        c.domain.origin,
        times(g.n().iter().map(|n| n.to_string()).collect()),
        g.h
    );
    let b = &c.boundaries;
    let sides: Vec<String> = Side::ALL.iter().map(|&s| format!("{} {:?}", s.name(), b.side(s))).collect();
    println!("sides    {}", sides.join(", "));
    println!("gravity  {:?}", c.gravity);
    let t = &c.time;
    println!(
        "time     end {}, cfl {}, max_dt {}{}{}{}",
        t.end,
        t.cfl,
        t.max_dt,
        t.fixed_dt.map(|d| format!(", fixed_dt {d}")).unwrap_or_default(),
        t.max_steps.map(|n| format!(", max_steps {n}")).unwrap_or_default(),
        if t.contact_substeps { ", contact_substeps (contact in sub-steps; not a Δt limit)" } else { "" }
    );
    for (spec, f) in c.fields.iter().zip(&sim.fields) {
        let frame = if spec.representation == Representation::MassPoint {
            "mass points (one per disk; representation MassPoint)".to_string()
        } else {
            format!("{} frame {}", spec.frame.model, params_text(&spec.frame.params))
        };
        println!(
            "field    {}: density {}, {frame}, {}, mass {:.6e}",
            spec.name,
            spec.density,
            region_text(&spec.region),
            f.frame.mass()
        );
        for s in &spec.stress {
            println!("           stress {} {}", s.model, params_text(&s.params));
        }
    }
    for g in generated {
        let [lo, mean, hi] = g.diameters;
        println!(
            "bodies   {}: {} disks `{}0`…, diameters {lo:.6}–{hi:.6} (mean {mean:.6}); solid fraction {:.6} of \
             its region, {:.6} of the domain; smallest gap {} between its disks, {:.6} to the domain's sides",
            g.path,
            g.count,
            g.name,
            g.region_fraction,
            g.domain_fraction,
            g.smallest_gap.map_or("none (one disk)".to_string(), |x| format!("{x:.6}")),
            g.wall_gap
        );
    }
    for e in &c.exchange {
        let points = c.fields.iter().any(|f| f.name == e.between[1] && f.representation == Representation::MassPoint);
        let (model, params) = match (&e.mass_point, points) {
            (Some(m), true) => (format!("{} (the mass points' drag law)", m.model), &m.params),
            _ => (e.model.clone(), &e.params),
        };
        println!("exchange {} – {}: {model} {} ({:?})", e.between[0], e.between[1], params_text(params), e.integration);
    }
    for w in sim.warnings() {
        println!("warning  {w}");
    }
    match &c.pressure {
        Some(p) => println!("pressure {} {}", p.model, params_text(&p.params)),
        None => println!("pressure none (no incompressibility constraint)"),
    }
    // the time: the planned steps, and a step timed on a coarsened copy (which writes nothing)
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Failure::Run(format!("cannot start {threads} worker threads: {e}")))?;
    let timing = pool.install(|| limits::time_estimate(&sim, CALIBRATION_BUDGET));
    let (steps, dt, limit) = match &timing {
        Ok(e) => (e.steps, e.first_dt.0, e.first_dt.1.clone()),
        Err(_) => sim.planned_steps(limits::WALKED_STEPS),
    };
    println!(
        "start    kinetic energy {:.6e}; first Δt {:.3e} (limited by {limit}), about {} steps to t = {}{}",
        sim.initial_energy,
        dt,
        limits::group(steps),
        t.end,
        match t.max_steps {
            Some(m) if steps >= m => format!(" (time.max_steps = {m} ends it before)"),
            _ => String::new(),
        }
    );
    match &timing {
        Ok(e) => println!("time     {}", time_text(e)),
        Err(e) => println!("time     not estimated: {e}"),
    }
    println!(
        "output   a diagnostics row every {}",
        if c.output.interval > 0.0 { format!("{} of simulated time", c.output.interval) } else { "step".into() }
    );
    let names = |v: &[crate::core::case::QuantityName]| v.iter().map(|q| q.as_str()).collect::<Vec<_>>().join(", ");
    // "every 0.1", "at t = 0.5, 1, at the end", …
    let when = |interval: crate::core::math::Real, times: &[crate::core::math::Real], at_end: bool| {
        let mut parts = Vec::new();
        if interval > 0.0 {
            parts.push(format!("every {interval}"));
        }
        if !times.is_empty() {
            let list: Vec<String> = times.iter().map(|t| t.to_string()).collect();
            parts.push(format!("at t = {}", list.join(", ")));
        }
        if at_end && interval == 0.0 {
            parts.push("at the end".to_string());
        }
        parts.join(", ")
    };
    if let Some(s) = &c.output.snapshots {
        println!(
            "output   a snapshot {} (mixture: {}; each field: {}; points: {})",
            when(s.interval, &s.times, s.at_end),
            names(&s.mixture),
            names(&s.fields),
            names(&s.points)
        );
    }
    if let Some(p) = &c.output.pictures {
        let (q, field) = crate::picture::picked(&sim, p).map_err(|e| Failure::Input(e.in_file(file)))?;
        let of = field.map_or("the mixture".to_string(), |k| format!("field {}", sim.fields[k].name));
        let w = when(p.interval, &p.times, p.at_end);
        let slices: Vec<String> =
            p.slice.iter().map(|s| format!("{} = {} (frames/{}/)", s.axis.name(), s.at, s.folder())).collect();
        let on = if slices.is_empty() { String::new() } else { format!(" on the planes {}", slices.join(", ")) };
        println!("output   a picture of the {} of {of} {w}, {} pixels wide{on}", q.name, p.width);
    }
    if let Some(k) = &c.output.checkpoints {
        println!("output   a checkpoint every {}", k.interval);
    }
    for m in &c.monitors {
        println!("monitor  {}: {}", m.name, m.describe());
    }
    for s in &c.stop {
        println!("stop     {}", s.describe());
    }
    if !c.stop.is_empty() {
        println!("stop     (the first condition met ends the run as completed; time.end = {} stays the bound)", t.end);
    }
    let parts: Vec<String> =
        estimate.breakdown.iter().map(|(what, b)| format!("{what} {}", limits::bytes_text(*b))).collect();
    println!(
        "memory   about {} at the peak ({} bytes: {}){}; limit: {}",
        limits::bytes_text(estimate.bytes),
        limits::group(estimate.bytes),
        parts.join(", "),
        if estimate.points > 0 { format!(", about {} material points", estimate.points) } else { String::new() },
        allowed.describe()
    );
    Ok(())
}

fn plugins() {
    for role in Role::ALL {
        let entries = registry::entries(role);
        println!("{} models ({}):", role.name(), entries.len());
        if entries.is_empty() {
            println!("  none registered");
        }
        for e in entries {
            println!("  {:<14} {}", e.name, e.summary);
            for p in e.params {
                println!("      {:<18} [{}] default {}: {}", p.name, p.unit, p.default, p.doc);
            }
        }
        println!();
    }
    // what the 3D library has (issue 17 brings the rest)
    #[cfg(feature = "dim2")]
    {
        multifield3d::link_all();
        println!("in 3D (a case whose domain.cells has 3 numbers):");
        for role in multifield3d::core::registry::Role::ALL {
            let names: Vec<&str> = multifield3d::core::registry::entries(role).iter().map(|e| e.name).collect();
            println!(
                "  {:<9} {}",
                role.name(),
                if names.is_empty() { "none yet".to_string() } else { names.join(", ") }
            );
        }
    }
}

fn quantities() {
    let all = crate::core::quantity::quantities();
    println!("output quantities ({}), for output.snapshots (mixture, fields, points) and output.pictures:", all.len());
    for q in all {
        let kind = if q.components == 3 { "×3" } else { "" };
        println!("  {:<12} {:<16} {:<3} [{}] {}", q.name, q.places(), kind, q.units, q.description);
    }
    let d = |v: &[&str]| v.join(", ");
    println!();
    println!(
        "snapshots write by default: mixture {}; fields {}; points {} (and the points' body).",
        d(&crate::core::case::DEFAULT_MIXTURE_QUANTITIES),
        d(&crate::core::case::DEFAULT_FIELD_QUANTITIES),
        d(&crate::core::case::DEFAULT_POINT_QUANTITIES)
    );
}

/// `multifield study STUDY.ron`: exit 0 when every run ended (completed, unstable or
/// failed: all data), 2 on bad input, 1 when the output cannot be written, 130 when an
/// interrupt stopped it (the same command continues it).
#[allow(clippy::too_many_arguments)]
fn run_study(
    file: &Path,
    out: Option<PathBuf>,
    only: &[String],
    options: &crate::study::StudyOptions,
    limits: &crate::study::Limits,
    cluster: &crate::slurm::ClusterArgs,
    max_memory: &Option<String>,
) -> Result<(), Failure> {
    // a task or the report builds no simulation but its own: the submission checked them all
    let part = cluster.index.is_some() || cluster.report;
    let plan = crate::study::plan_to(file, out, only, limits, !part)?;
    if let Some(i) = cluster.index {
        return study_index(&plan, i, options.threads_per_run);
    }
    if cluster.report {
        return study_report(&plan);
    }
    let spec = cluster.resolve(&plan.study.scheduler);
    if spec.kind == crate::slurm::SchedulerKind::Slurm {
        let submit = crate::slurm::Submit {
            spec,
            threads_per_run: options.threads_per_run,
            only: only.to_vec(),
            max_runs: limits.max_runs,
            max_memory: max_memory.clone(),
            wait: cluster.wait,
        };
        return study_slurm(&plan, &submit);
    }
    if !options.quiet {
        println!("study {}: {} runs (at most {} with --max-runs)", plan.study.name, plan.runs.len(), limits.max_runs);
    }
    let report = crate::study::run_study(&plan, options).map_err(|e| Failure::Run(e.to_string()))?;
    println!(
        "study {}: {} ({} run now, {} skipped as finished)",
        plan.study.name,
        counts(&report.statuses),
        report.ran,
        report.skipped
    );
    println!("results: {}", report.results.display());
    for c in &report.charts {
        println!("chart:   {} (and .svg)", c.display());
    }
    if crate::run::interrupted() {
        return Err(Failure::Interrupted(format!(
            "study {} interrupted: run the same command to continue it (finished runs are skipped)",
            plan.study.name
        )));
    }
    Ok(())
}

/// `N runs: a completed, b unstable, c failed`, then the other statuses (interrupted,
/// pending, Slurm's cancelled, timeout, …) when there are any.
fn counts(statuses: &[String]) -> String {
    let count = |s: &str| statuses.iter().filter(|x| x.as_str() == s).count();
    let mut others: Vec<&str> = Vec::new();
    for s in statuses {
        if !["completed", "unstable", "failed"].contains(&s.as_str()) && !others.contains(&s.as_str()) {
            others.push(s);
        }
    }
    let rest: String = others.iter().map(|s| format!(", {} {s}", count(s))).collect();
    format!(
        "{} runs: {} completed, {} unstable, {} failed{rest}",
        statuses.len(),
        count("completed"),
        count("unstable"),
        count("failed")
    )
}

/// `multifield study STUDY.ron --index I`: runs combination I alone (a Slurm array task).
fn study_index(plan: &crate::study::Plan, i: usize, threads: usize) -> Result<(), Failure> {
    let n = plan.runs.len();
    let c = plan.runs.get(i).ok_or_else(|| {
        Failure::Input(Error::Model(format!(
            "--index {i}: the study {} has {n} runs, numbered 0 to {}",
            plan.study.name,
            n.saturating_sub(1)
        )))
    })?;
    let what = c.describe(&plan.study.axes);
    let text = c.case.to_ron();
    if crate::study::finished(&c.dir, &text) {
        println!("run {i} ({what}) finished before: not run again ({})", c.dir.display());
        return Ok(());
    }
    let task = crate::slurm::TaskRecord::from_env();
    let record = task.as_ref().and_then(|t| serde_json::to_vec_pretty(t).ok());
    let restart = crate::study::resume_point(&c.dir, &text);
    println!(
        "run {i} of {n} ({what}) into {}{}{}",
        c.dir.display(),
        task.as_ref().map(|t| format!(" as Slurm job {}", t.job_id)).unwrap_or_default(),
        restart.map(|p| format!(", continuing from {}", p.display())).unwrap_or_default()
    );
    match crate::study::run_one(c, &text, threads, record.as_deref()) {
        Ok(o) => println!(
            "run {i}: {} after {} steps, {:.2} s{}",
            o.summary.status,
            o.summary.steps,
            o.summary.wall_seconds,
            if o.summary.reason.is_empty() { String::new() } else { format!(": {}", o.summary.reason) }
        ),
        Err(e @ Error::Io { .. }) => return Err(Failure::Run(e.to_string())),
        // a run that cannot start is a failed run (its summary says so): data, as locally
        Err(e) => println!("run {i}: failed: {e}"),
    }
    if crate::run::interrupted() {
        return Err(Failure::Interrupted(format!("run {i} interrupted; its output is written up to the last step")));
    }
    Ok(())
}

/// `multifield study STUDY.ron --report`: records how Slurm ended the unfinished runs, then
/// rebuilds results.csv and the charts from the run directories.
fn study_report(plan: &crate::study::Plan) -> Result<(), Failure> {
    let run_error = |e: Error| Failure::Run(e.to_string());
    std::fs::create_dir_all(&plan.out).map_err(|e| Failure::Run(format!("{}: {e}", plan.out.display())))?;
    let ended = crate::slurm::record_ends(plan).map_err(run_error)?;
    let rows = crate::study::write_results(plan).map_err(run_error)?;
    let charts = crate::study_chart::write(plan, &rows).map_err(run_error)?;
    let statuses: Vec<String> = rows.iter().map(|r| r.status.clone()).collect();
    println!(
        "study {}: {}{}",
        plan.study.name,
        counts(&statuses),
        if ended > 0 { format!(" ({ended} ended by Slurm now recorded)") } else { String::new() }
    );
    println!("results: {}", plan.out.join("results.csv").display());
    for c in &charts {
        println!("chart:   {} (and .svg)", c.display());
    }
    Ok(())
}

/// `multifield study STUDY.ron --scheduler slurm`: submits the unfinished runs.
fn study_slurm(plan: &crate::study::Plan, submit: &crate::slurm::Submit) -> Result<(), Failure> {
    let s = crate::slurm::submit(plan, submit).map_err(Failure::Input)?;
    let name = &plan.study.name;
    if s.indices.is_empty() {
        println!("study {name}: every one of its {} runs is finished: nothing submitted", plan.runs.len());
        return study_report(plan);
    }
    let logs = crate::slurm::folder(&plan.out);
    println!(
        "study {name}: {} runs, {} finished before; {} submitted to Slurm partition {} as job array {} (--array={})",
        plan.runs.len(),
        s.skipped,
        s.indices.len(),
        s.partition,
        s.array_job,
        s.array
    );
    println!(
        "report job {} (afterany:{}) writes {} and the charts",
        s.report_job,
        s.array_job,
        plan.out.join("results.csv").display()
    );
    println!(
        "logs: {}/{}_<index>.log; follow: squeue -j {},{}",
        logs.display(),
        s.array_job,
        s.array_job,
        s.report_job
    );
    match s.report_state.as_deref() {
        None => Ok(()),
        Some("COMPLETED") => {
            let statuses: Vec<String> = crate::study::rows(plan).into_iter().map(|r| r.status).collect();
            println!("study {name}: {}", counts(&statuses));
            println!("results: {}", plan.out.join("results.csv").display());
            Ok(())
        }
        Some(state) => Err(Failure::Run(format!(
            "the report job {} ended {state}; its log: {}/report_{}.log",
            s.report_job,
            logs.display(),
            s.report_job
        ))),
    }
}

/// `multifield compare CASE`: the scene resolved and as mass points, side by side.
fn compare(
    case: &Case,
    file: &Path,
    point_overrides: &[String],
    out: Option<PathBuf>,
    options: &RunOptions,
    reference: Option<PathBuf>,
) -> Result<(), Failure> {
    let reference = crate::dkt::ReferenceCurves::from_option(reference);
    let dir = out.unwrap_or_else(|| Path::new("out").join(format!("compare_{}", run::directory_name(&case.name))));
    println!("running {} resolved, then as mass points, into {}", case.name, dir.display());
    let c = crate::compare::compare(case, point_overrides, &dir, options, Some(&reference)).map_err(|e| match e {
        Error::Io { .. } => Failure::Run(e.to_string()),
        e => Failure::Input(e.in_file(file)),
    })?;
    let show = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.4}"));
    println!(
        "{:<10} {:>10} {:>8} {:>9} {:>10} {:>10} {:>10} {:>8}  largest settling speed (per body)",
        "run", "status", "cells/d", "steps", "wall (s)", "kiss", "tumble", "RMS U05"
    );
    for r in [&c.resolved, &c.point] {
        let speeds: Vec<String> = r.bodies.iter().map(|b| format!("{} {:.4}", b.body, b.max_settling_speed)).collect();
        println!(
            "{:<10} {:>10} {:>8.1} {:>9} {:>10.2} {:>10} {:>10} {:>8}  {}",
            r.representation,
            r.status,
            r.cells_per_diameter,
            r.steps,
            r.wall_seconds,
            show(r.kiss_time),
            show(r.tumble_time),
            r.rms_to_uhlmann_over_d.map_or("-".into(), |e| format!("{e:.3}d")),
            speeds.join(", ")
        );
    }
    let signed = |t: Option<f64>| t.map_or("-".to_string(), |t| format!("{t:+.4}"));
    println!(
        "point − resolved: kiss {}, tumble {}; largest settling speed {}; the point run is {:.1}× faster",
        signed(c.kiss_time_difference),
        signed(c.tumble_time_difference),
        c.terminal_speed_relative_difference
            .iter()
            .map(|(b, d)| format!("{b} {:+.1} %", 100.0 * d))
            .collect::<Vec<_>>()
            .join(", "),
        c.speedup
    );
    for w in &c.point.warnings {
        println!("point run: warning: {w}");
    }
    if !c.suspension.is_empty() {
        println!(
            "{:<12} {:<24} {:>7} {:>12} {:>12} {:>12} {:>12}  (point − resolved)",
            "monitor", "statistic", "samples", "L2", "L∞", "resolved", "point"
        );
        for d in &c.suspension {
            println!(
                "{:<12} {:<24} {:>7} {:>12.4e} {:>12.4e} {:>12.5} {:>12.5}",
                d.monitor, d.quantity, d.samples, d.l2, d.linf, d.resolved_mean, d.point_mean
            );
        }
    }
    println!(
        "wrote {}/comparison.{{json,csv}}{} and the charts compare_position, compare_velocity{} (PNG and SVG)",
        dir.display(),
        if c.suspension.is_empty() { "" } else { ", suspension_comparison.csv" },
        if c.suspension.is_empty() { "" } else { ", compare_suspension_<monitor>" }
    );
    Ok(())
}

/// `multifield dkt RUN_DIR...`: analysis and plots of drafting–kissing–tumbling runs.
fn dkt(runs: &[PathBuf], reference: Option<PathBuf>, out: Option<PathBuf>) -> Result<(), Failure> {
    let reference = crate::dkt::ReferenceCurves::from_option(reference);
    let show = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.4}"));
    let mut analysed = Vec::new();
    for run in runs {
        let (report, tracks, case) = crate::dkt::analyse(run, Some(&reference))?;
        let json = serde_json::to_string_pretty(&report).map_err(|e| Failure::Run(e.to_string()))?;
        std::fs::write(run.join("dkt.json"), json + "\n")
            .map_err(|e| Failure::Run(format!("{}: {e}", run.display())))?;
        analysed.push((run, report, tracks, case));
    }
    if let [(run, report, tracks, case)] = &analysed[..] {
        println!("trailing disk: {}, leading disk: {}, d = {}", report.trailing, report.leading, report.diameter);
        println!("kiss time (gap along gravity first <= d): {}", show(report.kiss_time));
        println!("tumble time (trailing passes leading):     {}", show(report.tumble_time));
        println!("smallest gap along gravity: {:.3} d", report.min_gap_over_d);
        match report.rms_position_error_over_d {
            Some(e) => println!("RMS distance to Uhlmann 2005 positions over [0, 0.28]: {e:.3} d"),
            None if !crate::dkt::is_reference_scene(case) => {
                println!("(not the scene of the reference curves, d = 0.25 in 2 × 6: no comparison)")
            }
            None => println!("(no reference point within the run's times: no comparison)"),
        }
        if let Some(e) = report.rms_lateral_error_over_d {
            println!("RMS distance to Uhlmann 2005 lateral positions over [0, 0.28]: {e:.3} d");
        }
        if let Some(e) = report.rms_speed_error_over_uref {
            println!("RMS difference to Uhlmann 2005 settling speeds over [0, 0.28]: {e:.4} u_ref");
        }
        if let Some(e) = report.rms_angular_velocity_error_tref {
            println!("RMS difference to Uhlmann 2005 angular velocities over [0, 0.28]: {e:.4} / t_ref");
        }
        let dir = out.unwrap_or_else(|| run.to_path_buf());
        std::fs::create_dir_all(&dir).map_err(|e| Failure::Run(format!("{}: {e}", dir.display())))?;
        for p in crate::dkt::plot(&dir, report, tracks, case, Some(&reference))? {
            println!("wrote {} (and .svg)", p.display());
        }
        return Ok(());
    }
    println!(
        "{:<28} {:>9} {:>10} {:>10} {:>9} {:>11} {:>11} {:>11} {:>11} {:>8} {:>10}",
        "run",
        "cells/d",
        "kiss",
        "tumble",
        "min gap",
        "RMS to U05",
        "lateral",
        "speed/u_ref",
        "ω·t_ref",
        "steps",
        "wall (s)"
    );
    for (run, report, _, case) in &analysed {
        let h = case.domain.size[0] / case.cells()[0] as f64;
        let summary: serde_json::Value = std::fs::read_to_string(run.join("summary.json"))
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default();
        println!(
            "{:<28} {:>9.1} {:>10} {:>10} {:>8.3}d {:>11} {:>11} {:>11} {:>11} {:>8} {:>10}",
            run.file_name().map_or_else(|| run.display().to_string(), |n| n.to_string_lossy().into_owned()),
            report.diameter / h,
            show(report.kiss_time),
            show(report.tumble_time),
            report.min_gap_over_d,
            report.rms_position_error_over_d.map_or("-".into(), |e| format!("{e:.3}d")),
            report.rms_lateral_error_over_d.map_or("-".into(), |e| format!("{e:.3}d")),
            report.rms_speed_error_over_uref.map_or("-".into(), |e| format!("{e:.4}")),
            report.rms_angular_velocity_error_tref.map_or("-".into(), |e| format!("{e:.4}")),
            summary["steps"].as_u64().map_or("-".into(), |s| s.to_string()),
            summary["wall_seconds"].as_f64().map_or("-".into(), |s| format!("{s:.1}")),
        );
    }
    let dir = out.unwrap_or_else(|| PathBuf::from("out/dkt_compare"));
    std::fs::create_dir_all(&dir).map_err(|e| Failure::Run(format!("{}: {e}", dir.display())))?;
    let list: Vec<crate::dkt::Run> = analysed
        .iter()
        .map(|(run, report, tracks, case)| crate::dkt::Run {
            label: run.file_name().map_or_else(|| run.display().to_string(), |n| n.to_string_lossy().into_owned()),
            report,
            tracks,
            case,
        })
        .collect();
    for p in crate::dkt::plot_runs(&dir, &list, Some(&reference))? {
        println!("wrote {} (and .svg)", p.display());
    }
    Ok(())
}
