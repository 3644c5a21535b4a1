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

/// The FLIP Taylor–Green vortex (examples/taylor_green_flip.ron): its fluid's points open
/// holes as they move, and max |Σθ − 1| grows (0.06 at t = 1.1; 0.97 by t = 2).
fn flip_vortex(bound: Option<f64>) -> Case {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green_flip.ron");
    let mut sets = vec!["time.end=1.2".to_string(), "output.snapshots=None".into(), "output.charts=false".into()];
    sets.extend(bound.map(|b| format!("coupling.max_volume_fraction_error={b}")));
    Case::load(&file, &sets).unwrap()
}

#[test]
fn volume_fraction_drift_beyond_the_bound_stops_the_run() {
    multifield::link_all();
    // the drift stays below the default bound 1: the run completes
    let dir = scratch("within");
    let out = run(&flip_vortex(None), &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.status, Status::Completed, "{:?}", out.status);
    let drift = out.summary.max_volume_fraction_error;
    assert!(drift > 0.05 && drift < 0.2, "{drift}");

    // with the bound at 0.05 it stops at the first step beyond it and says why
    let dir = scratch("beyond");
    let out = run(&flip_vortex(Some(0.05)), &dir, &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("not unstable: {:?}", out.status) };
    assert!(reason.starts_with("max |Σθ − 1| = 6.0400e-2 at step 22,"), "{reason}");
    assert!(reason.contains("coupling.max_volume_fraction_error = 0.05"), "{reason}");
    assert_eq!(out.summary.steps, 22);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "unstable");
    assert_eq!(summary["reason"].as_str(), Some(reason.as_str()));

    // a bound that is not positive is bad input
    let e = flip_vortex(None).with_overrides(&["coupling.max_volume_fraction_error=0".into()]).unwrap();
    let e = e.validate().unwrap_err().to_string();
    assert!(e.contains("coupling.max_volume_fraction_error") && e.contains("must be positive"), "{e}");
}

/// Two rigid disks in vacuum, each in its own Lagrangian field (so their grids do not
/// touch), no contact model: moving toward each other at `u` each, they pass through each
/// other: inside the box at `u` = 1, across its periodic sides at `u` = −1 (as mass points:
/// a resolved body does not cross a periodic side).
fn crossing_disks(u: f64) -> Case {
    let representation = if u < 0.0 { "representation: MassPoint," } else { "" };
    let disk = |name: &str, x: f64, u: f64| {
        format!(
            r#"(name: "{name}", density: 1.0,
                frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "pic")), {representation}
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
        disk("left", 0.2, u),
        disk("right", 0.8, -u)
    );
    Case::from_ron(&text, Path::new("crossing.ron")).unwrap()
}

#[test]
fn bodies_passing_through_each_other_stop_the_run() {
    multifield::link_all();
    let dir = scratch("crossing");
    let out = run(&crossing_disks(1.0), &dir, &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("not unstable: {:?}", out.status) };
    assert!(reason.starts_with("bodies `left` and `right` overlap at step"), "{reason}");
    assert!(reason.contains("below 0.5 × the sum of the radii 2.0000e-1"), "{reason}");
    // centres 0.6 apart closing at 2: 0.1 apart (half the contact distance) at t = 0.25
    let t = out.summary.simulated_time;
    assert!((0.25..0.25 + 0.006).contains(&t), "stopped at t = {t}");

    // through the periodic sides (the minimum image): 0.4 apart closing at 2, 0.1 apart at
    // t = 0.15; a check on the plain distance would see them 0.6 → 1 apart and let them pass
    let out = run(&crossing_disks(-1.0), &scratch("through_the_sides"), &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("not unstable: {:?}", out.status) };
    assert!(reason.starts_with("bodies `left` and `right` overlap at step"), "{reason}");
    let t = out.summary.simulated_time;
    assert!((0.15..0.15 + 0.006).contains(&t), "stopped at t = {t}");
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
