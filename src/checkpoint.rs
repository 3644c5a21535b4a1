//! Checkpoints: the whole state of a run, to continue it with `multifield run CASE
//! --restart FILE` exactly as if it had not stopped (bit for bit).
//!
//! With `output.checkpoints: Some((interval: Δ))` a run writes
//! `checkpoints/checkpoint_<step>.bin` at the first step at or after t = Δ, 2Δ, …, and
//! after the run's last step when it completed (or stopped at `time.max_steps`), so that a
//! finished run can be extended with `--set time.end=…` and `--restart`. No checkpoint is
//! written after a step that went unstable. Each file is written under a temporary name
//! and renamed ([`crate::output::write_atomically`]); once it is complete, the checkpoints
//! of earlier steps are deleted but the newest of them, so the folder holds the last two
//! and a run killed at any moment loses at most one interval. (The rename is atomic for a
//! killed process; after a power cut a file the system had not yet flushed fails its
//! length or CRC-32 check and is refused, naming the other one.)
//!
//! A checkpoint is a fixed-length header followed by a payload, both plain
//! `#[derive(Serialize, Deserialize)]` structs encoded with
//! [postcard](https://docs.rs/postcard) (integers as varints, reals as their 8 bytes
//! little-endian, bit for bit):
//!
//! | part | contents |
//! |---|---|
//! | header | the signature [`MAGIC`], the format [`VERSION`] (u32), the payload's length (u64) and its CRC-32 (u32), fixed-width little-endian: 24 bytes |
//! | position | step, simulated time |
//! | case | the case as run, RON text as in `case.ron` (every default filled in) |
//! | runner | [`RunnerState`]: next diagnostics time, whether the last step has its row, rows written, the summary's running figures, next checkpoint time |
//! | simulation | [`Simulation::save_state`]: time, steps, pressure (the warm start of the next solve), last step's figures, initial energy, contact forces, every field's grid state and its frame's own state, each the frame's derived struct in postcard (Eulerian: θ, face velocities, steps taken; Lagrangian: every point array including the APIC matrices, and each body's state; mass points: each point's state), the lagged marker forces of each direct forcing, and the running time averages of the `TimeAverage` monitors |
//!
//! The pressure solvers keep only caches that every solve rebuilds from its problem (the
//! multigrid hierarchy, the Cholesky factorizations), so a solve depends only on the
//! problem and the initial guess, which is the checkpointed pressure.
//!
//! A run continued from the checkpoint of step n into a directory deletes the checkpoints
//! of later steps there ([`discard_after`]), as it drops the rows after step n.
//!
//! A restart refuses a checkpoint that is missing, truncated, corrupt (its CRC-32 does not
//! match), of another format version (an older multifield's checkpoint cannot be continued
//! by this one: run the case again from t = 0, or continue it with the multifield that
//! wrote it), or written by another case: the case may differ only in `time` (e.g. a later
//! `time.end`), `output`, `description`, `monitors` and `stop`. It also refuses, with the field, the array,
//! the index and the value, a checkpoint whose CRC-32 is right but whose state no run
//! writes (a damaged file whose checksum was recomputed, or a forged one): arrays of
//! another length than the grid's or the points', reals that are not finite, volume
//! fractions or masses below zero, an Eulerian field's volume fraction above
//! 1 + `coupling.max_volume_fraction_error`, points or body centres outside the domain,
//! another number of bodies, a stress model's point state that does not fit its model
//! ([`Simulation::load_state`]; each frame checks its own state). The rows of `diagnostics.csv` and
//! `bodies.csv` up to the checkpoint's step are kept (from the checkpoint's run directory,
//! else from the output directory) and the restarted run appends after them.

