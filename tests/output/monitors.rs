//! Monitors and stop conditions (issue 22): what `monitors/<name>.csv` holds, read back
//! and compared with exact values, with `bodies.csv`, and with longer runs; the stop
//! conditions end runs where they should.

use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::monitor::Monitors;
use multifield::core::simulation::{Simulation, Status};
use multifield::core::table::Table;
use multifield::run::{run, Outcome, RunOptions};
use std::path::{Path, PathBuf};

fn out_dir(name: &str) -> PathBuf {
    super::common::created_dir("monitors", name)
}

/// The case of `text` with `monitors` and `stop` added (RON lists' contents).
fn case_of(name: &str, text: &str, monitors: &str, stop: &str, overrides: &[&str]) -> Case {
    multifield::link_all();
    let end = text.trim_end().strip_suffix(')').expect("a case ends with `)`");
    let text = format!("{end}    monitors: [{monitors}],\n    stop: [{stop}],\n)\n");
    let path = out_dir(&format!("cases/{name}")).join("case.ron");
    std::fs::write(&path, text).unwrap();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Case::load(&path, &overrides).unwrap_or_else(|e| panic!("{e}"))
}

fn example(file: &str) -> String {
    std::fs::read_to_string(file).unwrap()
}

fn run_into(case: &Case, dir: &Path) -> Outcome {
    let outcome = run(case, dir, &RunOptions::quiet()).unwrap();
    assert_eq!(outcome.status, Status::Completed, "{:?}", outcome.summary.reason);
    outcome
}

fn table(path: &Path) -> Table {
    Table::read(path).unwrap().unwrap_or_else(|| panic!("{} is missing", path.display()))
}

fn column(t: &Table, name: &str) -> Vec<Real> {
    t.numbers(name).unwrap_or_else(|| panic!("no column {name} in {:?}", t.header))
}

/// A box of 8 × 8 cells with one Eulerian field in rigid rotation (u = −ω(y − c),
/// v = ω(x − c): linear in x and y) and the given monitors.
const ROTATION: &str = r#"(
    name: "rotation",
    domain: (origin: (-0.5, 0.25), size: (1.0, 1.0), cells: (8, 8)),
    time: (end: 0.01, cfl: 0.4, max_dt: 0.01),
    fields: [
        (
            name: "fluid",
            density: 1.0,
            frame: (model: "eulerian"),
            region: All,
            velocity: RigidRotation(center: (0.1, 0.7), angular_velocity: 3.0),
            stress: [(model: "newtonian", params: (viscosity: 0.01))],
        ),
    ],
    pressure: Some((model: "pcg")),
    output: (charts: false),
)"#;

/// A probe of a field linear in x and y returns the exact value at points off the grid:
/// the pressure (cell centres; a point between the last centre and the wall is
/// extrapolated) and the velocity (u on the x-faces, v on the y-faces).
#[test]
fn a_probe_of_a_linear_field_is_exact_at_points_off_the_grid() {
    let points = [[-0.43, 0.31], [0.0123, 0.777], [0.37, 1.1], [-0.2, 0.9], [0.49, 1.24]];
    // the faces on the walls hold no-slip's zero normal velocity: points a cell inside
    let inner = [[0.0123, 0.777], [0.37, 1.1], [-0.2, 0.9], [-0.3, 0.5]];
    let text = |p: &[[Real; 2]]| p.iter().map(|p| format!("({}, {})", p[0], p[1])).collect::<Vec<_>>().join(", ");
    let monitors = format!(
        r#"(name: "p", of: Probes(quantity: "pressure", points: [{0}])),
           (name: "u", of: Probes(quantity: "velocity", points: [{1}])),
           (name: "uf", of: Probes(quantity: "velocity", field: Some("fluid"), points: [{1}]))"#,
        text(&points),
        text(&inner)
    );
    let case = case_of("linear", ROTATION, &monitors, "", &[]);
    let mut sim = Simulation::new(&case).unwrap();
    // a pressure linear in x and y at the cell centres
    let pressure = |x: Real, y: Real| 2.5 - 1.75 * x + 0.625 * y;
    let g = sim.grid.clone();
    for j in 0..g.ny {
        for i in 0..g.nx {
            let c = g.cell_center(i, j);
            sim.pressure[g.cell(i, j)] = pressure(c.x, c.y);
        }
    }
    let dir = out_dir("linear");
    let mut monitors = Monitors::create(&mut sim, &dir).unwrap().unwrap();
    monitors.start(&mut sim).unwrap();
    let p = table(&dir.join("monitors/p.csv"));
    let mut worst: Real = 0.0;
    for (k, q) in points.iter().enumerate() {
        let got = column(&p, &format!("p{k}"))[0];
        let exact = pressure(q[0], q[1]);
        worst = worst.max((got - exact).abs());
    }
    let (w, c) = (3.0, [0.1, 0.7]);
    for file in ["u", "uf"] {
        let u = table(&dir.join(format!("monitors/{file}.csv")));
        for (k, q) in inner.iter().enumerate() {
            let (ux, uy) = (column(&u, &format!("p{k}_x"))[0], column(&u, &format!("p{k}_y"))[0]);
            worst = worst.max((ux + w * (q[1] - c[1])).abs()).max((uy - w * (q[0] - c[0])).abs());
        }
    }
    eprintln!("linear fields: largest probe error {worst:e}");
    assert!(worst < 1e-14, "largest error {worst:e}");
}

