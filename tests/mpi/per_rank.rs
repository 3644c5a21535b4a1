//! Snapshots written per rank (`output.snapshots.layout: PerRank`, issue 19): under
//! `mpirun -np 2/3/4` each rank writes its block to `snapshots/snapshot_<n>/rank_<r>.h5` and
//! rank 0 an XDMF that ties the blocks of each time into one dataset. On `dkt_seed` (an
//! Eulerian fluid with its face velocities, and two resolved disks of material points) at
//! 64 × 256 with rank grids that cut through the disks: the blocks tile the domain once,
//! and every cell value, face velocity and point of the rank files, put together, is the
//! serial run's (its one file per time) to the bit.

use super::common::{mpirun, scratch, text};
use multifield::snapshot::{PointData, Snapshot};
use std::path::Path;
use std::process::Command;

/// Every value of the per-rank snapshot folder `folder` (np files) against the serial
/// snapshot `serial`; returns the number of points compared.
fn compare(np: usize, folder: &Path, serial: &Snapshot) -> usize {
    let [nx, ny] = serial.cells_along();
    let h = serial.spacing;
    let mut covered = vec![0u8; nx * ny];
    // per field: the ranks' points, every array's values a point
    let mut points: Vec<Vec<Vec<u64>>> = vec![Vec::new(); serial.fields.len()];
    for r in 0..np {
        let piece = Snapshot::read(&folder.join(format!("rank_{r:04}.h5"))).unwrap();
        assert_eq!((piece.time, piece.step), (serial.time, serial.step));
        let [bx, by] = piece.cells_along();
        let at = |a: usize| ((piece.origin[a] - serial.origin[a]) / h).round() as usize;
        let (i0, j0) = (at(0), at(1));
        // the block's origin is its first cell's corner, exactly
        assert_eq!(piece.origin[0], serial.origin[0] + h * i0 as f64, "rank {r}");
        for j in 0..by {
            for i in 0..bx {
                covered[(i0 + i) + (j0 + j) * nx] += 1;
            }
        }
        let same_cells = |name: &str, mine: &[f64], whole: &[f64]| {
            let per = whole.len() / (nx * ny);
            assert_eq!(mine.len(), per * bx * by, "np {np} rank {r}: {name}");
            for j in 0..by {
                for i in 0..bx {
                    for c in 0..per {
                        let (m, w) = (mine[(i + j * bx) * per + c], whole[((i0 + i) + (j0 + j) * nx) * per + c]);
                        assert!(m.to_bits() == w.to_bits(), "np {np} rank {r}: {name} at ({i}, {j}): {m} != {w}");
                    }
                }
            }
        };
        for (name, whole) in &serial.cells {
            same_cells(name, &piece.cells[name], whole);
        }
        for (k, f) in serial.fields.iter().enumerate() {
            let mine = &piece.fields[k];
            for (name, whole) in &f.cells {
                same_cells(&format!("{}/{name}", f.group), &mine.cells[name], whole);
            }
            if let Some(faces) = &f.faces {
                let got = mine.faces.as_ref().expect("the block's faces");
                // u: (ny, nx + 1) faces, v: (ny + 1, nx); a block's, its cells' faces
                for (a, (whole, got)) in faces.iter().zip(got).enumerate() {
                    let (wx, fx, fy) = (nx + (a == 0) as usize, bx + (a == 0) as usize, by + (a == 1) as usize);
                    assert_eq!(got.len(), fx * fy);
                    for j in 0..fy {
                        for i in 0..fx {
                            let (m, w) = (got[i + j * fx], whole[(i0 + i) + (j0 + j) * wx]);
                            assert!(m.to_bits() == w.to_bits(), "np {np} rank {r}: face {a} at ({i}, {j})");
                        }
                    }
                }
            }
            if let Some(p) = &mine.points {
                points[k].extend(rows(p));
            }
        }
    }
    assert!(covered.iter().all(|&c| c == 1), "np {np}: the blocks do not tile the domain once");
    let mut compared = 0;
    for (k, f) in serial.fields.iter().enumerate() {
        let Some(p) = &f.points else { continue };
        let mut whole = rows(p);
        // the same points, each once (the ranks' order is not the serial one)
        whole.sort();
        points[k].sort();
        assert!(points[k] == whole, "np {np}: the points of {} differ from the serial run's", f.group);
        compared += whole.len();
    }
    compared
}

