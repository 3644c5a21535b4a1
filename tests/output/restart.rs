//! Checkpoint and restart (`output.checkpoints`, `multifield run --restart`):
//!
//! - a run continued from a checkpoint reproduces the uninterrupted run bit for bit (body
//!   states, pressure, every field's velocities and points, the APIC matrices, the whole
//!   final checkpoint) and its `diagnostics.csv`/`bodies.csv` continue byte for byte: on a
//!   coupled DKT scene (Eulerian water, rigid Lagrangian disks, contact, MG-PCG), on a
//!   Lagrangian APIC fluid with each pressure solver, on a lone Lagrangian fluid on the
//!   collocated grid, and for a finished run extended to a later `time.end`;
//! - a run killed mid-write (a leftover temporary checkpoint, a half-written row, rows past
//!   the last checkpoint) continues from its last complete checkpoint, and a truncated
//!   checkpoint is refused with the reason and the complete one to use (exit code 2);
//! - a file that is not a checkpoint, a corrupt one (CRC-32), one with extra bytes and one of
//!   an older format version are refused, each saying what is wrong and what to do;
//! - a checkpoint of a case with another grid is refused with the entry that differs.

use super::common::load;
use multifield::checkpoint::{self, Checkpoint};
use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::simulation::{Simulation, Status};
use multifield::frames::eulerian::Eulerian;
use multifield::frames::lagrangian::Lagrangian;
use multifield::run::{run, Outcome, RunOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn out_dir(name: &str) -> PathBuf {
    super::common::fresh_dir("restart", name)
}

fn run_into(case: &Case, dir: &Path, restart: Option<&Path>) -> Outcome {
    let options = RunOptions { restart: restart.map(Path::to_path_buf), ..RunOptions::quiet() };
    let outcome = run(case, dir, &options).unwrap();
    assert_eq!(outcome.status, Status::Completed, "{:?}", outcome.summary.reason);
    outcome
}

fn bits(x: &[Real]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

fn vector_bits(x: &[multifield::core::math::Vector]) -> Vec<[u64; 2]> {
    x.iter().map(|v| [v.x.to_bits(), v.y.to_bits()]).collect()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Asserts that two simulations hold the same state, bit for bit, part by part.
fn assert_same_state(a: &Simulation, b: &Simulation) {
    assert_eq!((a.steps, a.time.to_bits()), (b.steps, b.time.to_bits()), "step and time");
    assert_eq!(bits(&a.pressure), bits(&b.pressure), "pressure");
    let body = |s: &multifield::core::plugin::BodyState| {
        [s.position.x, s.position.y, s.velocity.x, s.velocity.y, s.angular_velocity, s.force.x, s.force.y, s.torque]
            .map(Real::to_bits)
    };
    let (ba, bb) = (a.bodies(), b.bodies());
    assert_eq!(ba.len(), bb.len());
    for ((_, x), (_, y)) in ba.iter().zip(&bb) {
        assert_eq!(x.name, y.name);
        assert_eq!(body(x), body(y), "body {}", x.name);
    }
    for (fa, fb) in a.fields.iter().zip(&b.fields) {
        let name = &fa.name;
        assert_eq!(bits(&fa.state.velocity.u), bits(&fb.state.velocity.u), "grid u of {name}");
        assert_eq!(bits(&fa.state.velocity.v), bits(&fb.state.velocity.v), "grid v of {name}");
        assert_eq!(bits(&fa.state.theta), bits(&fb.state.theta), "θ of {name}");
        if let Some(ea) = fa.frame.as_any().downcast_ref::<Eulerian>() {
            let eb = fb.frame.as_any().downcast_ref::<Eulerian>().unwrap();
            assert_eq!(bits(&ea.velocity().u), bits(&eb.velocity().u), "u of {name}");
            assert_eq!(bits(&ea.velocity().v), bits(&eb.velocity().v), "v of {name}");
            assert_eq!(bits(ea.theta()), bits(eb.theta()), "frame θ of {name}");
        }
        if let Some(la) = fa.frame.as_any().downcast_ref::<Lagrangian>() {
            let (pa, pb) = (&la.points, &fb.frame.as_any().downcast_ref::<Lagrangian>().unwrap().points);
            assert_eq!(vector_bits(&pa.x), vector_bits(&pb.x), "point positions of {name}");
            assert_eq!(vector_bits(&pa.v), vector_bits(&pb.v), "point velocities of {name}");
            assert_eq!(vector_bits(&pa.c_u), vector_bits(&pb.c_u), "APIC C (u) of {name}");
            assert_eq!(vector_bits(&pa.c_v), vector_bits(&pb.c_v), "APIC C (v) of {name}");
        }
    }
}

/// The checkpoints of a run directory.
fn checkpoints(dir: &Path) -> Vec<(u64, PathBuf)> {
    checkpoint::list(dir)
}

/// Runs `case` uninterrupted into `name/full`, then from its first checkpoint into
/// `name/restarted`; checks both end in the same state and write the same rows.
fn restart_reproduces_the_run(name: &str, case: &Case) -> (Checkpoint, Checkpoint) {
    let full = out_dir(&format!("{name}/full"));
    let t = Instant::now();
    let a = run_into(case, &full, None);
    let list = checkpoints(&full);
    assert_eq!(list.len(), 2, "the last two checkpoints are kept: {list:?}");
    let (mid_step, mid) = list[0].clone();
    let (end_step, end) = list[1].clone();
    assert_eq!(end_step, a.summary.steps, "a completed run ends with a checkpoint");
    assert!(0 < mid_step && mid_step < end_step, "{list:?}");
    let restarted = out_dir(&format!("{name}/restarted"));
    let b = run_into(case, &restarted, Some(&mid));
    eprintln!("{name}: {} steps, restarted at step {mid_step}, {:.2} s", a.summary.steps, t.elapsed().as_secs_f64());
    assert_eq!(b.summary.restarted_from.as_deref(), Some(mid.display().to_string().as_str()));

    // the final states, part by part, then the whole final checkpoints byte for byte
    let (sa, ca) = checkpoint::restore(case, &end).unwrap();
    let end_b = restarted.join("checkpoints").join(checkpoint::file_name(end_step));
    let (sb, cb) = checkpoint::restore(case, &end_b).unwrap();
    assert_same_state(&sa, &sb);
    assert!(std::fs::read(&end).unwrap() == std::fs::read(&end_b).unwrap(), "final checkpoints differ");

    // the rows after the checkpoint, then the whole files (the earlier rows are carried over)
    for file in ["diagnostics.csv", "bodies.csv"] {
        if !full.join(file).exists() {
            continue;
        }
        let (ta, tb) = (read(&full.join(file)), read(&restarted.join(file)));
        let after = |t: &str| -> Vec<String> {
            t.lines()
                .skip(1)
                .filter(|l| l.split(',').next().unwrap().parse::<u64>().unwrap() > mid_step)
                .map(String::from)
                .collect()
        };
        assert!(!after(&ta).is_empty(), "{file} has rows after step {mid_step}");
        assert_eq!(after(&ta), after(&tb), "{file} after step {mid_step}");
        assert_eq!(ta, tb, "{file}");
    }
    // the monitors' files, whole
    if let Ok(list) = std::fs::read_dir(full.join("monitors")) {
        for entry in list {
            let name = entry.unwrap().file_name();
            let (ta, tb) = (read(&full.join("monitors").join(&name)), read(&restarted.join("monitors").join(&name)));
            assert!(ta.lines().count() > 2, "{name:?}: {ta}");
            assert_eq!(ta, tb, "monitors/{name:?}");
        }
    }
    let (x, y) = (&a.summary, &b.summary);
    assert_eq!(
        (x.steps, x.diagnostics_rows, x.pressure_iterations_total),
        (y.steps, y.diagnostics_rows, y.pressure_iterations_total)
    );
    assert_eq!(
        [x.max_divergence, x.max_volume_fraction_error, x.min_dt, x.final_kinetic_energy].map(Real::to_bits),
        [y.max_divergence, y.max_volume_fraction_error, y.min_dt, y.final_kinetic_energy].map(Real::to_bits)
    );
    (ca, cb)
}

/// Uhlmann's two settling disks with contact on a small grid, checkpointed at t = 0.01,
/// with `extra` overrides: a restart reproduces the run, and the disks settle.
fn dkt_restarts(name: &str, extra: &[&str]) {
    let mut overrides = vec![
        "domain.cells=(16, 48)",
        "time.end=0.02",
        "output.interval=0.002",
        "output.checkpoints=Some((interval: 0.01))",
        "output.charts=false",
    ];
    overrides.extend_from_slice(extra);
    let case = load("examples/dkt_uhlmann2005.ron", &overrides);
    let (end, _) = restart_reproduces_the_run(name, &case);
    assert!(end.step >= 20, "{} steps", end.step);
    let sim = checkpoint::restore(&case, &end.path).unwrap().0;
    assert!(sim.bodies().iter().all(|(_, b)| b.velocity.y < 0.0), "the disks settle");
}

/// Coupled scene: Eulerian water, two rigid Lagrangian disks with contact resolved by
/// direct forcing (the free disks' lagged marker forces carry over), MG-preconditioned CG
/// (warm-started from the checkpointed pressure).
#[test]
fn a_restarted_dkt_run_is_bit_identical_to_the_uninterrupted_one() {
    dkt_restarts("dkt", &[]);
}

/// The same scene with the seed's `no_slip` exchange.
#[test]
fn a_restarted_no_slip_run_is_bit_identical_to_the_uninterrupted_one() {
    dkt_restarts("dkt_no_slip", &["exchange.0.model=\"no_slip\"", "contact.params.range_cells=2.0"]);
}

/// Mass-point disks (drag law with added mass and rotation, contact): the points' state
/// and their largest Reynolds numbers carry over.
#[test]
fn a_restarted_point_particle_run_is_bit_identical_to_the_uninterrupted_one() {
    let case = load(
        "examples/dkt_uhlmann2005.ron",
        &[
            "fields.disks.representation=MassPoint",
            "domain.cells=(16, 48)",
            "time.end=0.04",
            "output.interval=0.002",
            "output.checkpoints=Some((interval: 0.02))",
            "output.charts=false",
        ],
    );
    let (end, _) = restart_reproduces_the_run("points", &case);
    let sim = checkpoint::restore(&case, &end.path).unwrap().0;
    assert!(sim.bodies().iter().all(|(_, b)| b.velocity.y < -1.0), "the points settle");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("restart").join("points");
    let full = std::fs::read_to_string(dir.join("full").join("summary.json")).unwrap();
    let restarted = std::fs::read_to_string(dir.join("restarted").join("summary.json")).unwrap();
    let warnings = |t: &str| serde_json::from_str::<serde_json::Value>(t).unwrap()["warnings"].clone();
    assert_eq!(warnings(&full), warnings(&restarted));
}

/// Two mass-point disks with no fluid colliding off-centre under the `dem` contact with
/// friction, checkpointed mid-collision (the tangential spring's history ξ non-zero): the
/// restart reproduces the run bit for bit, as does a run on one thread.
#[test]
fn a_restart_mid_collision_carries_the_dem_history_bit_for_bit() {
    multifield::link_all();
    let text = r#"(
        name: "dem_restart",
        domain: (size: (1.0, 1.0), cells: (10, 10)),
        boundaries: (left: Periodic, right: Periodic, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, 0.0),
        time: (end: 0.05, cfl: 0.4, max_dt: 1.0),
        fields: [(
            name: "disks",
            density: 2.0,
            representation: MassPoint,
            frame: (model: "lagrangian"),
            region: Bodies([
                (name: "a", shape: Disk(center: (0.37, 0.45), radius: 0.1), velocity: (1.0, 0.0)),
                (name: "b", shape: Disk(center: (0.63, 0.55), radius: 0.1), velocity: (-1.0, 0.0)),
            ]),
        )],
        contact: Some((model: "dem", params: (restitution: 0.5, collision_time: 0.01, friction: 0.3))),
        output: (interval: 0.0, charts: false, checkpoints: Some((interval: 0.048))),
    )"#;
    let case = Case::from_ron(text, Path::new("dem_restart.ron")).unwrap();
    let (_, _) = restart_reproduces_the_run("dem", &case);
    // the first checkpoint (t = 0.048) is mid-collision, with the spring loaded
    let full = Path::new(env!("CARGO_TARGET_TMPDIR")).join("restart").join("dem").join("full");
    let (_, mid) = checkpoints(&full)[0].clone();
    let sim = checkpoint::restore(&case, &mid).unwrap().0;
    let history = sim.contact.as_ref().unwrap().history();
    assert_eq!(history.len(), 8 + 24, "one touching pair in the history");
    let xi = Real::from_bits(u64::from_le_bytes(history[24..32].try_into().unwrap()));
    assert!(xi.abs() > 1e-4, "ξ = {xi}");
    // one thread: the same rows
    let one = out_dir("dem/one_thread");
    let options = RunOptions { threads: 1, ..RunOptions::quiet() };
    run(&case, &one, &options).unwrap();
    assert_eq!(read(&one.join("bodies.csv")), read(&full.join("bodies.csv")));
}

/// A resolved disk (direct forcing) launched obliquely at a wall through a viscous fluid
/// under the `dem` contact with the Hertzian law, friction and lubrication, sub-stepped,
/// checkpointed while it touches the wall (the tangential spring loaded; the lubrication acts
/// before and after the touch, and the forcing is held at ε_act from the wall throughout):
/// the restart reproduces the run bit for bit, as does a run on one thread.
#[test]
fn a_restart_mid_wet_collision_with_hertz_and_lubrication_is_bit_identical() {
    multifield::link_all();
    let text = r#"(
        name: "wet_restart",
        domain: (size: (1.5, 1.0), cells: (48, 32)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, 0.0),
        time: (end: 0.2, cfl: 0.4, max_dt: 2e-3, contact_substeps: true),
        fields: [
            (name: "fluid", density: 1.0, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 1e-4))]),
            (name: "disk", density: 8.0, frame: (model: "lagrangian"),
             region: Bodies([(name: "disk", shape: Disk(center: (0.75, 0.225), radius: 0.125),
                              velocity: (0.5, -1.0))]),
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("fluid", "disk"), model: "direct_forcing")],
        contact: Some((model: "dem", params: (restitution: 0.8, collision_time: 0.01, friction: 0.3,
                       normal: "hertz", reference_speed: 1.0, lubrication: true, lubrication_range: 2.0))),
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-10))),
        output: (interval: 0.0, charts: false, checkpoints: Some((interval: CHECKPOINT))),
    )"#
    .replace("CHECKPOINT", "0.132");
    let case = Case::from_ron(&text, Path::new("wet_restart.ron")).unwrap();
    let (_, _) = restart_reproduces_the_run("wet", &case);
    // the first checkpoint is mid-contact, with the spring loaded
    let full = Path::new(env!("CARGO_TARGET_TMPDIR")).join("restart").join("wet").join("full");
    let (_, mid) = checkpoints(&full)[0].clone();
    let sim = checkpoint::restore(&case, &mid).unwrap().0;
    let history = sim.contact.as_ref().unwrap().history();
    assert_eq!(history.len(), 8 + 24, "one touching pair in the history");
    let xi = Real::from_bits(u64::from_le_bytes(history[24..32].try_into().unwrap()));
    assert!(xi.abs() > 1e-6, "ξ = {xi}");
    let one = out_dir("wet/one_thread");
    let options = RunOptions { threads: 1, ..RunOptions::quiet() };
    run(&case, &one, &options).unwrap();
    assert_eq!(read(&one.join("bodies.csv")), read(&full.join("bodies.csv")));
}

