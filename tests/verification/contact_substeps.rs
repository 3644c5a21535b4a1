//! Contact in sub-steps inside a fluid step (`time.contact_substeps`, docs/method.md §5):
//! a large step with sub-steps follows the contact-limited run where one without fails,
//! momentum is conserved through a sub-stepped collision, a settling pack takes its Δt
//! from the flow, and restarts and thread counts change no bit.

use multifield_core::case::Case;
use multifield_core::math::{Real, Vector};
use multifield_core::simulation::Simulation;
use std::path::Path;

const G: Real = 981.0;

/// A dry box (no fluid: the bodies' field alone, on 16 × 16 cells of 1/16), gravity
/// `g`, the repulsion with `contact_params`, bodies `bodies` (RON), fixed step `dt`.
fn dry_box(bodies: &str, g: Real, contact_params: &str, dt: Real, substeps: bool) -> Case {
    let text = format!(
        r#"(
        name: "dry_box", domain: (size: (1.0, 1.0), cells: (16, 16)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, -{g}),
        time: (end: 1.0, max_dt: {dt}, fixed_dt: Some({dt}), contact_substeps: {substeps}),
        fields: [
            (name: "disks", density: 2.0, frame: (model: "lagrangian"),
             region: Bodies([{bodies}]), representation: MassPoint),
        ],
        contact: Some((model: "repulsion", params: ({contact_params}))),
    )"#
    );
    Case::from_ron(&text, Path::new("dry_box.ron")).unwrap()
}

/// The run of `case` to `t_end` in steps of `dt`: the body's (y, v_y) at every multiple
/// of `every` steps.
fn drop_trajectory(case: &Case, steps: usize, every: usize) -> Vec<(Real, Real)> {
    let mut sim = Simulation::new(case).unwrap();
    let mut out = Vec::new();
    for k in 1..=steps {
        let d = sim.step().unwrap();
        assert!(!d.dt_limit.starts_with("contact"), "step {k} limited by {}", d.dt_limit);
        if k % every == 0 {
            let b = &sim.bodies()[0].1;
            out.push((b.position.y, b.velocity.y));
        }
    }
    out
}

#[test]
fn a_disk_dropped_on_a_wall_rebounds_as_with_the_contact_limited_step() {
    multifield::link_all();
    // d = 0.1 dropped from y = 0.3: it reaches the wall's range (y = R + ρ/2 = 0.0625) at
    // 22 cm/s; the repulsion (ρ = 0.025, ε = 1e-2, c = Mg) limits the step to
    // 0.1 sqrt(M/k) = 3.57e-5, k = 2Mg/(ερ). Reference: Δt = 1e-5; large step: 1e-3 = 28×
    // the contact limit, with and without sub-steps, to t = 0.04 (bounce at t ≈ 0.023)
    let body = "(name: \"d\", shape: Disk(center: (0.5, 0.3), radius: 0.05))";
    let params = "";
    let limit = 0.1 * (0.025 * 1e-2 / (2.0 * G)).sqrt();
    let (fine, large) = (1e-5, 1e-3);
    assert!(large / limit > 25.0);
    let reference = drop_trajectory(&dry_box(body, G, params, fine, false), 4000, 100);
    let sub = drop_trajectory(&dry_box(body, G, params, large, true), 40, 1);
    let plain = drop_trajectory(&dry_box(body, G, params, large, false), 40, 1);
    let err = |run: &[(Real, Real)]| {
        let (mut ey, mut ev): (Real, Real) = (0.0, 0.0);
        for (a, b) in run.iter().zip(&reference) {
            ey = ey.max((a.0 - b.0).abs());
            ev = ev.max((a.1 - b.1).abs());
        }
        (ey, ev)
    };
    let v_impact = (2.0 * G * 0.2375).sqrt();
    let ((ey_sub, ev_sub), (ey_plain, ev_plain)) = (err(&sub), err(&plain));
    let top = |run: &[(Real, Real)]| run.iter().map(|s| s.1).fold(Real::NEG_INFINITY, Real::max);
    let rebound = top(&reference);
    eprintln!(
        "contact limit {limit:.3e}; impact speed {v_impact:.4}, largest rebound speed: reference {rebound:.4}, \
         sub-steps {:.4}, none {:.4}; max |Δy| sub-steps {ey_sub:.2e} (none {ey_plain:.2e}), max |Δv_y|/v_impact \
         sub-steps {:.2e} (none {:.2e})",
        top(&sub),
        top(&plain),
        ev_sub / v_impact,
        ev_plain / v_impact,
    );
    // the bounce happened: the (elastic) repulsion returns the impact speed, less the
    // gravity of the half millisecond after the contact at which the first sample falls
    assert!((rebound / v_impact - 1.0).abs() < 0.05, "reference rebound {rebound}");
    // with sub-steps: within 0.2 % of the impact speed and 0.5 % of d along the whole path
    // (δt = 3.6e-5 against the reference's 1e-5: first order, measured 0.1 % and 0.27 % of d)
    assert!(ev_sub < 0.002 * v_impact, "sub-steps: velocity off by {ev_sub}");
    assert!(ey_sub < 0.0005, "sub-steps: position off by {ey_sub}");
    // without: off by more than the impact speed, and by half the drop height
    assert!(ev_plain > v_impact && ey_plain > 0.1, "no sub-steps: off by only {ev_plain}, {ey_plain}");
}