use crate::core::case::{Case, Schedule};
use crate::core::driver::{End, RunState, Step, Writer};
use crate::core::error::Error;
use crate::core::math::Real;
use crate::core::simulation::{Simulation, Status};
use crate::output::Due;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// The first bytes of every checkpoint of a 2D run.
pub const MAGIC2: &[u8; 8] = b"MFCKPT\r\n";
/// The first bytes of every checkpoint of a 3D run: the dimension is read before anything
/// is decoded, so a checkpoint of the other dimension is refused by name.
pub const MAGIC3: &[u8; 8] = b"MFCKP3\r\n";
/// The first bytes of every checkpoint of this compile's dimension.
#[cfg(feature = "dim2")]
pub const MAGIC: &[u8; 8] = MAGIC2;
/// The first bytes of every checkpoint of this compile's dimension.
#[cfg(feature = "dim3")]
pub const MAGIC: &[u8; 8] = MAGIC3;
/// Version of the format; a checkpoint of another version is refused. Version 2 was the
/// hand-written encoding with a 64-bit checksum; version 3 is derived structs encoded
/// with postcard, with a CRC-32; version 4 adds the stress models' per-point state to the
/// Lagrangian frame's points (`StressModel::point_state`); version 5 adds the strain energy
/// and max Σθ to the last step's figures; version 6 adds the running time averages of the
/// `TimeAverage` monitors and the contact model's history (`ContactModel::history`: the
/// `dem` tangential springs).
pub const VERSION: u32 = 6;
/// Length of the [`Header`]: signature, version, payload length, CRC-32.
const HEADER: usize = 8 + 4 + 8 + 4;
/// Folder of the checkpoints in a run directory.
pub const FOLDER: &str = "checkpoints";

/// The fixed-length start of a checkpoint. Its fields are fixed-width little-endian (not
/// postcard's varints), so the version sits at the same bytes 8–11 in every version of the
/// format and the length is known before the payload is read.
#[derive(Serialize, Deserialize)]
struct Header {
    /// [`MAGIC`].
    magic: [u8; 8],
    /// [`VERSION`].
    #[serde(with = "postcard::fixint::le")]
    version: u32,
    /// Bytes of the payload that follows.
    #[serde(with = "postcard::fixint::le")]
    length: u64,
    /// CRC-32 of the payload (detects truncation and corruption, not tampering).
    #[serde(with = "postcard::fixint::le")]
    crc32: u32,
}

/// What follows the [`Header`]: borrowed when written, owned when read.
#[derive(Serialize, Deserialize)]
struct Payload<'a> {
    /// Steps taken.
    step: u64,
    /// Simulated time.
    time: Real,
    /// The case as run, RON text as in `case.ron` (every default filled in).
    case: Cow<'a, str>,
    /// The runner's state.
    runner: Cow<'a, RunnerState>,
    /// [`Simulation::save_state`].
    simulation: Cow<'a, [u8]>,
}

/// The runner's own state at a checkpoint: what `diagnostics.csv`, the summary and the
/// checkpoint schedule need to continue.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunnerState {
    /// Simulated time of the next `diagnostics.csv` row.
    pub next_output: Real,
    /// Whether the checkpoint's step has a regular row (not only the row every run
    /// writes for its last step); a restart keeps the rows up to the step, that one
    /// only if this is set.
    pub last_row_written: bool,
    /// Rows of `diagnostics.csv` so far.
    pub diagnostics_rows: u64,
    /// Largest constraint residual so far.
    pub max_divergence: Real,
    /// Largest |Σθ − 1| so far.
    pub max_volume_fraction_error: Real,
    /// Pressure iterations so far.
    pub pressure_iterations_total: u64,
    /// Smallest Δt so far.
    pub min_dt: Real,
    /// What limited the last step.
    pub last_dt_limit: String,
    /// Simulated time of the next checkpoint.
    pub next_checkpoint: Real,
}

/// A checkpoint read from a file (checked: complete, of this version, checksum right).
pub struct Checkpoint {
    /// The file.
    pub path: PathBuf,
    /// Steps taken.
    pub step: u64,
    /// Simulated time.
    pub time: Real,
    /// The case as run.
    pub case: Case,
    /// The runner's state.
    pub runner: RunnerState,
    /// [`Simulation::save_state`].
    simulation: Vec<u8>,
}