/// A Lagrangian fluid (APIC, quadratic B-splines: the C matrices carry over), with each
/// pressure solver (none keeps a state that changes its result but the initial guess).
#[test]
fn a_restarted_apic_run_is_bit_identical_with_every_pressure_solver() {
    for (k, solver) in [
        "Some((model: \"pcg\"))",
        "Some((model: \"pcg\", params: (preconditioner: \"multigrid\")))",
        "Some((model: \"multigrid\"))",
        "Some((model: \"cholesky\"))",
    ]
    .iter()
    .enumerate()
    {
        let case = load(
            "examples/taylor_green_flip.ron",
            &[
                "domain.cells=(16, 16)",
                "time.end=1.0",
                "output.checkpoints=Some((interval: 0.5))",
                "output.charts=false",
                &format!("pressure={solver}"),
            ],
        );
        restart_reproduces_the_run(&format!("apic_{k}"), &case);
    }
}

/// A field alone on the collocated grid (mpm88: no pressure solve, the core's phases
/// skipped): the points carry over, and the grid state the checkpoints hold is refreshed
/// before each one, so the final checkpoints are the same bytes.
#[test]
fn a_restarted_collocated_run_is_bit_identical_to_the_uninterrupted_one() {
    let case = load(
        "examples/mpm88.ron",
        &["time.end=0.16", "output.interval=0.004", "output.checkpoints=Some((interval: 0.08))", "output.charts=false"],
    );
    let (end, _) = restart_reproduces_the_run("collocated", &case);
    assert_eq!(end.step, 800);
    // an adaptive Δt: the restarted run's first step takes its limit from the checkpointed
    // step's largest speed, as the uninterrupted run does
    let adaptive = load(
        "examples/mpm88.ron",
        &[
            "time.end=0.16",
            "time.fixed_dt=None",
            "output.interval=0.004",
            "output.checkpoints=Some((interval: 0.08))",
            "output.charts=false",
        ],
    );
    let (end, _) = restart_reproduces_the_run("collocated_adaptive", &adaptive);
    assert!(end.step > 800, "{} steps: Δt below the fixed 2e-4", end.step);
}