/// Plane Poiseuille flow (periodic in x, no-slip walls at y = 0 and 1, body force g = 8,
/// ν = 1: u = 4 y (1 − y), u_max = 1) on 4 × 16 cells, run to t = 1.5 (the slowest mode
/// decayed by e^(−1.5π²) ≈ 4e-7): a `Line` of the velocity across the channel matches the
/// parabola within the scheme's error at 16 cells: the discrete solution at the faces,
/// plus the linear interpolation between the rows of faces (at most h²/8 |u''| =
/// 3.9e-3 u_max), plus, between the first row and the wall, the linear extrapolation of
/// the two first rows (3h²/8 |u''| = 1.17e-2 u_max at the wall).
#[test]
fn a_line_across_poiseuille_flow_matches_the_parabola() {
    let text = r#"(
    name: "poiseuille",
    domain: (size: (0.25, 1.0), cells: (4, 16)),
    boundaries: (left: Periodic, right: Periodic, bottom: NoSlip, top: NoSlip),
    gravity: (8.0, 0.0),
    time: (end: 1.5, cfl: 0.4, max_dt: 0.01),
    fields: [
        (
            name: "fluid",
            density: 1.0,
            frame: (model: "eulerian"),
            region: All,
            stress: [(model: "newtonian", params: (viscosity: 1.0))],
        ),
    ],
    pressure: Some((model: "pcg", params: (tolerance: 1e-12))),
    output: (interval: 0.5, charts: false),
)"#;
    let n = 21;
    let monitors = format!(
        r#"(name: "profile", every: Time(0.5), of: Line(quantity: "velocity", from: (0.1, 0.0), to: (0.1, 1.0), points: {n}))"#
    );
    let case = case_of("poiseuille", text, &monitors, "", &[]);
    let dir = out_dir("poiseuille");
    run_into(&case, &dir);
    let t = table(&dir.join("monitors/profile.csv"));
    assert_eq!(column(&t, "time").len(), 4, "rows at t = 0, 0.5, 1, 1.5");
    let last = t.rows.len() - 1;
    let (mut err, mut err_v, mut interior): (Real, Real, Real) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let y = k as Real / (n - 1) as Real;
        let u = column(&t, &format!("s{k}_x"))[last];
        let v = column(&t, &format!("s{k}_y"))[last];
        err = err.max((u - 4.0 * y * (1.0 - y)).abs());
        if (1.0 / 32.0..=31.0 / 32.0).contains(&y) {
            interior = interior.max((u - 4.0 * y * (1.0 - y)).abs());
        }
        err_v = err_v.max(v.abs());
    }
    eprintln!(
        "Poiseuille, 16 cells across, a line of {n} points: max |u − parabola| = {err:.3e} u_max \
         ({interior:.3e} between the first and last rows of faces), max |v| = {err_v:.1e}"
    );
    // between the rows: the scheme's error and h²/8 |u''| = 3.9e-3; at the walls the rows
    // are extrapolated linearly: 3h²/8 |u''| = 1.17e-2 more
    assert!(interior < 4.5e-3, "max error between the rows {interior:.3e}");
    assert!(err < 1.6e-2, "max error {err:.3e}");
    assert!(err_v < 1e-10, "max |v| {err_v:e}");
}