/// Each point's values (every array's, then its body) as bits.
fn rows(p: &PointData) -> Vec<Vec<u64>> {
    (0..p.len())
        .map(|q| {
            let mut v: Vec<u64> = p
                .values
                .values()
                .flat_map(|a| {
                    let per = a.len() / p.len();
                    a[q * per..(q + 1) * per].iter().map(|x| x.to_bits())
                })
                .collect();
            v.push(p.body[q] as u64);
            v
        })
        .collect()
}

#[test]
fn snapshots_per_rank_hold_the_serial_values() {
    let t = "snapshots_per_rank_hold_the_serial_values";
    let dir = scratch(t);
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_seed.ron").display().to_string();
    let args = |out: &Path, layout: &str| -> Vec<String> {
        let mut a: Vec<String> = ["run", &case, "--out", &out.display().to_string(), "--quiet", "--threads", "1"]
            .map(str::to_string)
            .to_vec();
        for s in [
            "domain.cells=(64, 256)",
            "time.max_steps=10",
            "output.interval=0",
            "output.charts=false",
            &format!("output.snapshots=Some((interval: 0.05, faces: true, layout: {layout}))"),
        ] {
            a.extend(["--set".to_string(), s.to_string()]);
        }
        a
    };
    let serial = dir.join("serial");
    // one process writes one file a time whatever the layout
    let o = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args(&serial, "PerRank")).output().unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
    let mut files: Vec<String> = std::fs::read_dir(serial.join("snapshots"))
        .unwrap()
        .filter_map(|e| e.unwrap().file_name().to_string_lossy().strip_suffix(".h5").map(str::to_string))
        .collect();
    files.sort();
    assert!(files.len() >= 2, "{files:?}");
    for (np, ranks) in [(2, "(2, 1)"), (3, "(1, 3)"), (4, "(2, 2)")] {
        let out = dir.join(format!("np{np}"));
        let mut a = args(&out, "PerRank");
        a.extend(["--set".to_string(), format!("domain.ranks=Some({ranks})")]);
        let Some(o) = mpirun(t, np, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return };
        let (stdout, err) = text(&o);
        assert!(o.status.success(), "np {np}: {stdout}\n{err}");
        for f in &files {
            let whole = Snapshot::read(&serial.join("snapshots").join(format!("{f}.h5"))).unwrap();
            let folder = out.join("snapshots").join(f);
            let names = std::fs::read_dir(&folder).unwrap().count();
            assert_eq!(names, np, "np {np}: {f} holds one file a rank");
            // the two disks' points (about 290 each at 6.4 cells a diameter, 3² a cell)
            let compared = compare(np, &folder, &whole);
            assert!(compared > 2 * 250, "np {np}: {compared} points in {f}");
            // read whole (`Snapshot::read` of the folder): the serial cells and faces, the
            // serial points in the ranks' order
            let read = Snapshot::read(&folder).unwrap();
            assert_eq!((read.cells_along(), read.origin), (whole.cells_along(), whole.origin), "np {np}: {f}");
            assert!(read.cells == whole.cells, "np {np}: {f}: the mixture's cells");
            for (mine, theirs) in read.fields.iter().zip(&whole.fields) {
                assert!(mine.cells == theirs.cells && mine.faces == theirs.faces, "np {np}: {f}: {}", mine.group);
                if let (Some(a), Some(b)) = (&mine.points, &theirs.points) {
                    let (mut a, mut b) = (rows(a), rows(b));
                    a.sort();
                    b.sort();
                    assert!(a == b, "np {np}: {f}: the points of {}", mine.group);
                }
            }
        }
        check_with_h5py(&out, &format!("np {np}"));
        // the XDMF: a grid of each rank's block (and one of its points, for the ranks that
        // hold disk points) in each time, from its file
        let xdmf = std::fs::read_to_string(out.join("snapshots/dkt_seed.xdmf")).unwrap();
        assert_eq!(xdmf.matches("CollectionType=\"Spatial\"").count(), files.len());
        for f in &files {
            for r in 0..np {
                let grid = format!("<Grid Name=\"grid rank {r}\"");
                assert_eq!(xdmf.matches(&grid).count(), files.len(), "np {np}: {grid}");
                assert!(xdmf.contains(&format!("{f}/rank_{r:04}.h5:/pressure")), "np {np}: {f} rank {r}");
            }
        }
    }
}