/// Eulerian Taylor–Green, fixed Δt = 0.01, rows every 0.02, checkpoints every 0.05.
fn taylor_green(overrides: &[&str]) -> Case {
    let mut all = vec![
        "domain.cells=(16, 16)",
        "time.fixed_dt=Some(0.01)",
        "output.interval=0.02",
        "output.checkpoints=Some((interval: 0.05))",
        "output.charts=false",
    ];
    all.extend_from_slice(overrides);
    load("examples/taylor_green.ron", &all)
}

/// Taylor–Green with monitors of every kind but forces (velocity probes every step, a line
/// of vorticity, the difference of the pressure, the mean speed, the running time average
/// of the velocity) and a `Steady` stop
/// that fires after the restart: the restarted run writes the same monitor files, byte
/// for byte, and stops at the same step (the stop's history is read back from them).
#[test]
fn a_restarted_run_with_monitors_writes_the_same_monitor_files() {
    multifield::link_all();
    let text = std::fs::read_to_string("examples/taylor_green.ron").unwrap();
    let monitors = r#"
    monitors: [
        (name: "probes", of: Probes(quantity: "velocity", points: [(1.0, 2.0), (3.3, 0.1), (6.0, 6.2)])),
        (name: "line", every: Time(0.03), of: Line(quantity: "vorticity", from: (0.0, 1.0), to: (6.2, 5.0), points: 25)),
        (name: "dp", every: Time(0.02), of: Difference(quantity: "pressure", from: (1.0, 1.0), to: (2.0, 3.0))),
        (name: "mean", of: Average(quantity: "speed", min: (1.0, 1.0), max: (3.0, 2.5))),
        (name: "u_mean", every: Time(0.02), of: TimeAverage(quantity: "velocity", start: 0.03)),
    ],
    stop: [Steady(monitor: "mean", column: "mean", tolerance: 0.01, window: 0.15)],
)
"#;
    let text = text.trim_end().strip_suffix(')').unwrap().to_string() + monitors;
    let dir = out_dir("monitors_case");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("taylor_green_monitors.ron");
    std::fs::write(&file, text).unwrap();
    let case = load(
        file.to_str().unwrap(),
        &[
            "domain.cells=(16, 16)",
            "time.fixed_dt=Some(0.01)",
            "time.end=0.3",
            "output.interval=0.02",
            "output.checkpoints=Some((interval: 0.05))",
            "output.charts=false",
        ],
    );
    let (end, _) = restart_reproduces_the_run("monitors", &case);
    // the time average went through the checkpoint of step 10 (the final checkpoints are
    // byte-identical): samples at t = 0.04, 0.06, …, 0.14 and the last step's
    let sim = checkpoint::restore(&case, &end.path).unwrap().0;
    assert_eq!(sim.averages.len(), 1);
    assert_eq!((sim.averages[0].samples, sim.averages[0].first), (7, 0.04));
    // the mean speed decays by about 2ν = 2% per unit of time, 0.3% over the window: the
    // stop fires once the window is spanned (step 15), after the restart from step 10,
    // which read the window's first rows back from the files
    assert_eq!(end.step, 15, "stopped at step {}", end.step);
}