/// `Forces` on the cylinder of the channel: fx, fy, torque and the pressure and viscous
/// parts are `bodies.csv`'s (the same text, row by row), and the coefficient columns are them divided by q = ½ ρ U² L (and
/// q L), exactly.
#[test]
fn forces_are_the_bodies_forces_and_the_coefficients_their_normalisation() {
    let (u, l, rho) = (0.2, 0.1, 1.0);
    let monitors = format!(
        r#"(name: "drag", of: Forces(bodies: ["cylinder"], reference: Some((velocity: {u}, length: {l}, density: {rho})))),
           (name: "all", every: Time(0.05), of: Forces(field: Some("cylinder")))"#
    );
    let case = case_of(
        "forces",
        &example("examples/cylinder_channel.ron"),
        &monitors,
        "",
        &["time.end=0.2", "output.interval=0", "output.charts=false"],
    );
    let dir = out_dir("forces");
    let outcome = run_into(&case, &dir);
    let bodies = table(&dir.join("bodies.csv"));
    let drag = table(&dir.join("monitors/drag.csv"));
    assert_eq!(drag.rows.len() as u64, outcome.summary.steps + 1, "a row at t = 0 and after every step");
    assert_eq!(drag.rows.len(), bodies.rows.len());
    let text = |t: &Table, name: &str| -> Vec<String> {
        let k = t.index(name).unwrap();
        t.rows.iter().map(|r| r[k].to_string()).collect()
    };
    for c in ["step", "time", "fx", "fy", "torque", "fx_pressure", "fy_pressure", "fx_viscous", "fy_viscous"] {
        assert_eq!(text(&drag, c), text(&bodies, c), "column {c}");
    }
    let q = 0.5 * rho * u * u * l;
    let (fx, fy, t) = (column(&drag, "fx"), column(&drag, "fy"), column(&drag, "torque"));
    let (cd, cl, cm) = (column(&drag, "c_D"), column(&drag, "c_L"), column(&drag, "c_M"));
    for k in 0..fx.len() {
        assert_eq!(cd[k].to_bits(), (fx[k] / q).to_bits(), "c_D row {k}");
        assert_eq!(cl[k].to_bits(), (fy[k] / q).to_bits(), "c_L row {k}");
        assert_eq!(cm[k].to_bits(), (t[k] / (q * l)).to_bits(), "c_M row {k}");
    }
    assert!(cd[cd.len() - 1] > 1.0, "a drag: c_D = {}", cd[cd.len() - 1]);
    assert!(column(&drag, "fx_pressure")[cd.len() - 1] > 0.0, "the pressure part is given");
    // every 0.05: rows at t = 0, the first steps at or after 0.05, 0.1, 0.15, and the last
    let all = table(&dir.join("monitors/all.csv"));
    let times = column(&all, "time");
    assert_eq!(times.len(), 5, "{times:?}");
    for (k, t) in times.iter().enumerate().skip(1) {
        assert!(*t >= 0.05 * k as Real - 1e-12, "{times:?}");
    }
    assert_eq!(text(&all, "fx").last(), text(&drag, "fx").last());
}