#[test]
fn momentum_is_conserved_through_a_substepped_collision() {
    multifield::link_all();
    // two free disks of masses 1 : 2.25 head-on at 20 and −10 cm/s, no gravity, no fluid;
    // steps of 2e-3 against a contact limit ≈ 1.6e-4: sub-steps in every step
    let bodies = "(name: \"a\", shape: Disk(center: (0.3, 0.5), radius: 0.05), velocity: (20.0, 0.0)),\
                  (name: \"b\", shape: Disk(center: (0.7, 0.52), radius: 0.075), velocity: (-10.0, 0.0))";
    let case = dry_box(bodies, 0.0, "force_scale: 1.0, walls: false", 2e-3, true);
    let mut sim = Simulation::new(&case).unwrap();
    let momentum = |sim: &Simulation| sim.bodies().iter().fold(Vector::zeros(), |p, (_, b)| p + b.mass * b.velocity);
    let p0 = momentum(&sim);
    let scale = sim.bodies().iter().map(|(_, b)| b.mass * b.velocity.norm()).sum::<Real>();
    let mut worst: Real = 0.0;
    for _ in 0..15 {
        sim.step().unwrap();
        worst = worst.max((momentum(&sim) - p0).norm() / scale);
    }
    let b = sim.bodies();
    eprintln!(
        "after the collision: v_a = {:?}, v_b = {:?}; max |ΔP|/Σ m|v| = {worst:.2e}",
        b[0].1.velocity, b[1].1.velocity
    );
    // they collided (the light one turned back) and the momentum stayed to round-off
    assert!(b[0].1.velocity.x < 0.0 && b[1].1.velocity.x > 0.0, "no collision");
    assert!(worst < 1e-14, "momentum changed by {worst:e}");
}

/// Issue 15's scene, small: `n` rigid disks (d = 0.1, ρs = 1.1) resolved at 8 cells per
/// diameter (`no_slip`) in a closed 1 × 2 channel of water (μ = 0.01), packed in rows of
/// 6 at a gap of 0.4 d (inside the repulsion's look-ahead 2ρ = 0.5 d: in contact range from
/// the first step), with small fixed offsets, to `end`; benches/contact_substeps/disks.py
/// writes the full one.
fn pack(n: usize, end: Real, substeps: bool) -> Case {
    let (d, pitch, cols) = (0.1, 0.14, 6);
    let bodies: Vec<String> = (0..n)
        .map(|k| {
            let (i, j) = ((k % cols) as Real, (k / cols) as Real);
            // offsets of ±0.02 d from a fixed sequence
            let (ox, oy) = (0.02 * d * (0.618034 * k as Real).fract(), 0.02 * d * (0.414214 * k as Real).fract());
            let (x, y) = (0.5 - 2.5 * pitch + i * pitch + ox, 1.8 - j * pitch + oy);
            format!("(name: \"d{k}\", shape: Disk(center: ({x}, {y}), radius: 0.05))")
        })
        .collect();
    let text = format!(
        r#"(
        name: "pack", domain: (size: (1.0, 2.0), cells: (80, 160)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, -{G}),
        time: (end: {end}, cfl: 0.4, max_dt: 1e-2, contact_substeps: {substeps}),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian", params: (diffusion: "explicit")), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            (name: "disks", density: 1.1,
             frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "flip", flip_blend: 1.0)),
             region: Bodies([{}]), stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("water", "disks"), model: "no_slip")],
        contact: Some((model: "repulsion")),
        pressure: Some((model: "pcg", params: (tolerance: 1e-10))),
    )"#,
        bodies.join(", ")
    );
    Case::from_ron(&text, Path::new("pack.ron")).unwrap()
}