/// The settling cloud of 250 mass-point disks with a `Suspension` monitor (every step) and
/// one every 0.004: both files and the profiles are byte-identical through a checkpoint.
#[test]
fn a_restarted_run_with_a_suspension_monitor_writes_the_same_files() {
    multifield::link_all();
    let text = std::fs::read_to_string("examples/sedimentation_cloud.ron").unwrap();
    let monitors = r#"
    monitors: [
        (name: "cloud", of: Suspension(field: "disks", bins: 12)),
        (name: "cloud_x", every: Time(0.004), of: Suspension(field: "disks", axis: X, bins: 5, contact_gap: 0.05)),
    ],
)
"#;
    let text = text.trim_end().strip_suffix(')').unwrap().to_string() + monitors;
    let dir = out_dir("suspension_case");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("sedimentation_monitors.ron");
    std::fs::write(&file, text).unwrap();
    let case = load(
        file.to_str().unwrap(),
        &["time.end=0.02", "output.interval=0", "output.checkpoints=Some((interval: 0.01))", "output.charts=false"],
    );
    restart_reproduces_the_run("suspension", &case);
    let full = Path::new(env!("CARGO_TARGET_TMPDIR")).join("restart").join("suspension").join("full");
    let rows = read(&full.join("monitors").join("cloud_profiles.csv")).lines().count();
    let steps = read(&full.join("monitors").join("cloud.csv")).lines().count() - 1;
    assert_eq!(rows, 1 + 12 * steps, "12 slabs per row of the monitor");
    let x = multifield::core::table::Table::read(&full.join("monitors").join("cloud_x.csv")).unwrap().unwrap();
    let contacts = x.numbers("contacts").unwrap();
    assert!(contacts.iter().all(|&c| c > 0.0), "pairs within 0.05: {contacts:?}");
}

