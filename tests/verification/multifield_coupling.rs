//! Multifield coupling (docs/method.md §2–4, §6): the tests that expose where such methods fail.
//!
//! - Exchange: two interpenetrating fields in a periodic box with a constant K relax as
//!   slip(t) = slip(0) e^(−t/τ), τ = 1/(θ_aθ_b K (1/ρ_a + 1/ρ_b)); the implicit solve is
//!   stable at Δt = 10τ and conserves momentum to round-off; explicit exchange there blows up.
//! - Σθ and spurious currents: a neutrally buoyant rigid disk at rest in a closed box under
//!   gravity stays at rest.
//! - Added mass: a rigid disk released from rest at ρs/ρf = 1.01 starts with the
//!   acceleration (ρs − ρf) g / (ρs + ρf), because its inertia is inside the pressure solve.

use multifield::run::{run, RunOptions};
use multifield_core::case::Case;
use multifield_core::math::{Real, Vector};
use multifield_core::simulation::{Simulation, Status};
use std::path::Path;

fn two_field_box(k: Real, dt: Real, steps: usize, integration: &str) -> Case {
    let text = format!(
        r#"(
        name: "exchange_box", domain: (size: (1.0, 1.0), cells: (8, 8)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: {end}, max_dt: {dt}, fixed_dt: Some({dt})),
        fields: [
            (name: "a", density: 1.0, frame: (model: "eulerian"), region: All, volume_fraction: 0.5,
             velocity: Uniform((1.0, 0.5))),
            (name: "b", density: 2.0, frame: (model: "eulerian"), region: Rest, velocity: Uniform((-1.0, 0.0))),
        ],
        exchange: [(between: ("a", "b"), model: "constant", params: (coefficient: {k}), integration: {integration})],
        pressure: Some((model: "pcg", params: (tolerance: 1e-12))),
    )"#,
        end = dt * steps as Real
    );
    Case::from_ron(&text, Path::new("exchange_box.ron")).unwrap()
}

/// Mean x velocity of a field over its x-faces.
fn mean_u(sim: &Simulation, field: usize) -> Real {
    let u = &sim.fields[field].state.velocity.u;
    let g = &sim.grid;
    (0..g.ny).flat_map(|j| (0..g.nx).map(move |i| (i, j))).map(|(i, j)| u[g.xface(i, j)]).sum::<Real>()
        / (g.nx * g.ny) as Real
}

#[test]
fn exchange_slip_decays_exponentially_and_implicit_is_stable_beyond_tau() {
    multifield::link_all();
    // bulk densities ρa = 0.5, ρb = 1.0, θaθb = 0.25: τ = 1 / (0.25 K · 3) = 1 for K = 4/3
    let k = 4.0 / 3.0;
    let tau = 1.0;
    // accuracy: Δt = τ/200 follows e^(−t/τ) within 1 % of the initial slip at t = τ and 2τ
    let case = two_field_box(k, tau / 200.0, 400, "Implicit");
    let mut sim = Simulation::new(&case).unwrap();
    let p0 = sim.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
    let mut worst: Real = 0.0;
    for step in 1..=400 {
        sim.step().unwrap();
        let slip = mean_u(&sim, 0) - mean_u(&sim, 1);
        if step % 200 == 0 {
            let exact = 2.0 * (-sim.time / tau).exp();
            worst = worst.max((slip - exact).abs() / 2.0);
        }
    }
    assert!(worst < 0.01, "slip off e^(-t/τ) by {worst:.4} of the initial slip");
    let p1 = sim.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
    assert!((p1 - p0).norm() / p0.norm() < 1e-12, "momentum drift {:e}", (p1 - p0).norm() / p0.norm());

    // stability: Δt = 10τ, implicit: each step multiplies the slip by 1/(1 + Δt/τ) exactly
    let case = two_field_box(k, 10.0 * tau, 3, "Implicit");
    let mut sim = Simulation::new(&case).unwrap();
    let mut slip = 2.0;
    for _ in 0..3 {
        sim.step().unwrap();
        let s = mean_u(&sim, 0) - mean_u(&sim, 1);
        assert!((s - slip / 11.0).abs() < 1e-12, "implicit factor: {s} vs {}", slip / 11.0);
        assert!(s > 0.0, "implicit exchange overshoots");
        slip = s;
    }
    let p1 = sim.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
    assert!((p1 - p0).norm() / p0.norm() < 1e-12);

    // explicit at Δt = 10τ: the slip is multiplied by 1 − Δt/τ = −9 per step: the run says unstable
    let case = two_field_box(k, 10.0 * tau, 20, "Explicit");
    let dir = std::env::temp_dir().join(format!("mf_explicit_{}", std::process::id()));
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert!(matches!(out.status, Status::Unstable(_)), "explicit exchange at Δt = 10τ not detected: {:?}", out.status);
    assert!(out.summary.steps < 20);
    let _ = std::fs::remove_dir_all(dir);
}

