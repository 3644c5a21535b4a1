//! Resolved bodies by direct forcing on their surfaces (`direct_forcing`, issue 14): forces
//! that converge to published values and do not depend on the body's density, on Δt, or
//! on the length of the last step.

use multifield::core::case::Case;
use multifield::core::grid::Lattice;
use multifield::core::immersed;
use multifield::core::math::{Real, Vector};
use multifield::core::simulation::Simulation;
use std::path::Path;

const CHANNEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/cylinder_channel.ron");

/// John (2004), the reference values of Schäfer & Turek's 2D-1.
const DRAG: Real = 5.57953523384;
const LIFT: Real = 0.010618948146;

/// Runs the channel with `overrides` on one thread (a 220 × 41 grid is too small to share)
/// and returns the force rows (time, fx, fy) of the cylinder, one per step.
fn channel(overrides: &[&str]) -> Vec<(Real, Real, Real)> {
    multifield::link_all();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let case = Case::load(Path::new(CHANNEL), &overrides).expect("valid case");
    rows_of(&case).into_iter().map(|(t, _, f)| (t, f.x, f.y)).collect()
}

/// Runs `case` to its end on one thread and returns the first body's rows (time,
/// velocity, force), one per step.
fn rows_of(case: &Case) -> Vec<(Real, Vector, Vector)> {
    run(case).0
}

/// [`rows_of`], and the simulation as it ends.
fn run(case: &Case) -> (Vec<(Real, Vector, Vector)>, Simulation) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    pool.install(|| {
        let mut sim = Simulation::new(case).expect("builds");
        let mut rows = Vec::new();
        while sim.time < case.time.end * (1.0 - 1e-12) {
            sim.step().expect("steps");
            let b = &sim.bodies()[0].1;
            rows.push((sim.time, b.velocity, b.force));
        }
        (rows, sim)
    })
}

/// The channel's cylinder at `cells_per_d` cells per diameter to t = 8: C_D, its pressure
/// part C_Dp, and Δp = p(front) − p(back) on the surface ([`immersed::surface_pressure`]).
fn channel_pressure(cells_per_d: usize) -> (Real, Real, Real) {
    multifield::link_all();
    let cells = format!("domain.cells=({}, {})", 22 * cells_per_d, (41 * cells_per_d) / 10);
    let case = Case::load(Path::new(CHANNEL), &["time.end=8.0".to_string(), cells]).expect("valid case");
    let (rows, sim) = run(&case);
    let fp = sim.pressure_forces()[0].expect("a disk held by direct forcing has a pressure force");
    let p = |angle: Real| {
        immersed::surface_pressure(&sim.grid, [false, false], &sim.pressure, Vector::new(0.2, 0.2), 0.05, 0.3, angle)
    };
    (coefficient(rows.last().unwrap().2.x), coefficient(fp.x), p(std::f64::consts::PI) - p(0.0))
}

/// The pressure drop across the cylinder of Schäfer–Turek 2D-1 (John 2004).
const PRESSURE_DROP: Real = 0.11752016697;

/// The drag of the channel's cylinder split into its pressure and viscous parts: at 10
/// cells per diameter C_Dp = 3.4868 and C_Dv = 2.1031 (their sum the reported C_D), and the
/// surface pressure drop Δp = 0.11362, −3.3 % of John's (the pressure is read 2.2 h off the
/// surface, beyond the force layer, and extrapolated: first order; −2.5 % at 20 cells per
/// diameter, C_Dp = 3.4376, C_Dv = 2.1244). John (2004) publishes only the sum; the
/// viscous part is the total less the pressure part, so their sum is exact by construction
/// and the pressure part's own error is measured through Δp.
#[test]
fn the_channel_cylinders_drag_splits_into_pressure_and_viscous_parts() {
    let (cd, cdp, dp) = channel_pressure(10);
    eprintln!(
        "10 cells per D: C_D {cd:.5} = C_Dp {cdp:.5} + C_Dv {:.5}; Δp = {dp:.6} ({:+.3} % of {PRESSURE_DROP})",
        cd - cdp,
        100.0 * (dp / PRESSURE_DROP - 1.0)
    );
    assert!((dp / PRESSURE_DROP - 1.0).abs() < 0.04, "Δp {dp}");
}

