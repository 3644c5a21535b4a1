//! Bodies of one field with their own density (`density: Some(ρ)` on a body, issue 22
//! item 5): the same trajectories as the same bodies in fields of those densities.

use multifield::run::{run, RunOptions};
use multifield_core::case::Case;
use multifield_core::math::Real;
use std::path::Path;

/// The DKT scene of examples/dkt_uhlmann2005.ron on a coarse grid (32 × 96, 4 cells per
/// diameter), 50 steps of 1 ms, with the bodies' fields `fields` and the exchange entries
/// `exchange` (with `{model}` the coupling).
fn dkt(fields: &str, exchange: &str) -> String {
    format!(
        r#"(
        name: "dkt_densities",
        domain: (size: (2.0, 6.0), cells: (32, 96)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, -981.0),
        time: (end: 0.05, cfl: 0.4, max_dt: 1e-3),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian", params: (limiter: "none", diffusion: "explicit")),
             region: Rest, stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            {fields}
        ],
        exchange: [{exchange}],
        contact: Some((model: "repulsion", params: (range_cells: 1.0, stiffness: 1e-2, dt_factor: 0.3))),
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-10))),
        output: (interval: 0.0, charts: false),
    )"#
    )
}

const FRAME: &str =
    r#"frame: (model: "lagrangian", params: (points_per_cell: 3, shape: "linear", transfer: "flip", flip_blend: 1.0))"#;
const TRAILING: &str = r#"(name: "trailing", shape: Disk(center: (1.001, 5.0), radius: 0.125))"#;
const LEADING: &str = r#"(name: "leading", shape: Disk(center: (0.999, 4.5), radius: 0.125)"#;

/// Runs `text` and returns the rows of `bodies.csv` as (body, [x, y, vx, vy, ω]).
fn trajectories(name: &str, text: &str) -> Vec<(String, [Real; 5])> {
    multifield::link_all();
    let case = Case::from_ron(text, Path::new("dkt_densities.ron")).unwrap();
    let dir = std::env::temp_dir().join(format!("mf_body_densities_{name}_{}", std::process::id()));
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.summary.status, "completed", "{}", out.summary.reason);
    let text = std::fs::read_to_string(dir.join("bodies.csv")).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    text.lines()
        .skip(1)
        .map(|line| {
            let c: Vec<&str> = line.split(',').collect();
            (c[2].to_string(), std::array::from_fn(|k| c[3 + k].parse().unwrap()))
        })
        .collect()
}

/// Largest differences between two runs, row by row (the body names must agree row by
/// row): of the positions relative to |x|, of the velocities relative to the speed |v|,
/// and of the angular velocities relative to |v|/r (r = 0.125, the disks' radius).
fn largest_difference(a: &[(String, [Real; 5])], b: &[(String, [Real; 5])]) -> [Real; 3] {
    assert_eq!(a.len(), b.len());
    let mut worst: [Real; 3] = [0.0; 3];
    for ((na, ra), (nb, rb)) in a.iter().zip(b) {
        assert_eq!(na, nb);
        let position = ((ra[0] - rb[0]).hypot(ra[1] - rb[1])) / ra[0].hypot(ra[1]);
        let speed = ra[2].hypot(ra[3]).max(rb[2].hypot(rb[3]));
        if speed == 0.0 {
            assert_eq!(ra, rb);
            continue;
        }
        let velocity = (ra[2] - rb[2]).hypot(ra[3] - rb[3]) / speed;
        let spin = (ra[4] - rb[4]).abs() / (speed / 0.125);
        for (w, d) in worst.iter_mut().zip([position, velocity, spin]) {
            *w = w.max(d);
        }
    }
    worst
}

/// Settling speed of body `name` in the last row.
fn last_speed(rows: &[(String, [Real; 5])], name: &str) -> Real {
    rows.iter().rev().find(|(n, _)| n == name).unwrap().1[3]
}

#[test]
fn two_densities_in_one_field_follow_the_two_field_trajectories() {
    // mass points (the drag law with added mass and rotation of the DKT example): one field
    // of density 1.5 whose leading disk has its own 1.25, against fields of 1.5 and 1.25
    let mass_point = r#"representation: MassPoint"#;
    let law = r#"model: "cylinder", params: (added_mass: 1.0, rotation: true)"#;
    let one = dkt(
        &format!(
            r#"(name: "disks", density: 1.5, {FRAME}, region: Bodies([{TRAILING}, {LEADING}, density: Some(1.25))]),
               stress: [(model: "rigid")], {mass_point}),"#
        ),
        &format!(r#"(between: ("water", "disks"), {law})"#),
    );
    let two = dkt(
        &format!(
            r#"(name: "heavy", density: 1.5, {FRAME}, region: Bodies([{TRAILING}]), stress: [(model: "rigid")], {mass_point}),
               (name: "light", density: 1.25, {FRAME}, region: Bodies([{LEADING})]), stress: [(model: "rigid")], {mass_point}),"#
        ),
        &format!(r#"(between: ("water", "heavy"), {law}), (between: ("water", "light"), {law})"#),
    );
    let (a, b) = (trajectories("one_field", &one), trajectories("two_fields", &two));
    assert_eq!(a.len(), 2 * 51);
    let d = largest_difference(&a, &b);
    let (trailing, leading) = (last_speed(&a, "trailing"), last_speed(&a, "leading"));
    eprintln!("mass points: one field against two, largest relative differences of positions, velocities, spins {d:?}; at t = 0.05 the trailing disk falls at {trailing:.4}, the leading at {leading:.4} cm/s");
    assert!(d.iter().all(|&d| d <= 1e-12), "one field and two fields differ by {d:?}");
    // the densities matter: ρ_b − ρ_f of 0.5 and 0.25 give clearly different speeds
    assert!(trailing < 1.3 * leading, "trailing {trailing}, leading {leading}");
}