/// A finished run goes on to a later `time.end` from its final checkpoint, in its own
/// directory, as if it had been run to that time at once.
#[test]
fn a_finished_run_extends_to_a_later_end_time() {
    let long = taylor_green(&["time.end=0.2"]);
    let full = out_dir("extend/full");
    run_into(&long, &full, None);
    let dir = out_dir("extend/extended");
    let short = run_into(&taylor_green(&["time.end=0.1"]), &dir, None);
    assert_eq!(short.summary.steps, 10);
    let last = checkpoints(&dir).last().unwrap().clone();
    assert_eq!(last.0, 10);
    let extended = run_into(&long, &dir, Some(&last.1));
    assert_eq!(extended.summary.steps, 20);
    assert_eq!(read(&full.join("diagnostics.csv")), read(&dir.join("diagnostics.csv")));
    let end = checkpoint::file_name(20);
    assert!(
        std::fs::read(full.join("checkpoints").join(&end)).unwrap()
            == std::fs::read(dir.join("checkpoints").join(&end)).unwrap()
    );
}

/// A run killed after step 14 (rows written to step 14, the last one cut in half, a
/// checkpoint half-written under its temporary name) continues from its last complete
/// checkpoint (step 10) and ends with the files of the uninterrupted run; a truncated
/// checkpoint is refused, naming the complete one.
#[test]
fn a_run_killed_mid_write_continues_from_its_last_complete_checkpoint() {
    let case = taylor_green(&["time.end=0.2"]);
    let full = out_dir("killed/full");
    run_into(&case, &full, None);

    // the killed run: stopped after step 14, its clean final checkpoint removed (a killed
    // run writes none), a torn row and a temporary checkpoint left behind
    let dir = out_dir("killed/run");
    run_into(&taylor_green(&["time.end=0.2", "time.max_steps=Some(14)"]), &dir, None);
    let list = checkpoints(&dir);
    assert_eq!(list.iter().map(|c| c.0).collect::<Vec<_>>(), [10, 14], "{list:?}");
    let later = std::fs::read(&list[1].1).unwrap();
    std::fs::remove_file(&list[1].1).unwrap();
    let good = list[0].1.clone();
    let bytes = std::fs::read(&good).unwrap();
    let tmp = dir.join("checkpoints").join(".checkpoint_15.bin.tmp");
    std::fs::write(&tmp, &bytes[..bytes.len() / 2]).unwrap();
    let mut csv = read(&dir.join("diagnostics.csv"));
    assert!(csv.lines().last().unwrap().starts_with("14,"), "the killed run wrote rows past its checkpoint");
    csv.push_str("16,0.16,0.01,fi");
    std::fs::write(dir.join("diagnostics.csv"), &csv).unwrap();

    // what a killed run leaves: only complete checkpoints are listed, and they read
    assert_eq!(checkpoints(&dir), vec![(10, good.clone())]);
    let c = checkpoint::read(&good).unwrap();
    assert_eq!((c.step, c.case.name.as_str()), (10, "taylor_green"));

    // a truncated checkpoint (a copy cut short) is refused with the reason and the fix
    let truncated = dir.join("checkpoints").join(checkpoint::file_name(15));
    std::fs::write(&truncated, &bytes[..bytes.len() - 100]).unwrap();
    let before = read(&dir.join("summary.json"));
    let options = RunOptions { restart: Some(truncated.clone()), ..RunOptions::quiet() };
    let e = run(&case, &dir, &options).expect_err("a truncated checkpoint is refused").to_string();
    assert!(e.contains("truncated") && e.contains("a run killed while writing it"), "{e}");
    assert!(e.contains(&format!("restart from the complete checkpoint {}", good.display())), "{e}");
    assert_eq!(read(&dir.join("summary.json")), before, "a refused restart leaves the run's files alone");
    // the command line says it on stderr with exit code 2 (bad input)
    let case_file = dir.join("case.ron");
    let cli = std::process::Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["run", case_file.to_str().unwrap(), "--quiet", "--out"])
        .arg(&dir)
        .arg("--restart")
        .arg(&truncated)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&cli.stderr);
    assert_eq!(cli.status.code(), Some(2), "{stderr}");
    assert!(stderr.starts_with("error: checkpoint ") && stderr.contains("truncated"), "{stderr}");
    // a missing one too
    let e = run(&case, &dir, &RunOptions { restart: Some(dir.join("nothing.bin")), ..RunOptions::quiet() })
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("nothing.bin: cannot be read"), "{e}");
    std::fs::remove_file(&truncated).unwrap();

    // the restart from step 10 replaces the later rows and checkpoints (here one of a
    // step the new run does not reach) and ends with the uninterrupted run's files
    std::fs::write(dir.join("checkpoints").join(checkpoint::file_name(30)), &later).unwrap();
    run_into(&case, &dir, Some(&good));
    assert!(!tmp.exists(), "the temporary file of the killed write is cleaned up");
    assert_eq!(read(&full.join("diagnostics.csv")), read(&dir.join("diagnostics.csv")));
    let end = checkpoint::file_name(20);
    assert!(
        std::fs::read(full.join("checkpoints").join(&end)).unwrap()
            == std::fs::read(dir.join("checkpoints").join(&end)).unwrap()
    );
    assert_eq!(checkpoints(&dir).iter().map(|c| c.0).collect::<Vec<_>>(), [15, 20], "the last two are kept");
}

