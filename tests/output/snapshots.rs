//! HDF5 snapshots and their XDMF sidecar (`output.snapshots`): what a snapshot holds equals
//! the simulation's state, it reads back equal to what was written, the XDMF lists every
//! snapshot with the paths and shapes in the files, a killed run leaves only complete
//! snapshots, and the reference C library's `h5dump` and `h5py` open the files
//! (`tests/output/check_snapshot.py`; skipped with a note where they are not installed).

use hdf5_pure::{AttrValue, File};
use multifield::core::case::{Case, SnapshotSpec};
use multifield::core::math::Real;
use multifield::core::simulation::Simulation;
use multifield::frames::lagrangian::Lagrangian;
use multifield::run::{run, RunOptions};
use multifield::snapshot::{file_name, xdmf_name, Snapshot, Snapshots};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Water (Eulerian) and a settling rigid disk (Lagrangian) in a 2 × 2 closed box, 16 × 16
/// cells, Δt fixed at 1e-3 (`disk_in_box` of tests/verification/multifield_coupling.rs, smaller).
fn case_text(end: Real, interval: Real) -> String {
    format!(
        r#"(
        name: "snapshot disk", domain: (size: (2.0, 2.0), cells: (16, 16)),
        gravity: (0.0, -981.0),
        time: (end: {end}, max_dt: 1e-3, fixed_dt: Some(1e-3)),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            (name: "disk", density: 1.5,
             frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "pic")),
             region: Bodies([(name: "puck", shape: Disk(center: (1.0, 1.2), radius: 0.3), velocity: (2.0, 0.0))]),
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("water", "disk"), model: "no_slip")],
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-10))),
        output: (interval: 0.0, snapshots: Some((interval: {interval})), charts: false),
    )"#
    )
}

fn case(end: Real, interval: Real) -> Case {
    multifield::link_all();
    Case::from_ron(&case_text(end, interval), Path::new("snapshot_disk.ron")).unwrap()
}

fn out_dir(name: &str) -> PathBuf {
    super::common::created_dir("snapshots", name)
}

fn snapshot_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "h5"))
        .collect();
    v.sort();
    v
}

fn attr_str(attrs: &std::collections::HashMap<String, AttrValue>, k: &str) -> String {
    attrs.get(k).and_then(AttrValue::as_str).unwrap_or_else(|| panic!("attribute {k}: {:?}", attrs.get(k))).into()
}

/// The cell-centred velocity of face velocities, computed here independently of the crate.
fn cell_mean(sim: &Simulation, k: usize) -> Vec<[Real; 2]> {
    let g = &sim.grid;
    let s = &sim.fields[k].state.velocity;
    let mut out = Vec::new();
    for j in 0..g.ny {
        for i in 0..g.nx {
            out.push([
                0.5 * (s.u[i + j * (g.nx + 1)] + s.u[i + 1 + j * (g.nx + 1)]),
                0.5 * (s.v[i + j * g.nx] + s.v[i + (j + 1) * g.nx]),
            ]);
        }
    }
    out
}

fn close(a: Real, b: Real) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
}