/// A run continued from a checkpoint in the same output directory keeps the snapshots
/// written per rank before the checkpoint's step, and numbers on: 10 steps of the
/// Taylor–Green vortex on 2 ranks, then steps 10 to 20 on 3 (a checkpoint restarts on any
/// rank count). The XDMF lists every time once, in order, each time's grids those of the
/// ranks that wrote it; the last snapshot holds the serial run's values.
#[test]
fn a_restart_keeps_the_snapshots_per_rank_before_it() {
    let t = "a_restart_keeps_the_snapshots_per_rank_before_it";
    let dir = scratch(t);
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green.ron").display().to_string();
    let args = |out: &Path, steps: u32, restart: Option<&Path>| -> Vec<String> {
        let mut a: Vec<String> = ["run", &case, "--out", &out.display().to_string(), "--quiet", "--threads", "1"]
            .map(str::to_string)
            .to_vec();
        for s in [
            "domain.cells=(64, 64)".to_string(),
            format!("time.max_steps={steps}"),
            "output.interval=0".into(),
            "output.charts=false".into(),
            "output.checkpoints=Some((interval: 10.0))".into(),
            "output.snapshots=Some((interval: 0.1, faces: true, layout: PerRank))".into(),
        ] {
            a.extend(["--set".to_string(), s]);
        }
        if let Some(r) = restart {
            a.extend(["--restart".to_string(), r.display().to_string()]);
        }
        a
    };
    let serial = dir.join("serial");
    let o = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args(&serial, 20, None)).output().unwrap();
    assert!(o.status.success(), "{:?}", text(&o));
    let out = dir.join("ranks");
    let a = args(&out, 10, None);
    let Some(o) = mpirun(t, 2, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return };
    assert!(o.status.success(), "{:?}", text(&o));
    let before: Vec<String> = snapshot_folders(&out);
    let checkpoint = out.join("checkpoints/checkpoint_10.bin");
    let a = args(&out, 20, Some(&checkpoint));
    let Some(o) = mpirun(t, 3, &a.iter().map(String::as_str).collect::<Vec<_>>()) else { return };
    assert!(o.status.success(), "{:?}", text(&o));
    let after = snapshot_folders(&out);
    // the first run's folders kept but the one of its last step, step 10, which the
    // continued run writes again (at its start, as with one file a time), numbering on
    assert!(before.len() >= 2 && after.len() > before.len() && after.starts_with(&before), "{before:?} {after:?}");
    for (k, f) in after.iter().enumerate() {
        let files = std::fs::read_dir(out.join("snapshots").join(f)).unwrap().count();
        let ranks = if k + 1 < before.len() { 2 } else { 3 };
        assert_eq!(files, ranks, "{f}");
    }
    let xdmf = std::fs::read_to_string(out.join("snapshots/taylor_green.xdmf")).unwrap();
    let times: Vec<f64> = xdmf
        .match_indices("<Time Value=\"")
        .map(|(i, m)| xdmf[i + m.len()..].split('"').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(times.len(), after.len());
    assert!(times.windows(2).all(|w| w[0] < w[1]), "{times:?}");
    for (k, f) in after.iter().enumerate() {
        let ranks = if k + 1 < before.len() { 2 } else { 3 };
        let grid = |r: usize| format!("{f}/rank_{r:04}.h5:/pressure");
        assert!(xdmf.contains(&grid(ranks - 1)) && !xdmf.contains(&grid(ranks)), "{f}");
    }
    check_with_h5py(&out, "after the restart");
    // the last time, step 20, holds the serial run's values
    let last = after.last().unwrap();
    let mut serial_files: Vec<String> = std::fs::read_dir(serial.join("snapshots"))
        .unwrap()
        .filter_map(|e| e.unwrap().file_name().to_string_lossy().strip_suffix(".h5").map(str::to_string))
        .collect();
    serial_files.sort();
    let whole = Snapshot::read(&serial.join("snapshots").join(format!("{}.h5", serial_files.last().unwrap()))).unwrap();
    assert_eq!(whole.step, 20);
    compare(3, &out.join("snapshots").join(last), &whole);
}

/// h5py opens every rank file of the last time and every file:/path the XDMF of the run
/// `out` references, with the stated shapes (tests/output/check_snapshot.py); skipped with
/// a note where h5py is missing (CI installs it).
fn check_with_h5py(out: &Path, what: &str) {
    let h5py = Command::new("python3").args(["-c", "import h5py"]).output().is_ok_and(|o| o.status.success());
    if !h5py {
        println!("note: {what}: h5py not installed (python3 -m pip install h5py): its check skipped");
        return;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/output/check_snapshot.py");
    let o = Command::new("python3").arg(script).arg(out).output().unwrap();
    assert!(o.status.success(), "{what}: check_snapshot.py: {:?}", text(&o));
}

/// The snapshot folders of a run written per rank, in order.
fn snapshot_folders(out: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(out.join("snapshots"))
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}