/// A file that is not a checkpoint, a corrupt one (a flipped bit: its CRC-32 does not
/// match), one with bytes after its end and one of an older format version are refused,
/// each saying what is wrong and what to do; the older version's message says to run the
/// case from t = 0 (or to continue with the multifield that wrote it).
#[test]
fn a_foreign_corrupt_or_older_checkpoint_is_refused() {
    let case = taylor_green(&["time.end=0.05"]);
    let dir = out_dir("refused");
    run_into(&case, &dir, None);
    let bytes = std::fs::read(&checkpoints(&dir).last().unwrap().1).unwrap();
    assert!(checkpoint::read(&checkpoints(&dir).last().unwrap().1).is_ok());
    let refused = |name: &str, bytes: &[u8]| {
        // outside a checkpoints folder: no other checkpoint to name
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = run(&case, &dir, &RunOptions { restart: Some(path.clone()), ..RunOptions::quiet() })
            .expect_err("refused")
            .to_string();
        assert!(e.starts_with(&format!("checkpoint {}: ", path.display())), "{e}");
        e
    };
    let e = refused("foreign.bin", b"(name: \"taylor_green\")");
    assert!(
        e.contains("not a multifield checkpoint") && e.contains("run the case from t = 0 without --restart"),
        "{e}"
    );

    let mut corrupt = bytes.clone();
    corrupt[bytes.len() / 2] ^= 0x10;
    let e = refused("corrupt.bin", &corrupt);
    assert!(e.contains("corrupt: the CRC-32 of its contents does not match"), "{e}");
    assert!(e.contains("restart from another checkpoint"), "{e}");

    let mut longer = bytes.clone();
    longer.push(0);
    let e = refused("longer.bin", &longer);
    assert!(e.contains("extra bytes after the end"), "{e}");

    // the version sits at bytes 8–11 (u32, little-endian) in every version of the format
    assert_eq!(bytes[8..12], checkpoint::VERSION.to_le_bytes());
    let mut older = bytes.clone();
    older[8..12].copy_from_slice(&2u32.to_le_bytes());
    let e = refused("older.bin", &older);
    let message = format!(
        "format version 2 (written by an older multifield), this multifield reads version {}",
        checkpoint::VERSION
    );
    assert!(e.contains(&message), "{e}");
    assert_eq!(checkpoint::VERSION, 6, "version 6: the monitors' time averages and the contact model's history");
    assert!(e.contains("run the case from t = 0 without --restart, or continue it with the multifield that"), "{e}");
    assert!(!e.contains("restart from another checkpoint"), "{e}");
}

