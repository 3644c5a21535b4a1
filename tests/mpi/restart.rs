//! Checkpoints of a decomposed run (issue 19): a checkpoint holds the whole domain's state
//! (gathered onto rank 0), so the checkpoint `mpirun -np 2` writes is the one the run
//! without mpirun writes at the same step, byte for byte, and a restart from it on any
//! number of ranks continues the serial run bit for bit.

use super::common::{mpirun, scratch, text};
use std::path::{Path, PathBuf};
use std::process::Command;

fn args(case: &str, out: &Path, steps: u32, restart: Option<&Path>) -> Vec<String> {
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join(case).display().to_string();
    let mut a: Vec<String> =
        ["run", &case, "--out", &out.display().to_string(), "--quiet", "--threads", "1"].map(str::to_string).to_vec();
    for s in [
        "domain.cells=(64, 64)".to_string(),
        format!("time.max_steps={steps}"),
        "output.interval=0".into(),
        "output.charts=false".into(),
        "output.checkpoints=Some((interval: 0.3))".into(),
    ] {
        a.extend(["--set".to_string(), s]);
    }
    if let Some(r) = restart {
        a.extend(["--restart".to_string(), r.display().to_string()]);
    }
    a
}

fn serial(case: &str, out: &Path, steps: u32, restart: Option<&Path>) {
    let o = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args(case, out, steps, restart)).output().unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
}

fn checkpoint(out: &Path, step: u64) -> PathBuf {
    out.join("checkpoints").join(format!("checkpoint_{step}.bin"))
}

#[test]
fn a_checkpoint_of_ranks_is_the_serial_one_and_restarts_on_any_rank_count() {
    checkpoint_and_restart(
        "a_checkpoint_of_ranks_is_the_serial_one_and_restarts_on_any_rank_count",
        "examples/taylor_green.ron",
    );
}

/// A Lagrangian field: the checkpoint holds every rank's points in id order (the serial
/// arrays), and a restart gives each rank the points in its block.
#[test]
fn a_checkpoint_of_material_points_on_ranks_is_the_serial_one_and_restarts_on_any_rank_count() {
    checkpoint_and_restart(
        "a_checkpoint_of_material_points_on_ranks_is_the_serial_one_and_restarts_on_any_rank_count",
        "examples/taylor_green_flip.ron",
    );
}

fn checkpoint_and_restart(t: &str, case: &str) {
    let dir = scratch(t);
    // the serial run of 20 steps, and one of 10 (its checkpoint at the end)
    let (whole, half) = (dir.join("serial20"), dir.join("serial10"));
    serial(case, &whole, 20, None);
    serial(case, &half, 10, None);
    let reference = std::fs::read(whole.join("diagnostics.csv")).unwrap();
    // 10 steps on 2 ranks: the same checkpoint, byte for byte
    let ranks = dir.join("np2");
    let a = args(case, &ranks, 10, None);
    let Some(o) = mpirun(t, 2, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return };
    assert!(o.status.success(), "{:?}", text(&o));
    let (mine, theirs) = (checkpoint(&ranks, 10), checkpoint(&half, 10));
    assert!(std::fs::read(&mine).unwrap() == std::fs::read(&theirs).unwrap(), "the checkpoints of step 10 differ");
    // continued to step 20 on 3 ranks and on one process: the serial run's rows
    for np in [3, 0] {
        let out = dir.join(format!("restart_np{np}"));
        let a = args(case, &out, 20, Some(&mine));
        let o = if np == 0 {
            Command::new(env!("CARGO_BIN_EXE_multifield")).args(&a).output().unwrap()
        } else {
            let Some(o) = mpirun(t, np, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return };
            o
        };
        assert!(o.status.success(), "np {np}: {:?}", text(&o));
        let got = std::fs::read(out.join("diagnostics.csv")).unwrap();
        assert_eq!(String::from_utf8_lossy(&got).lines().count(), 21, "np {np}");
        assert!(got == reference, "np {np}: the restarted run's diagnostics.csv differs from the uninterrupted one's");
    }
}