fn disk_in_box(rho_s: Real, cells: usize, end: Real) -> Case {
    let text = format!(
        r#"(
        name: "disk_in_box", domain: (size: (2.0, 2.0), cells: ({cells}, {cells})),
        gravity: (0.0, -981.0),
        time: (end: {end}, cfl: 0.4, max_dt: 1e-3),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            (name: "disk", density: {rho_s},
             frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "pic")),
             region: Bodies([(name: "disk", shape: Disk(center: (1.0, 1.0), radius: 0.1))]),
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("water", "disk"), model: "no_slip")],
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-12))),
    )"#
    );
    Case::from_ron(&text, Path::new("disk_in_box.ron")).unwrap()
}

/// A neutrally buoyant rigid disk at rest in a closed box under gravity: the mixture
/// density is uniform (Σθ = 1 exactly, face densities from the same θ), so the pressure
/// is exactly hydrostatic and nothing may move. The bound 1e-9 √(gL) is a few orders
/// above the pressure tolerance (1e-12 relative) times g Δt.
#[test]
fn neutrally_buoyant_disk_stays_at_rest() {
    multifield::link_all();
    let case = disk_in_box(1.0, 40, 0.2);
    let mut sim = Simulation::new(&case).unwrap();
    let scale = (981.0_f64 * 2.0).sqrt();
    let (mut first, mut second) = (0.0_f64, 0.0_f64);
    let mut steps = 0;
    while sim.time < case.time.end - 1e-12 {
        let d = sim.step().unwrap();
        steps += 1;
        if sim.time < 0.1 {
            first = first.max(d.max_speed);
        } else {
            second = second.max(d.max_speed);
        }
        assert!(d.volume_fraction_error < 1e-12, "Σθ − 1 = {:e}", d.volume_fraction_error);
    }
    println!("{steps} steps; max speed/√(gL): {:e} then {:e}", first / scale, second / scale);
    assert!(second < 1e-9 * scale, "spurious current {second:e}");
    assert!(second <= 10.0 * first + 1e-12 * scale, "speed grows: {first:e} -> {second:e}");
    let body = &sim.bodies()[0].1;
    assert!((body.position - Vector::new(1.0, 1.0)).norm() < 1e-9);
}

/// Added mass: released from rest at ρs/ρf = 1.01, the disk's first-step acceleration is
/// (ρs − ρf) g / (ρs + ρf) = 4.88 cm/s² (C_A = 1 for a 2D disk), not (ρs − ρf) g / ρs = 9.71.
/// The smeared interface adds effective mass (the hydrodynamic radius is a little larger
/// than the geometric one), so the error falls as the grid is refined: assert 10 % at 16
/// cells per diameter and that 8 → 16 cells per diameter gets closer.
#[test]
fn released_disk_accelerates_with_its_added_mass() {
    multifield::link_all();
    let expected = 0.01 * 981.0 / 2.01;
    let accel = |cells: usize| {
        let case = disk_in_box(1.01, cells, 1e-3);
        let mut sim = Simulation::new(&case).unwrap();
        let d = sim.step().unwrap();
        -sim.bodies()[0].1.velocity.y / d.dt
    };
    let (coarse, fine) = (accel(80), accel(160));
    println!(
        "acceleration {coarse:.4} (8 cells/d), {fine:.4} (16 cells/d) cm/s²; expected {expected:.4}, without added mass {:.4}",
        0.01 * 981.0 / 1.01
    );
    assert!((fine - expected).abs() / expected < 0.10, "a = {fine}, expected {expected}");
    assert!((fine - expected).abs() < (coarse - expected).abs(), "no convergence: {coarse} -> {fine}");
}