/// Another grid (or another field) is refused with the entries that differ; `time` and
/// `output` may change.
#[test]
fn a_checkpoint_of_another_grid_is_refused() {
    let case = taylor_green(&["time.end=0.1"]);
    let dir = out_dir("other_grid");
    run_into(&case, &dir, None);
    let last = checkpoints(&dir).last().unwrap().1.clone();
    let finer = taylor_green(&["time.end=0.2", "domain.cells=(32, 32)"]);
    let e =
        run(&finer, &out_dir("other_grid_finer"), &RunOptions { restart: Some(last.clone()), ..RunOptions::quiet() })
            .expect_err("another grid is refused")
            .to_string();
    assert!(e.contains("was written by a different case `taylor_green`"), "{e}");
    assert!(e.contains("`domain.cells` is [16,16] in the checkpoint, [32,32] here"), "{e}");
    assert!(
        e.contains("A restart may change only domain.ranks, time.*, output.*, description, monitors and stop"),
        "{e}"
    );
    let thicker = taylor_green(&["time.end=0.2", "fields.fluid.density=2.0"]);
    let e = checkpoint::restore(&thicker, &last).err().unwrap().to_string();
    assert!(e.contains("`fields.fluid.density` is 1.0 in the checkpoint, 2.0 here"), "{e}");
    // time and output may change
    let later = taylor_green(&["time.end=0.15", "output.interval=0.05", "output.checkpoints=None"]);
    let outcome = run_into(&later, &out_dir("other_grid_later"), Some(&last));
    assert_eq!(outcome.summary.steps, 15);
    assert!(checkpoints(&outcome.output_dir).is_empty());
}

