//! Studies on a Slurm cluster: `multifield study STUDY.ron --scheduler slurm`.
//!
//! The submission checks what it can before anything is submitted (`sbatch` and `sinfo`
//! on `PATH`, the partition, the time limit against the partition's, the CPUs per run
//! against its nodes'), then submits one job array with a task per unfinished combination,
//! throttled to `--max-parallel` tasks at a time (`%K`), and a report job that depends on
//! it with `afterany` (it starts when every task has ended, however it ended).
//!
//! - The task of array index `i` runs `multifield study STUDY.ron --index i`: exactly the
//!   combination `i` of the study (in the order of the plan, the first axis varying
//!   slowest), into its own run directory. It first writes [`TASK`] there (its job id), and
//!   never writes `results.csv`: concurrent tasks never write the same file.
//! - The report job runs `multifield study STUDY.ron --report`: for every unfinished run
//!   that a task started (or a submission listed) it asks `scontrol show job` how the task
//!   ended, or, once Slurm has forgotten the job (`MinJobAge`), reads the task's log for
//!   slurmstepd's `*** JOB … CANCELLED …` line, and writes the state into [`ENDED`]; then it
//!   rebuilds `results.csv` from the runs' own `summary.json` and draws the charts, as a
//!   local study does. No accounting (`sacct`) is needed.
//! - A resubmission submits only the combinations that are not finished; a run that was
//!   killed after writing a checkpoint continues from its last one
//!   ([`crate::study::resume_point`]).
//!
//! Files: `<out>/slurm/task.sh` and `report.sh` (the job scripts), `<out>/slurm/<array
//! job>_<index>.log` (a task's output), `<out>/slurm/report_<job>.log`, and
//! `<out>/slurm/submission_<array job>.json` (what was submitted).

use crate::core::error::Error;
use crate::study::{self, Plan};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// The record a Slurm task writes into its run directory before the run starts.
pub const TASK: &str = "slurm_task.json";

/// The record the report writes into the directory of a run Slurm ended before it finished.
pub const ENDED: &str = "slurm_ended.json";

/// Where a study's runs go.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, clap::ValueEnum)]
pub enum SchedulerKind {
    /// On this machine, `--jobs` at a time.
    #[default]
    Local,
    /// Through Slurm: one job array, one task per unfinished run.
    Slurm,
}

/// The `scheduler:` entry of a study file; every entry may be left out, and the command
/// line's option of the same name overrides it.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SchedulerSpec {
    /// `Local` (default) or `Slurm`.
    #[serde(default)]
    pub kind: SchedulerKind,
    /// The Slurm partition; empty: the cluster's default partition.
    #[serde(default)]
    pub partition: String,
    /// Time limit of each task, in Slurm's notation (`MM`, `MM:SS`, `HH:MM:SS`, `D-HH`,
    /// `D-HH:MM`, `D-HH:MM:SS`); empty: the partition's default.
    #[serde(default)]
    pub time: String,
    /// CPUs of each task, and the run's worker threads; 0: `--threads-per-run`.
    #[serde(default)]
    pub cpus_per_run: usize,
    /// The most tasks running at once (the array's `%K`); 0: as many as Slurm allows.
    #[serde(default)]
    pub max_parallel: usize,
    /// Further `sbatch` arguments for the array and the report job (`--account=…`,
    /// `--qos=…`, `--mem=…`).
    #[serde(default)]
    pub sbatch_args: Vec<String>,
}