/// docs/validation.md's table of the split: 10 and 20 cells per diameter (50 s), the
/// pressure drop's error falling (−3.3 %, −2.5 %) and the pressure part moving by less
/// than 2 %.
#[test]
#[ignore]
fn the_drags_split_on_10_and_20_cells_per_diameter() {
    let (cd10, cdp10, dp10) = channel_pressure(10);
    let (cd20, cdp20, dp20) = channel_pressure(20);
    for (n, cd, cdp, dp) in [(10, cd10, cdp10, dp10), (20, cd20, cdp20, dp20)] {
        eprintln!(
            "{n} cells per D: C_D {cd:.5} = C_Dp {cdp:.5} + C_Dv {:.5}; Δp = {dp:.6} ({:+.3} %)",
            cd - cdp,
            100.0 * (dp / PRESSURE_DROP - 1.0)
        );
    }
    let (e10, e20) = ((dp10 / PRESSURE_DROP - 1.0).abs(), (dp20 / PRESSURE_DROP - 1.0).abs());
    assert!(e20 < e10 && e20 < 0.03, "Δp's error {e10} at 10 cells, {e20} at 20");
    assert!((cdp20 / cdp10 - 1.0).abs() < 0.02, "C_Dp {cdp10} at 10 cells, {cdp20} at 20");
}

/// A fixed disk (R = 0.15) in a closed box of water (ρ = 1000) at rest under gravity
/// g = (0, −9.81): the pressure is hydrostatic, p = p₀ − ρ g y, and exerts the buoyancy
/// ρ π R² |g| upward on the disk, none sideways; the flow stays at rest, so the viscous part
/// is nil. Linear pressure: [`immersed::surface_pressure`]'s extrapolation is exact, and the
/// midpoint rule integrates the circle's n y to rounding.
#[test]
fn a_disk_in_water_at_rest_feels_the_buoyancy_of_archimedes() {
    let case = r#"(
        name: "buoyancy", gravity: (0.0, -9.81),
        domain: (size: (1.0, 1.0), cells: (40, 40)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        time: (end: 0.2, cfl: 0.4, max_dt: 0.01),
        fields: [
            (name: "water", density: 1000.0, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 0.001))]),
            (name: "disk", density: 2000.0, frame: (model: "lagrangian"),
             region: Bodies([(name: "disk", shape: Disk(center: (0.5, 0.45), radius: 0.15), motion: Fixed)]),
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("water", "disk"), model: "direct_forcing")],
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-12))),
    )"#;
    multifield::link_all();
    let (rows, sim) = run(&Case::from_ron(case, Path::new("case.ron")).expect("valid case"));
    let fp = sim.pressure_forces()[0].expect("a pressure force");
    let total = rows.last().unwrap().2;
    let buoyancy = 1000.0 * std::f64::consts::PI * 0.15 * 0.15 * 9.81;
    eprintln!("buoyancy {buoyancy:.6}: pressure part {fp:?}, total {total:?}");
    assert!((fp.y / buoyancy - 1.0).abs() < 1e-9 && fp.x.abs() < 1e-9 * buoyancy, "pressure force {fp:?}");
    let viscous = total - fp;
    assert!(viscous.norm() < 1e-9 * buoyancy, "viscous part {viscous:?}");
}

/// C = 2F/(ρ Ū² D) with Ū = 0.2, D = 0.1, ρ = 1.
fn coefficient(f: Real) -> Real {
    2.0 * f / (0.2 * 0.2 * 0.1)
}

