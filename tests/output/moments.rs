//! Output at chosen moments (issue 22, item 3): snapshots and pictures at a list of exact
//! times, on which the step lands, and `at_end`.

use super::common::load;
use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::simulation::Status;
use multifield::core::table::Table;
use multifield::run::{run, Outcome, RunOptions};
use multifield::snapshot::Snapshot;
use std::path::{Path, PathBuf};

fn out_dir(name: &str) -> PathBuf {
    super::common::fresh_dir("moments", name)
}

fn run_into(case: &Case, dir: &Path) -> Outcome {
    let outcome = run(case, dir, &RunOptions::quiet()).unwrap();
    assert_eq!(outcome.status, Status::Completed, "{:?}", outcome.summary.reason);
    outcome
}

/// The snapshots in `dir/snapshots`, in order of their numbers.
fn snapshots(dir: &Path) -> Vec<Snapshot> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "h5"))
        .collect();
    files.sort();
    files.iter().map(|p| Snapshot::read(p).unwrap()).collect()
}

fn frames(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with("frame_"))
        .count()
}

fn table(path: &Path) -> Table {
    Table::read(path).unwrap().unwrap_or_else(|| panic!("{} is missing", path.display()))
}

/// Taylor–Green on 16 × 16 cells with an adaptive step, snapshots and pictures at exact
/// times that no step of the unshortened sequence meets: one snapshot per requested time,
/// with t equal to it to round-off (1e-12 t), the step before each shortened ("output
/// time" in `diagnostics.csv`) and the step after at the normal Δt again.
#[test]
fn snapshots_and_pictures_land_on_the_requested_times() {
    let times = [0.0137, 0.05, 0.1234];
    let case = load(
        "examples/taylor_green.ron",
        &[
            "domain.cells=(16, 16)",
            "time.end=0.2",
            "time.max_dt=0.01",
            "output.interval=0",
            "output.snapshots=Some((times: [0.0137, 0.05, 0.1234]))",
            "output.pictures=Some((times: [0.05], width: 64))",
            "output.charts=false",
        ],
    );
    let dir = out_dir("times");
    run_into(&case, &dir);
    let snaps = snapshots(&dir);
    let got: Vec<Real> = snaps.iter().map(|s| s.time).collect();
    assert_eq!(got.len(), times.len(), "one snapshot per requested time, none at 0 or the end: {got:?}");
    for (t, want) in got.iter().zip(times) {
        assert!((t - want).abs() <= 1e-12 * want, "snapshot at t = {t:e}, asked for {want}");
    }
    assert_eq!(frames(&dir), 1, "one picture, at t = 0.05");
    let d = table(&dir.join("diagnostics.csv"));
    let (step, dt, limit) = (d.numbers("step").unwrap(), d.numbers("dt").unwrap(), d.index("dt_limit").unwrap());
    for s in &snaps {
        let k = step.iter().position(|&x| x as u64 == s.step).unwrap();
        assert_eq!(&d.rows[k][limit], "output time", "step {}", s.step);
        // the step after goes on with the normal Δt (the max_dt of 0.01 here)
        assert_eq!(dt[k + 1], 0.01, "Δt after the landing at step {}: {}", s.step, dt[k + 1]);
        println!("landed on t = {:.6} with Δt = {:.3e} (normal {:.3e})", s.time, dt[k], dt[k + 1]);
    }
}

/// `at_end` writes exactly one snapshot and one picture, at the last step, whatever ends
/// the run: `time.end` or `time.max_steps`.
#[test]
fn at_end_writes_one_snapshot_at_the_last_step() {
    for (name, extra) in [("end", "time.end=0.05"), ("max_steps", "time.max_steps=Some(3)")] {
        let case = load(
            "examples/taylor_green.ron",
            &[
                "domain.cells=(16, 16)",
                "time.max_dt=0.01",
                "time.end=0.05",
                extra,
                "output.snapshots=Some((at_end: true))",
                "output.pictures=Some((at_end: true, width: 64))",
                "output.charts=false",
            ],
        );
        let dir = out_dir(&format!("at_end_{name}"));
        let outcome = run_into(&case, &dir);
        let snaps = snapshots(&dir);
        assert_eq!(snaps.len(), 1, "{name}: {:?}", snaps.iter().map(|s| s.step).collect::<Vec<_>>());
        assert_eq!(snaps[0].step, outcome.summary.steps, "{name}");
        assert_eq!(snaps[0].time.to_bits(), outcome.summary.simulated_time.to_bits(), "{name}");
        assert_eq!(frames(&dir), 1, "{name}");
    }
}

/// The fixed cylinder of the Schäfer–Turek channel (10 cells per diameter), its wake
/// established by t = 2: a step landed on t = 2.5013 (a fraction of the normal Δt) reports
/// a force in line with its neighbours. The deviation of the landed row from the mean of
/// the rows either side is below the change between consecutive rows around it.
#[test]
fn a_landed_step_reports_the_fixed_bodys_force_in_line_with_its_neighbours() {
    let landing = 2.5013;
    let case = load(
        "examples/cylinder_channel.ron",
        &["time.end=2.55", "output.interval=0", "output.snapshots=Some((times: [2.5013]))", "output.charts=false"],
    );
    let dir = out_dir("cylinder");
    run_into(&case, &dir);
    let b = table(&dir.join("bodies.csv"));
    let (t, fx, fy) = (b.numbers("time").unwrap(), b.numbers("fx").unwrap(), b.numbers("fy").unwrap());
    let k = t.iter().position(|&x| (x - landing).abs() <= 1e-12 * landing).expect("a row at the landed time");
    let (dt, normal) = (t[k] - t[k - 1], t[k + 1] - t[k]);
    println!("landed Δt = {dt:.4e}, normal Δt = {normal:.4e}");
    assert!(dt < 0.7 * normal, "the landing step is shortened: {dt:e} against {normal:e}");
    for (name, f) in [("fx", &fx), ("fy", &fy)] {
        let deviation = (f[k] - 0.5 * (f[k - 1] + f[k + 1])).abs();
        let spread = [k - 3, k - 2, k + 1, k + 2].iter().map(|&j| (f[j + 1] - f[j]).abs()).fold(0.0, Real::max);
        println!("{name}: landed {:.6e}, neighbours {:.6e} {:.6e}, deviation {deviation:.3e}, consecutive changes up to {spread:.3e}", f[k], f[k - 1], f[k + 1]);
        assert!(deviation <= spread, "{name} at the landed step deviates by {deviation:e}, rows differ by {spread:e}");
    }
}