/// The command line's scheduler options of `multifield study`.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct ClusterArgs {
    /// Where the runs go [default: the study file's `scheduler`, else local].
    #[arg(long, value_enum)]
    pub scheduler: Option<SchedulerKind>,
    /// Slurm partition [default: the cluster's default].
    #[arg(long, value_name = "P")]
    pub partition: Option<String>,
    /// Slurm time limit per run (HH:MM:SS, D-HH:MM:SS, MM) [default: the partition's].
    #[arg(long, value_name = "HH:MM:SS")]
    pub time: Option<String>,
    /// CPUs of each Slurm task, and the run's worker threads [default: --threads-per-run].
    #[arg(long, value_name = "N")]
    pub cpus_per_run: Option<usize>,
    /// The most Slurm tasks running at once (the array's %K) [default: no limit].
    #[arg(long, value_name = "K")]
    pub max_parallel: Option<usize>,
    /// A further sbatch argument, e.g. --sbatch-arg=--account=abc (repeatable; replaces the
    /// study file's list).
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    pub sbatch_args: Vec<String>,
    /// With Slurm: wait until the report job has written results.csv, then report.
    #[arg(long)]
    pub wait: bool,
    /// Run exactly combination I (from 0, in results.csv's order) and nothing else: what
    /// each task of the Slurm array runs. Does not write results.csv.
    #[arg(long, value_name = "I", conflicts_with_all = ["report", "scheduler"])]
    pub index: Option<usize>,
    /// Record how Slurm ended unfinished runs, rebuild results.csv and the charts from the
    /// runs' directories, and run nothing: what the report job runs.
    #[arg(long, conflicts_with = "scheduler")]
    pub report: bool,
}

impl ClusterArgs {
    /// The study file's `scheduler` entry with the command line's options over it.
    pub fn resolve(&self, spec: &SchedulerSpec) -> SchedulerSpec {
        SchedulerSpec {
            kind: self.scheduler.unwrap_or(spec.kind),
            partition: self.partition.clone().unwrap_or_else(|| spec.partition.clone()),
            time: self.time.clone().unwrap_or_else(|| spec.time.clone()),
            cpus_per_run: self.cpus_per_run.unwrap_or(spec.cpus_per_run),
            max_parallel: self.max_parallel.unwrap_or(spec.max_parallel),
            sbatch_args: if self.sbatch_args.is_empty() { spec.sbatch_args.clone() } else { self.sbatch_args.clone() },
        }
    }
}

/// A Slurm task's record of itself ([`TASK`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TaskRecord {
    /// `<array job>_<index>`, as `squeue` and `scancel` name it.
    pub job_id: String,
    /// The array's job id.
    pub array_job: String,
    /// The array index (the combination).
    pub index: usize,
    /// The node it ran on.
    pub node: String,
}

impl TaskRecord {
    /// The record of this process when Slurm started it as an array task.
    pub fn from_env() -> Option<TaskRecord> {
        let var = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
        let array_job = var("SLURM_ARRAY_JOB_ID")?;
        let index: usize = var("SLURM_ARRAY_TASK_ID")?.parse().ok()?;
        Some(TaskRecord {
            job_id: format!("{array_job}_{index}"),
            array_job,
            index,
            node: var("SLURMD_NODENAME").unwrap_or_default(),
        })
    }

    /// The record in the run directory `dir`.
    pub fn read(dir: &Path) -> Option<TaskRecord> {
        serde_json::from_str(&std::fs::read_to_string(dir.join(TASK)).ok()?).ok()
    }
}

/// How Slurm ended a run's task before the run finished ([`ENDED`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Ended {
    /// `<array job>_<index>`.
    pub job_id: String,
    /// Slurm's job state: `CANCELLED`, `TIMEOUT`, `NODE_FAIL`, `PREEMPTED`, `OUT_OF_MEMORY`,
    /// …, or `KILLED` when the task started and Slurm has no record left of how it ended.
    pub state: String,
    /// Where the state was read, and the task's log.
    pub how: String,
}

impl Ended {
    /// The record in the run directory `dir`.
    pub fn read(dir: &Path) -> Option<Ended> {
        serde_json::from_str(&std::fs::read_to_string(dir.join(ENDED)).ok()?).ok()
    }
}

/// What one submission submitted (`<out>/slurm/submission_<array job>.json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Submission {
    /// The array's job id.
    pub array_job: String,
    /// The report job's id (empty until it is submitted).
    pub report_job: String,
    /// The combinations submitted (array indices).
    pub indices: Vec<usize>,
}

/// The folder of the job scripts, logs and submission records.
pub fn folder(out: &Path) -> PathBuf {
    out.join("slurm")
}