/// The lid-driven cavity at Re 100 on 16 × 16 cells: a `Steady` stop on the centre line's
/// u at y = 0.25 (tolerance 1e-4 over 1 unit of time) ends the run long before t = 50, and
/// its centre-line profile is the t = 50 run's within the tolerance (relative to the
/// profile's largest |u|).
#[test]
fn a_steady_stop_ends_the_cavity_early_with_the_long_runs_profile() {
    let tolerance = 1e-4;
    let monitors = r#"(name: "centre", every: Time(0.1), of: Line(quantity: "velocity", from: (0.5, 0.0), to: (0.5, 1.0), points: 17))"#;
    let steady = format!(r#"Steady(monitor: "centre", column: "s4_x", tolerance: {tolerance}, window: 1.0)"#);
    let overrides = ["domain.cells=(16, 16)", "time.end=50", "output.interval=1", "output.charts=false"];
    let text = example("examples/lid_driven_cavity.ron");
    let stopped = case_of("cavity_steady", &text, monitors, &steady, &overrides);
    let long = case_of("cavity_long", &text, monitors, "", &overrides);
    let (a, b) = (out_dir("cavity_steady"), out_dir("cavity_long"));
    let short = run_into(&stopped, &a);
    let full = run_into(&long, &b);
    let reason = &short.summary.reason;
    assert!(reason.starts_with("steady: centre.s4_x changed "), "{reason}");
    assert!((full.summary.simulated_time - 50.0).abs() < 1e-9);
    let profile = |dir: &Path| -> Vec<Real> {
        let t = table(&dir.join("monitors/centre.csv"));
        let last = t.rows.len() - 1;
        (0..17).map(|k| column(&t, &format!("s{k}_x"))[last]).collect()
    };
    let (p, q) = (profile(&a), profile(&b));
    let scale = q.iter().fold(0.0 as Real, |m, x| m.max(x.abs()));
    let diff = p.iter().zip(&q).fold(0.0 as Real, |m, (x, y)| m.max((x - y).abs())) / scale;
    eprintln!(
        "cavity 16²: steady stop after {} steps at t = {:.3} ({}), the t = 50 run {} steps; \
         max |Δu| on the centre line {diff:.3e} of max |u| = {scale:.4}",
        short.summary.steps, short.summary.simulated_time, reason, full.summary.steps
    );
    // 551 steps (t ≈ 17.6) against 1582 to t = 50
    assert!(short.summary.steps <= 600, "{} steps", short.summary.steps);
    assert!(short.summary.steps * 2 < full.summary.steps, "{} steps vs {}", short.summary.steps, full.summary.steps);
    assert!(diff < tolerance, "profile differs by {diff:e} of max |u|");
    // the stop is the run's last step: the summary, the monitor's last row and the
    // diagnostics' last row agree
    let d = table(&a.join("diagnostics.csv"));
    assert_eq!(*column(&d, "step").last().unwrap() as u64, short.summary.steps);
    let c = table(&a.join("monitors/centre.csv"));
    assert_eq!(*column(&c, "step").last().unwrap() as u64, short.summary.steps);
}

/// A disk settling in a channel: `Reaches(disk, Y, 5.0, Below)` ends the run at the first
/// step whose centre is at or below y = 5 (the step before it is above), which is the
/// step at which the uninterrupted run crosses y = 5.
#[test]
fn a_reaches_stop_ends_a_falling_disk_at_the_step_it_crosses() {
    let value = 5.0;
    let overrides = ["domain.cells=(32, 96)", "time.end=0.3", "output.interval=0", "output.charts=false"];
    let text = example("examples/settling_disk.ron");
    let reaches = format!("Reaches(body: \"disk\", coordinate: Y, value: {value}, direction: Below)");
    let stopped = case_of("reaches", &text, "", &reaches, &overrides);
    let long = case_of("reaches_long", &text, "", "", &overrides);
    let (a, b) = (out_dir("reaches"), out_dir("reaches_long"));
    let short = run_into(&stopped, &a);
    run_into(&long, &b);
    let ys = |dir: &Path| column(&table(&dir.join("bodies.csv")), "y");
    let (y, y_long) = (ys(&a), ys(&b));
    let n = y.len();
    assert!(y[n - 1] <= value && y[n - 2] > value, "last two y {} {}", y[n - 2], y[n - 1]);
    let crossing = y_long.iter().position(|&y| y <= value).expect("the long run crosses");
    let steps = column(&table(&b.join("bodies.csv")), "step");
    eprintln!(
        "settling disk: stopped at step {} (t = {:.5}, y = {}); the long run crosses at step {}",
        short.summary.steps,
        short.summary.simulated_time,
        y[n - 1],
        steps[crossing]
    );
    assert_eq!(short.summary.steps, steps[crossing] as u64);
    assert!(short.summary.reason.starts_with("reaches: body `disk` has y = "), "{}", short.summary.reason);
    // what a study's `Stopped` metric reads as a stop condition's
    assert!(multifield::core::monitor::is_stop_reason(&short.summary.reason));
}

/// `Steps(n)` and `WallTime` end runs as completed, with the reason.
#[test]
fn steps_and_wall_time_stops_end_the_run_as_completed() {
    let text = example("examples/lid_driven_cavity.ron");
    let overrides = ["domain.cells=(8, 8)", "output.charts=false"];
    let case = case_of("steps", &text, "", "Steps(7)", &overrides);
    let o = run_into(&case, &out_dir("steps"));
    assert_eq!(o.summary.steps, 7);
    assert!(o.summary.reason.starts_with("steps: 7 steps reached"), "{}", o.summary.reason);
    assert!(multifield::core::monitor::is_stop_reason(&o.summary.reason));
    let case = case_of("wall", &text, "", "WallTime(seconds: 1e-9)", &overrides);
    let o = run_into(&case, &out_dir("wall"));
    assert_eq!(o.summary.steps, 1);
    assert!(o.summary.reason.starts_with("wall time: "), "{}", o.summary.reason);
    assert!(multifield::core::monitor::is_stop_reason(&o.summary.reason));
}

/// The cost of the monitors (issue 22's benchmark): the Uhlmann DKT at 16 cells per
/// diameter with ten velocity probes, a line of 100 points and the forces on both disks,
/// all sampled every step, for 150 steps: the time spent sampling against the run's.
/// `cargo test --release --test output monitors::cost -- --ignored --nocapture`
#[test]
#[ignore = "a benchmark: about 15 s"]
fn cost_of_the_monitors_in_a_dkt_run() {
    use multifield::core::driver::Driver;
    let points: Vec<String> =
        (0..10).map(|k| format!("({}, {})", 0.2 + 0.16 * k as Real, 1.0 + 0.45 * k as Real)).collect();
    let monitors = format!(
        r#"(name: "probes", of: Probes(quantity: "velocity", points: [{}])),
           (name: "line", of: Line(quantity: "velocity", from: (0.0, 3.0), to: (2.0, 3.0), points: 100)),
           (name: "forces", of: Forces(bodies: ["trailing", "leading"]))"#,
        points.join(", ")
    );
    let case = case_of("cost", &example("examples/dkt_uhlmann2005.ron"), &monitors, "", &["time.max_steps=150"]);
    let dir = out_dir("cost");
    let mut sim = Simulation::new(&case).unwrap();
    let m = Monitors::create(&mut sim, &dir).unwrap().unwrap();
    let mut driver = Driver::new(sim);
    driver.set_monitors(m);
    let end = driver.run().unwrap();
    let sampling = driver.monitors().unwrap().seconds();
    eprintln!(
        "DKT 16 cells per diameter, {} steps: {:.3} s, of which {:.4} s sampling the monitors ({:.3} %)",
        driver.sim.steps,
        end.wall_seconds,
        sampling,
        100.0 * sampling / end.wall_seconds
    );
    assert_eq!(driver.sim.steps, 150);
    assert!(sampling < 0.02 * end.wall_seconds, "{sampling} s of {} s", end.wall_seconds);
}

/// A `TimeAverage` of the Taylor–Green vortex (ν = 0.01, 32², Δt = 0.05): the snapshots
/// hold `/averages/<name>`, which equals the trapezoid rule over the snapshots' own
/// velocity from the start on (one snapshot per step), and the decay of the vortex makes
/// its average the initial field times (e^{−2νt₀} − e^{−2νt₁}) / (2ν (t₁ − t₀)).
#[test]
fn a_time_average_is_the_trapezoid_rule_over_the_steps_and_follows_the_decay() {
    use multifield::snapshot::Snapshot;
    let case = case_of(
        "time_average",
        &example("examples/taylor_green.ron"),
        r#"(name: "u_mean", of: TimeAverage(quantity: "velocity", start: 0.5)),
           (name: "p_mean", every: Time(0.25), of: TimeAverage(quantity: "pressure"))"#,
        "",
        &["output.snapshots=Some((interval: 0.05))", "output.charts=false", "time.fixed_dt=Some(0.05)"],
    );
    let dir = out_dir("time_average");
    let outcome = run_into(&case, &dir);
    assert_eq!(outcome.summary.steps, 40);
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "h5"))
        .collect();
    files.sort();
    let snaps: Vec<Snapshot> = files.iter().map(|f| Snapshot::read(f).unwrap()).collect();
    assert_eq!(snaps.len(), 41);
    // before the start, no average; from it on, the trapezoid rule over the steps
    assert!(snaps[9].average("u_mean").is_none() && snaps[10].average("u_mean").is_some());
    let last = snaps.last().unwrap();
    let avg = last.average("u_mean").unwrap();
    assert_eq!((avg.from, avg.to, avg.samples), (snaps[10].time, last.time, 31));
    let mut integral = vec![0.0; avg.values.len()];
    for w in snaps[10..].windows(2) {
        let (a, b) = (w[0].get("velocity").unwrap(), w[1].get("velocity").unwrap());
        for ((s, a), b) in integral.iter_mut().zip(a).zip(b) {
            *s += 0.5 * (w[1].time - w[0].time) * (a + b);
        }
    }
    let window = last.time - snaps[10].time;
    let scale = avg.values.iter().fold(0.0, |m: Real, v| m.max(v.abs()));
    let error = avg.values.iter().zip(&integral).fold(0.0, |m: Real, (v, s)| m.max((v - s / window).abs()));
    println!("time average against the trapezoid rule over the snapshots: {error:.2e} of {scale:.3}");
    assert!(error < 1e-14 * scale, "{error:e}");
    // the decay: where |u| is large, average / initial velocity against the analytic
    // (e^{−2νt₀} − e^{−2νt₁}) / (2ν (t₁ − t₀)), within the scheme's error at 32² (−1.7e-3
    // to +4.8e-3: its advection changes the decay a little from cell to cell)
    let nu = 0.01;
    let (t0, t1) = (snaps[10].time, last.time);
    let exact = ((-2.0 * nu * t0).exp() - (-2.0 * nu * t1).exp()) / (2.0 * nu * (t1 - t0));
    let initial = snaps[0].get("velocity").unwrap();
    let (mut lo, mut hi): (Real, Real) = (Real::INFINITY, Real::NEG_INFINITY);
    for (v, u0) in avg.values.iter().zip(initial) {
        if u0.abs() > 0.5 {
            lo = lo.min(exact - v / u0);
            hi = hi.max(exact - v / u0);
        }
    }
    println!("average / initial velocity: exact {exact:.6}, minus the average's {lo:.2e} to {hi:.2e}");
    assert!(lo > -5e-3 && hi < 5e-3, "{lo:e} to {hi:e}");
    // the pressure's, every 0.25 from t = 0: nine samples, its monitor's row the same
    let p = last.average("p_mean").unwrap();
    assert_eq!((p.from, p.samples), (0.0, 9));
    let t = table(&dir.join("monitors/p_mean.csv"));
    assert_eq!(column(&t, "samples").last().copied(), Some(9.0));
    // the mean over the cells by the reduction rule (docs/design/mpi.md §3: row groups of
    // 32 cells along x summed in order, the groups added exactly), to the bit
    let nx = case.cells()[0];
    let mean = multifield::core::exact::sum(&p.values, nx, nx) / p.values.len() as Real;
    assert_eq!(column(&t, "mean").last().copied(), Some(mean));
    assert_eq!(column(&t, "window").last().copied(), Some(2.0));
}