#[test]
fn a_body_of_its_own_density_moves_as_in_a_field_of_that_density() {
    // direct forcing, one body in one field: the leading disk with its own density 1.25 in
    // a field of 1.5, against the field of 1.25 (two bodies: the next test)
    let own = dkt(
        &format!(
            r#"(name: "disks", density: 1.5, {FRAME}, region: Bodies([{LEADING}, density: Some(1.25))]), stress: [(model: "rigid")]),"#
        ),
        r#"(between: ("water", "disks"), model: "direct_forcing")"#,
    );
    let field = own.replace("density: 1.5", "density: 1.25").replace(", density: Some(1.25)", "");
    let heavy = own.replace(", density: Some(1.25)", "");
    let (a, b, c) = (trajectories("own", &own), trajectories("field", &field), trajectories("heavy", &heavy));
    let d = largest_difference(&a, &b);
    let (own_speed, heavy_speed) = (last_speed(&a, "leading"), last_speed(&c, "leading"));
    eprintln!("direct forcing: own density against the field's, largest relative differences {d:?}; at t = 0.05 {own_speed:.4} cm/s (1.25), {heavy_speed:.4} cm/s (1.5)");
    assert_eq!(d, [0.0; 3]);
    // and the field's 1.5 would have given another trajectory
    assert!(heavy_speed < 1.3 * own_speed, "1.5: {heavy_speed}, 1.25: {own_speed}");
}

#[test]
fn two_forcings_on_one_fluid_move_their_bodies_as_one_forcing_does() {
    // the DKT pair (8 cells apart: no marker stencils overlap) as one field under one direct
    // forcing, against two fields under a forcing each. Each forcing used to spread only its
    // own lagged forces and to add the fluid's whole lagged force to the velocity again: the
    // trajectories differed by 16 % from step 2
    let one = dkt(
        &format!(
            r#"(name: "disks", density: 1.5, {FRAME}, region: Bodies([{TRAILING}, {LEADING})]), stress: [(model: "rigid")]),"#
        ),
        r#"(between: ("water", "disks"), model: "direct_forcing")"#,
    );
    let two = dkt(
        &format!(
            r#"(name: "upper", density: 1.5, {FRAME}, region: Bodies([{TRAILING}]), stress: [(model: "rigid")]),
               (name: "lower", density: 1.5, {FRAME}, region: Bodies([{LEADING})]), stress: [(model: "rigid")]),"#
        ),
        r#"(between: ("water", "upper"), model: "direct_forcing"), (between: ("water", "lower"), model: "direct_forcing")"#,
    );
    let (a, b) = (trajectories("one_forcing", &one), trajectories("two_forcings", &two));
    let order = |rows: Vec<(String, [Real; 5])>| {
        let mut rows = rows;
        rows.sort_by(|x, y| x.0.cmp(&y.0));
        rows
    };
    let d = largest_difference(&order(a.clone()), &order(b));
    eprintln!(
        "direct forcing: one entry against two, largest relative differences of positions, velocities, spins {d:?}"
    );
    assert!(d.iter().all(|&d| d <= 1e-12), "one forcing and two differ by {d:?}");
    // the disks moved: 50 steps of settling
    assert!(last_speed(&a, "leading") < -1.0, "{}", last_speed(&a, "leading"));

    // and two densities: the leading disk of its own 1.25 in the field of 1.5, against
    // fields of 1.5 and 1.25 under a forcing each
    let own = one.replacen(&format!("{LEADING})"), &format!("{LEADING}, density: Some(1.25))"), 1);
    let fields = two.replacen(r#"(name: "lower", density: 1.5"#, r#"(name: "lower", density: 1.25"#, 1);
    let (a, b) = (trajectories("own_density", &own), trajectories("two_densities", &fields));
    let d = largest_difference(&order(a.clone()), &order(b));
    let (trailing, leading) = (last_speed(&a, "trailing"), last_speed(&a, "leading"));
    eprintln!("direct forcing, densities 1.5 and 1.25: one field against two, largest relative differences {d:?}; at t = 0.05 the trailing disk falls at {trailing:.4}, the leading at {leading:.4} cm/s");
    assert!(d.iter().all(|&d| d <= 1e-12), "one field and two differ by {d:?}");
    assert!(trailing < 1.3 * leading, "trailing {trailing}, leading {leading}");
}