/// A Slurm time limit in seconds (`None`: unlimited), from Slurm's notations: `MM`,
/// `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS`, `infinite`/`UNLIMITED`.
pub fn parse_time(text: &str) -> Result<Option<u64>, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("infinite") || t.eq_ignore_ascii_case("unlimited") {
        return Ok(None);
    }
    let bad = || {
        format!(
            "`{text}` is not a Slurm time limit; write HH:MM:SS (e.g. 01:30:00), MM, MM:SS, D-HH, D-HH:MM or \
             D-HH:MM:SS, minutes and seconds below 60 after the first field"
        )
    };
    let number = |s: &str| -> Result<u64, String> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad());
        }
        s.parse().map_err(|_| bad())
    };
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(number(d)?), r),
        None => (None, t),
    };
    let parts: Vec<u64> = rest.split(':').map(number).collect::<Result<_, _>>()?;
    // (hours, minutes, seconds); a field after the first is below 60
    let (h, m, s) = match (days.is_some(), parts.as_slice()) {
        (false, [m]) => (0, *m, 0),
        (false, [m, s]) => (0, *m, *s),
        (_, [h, m, s]) => (*h, *m, *s),
        (true, [h]) => (*h, 0, 0),
        (true, [h, m]) => (*h, *m, 0),
        _ => return Err(bad()),
    };
    let later = &parts[1..];
    if later.iter().any(|&x| x >= 60) || (days.is_some() && h >= 24) {
        return Err(bad());
    }
    let total = days
        .unwrap_or(0)
        .checked_mul(86_400)
        .and_then(|d| h.checked_mul(3600).and_then(|h| d.checked_add(h)))
        .and_then(|x| m.checked_mul(60).and_then(|m| x.checked_add(m)))
        .and_then(|x| x.checked_add(s))
        .ok_or_else(bad)?;
    Ok(Some(total))
}

/// Seconds as Slurm writes a time limit (`D-HH:MM:SS`, without a zero day).
fn show_time(seconds: Option<u64>) -> String {
    match seconds {
        None => "unlimited".into(),
        Some(s) => {
            let (d, h, m, s) = (s / 86_400, s % 86_400 / 3600, s % 3600 / 60, s % 60);
            if d > 0 {
                format!("{d}-{h:02}:{m:02}:{s:02}")
            } else {
                format!("{h:02}:{m:02}:{s:02}")
            }
        }
    }
}

/// The executable `name` on `PATH`.
pub fn tool(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).map(|d| d.join(name)).find(|p| {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            p.metadata().is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        }
        #[cfg(not(unix))]
        {
            p.is_file()
        }
    })
}

fn need(name: &str) -> Result<PathBuf, Error> {
    tool(name).ok_or_else(|| {
        Error::Model(format!(
            "--scheduler slurm: `{name}` is not on PATH, so nothing was submitted. Run the study on a machine \
             with Slurm's client commands (a cluster's login node; `module load slurm` on some), or run it here \
             with --scheduler local"
        ))
    })
}