/// Runs `sim` to its case's end: the steps, and how many were limited by the contact.
fn run_to_end(sim: &mut Simulation) -> (usize, usize) {
    let end = sim.case.time.end;
    let (mut steps, mut contact) = (0, 0);
    while sim.time < end * (1.0 - 1e-12) {
        let d = sim.step().unwrap();
        steps += 1;
        contact += d.dt_limit.starts_with("contact") as usize;
    }
    (steps, contact)
}

/// The difference a fluid step of the CFL makes against one of 1e-4 without any contact:
/// one disk of the pack alone, settling from rest to `end` (max |Δx|, max |Δv|).
fn one_disk_step_difference(end: Real) -> (Real, Real) {
    let mut case = pack(1, end, false);
    case.contact = None;
    if let multifield_core::case::Region::Bodies(b) = &mut case.fields[1].region {
        b[0].shape = multifield_core::case::BodyShape::Disk { center: [0.5, 1.8], radius: 0.05 };
    }
    let mut adaptive = Simulation::new(&case).unwrap();
    case.time.fixed_dt = Some(1e-4);
    let mut fine = Simulation::new(&case).unwrap();
    run_to_end(&mut adaptive);
    run_to_end(&mut fine);
    let (a, b) = (&adaptive.bodies()[0].1, &fine.bodies()[0].1);
    ((a.position - b.position).norm(), (a.velocity - b.velocity).norm())
}

#[test]
fn a_settling_pack_takes_its_step_from_the_flow() {
    multifield::link_all();
    let end = 0.04;
    let (dx_one, dv_one) = one_disk_step_difference(end);
    let mut limited = Simulation::new(&pack(24, end, false)).unwrap();
    let mut sub = Simulation::new(&pack(24, end, true)).unwrap();
    let (n_limited, by_contact) = run_to_end(&mut limited);
    let (n_sub, by_contact_sub) = run_to_end(&mut sub);
    let (a, b) = (limited.bodies(), sub.bodies());
    let (mut dx, mut dv, mut moved, mut speed): (Real, Real, Real, Real) = (0.0, 0.0, 0.0, 0.0);
    let start = Simulation::new(&pack(24, end, true)).unwrap().bodies();
    for ((a, b), s) in a.iter().zip(&b).zip(&start) {
        dx = dx.max((a.1.position - b.1.position).norm());
        dv = dv.max((a.1.velocity - b.1.velocity).norm());
        moved = moved.max((a.1.position - s.1.position).norm());
        speed = speed.max(a.1.velocity.norm());
    }
    eprintln!(
        "24 disks to t = {end}: {n_limited} steps contact-limited ({by_contact} by the contact), {n_sub} with \
         sub-steps ({by_contact_sub}); max |Δx| = {:.3e} d (the disks moved up to {:.3} d), max |Δv| = {dv:.3e} \
         (largest speed {speed:.3}); one disk without contact, CFL step against 1e-4: |Δx| = {:.3e} d, \
         |Δv| = {dv_one:.3e}",
        dx / 0.1,
        moved / 0.1,
        dx_one / 0.1,
    );
    assert_eq!(by_contact_sub, 0);
    assert!(by_contact * 10 > n_limited * 9, "the reference is contact-limited in {by_contact} of {n_limited}");
    assert!(n_limited > 10 * n_sub, "{n_limited} steps against {n_sub}");
    // the pack with sub-steps differs from the contact-limited run by less than a single
    // disk's run with the same two fluid steps and no contact at all: what the larger
    // step changes is the flow's time discretisation, not the contact (measured 2.9 % of d
    // and 0.21 cm/s against 5.8 % and 0.21)
    assert!(dx < 0.035 * 0.1 && dx < dx_one, "positions differ by {dx} (one disk: {dx_one})");
    assert!(dv < 1.1 * dv_one, "velocities differ by {dv} (one disk: {dv_one})");
}

/// Every body's position and velocity, and the fluid's velocity, as bits.
fn bits(sim: &Simulation) -> Vec<u64> {
    let mut out: Vec<u64> = Vec::new();
    for (_, b) in sim.bodies() {
        out.extend([b.position.x, b.position.y, b.velocity.x, b.velocity.y, b.angular_velocity].map(Real::to_bits));
    }
    let v = &sim.fields[0].state.velocity;
    out.extend(v.u.iter().chain(&v.v).map(|x| x.to_bits()));
    out
}

