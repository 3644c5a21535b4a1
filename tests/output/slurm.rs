//! `multifield study --scheduler slurm` (docs/studies.md, "On a cluster"): the array task's
//! `--index I` and the `--report` reproduce the local runner's directories and table; bad
//! scheduler options are refused before anything is submitted (against stand-in `sinfo` and
//! `sbatch` scripts that record their calls); and, through a real Slurm, the shipped small
//! study gives the local table, and a cancelled task is recorded and rerun alone from its
//! last checkpoint.
//!
//! The real-Slurm tests need `sbatch` on PATH and a running cluster (`.ci/slurm-local.sh
//! start` makes a one-node one). Without `sbatch`, or with the client tools but no
//! controller answering `sinfo`, they print why and pass, unless
//! `MULTIFIELD_REQUIRE_SLURM=1` (set by .ci/run, which starts the cluster): then they fail.

use crate::study::{multifield, table, text};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    super::common::created_dir("slurm", name)
}

fn shipped_study() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/slurm_small.ron")
}

/// The binary with `PATH` set to `path`.
fn multifield_on_path(args: &[&str], path: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_multifield")).args(args).env("PATH", path).output().expect("the binary runs")
}

/// Whether a Slurm cluster is there to test against; see the module's doc.
fn slurm_present(test: &str) -> bool {
    let required = std::env::var("MULTIFIELD_REQUIRE_SLURM").as_deref() == Ok("1");
    let why = if multifield::slurm::tool("sbatch").is_none() {
        "`sbatch` is not on PATH".to_string()
    } else {
        // the client tools without a controller to answer them (installed, not started)
        match Command::new("sinfo").arg("-h").output() {
            Ok(o) if o.status.success() => return true,
            Ok(o) => format!("`sinfo` finds no controller ({})", String::from_utf8_lossy(&o.stderr).trim()),
            Err(e) => format!("`sinfo` does not run ({e})"),
        }
    };
    assert!(
        !required,
        "{test}: MULTIFIELD_REQUIRE_SLURM=1 but {why}: the local Slurm of .ci/slurm-local.sh did not come up"
    );
    eprintln!(
        "{test}: skipped: {why} (`.ci/slurm-local.sh start` runs a local Slurm; \
         MULTIFIELD_REQUIRE_SLURM=1 turns this skip into a failure)"
    );
    false
}

/// The rows without the columns that differ between two runs of the same study.
fn comparable(rows: &[HashMap<String, String>]) -> Vec<HashMap<String, String>> {
    rows.iter()
        .map(|r| {
            r.iter()
                .filter(|(k, _)| *k != "wall_seconds" && *k != "job_id")
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        })
        .collect()
}

/// The files of a run directory, relative, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut all = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                all.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    all.sort();
    all
}

/// summary.json without what differs between two runs of one case: the wall time and paths.
fn summary(dir: &Path) -> serde_json::Value {
    let mut s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for k in ["wall_seconds", "restarted_from", "last_checkpoint"] {
        s.as_object_mut().unwrap().remove(k);
    }
    s
}

/// Counts the files of run directory `b` that equal those of `a` (summary.json up to the
/// wall time); panics on a file of one missing in the other.
fn same_files(a: &Path, b: &Path, skip: &[&str]) -> usize {
    let keep = |p: &PathBuf| !skip.iter().any(|s| p == Path::new(s));
    let (fa, fb): (Vec<PathBuf>, Vec<PathBuf>) =
        (files(a).into_iter().filter(keep).collect(), files(b).into_iter().filter(keep).collect());
    assert_eq!(fa, fb, "{} and {}: the same files", a.display(), b.display());
    fa.iter()
        .filter(|f| {
            if f.as_path() == Path::new("summary.json") {
                summary(a) == summary(b)
            } else {
                std::fs::read(a.join(f)).unwrap() == std::fs::read(b.join(f)).unwrap()
            }
        })
        .count()
}