impl std::fmt::Debug for Checkpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Checkpoint")
            .field("path", &self.path)
            .field("step", &self.step)
            .field("time", &self.time)
            .field("case", &self.case.name)
            .field("runner", &self.runner)
            .field("simulation_bytes", &self.simulation.len())
            .finish()
    }
}

/// Name of the checkpoint of `step`.
pub fn file_name(step: u64) -> String {
    format!("checkpoint_{step}.bin")
}

/// The step of a checkpoint's file name (`checkpoint_<step>.bin`), or of the folder of a
/// checkpoint written per rank (`checkpoint_<step>`).
pub fn step_of(path: &Path) -> Option<u64> {
    let n = path.file_name()?.to_str()?.strip_prefix("checkpoint_")?;
    n.strip_suffix(".bin").unwrap_or(n).parse().ok()
}

/// The folder of a checkpoint written per rank that `path` names: the folder itself, or one
/// of its rank files.
fn rank_folder(path: &Path) -> Option<PathBuf> {
    if path.is_dir() && path.file_name()?.to_str()?.starts_with("checkpoint_") {
        return Some(path.to_path_buf());
    }
    let in_folder = path.file_name()?.to_str()?.starts_with("rank_")
        && path.parent()?.file_name()?.to_str()?.starts_with("checkpoint_");
    in_folder.then(|| path.parent().map(Path::to_path_buf)).flatten()
}

/// The file of rank `rank` in the folder of a checkpoint written per rank.
fn rank_file(rank: usize) -> String {
    format!("rank_{rank:04}.bin")
}

/// Removes a checkpoint: a file, or the folder of one written per rank.
fn remove(path: &Path) -> Result<(), Error> {
    let removed = if path.is_dir() { std::fs::remove_dir_all(path) } else { std::fs::remove_file(path) };
    removed.map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// The checkpoints of the run directory `run_dir` (complete names only, not the
/// temporary files of a write in progress), by step.
pub fn list(run_dir: &Path) -> Vec<(u64, PathBuf)> {
    let mut out: Vec<(u64, PathBuf)> = std::fs::read_dir(run_dir.join(FOLDER))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter_map(|p| step_of(&p).map(|s| (s, p)))
        .collect();
    out.sort();
    out
}

/// The bytes of a checkpoint of `sim` with the runner's state `runner`.
pub fn encode(sim: &Simulation, runner: &RunnerState) -> Result<Vec<u8>, Error> {
    encode_with(sim, runner, sim.save_state()?)
}

/// [`encode`] with the simulation's state `simulation` (the whole domain's, or a rank's own,
/// [`Simulation::save_rank_state`]).
fn encode_with(sim: &Simulation, runner: &RunnerState, simulation: Vec<u8>) -> Result<Vec<u8>, Error> {
    let case = sim.case.to_ron();
    let payload = Payload {
        step: sim.steps,
        time: sim.time,
        case: Cow::Borrowed(&case),
        runner: Cow::Borrowed(runner),
        simulation: Cow::Borrowed(&simulation),
    };
    let payload = postcard::to_stdvec(&payload).map_err(|e| Error::Model(format!("checkpoint: {e}")))?;
    let header =
        Header { magic: *MAGIC, version: VERSION, length: payload.len() as u64, crc32: crc32fast::hash(&payload) };
    let mut out = postcard::to_stdvec(&header).map_err(|e| Error::Model(format!("checkpoint: {e}")))?;
    debug_assert_eq!(out.len(), HEADER);
    out.extend_from_slice(&payload);
    Ok(out)
}

/// The way on when no checkpoint will do.
const FROM_START: &str = "run the case from t = 0 without --restart";

/// A bad checkpoint: the message says what is wrong with `path` and how to go on.
fn bad(path: &Path, what: String) -> Error {
    let mut fix = String::new();
    let run_dir = path.parent().filter(|p| p.file_name().is_some_and(|n| n == FOLDER)).and_then(Path::parent);
    if let Some(run_dir) = run_dir {
        let others: Vec<PathBuf> =
            list(run_dir).into_iter().rev().map(|(_, p)| p).filter(|p| p.file_name() != path.file_name()).collect();
        if let Some(good) = others.iter().find(|p| load(p).is_ok()) {
            fix = format!("; restart from the complete checkpoint {} instead", good.display());
        }
    }
    if fix.is_empty() && !what.contains(FROM_START) {
        fix = format!(
            "; restart from another checkpoint (a run with output.checkpoints writes them into <run \
             directory>/checkpoints/), or {FROM_START}"
        );
    }
    Error::Model(format!("checkpoint {}: {what}{fix}", path.display()))
}

/// Reads and checks the checkpoint `path`.
pub fn read(path: &Path) -> Result<Checkpoint, Error> {
    load(path).map_err(|m| bad(path, m))
}

/// [`read`] with the bare reason of a failure.
fn load(path: &Path) -> Result<Checkpoint, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot be read: {e}"))?;
    decode(path, &bytes)
}

