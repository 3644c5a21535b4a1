//! `check`'s estimate of the time of a run: the planned steps against the run's own count
//! (exactly, when a constant limit fixes Δt), the calibration grid and the scaling of a
//! step's time by the cells and the pressure iterations (its arithmetic exactly), the
//! estimate against a measured run on the case's own grid (within a factor of 3, in 3D and
//! in 2D), and `check` writing nothing.

use multifield3d::core::case::Case;
use multifield3d::core::limits::{
    self, calibrate, calibration_cells, coarsened, iteration_growth, per_step, Calibration,
};
use multifield3d::core::simulation::Simulation;
use multifield3d::run::{run, RunOptions};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dim3-check").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The low-Re Taylor–Green vortex on an n³ periodic cube (A = 10⁻³: the CFL limit is far
/// above `max_dt`, which fixes Δt), with `time` and `output`.
fn tgv_text(n: usize, time: &str, output: &str) -> String {
    let l = 2.0 * std::f64::consts::PI;
    format!(
        r#"(
    name: "tgv3",
    domain: (size: ({l}, {l}, {l}), cells: ({n}, {n}, {n})),
    boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic, back: Periodic, front: Periodic),
    time: ({time}),
    fields: [(name: "water", frame: (model: "eulerian"), density: 1.0, region: All,
              velocity: TaylorGreen(amplitude: 0.001), stress: [(model: "newtonian", params: {{"viscosity": 0.1}})])],
    pressure: Some((model: "multigrid")),
    output: ({output}),
)"#
    )
}

fn case3(text: &str) -> Case {
    multifield3d::link_all();
    let case = Case::from_ron(text, Path::new("check3.ron")).unwrap_or_else(|e| panic!("{e}"));
    case.validate().unwrap_or_else(|e| panic!("{e}"));
    case
}

/// The steps `check` plans are the run's: Δt = max_dt = 0.05 to t = 0.5 (10 steps); with
/// exact picture times 0.123 and 0.3 and an end of 0.52, steps land on each (0.05, 0.1,
/// 0.123, 0.173, 0.223, 0.273, 0.3, 0.35, … 0.5, 0.52: 12 steps); a fixed Δt of 0.03 to 0.5
/// (17 steps, the last 0.02); `time.max_steps = 7` (7).
#[test]
fn the_planned_steps_are_the_runs_steps() {
    let slice = "slice: (axis: z, at: 1.0), width: 32";
    for (time, output, expected) in [
        ("end: 0.5, max_dt: 0.05", "charts: false".to_string(), 10),
        ("end: 0.52, max_dt: 0.05", format!("charts: false, pictures: Some((times: [0.123, 0.3], {slice}))"), 12),
        ("end: 0.5, max_dt: 0.05, fixed_dt: Some(0.03)", "charts: false".to_string(), 17),
        ("end: 0.5, max_dt: 0.05, max_steps: Some(7)", "charts: false".to_string(), 7),
    ] {
        let case = case3(&tgv_text(8, time, &output));
        let sim = Simulation::new(&case).unwrap();
        let (planned, dt, limit) = sim.planned_steps(limits::WALKED_STEPS);
        let out = run(&case, &dir("steps"), &RunOptions::quiet()).unwrap();
        assert_eq!(out.summary.status, "completed", "{time}: {}", out.summary.reason);
        assert_eq!((planned, out.summary.steps), (expected, expected), "{time} {output}");
        let fixed = time.contains("fixed");
        assert_eq!((dt, limit.as_str()), if fixed { (0.03, "fixed") } else { (0.05, "max_dt") }, "{time}");
    }
    // beyond the steps walked, whole steps of the stable Δt: 0.5 / 0.05 after 3 walked
    let sim = Simulation::new(&case3(&tgv_text(8, "end: 0.5, max_dt: 0.05", "charts: false"))).unwrap();
    assert_eq!(sim.planned_steps(3).0, 10);
}

/// The calibration grid: the cells divided by the smallest whole k that brings them to at
/// most 16³ (rounded up, each at least 2); the coarsened case keeps the domain when the
/// cells keep their proportions, else grows it along the axes k does not divide, and
/// validates (cubic cells).
#[test]
fn the_calibration_grid_divides_the_cells() {
    assert_eq!(limits::CALIBRATION_CELLS, 4096);
    assert_eq!(calibration_cells([16, 16, 16]), ([16, 16, 16], 1));
    assert_eq!(calibration_cells([32, 32, 32]), ([16, 16, 16], 2));
    assert_eq!(calibration_cells([48, 48, 48]), ([16, 16, 16], 3));
    assert_eq!(calibration_cells([8, 64, 64]), ([4, 32, 32], 2));
    assert_eq!(calibration_cells([50, 30, 30]), ([17, 10, 10], 3));
    assert_eq!(calibration_cells([400, 40, 40]), ([67, 7, 7], 6));
    assert_eq!(calibration_cells([100, 100, 100]), ([15, 15, 15], 7));
    assert_eq!(calibration_cells([1024, 4, 4]), ([512, 2, 2], 2));
    // proportional cells keep the domain
    let cube = case3(&tgv_text(100, "end: 0.5, max_dt: 0.05", "charts: false"));
    let c = coarsened(&cube, [15, 15, 15], 7);
    assert_eq!((c.domain.cells, c.domain.size), ([15; 3], cube.domain.size));
    let text = tgv_text(8, "end: 0.5, max_dt: 0.05", "charts: false")
        .replace(
            "size: (6.283185307179586, 6.283185307179586, 6.283185307179586), cells: (8, 8, 8)",
            "size: (5.0, 3.0, 3.0), cells: (50, 30, 30)",
        )
        .replace("Periodic", "NoSlip");
    let case = case3(&text);
    let c = coarsened(&case, [17, 10, 10], 3);
    assert_eq!((c.domain.cells, c.domain.size), ([17, 10, 10], [17.0 * 0.30000000000000004, 3.0, 3.0]));
    c.validate().unwrap();
    assert!(c.output.pictures.is_none() && c.output.snapshots.is_none() && !c.output.charts);
    // it steps: the first step untimed, then the two asked for (a budget of 10 s)
    let timed = calibrate(&c, 2, 10.0).unwrap();
    assert_eq!((timed.cells, timed.steps), ([17, 10, 10], 2));
    assert!(timed.seconds_per_step > 0.0 && timed.iterations >= 1.0, "{timed:?}");
    assert!(timed.pressure_share > 0.0 && timed.pressure_share < 1.0, "{timed:?}");
}