/// Driving the writer step by step: each file equals the state it was written from, read
/// back by the crate, and independently computed from the simulation (pressure, θ, the
/// cell-centred velocities, density, points, attributes); t = 0, every interval and the
/// last step are written, the last one once; earlier runs' files are removed.
#[test]
fn a_snapshot_holds_the_simulation_state_and_reads_back_equal() {
    let case = case(0.006, 0.003);
    let dir = out_dir("state");
    // leftovers of an earlier run, and of one killed while writing
    std::fs::create_dir_all(dir.join("snapshots")).unwrap();
    std::fs::write(dir.join("snapshots").join("snapshot_000042.h5"), b"old").unwrap();
    std::fs::write(dir.join("snapshots").join(".snapshot_000003.h5.tmp"), b"partial").unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let mut w = Snapshots::create(&sim, &dir, SnapshotSpec::every(0.003)).unwrap();
    assert!(
        !dir.join("snapshots/snapshot_000042.h5").exists() && !dir.join("snapshots/.snapshot_000003.h5.tmp").exists()
    );
    w.start(&sim).unwrap();
    let initial = Snapshot::of(&sim).unwrap();
    let mut written = vec![(0, initial.clone())];
    for _ in 0..6 {
        sim.step().unwrap();
        let last = sim.steps == 6;
        let before = w.files().len();
        w.after_step(&sim, last).unwrap();
        if w.files().len() > before {
            written.push((sim.steps, Snapshot::of(&sim).unwrap()));
        }
    }
    // t = 0, t = 0.003 (step 3), t = 0.006 (step 6, due and last: once)
    let steps: Vec<u64> = written.iter().map(|(s, _)| *s).collect();
    assert_eq!(steps, [0, 3, 6]);
    let files = snapshot_files(&dir);
    assert_eq!(files, w.files());
    assert_eq!(
        files.iter().map(|f| f.file_name().unwrap().to_str().unwrap()).collect::<Vec<_>>(),
        [file_name(0), file_name(1), file_name(2)]
    );
    for ((step, snap), f) in written.iter().zip(&files) {
        let back = Snapshot::read(f).unwrap();
        assert_eq!(&back, snap, "{} does not read back as written", f.display());
        assert_eq!(back.step, *step);
    }

    // the last snapshot against the simulation, computed here
    let last = File::open(&files[2]).unwrap();
    let (nx, ny) = (16usize, 16usize);
    let root = last.root().attrs().unwrap();
    assert_eq!(root["time"].as_f64(), Some(sim.time));
    assert_eq!(root["step"].as_i64(), Some(6));
    assert_eq!(attr_str(&root, "case"), "snapshot disk");
    assert_eq!(attr_str(&root, "program"), format!("multifield {}", env!("CARGO_PKG_VERSION")));
    assert!(attr_str(&root, "units").contains("case units"));
    let ds = |p: &str| last.dataset(p).unwrap_or_else(|e| panic!("{p}: {e}"));
    let shape = |p: &str| ds(p).shape().unwrap();
    let f64s = |p: &str| ds(p).read_f64().unwrap();
    assert_eq!(shape("pressure"), [ny as u64, nx as u64]);
    assert_eq!(f64s("pressure"), sim.pressure);
    assert!(sim.pressure.iter().any(|p| *p != 0.0));
    assert_eq!(shape("velocity"), [ny as u64, nx as u64, 3]);
    assert_eq!(shape("vorticity"), [ny as u64, nx as u64]);
    let mut mixture = vec![[0.0; 2]; nx * ny];
    let mut sum = vec![0.0; nx * ny];
    for (k, name) in ["water", "disk"].iter().enumerate() {
        let theta = &sim.fields[k].state.theta;
        assert_eq!(f64s(&format!("fields/{name}/theta")), *theta);
        assert_eq!(shape(&format!("fields/{name}/velocity")), [ny as u64, nx as u64, 3]);
        let rho = sim.fields[k].density;
        let density = f64s(&format!("fields/{name}/density"));
        assert!(density.iter().zip(theta).all(|(d, t)| close(*d, t * rho)));
        let v = f64s(&format!("fields/{name}/velocity"));
        let mean = cell_mean(&sim, k);
        for c in 0..nx * ny {
            assert!(close(v[3 * c], mean[c][0]) && close(v[3 * c + 1], mean[c][1]) && v[3 * c + 2] == 0.0);
            sum[c] += theta[c];
            mixture[c][0] += theta[c] * mean[c][0];
            mixture[c][1] += theta[c] * mean[c][1];
        }
        let units = ds(&format!("fields/{name}/density")).attrs().unwrap();
        assert_eq!(attr_str(&units, "units"), "mass/volume");
    }
    let v = f64s("velocity");
    for c in 0..nx * ny {
        assert!(close(v[3 * c], mixture[c][0] / sum[c]) && close(v[3 * c + 1], mixture[c][1] / sum[c]), "cell {c}");
    }
    assert!(v.iter().any(|x| *x != 0.0), "the disk moves the water");
    // the points
    let pts = &sim.fields[1].frame.as_any().downcast_ref::<Lagrangian>().unwrap().points;
    let n = pts.len() as u64;
    assert_eq!(shape("fields/disk/points/position"), [n, 3]);
    let x = f64s("fields/disk/points/position");
    let u = f64s("fields/disk/points/velocity");
    for p in 0..pts.len() {
        assert_eq!([x[3 * p], x[3 * p + 1], x[3 * p + 2]], [pts.x[p].x, pts.x[p].y, 0.0]);
        assert_eq!([u[3 * p], u[3 * p + 1], u[3 * p + 2]], [pts.v[p].x, pts.v[p].y, 0.0]);
    }
    assert_eq!(f64s("fields/disk/points/volume"), (0..pts.len()).map(|p| pts.volume(p)).collect::<Vec<_>>());
    assert_eq!(shape("fields/disk/points/stress"), [n, 3]);
    assert_eq!(ds("fields/disk/points/body").read_i64().unwrap(), vec![0; pts.len()]);
    let pg = last.group("fields/disk/points").unwrap().attrs().unwrap();
    assert_eq!(pg["count"].as_i64(), Some(n as i64));
    assert_eq!(pg["bodies"].as_strings().unwrap(), ["puck"]);
    assert!(last.group("fields/water/points").is_err(), "an Eulerian field has no points");

    // t = 0: θ from the regions (the water takes the rest), the initial velocities, p = 0
    assert_eq!(initial.step, 0);
    assert!(initial.get("pressure").unwrap().iter().all(|p| *p == 0.0));
    let (water, disk) = (&initial.fields[0], &initial.fields[1]);
    let (water_theta, disk_theta) = (water.get("theta").unwrap(), disk.get("theta").unwrap());
    let area: Real = disk_theta.iter().sum::<Real>() * 0.125 * 0.125;
    assert!((area - std::f64::consts::PI * 0.09).abs() < 0.02, "disk area {area}");
    assert!(water_theta.iter().zip(disk_theta).all(|(a, b)| close(a + b, 1.0)));
    // the disk's points move at (2, 0): so does the grid velocity wherever it has mass
    let inside = (0..nx * ny).filter(|&c| disk_theta[c] > 0.99).collect::<Vec<_>>();
    assert!(!inside.is_empty());
    let disk_velocity = disk.get("velocity").unwrap();
    assert!(inside.iter().all(|&c| close(disk_velocity[3 * c], 2.0) && disk_velocity[3 * c + 1].abs() < 1e-12));
    assert!(water.get("velocity").unwrap().iter().all(|v| *v == 0.0));
    let velocity = initial.get("velocity").unwrap();
    assert!(inside.iter().all(|&c| (velocity[3 * c] - 2.0).abs() < 1e-12));
    let _ = std::fs::remove_dir_all(&dir);
}

