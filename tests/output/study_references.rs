//! Study references that vary along an axis (issue 15): `Run` (the run of the same group
//! with given labels on given axes, compared by a metric) and `Table` (a known value of a
//! metric per label of an axis), on a CI-sized version of the shipped hindered-settling
//! study (studies/hindered_settling.ron on studies/hindered_box.ron: 32 disks on a square
//! lattice settling in a closed box periodic in x).

use super::study::{multifield, table, text};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

type Row = HashMap<String, String>;

fn scratch(name: &str) -> PathBuf {
    super::common::created_dir("study_references", name)
}

fn num(row: &Row, column: &str) -> f64 {
    row[column].parse().unwrap_or_else(|_| panic!("{column} = `{}` is not a number", row[column]))
}

const METRIC: &str = "mean_s_settling_velocity_in_0.05_0.1";

/// The hindered-settling scene at φ = 0.1 and 0.4, 4 and 8 cells per lattice spacing, as
/// mass points and resolved by direct forcing, to t = 0.1 s; `reference` is the study's.
fn study(reference: &str) -> String {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies").join("hindered_box.ron");
    format!(
        r#"(
    name: "hs_ci",
    base: "{base}",
    set: ["time.end=0.1", "exchange.0.mass_point=Some((model: \"cylinder\", params: (di_felice: true)))"],
    axes: [
        (name: "representation", values: Sets([
            (label: "points", set: ["fields.disks.representation=MassPoint"]),
            (label: "direct", set: []),
        ])),
        (name: "phi", values: Sets([
            (label: "0.1", set: []),
            (label: "0.4", set: ["fields.disks.generate.0.diameter=Fixed(0.071365)",
                                 "fields.disks.generate.0.region.min=(0.014318, 0.014318)"]),
        ])),
        (name: "cells_per_s", values: Sets([
            (label: "4", set: ["domain.cells=(16, 32)", "domain.point_cells=Some((16, 32))"]),
            (label: "8", set: []),
        ])),
    ],
    metrics: [Monitor(monitor: "s", column: "settling_velocity", of: Mean, window: Some((0.05, 0.1)))],
    reference: {reference},
    charts: [AccuracyCost(series: ["representation"]), StabilityMap(x: "phi", y: "cells_per_s")],
)"#,
        base = base.display()
    )
}

/// The time-weighted mean of `settling_velocity` over 0.05 ≤ t ≤ 0.1 in the run's
/// monitors/s.csv, by the trapezoidal rule, computed here from the file.
fn mean_settling_velocity(run: &Path) -> f64 {
    let t = std::fs::read_to_string(run.join("monitors").join("s.csv")).unwrap();
    let mut lines = t.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (kt, ku) = (
        header.iter().position(|h| *h == "time").unwrap(),
        header.iter().position(|h| *h == "settling_velocity").unwrap(),
    );
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|s| s.parse().unwrap()).collect();
            (f[kt], f[ku])
        })
        .filter(|(t, _)| (0.05..=0.1).contains(t))
        .collect();
    assert!(rows.len() >= 5, "{}: {} rows in the window", run.display(), rows.len());
    let area: f64 = rows.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum();
    area / (rows[rows.len() - 1].0 - rows[0].0)
}

/// `Run(labels: {representation: direct, cells_per_s: 8}, compare: Metric(...))`: every
/// run's error is |U − U_ref| / U_ref against the resolved run at 8 cells per spacing of
/// its own solid fraction, computed here from the runs' monitor files to 1e-12; the two
/// reference runs have error 0 and differ from each other (the reference varies along φ).
/// Then a `Table` of Sangani & Acrivos's settling velocities per φ over the same runs (the
/// study file changed, the cases did not: nothing runs again), its errors computed here
/// from the same values. Stability: the resolved run at 1.4 cells per diameter is stopped
/// by the overlap check; the others complete.
#[test]
fn run_and_table_references_measure_each_run_against_its_own_solid_fraction() {
    let dir = scratch("hindered");
    let file = dir.join("hs_ci.ron");
    let out = dir.join("out");
    std::fs::write(
        &file,
        study(&format!(
            r#"Run(labels: {{"representation": "direct", "cells_per_s": "8"}}, compare: Metric("{METRIC}"))"#
        )),
    )
    .unwrap();
    let args = ["study", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "2", "-q"];
    let o = multifield(&args);
    assert!(o.status.success(), "{}", text(&o));
    let rows = table(&out.join("results.csv"));
    assert_eq!(rows.len(), 8);
    let find = |r: &str, phi: &str, c: &str| -> &Row {
        rows.iter().find(|x| x["representation"] == r && x["phi"] == phi && x["cells_per_s"] == c).unwrap()
    };
    // stability: the resolved lattice at 4 cells per spacing and φ = 0.1 (1.4 cells per
    // diameter) is stopped by the overlap check: its lowest row sinks into the bottom wall
    // (the `dem` contact holds a disk there only to within half its radius); every other run
    // completes, the mass points at φ = 0.4 and 8 cells per spacing (5.7 cells per
    // diameter) too
    let unstable = find("direct", "0.1", "4");
    assert_eq!(unstable["status"], "unstable", "{unstable:?}");
    assert!(unstable["reason"].contains("crosses the Bottom wall"), "{}", unstable["reason"]);
    assert_eq!(unstable["error"], "", "an unstable run has no error");
    let rows: Vec<&Row> = rows.iter().filter(|r| !std::ptr::eq(*r, unstable)).collect();
    let mut measured = HashMap::new();
    for r in &rows {
        assert_eq!(r["status"], "completed", "{r:?}");
        let u = mean_settling_velocity(&out.join(&r["directory"]));
        assert!((num(r, METRIC) - u).abs() <= 1e-12 * u, "{r:?}: the metric against {u}");
        measured.insert((r["representation"].clone(), r["phi"].clone(), r["cells_per_s"].clone()), u);
    }
    for r in &rows {
        let reference = measured[&("direct".to_string(), r["phi"].clone(), "8".to_string())];
        let u = measured[&(r["representation"].clone(), r["phi"].clone(), r["cells_per_s"].clone())];
        let want = ((u - reference) / reference).abs();
        assert!((num(r, "error") - want).abs() <= 1e-12 * want.max(1e-300), "{r:?}: error against {want}");
    }
    for phi in ["0.1", "0.4"] {
        assert_eq!(num(find("direct", phi, "8"), "error"), 0.0, "the reference against itself");
    }
    let (u1, u4) = (num(find("direct", "0.1", "8"), METRIC), num(find("direct", "0.4", "8"), METRIC));
    // each φ its own reference: the denser lattice settles more than twice slower (Sangani
    // & Acrivos: 0.198 against 0.090 cm/s)
    assert!(u1 / u4 > 2.0, "U(0.1) = {u1}, U(0.4) = {u4}");

    // the same runs against Sangani & Acrivos's square arrays: nothing is run again
    let sa = [("0.1", 0.197543), ("0.4", 0.0900454)];
    std::fs::write(
        &file,
        study(&format!(
            r#"Table(column: "{METRIC}", axis: "phi", values: [("0.1", {}), ("0.4", {})])"#,
            sa[0].1, sa[1].1
        )),
    )
    .unwrap();
    let o = multifield(&args[..args.len() - 1]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("(0 run now, 8 skipped as finished)"), "{}", text(&o));
    for r in table(&out.join("results.csv")).iter().filter(|r| r["status"] == "completed") {
        let value = sa.iter().find(|(l, _)| *l == r["phi"]).unwrap().1;
        let want = ((num(r, METRIC) - value) / value).abs();
        assert!((num(r, "error") - want).abs() <= 1e-12 * want, "{r:?}: error against {want}");
    }
}