/// The time of a step on the case's grid: the calibration's × r (the cells' ratio), its
/// pressure share f also × r^{p/3} (p the iterations' growth with n along an axis):
/// 0.01 s on 16³ with f = 0.4, iterations 8 on 8³ and 10 on 16³ (p = log₂ 1.25), on 32³
/// r = 8: 0.01 × 8 × (0.6 + 0.4 × 1.25) = 0.088 s.
#[test]
fn a_step_scales_with_the_cells_and_the_pressure_iterations() {
    let cal = |n: usize, iterations: f64| Calibration {
        cells: [n; 3],
        steps: 4,
        seconds_per_step: 0.01,
        pressure_share: 0.4,
        iterations,
    };
    let p = iteration_growth(&cal(8, 8.0), &cal(16, 10.0));
    assert!((p - 1.25f64.log2()).abs() < 1e-15, "{p}");
    let t = per_step(&cal(16, 10.0), p, 32 * 32 * 32);
    assert!((t - 0.088).abs() < 1e-15, "{t}");
    // no growth: the cells' ratio alone; falling iterations give no growth
    assert!((per_step(&cal(16, 10.0), 0.0, 32 * 32 * 32) - 0.08).abs() < 1e-15);
    assert_eq!(iteration_growth(&cal(8, 10.0), &cal(16, 8.0)), 0.0);
}

/// The estimate of a case, 3D (the Taylor–Green vortex on 32³, calibrated on 16³ and 8³)
/// and 2D (the lid-driven cavity on 128², on 64²), is the calibration scaled by the model
/// (`per_step`) and the planned steps. How close it comes to a run's time is a matter of
/// the machine's load, so it is measured in the docs (docs/limits.md, `check` against
/// `run`: 0.68–1.0), not asserted here: a timed test on a shared machine would fail on
/// its noise.
#[test]
fn the_estimate_is_the_calibration_scaled_by_the_model() {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    // 3D
    let case = case3(&tgv_text(32, "end: 10.0, max_dt: 0.05", "charts: false"));
    let sim = Simulation::new(&case).unwrap();
    let e = pool.install(|| limits::time_estimate(&sim, 0.5)).unwrap();
    assert_eq!((e.calibration.cells, e.half.as_ref().map(|h| h.cells)), ([16; 3], Some([8; 3])));
    assert_eq!((e.steps, e.cells), (200, 32 * 32 * 32));
    assert_eq!(e.seconds_per_step, per_step(&e.calibration, e.growth, e.cells));
    // 2D, the same code
    multifield::link_all();
    let file = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/lid_driven_cavity.ron"));
    let case = multifield::core::case::Case::load(file, &["domain.cells=(128, 128)".into()]).unwrap();
    let sim = multifield::core::simulation::Simulation::new(&case).unwrap();
    let e = pool.install(|| multifield::core::limits::time_estimate(&sim, 0.5)).unwrap();
    assert_eq!(e.calibration.cells, [64, 64]);
    assert_eq!(e.seconds_per_step, multifield::core::limits::per_step(&e.calibration, e.growth, e.cells));
}

/// `check` prints the estimate (the planned steps, the calibration grid) and writes no
/// file: the directory it runs in stays empty. A calibration that cannot run is reported,
/// not fatal.
#[test]
fn check_prints_the_time_and_writes_nothing() {
    let d = dir("cli");
    let file = d.join("case.ron");
    let output = "charts: true, snapshots: Some((interval: 0.1)), pictures: Some((interval: 0.1, slice: (axis: x, at: 1.0))), checkpoints: Some((interval: 0.1))";
    std::fs::write(&file, tgv_text(24, "end: 0.5, max_dt: 0.05", output)).unwrap();
    let cwd = dir("cli_cwd");
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .current_dir(&cwd)
        .args(["check", file.to_str().unwrap(), "--threads", "2"])
        .output()
        .unwrap();
    let wall = start.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    let time = stdout.lines().find(|l| l.starts_with("time     about")).unwrap_or_else(|| panic!("{stdout}"));
    eprintln!("check in {wall:.2} s: {time}");
    assert!(time.starts_with("time     about 10 steps × "), "{time}");
    assert!(time.contains("on 2 threads") && time.contains("a step timed on 12 × 12 × 12 cells"), "{time}");
    assert!(time.contains("on 6 × 6 × 6 cells") && time.contains("the flow may change it"), "{time}");
    assert!(stdout.contains("about 10 steps to t = 0.5"), "{stdout}");
    let left: Vec<_> = std::fs::read_dir(&cwd).unwrap().collect();
    assert!(left.is_empty(), "check wrote {left:?}");
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1, "only the case file");
}