/// One `<DataItem … Format="HDF">file:/path</DataItem>` of an XDMF: (dimensions, number
/// type, file, path).
fn hdf_items(xdmf: &str) -> Vec<(Vec<u64>, String, String, String)> {
    let attr = |tag: &str, k: &str| {
        let start = tag.find(&format!("{k}=\""))? + k.len() + 2;
        Some(tag[start..start + tag[start..].find('"')?].to_string())
    };
    let mut out = Vec::new();
    let mut rest = xdmf;
    while let Some(a) = rest.find("<DataItem ") {
        let tag_end = a + rest[a..].find('>').unwrap();
        let tag = &rest[a..tag_end];
        let close = tag_end + rest[tag_end..].find("</DataItem>").unwrap();
        let text = rest[tag_end + 1..close].trim();
        if attr(tag, "Format").as_deref() == Some("HDF") {
            let dims = attr(tag, "Dimensions").unwrap().split_whitespace().map(|d| d.parse().unwrap()).collect();
            let (file, path) = text.split_once(':').unwrap();
            out.push((dims, attr(tag, "NumberType").unwrap(), file.to_string(), path.to_string()));
        }
        rest = &rest[close..];
    }
    out
}

/// Checks the XDMF of `dir` against the snapshot files: every referenced file and dataset
/// exists with the stated shape (cell data `1 NY NX` for an (NY, NX) array) and type, the
/// times are the files' `time` attributes. Returns the files it references, in order.
fn check_xdmf(dir: &Path, case_name: &str) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("snapshots").join(xdmf_name(case_name))).unwrap();
    assert!(text.contains("CollectionType=\"Temporal\"") && text.trim_end().ends_with("</Xdmf>"));
    let mut files: Vec<String> = Vec::new();
    for (dims, number, file, path) in hdf_items(&text) {
        let h5 = File::open(dir.join("snapshots").join(&file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let ds = h5.dataset(&path).unwrap_or_else(|e| panic!("{file}:{path}: {e}"));
        let shape = ds.shape().unwrap();
        let ok = dims == shape || (dims.len() == shape.len() + 1 && dims[0] == 1 && dims[1..] == shape[..]);
        assert!(ok, "{file}:{path}: XDMF says {dims:?}, the file {shape:?}");
        assert_eq!(number, if path.ends_with("/body") { "Int" } else { "Float" }, "{path}");
        if !files.contains(&file) {
            files.push(file);
        }
    }
    let times: Vec<Real> = text
        .match_indices("<Time Value=\"")
        .map(|(i, m)| {
            let s = &text[i + m.len()..];
            s[..s.find('"').unwrap()].parse().unwrap()
        })
        .collect();
    assert_eq!(times.len(), files.len());
    for (t, f) in times.iter().zip(&files) {
        let h5 = File::open(dir.join("snapshots").join(f)).unwrap();
        assert_eq!(h5.root().attrs().unwrap()["time"].as_f64(), Some(*t), "{f}");
    }
    assert!(times.windows(2).all(|w| w[0] < w[1]), "{times:?}");
    files
}

/// Through the runner: the snapshots at t = 0, every interval and the end, and the XDMF
/// lists them all with the paths, shapes and times of the files.
#[test]
fn a_run_writes_scheduled_snapshots_and_an_xdmf_of_them_all() {
    let case = case(0.01, 0.004);
    let dir = out_dir("run");
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.summary.status, "completed", "{}", out.summary.reason);
    let files = snapshot_files(&dir);
    let times: Vec<Real> = files.iter().map(|f| Snapshot::read(f).unwrap().time).collect();
    assert_eq!(times.len(), 4, "{times:?}");
    for (t, want) in times.iter().zip([0.0, 0.004, 0.008, 0.01]) {
        assert!((t - want).abs() < 1e-12, "{times:?}");
    }
    let listed = check_xdmf(&dir, &case.name);
    assert_eq!(listed, (0..4).map(file_name).collect::<Vec<_>>());
    let xdmf = std::fs::read_to_string(dir.join("snapshots").join(xdmf_name(&case.name))).unwrap();
    assert!(xdmf.contains("TopologyType=\"3DCoRectMesh\" Dimensions=\"2 17 17\""), "{xdmf}");
    assert!(xdmf.contains("Dimensions=\"1 16 16 3\""));
    assert!(xdmf.contains("TopologyType=\"Polyvertex\""));
    let names: Vec<String> = std::fs::read_dir(dir.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `multifield run` killed (SIGKILL) in the middle of a run with a snapshot every step:
/// every `snapshot_*.h5` left reads back whole and the XDMF lists only complete files.
#[test]
fn a_killed_run_leaves_only_complete_snapshots() {
    let dir = out_dir("killed");
    let case_file = dir.join("case.in.ron");
    std::fs::write(&case_file, case_text(100.0, 1e-3)).unwrap();
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["run", case_file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet", "--threads", "1"])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let count = || std::fs::read_dir(out.join("snapshots")).map(|d| d.count()).unwrap_or(0);
    while count() < 6 && start.elapsed() < Duration::from_secs(120) {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended by itself: {status}");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let files = snapshot_files(&out);
    assert!(files.len() >= 2, "{} snapshots before the kill", files.len());
    for (k, f) in files.iter().enumerate() {
        assert_eq!(f.file_name().unwrap().to_str().unwrap(), file_name(k));
        let s = Snapshot::read(f).unwrap_or_else(|e| panic!("{} after the kill: {e}", f.display()));
        assert_eq!(s.step, k as u64);
    }
    let listed = check_xdmf(&out, "snapshot disk");
    assert!(listed.len() + 1 >= files.len() && listed.len() <= files.len(), "{listed:?} of {files:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run continued from a checkpoint into the same directory keeps the snapshots before
/// the checkpoint's step, replaces the later ones and numbers on: the XDMF lists one
/// increasing series.
#[test]
fn a_restarted_run_keeps_the_earlier_snapshots_and_numbers_on() {
    let dir = out_dir("restart");
    let case_file = dir.join("case.in.ron");
    std::fs::write(
        &case_file,
        case_text(0.008, 0.002).replace("charts: false", "charts: false, checkpoints: Some((interval: 0.005))"),
    )
    .unwrap();
    let out = dir.join("out");
    let exe = env!("CARGO_BIN_EXE_multifield");
    let run = |end: &str, restart: Option<&Path>| {
        let mut c = Command::new(exe);
        c.args(["run", case_file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet", "--set", end]);
        if let Some(r) = restart {
            c.arg("--restart").arg(r);
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run("time.end=0.008", None);
    let steps = |files: &[PathBuf]| files.iter().map(|f| Snapshot::read(f).unwrap().step).collect::<Vec<_>>();
    assert_eq!(steps(&snapshot_files(&out)), [0, 2, 4, 6, 8]);
    // the first checkpoint (t = 0.005, step 5), whatever the files' names beyond their step
    let step_of = |p: &PathBuf| -> u64 {
        let name = p.file_name().unwrap().to_string_lossy();
        name.chars().filter(char::is_ascii_digit).collect::<String>().parse().unwrap_or(u64::MAX)
    };
    let checkpoint =
        std::fs::read_dir(out.join("checkpoints")).unwrap().map(|e| e.unwrap().path()).min_by_key(step_of).unwrap();
    assert_eq!(step_of(&checkpoint), 5, "{}", checkpoint.display());
    run("time.end=0.01", Some(&checkpoint));
    // the checkpoint at t = 0.005 (step 5): steps 0, 2, 4 kept, then 5 (the restart), 6, 8, 10
    let files = snapshot_files(&out);
    assert_eq!(steps(&files), [0, 2, 4, 5, 6, 8, 10]);
    assert_eq!(check_xdmf(&out, "snapshot disk"), (0..7).map(file_name).collect::<Vec<_>>());
    let _ = std::fs::remove_dir_all(&dir);
}

fn available(cmd: &str, args: &[&str]) -> bool {
    Command::new(cmd).args(args).output().is_ok_and(|o| o.status.success())
}

/// The reference C library's `h5dump` reads a snapshot whole, and `tests/output/check_snapshot.py`
/// (h5py) checks values, attributes and the XDMF's paths and shapes. Skipped, with a
/// note, where `h5dump` or h5py is missing (CI installs both).
#[test]
fn h5dump_and_h5py_open_the_snapshots() {
    let (h5dump, h5py) = (available("h5dump", &["--version"]), available("python3", &["-c", "import h5py"]));
    if !h5dump || !h5py {
        println!(
            "note: skipped, {} missing (apt-get install hdf5-tools; python3 -m pip install h5py)",
            [(!h5dump).then_some("h5dump"), (!h5py).then_some("h5py")]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>()
                .join(" and ")
        );
        return;
    }
    let case = case(0.005, 0.002);
    let dir = out_dir("tools");
    run(&case, &dir, &RunOptions::quiet()).unwrap();
    let files = snapshot_files(&dir);
    assert_eq!(files.len(), 4);
    for args in [vec!["-H"], vec!["-A", "-d", "/fields/disk/points/body"], vec!["-d", "/pressure"]] {
        let out = Command::new("h5dump").args(&args).arg(files.last().unwrap()).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "h5dump {args:?}: {}\n{text}", String::from_utf8_lossy(&out.stderr));
        assert!(text.contains("HDF5 \""), "{text}");
        if args == ["-H"] {
            for want in ["GROUP \"fields\"", "DATASET \"pressure\"", "ATTRIBUTE \"program\"", "( 16, 16, 3 )"] {
                assert!(text.contains(want), "h5dump -H lacks {want}:\n{text}");
            }
        }
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/output/check_snapshot.py");
    let out = Command::new("python3").arg(&script).arg(&dir).output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    println!("{stdout}");
    assert!(out.status.success(), "check_snapshot.py failed:\n{stdout}\n{stderr}");
    // and it does fail on a mismatch: an XDMF naming a dataset that is not there
    let xdmf = dir.join("snapshots").join(xdmf_name(&case.name));
    let text = std::fs::read_to_string(&xdmf).unwrap();
    std::fs::write(&xdmf, text.replacen(":/pressure<", ":/pressure_typo<", 1)).unwrap();
    let out = Command::new("python3").arg(&script).arg(&dir).output().unwrap();
    assert!(!out.status.success(), "check_snapshot.py accepted a wrong path");
    assert!(String::from_utf8_lossy(&out.stderr).contains("pressure_typo"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A folder read as a snapshot written per rank (`layout: PerRank`) must hold rank files
/// whose blocks tile a box once: an empty folder, and two copies of one block, are refused
/// naming the folder.
#[test]
fn a_folder_of_rank_files_is_read_whole_or_refused() {
    let dir = out_dir("per_rank_folder");
    let folder = dir.join("snapshot_000000");
    std::fs::create_dir_all(&folder).unwrap();
    let e = Snapshot::read(&folder).unwrap_err().to_string();
    assert!(e.contains("snapshot_000000") && e.contains("no rank_<r>.h5 file in it"), "{e}");
    // one whole snapshot as the only rank file: read back as itself
    let case = case(0.005, 0.002);
    let run_dir = dir.join("run");
    run(&case, &run_dir, &RunOptions::quiet()).unwrap();
    let file = snapshot_files(&run_dir).pop().unwrap();
    std::fs::copy(&file, folder.join("rank_0000.h5")).unwrap();
    assert_eq!(Snapshot::read(&folder).unwrap(), Snapshot::read(&file).unwrap());
    // the same block twice
    std::fs::copy(&file, folder.join("rank_0001.h5")).unwrap();
    let e = Snapshot::read(&folder).unwrap_err().to_string();
    assert!(e.contains("do not tile a box once"), "{e}");
}