/// Writes `study` next to a one-axis box case and runs it; it must be refused (exit code 2)
/// before anything runs. Returns standard error.
fn refused(name: &str, reference: &str) -> String {
    let dir = scratch(name);
    std::fs::write(
        dir.join("box.ron"),
        r#"(name: "box", domain: (size: (1.0, 1.0), cells: (4, 4)),
            boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
            time: (end: 1.0, max_dt: 1.0, fixed_dt: Some(0.5)),
            fields: [(name: "a", density: 1.0, frame: (model: "eulerian"), region: All)],
            output: (interval: 0.0, charts: false))"#,
    )
    .unwrap();
    let file = dir.join("s.ron");
    std::fs::write(
        &file,
        format!(
            r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.25, 0.5])),
                   (name: "end", values: List(path: "time.end", values: [1.0, 2.0]))],
            metrics: [Final("kinetic_energy")],
            reference: {reference})"#
        ),
    )
    .unwrap();
    let o = multifield(&["study", file.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
    assert!(!dir.join("out").join("runs").exists(), "{name}: nothing runs");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_reference_run_or_table_that_names_nothing_of_the_study_is_refused() {
    let e = refused("run_label", r#"Run(labels: {"dt": "0.3"}, compare: Metric("final_kinetic_energy"))"#);
    assert!(e.contains("reference.labels.dt") && e.contains("no value labelled `0.3`; labels: 0.25, 0.5"), "{e}");
    let e = refused("run_axis", r#"Run(labels: {"dtt": "0.5"}, compare: Metric("final_kinetic_energy"))"#);
    assert!(e.contains("reference.labels") && e.contains("axes: dt, end") && e.contains("did you mean `dt`?"), "{e}");
    let e = refused("run_empty", r#"Run(labels: {}, compare: Column("kinetic_energy"))"#);
    assert!(e.contains("reference.labels") && e.contains("axes: dt, end"), "{e}");
    let e = refused("run_metric", r#"Run(labels: {"dt": "0.25"}, compare: Metric("final_kinetic_enrgy"))"#);
    assert!(
        e.contains("reference.compare")
            && e.contains("its metric columns: final_kinetic_energy")
            && e.contains("did you mean `final_kinetic_energy`?"),
        "{e}"
    );
    let e = refused(
        "table_label",
        r#"Table(column: "final_kinetic_energy", axis: "dt", values: [("0.25", 1.0), ("1", 2.0)])"#,
    );
    assert!(e.contains("reference.values.1") && e.contains("no value labelled `1`; labels: 0.25, 0.5"), "{e}");
    let e = refused("table_missing", r#"Table(column: "final_kinetic_energy", axis: "end", values: [("1", 1.0)])"#);
    assert!(e.contains("reference.values") && e.contains("no value for the label 2 of axis `end`"), "{e}");
    let e = refused(
        "table_twice",
        r#"Table(column: "final_kinetic_energy", axis: "dt", values: [("0.25", 1.0), ("0.25", 2.0), ("0.5", 1.0)])"#,
    );
    assert!(e.contains("reference.values.1") && e.contains("`0.25` is given twice"), "{e}");
    let e = refused(
        "table_zero",
        r#"Table(column: "final_kinetic_energy", axis: "dt", values: [("0.25", 0.0), ("0.5", 1.0)])"#,
    );
    assert!(e.contains("reference.values.0") && e.contains("must be finite and not 0"), "{e}");
    let e = refused("table_axis", r#"Table(column: "final_kinetic_energy", axis: "phi", values: [])"#);
    assert!(e.contains("reference.axis") && e.contains("axes: dt, end"), "{e}");
}
