//! Open sides: a parabolic inflow (`Velocity` with a `Parabolic` profile) and an outflow at a
//! fixed pressure (`Outflow(pressure: …)`), verified on an Eulerian channel against plane
//! Poiseuille flow; and the Lagrangian frame's refusal of open sides, which it cannot feed
//! or drain of points.

use multifield_core::case::Case;
use multifield_core::grid::Lattice;
use multifield_core::math::Real;
use multifield_core::simulation::Simulation;
use multifield_frames::eulerian::Eulerian;
use std::path::Path;
use std::time::Instant;

fn link() {
    multifield_frames::link();
    multifield_physics::link();
}

/// The channel `[0, 4H] × [0, H]` as a case file: a parabolic inflow of centre-line speed
/// `uc` on the left, an outflow at pressure `p_out` on the right, no-slip walls at the bottom
/// and top, one field with frame `frame` (RON) and dynamic viscosity `mu`.
fn channel(cells: [usize; 2], height: Real, uc: Real, p_out: Real, mu: Real, end: Real, frame: &str) -> Case {
    let [nx, ny] = cells;
    let length = 4.0 * height;
    let text = format!(
        r#"(
        name: "inflow_outflow",
        domain: (size: ({length:?}, {height:?}), cells: ({nx}, {ny})),
        boundaries: (
            left: Velocity(velocity: ({uc:?}, 0.0), profile: Parabolic),
            right: Outflow(pressure: {p_out:?}),
            bottom: NoSlip,
            top: NoSlip,
        ),
        time: (end: {end:?}, cfl: 0.4, max_dt: 1.0),
        fields: [(
            name: "fluid", density: 1.0, frame: {frame}, region: All,
            stress: [(model: "newtonian", params: (viscosity: {mu:?}))],
        )],
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-12))),
    )"#
    );
    Case::from_ron(&text, Path::new("inflow_outflow.ron")).expect("channel case")
}

fn eulerian(sim: &Simulation) -> &Eulerian {
    sim.fields[0].frame.as_any().downcast_ref::<Eulerian>().expect("an Eulerian field")
}

/// What a steady channel run measured.
#[derive(Debug)]
struct Channel {
    /// max |u − 4U_c y(H − y)/H²| / U_c over the x-faces of the last quarter (outflow included).
    velocity: Real,
    /// max |v| / U_c over the y-faces of the last quarter.
    cross_flow: Real,
    /// max |u − 4U_c y(H − y)/H²| / U_c on the inflow faces.
    inflow: Real,
    /// |Q_out − Q_in| / Q_in, the volume fluxes through the two open sides.
    mass: Real,
    /// |dp/dx + 12 μ U_mean/H²| / (12 μ U_mean/H²), dp/dx fitted over x ≥ L/2.
    gradient: Real,
    /// |p(L) − p_out| / (12 μ U_mean L/H²), p(L) from the same fit.
    outlet_pressure: Real,
    steps: u64,
    seconds: f64,
}