fn decode(path: &Path, bytes: &[u8]) -> Result<Checkpoint, String> {
    let signature = bytes.get(..MAGIC.len());
    if signature != Some(MAGIC) && (signature == Some(MAGIC2) || signature == Some(MAGIC3)) {
        let (theirs, ours) = if signature == Some(MAGIC3) { (3, 2) } else { (2, 3) };
        return Err(format!(
            "a checkpoint of a {theirs}D run, and this case is {ours}D: continue it with the case that wrote it"
        ));
    }
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        let what = if bytes.is_empty() { "the file is empty" } else { "not a multifield checkpoint" };
        return Err(format!("{what} (it does not start with the checkpoint signature)"));
    }
    if bytes.len() < HEADER {
        return Err(format!(
            "truncated: {} bytes, shorter than the header (a run killed while writing it?)",
            bytes.len()
        ));
    }
    let (header, payload): (Header, _) =
        postcard::take_from_bytes(bytes).map_err(|e| format!("the header does not read: {e}"))?;
    if header.version != VERSION {
        let (version, by) = (header.version, if header.version < VERSION { "an older" } else { "a newer" });
        return Err(format!(
            "format version {version} (written by {by} multifield), this multifield reads version {VERSION}: \
             {FROM_START}, or continue it with the multifield that wrote it"
        ));
    }
    let length = header.length;
    if (payload.len() as u64) < length {
        return Err(format!(
            "truncated: {} of {} bytes (a run killed while writing it, or an incomplete copy)",
            bytes.len(),
            HEADER as u64 + length
        ));
    }
    if payload.len() as u64 > length {
        return Err(format!("{} bytes, {} expected: extra bytes after the end", bytes.len(), HEADER as u64 + length));
    }
    if crc32fast::hash(payload) != header.crc32 {
        return Err("corrupt: the CRC-32 of its contents does not match the one stored".into());
    }
    let p: Payload = crate::core::state::decode(payload, "the contents do not read")?;
    let case = Case::from_ron(&p.case, path).map_err(|e| format!("the case it holds does not parse: {e}"))?;
    Ok(Checkpoint {
        path: path.to_path_buf(),
        step: p.step,
        time: p.time,
        case,
        runner: p.runner.into_owned(),
        simulation: p.simulation.into_owned(),
    })
}

/// Entries of `case` that a restart may change.
const MAY_CHANGE: [&str; 5] = ["time", "output", "description", "monitors", "stop"];

