//! Issue 20: `check` on 10,000 bodies took 112 s: `region_fraction` tested 8 × 8
//! sub-samples of every cell against every body. The bodies are now rasterised one by one
//! over the cells their bounding box covers (the same sub-samples, so the same fractions),
//! and the other per-body setup is linear too. Also: more bodies than the cap are refused
//! with the entry named.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// A 100 × 100 lattice of `n` disks (radius 0.3, one per unit square) in water.
fn case(name: &str, side: usize) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("ten_thousand_bodies");
    std::fs::create_dir_all(&dir).unwrap();
    let mut bodies = String::new();
    for j in 0..side {
        for i in 0..side {
            bodies += &format!(
                "(name: \"b{i}_{j}\", shape: Disk(center: ({}, {}), radius: 0.3)),\n",
                i as f64 + 0.5,
                j as f64 + 0.5
            );
        }
    }
    let text = format!(
        r#"(
    name: "{name}",
    domain: (size: ({side}.0, {side}.0), cells: ({c}, {c})),
    gravity: (0.0, -981.0),
    time: (end: 0.1, max_dt: 1e-3),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian", params: (diffusion: "explicit")), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),
        (name: "disks", density: 1.5, frame: (model: "lagrangian", params: (points_per_cell: 2)),
         region: Bodies([{bodies}]), stress: [(model: "rigid")]),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip")],
    pressure: Some((model: "pcg")),
)"#,
        c = 4 * side
    );
    let file = dir.join(format!("{name}.ron"));
    std::fs::write(&file, text).unwrap();
    file
}

fn check(file: &Path) -> (Output, Duration) {
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).arg("check").arg(file).output().unwrap();
    (out, start.elapsed())
}

#[test]
fn check_on_ten_thousand_bodies_takes_under_a_second() {
    let file = case("bodies_10000", 100);
    let (out, took) = check(&file);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("10000 bodies"), "{text}");
    // the issue's one timing assertion (112 s before)
    assert!(took < Duration::from_secs(1), "check took {took:?}");
    // the mass of the disks: 10,000 × 16 points × 1.5 × (0.25/2)²
    assert!(text.contains("field    disks: density 1.5"), "{text}");
}

#[test]
fn more_bodies_than_the_cap_are_refused_with_the_entry() {
    let file = case("bodies_too_many", 142); // 20,164 > 20,000
    let (out, took) = check(&file);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("fields.disks.region") && err.contains("20164 bodies; at most 20000"), "{err}");
    assert!(took < Duration::from_secs(1), "{took:?}");
}