/// Runs the channel on `cells` (4:1) to steady state and measures it against plane
/// Poiseuille flow: `u(y) = 4 U_c y (H − y)/H²`, v = 0, `dp/dx = −12 μ U_mean/H²` with
/// U_mean = 2U_c/3, p = p_out at x = L.
fn poiseuille_channel(cells: [usize; 2]) -> Channel {
    link();
    // Re = ρ U_mean H/μ = 10: an entrance length of about 1.2 H, developed well before 3H.
    let (height, uc, p_out, mu) = (1.0, 1.5, 2.0, 0.1);
    let (length, u_mean) = (4.0 * height, 2.0 * uc / 3.0);
    // Starting from rest the flux is right after the first projection; what develops is a
    // profile of zero net flux, symmetric about the centre line, whose slowest mode decays as
    // e^(−80.8 μt/(ρH²)) (k H/2 = tan(k H/2), k = 8.99/H). Measured on 32 × 8: the largest
    // change of u in a step falls below 1e-10 U_c by t ≈ 0.3 ρH²/μ; run to ρH²/μ.
    let end = height * height / mu;
    let case = channel(cells, height, uc, p_out, mu, end, r#"(model: "eulerian")"#);
    let start = Instant::now();
    let mut sim = Simulation::new(&case).expect("valid case");
    while sim.time < end * (1.0 - 1e-12) {
        sim.step().expect("step");
    }
    let seconds = start.elapsed().as_secs_f64();
    let g = &sim.grid;
    let vel = eulerian(&sim).velocity();
    let (nx, ny, h) = (g.nx, g.ny, g.h);
    let parabola = |y: Real| 4.0 * uc * y * (height - y) / (height * height);
    let u_err = |i: usize, j: usize| (vel.u[g.xface(i, j)] - parabola(g.node_position(Lattice::XFace, i, j).y)).abs();

    let outlet = 3 * nx / 4;
    let velocity =
        (outlet..=nx).flat_map(|i| (0..ny).map(move |j| (i, j))).map(|(i, j)| u_err(i, j)).fold(0.0, Real::max);
    let cross_flow = (outlet..nx)
        .flat_map(|i| (0..=ny).map(move |j| (i, j)))
        .map(|(i, j)| vel.v[g.yface(i, j)].abs())
        .fold(0.0, Real::max);
    let inflow = (0..ny).map(|j| u_err(0, j)).fold(0.0, Real::max);
    let q_in: Real = (0..ny).map(|j| vel.u[g.xface(0, j)] * h).sum();
    let q_out: Real = (0..ny).map(|j| vel.u[g.xface(nx, j)] * h).sum();

    // least-squares line p = a + b x through the cell pressures of every row with x ≥ L/2
    let (mut sx, mut sp, mut sxx, mut sxp, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in nx / 2..nx {
        for j in 0..ny {
            let (x, p) = (g.node_position(Lattice::Cell, i, j).x, sim.pressure[g.cell(i, j)]);
            (sx, sp, sxx, sxp, n) = (sx + x, sp + p, sxx + x * x, sxp + x * p, n + 1.0);
        }
    }
    let slope = (n * sxp - sx * sp) / (n * sxx - sx * sx);
    let p_at_outlet = (sp - slope * sx) / n + slope * length;
    let dpdx = -12.0 * mu * u_mean / (height * height);

    let m = Channel {
        velocity: velocity / uc,
        cross_flow: cross_flow / uc,
        inflow: inflow / uc,
        mass: ((q_out - q_in) / q_in).abs(),
        gradient: ((slope - dpdx) / dpdx).abs(),
        outlet_pressure: (p_at_outlet - p_out).abs() / (-dpdx * length),
        steps: sim.steps,
        seconds,
    };
    eprintln!(
        "channel {nx}×{ny}, {} steps, {seconds:.2} s: outlet |u − parabola| {:.3e} U_c, |v| {:.1e} U_c, \
         inflow faces {:.1e} U_c; flux in {q_in:.12} out {q_out:.12} (relative {:.1e}); \
         dp/dx {slope:.6} vs {dpdx:.6} (relative {:.3e}); p(L) − p_out {:.1e} of the drop",
        m.steps, m.velocity, m.cross_flow, m.inflow, m.mass, m.gradient, m.outlet_pressure
    );
    m
}

/// Plane Poiseuille flow fed through the side: parabolic inflow, outflow at a fixed pressure,
/// no-slip walls, on 32 × 8 and 48 × 12 cells (0.1 s and 0.3 s in the test profile).
///
/// The errors are the scheme's, not of an unfinished transient: the wall ghost `−u` makes the
/// discrete developed profile `u_j = A (y_j (H − y_j) + h²/4)`, and its flux, equal to the
/// inflow's (the parabola sampled at face centres, `U_mean H (1 + h²/(2H²))`), gives
/// `A = (4U_c/H²)(1 + h²/(2H²))/(1 + 2h²/H²)` and `dp/dx = −2μA`: a gradient low by
/// `1.5 (h/H)² / (1 + 2 (h/H)²)` = 2.273e-2 at 8 cells across and 1.027e-2 at 12, and a
/// velocity off by 9.94e-3 U_c and 5.23e-3 U_c at the rows next to the walls, as measured.
#[test]
fn parabolic_inflow_and_outflow_give_plane_poiseuille_flow() {
    let coarse = poiseuille_channel([32, 8]);
    let fine = poiseuille_channel([48, 12]);
    for (m, velocity, gradient) in [(&coarse, 1.5e-2, 3.5e-2), (&fine, 8e-3, 1.6e-2)] {
        // the inflow faces carry the parabola exactly
        assert!(m.inflow < 1e-14, "inflow faces off the parabola by {:.1e} U_c", m.inflow);
        // measured 9.94e-3 (32 × 8) and 5.23e-3 (48 × 12) of U_c
        assert!(m.velocity < velocity, "outlet profile off the parabola by {:.3e} U_c: {m:?}", m.velocity);
        // measured 7.9e-10 and 1.6e-10 of U_c: the pressure solve's tolerance
        assert!(m.cross_flow < 1e-8, "cross-flow {:.1e} U_c at the outlet: {m:?}", m.cross_flow);
        // measured 2.2e-16 and 3.5e-12 (the last, shortened step's solve)
        assert!(m.mass < 1e-10, "outflux differs from influx by {:.1e}: {m:?}", m.mass);
        // measured 2.273e-2 and 1.027e-2 (the formula above)
        assert!(m.gradient < gradient, "dp/dx off by {:.3e}: {m:?}", m.gradient);
        // measured 1.4e-8 and 4.2e-9 of the drop over L
        assert!(m.outlet_pressure < 1e-6, "p(L) off p_out by {:.1e} of the drop: {m:?}", m.outlet_pressure);
    }
    // second order: measured 1.96 (the velocity's 1.58 is still short of its asymptotic 2:
    // by the formula above, next to the walls its h³ part is 3h/H of its h² part, 0.38 at 8 cells)
    let order = (coarse.gradient / fine.gradient).ln() / 1.5_f64.ln();
    assert!(order > 1.8, "dp/dx converges at order {order:.2}: {coarse:?} {fine:?}");
    eprintln!(
        "steps {} and {}, {:.2} s and {:.2} s; dp/dx order {order:.2}",
        coarse.steps, fine.steps, coarse.seconds, fine.seconds
    );
}

/// A Lagrangian continuum cannot face an inflow or an outflow (no points are created or
/// removed there): the case is refused before step 0 with the side and the fix (fields of
/// bodies: `bodies_at_open_sides.rs`).
#[test]
fn a_lagrangian_field_refuses_open_sides() {
    link();
    let frame = r#"(model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "flip"))"#;
    let case = channel([16, 4], 1.0, 1.5, 0.0, 0.1, 1.0, frame);
    let e = Simulation::new(&case).err().expect("an inflow and an outflow are refused").to_string();
    assert_eq!(
        e,
        "<case>: fields.fluid: side `left` is an inflow (Velocity with a normal component): a Lagrangian field \
         cannot create points at an inflow or remove them at an outflow yet; give this field an Eulerian frame \
         (`frame: (model: \"eulerian\")`), or make the side a wall (NoSlip, FreeSlip, or Velocity with a \
         tangential component only)"
    );
    let mut walled = case.clone();
    walled.boundaries.left = multifield_core::boundary::Boundary::NoSlip;
    let e = Simulation::new(&walled).err().expect("an outflow is refused").to_string();
    assert!(e.starts_with("<case>: fields.fluid: side `right` is an outflow (Outflow): "), "{e}");
    // a moving wall stays allowed
    walled.boundaries.right = multifield_core::boundary::Boundary::NoSlip;
    walled.boundaries.top =
        multifield_core::boundary::Boundary::Velocity { velocity: [1.0, 0.0], profile: Default::default() };
    Simulation::new(&walled).expect("a moving lid is a wall");
}

/// `velocity: FromInflow` starts the channel of [`poiseuille_channel`] (32 × 8) with the
/// inflow's parabola on every face: the flow is developed from step 0. After 3 steps the
/// velocity is still the parabola up to the scheme's own developed profile (the wall ghost's
/// h² error of the test above, 9.94e-3 U_c at the rows next to the walls, towards which it
/// relaxes), where a uniform start of the same flux is still a third of U_c off.
#[test]
fn a_channel_started_from_its_inflow_is_steady_from_step_0() {
    use multifield_core::case::InitialVelocity;
    link();
    let (height, uc, mu) = (1.0, 1.5, 0.1);
    let parabola = |y: Real| 4.0 * uc * y * (height - y) / (height * height);
    // (largest |u − parabola| / U_c at step 0, after 3 steps; largest |v| / U_c after 3 steps)
    let run = |velocity: InitialVelocity| {
        let mut case = channel([32, 8], height, uc, 0.0, mu, 1.0, r#"(model: "eulerian")"#);
        case.fields[0].velocity = velocity;
        let mut sim = Simulation::new(&case).expect("valid case");
        let off = |sim: &Simulation| {
            let (g, vel) = (&sim.grid, eulerian(sim).velocity());
            let mut worst: Real = 0.0;
            for j in 0..g.ny {
                for i in 0..=g.nx {
                    let y = g.node_position(Lattice::XFace, i, j).y;
                    worst = worst.max((vel.u[g.xface(i, j)] - parabola(y)).abs() / uc);
                }
            }
            worst
        };
        let start = off(&sim);
        for _ in 0..3 {
            sim.step().expect("step");
        }
        let (g, vel) = (&sim.grid, eulerian(&sim).velocity());
        let cross = (0..g.n_yfaces()).map(|f| vel.v[f].abs() / uc).fold(0.0, Real::max);
        (start, off(&sim), cross, sim.time)
    };
    let (start, after, cross, t) = run(InitialVelocity::FromInflow);
    let (uniform_start, uniform_after, _, _) = run(InitialVelocity::Uniform([uc * 2.0 / 3.0, 0.0]));
    eprintln!(
        "FromInflow: |u − parabola| {start:.2e} U_c at step 0, {after:.3e} U_c after 3 steps (t = {t:.4}), \
         |v| {cross:.1e} U_c; uniform start: {uniform_start:.3} and {uniform_after:.3} U_c"
    );
    // the parabola sampled at the faces, to round-off
    assert!(start < 1e-15, "step 0 off the parabola by {start:e} U_c");
    // within the scheme's developed profile's 9.94e-3 U_c of the parabola (measured 8.44e-3;
    // the uniform start 0.163 U_c, the cross-flow 3.3e-3 U_c)
    assert!(after < 9.94e-3, "after 3 steps off the parabola by {after:e} U_c");
    assert!(cross < 1e-2, "cross-flow {cross:e} U_c");
    assert!(uniform_after > 10.0 * after, "the uniform start is only {uniform_after:e} U_c off");
}