/// A box of water 1 × 2 on 8 × 16 cells with mass-point disks: the field `disks` lists
/// `disks` (and has the `generate` entry, if any), the field `layer` lists `layer`,
/// gravity −9.81 in y.
fn suspension_case(name: &str, disks: &str, generate: &str, layer: &str, monitors: &str) -> Case {
    let text = format!(
        r#"(
    name: "{name}",
    domain: (size: (1.0, 2.0), cells: (8, 16)),
    boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
    gravity: (0.0, -9.81),
    time: (end: 0.001, max_dt: 1e-3, fixed_dt: Some(1e-3)),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),
        (name: "disks", density: 2.0, frame: (model: "lagrangian"), representation: MassPoint,
         region: Bodies([{disks}]), {generate} stress: [(model: "rigid")]),
        (name: "layer", density: 2.0, frame: (model: "lagrangian"), representation: MassPoint,
         region: Bodies([{layer}]), stress: [(model: "rigid")]),
    ],
    pressure: Some((model: "pcg")),
    output: (interval: 0.0, charts: false),
)"#
    );
    case_of(name, &text, monitors, "", &[])
}

/// (x, y, r, u, v) of a body, as a body of the case.
fn disk_entry(k: usize, b: [Real; 5]) -> String {
    format!(
        "(name: \"b{k}\", shape: Disk(center: ({:?}, {:?}), radius: {:?}), motion: Prescribed(velocity: ({:?}, {:?})))",
        b[0], b[1], b[2], b[3], b[4]
    )
}

