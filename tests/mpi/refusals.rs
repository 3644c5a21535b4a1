//! Under `mpirun -np N` with N > 1, `multifield run` refuses before it reads or writes
//! anything (docs/design/mpi.md §7): decomposed runs are not built yet. On one rank it runs.

use super::common::{mpirun, scratch, text};
use std::path::Path;
use std::process::Command;

fn case() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green.ron").display().to_string()
}

#[test]
fn a_run_on_several_ranks_is_refused_before_any_output() {
    let t = "a_run_on_several_ranks_is_refused_before_any_output";
    let dir = scratch("refused");
    let out_dir = dir.join("out");
    let c = case();
    let Some(o) = mpirun(t, 2, &["run", &c, "--out", out_dir.to_str().unwrap(), "--quiet"]) else { return };
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{out}\n{err}");
    assert!(
        err.contains("error: run: a run on 2 ranks is not decomposed yet (issue 19")
            && err.contains("run this case on one process (`multifield run`, or `mpirun -np 1`)"),
        "{err}"
    );
    assert_eq!(err.matches("not decomposed yet").count(), 1, "rank 0 alone prints: {err}");
    assert!(!out_dir.exists(), "a refused run wrote {}", out_dir.display());
    // the other commands too
    let Some(o) = mpirun(t, 2, &["check", &c]) else { return };
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("error: check: runs on one process"), "{}", text(&o).1);
}

/// On one rank `run` runs, and writes the diagnostics of the same binary started without
/// mpirun, byte for byte.
#[test]
fn a_run_on_one_rank_runs_as_without_mpirun() {
    let t = "a_run_on_one_rank_runs_as_without_mpirun";
    let dir = scratch("one_rank");
    let c = case();
    let args = |out: &str| {
        ["run", &c, "--out", out, "--quiet", "--threads", "1", "--set", "time.max_steps=3"].map(str::to_string).to_vec()
    };
    let (under, alone) = (dir.join("mpirun"), dir.join("alone"));
    let a = args(under.to_str().unwrap());
    let Some(o) = mpirun(t, 1, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return };
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}\n{err}");
    let o = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args(alone.to_str().unwrap())).output().unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
    let read = |d: &Path| std::fs::read(d.join("diagnostics.csv")).expect("diagnostics.csv");
    let (a, b) = (read(&under), read(&alone));
    // the header and rows (one every output.interval)
    assert!(String::from_utf8_lossy(&a).lines().count() >= 3);
    assert!(a == b, "diagnostics.csv differs between mpirun -np 1 and no mpirun");
}
