//! Instability detection in every run (src/run.rs): Σθ drift beyond
//! `coupling.max_volume_fraction_error` and bodies passing through each other stop the run
//! as `"unstable"` with the reason in summary.json.

use multifield::core::case::Case;
use multifield::core::simulation::Status;
use multifield::run::{run, RunOptions};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("instability").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Two Eulerian fields that overfill a quarter of the box: Σθ = 1.6 there from the start.
fn overfilled(bound: Option<f64>) -> Case {
    let coupling = bound.map(|b| format!("coupling: (max_volume_fraction_error: {b}),")).unwrap_or_default();
    let text = format!(
        r#"(
        name: "overfilled", domain: (size: (1.0, 1.0), cells: (8, 8)),
        time: (end: 0.003, max_dt: 0.001, fixed_dt: Some(0.001)),
        fields: [
            (name: "a", density: 1.0, frame: (model: "eulerian"), region: All),
            (name: "b", density: 1.0, frame: (model: "eulerian"), volume_fraction: 0.6,
             region: Rectangle(min: (0.0, 0.0), max: (0.5, 0.5))),
        ],
        pressure: Some((model: "pcg")),
        {coupling}
        output: (charts: false),
    )"#
    );
    Case::from_ron(&text, Path::new("overfilled.ron")).unwrap()
}

#[test]
fn volume_fraction_drift_beyond_the_bound_stops_the_run() {
    multifield::link_all();
    // |Σθ − 1| = 0.6 stays below the default bound 1: the run completes
    let dir = scratch("within");
    let out = run(&overfilled(None), &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.status, Status::Completed, "{:?}", out.status);
    assert!((out.summary.max_volume_fraction_error - 0.6).abs() < 1e-12, "{}", out.summary.max_volume_fraction_error);
    assert_eq!(out.summary.steps, 3);

    // with the bound at 0.5 it stops after the first step and says why
    let dir = scratch("beyond");
    let out = run(&overfilled(Some(0.5)), &dir, &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("not unstable: {:?}", out.status) };
    assert!(reason.starts_with("max |Σθ − 1| = 6.0000e-1 at step 1,"), "{reason}");
    assert!(reason.contains("coupling.max_volume_fraction_error = 0.5"), "{reason}");
    assert_eq!(out.summary.steps, 1);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "unstable");
    assert_eq!(summary["reason"].as_str(), Some(reason.as_str()));

    // a bound that is not positive is bad input
    let e = overfilled(Some(0.0)).validate().unwrap_err().to_string();
    assert!(e.contains("coupling.max_volume_fraction_error") && e.contains("must be positive"), "{e}");
}

/// Two rigid disks in vacuum, each in its own Lagrangian field (so their grids do not
/// touch), no contact model: moving toward each other at 1 each, they pass through each other.
fn crossing_disks() -> Case {
    let disk = |name: &str, x: f64, u: f64| {
        format!(
            r#"(name: "{name}", density: 1.0,
                frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "pic")),
                region: Bodies([(name: "{name}", shape: Disk(center: ({x}, 0.5), radius: 0.1), velocity: ({u}, 0.0))]),
                stress: [(model: "rigid")])"#
        )
    };
    let text = format!(
        r#"(
        name: "crossing", domain: (size: (1.0, 1.0), cells: (20, 20)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 0.5, max_dt: 0.005),
        fields: [{}, {}],
        output: (charts: false),
    )"#,
        disk("left", 0.2, 1.0),
        disk("right", 0.8, -1.0)
    );
    Case::from_ron(&text, Path::new("crossing.ron")).unwrap()
}

#[test]
fn bodies_passing_through_each_other_stop_the_run() {
    multifield::link_all();
    let dir = scratch("crossing");
    let out = run(&crossing_disks(), &dir, &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("not unstable: {:?}", out.status) };
    assert!(reason.starts_with("bodies `left` and `right` overlap at step"), "{reason}");
    assert!(reason.contains("below 0.5 × the sum of the radii 2.0000e-1"), "{reason}");
    // centres 0.6 apart closing at 2: 0.1 apart (half the contact distance) at t = 0.25
    let t = out.summary.simulated_time;
    assert!((0.25..0.25 + 0.006).contains(&t), "stopped at t = {t}");
}

/// A rigid disk in vacuum thrown at the left wall (no contact model): the wall's grid nodes
/// stop it, softly at 2 (its centre stays 0.063 from the wall, above half its radius) and
/// not in time at 10 (its points pass the wall nodes).
fn thrown_at_the_wall(speed: f64) -> Case {
    let text = format!(
        r#"(
        name: "wall", domain: (size: (1.0, 1.0), cells: (20, 20)),
        time: (end: 0.2, max_dt: 0.005),
        fields: [
            (name: "disk", density: 1.0,
             frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "pic")),
             region: Bodies([(name: "disk", shape: Disk(center: (0.3, 0.5), radius: 0.1), velocity: (-{speed}, 0.0))]),
             stress: [(model: "rigid")]),
        ],
        output: (charts: false),
    )"#
    );
    Case::from_ron(&text, Path::new("wall.ron")).unwrap()
}

#[test]
fn a_body_through_a_wall_stops_the_run_and_one_stopped_by_it_does_not() {
    multifield::link_all();
    let out = run(&thrown_at_the_wall(2.0), &scratch("soft"), &RunOptions::quiet()).unwrap();
    assert_eq!(out.status, Status::Completed, "{:?}", out.status);
    let out = run(&thrown_at_the_wall(10.0), &scratch("hard"), &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("not unstable: {:?}", out.status) };
    assert!(reason.starts_with("body `disk` crosses the Left wall at step"), "{reason}");
    assert!(reason.contains("below 0.5 × its radius 1.0000e-1"), "{reason}");
}