/// At 10 cells per diameter the steady drag is within 0.5 % of the reference and the lift
/// within 3 %; the same for CFL 0.2 and 0.8 to 0.05 %, for body densities 1, 10 and 1000 to
/// the bit, and the last (shortened) step's force equals the rows before it to 1e-5.
#[test]
fn fixed_cylinder_in_a_channel_matches_schafer_turek_whatever_the_density_and_the_step() {
    let end = "time.end=8.0";
    let base = channel(&[end]);
    let (t, fx, fy) = *base.last().unwrap();
    let (cd, cl) = (coefficient(fx), coefficient(fy));
    let before = base[base.len() - 2];
    eprintln!(
        "Schäfer–Turek 2D-1, 10 cells per diameter, t = {t}: C_D = {cd:.5} ({:+.3} % of {DRAG}), \
         C_L = {cl:.6} ({:+.2} % of {LIFT}); the row before the last step: C_D = {:.5}",
        100.0 * (cd / DRAG - 1.0),
        100.0 * (cl / LIFT - 1.0),
        coefficient(before.1)
    );
    assert!((cd / DRAG - 1.0).abs() < 0.005, "C_D {cd}");
    assert!((cl / LIFT - 1.0).abs() < 0.03, "C_L {cl}");
    assert!((fx / before.1 - 1.0).abs() < 1e-5, "the last step's drag {fx} against {}", before.1);
    for cfl in ["0.2", "0.8"] {
        let (_, f, _) = *channel(&[end, &format!("time.cfl={cfl}")]).last().unwrap();
        eprintln!("CFL {cfl}: C_D = {:.6} ({:+.2e} relative to CFL 0.4)", coefficient(f), f / fx - 1.0);
        assert!((f / fx - 1.0).abs() < 5e-4, "CFL {cfl}: drag {f} against {fx} at CFL 0.4");
    }
    for density in ["10.0", "1000.0"] {
        let rows = channel(&[end, &format!("fields.cylinder.density={density}")]);
        assert_eq!(rows.last().unwrap().1.to_bits(), fx.to_bits(), "density {density}");
    }
}

const COUETTE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/couette.ron");

/// Runs the circular Couette flow of examples/couette.ron on `cells`² (10 cells per R₁ at
/// 48) to t = 4 on one thread and returns the rotor's torque and the RMS errors of the
/// velocity on the faces against the steady solution: in the gap (R₁ < r < R₂, against
/// u_θ = Ar + B/r) and over all the fluid inside R₂ (the disk's inside, fictitious fluid, too:
/// rigid rotation u_θ = Ωr there).
fn couette(cells: usize) -> (Real, Real, Real) {
    multifield::link_all();
    let overrides = [format!("domain.cells=({cells}, {cells})"), "time.end=4.0".to_string()];
    let case = Case::load(Path::new(COUETTE), &overrides).expect("valid case");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    pool.install(|| {
        let mut sim = Simulation::new(&case).expect("builds");
        while sim.time < case.time.end * (1.0 - 1e-12) {
            sim.step().expect("steps");
        }
        // Ω = 1, R₁ = 0.5, R₂ = 1: A = −1/3, B = 1/3
        let exact = |r: Real| if r < 0.5 { r } else { (1.0 / r - r) / 3.0 };
        let (g, vel) = (&sim.grid, &sim.fields[0].state.velocity);
        let (mut gap, mut all) = ((0.0, 0usize), (0.0, 0usize));
        for (lattice, axis) in [(Lattice::XFace, 0), (Lattice::YFace, 1)] {
            let (columns, rows) = g.lattice_shape(lattice);
            for j in 0..rows {
                for i in 0..columns {
                    let p = g.node_position(lattice, i, j);
                    let r = p.norm();
                    if r >= 1.0 {
                        continue;
                    }
                    // the face's component of u_θ e_θ, e_θ = (−y, x)/r
                    let (u, e) = match axis {
                        0 => (vel.u[g.xface(i, j)], -exact(r) * p.y / r),
                        _ => (vel.v[g.yface(i, j)], exact(r) * p.x / r),
                    };
                    let d2 = (u - e) * (u - e);
                    all = (all.0 + d2, all.1 + 1);
                    if r > 0.5 {
                        gap = (gap.0 + d2, gap.1 + 1);
                    }
                }
            }
        }
        let rms = |(s, n): (Real, usize)| (s / n as Real).sqrt();
        (sim.bodies()[0].1.torque, rms(gap), rms(all))
    })
}

