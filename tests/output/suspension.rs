//! A `Suspension` monitor's statistics beyond its CSV files (issue 15): in the HDF5
//! snapshots (read back by the crate and by h5py in `check_snapshot.py`), as study metrics
//! over a window of time, and compared between the resolved and the mass-point run of one
//! scene by `multifield compare`.

use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::monitor::suspension::COLUMNS;
use multifield::core::simulation::Status;
use multifield::core::table::Table;
use multifield::run::{run, RunOptions};
use multifield::snapshot::Snapshot;
use std::path::{Path, PathBuf};
use std::process::Command;

fn out_dir(name: &str) -> PathBuf {
    super::common::created_dir("suspension", name)
}

/// A cloud of 16 generated disks (d = 0.1) settling in a closed 1 × 2 box of water,
/// with `representation`, the monitor `s` (8 slabs along y) on `every`, and snapshots
/// every 0.005.
fn cloud(representation: &str, cells: [usize; 2], end: Real, every: &str) -> String {
    format!(
        r#"(
    name: "cloud",
    domain: (size: (1.0, 2.0), cells: ({nx}, {ny})),
    boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
    gravity: (0.0, -981.0),
    time: (end: {end}, cfl: 0.4, max_dt: 1e-3),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),
        (name: "disks", density: 1.5, frame: (model: "lagrangian"), representation: {representation},
         region: Bodies([]),
         generate: [(name: "p", region: (min: (0.1, 0.8), max: (0.9, 1.9)), count: Some(16),
                     diameter: Fixed(0.1), min_gap: 0.03, seed: 7)],
         stress: [(model: "rigid")]),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip",
                mass_point: Some((model: "cylinder", params: (added_mass: 1.0))))],
    contact: Some((model: "repulsion")),
    pressure: Some((model: "pcg", params: (tolerance: 1e-8))),
    monitors: [(name: "s", every: {every}, of: Suspension(field: "disks", bins: 8))],
    output: (interval: 0.005, charts: false, snapshots: Some((interval: 0.005))),
)"#,
        nx = cells[0],
        ny = cells[1]
    )
}