/// The area of the disk (c, r) below the level z, from the circular cap r² acos(h/r) −
/// h √(r² − h²) (not the monitor's formula).
fn below(c: Real, r: Real, z: Real) -> Real {
    let cap = |h: Real| r * r * (h / r).acos() - h * (r * r - h * h).sqrt();
    if z <= c - r {
        0.0
    } else if z >= c + r {
        std::f64::consts::PI * r * r
    } else if z < c {
        cap(c - z)
    } else {
        std::f64::consts::PI * r * r - cap(z - c)
    }
}

/// A `Suspension` monitor's row at t = 0 against the figures computed here from the bodies:
/// the solid fraction Σπr²/A, the area-weighted mean velocity, the settling velocity, the
/// granular temperature (to round-off), the contacts (one touching pair) and the wall
/// contacts (a body on the bottom, one in the top-right corner); the profile's areas
/// against the circular caps of disks cut by the slabs' edges (1e-12); the bed height of a
/// layer of disks centred on one level (half of its area below: the level itself).
#[test]
fn a_suspension_monitor_gives_the_exact_statistics_of_known_bodies() {
    let pi = std::f64::consts::PI;
    let disks: [[Real; 5]; 5] = [
        [0.3, 0.5, 0.1, 1.0, -2.0],
        [0.44, 0.5, 0.04, 0.0, 0.0],  // touches the first
        [0.7, 0.52, 0.05, -1.0, 0.0], // cut by the slab edge y = 0.5
        [0.5, 0.05, 0.05, 0.5, 0.5],  // on the bottom wall
        [0.95, 1.95, 0.05, 0.0, 3.0], // in the top-right corner
    ];
    let layer: [[Real; 5]; 3] = [[0.2, 1.2, 0.05, 0.0, -1.0], [0.5, 1.2, 0.08, 0.0, -1.0], [0.8, 1.2, 0.03, 0.0, -1.0]];
    let list = |b: &[[Real; 5]], from: usize| -> String {
        b.iter().enumerate().map(|(k, b)| disk_entry(from + k, *b)).collect::<Vec<_>>().join(", ")
    };
    let monitors = r#"(name: "s", of: Suspension(field: "disks", bins: 8)),
        (name: "half", of: Suspension(field: "layer", bins: 1, bed_fraction: 0.5)),
        (name: "top", of: Suspension(field: "layer", axis: X, bins: 4, bed_fraction: 1.0))"#;
    let case = suspension_case("suspension", &list(&disks, 0), "", &list(&layer, 10), monitors);
    let dir = out_dir("suspension");
    run_into(&case, &dir);
    let s = table(&dir.join("monitors/s.csv"));
    let at0 = |t: &Table, c: &str| column(t, c)[0];
    let a: Vec<Real> = disks.iter().map(|b| pi * b[2] * b[2]).collect();
    let sa: Real = a.iter().sum();
    let ux = disks.iter().zip(&a).map(|(b, a)| a * b[3]).sum::<Real>() / sa;
    let uy = disks.iter().zip(&a).map(|(b, a)| a * b[4]).sum::<Real>() / sa;
    let t =
        disks.iter().zip(&a).map(|(b, a)| a * ((b[3] - ux).powi(2) + (b[4] - uy).powi(2))).sum::<Real>() / (2.0 * sa);
    let close = |got: Real, want: Real, what: &str| {
        assert!((got - want).abs() <= 1e-15 * want.abs().max(1.0), "{what}: {got} against {want}");
    };
    assert_eq!(at0(&s, "bodies"), 5.0);
    close(at0(&s, "solid_fraction"), sa / 2.0, "solid fraction");
    close(at0(&s, "u_x"), ux, "u_x");
    close(at0(&s, "u_y"), uy, "u_y");
    close(at0(&s, "settling_velocity"), -uy, "settling velocity (gravity along −y)");
    close(at0(&s, "temperature"), t, "granular temperature");
    assert_eq!((at0(&s, "contacts"), at0(&s, "wall_contacts")), (1.0, 3.0));
    eprintln!("solid fraction {}, U = ({ux}, {uy}), T = {t}", sa / 2.0);
    // the profile at t = 0: 8 slabs 0.25 high across the width 1
    let p = table(&dir.join("monitors/s_profiles.csv"));
    let (step, bin, centre, phi) =
        (column(&p, "step"), column(&p, "bin"), column(&p, "centre"), column(&p, "solid_fraction"));
    let (pu, pv) = (column(&p, "u_x"), column(&p, "u_y"));
    let mut worst: Real = 0.0;
    for k in 0..8 {
        assert_eq!((step[k], bin[k]), (0.0, k as Real));
        let (lo, hi) = (0.25 * k as Real, 0.25 * (k + 1) as Real);
        close(centre[k], lo + 0.125, "centre");
        let parts: Vec<Real> = disks.iter().map(|b| below(b[1], b[2], hi) - below(b[1], b[2], lo)).collect();
        let area: Real = parts.iter().sum();
        worst = worst.max((phi[k] * 0.25 - area).abs());
        assert!((phi[k] * 0.25 - area).abs() <= 1e-12, "slab {k}: {} against {area}", phi[k] * 0.25);
        if area > 0.0 {
            let u = disks.iter().zip(&parts).map(|(b, p)| p * b[3]).sum::<Real>() / area;
            let v = disks.iter().zip(&parts).map(|(b, p)| p * b[4]).sum::<Real>() / area;
            assert!(
                (pu[k] - u).abs() <= 1e-12 && (pv[k] - v).abs() <= 1e-12,
                "slab {k}: ({}, {}) against ({u}, {v})",
                pu[k],
                pv[k]
            );
        } else {
            assert!(pu[k].is_nan() && pv[k].is_nan(), "an empty slab has no velocity");
        }
    }
    // the slab 0.5–0.75 holds the upper parts of the disks cut at y = 0.5
    assert!(phi[2] > 0.0 && phi[1] > 0.0);
    eprintln!("largest error of a slab's area: {worst:e}");
    // the profiles of the whole slabs add up to the solid fraction
    close(phi[..8].iter().sum::<Real>() / 8.0, sa / 2.0, "mean of the profile");
    // the bed height: half of the layer's area lies below its centres' level (y = 1.2); along
    // X with bed_fraction 1, all of it lies left of the rightmost disk's right edge, 0.83
    let half = table(&dir.join("monitors/half.csv"));
    assert!((at0(&half, "bed_height") - 1.2).abs() <= 1e-14, "{}", at0(&half, "bed_height"));
    assert_eq!(at0(&half, "settling_velocity"), 1.0);
    assert_eq!((at0(&half, "contacts"), at0(&half, "temperature")), (0.0, 0.0));
    let top = table(&dir.join("monitors/top.csv"));
    // 1 − F(z) ∝ (0.83 − z)^{3/2}: round-off of the total hides up to ~1e-10 below the top
    assert!((at0(&top, "bed_height") - 0.83).abs() <= 1e-9, "{}", at0(&top, "bed_height"));
}