/// Runs a Slurm command; its standard output, or an error with its standard error.
fn call(program: &Path, args: &[String]) -> Result<String, Error> {
    let shown = || format!("{} {}", program.display(), args.join(" "));
    let out = Command::new(program)
        .args(args)
        .output()
        .map_err(|e| Error::Model(format!("cannot run `{}`: {e}", shown())))?;
    if !out.status.success() {
        return Err(Error::Model(format!(
            "`{}` failed ({}): {}",
            shown(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// A partition as `sinfo` describes it.
#[derive(Clone, Debug, PartialEq)]
struct Partition {
    name: String,
    default: bool,
    /// Its time limit in seconds (`None`: unlimited).
    max_time: Option<u64>,
    /// The most CPUs of one of its nodes.
    cpus: usize,
}

/// The partitions, from `sinfo -h -o %P|%l|%c` (a line per partition and node state).
fn partitions(sinfo: &Path) -> Result<Vec<Partition>, Error> {
    let text = call(sinfo, &["-h".into(), "-o".into(), "%P|%l|%c".into()])?;
    let mut all: Vec<Partition> = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let f: Vec<&str> = line.trim().split('|').collect();
        let [name, limit, cpus] = f[..] else { continue };
        let default = name.ends_with('*');
        let name = name.trim_end_matches('*').to_string();
        let max_time = parse_time(limit).unwrap_or(None);
        let cpus = cpus.trim_end_matches('+').parse().unwrap_or(0);
        match all.iter_mut().find(|p| p.name == name) {
            Some(p) => p.cpus = p.cpus.max(cpus),
            None => all.push(Partition { name, default, max_time, cpus }),
        }
    }
    Ok(all)
}

/// The array indices as Slurm's `--array` list, runs of consecutive ones as ranges.
pub fn array_list(indices: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut k = 0;
    while k < indices.len() {
        let mut j = k;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        parts.push(if j == k { indices[k].to_string() } else { format!("{}-{}", indices[k], indices[j]) });
        k = j + 1;
    }
    parts.join(",")
}

fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// What a submission passes on to its tasks and report.
#[derive(Clone, Debug, Default)]
pub struct Submit {
    /// The scheduler's options (file and command line resolved).
    pub spec: SchedulerSpec,
    /// `--threads-per-run` (used when `cpus_per_run` is 0).
    pub threads_per_run: usize,
    /// `--only` of the study.
    pub only: Vec<String>,
    /// `--max-runs`.
    pub max_runs: u64,
    /// `--max-memory`.
    pub max_memory: Option<String>,
    /// Wait for the report job.
    pub wait: bool,
}

/// What [`submit`] did.
#[derive(Debug, Default)]
pub struct Submitted {
    /// The combinations submitted.
    pub indices: Vec<usize>,
    /// Finished combinations not submitted.
    pub skipped: usize,
    /// The array's job id (empty when nothing was submitted).
    pub array_job: String,
    /// The report job's id (empty when nothing was submitted).
    pub report_job: String,
    /// The `--array` value.
    pub array: String,
    /// The partition.
    pub partition: String,
    /// With `wait`: the report job's end state.
    pub report_state: Option<String>,
}

/// Checks the options against the cluster (before anything is submitted), then submits the
/// unfinished combinations of `plan` as one job array and the report job.
pub fn submit(plan: &Plan, options: &Submit) -> Result<Submitted, Error> {
    let spec = &options.spec;
    let sbatch = need("sbatch")?;
    let sinfo = need("sinfo")?;
    let cpus = if spec.cpus_per_run > 0 { spec.cpus_per_run } else { options.threads_per_run.max(1) };
    if cpus > crate::run::MAX_THREADS {
        return Err(Error::Model(format!("--cpus-per-run {cpus}: at most {}", crate::run::MAX_THREADS)));
    }
    let limit = if spec.time.trim().is_empty() {
        None
    } else {
        let t = parse_time(&spec.time).map_err(|e| Error::Model(format!("--time: {e}")))?;
        if t == Some(0) {
            return Err(Error::Model(format!(
                "--time {}: a limit of 0 lets no run start; give the time one run needs, e.g. --time 01:00:00",
                spec.time
            )));
        }
        Some(t)
    };
    let all = partitions(&sinfo)?;
    let names: Vec<&str> = all.iter().map(|p| p.name.as_str()).collect();
    let partition = if spec.partition.is_empty() {
        all.iter().find(|p| p.default).ok_or_else(|| {
            Error::Model(format!(
                "the cluster has no default partition: give --partition, one of: {}",
                names.join(", ")
            ))
        })?
    } else {
        all.iter().find(|p| p.name == spec.partition).ok_or_else(|| {
            Error::Model(format!(
                "--partition {}: the cluster has no such partition (sinfo); partitions: {}{}",
                spec.partition,
                names.join(", "),
                crate::core::error::did_you_mean(&spec.partition, names.iter().copied())
            ))
        })?
    };
    if let (Some(t), Some(max)) = (limit.flatten(), partition.max_time) {
        if t > max {
            return Err(Error::Model(format!(
                "--time {}: longer than partition {}'s limit of {}; give at most {} or another partition",
                spec.time,
                partition.name,
                show_time(Some(max)),
                show_time(Some(max))
            )));
        }
    }
    if partition.cpus > 0 && cpus > partition.cpus {
        return Err(Error::Model(format!(
            "--cpus-per-run {cpus}: the nodes of partition {} have at most {} CPUs",
            partition.name, partition.cpus
        )));
    }

    let texts: Vec<String> = plan.runs.iter().map(|c| c.case.to_ron()).collect();
    let indices: Vec<usize> =
        (0..plan.runs.len()).filter(|&k| !study::finished(&plan.runs[k].dir, &texts[k])).collect();
    if let (Some(&last), Some(max)) = (indices.last(), max_array_size()) {
        if last >= max {
            return Err(Error::Model(format!(
                "the study has {} runs, but this cluster's array indices end at {} (MaxArraySize = {max} in \
                 slurm.conf): submit it in parts with --only AXIS=LABEL, each part a study folder of its own \
                 (--out)",
                plan.runs.len(),
                max - 1
            )));
        }
    }
    let mut done = Submitted {
        skipped: plan.runs.len() - indices.len(),
        partition: partition.name.clone(),
        ..Submitted::default()
    };
    let dir = folder(&plan.out);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path: path.clone(), source }
    };
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    if indices.is_empty() {
        return Ok(done);
    }
    // the scripts: absolute paths, as a task runs wherever Slurm starts it
    let absolute = |p: &Path| std::path::absolute(p).map_err(io(p));
    let exe = std::env::current_exe().map_err(|e| Error::Model(format!("cannot find this program's path: {e}")))?;
    let mut common = vec![
        quote(&exe.display().to_string()),
        "study".into(),
        quote(&absolute(&plan.file)?.display().to_string()),
        "--out".into(),
        quote(&absolute(&plan.out)?.display().to_string()),
        "--max-runs".into(),
        options.max_runs.to_string(),
        "--quiet".into(),
    ];
    for o in &options.only {
        common.extend(["--only".into(), quote(o)]);
    }
    if let Some(m) = &options.max_memory {
        common.extend(["--max-memory".into(), quote(m)]);
    }
    let script = |what: &str, args: &str| {
        format!(
            "#!/bin/sh\n# written by `multifield study --scheduler slurm`: {what}\nexec {} {args}\n",
            common.join(" ")
        )
    };
    let task = dir.join("task.sh");
    let report = dir.join("report.sh");
    let write = |path: &Path, text: String| -> Result<(), Error> {
        crate::output::write_atomically(path, text.as_bytes())?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).map_err(io(path))?;
        }
        Ok(())
    };
    write(
        &task,
        script(
            "array task I runs combination I of the study",
            &format!("--threads-per-run {cpus} --index \"$SLURM_ARRAY_TASK_ID\""),
        ),
    )?;
    write(&report, script("rebuilds results.csv and the charts when the array has ended", "--report"))?;

    let array = if spec.max_parallel > 0 {
        format!("{}%{}", array_list(&indices), spec.max_parallel)
    } else {
        array_list(&indices)
    };
    let name = format!("multifield-{}", crate::run::directory_name(&plan.study.name));
    let mut args: Vec<String> = vec!["--parsable".into(), format!("--partition={}", partition.name)];
    if let Some(t) = &limit {
        args.push(format!("--time={}", show_time(*t)));
    }
    args.extend(spec.sbatch_args.iter().cloned());
    let mut array_args = args.clone();
    array_args.extend([
        format!("--job-name={name}"),
        format!("--array={array}"),
        format!("--cpus-per-task={cpus}"),
        "--ntasks=1".into(),
        format!("--output={}", absolute(&dir)?.join("%A_%a.log").display()),
        task.display().to_string(),
    ]);
    let job_id = |text: String| text.trim().split(';').next().unwrap_or_default().to_string();
    let array_job = job_id(call(&sbatch, &array_args)?);
    let mut record = Submission { array_job: array_job.clone(), report_job: String::new(), indices: indices.clone() };
    let record_file = dir.join(format!("submission_{array_job}.json"));
    let save = |r: &Submission| {
        let text = serde_json::to_string_pretty(r).map_err(|e| Error::Model(e.to_string()))?;
        crate::output::write_atomically(&record_file, text.as_bytes())
    };
    save(&record)?;
    let mut report_args = args;
    report_args.extend([
        format!("--job-name={name}-report"),
        format!("--dependency=afterany:{array_job}"),
        "--cpus-per-task=1".into(),
        "--ntasks=1".into(),
        format!("--output={}", absolute(&dir)?.join("report_%j.log").display()),
        report.display().to_string(),
    ]);
    let report_job = job_id(call(&sbatch, &report_args)?);
    record.report_job = report_job.clone();
    save(&record)?;
    done.indices = indices;
    done.array_job = array_job;
    done.report_job = report_job.clone();
    done.array = array;
    if options.wait {
        done.report_state = Some(wait_for(&report_job)?);
    }
    Ok(done)
}

/// `MaxArraySize` of the cluster's configuration (`scontrol show config`): array indices
/// are below it. `None` when it cannot be read.
fn max_array_size() -> Option<usize> {
    let out = Command::new(tool("scontrol")?).args(["show", "config"]).output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().find(|l| l.trim_start().starts_with("MaxArraySize"))?;
    line.split('=').nth(1)?.trim().parse().ok()
}

/// The state of a job (`JobState` of `scontrol show job`); `None` once Slurm has forgotten
/// it (`MinJobAge` after it ended) or when `scontrol` is missing.
pub fn job_state(job: &str) -> Option<String> {
    let scontrol = tool("scontrol")?;
    let out = Command::new(scontrol).args(["show", "job", "-o", job]).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let state = text.split_whitespace().find_map(|w| w.strip_prefix("JobState="))?;
    Some(state.to_string())
}

/// Whether a job in this state has not ended yet.
fn active(state: &str) -> bool {
    matches!(
        state,
        "PENDING" | "RUNNING" | "CONFIGURING" | "COMPLETING" | "SUSPENDED" | "REQUEUED" | "RESIZING" | "SIGNALING"
    )
}

/// Waits until the job has ended; its end state (`COMPLETED`, `FAILED`, …; `UNKNOWN` when
/// Slurm forgot it before it was seen to end).
pub fn wait_for(job: &str) -> Result<String, Error> {
    need("scontrol")?;
    let mut last = String::from("UNKNOWN");
    loop {
        match job_state(job) {
            Some(s) if active(&s) => last = s,
            Some(s) => return Ok(s),
            None => return Ok(if active(&last) { "UNKNOWN".into() } else { last }),
        }
        if crate::run::interrupted() {
            return Err(Error::Model(format!(
                "interrupted while waiting for job {job}; it goes on: follow it with `squeue -j {job}`"
            )));
        }
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// The end state slurmstepd wrote into a task's log (`*** JOB … CANCELLED AT … DUE TO TIME
/// LIMIT ***`), if it wrote one.
fn state_in_log(log: &Path) -> Option<String> {
    let text = std::fs::read_to_string(log).ok()?;
    let line = text.lines().rev().find(|l| l.contains("*** JOB ") || l.contains("*** STEP "))?;
    let state = if line.contains("DUE TO TIME LIMIT") {
        "TIMEOUT"
    } else if line.contains("DUE TO PREEMPTION") {
        "PREEMPTED"
    } else if line.contains("DUE TO NODE FAILURE") {
        "NODE_FAIL"
    } else if line.contains("CANCELLED") {
        "CANCELLED"
    } else {
        return None;
    };
    Some(state.into())
}

/// The submissions recorded in `<out>/slurm/`, oldest first.
fn submissions(out: &Path) -> Vec<Submission> {
    let Ok(entries) = std::fs::read_dir(folder(out)) else { return Vec::new() };
    let mut all: Vec<(u64, Submission)> = entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_prefix("submission_").and_then(|n| n.strip_suffix(".json"))?;
            let s: Submission = serde_json::from_str(&std::fs::read_to_string(e.path()).ok()?).ok()?;
            Some((s.array_job.parse().unwrap_or(0), s))
        })
        .collect();
    all.sort_by_key(|(id, _)| *id);
    all.into_iter().map(|(_, s)| s).collect()
}

/// For every unfinished run that a Slurm task started, or that a submission listed, how
/// Slurm ended it ([`ENDED`]), when it ended without finishing; returns how many were
/// recorded. Runs whose task has not ended yet are left alone.
pub fn record_ends(plan: &Plan) -> Result<usize, Error> {
    let subs = submissions(&plan.out);
    let mut recorded = 0;
    for (k, c) in plan.runs.iter().enumerate() {
        if study::finished(&c.dir, &c.case.to_ron()) || Ended::read(&c.dir).is_some() {
            continue;
        }
        let started = TaskRecord::read(&c.dir);
        let job = match &started {
            Some(t) => t.job_id.clone(),
            None => match subs.iter().rev().find(|s| s.indices.contains(&k)) {
                Some(s) => format!("{}_{k}", s.array_job),
                None => continue,
            },
        };
        let log = folder(&plan.out).join(format!("{job}.log"));
        let shown = log.strip_prefix(&plan.out).unwrap_or(&log).display().to_string();
        let (state, how) = match job_state(&job) {
            Some(s) if active(&s) => continue,
            // ended by itself: its summary says how (failed), or it never started
            Some(s) if matches!(s.as_str(), "COMPLETED" | "FAILED") => continue,
            Some(s) => (s, format!("scontrol show job; its log: {shown}")),
            None => match state_in_log(&log) {
                Some(s) => (s, format!("from its log {shown}")),
                None if started.is_some() && !c.dir.join("summary.json").is_file() => {
                    ("KILLED".into(), format!("started, no summary, no record left in Slurm; its log: {shown}"))
                }
                None => continue,
            },
        };
        let text = serde_json::to_string_pretty(&Ended { job_id: job, state, how })
            .map_err(|e| Error::Model(e.to_string()))?;
        crate::output::write_atomically(&c.dir.join(ENDED), text.as_bytes())?;
        recorded += 1;
    }
    Ok(recorded)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_limits_in_slurms_notations() {
        assert_eq!(parse_time("90"), Ok(Some(5400)));
        assert_eq!(parse_time("30:15"), Ok(Some(1815)));
        assert_eq!(parse_time("01:30:00"), Ok(Some(5400)));
        assert_eq!(parse_time("2-00"), Ok(Some(172_800)));
        assert_eq!(parse_time("1-02:03"), Ok(Some(93_780)));
        assert_eq!(parse_time("1-02:03:04"), Ok(Some(93_784)));
        assert_eq!(parse_time("infinite"), Ok(None));
        for bad in ["", "1:60:00", "1:2:3:4", "-1", "a", "1-24:00:00", "1:-2", "99999999999999999999"] {
            assert!(parse_time(bad).is_err(), "{bad}");
        }
        assert_eq!(show_time(Some(93_784)), "1-02:03:04");
        assert_eq!(show_time(Some(5400)), "01:30:00");
    }

    #[test]
    fn array_lists_are_ranges() {
        assert_eq!(array_list(&[0, 1, 2, 5, 7, 8]), "0-2,5,7-8");
        assert_eq!(array_list(&[3]), "3");
    }

    #[test]
    fn slurmstepd_lines_give_the_state() {
        let dir = std::env::temp_dir().join(format!("multifield-slurm-log-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let log = dir.join("1_2.log");
        let case = |line: &str| {
            std::fs::write(&log, format!("step 1\n{line}\n")).unwrap();
            state_in_log(&log)
        };
        assert_eq!(
            case("slurmstepd-vm: error: *** JOB 5 ON vm CANCELLED AT 2026-01-01T00:00:00 ***").as_deref(),
            Some("CANCELLED")
        );
        assert_eq!(
            case("slurmstepd: error: *** JOB 5 ON vm CANCELLED AT 2026-01-01T00:00:00 DUE TO TIME LIMIT ***")
                .as_deref(),
            Some("TIMEOUT")
        );
        assert_eq!(case("all well"), None);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
