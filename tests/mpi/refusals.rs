//! Under `mpirun -np N` with N > 1, what is not decomposed yet is refused before step 0
//! (docs/design/mpi.md §7), rank 0 saying why: a plugin (named with its key), the output
//! that is not written from many ranks yet (pictures), a domain the ranks do not fit, and
//! every command but `run` and
//! `mpi-check`. On one rank a run is the run without mpirun.

use super::common::{mpirun, scratch, text};
use std::path::Path;
use std::process::Command;

fn case() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green.ron").display().to_string()
}

#[test]
fn what_is_not_decomposed_is_refused_before_step_0() {
    let t = "what_is_not_decomposed_is_refused_before_step_0";
    let dir = scratch("refused");
    let c = case();
    let run = |name: &str, sets: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["run".to_string(), c.clone(), "--out".into(), out.display().to_string(), "--quiet".into()];
        args.extend(["--set".to_string(), "domain.cells=(64, 64)".into()]);
        for s in sets {
            args.extend(["--set".to_string(), s.to_string()]);
        }
        let o = mpirun(t, 2, &args.iter().map(String::as_str).collect::<Vec<_>>())?;
        Some((o, out))
    };
    // a Lagrangian field on the collocated grid (mpm88's fast path): not decomposed yet
    let mpm88 = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mpm88.ron").display().to_string();
    let out = dir.join("mpm88");
    let Some(o) = mpirun(t, 2, &["run", &mpm88, "--out", out.to_str().unwrap(), "--quiet"]) else { return };
    let (stdout, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{stdout}\n{err}");
    assert!(
        err.contains(
            "fields.fluid.frame: the `lagrangian` frame does not run on several ranks yet, and this run has 2"
        ) && err.contains("Lagrangian fields (material or resolved bodies) on the staggered grid"),
        "{err}"
    );
    assert_eq!(err.matches("does not run on several ranks").count(), 1, "rank 0 alone prints: {err}");
    // as on one process, a case that cannot start leaves its summary
    let summary = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    assert!(summary.contains("\"status\": \"failed\""), "{summary}");
    assert!(!out.join("diagnostics.csv").exists());
    // pictures are not drawn from many ranks yet
    let Some((o, _)) = run("pictures", &["output.pictures=Some((interval: 0.1, quantity: Speed))"]) else { return };
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("output.pictures: pictures: not yet on several ranks"), "{}", text(&o).1);
    // 6 × 6 cells: cuts along x on multiples of 32 cells, blocks of at least 4 cells
    let Some((o, _)) = run("cells", &["domain.cells=(6, 6)"]) else { return };
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("domain.cells: a run on 2 ranks:"), "{}", text(&o).1);
    // the other commands
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