fn case_of(dir: &Path, text: &str) -> Case {
    multifield::link_all();
    let path = dir.join("cloud.ron");
    std::fs::write(&path, text).unwrap();
    Case::load(&path, &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn table(path: &Path) -> Table {
    Table::read(path).unwrap().unwrap_or_else(|| panic!("{} is missing", path.display()))
}

fn column(t: &Table, name: &str) -> Vec<Real> {
    t.numbers(name).unwrap_or_else(|| panic!("no column {name} in {:?}", t.header))
}

/// Equal, NaN equal to NaN (an empty slab's velocity).
fn same(a: Real, b: Real) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// Every snapshot holds `/suspension/s`: its statistics and profile equal, bit for bit,
/// the monitor's CSV rows of the snapshot's step, read back by the crate and by h5py
/// (`check_snapshot.py`, which also fails on a CSV changed in one digit).
#[test]
fn the_snapshots_hold_the_suspension_statistics_of_the_csv() {
    let dir = out_dir("snapshots");
    let case = case_of(&dir, &cloud("MassPoint", [16, 32], 0.02, "Step"));
    let run_dir = dir.join("run");
    let outcome = run(&case, &run_dir, &RunOptions::quiet()).unwrap();
    assert_eq!(outcome.status, Status::Completed);
    let rows = table(&run_dir.join("monitors/s.csv"));
    let profiles = table(&run_dir.join("monitors/s_profiles.csv"));
    let (steps, psteps, bins) = (column(&rows, "step"), column(&profiles, "step"), column(&profiles, "bin"));
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(run_dir.join("snapshots")).unwrap().map(|e| e.unwrap().path()).collect();
    files.retain(|p| p.extension().is_some_and(|e| e == "h5"));
    files.sort();
    assert_eq!(files.len(), 5, "t = 0, 0.005, 0.01, 0.015, 0.02");
    for f in &files {
        let snap = Snapshot::read(f).unwrap();
        let s = snap.suspension("s").unwrap_or_else(|| panic!("{}: no /suspension/s", f.display()));
        assert_eq!((s.field.as_str(), s.axis.as_str(), s.profiles.len()), ("disks", "Y", 8));
        let r = steps.iter().position(|&k| k == snap.step as Real).expect("a row of the snapshot's step");
        for (k, c) in COLUMNS.iter().enumerate() {
            let want = column(&rows, c)[r];
            assert!(same(s.statistics[k], want), "{}: {c} = {} against {want}", f.display(), s.statistics[k]);
        }
        let slabs: Vec<usize> = (0..psteps.len()).filter(|&k| psteps[k] == snap.step as Real).collect();
        assert_eq!(slabs.len(), 8);
        for &k in &slabs {
            let b = bins[k] as usize;
            for (c, name) in ["centre", "solid_fraction", "u_x", "u_y"].iter().enumerate() {
                let want = column(&profiles, name)[k];
                assert!(same(s.profiles[b][c], want), "{}: slab {b} {name}", f.display());
            }
        }
    }
    // the last snapshot: the cloud settles (not a state at rest compared with itself)
    let last = Snapshot::read(files.last().unwrap()).unwrap();
    let settling = last.suspension("s").unwrap().statistics[4];
    assert!(settling > 0.5, "settling velocity {settling} cm/s at t = 0.02");
    if !Command::new("python3").args(["-c", "import h5py"]).output().is_ok_and(|o| o.status.success()) {
        println!("note: h5py missing, its check skipped (python3 -m pip install h5py)");
        return;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/output/check_snapshot.py");
    let out = Command::new("python3").arg(&script).arg(&run_dir).output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    println!("{stdout}");
    assert!(out.status.success(), "check_snapshot.py failed:\n{stdout}\n{stderr}");
    assert!(stdout.contains("5 suspension groups equal to their monitors' CSV rows"), "{stdout}");
    // one digit changed in the CSV's last bed height: h5py's check finds it
    let csv = run_dir.join("monitors/s.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let last_line = text.lines().last().unwrap();
    let mut cells: Vec<String> = last_line.split(',').map(String::from).collect();
    let k = 2 + COLUMNS.iter().position(|c| *c == "bed_height").unwrap();
    cells[k] = (cells[k].parse::<Real>().unwrap() * (1.0 + 1e-12)).to_string();
    std::fs::write(&csv, text.replace(last_line, &cells.join(","))).unwrap();
    let out = Command::new("python3").arg(&script).arg(&run_dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("`bed_height`"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A study's `Monitor` metric on a `Suspension` column over a window of time equals the
/// trapezoidal mean of the CSV's rows in the window computed here; a window that is not a
/// span of time is refused.
#[test]
fn a_study_metric_averages_the_settling_velocity_over_a_window() {
    let dir = out_dir("study");
    std::fs::write(dir.join("cloud.ron"), cloud("MassPoint", [16, 32], 0.02, "Time(0.002)")).unwrap();
    let study = |metrics: &str| {
        let path = dir.join("s.ron");
        std::fs::write(
            &path,
            format!(
                r#"(name: "s", base: "cloud.ron",
                    axes: [(name: "seed", values: List(path: "fields.disks.generate.0.seed", values: [7, 8]))],
                    set: ["output.snapshots=None"],
                    metrics: [{metrics}],
                    charts: [AccuracyCost(series: [])])"#
            ),
        )
        .unwrap();
        let out = dir.join("out");
        let o = Command::new(env!("CARGO_BIN_EXE_multifield"))
            .args(["study", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"])
            .output()
            .unwrap();
        (o, out)
    };
    let (o, out) = study(
        r#"Monitor(monitor: "s", column: "settling_velocity", of: Mean, window: Some((0.005, 0.015))),
           Monitor(monitor: "s", column: "bed_height", of: Min)"#,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let results = table(&out.join("results.csv"));
    let directories: Vec<String> =
        results.rows.iter().map(|r| r[results.index("directory").unwrap()].to_string()).collect();
    assert_eq!(directories.len(), 2);
    let (mean, min) =
        (column(&results, "mean_s_settling_velocity_in_0.005_0.015"), column(&results, "min_s_bed_height"));
    for (k, d) in directories.iter().enumerate() {
        let s = table(&out.join(d).join("monitors/s.csv"));
        let (t, u, bed) = (column(&s, "time"), column(&s, "settling_velocity"), column(&s, "bed_height"));
        let inside: Vec<usize> = (0..t.len()).filter(|&i| (0.005..=0.015).contains(&t[i])).collect();
        assert!(inside.len() >= 4, "{} rows in the window", inside.len());
        let mut area = 0.0;
        for w in inside.windows(2) {
            area += 0.5 * (u[w[0]] + u[w[1]]) * (t[w[1]] - t[w[0]]);
        }
        let want = area / (t[inside[inside.len() - 1]] - t[inside[0]]);
        eprintln!("run {d}: mean settling velocity over [0.005, 0.015] {} against {want}", mean[k]);
        assert!((mean[k] - want).abs() <= 1e-12 * want.abs(), "{} against {want}", mean[k]);
        // not the mean over every row (the cloud accelerates from rest)
        let all = s.rows.len();
        let mut whole = 0.0;
        for i in 1..all {
            whole += 0.5 * (u[i] + u[i - 1]) * (t[i] - t[i - 1]);
        }
        assert!((mean[k] - whole / (t[all - 1] - t[0])).abs() > 1e-3 * want.abs());
        assert_eq!(min[k], bed.iter().copied().fold(Real::INFINITY, Real::min));
    }
    let (o, _) = study(r#"Monitor(monitor: "s", column: "settling_velocity", of: Mean, window: Some((0.02, 0.01)))"#);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("metrics.0.window") && e.contains("from ≤ to"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `multifield compare` on the cloud: the L2 and L∞ differences point − resolved of the
/// settling velocity, the bed height and the granular temperature (the point run's rows
/// interpolated linearly at the resolved run's times) and of the last solid-fraction
/// profile equal those computed here from the two runs' CSV files.
#[test]
fn compare_gives_the_differences_of_the_suspension_statistics() {
    let dir = out_dir("compare");
    let case = case_of(&dir, &cloud("Resolved", [32, 64], 0.01, "Time(0.002)"));
    let out = dir.join("out");
    let c = multifield::compare::compare(&case, &[], &out, &RunOptions::quiet(), None).unwrap();
    assert_eq!((c.resolved.status.as_str(), c.point.status.as_str()), ("completed", "completed"));
    let read = |run: &str, f: &str| table(&out.join(run).join("monitors").join(f));
    let (r, p) = (read("resolved", "s.csv"), read("point", "s.csv"));
    let (tr, tp) = (column(&r, "time"), column(&p, "time"));
    assert_eq!(c.suspension.len(), 4);
    for (k, q) in ["settling_velocity", "bed_height", "temperature"].iter().enumerate() {
        let (yr, yp) = (column(&r, q), column(&p, q));
        let mut d = Vec::new();
        for (i, &t) in tr.iter().enumerate() {
            // the point run's row pair around t
            let Some(j) = (1..tp.len()).find(|&j| tp[j - 1] <= t && t <= tp[j]) else { continue };
            let y = yp[j - 1] + (yp[j] - yp[j - 1]) * (t - tp[j - 1]) / (tp[j] - tp[j - 1]);
            d.push(y - yr[i]);
        }
        let l2 = (d.iter().map(|x| x * x).sum::<Real>() / d.len() as Real).sqrt();
        let linf = d.iter().map(|x| x.abs()).fold(0.0, Real::max);
        let got = &c.suspension[k];
        eprintln!("{q}: {} samples, L2 {} (here {l2}), L∞ {} (here {linf})", got.samples, got.l2, got.linf);
        assert_eq!((got.monitor.as_str(), got.quantity.as_str(), got.samples), ("s", *q, d.len()));
        assert!(d.len() >= 5, "{} samples", d.len());
        assert!((got.l2 - l2).abs() <= 1e-12 * l2 && (got.linf - linf).abs() <= 1e-12 * linf, "{got:?}");
        assert!(linf > 0.0, "the representations differ");
    }
    // the last profiles, slab by slab
    let (rp, pp) = (read("resolved", "s_profiles.csv"), read("point", "s_profiles.csv"));
    let last = |t: &Table| -> Vec<Real> {
        let (step, phi) = (column(t, "step"), column(t, "solid_fraction"));
        let end = step[step.len() - 1];
        step.iter().zip(phi).filter(|(s, _)| **s == end).map(|(_, x)| x).collect()
    };
    let d: Vec<Real> = last(&rp).iter().zip(last(&pp)).map(|(a, b)| b - a).collect();
    assert_eq!(d.len(), 8);
    let l2 = (d.iter().map(|x| x * x).sum::<Real>() / 8.0).sqrt();
    let got = &c.suspension[3];
    assert_eq!(got.quantity, "solid_fraction_profile");
    assert!((got.l2 - l2).abs() <= 1e-12 * l2.max(1e-300), "{} against {l2}", got.l2);
    let csv = std::fs::read_to_string(out.join("suspension_comparison.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(std::fs::read_to_string(out.join("comparison.json")).unwrap().contains("\"solid_fraction_profile\""));
    for f in ["compare_suspension_s.png", "compare_suspension_s.svg"] {
        assert!(std::fs::metadata(out.join(f)).unwrap().len() > 500, "{f}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