/// The entries in which two cases differ (dotted paths as for `--set`, named list entries
/// by name), except [`MAY_CHANGE`] and `domain.ranks`; each as "`path` is A in the checkpoint, B here".
pub fn differences(checkpoint: &Case, here: &Case) -> Vec<String> {
    fn walk(path: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
        use serde_json::Value;
        let join = |k: &str| if path.is_empty() { k.to_string() } else { format!("{path}.{k}") };
        match (a, b) {
            (Value::Object(x), Value::Object(y)) => {
                for (k, va) in x {
                    if path.is_empty() && MAY_CHANGE.contains(&k.as_str()) {
                        continue;
                    }
                    walk(&join(k), va, y.get(k).unwrap_or(&Value::Null), out);
                }
                for (k, vb) in y.iter().filter(|(k, _)| !x.contains_key(*k)) {
                    if !(path.is_empty() && MAY_CHANGE.contains(&k.as_str())) {
                        walk(&join(k), &Value::Null, vb, out);
                    }
                }
            }
            (Value::Array(x), Value::Array(y))
                if x.len() == y.len() && x.iter().chain(y).any(|v| v.is_object() || v.is_array()) =>
            {
                for (k, (va, vb)) in x.iter().zip(y).enumerate() {
                    let key = match (va.get("name"), vb.get("name")) {
                        (Some(Value::String(n)), Some(Value::String(m))) if n == m => n.clone(),
                        _ => k.to_string(),
                    };
                    walk(&join(&key), va, vb, out);
                }
            }
            _ if a == b => {}
            // the rank grid changes where a run happens, not its results
            _ if path == "domain.ranks" => {}
            _ => out.push(format!("`{path}` is {a} in the checkpoint, {b} here")),
        }
    }
    let (Ok(a), Ok(b)) = (serde_json::to_value(checkpoint), serde_json::to_value(here)) else {
        return vec!["the cases cannot be compared".into()];
    };
    let mut out = Vec::new();
    walk("", &a, &b, &mut out);
    out
}

/// Builds the simulation of `case` and restores the checkpoint `path` into it. Refuses a
/// checkpoint of another case (module doc) with the entries that differ.
pub fn restore(case: &Case, path: &Path) -> Result<(Simulation, Checkpoint), Error> {
    restore_on(case, path, None)
}

/// [`restore`] on the ranks of a decomposed run (`None`: one process): every rank reads the
/// checkpoint (of the whole domain, whatever the rank count that wrote it) and takes its
/// block.
pub fn restore_on(
    case: &Case,
    path: &Path,
    comm: Option<std::sync::Arc<dyn crate::core::parallel::Comm>>,
) -> Result<(Simulation, Checkpoint), Error> {
    let folder = rank_folder(path);
    let checkpoint = match &folder {
        Some(folder) => read_rank(folder, comm.as_deref())?,
        None => read(path)?,
    };
    let mut sim = match comm {
        Some(comm) => Simulation::with_comm(case, comm)?,
        None => Simulation::new(case)?,
    };
    let diff = differences(&checkpoint.case, &sim.case);
    if !diff.is_empty() {
        let shown = diff.iter().take(6).cloned().collect::<Vec<_>>().join("; ");
        let more = if diff.len() > 6 { format!("; and {} more", diff.len() - 6) } else { String::new() };
        return Err(Error::Model(format!(
            "checkpoint {} was written by a different case `{}`: {shown}{more}. A restart may change only domain.ranks, \
             time.*, output.*, description, monitors and stop: restart with the case the checkpoint was written with (its \
             run directory's case.ron, with --set time.end=… to go further), or run the changed case from \
             t = 0 without --restart",
            path.display(),
            checkpoint.case.name
        )));
    }
    match &folder {
        Some(folder) => sim
            .load_rank_state(&checkpoint.simulation)
            .map_err(|e| Error::Model(format!("checkpoint {}: {e}", folder.display())))?,
        None => sim.load_state(&checkpoint.simulation).map_err(|e| bad(path, format!("does not fit the case: {e}")))?,
    }
    if sim.steps != checkpoint.step || sim.time.to_bits() != checkpoint.time.to_bits() {
        return Err(bad(path, "its header and its simulation state disagree on the step".into()));
    }
    Ok((sim, checkpoint))
}

