//! What a 3D run writes: snapshots (read back, by h5py and by VTK's XDMF reader),
//! checkpoints and a restart bit-identical to the run, a checkpoint of the other
//! dimension refused.

use multifield3d::checkpoint;
use multifield3d::core::case::Case;
use multifield3d::run::{run, RunOptions};
use multifield3d::snapshot::Snapshot;
use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dim3-output").join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The low-Re Taylor–Green vortex on an n³ periodic cube, with `output`.
fn tgv(n: usize, end: f64, output: &str) -> Case {
    let text = tgv_text(n, end, output);
    let case = Case::from_ron(&text, Path::new("tgv3.ron")).unwrap();
    case.validate().unwrap();
    case
}

/// The case file of [`tgv`].
fn tgv_text(n: usize, end: f64, output: &str) -> String {
    multifield3d::link_all();
    format!(
        r#"(
    name: "tgv3",
    domain: (size: (6.283185307179586, 6.283185307179586, 6.283185307179586), cells: ({n}, {n}, {n})),
    boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic, back: Periodic, front: Periodic),
    time: (end: {end}, cfl: 0.5, max_dt: 0.05),
    fields: [(name: "water", frame: (model: "eulerian"), density: 1.0, region: All,
              velocity: TaylorGreen(amplitude: 0.001), stress: [(model: "newtonian", params: {{"viscosity": 0.1}})])],
    pressure: Some((model: "multigrid")),
    output: ({output}),
)"#
    )
}

#[test]
fn a_restart_from_a_checkpoint_continues_the_run_bit_for_bit() {
    let case = tgv(12, 0.5, "checkpoints: Some((interval: 0.25))");
    let full = dir("restart/full");
    let a = run(&case, &full, &RunOptions::quiet()).unwrap();
    let list = checkpoint::list(&full);
    assert_eq!(list.iter().map(|c| c.0).collect::<Vec<_>>(), [5, 10], "{list:?}");
    assert_eq!(a.summary.steps, 10);
    let restarted = dir("restart/restarted");
    let options = RunOptions { restart: Some(list[0].1.clone()), ..RunOptions::quiet() };
    let b = run(&case, &restarted, &options).unwrap();
    assert_eq!(b.summary.steps, 10);
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    assert_eq!(read(&full, "diagnostics.csv"), read(&restarted, "diagnostics.csv"));
    let last = checkpoint::file_name(10);
    assert!(read(&full.join("checkpoints"), &last) == read(&restarted.join("checkpoints"), &last), "final checkpoints");
    // the signature says 3D; the 2D library refuses it by name
    let bytes = read(&full.join("checkpoints"), &last);
    assert_eq!(&bytes[..8], checkpoint::MAGIC3);
    let example = multifield::core::case::Case::load(
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/taylor_green.ron")),
        &[],
    )
    .unwrap();
    multifield::link_all();
    let e = match multifield::checkpoint::restore(&example, &full.join("checkpoints").join(&last)) {
        Ok(_) => panic!("a 3D checkpoint restored into a 2D case"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("a checkpoint of a 3D run, and this case is 2D"), "{e}");
}

/// The first interpreter of `python3` and Debian's `/usr/bin/python3` that imports `module`.
fn python_with(module: &str) -> Option<&'static str> {
    ["python3", "/usr/bin/python3"]
        .into_iter()
        .find(|p| Command::new(p).args(["-c", &format!("import {module}")]).output().is_ok_and(|o| o.status.success()))
}