#[test]
fn index_runs_and_the_report_reproduce_the_local_runner() {
    let dir = scratch("index");
    let study = shipped_study();
    let (local, parts) = (dir.join("local"), dir.join("parts"));
    let s = study.to_str().unwrap();
    let o = multifield(&["study", s, "--out", local.to_str().unwrap(), "--jobs", "2", "--quiet"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("8 runs: 6 completed, 2 unstable, 0 failed (8 run now"), "{}", text(&o));
    for i in 0..8 {
        let o = multifield(&["study", s, "--out", parts.to_str().unwrap(), "--index", &i.to_string()]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains(&format!("run {i} of 8 (")), "{}", text(&o));
    }
    assert!(!parts.join("results.csv").exists(), "--index does not write the table");
    let rows = table(&local.join("results.csv"));
    assert_eq!(rows.len(), 8);
    let mut identical = 0;
    for (k, r) in rows.iter().enumerate() {
        let (a, b) = (local.join(&r["directory"]), parts.join(&r["directory"]));
        let n = same_files(&a, &b, &[]);
        assert_eq!(n, files(&a).len(), "run {k} ({}): every file the same", r["directory"]);
        identical += n;
    }
    assert!(identical >= 8 * 4, "{identical} files compared");
    // the index is the row: run 5 is the second dt of Explicit
    assert_eq!((rows[5]["integration"].as_str(), rows[5]["dt_over_tau"].as_str()), ("Explicit", "1"));
    // a finished run is not run again; an index past the end is refused
    let o = multifield(&["study", s, "--out", parts.to_str().unwrap(), "--index", "5"]);
    assert!(text(&o).contains("run 5 (integration=Explicit, dt_over_tau=1) finished before"), "{}", text(&o));
    let o = multifield(&["study", s, "--out", parts.to_str().unwrap(), "--index", "8"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--index 8: the study slurm_small has 8 runs, numbered 0 to 7"), "{}", text(&o));
    // the report builds the same table and the same chart from the directories
    let o = multifield(&["study", s, "--out", parts.to_str().unwrap(), "--report"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("8 runs: 6 completed, 2 unstable, 0 failed"), "{}", text(&o));
    assert_eq!(comparable(&table(&parts.join("results.csv"))), comparable(&rows));
    let svg = |d: &Path| std::fs::read(d.join("stability_dt_over_tau_integration.svg")).unwrap();
    assert_eq!(svg(&parts), svg(&local), "the same chart");
}

/// A stand-in `sinfo` (partitions `debug`, default, 1 h, and `long`, 2 days; 2 CPUs) and
/// an `sbatch` that appends its arguments to `calls` and answers job id 41 then 42.
fn fake_slurm(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let calls = dir.join("calls");
    let write = |name: &str, body: String| {
        let p = bin.join(name);
        std::fs::write(&p, format!("#!/bin/sh\n{body}")).unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
    };
    write("sinfo", "printf 'debug*|1:00:00|2\\nlong|2-00:00:00|2\\nlong|2-00:00:00|1\\n'\n".into());
    // shell built-ins only: PATH holds just this folder
    let count = "n=40\nwhile read -r _; do n=$((n + 1)); done <";
    write("sbatch", format!("echo \"$@\" >> '{c}'\n{count} '{c}'\necho $n\n", c = calls.display()));
    bin
}

#[test]
fn bad_scheduler_options_are_refused_before_anything_is_submitted() {
    let dir = scratch("bad");
    let study = shipped_study();
    let out = dir.join("out");
    let args = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> =
            ["study", study.to_str().unwrap(), "--out", out.to_str().unwrap(), "--scheduler", "slurm"]
                .iter()
                .map(|s| s.to_string())
                .collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let run = |extra: &[&str], path: &Path| {
        let a = args(extra);
        multifield_on_path(&a.iter().map(String::as_str).collect::<Vec<_>>(), path)
    };
    // no sbatch at all
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = run(&[], &empty);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("`sbatch` is not on PATH, so nothing was submitted"), "{}", text(&o));
    assert!(!out.join("slurm").exists(), "nothing written");

    let bin = fake_slurm(&dir);
    let calls = dir.join("calls");
    for (extra, message) in [
        (
            &["--partition", "gpu"][..],
            "--partition gpu: the cluster has no such partition (sinfo); partitions: debug, long",
        ),
        (&["--time", "2:00:00"], "--time 2:00:00: longer than partition debug's limit of 01:00:00"),
        (&["--time", "0"], "--time 0: a limit of 0 lets no run start"),
        (&["--time", "1:75:00"], "--time: `1:75:00` is not a Slurm time limit"),
        (
            &["--partition", "long", "--cpus-per-run", "3"],
            "--cpus-per-run 3: the nodes of partition long have at most 2 CPUs",
        ),
    ] {
        let o = run(extra, &bin);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", text(&o));
        assert!(text(&o).contains(message), "{extra:?}: {}", text(&o));
        assert!(!calls.exists(), "{extra:?}: sbatch was called");
    }
    // good options: one array of the 8 runs, throttled by the study file's max_parallel (2)
    // unless the command line says otherwise, then the report after it
    let o = run(&["--partition", "long", "--time", "1-12", "--max-parallel", "3", "--sbatch-arg=--qos=low"], &bin);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("8 submitted to Slurm partition long as job array 41 (--array=0-7%3)"), "{}", text(&o));
    let c = std::fs::read_to_string(&calls).unwrap();
    let lines: Vec<&str> = c.lines().collect();
    assert_eq!(lines.len(), 2, "{c}");
    for want in ["--partition=long", "--time=1-12:00:00", "--qos=low", "--array=0-7%3", "--cpus-per-task=1"] {
        assert!(lines[0].split(' ').any(|a| a == want), "{want} in {}", lines[0]);
    }
    assert!(lines[1].split(' ').any(|a| a == "--dependency=afterany:41"), "{}", lines[1]);
    assert!(lines[1].ends_with("report.sh") && lines[0].ends_with("task.sh"));
    let task = std::fs::read_to_string(out.join("slurm/task.sh")).unwrap();
    assert!(task.contains("--index \"$SLURM_ARRAY_TASK_ID\"") && task.contains("--threads-per-run 1"), "{task}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("slurm/submission_41.json")).unwrap()).unwrap();
    assert_eq!(record["report_job"], "42");
    assert_eq!(record["indices"].as_array().unwrap().len(), 8);
    // the study file's own settings: 2 at a time, 5 minutes, the default partition
    std::fs::remove_file(&calls).unwrap();
    let o = run(&[], &bin);
    assert!(o.status.success(), "{}", text(&o));
    let c = std::fs::read_to_string(&calls).unwrap();
    assert!(c.contains("--array=0-7%2") && c.contains("--time=00:05:00") && c.contains("--partition=debug"), "{c}");
}

/// The job array's id from the submission's output.
fn array_job(o: &Output) -> String {
    let t = text(o);
    let at = t.find("as job array ").unwrap_or_else(|| panic!("no job array in: {t}")) + "as job array ".len();
    t[at..].split_whitespace().next().unwrap().to_string()
}

#[test]
fn the_small_study_through_slurm_gives_the_local_table() {
    if !slurm_present("the_small_study_through_slurm_gives_the_local_table") {
        return;
    }
    let dir = scratch("same");
    let study = shipped_study();
    let s = study.to_str().unwrap();
    let (local, cluster) = (dir.join("local"), dir.join("cluster"));
    // the real sinfo's partitions: an unknown one is refused, nothing written
    let o =
        multifield(&["study", s, "--out", cluster.to_str().unwrap(), "--scheduler", "slurm", "--partition", "nosuch"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("--partition nosuch: the cluster has no such partition (sinfo); partitions: "),
        "{}",
        text(&o)
    );
    assert!(!cluster.exists());
    let o = multifield(&["study", s, "--out", local.to_str().unwrap(), "--jobs", "2", "--quiet"]);
    assert!(o.status.success(), "{}", text(&o));
    let o = multifield(&["study", s, "--out", cluster.to_str().unwrap(), "--scheduler", "slurm", "--wait"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("8 runs, 0 finished before; 8 submitted"), "{}", text(&o));
    assert!(text(&o).contains("8 runs: 6 completed, 2 unstable, 0 failed"), "{}", text(&o));
    let job = array_job(&o);
    let (a, b) = (table(&local.join("results.csv")), table(&cluster.join("results.csv")));
    assert_eq!(b.len(), 8);
    assert_eq!(b.iter().filter(|r| ["completed", "unstable"].contains(&r["status"].as_str())).count(), 8);
    assert_eq!(comparable(&a), comparable(&b), "the same rows apart from wall times and job ids");
    for (k, r) in b.iter().enumerate() {
        assert_eq!(r["job_id"], format!("{job}_{k}"), "row {k} ran as array task {k}");
        assert!(cluster.join(format!("slurm/{job}_{k}.log")).is_file());
    }
    let svg = |d: &Path| std::fs::read(d.join("stability_dt_over_tau_integration.svg")).unwrap();
    assert_eq!(svg(&cluster), svg(&local), "the same chart");
    // a second submission has nothing to submit
    let o = multifield(&["study", s, "--out", cluster.to_str().unwrap(), "--scheduler", "slurm", "--wait"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("every one of its 8 runs is finished: nothing submitted"), "{}", text(&o));
}

#[test]
fn a_cancelled_task_is_recorded_and_rerun_alone_from_its_checkpoint() {
    if !slurm_present("a_cancelled_task_is_recorded_and_rerun_alone_from_its_checkpoint") {
        return;
    }
    let dir = scratch("cancel");
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/exchange_box.ron");
    // run 0: a fraction of a second; run 1: a few seconds (a finer grid, many steps), with
    // a checkpoint every 1/20 of it
    let study = format!(
        r#"(
    name: "cancel",
    base: "{}",
    set: ["time.end=40", "output.checkpoints=Some((interval: 2.0))"],
    axes: [(name: "grid", values: Sets([
        (label: "coarse", set: ["time.fixed_dt=0.5"]),
        (label: "fine", set: ["domain.cells=(32, 32)", "time.fixed_dt=0.01"]),
    ]))],
    metrics: [Final("kinetic_energy")],
)"#,
        base.display()
    );
    let file = dir.join("cancel.ron");
    std::fs::write(&file, study).unwrap();
    let (f, cluster, local) = (file.to_str().unwrap(), dir.join("cluster"), dir.join("local"));
    let c = cluster.to_str().unwrap();
    let o = multifield(&["study", f, "--out", c, "--scheduler", "slurm"]);
    assert!(o.status.success(), "{}", text(&o));
    let job = array_job(&o);
    let rows = |d: &Path| table(&d.join("results.csv"));
    let fine = cluster.join("runs/grid-fine");
    // cancel task 1 once it has written a checkpoint
    let start = std::time::Instant::now();
    while multifield::checkpoint::list(&fine).is_empty() {
        assert!(start.elapsed().as_secs() < 120, "no checkpoint of the fine run after 2 minutes");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let o = Command::new("scancel").arg(format!("{job}_1")).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    // the report job (afterany) has the table
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cluster.join(format!("slurm/submission_{job}.json"))).unwrap())
            .unwrap();
    let state = multifield::slurm::wait_for(report["report_job"].as_str().unwrap()).unwrap();
    assert_eq!(state, "COMPLETED");
    let first = rows(&cluster);
    assert_eq!((first[0]["status"].as_str(), first[0]["job_id"].clone()), ("completed", format!("{job}_0")));
    assert_eq!((first[1]["status"].as_str(), first[1]["job_id"].clone()), ("cancelled", format!("{job}_1")));
    assert!(first[1]["reason"].contains(&format!("Slurm ended job {job}_1 as CANCELLED")), "{}", first[1]["reason"]);

    // the resubmission runs the cancelled one alone, from its last checkpoint
    let o = multifield(&["study", f, "--out", c, "--scheduler", "slurm", "--wait"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("2 runs, 1 finished before; 1 submitted"), "{}", text(&o));
    let again = array_job(&o);
    let ran_by = |j: &str| {
        ["grid-coarse", "grid-fine"]
            .iter()
            .filter(|d| {
                multifield::slurm::TaskRecord::read(&cluster.join("runs").join(d)).is_some_and(|t| t.array_job == j)
            })
            .count()
    };
    assert_eq!(ran_by(&again), 1, "runs executed by the resubmission");
    assert_eq!(ran_by(&job), 1, "the first one's completed run is left as it was");
    let second = rows(&cluster);
    assert_eq!(second[1]["status"], "completed");
    assert_eq!(second[1]["job_id"], format!("{again}_1"));
    let restarted: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fine.join("summary.json")).unwrap()).unwrap();
    assert!(restarted["restarted_from"].as_str().is_some_and(|p| p.contains("checkpoint")), "{restarted}");
    // and ends as the uninterrupted run does, bit for bit
    let o = multifield(&["study", f, "--out", local.to_str().unwrap(), "--jobs", "2", "--quiet"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(comparable(&rows(&local)), comparable(&second));
    for name in ["diagnostics.csv", "case.ron"] {
        assert_eq!(
            std::fs::read(fine.join(name)).unwrap(),
            std::fs::read(local.join("runs/grid-fine").join(name)).unwrap(),
            "{name}"
        );
    }
}