/// This rank's file of the checkpoint `folder` written per rank (rank 0's without `comm`):
/// refused on every rank alike when the folder holds another number of rank files than
/// the run has ranks, or when a rank's file does not read.
fn read_rank(folder: &Path, comm: Option<&dyn crate::core::parallel::Comm>) -> Result<Checkpoint, Error> {
    let (rank, ranks) = comm.map_or((0, 1), |c| (c.rank(), c.size()));
    let mine = || -> Result<Checkpoint, Error> {
        let files = std::fs::read_dir(folder)
            .map_err(|source| Error::Io { path: folder.to_path_buf(), source })?
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with("rank_"))
            .count();
        if files == 0 {
            return Err(Error::Model(format!(
                "checkpoint {}: no rank_<r>.bin file in it (a checkpoint written per rank is a folder of one \
                 file a rank; give a checkpoint_<step>.bin file or such a folder)",
                folder.display()
            )));
        }
        if files != ranks {
            return Err(Error::Model(format!(
                "checkpoint {}: written per rank by {files} ranks, and this run has {ranks}: continue it with \
                 `mpirun -np {files}` (and the rank grid it was written on), or from a checkpoint written with \
                 `layout: Gathered` (the default), which restarts on any number of ranks",
                folder.display()
            )));
        }
        let mut checkpoint = read(&folder.join(rank_file(rank)))?;
        checkpoint.path = folder.to_path_buf();
        Ok(checkpoint)
    };
    let checkpoint = mine();
    // every rank learns whether every rank could read its file
    if comm.is_some_and(|c| c.any(checkpoint.is_err())) && checkpoint.is_ok() {
        return Err(Error::Model(format!("checkpoint {}: another rank's file does not read", folder.display())));
    }
    checkpoint
}

/// Next time of a schedule of `interval` after `t` when it cannot be carried over: the
/// first multiple of `interval` after `t`.
pub fn next_after(t: Real, interval: Real) -> Real {
    let first = ((t / interval).floor() + 1.0) * interval;
    crate::core::driver::schedule_past(if first.is_finite() { first } else { t }, t + 1e-9 * interval, interval)
}

/// Deletes the checkpoints of `run_dir` beyond `step`: a run continued from the
/// checkpoint of `step` replaces them (as it replaces the rows after that step), and a
/// checkpoint of the abandoned steps must not be mistaken for one of the new run.
pub fn discard_after(run_dir: &Path, step: u64) -> Result<(), Error> {
    for (_, path) in list(run_dir).into_iter().filter(|(s, _)| *s > step) {
        remove(&path)?;
    }
    Ok(())
}

/// The checkpoint writer of a run.
#[derive(Debug)]
pub struct Checkpoints {
    folder: PathBuf,
    due: Due,
    last_step: Option<u64>,
    last_path: Option<PathBuf>,
    /// Whether this process writes the files: one process, or rank 0 of a decomposed run
    /// (every rank gathers its block into the checkpoint and keeps the schedule).
    writes: bool,
    /// Each rank writes its own state (`layout: PerRank` on several ranks).
    per_rank: bool,
}

impl Checkpoints {
    /// Checkpoints into `run_dir/checkpoints/` on `schedule`, the next at `next` (the
    /// interval for a new run); `last_step` is the step of a checkpoint the run starts
    /// from. Creates the folder and removes temporary files left by a killed run.
    pub fn create(run_dir: &Path, schedule: Schedule, next: Real, last_step: Option<u64>) -> Result<Self, Error> {
        Self::create_on(run_dir, schedule, next, last_step, true, false)
    }

