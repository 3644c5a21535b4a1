//! Generated bodies (issue 15) downstream: a run of a generated case writes the same
//! `bodies.csv`, byte for byte, as a run of the same bodies written out by hand, on 1 and
//! 2 threads; its `case.ron` lists the bodies (the same bits); and a restart from its checkpoint, with the
//! generator file or with the run's `case.ron`, reproduces the uninterrupted run (and one
//! with a changed generator is refused).

use multifield::core::case::{BodyShape, Case, Region};
use multifield::run::{run, RunOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Five resolved disks in water on a 32 × 32 grid, 20 steps of 1 ms, a checkpoint every
/// 10; the field `disks` takes `region` and `generate` (`generate` may be empty).
fn text(bodies: &str, generate: &str) -> String {
    format!(
        r#"(
    name: "generated_run",
    domain: (size: (1.0, 1.0), cells: (32, 32)),
    gravity: (0.0, -981.0),
    time: (end: 0.02, max_dt: 1e-3, fixed_dt: Some(1e-3)),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),
        (name: "disks", density: 1.5, frame: (model: "lagrangian", params: (points_per_cell: 2)),
         region: Bodies([{bodies}]), {generate} stress: [(model: "rigid")]),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip")],
    contact: Some((model: "repulsion")),
    pressure: Some((model: "pcg", params: (tolerance: 1e-10))),
    output: (interval: 0.0, checkpoints: Some((interval: 0.01))),
)"#
    )
}

const GENERATE: &str = r#"generate: [(name: "p", region: (min: (0.2, 0.4), max: (0.8, 0.9)), count: Some(5),
    diameter: Uniform(min: 0.1, max: 0.14), min_gap: 0.05, seed: 21, velocity: (0.0, -1.0))],"#;

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("generated_bodies").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn run_case(case: &Case, out: &Path, threads: usize) -> String {
    let options = RunOptions { threads, ..RunOptions::quiet() };
    let outcome = run(case, out, &options).unwrap();
    assert_eq!(outcome.summary.steps, 20, "{}", outcome.summary.reason);
    read(&out.join("bodies.csv"))
}

#[test]
fn a_generated_case_runs_as_its_bodies_written_by_hand() {
    multifield::link_all();
    let root = dir("by_hand");
    let generated = root.join("generated.ron");
    std::fs::write(&generated, text("", GENERATE)).unwrap();
    let case = Case::load(&generated, &[]).unwrap();
    // the bodies written out by hand (`{:?}` prints the shortest text that reads back the same bits)
    let (expanded, _) = case.expand_generators().unwrap();
    let Region::Bodies(bodies) = &expanded.fields[1].region else { panic!() };
    assert_eq!(bodies.len(), 5);
    let listed: Vec<String> = bodies
        .iter()
        .map(|b| {
            let BodyShape::Disk { center, radius } = b.shape else { panic!() };
            format!(
                "(name: \"{}\", shape: Disk(center: ({:?}, {:?}), radius: {:?}), velocity: (0.0, -1.0)),",
                b.name, center[0], center[1], radius
            )
        })
        .collect();
    let by_hand_file = root.join("by_hand.ron");
    std::fs::write(&by_hand_file, text(&listed.join("\n"), "")).unwrap();
    let by_hand = Case::load(&by_hand_file, &[]).unwrap();
    assert_eq!(by_hand, expanded);

    let a = run_case(&case, &root.join("generated"), 2);
    let b = run_case(&by_hand, &root.join("by_hand_run"), 2);
    let c = run_case(&case, &root.join("one_thread"), 1);
    assert!(a.lines().count() > 5 * 20, "5 bodies, a row each at every step: {a}");
    assert!(a.lines().any(|l| l.contains("p4")), "{a}");
    assert_eq!(a, b, "generated and written by hand");
    assert_eq!(a, c, "2 threads and 1");
    // the run's case.ron lists the bodies (no generator), and reads back as the expanded case
    let written = read(&root.join("generated").join("case.ron"));
    assert!(!written.contains("generate:") && written.contains("\"p4\""), "{written}");
    // (with the plugins' parameters filled in)
    let read_back = Case::from_ron(&written, Path::new("case.ron")).unwrap();
    assert_eq!(read_back.fields[1].region, expanded.fields[1].region);
    assert!(read_back.fields[1].generate.is_empty());
}

fn cli(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args).output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn a_restart_of_a_generated_run_reproduces_it() {
    let root = dir("restart");
    let file = root.join("generated.ron");
    std::fs::write(&file, text("", GENERATE)).unwrap();
    let s = |p: &Path| p.display().to_string();
    let full = root.join("full");
    cli(&["run", &s(&file), "--out", &s(&full), "--quiet"]);
    let mut checkpoints: Vec<PathBuf> =
        std::fs::read_dir(full.join("checkpoints")).unwrap().map(|e| e.unwrap().path()).collect();
    checkpoints.sort();
    assert_eq!(checkpoints.len(), 2, "{checkpoints:?}");
    let mid = s(&checkpoints[0]);
    let whole = read(&full.join("bodies.csv"));
    // from the generator file, and from the run's own case.ron (the bodies listed)
    for (name, case) in [("from_generator", s(&file)), ("from_case_ron", s(&full.join("case.ron")))] {
        let out = root.join(name);
        cli(&["run", &case, "--out", &s(&out), "--restart", &mid, "--quiet"]);
        assert_eq!(read(&out.join("bodies.csv")), whole, "{name}");
        let last = |d: &Path| std::fs::read(d.join("checkpoints").join(checkpoints[1].file_name().unwrap())).unwrap();
        assert!(last(&out) == last(&full), "{name}: the final checkpoints differ");
    }
    // a changed generator makes other bodies: the restart is refused, the moved bodies named
    let out = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["run", &s(&file), "--set", "fields.disks.generate.0.min_gap=0.01", "--restart", &mid, "--quiet"])
        .args(["--out", &s(&root.join("changed"))])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("was written by a different case") && err.contains("fields.disks.region.Bodies.p0"), "{err}");
}