/// Circular Couette flow between a disk (R₁ = 0.5) turning at Ω = 1 and a fixed annulus
/// (R₂ = 1), μ = 0.1: the torque per unit length on the disk is −4πμΩR₁²R₂²/(R₂² − R₁²) =
/// −0.41888, the velocity u_θ = Ar + B/r. At t = 4 (16 times the slowest decay time
/// (ΔR)²/(π²ν) = 0.25), on 5, 10 and 20 cells per R₁, measured:
///
/// | cells per R₁ | torque error | RMS error, gap | RMS error, r < R₂ |
/// |---:|---:|---:|---:|
/// | 5 | 1.28e-2 | 1.55e-3 | 1.81e-2 |
/// | 10 | 2.1e-4 | 5.55e-4 | 9.22e-3 |
/// | 20 | 1.47e-3 | 3.74e-4 | 4.66e-3 |
///
/// The velocity converges at first order (0.98 and 0.98 over r < R₂; 1.03 in the gap from 5
/// to 20): the regularised delta function spreads the no-slip over about three cells, so
/// the velocity near the surface is O(h) (Uhlmann 2005; Breugem 2012's retraction of the
/// markers, used here, lowers the constant, not the order). The torque is within 0.2 %
/// from 10 cells on, but without an order: at that level it moves with the markers'
/// placing against the faces (2.1e-4 with the rotor's markers 1.016 h apart at 10 cells,
/// 2.0e-3 with 0.999 h at 13.3; [`couette_from_5_to_40_cells_per_radius`] runs 5 to 40).
#[test]
fn circular_couette_converges_at_first_order_to_the_analytic_flow_and_torque() {
    let exact = -4.0 * std::f64::consts::PI * 0.1 * 0.25 / 0.75;
    let runs: Vec<(Real, Real, Real)> = [24, 48, 96].into_iter().map(couette).collect();
    let order = |a: Real, b: Real| (a / b).log2();
    for (k, &(torque, gap, all)) in runs.iter().enumerate() {
        eprintln!(
            "Couette, {} cells per R₁: torque {torque:.6} against {exact:.6} (relative error {:.3e}), \
             RMS velocity error {gap:.3e} in the gap, {all:.3e} over r < R₂",
            5 << k,
            (torque / exact - 1.0).abs()
        );
    }
    let e: Vec<Real> = runs.iter().map(|r| (r.0 / exact - 1.0).abs()).collect();
    let gap: Vec<Real> = runs.iter().map(|r| r.1).collect();
    let all: Vec<Real> = runs.iter().map(|r| r.2).collect();
    let orders = [order(all[0], all[1]), order(all[1], all[2]), order(gap[0], gap[2]) / 2.0];
    eprintln!(
        "observed orders: {:.3} and {:.3} over r < R₂, {:.3} in the gap from 5 to 20",
        orders[0], orders[1], orders[2]
    );
    assert!(orders.iter().all(|&p| p > 0.9 && p < 1.2), "orders {orders:?}");
    assert!(all[2] < 5e-3 && gap[2] < 4e-4, "velocity errors {all:?} {gap:?}");
    assert!(e[0] < 1.5e-2 && e[1] < 5e-4 && e[2] < 2e-3, "torque errors {e:?}");
}