    /// [`Checkpoints::create`] on a rank of a decomposed run: `writes` on rank 0 only (the
    /// others touch no file but, `per_rank`, their own rank files).
    pub fn create_on(
        run_dir: &Path,
        schedule: Schedule,
        next: Real,
        last_step: Option<u64>,
        writes: bool,
        per_rank: bool,
    ) -> Result<Self, Error> {
        let folder = run_dir.join(FOLDER);
        if writes {
            std::fs::create_dir_all(&folder).map_err(|source| Error::Io { path: folder.clone(), source })?;
            for e in std::fs::read_dir(&folder).map_err(|source| Error::Io { path: folder.clone(), source })?.flatten()
            {
                let name = e.file_name().to_string_lossy().into_owned();
                if name.starts_with(".checkpoint_") && name.ends_with(".bin.tmp") {
                    let _ = std::fs::remove_file(e.path());
                }
                // a per-rank checkpoint a killed run did not complete
                if name.starts_with(".checkpoint_") && name.ends_with(".tmp") && e.path().is_dir() {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        Ok(Self { folder, due: Due::new(next, schedule.interval), last_step, last_path: None, writes, per_rank })
    }

    /// Whether a checkpoint is due after a step that ended at `t`; if so, moves the
    /// schedule past `t` ([`Due::check`]).
    pub fn due(&mut self, t: Real) -> bool {
        self.due.check(t)
    }

    /// Simulated time of the next checkpoint.
    pub fn next(&self) -> Real {
        self.due.next()
    }

    /// Step of the last checkpoint written (or started from).
    pub fn last_step(&self) -> Option<u64> {
        self.last_step
    }

    /// Writes the checkpoint of `sim` (atomically), then deletes those of earlier steps
    /// but the newest of them. `runner.next_checkpoint` is set here.
    pub fn write(&mut self, sim: &Simulation, runner: &RunnerState) -> Result<PathBuf, Error> {
        let runner = RunnerState { next_checkpoint: self.due.next(), ..runner.clone() };
        if self.per_rank {
            return self.write_per_rank(sim, &runner);
        }
        // (every rank of a decomposed run: the state is gathered)
        let bytes = encode(sim, &runner)?;
        let path = self.folder.join(file_name(sim.steps));
        let written = if self.writes { self.write_file(&path, &bytes, sim.steps) } else { Ok(()) };
        // every rank learns whether rank 0 could write
        if sim.grid.part.any(written.is_err()) {
            return Err(written.err().unwrap_or_else(|| Error::Model("rank 0 could not write a checkpoint".into())));
        }
        self.last_step = Some(sim.steps);
        self.last_path = Some(path.clone());
        Ok(path)
    }

    /// Writes the checkpoint file of `step` and deletes those of earlier steps but the
    /// newest of them.
    fn write_file(&self, path: &Path, bytes: &[u8], step: u64) -> Result<(), Error> {
        crate::output::write_atomically(path, bytes)?;
        self.prune(step)
    }

    /// Deletes the checkpoints of steps before `step` but the newest of them.
    fn prune(&self, step: u64) -> Result<(), Error> {
        let run_dir = self.folder.parent().unwrap_or(Path::new("."));
        let earlier: Vec<PathBuf> = list(run_dir).into_iter().filter(|(s, _)| *s < step).map(|(_, p)| p).collect();
        for old in earlier.iter().rev().skip(1) {
            remove(old)?;
        }
        Ok(())
    }

    /// [`Checkpoints::write`] per rank: every rank writes its own state
    /// ([`Simulation::save_rank_state`]) to `rank_<r>.bin` in `.checkpoint_<step>.tmp/`;
    /// once every rank has, rank 0 renames the folder `checkpoint_<step>` (a killed run
    /// leaves whole checkpoints only) and prunes the earlier ones.
    fn write_per_rank(&mut self, sim: &Simulation, runner: &RunnerState) -> Result<PathBuf, Error> {
        let part = &sim.grid.part;
        let step = sim.steps;
        let (tmp, done) = (self.folder.join(format!(".checkpoint_{step}.tmp")), self.folder.join(file_name(step)));
        let done = done.with_extension("");
        let written = sim.save_rank_state().and_then(|state| encode_with(sim, runner, state)).and_then(|bytes| {
            std::fs::create_dir_all(&tmp).map_err(|source| Error::Io { path: tmp.clone(), source })?;
            crate::output::write_atomically(&tmp.join(rank_file(part.rank())), &bytes)
        });
        let agreed = |result: Result<(), Error>, what: &str| {
            if part.any(result.is_err()) {
                return Err(result.err().unwrap_or_else(|| Error::Model(format!("another rank could not {what}"))));
            }
            Ok(())
        };
        agreed(written, "write its part of a checkpoint")?;
        let renamed = if self.writes {
            (if done.exists() { remove(&done) } else { Ok(()) })
                .and_then(|_| std::fs::rename(&tmp, &done).map_err(|source| Error::Io { path: done.clone(), source }))
                .and_then(|_| self.prune(step))
        } else {
            Ok(())
        };
        agreed(renamed, "complete a checkpoint")?;
        self.last_step = Some(step);
        self.last_path = Some(done.clone());
        Ok(done)
    }
}

impl RunnerState {
    /// The runner's part of a checkpoint from the driver's state (`next_checkpoint` is set
    /// by [`Checkpoints::write`]).
    pub fn of(state: &RunState) -> Self {
        Self {
            next_output: state.next_row,
            last_row_written: state.last_row_written,
            diagnostics_rows: state.rows,
            max_divergence: state.max_divergence,
            max_volume_fraction_error: state.max_volume_fraction_error,
            pressure_iterations_total: state.pressure_iterations_total,
            min_dt: state.min_dt,
            last_dt_limit: state.last_dt_limit.clone(),
            next_checkpoint: 0.0,
        }
    }

    /// The driver's state of `sim` restored from this, the next table row at `next_row`
    /// (this one's `next_output` when the interval is unchanged).
    pub fn run_state(&self, sim: &Simulation, next_row: Real) -> RunState {
        RunState {
            max_divergence: self.max_divergence,
            max_volume_fraction_error: self.max_volume_fraction_error,
            pressure_iterations_total: self.pressure_iterations_total,
            min_dt: self.min_dt,
            last_dt_limit: self.last_dt_limit.clone(),
            next_row,
            last_row_written: self.last_row_written,
            rows: self.diagnostics_rows,
            ..RunState::new(sim)
        }
    }
}

/// Checkpoints as a writer of the driver: after every step on the case's schedule (not
/// after the step that ends a run as unstable: the run keeps its last good checkpoint), and
/// at the end of a completed run (to be extended with a later `time.end`) or an
/// interrupted one (to be continued).
impl Writer for Checkpoints {
    fn name(&self) -> &str {
        "checkpoints"
    }
    fn needs_grid_state(&self, step: &Step) -> bool {
        // a checkpoint holds the grid state too: the same bits whenever it was written
        !step.unstable && self.due.peek(step.sim.time)
    }
    fn after_step(&mut self, step: &Step) -> Result<(), Error> {
        if !step.unstable && self.due(step.sim.time) {
            self.write(step.sim, &RunnerState::of(step.state))?;
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, end: &End) -> Result<(), Error> {
        let closes = matches!(end.status, Status::Completed | Status::Interrupted(_));
        if closes && sim.steps > 0 && self.last_step() != Some(sim.steps) {
            sim.refresh_grid_state()?;
            self.write(sim, &RunnerState::of(end.state))?;
        }
        Ok(())
    }
    fn last_written(&self) -> Option<PathBuf> {
        self.last_path.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_has_a_fixed_layout() {
        let header = Header { magic: *MAGIC, version: VERSION, length: 1 << 40, crc32: 0xdead_beef };
        let b = postcard::to_stdvec(&header).unwrap();
        assert_eq!(b.len(), HEADER);
        assert_eq!(&b[..8], MAGIC);
        assert_eq!(b[8..12], VERSION.to_le_bytes(), "the version where every version has it");
        assert_eq!(b[12..20], (1u64 << 40).to_le_bytes());
        assert_eq!(b[20..24], 0xdead_beef_u32.to_le_bytes());
    }

    #[test]
    fn names_carry_the_step() {
        assert_eq!(step_of(Path::new("x/checkpoints/checkpoint_120.bin")), Some(120));
        assert_eq!(step_of(Path::new(&file_name(7))), Some(7));
        assert_eq!(step_of(Path::new(".checkpoint_120.bin.tmp")), None);
    }

    #[test]
    fn a_schedule_after_a_time_starts_at_the_next_multiple() {
        assert_eq!(next_after(0.0, 0.1), 0.1);
        assert!((next_after(0.25, 0.1) - 0.3).abs() < 1e-12);
        assert!((next_after(0.3 - 1e-15, 0.1) - 0.4).abs() < 1e-12);
    }
}