#[test]
fn snapshots_hold_the_3d_arrays_that_h5py_and_the_xdmf_reader_read() {
    let case = tgv(8, 0.1, "snapshots: Some((interval: 0.05, faces: true))");
    let out = dir("snapshots");
    run(&case, &out, &RunOptions::quiet()).unwrap();
    let s = Snapshot::read(&out.join("snapshots/snapshot_000002.h5")).unwrap();
    assert_eq!(s.cells_along(), [8, 8, 8]);
    assert_eq!(s.get("velocity").map(<[f64]>::len), Some(3 * 512));
    assert_eq!(s.get("vorticity").map(<[f64]>::len), Some(3 * 512));
    let faces = s.field("water").and_then(|f| f.faces.clone()).unwrap();
    assert_eq!(faces.each_ref().map(Vec::len), [9 * 64, 9 * 64, 9 * 64]);
    // the cell velocity is the mean of each component's two faces: cell (i, j, k) = (3, 2, 5)
    let (i, j, k) = (3, 2, 5);
    let velocity = s.get("velocity").unwrap();
    let cell = i + 8 * (j + 8 * k);
    let u = 0.5 * (faces[0][i + 9 * (j + 8 * k)] + faces[0][i + 1 + 9 * (j + 8 * k)]);
    let w = 0.5 * (faces[2][i + 8 * (j + 8 * k)] + faces[2][i + 8 * (j + 8 * (k + 1))]);
    assert_eq!((velocity[3 * cell], velocity[3 * cell + 2]), (u, w));
    // the Taylor–Green vortex has no z velocity and its vorticity's z component is
    // ∂v/∂x − ∂u/∂y = 2A cos x cos y cos z (to the grid's error)
    let w_max = faces[2].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let u_max = faces[0].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(w_max < 1e-3 * u_max, "w {w_max}, u {u_max}");

    let file = out.join("snapshots/snapshot_000002.h5");
    match python_with("h5py") {
        None => eprintln!("note: h5py check skipped: no python3 with h5py (python3 -m pip install h5py)"),
        Some(python) => {
            let script = "import h5py, sys\nf = h5py.File(sys.argv[1])\nprint(list(f.attrs['cells']), f['velocity'].shape, \
                          f['fields/water/faces/u'].shape, f['fields/water/faces/v'].shape, f['fields/water/faces/w'].shape)";
            let o = Command::new(python).args(["-c", script]).arg(&file).output().unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert_eq!(
                text.trim(),
                "[np.int64(8), np.int64(8), np.int64(8)] (8, 8, 8, 3) (8, 8, 9) (8, 9, 8) (9, 8, 8)",
                "{o:?}"
            );
        }
    }
    match python_with("vtkmodules.vtkIOXdmf2") {
        None => eprintln!(
            "note: XDMF check skipped: no python3 with VTK's XDMF reader (python3 -m pip install vtk; Debian's \
             python3-vtk9 has no XDMF module)"
        ),
        Some(python) => {
            let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/dim3/read_xdmf.py");
            let o = Command::new(python).arg(script).arg(out.join("snapshots/tgv3.xdmf")).output().unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(o.status.success(), "{o:?}");
            // three times, each a uniform grid of 8³ cells with the velocity as 3-vectors whose
            // largest |u| is the snapshot's
            let speed_max = (0..512)
                .map(|c| (velocity[3 * c].powi(2) + velocity[3 * c + 1].powi(2) + velocity[3 * c + 2].powi(2)).sqrt())
                .fold(0.0, f64::max);
            let last = text.lines().rfind(|l| l.starts_with("velocity")).unwrap_or_default().to_string();
            let fields: Vec<&str> = last.split_whitespace().collect();
            assert_eq!(text.lines().filter(|l| l.starts_with("grid 512 cells")).count(), 3, "{text}");
            assert_eq!(fields[..3], ["velocity", "512", "3"], "{text}");
            let read_max: f64 = fields[3].parse().unwrap();
            assert!((read_max / speed_max - 1.0).abs() < 1e-12, "{read_max} against {speed_max}");
        }
    }
}

#[test]
fn monitors_sample_all_three_components() {
    let monitors = r#"output: (), monitors: [
        (name: "probe", of: Probes(quantity: "velocity", points: [(1.5707963267948966, 3.141592653589793, 0.0)])),
        (name: "vorticity", of: Average(quantity: "vorticity", min: (0.0, 0.0, 0.0), max: (6.28, 6.28, 6.28))),
    ],"#;
    let text = tgv_text(16, 0.1, "").replacen("output: (),", monitors, 1);
    let case = Case::from_ron(&text, Path::new("tgv3.ron")).unwrap();
    let out = dir("monitors");
    run(&case, &out, &RunOptions::quiet()).unwrap();
    let probe = std::fs::read_to_string(out.join("monitors/probe.csv")).unwrap();
    let mut lines = probe.lines();
    assert_eq!(lines.next(), Some("step,time,p0_x,p0_y,p0_z"));
    // at t = 0, (π/2, π, 0): u = A sin x cos y cos z = −A, v = w = 0 (bilinear on the faces:
    // u is interpolated between the faces either side along y and z, O(h²))
    let first: Vec<f64> = lines.next().unwrap().split(',').map(|x| x.parse().unwrap()).collect();
    let h = std::f64::consts::TAU / 16.0;
    assert!((first[2] + 1e-3).abs() < 1e-3 * h * h, "{first:?}");
    assert!(first[3].abs() < 1e-18 && first[4] == 0.0, "{first:?}");
    let vorticity = std::fs::read_to_string(out.join("monitors/vorticity.csv")).unwrap();
    assert!(vorticity.starts_with("step,time,mean_x,mean_y,mean_z\n"), "{vorticity}");
}
