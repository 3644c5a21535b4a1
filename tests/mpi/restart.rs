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

/// Checkpoints written per rank (`output.checkpoints.layout: PerRank`): `dkt_seed` (an
/// Eulerian fluid, two resolved disks of material points) at 64 × 256 on 2 × 2 ranks, 10
/// steps; each rank writes its own state to `checkpoint_10/rank_<r>.bin`. Continued to
/// step 20 on the same 2 × 2 ranks it writes the uninterrupted serial run's
/// `diagnostics.csv` and `bodies.csv` byte for byte; on 3 ranks, on another rank grid of 4,
/// or on one process it is refused before step 0, naming the ranks that wrote it.
#[test]
fn a_checkpoint_per_rank_restarts_on_its_ranks_and_refuses_others() {
    let t = "a_checkpoint_per_rank_restarts_on_its_ranks_and_refuses_others";
    let dir = scratch(t);
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_seed.ron").display().to_string();
    let args = |out: &Path, steps: u32, restart: Option<&Path>, ranks: &str| -> Vec<String> {
        let mut a: Vec<String> = ["run", &case, "--out", &out.display().to_string(), "--quiet", "--threads", "1"]
            .map(str::to_string)
            .to_vec();
        for s in [
            "domain.cells=(64, 256)".to_string(),
            format!("time.max_steps={steps}"),
            "output.interval=0".into(),
            "output.charts=false".into(),
            "output.snapshots=None".into(),
            "output.checkpoints=Some((interval: 10.0, layout: PerRank))".into(),
            format!("domain.ranks={ranks}"),
        ] {
            a.extend(["--set".to_string(), s]);
        }
        if let Some(r) = restart {
            a.extend(["--restart".to_string(), r.display().to_string()]);
        }
        a
    };
    let run = |np: usize, a: Vec<String>| {
        if np == 0 {
            Some(Command::new(env!("CARGO_BIN_EXE_multifield")).args(&a).output().unwrap())
        } else {
            mpirun(t, np, &a.iter().map(String::as_str).collect::<Vec<_>>())
        }
    };
    let serial = dir.join("serial20");
    let o = run(0, args(&serial, 20, None, "None")).unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
    let ranks = dir.join("np4");
    let Some(o) = run(4, args(&ranks, 10, None, "Some((2, 2))")) else { return };
    assert!(o.status.success(), "{:?}", text(&o));
    let folder = ranks.join("checkpoints/checkpoint_10");
    let mut files: Vec<String> =
        std::fs::read_dir(&folder).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    files.sort();
    assert_eq!(files, ["rank_0000.bin", "rank_0001.bin", "rank_0002.bin", "rank_0003.bin"]);
    // only the complete checkpoint is left in the folder (no temporary one)
    assert_eq!(std::fs::read_dir(ranks.join("checkpoints")).unwrap().count(), 1);
    let out = dir.join("restart4");
    let o = run(4, args(&out, 20, Some(&folder), "Some((2, 2))")).unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
    for file in ["diagnostics.csv", "bodies.csv"] {
        let (a, b) = (std::fs::read(serial.join(file)).unwrap(), std::fs::read(out.join(file)).unwrap());
        assert_eq!(String::from_utf8_lossy(&b).lines().count(), String::from_utf8_lossy(&a).lines().count());
        assert!(a == b, "{file}: the run continued on its ranks differs from the uninterrupted serial one");
    }
    // another rank count, another grid of 4, one process: refused, naming the writers
    for (np, grid, says) in [
        (3, "Some((1, 3))", "written per rank by 4 ranks, and this run has 3"),
        (4, "Some((1, 4))", "rank grid 2 × 2), and this run has 4 (rank grid 1 × 4)"),
        (0, "None", "written per rank by 4 ranks, and this run has 1"),
    ] {
        let o = run(np, args(&dir.join(format!("refused{np}")), 20, Some(&folder), grid)).unwrap();
        let (stdout, stderr) = text(&o);
        assert!(!o.status.success(), "np {np} {grid}: {stdout}");
        assert!(stderr.contains(says) && stderr.contains("mpirun -np 4"), "np {np} {grid}: {stderr}");
    }
}