/// The whole table of docs/validation.md ("Circular Couette flow"): 5 to 40 cells per R₁
/// (about 2 min on one thread; `--ignored` to run it). The gap's velocity error falls at
/// first order from 5 to 40 cells (measured: 1.55e-3 to 1.94e-4, a factor 8.0), and the
/// torque stays within 0.2 % from 10 cells on.
#[test]
#[ignore]
fn couette_from_5_to_40_cells_per_radius() {
    let exact = -4.0 * std::f64::consts::PI * 0.1 * 0.25 / 0.75;
    let mut rows = Vec::new();
    for cells in [24, 48, 64, 72, 96, 128, 192] {
        let (torque, gap, all) = couette(cells);
        let e = (torque / exact - 1.0).abs();
        eprintln!(
            "{:.1} cells per R₁: torque {torque:.6} (error {e:.3e}), RMS {gap:.3e} in the gap, {all:.3e} over r < R₂",
            cells as Real * 0.5 / 2.4
        );
        rows.push((e, gap));
    }
    let order = (rows[0].1 / rows[6].1).log2() / 3.0;
    eprintln!("the gap's order from 5 to 40 cells per R₁: {order:.3}");
    assert!(order > 0.9 && order < 1.2, "order {order}");
    assert!(rows[1..].iter().all(|r| r.0 < 2.5e-3), "torque errors {rows:?}");
}

/// What direct forcing cannot hold is refused before step 0 with the fix: rectangles, an
/// annulus that translates or moves freely, and an Eulerian field of bodies.
#[test]
fn what_direct_forcing_cannot_hold_is_refused() {
    multifield::link_all();
    let refused = |set: &str| {
        let case = Case::load(Path::new(CHANNEL), &[set.to_string()]).expect("valid case");
        Simulation::new(&case).err().expect("refused").to_string()
    };
    let e = refused(
        "fields.cylinder.region=Bodies([(name: \"r\", shape: Rectangle(min: (0.15, 0.15), max: (0.25, 0.25)), motion: Fixed)])",
    );
    assert!(e.contains("a rectangle is not supported; use a Disk or an Annulus, or `no_slip`"), "{e}");
    let annulus = "shape: Annulus(center: (0.2, 0.2), inner_radius: 0.1, outer_radius: 0.3)";
    let e = refused(&format!(
        "fields.cylinder.region=Bodies([(name: \"a\", {annulus}, motion: Prescribed(velocity: (0.1, 0.0)))])"
    ));
    assert!(e.contains("fields.cylinder.region.a.motion") && e.contains("set `velocity: (0, 0)`"), "{e}");
    let e = refused(&format!("fields.cylinder.region=Bodies([(name: \"a\", {annulus})])"));
    assert!(e.contains("fields.cylinder.region.a.motion") && e.contains("an annulus holds a flow"), "{e}");
    let e = refused("fields.cylinder.frame=(model: \"eulerian\")");
    assert!(e.contains("give field `cylinder` a Lagrangian frame"), "{e}");
}

const STREAM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/cylinder_stream.ron");

/// Runs examples/cylinder_stream.ron (D = U = ρ = 1, the cylinder at (15, 20) in a 40 D
/// box) on `cells`² to t = `end` and returns C_D = 2 F_x and the recirculation length L/D:
/// where the centre-line velocity behind the cylinder turns positive, less the radius.
fn stream(cells: usize, end: Real) -> (Real, Real) {
    multifield::link_all();
    let overrides = [format!("domain.cells=({cells}, {cells})"), format!("time.end={end}")];
    let case = Case::load(Path::new(STREAM), &overrides).expect("valid case");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    pool.install(|| {
        let mut sim = Simulation::new(&case).expect("builds");
        while sim.time < end * (1.0 - 1e-12) {
            sim.step().expect("steps");
        }
        let cd = 2.0 * sim.bodies()[0].1.force.x;
        let (g, s) = (&sim.grid, &sim.fields[0].state);
        // y = 20 is a cell edge: the mean of the x-face rows beside it
        let j = (20.0 / g.h).round() as usize;
        let u = |i: usize| 0.5 * (s.velocity.u[g.xface(i, j - 1)] + s.velocity.u[g.xface(i, j)]);
        let mut i = (15.5 / g.h).ceil() as usize;
        while u(i + 1) <= 0.0 {
            i += 1;
        }
        let (x0, x1) = (i as Real * g.h, (i + 1) as Real * g.h);
        let x = x0 - u(i) * (x1 - x0) / (u(i + 1) - u(i));
        (cd, x - 15.5)
    })
}