#[test]
fn substepped_contact_restarts_and_threads_change_no_bit() {
    multifield::link_all();
    // 12 disks in contact range, 8 steps; a checkpoint after 4 (the hydrodynamic force the
    // sub-steps take lagged must come back with the bodies)
    let case = pack(12, 1.0, true);
    let run = |threads: usize, restart_at: Option<usize>| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut sim = Simulation::new(&case).unwrap();
            for k in 0..8 {
                if restart_at == Some(k) {
                    let bytes = sim.save_state().unwrap();
                    sim = Simulation::new(&case).unwrap();
                    sim.load_state(&bytes).unwrap();
                }
                let d = sim.step().unwrap();
                assert!(!d.dt_limit.starts_with("contact"));
            }
            bits(&sim)
        })
    };
    let one = run(1, None);
    assert!(one == run(2, None), "1 and 2 threads differ");
    assert!(one == run(1, Some(4)), "a restart after 4 steps differs");
}

#[test]
fn more_substeps_than_the_cap_is_an_error_naming_the_entry() {
    multifield::link_all();
    // the drop of the first test with a step of 0.5: 14,000 sub-steps of 3.57e-5
    let body = "(name: \"d\", shape: Disk(center: (0.5, 0.3), radius: 0.05))";
    let mut sim = Simulation::new(&dry_box(body, G, "", 0.5, true)).unwrap();
    let e = sim.step().unwrap_err().to_string();
    assert!(e.contains("time.contact_substeps") && e.contains("more than 10000") && e.contains("time.max_dt"), "{e}");
}

#[test]
fn the_option_is_off_by_default_left_out_of_the_written_case_and_set_by_override() {
    let body = "(name: \"d\", shape: Disk(center: (0.5, 0.3), radius: 0.05))";
    let case = dry_box(body, G, "", 1e-3, false);
    assert!(!case.time.contact_substeps && !case.to_ron().contains("contact_substeps"));
    let on = case.with_overrides(&["time.contact_substeps=true".to_string()]).unwrap();
    assert!(on.time.contact_substeps && on.to_ron().contains("contact_substeps: true"));
    let e = case.with_overrides(&["time.contact_substep=true".to_string()]).unwrap_err().to_string();
    assert!(e.contains("contact_substeps") && e.contains("did you mean"), "{e}");
}

/// A small copy of the mass-point suspension of benches/suspension/cost.py: `n` generated
/// points (d = 2h) settling in water on 48 × 96 cells with the cylinder drag and added
/// mass, `dem` in sub-steps; enough points and faces that the parallel footprints, the
/// drag and the exchange split into several tasks.
fn point_suspension(n: usize) -> Case {
    let text = format!(
        r#"(
        name: "suspension", domain: (size: (0.48, 0.96), cells: (48, 96)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, -{G}),
        time: (end: 1.0, cfl: 0.4, max_dt: 2e-3, contact_substeps: true),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian", params: (diffusion: "explicit")), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            (name: "points", density: 1.1, frame: (model: "lagrangian", params: (points_per_cell: 2)),
             representation: MassPoint, region: Bodies([]),
             generate: [(name: "p", region: (min: (0.02, 0.1), max: (0.46, 0.94)), count: Some({n}),
                         diameter: Fixed(0.02), min_gap: 0.002, seed: 15)],
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("water", "points"), model: "no_slip",
                    mass_point: Some((model: "cylinder", params: (added_mass: 1.0))))],
        contact: Some((model: "dem", params: (restitution: 0.9, collision_time: 1e-3, friction: 0.3))),
        pressure: Some((model: "pcg", params: (tolerance: 1e-8))),
    )"#
    );
    Case::from_ron(&text, Path::new("suspension.ron")).unwrap().expand_generators().unwrap().0
}

#[test]
fn a_mass_point_suspension_is_bit_identical_on_any_thread_count_and_restart() {
    multifield::link_all();
    // 400 points (solid fraction 0.34 of their region, gaps of d/10: many come into
    // contact), 6 steps;
    // a checkpoint after 3
    let case = point_suspension(400);
    let run = |threads: usize, restart_at: Option<usize>| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut sim = Simulation::new(&case).unwrap();
            for k in 0..6 {
                if restart_at == Some(k) {
                    let bytes = sim.save_state().unwrap();
                    sim = Simulation::new(&case).unwrap();
                    sim.load_state(&bytes).unwrap();
                }
                sim.step().unwrap();
            }
            bits(&sim)
        })
    };
    let one = run(1, None);
    // the points fell: the run is not at rest (every point's vertical velocity is negative)
    let sim_bodies = one.len() - 49 * 96 - 48 * 97;
    assert_eq!(sim_bodies, 5 * 400);
    let falling = (0..400).filter(|k| Real::from_bits(one[5 * k + 3]) < 0.0).count();
    assert!(falling > 390, "{falling} of 400 points fall");
    assert!(one == run(2, None), "1 and 2 threads differ");
    assert!(one == run(3, None), "1 and 3 threads differ");
    assert!(one == run(1, Some(3)), "a restart after 3 steps differs");
}