/// A hexagonal lattice of 6 × 4 disks with the spacing equal to the diameter (to 10⁻⁹): every
/// neighbour touches, 4·5 pairs along the rows and 3·11 between them, 53 contacts; the
/// monitor's files are the same on 1 and 2 threads.
#[test]
fn a_suspension_monitor_counts_the_contacts_of_a_touching_lattice() {
    let generate = r#"generate: [(name: "p", region: (min: (0.2, 0.2), max: (0.86, 0.58)), count: Some(24),
        diameter: Fixed(0.1), arrangement: Lattice(Hexagonal), seed: 1)],"#;
    // the default spacing is the diameter and 10⁻⁹ of it (neighbours never overlap by
    // round-off): gaps of 10⁻¹⁰
    let monitors = r#"(name: "s", of: Suspension(field: "disks", bins: 10, contact_gap: 1e-6))"#;
    let case = suspension_case("lattice", "", generate, &disk_entry(0, [0.5, 1.5, 0.05, 0.0, 0.0]), monitors);
    let mut files = Vec::new();
    for threads in [1, 2] {
        let dir = out_dir(&format!("lattice_{threads}"));
        let outcome = run(&case, &dir, &RunOptions { threads, ..RunOptions::quiet() }).unwrap();
        assert_eq!(outcome.status, Status::Completed);
        let s = table(&dir.join("monitors/s.csv"));
        assert_eq!(column(&s, "bodies")[0], 24.0);
        assert_eq!(column(&s, "contacts")[0], 53.0, "4·5 + 3·11 lattice edges");
        assert_eq!(column(&s, "wall_contacts")[0], 0.0);
        let phi = column(&s, "solid_fraction")[0];
        assert!((phi - 24.0 * std::f64::consts::PI * 0.0025 / 2.0).abs() <= 1e-15, "{phi}");
        files.push(["s.csv", "s_profiles.csv"].map(|f| std::fs::read_to_string(dir.join("monitors").join(f)).unwrap()));
    }
    assert_eq!(files[0], files[1], "1 and 2 threads");
}