/// A cylinder in a uniform stream at Re 20 (40 D box, free-slip sides 20 D away), against
/// Dennis & Chang (1970): C_D = 2.045, L/D = 0.94, and Fornberg (1980): 2.000, 0.91.
/// Measured to t = 50 (89 s for both runs): C_D = 2.1678 (+6.0 % of Dennis & Chang) at 4
/// cells per diameter, 2.0943 (+2.4 %) at 8, with L/D = 0.884 (−6.0 % of Dennis & Chang,
/// −2.9 % of Fornberg). With 23 markers on the cylinder at 8 cells per diameter instead of
/// today's even 24, L/D was 0.945 and C_D 2.0958: at this resolution the recirculation
/// length moves by 7 % with the markers' placing at the rear. docs/validation.md has Re 40
/// and 16 cells per diameter.
#[test]
fn cylinder_in_a_uniform_stream_approaches_dennis_and_chang() {
    let (cd4, _) = stream(160, 50.0);
    let (cd8, l8) = stream(320, 50.0);
    let (e4, e8) = (cd4 / 2.045 - 1.0, cd8 / 2.045 - 1.0);
    eprintln!(
        "Re 20: 4 cells per D: C_D = {cd4:.4} ({e4:+.4}); 8: C_D = {cd8:.4} ({e8:+.4}), L/D = {l8:.3} ({:+.4} of \
         Dennis & Chang, {:+.4} of Fornberg)",
        l8 / 0.94 - 1.0,
        l8 / 0.91 - 1.0
    );
    assert!(e8 > 0.0 && e8 < 0.03, "C_D error at 8 cells per D: {e8}");
    assert!(e4 / e8 > 2.2, "the drag's error fell from {e4} to only {e8}");
    assert!((l8 / 0.91 - 1.0).abs() < 0.04 && (l8 / 0.94 - 1.0).abs() < 0.07, "L/D {l8}");
}

/// [`rows_of`] the case `text`.
fn body_rows(text: &str) -> Vec<(Real, Vector, Vector)> {
    multifield::link_all();
    rows_of(&Case::from_ron(text, Path::new("case.ron")).expect("valid case"))
}