/// `multifield run` killed (SIGKILL) while it writes a checkpoint every step: every
/// checkpoint left reads back whole, and the run continued from the last one ends with the
/// files of a run that was never interrupted.
#[test]
fn a_killed_process_leaves_readable_checkpoints_and_continues_from_them() {
    let dir = out_dir("sigkill");
    let exe = env!("CARGO_BIN_EXE_multifield");
    let sets = |end: &str| {
        ["domain.cells=(16, 16)", "time.fixed_dt=Some(0.01)", "output.interval=0.02", "output.charts=false"]
            .into_iter()
            .map(String::from)
            .chain(["output.checkpoints=Some((interval: 0.01))".into(), format!("time.end={end}")])
            .flat_map(|s| ["--set".to_string(), s])
            .collect::<Vec<_>>()
    };
    let out = dir.join("run");
    let mut child = std::process::Command::new(exe)
        .args(["run", "examples/taylor_green.ron", "--quiet", "--out"])
        .arg(&out)
        .args(sets("1000"))
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while checkpoints(&out).last().is_none_or(|c| c.0 < 5) {
        assert!(child.try_wait().unwrap().is_none(), "the run ended by itself");
        assert!(start.elapsed().as_secs() < 120, "no checkpoint after 120 s");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let list = checkpoints(&out);
    assert!(list.len() >= 2, "{list:?}");
    for (step, path) in &list {
        let c = checkpoint::read(path).unwrap_or_else(|e| panic!("after the kill: {e}"));
        assert_eq!(c.step, *step);
    }
    // continue to 5 steps past the last checkpoint, and compare with a run to that time
    let (last, path) = list.last().unwrap().clone();
    let end = format!("{}", (last + 5) as Real * 0.01);
    let cli = std::process::Command::new(exe)
        .args(["run", "examples/taylor_green.ron", "--quiet", "--out"])
        .arg(&out)
        .args(sets(&end))
        .arg("--restart")
        .arg(&path)
        .output()
        .unwrap();
    assert!(cli.status.success(), "{}", String::from_utf8_lossy(&cli.stderr));
    let reference = out_dir("sigkill_reference");
    let case = taylor_green(&["output.checkpoints=Some((interval: 0.01))", &format!("time.end={end}")]);
    let r = run_into(&case, &reference, None);
    assert_eq!(r.summary.steps, last + 5);
    assert_eq!(read(&reference.join("diagnostics.csv")), read(&out.join("diagnostics.csv")));
    let name = checkpoint::file_name(last + 5);
    let (a, b) = (reference.join("checkpoints").join(&name), out.join("checkpoints").join(&name));
    assert!(std::fs::read(a).unwrap() == std::fs::read(b).unwrap(), "final checkpoints differ");
}

/// Snapshots at exact times (the steps land on them) and at the end, continued from a
/// checkpoint between two of the times: the restarted run lands on the same times and
/// writes the same snapshots (same steps, times and arrays, bit for bit) as the
/// uninterrupted one after the checkpoint.
#[test]
fn a_restarted_run_writes_the_same_snapshots_at_the_requested_times() {
    multifield::link_all();
    let case = taylor_green(&[
        "time.end=0.2",
        "output.snapshots=Some((times: [0.033, 0.077, 0.15], at_end: true))",
        "output.pictures=Some((times: [0.077, 0.15], width: 64))",
        "output.checkpoints=Some((interval: 0.1))",
    ]);
    restart_reproduces_the_run("moments", &case);
    let read_all = |dir: &Path| -> Vec<multifield::snapshot::Snapshot> {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("snapshots"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "h5"))
            .collect();
        files.sort();
        files.iter().map(|p| multifield::snapshot::Snapshot::read(p).unwrap()).collect()
    };
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("restart").join("moments");
    let (full, restarted) = (read_all(&root.join("full")), read_all(&root.join("restarted")));
    let times: Vec<Real> = full.iter().map(|s| s.time).collect();
    assert_eq!(times.len(), 4, "three times and the end: {times:?}");
    for (t, want) in times.iter().zip([0.033, 0.077, 0.15, 0.2]) {
        assert!((t - want).abs() <= 1e-12 * want, "{times:?}");
    }
    // the checkpoint is at the first step at or past 0.1: the restarted run writes the last two
    let after: Vec<_> = full.iter().filter(|s| s.time > 0.1).collect();
    assert_eq!(after.len(), 2);
    assert_eq!(restarted.len(), after.len(), "{:?}", restarted.iter().map(|s| s.time).collect::<Vec<_>>());
    for (a, b) in after.iter().zip(&restarted) {
        assert_eq!((a.step, a.time.to_bits()), (b.step, b.time.to_bits()));
        assert!(**a == *b, "the snapshot of step {} differs", a.step);
    }
    // the pictures: two in the full run; the restarted one draws the second, numbered on
    let names = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d.join("frames"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(&root.join("full")), ["frame_000000.png", "frame_000001.png", "frames.csv"]);
    assert_eq!(names(&root.join("restarted")), ["frame_000001.png", "frames.csv"]);
    // the restarted run's index lists its own frame, numbered on
    let index = std::fs::read_to_string(root.join("restarted/frames/frames.csv")).unwrap();
    assert_eq!(index.lines().count(), 2, "{index}");
    assert!(index.lines().nth(1).unwrap().ends_with(",1"), "{index}");
}