/// A disk of diameter 0.5 in a periodic 4 × 4 box (ν = 0.01, Re = UD/ν = 50): moving at
/// (0, −1) through fluid at rest, and held fixed in a stream of (0, 1). Galilean invariance
/// makes their drags equal; the grid and its advection are not Galilean invariant, so they
/// differ by a discretisation error, which must fall with the grid. Measured, the mean
/// over 1 ≤ t ≤ 1.2: 0.4175 (held) against 0.4287 (moving), +2.68 %, at 8 cells per
/// diameter; 0.4167 against 0.4190, +0.57 %, at 16. The moving disk's force rings by
/// ±1–2 % as it crosses the cells; its last, shortened step stays inside that band.
/// (Before the marker forces were carried with the body, the lagged face force left
/// behind a moving disk reversed its drag: −10.6 against +21.6 at Re 500.)
#[test]
fn a_translating_disk_feels_the_drag_of_the_same_disk_held_in_a_stream() {
    let case = |cells: usize, moving: bool| {
        let (velocity, center, motion) = if moving {
            ("(0.0, 0.0)", "(2.0, 3.2)", "Prescribed(velocity: (0.0, -1.0), angular_velocity: 0.0)")
        } else {
            ("(0.0, 1.0)", "(2.0, 2.0)", "Fixed")
        };
        format!(
            r#"(
            name: "galilean",
            domain: (size: (4.0, 4.0), cells: ({cells}, {cells})),
            boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
            time: (end: 1.2, cfl: 0.4, max_dt: 0.05),
            fields: [
                (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
                 velocity: Uniform({velocity}), stress: [(model: "newtonian", params: (viscosity: 0.01))]),
                (name: "disk", density: 1.5, frame: (model: "lagrangian"), stress: [(model: "rigid")],
                 region: Bodies([(name: "disk", shape: Disk(center: {center}, radius: 0.25), motion: {motion})])),
            ],
            exchange: [(between: ("water", "disk"), model: "direct_forcing")],
            pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-10))),
        )"#
        )
    };
    let mut gaps = Vec::new();
    for cells in [64, 128] {
        let fixed = body_rows(&case(cells, false));
        let moving = body_rows(&case(cells, true));
        // the mean over t ≥ 1 (the moving disk's force rings with its crossing of the cells)
        let mean = |rows: &[(Real, Vector, Vector)]| {
            let late: Vec<Real> = rows.iter().filter(|r| r.0 >= 1.0).map(|r| r.2.y).collect();
            late.iter().sum::<Real>() / late.len() as Real
        };
        let (f, m) = (mean(&fixed), mean(&moving));
        let gap = m / f - 1.0;
        // the last, shortened step reports a force like the steps before it
        let (last, recent) = (moving.last().unwrap().2.y, &moving[moving.len() - 7..moving.len() - 1]);
        let (lo, hi) = recent.iter().fold((Real::INFINITY, -Real::INFINITY), |(a, b), r| (a.min(r.2.y), b.max(r.2.y)));
        eprintln!(
            "{} cells per D: drag held {f:.4}, moving {m:.4} ({:+.2} %); the last step's {last:.4}, the 6 before in \
             [{lo:.4}, {hi:.4}]",
            cells / 8,
            100.0 * gap
        );
        assert!(f > 0.0 && m > 0.0, "both drags oppose the relative motion");
        assert!(last > lo * 0.995 && last < hi * 1.005, "the last step's drag {last} against [{lo}, {hi}]");
        gaps.push(gap.abs());
    }
    assert!(gaps[0] < 0.05 && gaps[1] < 0.01 && gaps[1] < 0.35 * gaps[0], "moving against held: {gaps:?}");
}

/// examples/settling_disk.ron: a disk (d = 0.25, ρ_b/ρ_f = 1.5) settling from rest in a
/// closed 8 d × 24 d channel (ν = 0.1, g = 981: Re ≈ 22 at its speed of 8.9), free under
/// direct forcing: its speed at
/// t = 0.4 (within 0.3 % of terminal) on 4, 8 and 16 cells per diameter converges
/// monotonically. Measured: 8.8939, 8.9090, 8.9182 (differences 0.0151 and 0.0092: observed
/// order 0.71); at 32 cells per diameter (855 s, docs/validation.md) 8.9160, a difference
/// of −0.0022: the convergence turns oscillatory, and the speed is 8.917 ± 0.002. The disk
/// stays on the axis to 1e-12 (its markers are symmetric).
#[test]
fn a_free_disk_settles_to_a_speed_that_converges_with_the_grid() {
    multifield::link_all();
    let mut speeds = Vec::new();
    for n in [4, 8, 16] {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/settling_disk.ron");
        let case = Case::load(&file, &[format!("domain.cells=({}, {})", 8 * n, 24 * n)]).expect("valid case");
        let rows = rows_of(&case);
        let (_, v, f) = *rows.last().unwrap();
        eprintln!("{n} cells per diameter: v = {v:?} at t = 0.4, hydrodynamic force {f:?}");
        assert!(v.x.abs() < 1e-9, "the disk left the axis: {v:?}");
        speeds.push(-v.y);
    }
    let (d1, d2) = (speeds[1] - speeds[0], speeds[2] - speeds[1]);
    let order = (d1 / d2).log2();
    eprintln!("speeds {speeds:?}, differences {d1:.4e} {d2:.4e}, observed order {order:.2}");
    assert!(d1 > 0.0 && d2 > 0.0 && order > 0.5, "speeds {speeds:?}: order {order}");
    // within 0.05 % of the 32-cells-per-diameter run's 8.9160
    assert!((speeds[2] / 8.9160 - 1.0).abs() < 5e-4, "{speeds:?}");
}

/// Three disks (d = 0.1, ρ_b/ρ_f = 1.1, 4 cells per diameter) settling into a pyramid on
/// the floor of a closed 0.4 × 0.4 box of water: two side by side 0.001 apart, the third
/// resting on both. Their markers lie within one kernel support of each other's (issue 15:
/// the fluidized bed's `direct_forcing` blow-up in miniature). Runs `overrides` to t = 1
/// and returns the largest kinetic energy of a step and the potential energy the disks can
/// release, Σ (ρ_b − ρ_f) V g (y₀ − R): with the fluid and the disks at rest at
/// the start and the walls doing no work, the kinetic energy can never exceed it.
fn pyramid(overrides: &[&str]) -> (Real, Real) {
    multifield::link_all();
    let text = r#"(
        name: "pyramid",
        domain: (size: (0.4, 0.4), cells: (16, 16)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, -981.0),
        time: (end: 1.0, cfl: 0.4, max_dt: 0.01, contact_substeps: true),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian", params: (diffusion: "explicit")),
             region: Rest, stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            (name: "disks", density: 1.1, frame: (model: "lagrangian", params: (points_per_cell: 2)),
             region: Bodies([
                (name: "a", shape: Disk(center: (0.149, 0.06), radius: 0.05)),
                (name: "b", shape: Disk(center: (0.25, 0.06), radius: 0.05)),
                (name: "c", shape: Disk(center: (0.2, 0.148), radius: 0.05)),
             ]),
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("water", "disks"), model: "direct_forcing")],
        contact: Some((model: "dem", params: (restitution: 0.5, collision_time: 0.01, friction: 0.1))),
        pressure: Some((model: "pcg", params: (tolerance: 1e-8))),
    )"#;
    static RUNS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let run = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("mf_pyramid_{}_{run}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let file = dir.join("pyramid.ron");
    std::fs::write(&file, text).expect("writes the case");
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let case = Case::load(&file, &overrides).expect("valid case");
    std::fs::remove_dir_all(&dir).expect("removes the temporary directory");
    let excess = case.fields[1].density - case.fields[0].density;
    let released: Real =
        [0.06, 0.06, 0.148].iter().map(|y| excess * std::f64::consts::PI * 0.05 * 0.05 * 981.0 * (y - 0.05)).sum();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let peak = pool.install(|| {
        let mut sim = Simulation::new(&case).expect("builds");
        let mut peak: Real = 0.0;
        while sim.time < case.time.end * (1.0 - 1e-12) {
            let d = sim.step().expect("steps");
            // a blow-up: stop before the step shrinks to nothing (it takes ~1e-6 s then)
            peak = peak.max(d.kinetic_energy);
            if peak > 1e3 * released || peak.is_nan() {
                break;
            }
        }
        peak
    });
    (peak, released)
}

/// The pyramid's energy stays below what the disks can release, under `no_slip`, and under
/// `direct_forcing` exact and with sweeps, at 4 and 8 cells per diameter, and with the disks
/// twice as heavy. Before the touching bodies were solved together (issue 15) the exact
/// forcing at 4 cells per diameter blew up at t ≈ 0.47 s, passing 1.4e3 against 0.091
/// released (at ρs/ρf = 2 at t ≈ 0.29 s), while `no_slip`, the sweeps and 8 cells per
/// diameter held.
#[test]
fn touching_disks_keep_their_energy_under_direct_forcing() {
    for overrides in [
        &[][..],
        &["fields.disks.density=2.0"][..],
        &["domain.cells=(32, 32)"][..],
        &["exchange.0.params=(forcing: \"sweeps\")"][..],
        &["exchange.0.model=\"no_slip\""][..],
    ] {
        let (peak, released) = pyramid(overrides);
        eprintln!("{overrides:?}: peak kinetic energy {peak:e} of {released:e} released");
        assert!(peak < released, "{overrides:?}: kinetic energy {peak:e} against {released:e} released");
    }
}
