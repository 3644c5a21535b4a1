//! Single-mass-point bodies (`representation: MassPoint`, docs/method.md §4): volume spreading,
//! settling against the closed forms of the drag laws, added mass, the rotation torque,
//! drafting in the seed's DKT scene, the validity warnings and the errors of a bad case.
//!
//! The settling boxes make the particle small against the cell (d/h ≤ 0.02), so that the
//! fluid it drags along stays below 0.1 % of its speed over the run: the particle then
//! moves as its drag law alone says, which is what the closed forms describe.

use multifield::run::{run, RunOptions};
use multifield_core::case::Case;
use multifield_core::geometry::disk_cell_fractions;
use multifield_core::grid::Grid;
use multifield_core::math::{Real, Vector};
use multifield_core::simulation::Simulation;
use std::f64::consts::PI;
use std::path::Path;

const G: Real = 981.0;

/// A closed box of water (16 × 16 cells of side h) with one point of diameter d at
/// (x, y), drag law `model` with `params`, fixed step `dt` for `steps` steps.
#[allow(clippy::too_many_arguments)]
fn settling_box(
    h: Real,
    d: Real,
    rho_s: Real,
    mu: Real,
    at: [Real; 2],
    model: &str,
    params: &str,
    dt: Real,
    steps: usize,
) -> Case {
    let size = 16.0 * h;
    let text = format!(
        r#"(
        name: "settling_point", domain: (size: ({size}, {size}), cells: (16, 16)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, -{G}),
        time: (end: {end}, max_dt: {dt}, fixed_dt: Some({dt})),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: {mu}))]),
            (name: "particle", density: {rho_s}, frame: (model: "lagrangian"),
             region: Bodies([(name: "p", shape: Disk(center: ({x}, {y}), radius: {r}))]),
             representation: MassPoint),
        ],
        exchange: [(between: ("water", "particle"), model: "{model}", params: ({params}))],
        pressure: Some((model: "pcg", params: (tolerance: 1e-12))),
    )"#,
        end = dt * steps as Real,
        x = at[0],
        y = at[1],
        r = 0.5 * d
    );
    Case::from_ron(&text, Path::new("settling_point.ron")).unwrap()
}

#[test]
fn spreading_conserves_volume_at_any_position() {
    multifield::link_all();
    // through the solver: a point of d = 2.5 h at positions on cell faces, on nodes,
    // anywhere, and touching each wall; Σθ = 1 in every cell, Σ θ_s h² = V
    let (h, r) = (0.1, 0.125);
    let positions = [
        [0.8, 0.8],          // on a node
        [0.8, 0.83],         // on an x-face line
        [0.77, 0.8],         // on a y-face line
        [0.8137, 0.7259],    // anywhere
        [r, 0.8],            // touching the left wall
        [1.6 - r, 0.9],      // touching the right wall
        [0.8, r],            // touching the bottom
        [0.4, 1.6 - r],      // touching the top
        [r, r],              // in a corner
        [0.4 + 1e-13, 0.95], // a hair off a face
    ];
    let mut worst_sum: Real = 0.0;
    let mut worst_volume: Real = 0.0;
    for at in positions {
        let case = settling_box(h, 2.0 * r, 1.5, 0.01, at, "stokes", "", 1e-6, 1);
        let mut sim = Simulation::new(&case).unwrap();
        let d = sim.step().unwrap();
        worst_sum = worst_sum.max(d.volume_fraction_error);
        let v: Real = sim.fields[1].state.theta.iter().sum::<Real>() * h * h;
        worst_volume = worst_volume.max((v - PI * r * r).abs() / (PI * r * r));
        assert!(sim.fields[1].state.theta.iter().all(|t| *t <= 1.0 + 1e-15));
    }
    eprintln!("max |Σθ − 1| = {worst_sum:.2e}, max |Σθ_s h² − V|/V = {worst_volume:.2e}");
    assert!(worst_sum < 1e-12, "max |Σθ − 1| = {worst_sum:e}");
    assert!(worst_volume < 1e-12, "spread volume off by {worst_volume:e}");

    // across periodic sides, and disks from 0.05 h to 6 h, at 200 positions each
    let g = Grid::new(12, 10, 0.1, Vector::new(-0.3, 0.2));
    let mut worst: Real = 0.0;
    for r in [0.005, 0.05, 0.1, 0.3] {
        for k in 0..200 {
            let t = k as Real;
            let c = [-0.3 + 1.2 * (0.618034 * t).fract(), 0.2 + (0.414214 * t).fract()];
            let mut cells = Vec::new();
            disk_cell_fractions(&g, c, r, [true, true], &mut cells);
            let mut theta = vec![0.0; g.n_cells()];
            for (cell, th) in cells {
                theta[cell] += th;
            }
            assert!(theta.iter().all(|t| *t <= 1.0 + 1e-15), "θ > 1 for r = {r} at {c:?}");
            let v: Real = theta.iter().sum::<Real>() * g.cell_volume();
            worst = worst.max((v - PI * r * r).abs() / (PI * r * r));
        }
    }
    eprintln!("periodic: max relative volume error {worst:.2e}");
    assert!(worst < 1e-12);
}

/// U(t) of a point released from rest with constant K: U_t (1 − e^(−t/τ)).
fn stokes_settling(added_mass: Real) -> (Real, Real) {
    multifield::link_all();
    let (h, d, rho_s, mu) = (0.1, 0.002, 2.0, 0.01);
    let tau = (rho_s + added_mass) * d * d / (18.0 * mu);
    let u_t = (rho_s - 1.0) * G * d * d / (18.0 * mu);
    let dt = tau / 100.0;
    let steps = 600;
    let params = format!("added_mass: {added_mass}");
    let case = settling_box(h, d, rho_s, mu, [0.8, 0.9], "stokes", &params, dt, steps);
    let mut sim = Simulation::new(&case).unwrap();
    let (mut worst, mut worst_fluid): (Real, Real) = (0.0, 0.0);
    for _ in 0..steps {
        sim.step().unwrap();
        let b = &sim.bodies()[0].1;
        let exact = -u_t * (1.0 - (-sim.time / tau).exp());
        worst = worst.max((b.velocity.y - exact).abs() / u_t);
        worst_fluid = worst_fluid.max(sim.fields[0].state.velocity.v.iter().fold(0.0, |m: Real, v| m.max(v.abs())));
    }
    (worst, worst_fluid / u_t)
}

#[test]
fn stokes_settling_follows_the_closed_form_without_added_mass() {
    let (err, fluid) = stokes_settling(0.0);
    eprintln!("C_A = 0: max |U − U_t(1 − e^(−t/τ))| / U_t = {err:.2e}; largest fluid speed {fluid:.1e} U_t");
    assert!(err < 0.01, "{err}");
}

#[test]
fn stokes_settling_follows_the_closed_form_with_added_mass() {
    // τ = (ρ_s + C_A ρ_f) d²/(18μ): the release is slower by (ρ_s + 1)/ρ_s = 1.5; a run
    // that ignored the added mass would be off by 14 % of U_t at t = τ
    let (err, fluid) = stokes_settling(1.0);
    eprintln!("C_A = 1: max |U − U_t(1 − e^(−t/τ))| / U_t = {err:.2e}; largest fluid speed {fluid:.1e} U_t");
    assert!(err < 0.01, "{err}");
}

#[test]
fn schiller_naumann_terminal_velocity_is_the_root_of_the_force_balance() {
    multifield::link_all();
    // d = 0.05, ρ_s = 1.5, μ = 0.01: Re ≈ 25, where Schiller–Naumann is 1.9 × Stokes' drag
    let (h, d, rho_s, mu) = (5.0, 0.05, 1.5, 0.01);
    // (ρ_s − ρ_f) g = (3/4) μ/d² · 24 (1 + 0.15 Re^0.687) U, Re = ρ_f U d/μ
    let balance = |u: Real| {
        let re = u * d / mu;
        0.75 * mu / (d * d) * 24.0 * (1.0 + 0.15 * re.powf(0.687)) * u - (rho_s - 1.0) * G
    };
    let (mut lo, mut hi) = (0.0, 100.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if balance(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let u_root = 0.5 * (lo + hi);
    let stokes = (rho_s - 1.0) * G * d * d / (18.0 * mu);
    let tau = (rho_s + 1.0) * d * d / (18.0 * mu);
    let dt = tau / 20.0;
    let steps = 300; // 15 τ_Stokes: within 1e-4 of terminal
    let case = settling_box(h, d, rho_s, mu, [40.0, 60.0], "schiller_naumann", "added_mass: 1.0", dt, steps);
    let mut sim = Simulation::new(&case).unwrap();
    for _ in 0..steps {
        sim.step().unwrap();
    }
    let u = -sim.bodies()[0].1.velocity.y;
    let err = (u - u_root) / u_root;
    eprintln!(
        "Schiller–Naumann: U = {u:.5}, root {u_root:.5} (Re {:.2}; Stokes would give {stokes:.3}); error {:.3} %",
        u_root * d / mu,
        100.0 * err
    );
    assert!(err.abs() < 0.005, "terminal velocity off the root by {:.3} %", 100.0 * err);
}

#[test]
fn a_point_turns_with_the_fluid_through_the_rotation_torque() {
    multifield::link_all();
    // a neutrally buoyant point at the centre of a Taylor–Green cell, where the fluid turns
    // at Ω_f = ½ ∇×u = A e^(−2νt); I dω/dt = 4πμa² (Ω_f − ω) gives, from rest,
    // ω(t) = A (e^(−λt) − e^(−t/τ_r)) / (1 − λ τ_r), λ = 2ν, τ_r = I/(4πμa²) = m/(8πμ)
    // a small point (d = h/10): a larger one drags the fluid of its footprint towards its
    // own (zero) translation and so slows the rotation it samples (by 5 % at d = h)
    let (a, mu) = (0.005, 0.01);
    let tau_r = PI * a * a / (8.0 * PI * mu);
    let (dt, end) = (tau_r / 50.0, 8.0 * tau_r);
    let n = 64;
    let size = 2.0 * PI;
    let text = format!(
        r#"(
        name: "turning_point", domain: (size: ({size}, {size}), cells: ({n}, {n})),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: {end}, max_dt: {dt}, fixed_dt: Some({dt})),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
             velocity: TaylorGreen(amplitude: 1.0),
             stress: [(model: "newtonian", params: (viscosity: {mu}))]),
            (name: "particle", density: 1.0, frame: (model: "lagrangian"),
             region: Bodies([(name: "p", shape: Disk(center: ({c}, {c}), radius: {a}))]),
             representation: MassPoint),
        ],
        exchange: [(between: ("water", "particle"), model: "stokes", params: (rotation: true))],
        pressure: Some((model: "pcg", params: (tolerance: 1e-12))),
    )"#,
        c = 0.5 * PI
    );
    let case = Case::from_ron(&text, Path::new("turning_point.ron")).unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let lambda = 2.0 * mu;
    let mut worst: Real = 0.0;
    while sim.time < end - 1e-12 {
        sim.step().unwrap();
        let t = sim.time;
        let exact = ((-lambda * t).exp() - (-t / tau_r).exp()) / (1.0 - lambda * tau_r);
        let w = sim.bodies()[0].1.angular_velocity;
        worst = worst.max((w - exact).abs());
        if std::env::var("MF_DEBUG").is_ok() {
            eprintln!("t {t:.4} ω {w:.5} exact {exact:.5}");
        }
    }
    eprintln!("rotation: τ_r = {tau_r:.4}, max |ω − ω_exact| / A = {worst:.2e}");
    // the grid vorticity at the point is 2A(1 − O((kh)²)), 0.7 % low at 64 cells; backward
    // Euler at Δt = τ_r/50 adds up to 0.4 % in the transient
    assert!(worst < 0.01, "{worst}");
}

/// The seed's DKT case with mass points on a grid of `cells`, to `end`.
fn point_dkt(cells: (usize, usize), end: Real) -> Case {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_seed.ron");
    Case::load(
        &path,
        &[
            "fields.disks.representation=MassPoint".into(),
            format!("domain.cells=({}, {})", cells.0, cells.1),
            format!("time.end={end}"),
        ],
    )
    .unwrap()
}

#[test]
fn point_particle_dkt_drafts_and_kisses_in_the_seed_case() {
    multifield::link_all();
    // 2 cells per diameter (d = h at 10 × 40 is the point model's home; 20 × 80 is the
    // coarsest grid where the leading point's wake is two cells wide)
    let case = point_dkt((20, 80), 1.6);
    let dir = std::env::temp_dir().join(format!("mf_point_dkt_{}", std::process::id()));
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.summary.status, "completed", "{}", out.summary.reason);
    let text = std::fs::read_to_string(dir.join("bodies.csv")).unwrap();
    let mut upper = Vec::new();
    let mut lower = Vec::new();
    for line in text.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        let t: Real = c[1].parse().unwrap();
        let y: Real = c[4].parse().unwrap();
        let vy: Real = c[6].parse().unwrap();
        if c[2] == "upper" {
            upper.push((t, y, vy));
        } else {
            lower.push((t, y, vy));
        }
    }
    let d = 0.2;
    let gap0 = (upper[0].1 - lower[0].1) / d;
    let min_gap = upper.iter().zip(&lower).map(|(u, l)| (u.1 - l.1) / d).fold(Real::INFINITY, Real::min);
    // drafting: the trailing point falls faster than the leading one once the wake forms
    let (u, l) = upper.iter().zip(&lower).find(|(u, _)| u.0 >= 1.0).unwrap();
    eprintln!(
        "point DKT (20 × 80): gap {gap0:.2} d → {min_gap:.3} d; at t = {:.2}: trailing {:.3}, leading {:.3} cm/s; warnings {:?}",
        u.0, u.2, l.2, out.summary.warnings
    );
    assert!((gap0 - 2.0).abs() < 1e-12);
    assert!(u.2 < l.2, "no drafting: trailing {} vs leading {}", u.2, l.2);
    assert!(min_gap < 1.0, "the trailing point never reached the leading one: gap {min_gap} d");
    // d = 2h: the summary names both points with the ratio
    assert_eq!(out.summary.warnings.len(), 2, "{:?}", out.summary.warnings);
    assert!(out.summary.warnings.iter().all(|w| w.contains("2.00 × the cell size")), "{:?}", out.summary.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_reynolds_number_beyond_the_law_is_named_with_its_ratio() {
    multifield::link_all();
    // Stokes' law at Re ≈ 25 (the Schiller–Naumann box): beyond its range Re ≤ 1
    let (d, mu) = (0.05, 0.01);
    let tau = 2.5 * d * d / (18.0 * mu);
    let case = settling_box(5.0, d, 1.5, mu, [40.0, 60.0], "stokes", "added_mass: 1.0", tau / 10.0, 100);
    let dir = std::env::temp_dir().join(format!("mf_point_re_{}", std::process::id()));
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    // Stokes: U_t = 0.5 g d²/(18μ) = 6.81, Re = 34.1
    let w = &out.summary.warnings;
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("point `p`") && w[0].contains("`stokes`"), "{w:?}");
    let re: Real = w[0].split("reached ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((re - 34.06).abs() < 0.5, "Re {re}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_point_cases_say_how_to_fix_them() {
    multifield::link_all();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sedimentation.ron");
    // no_slip without a drag law for the points
    let case =
        Case::load(&path, &["fields.disks.representation=MassPoint".into(), "exchange.0.mass_point=None".into()])
            .unwrap();
    let e = Simulation::new(&case).err().unwrap().to_string();
    assert!(e.contains("exchange.0.mass_point") && e.contains("mass_point: Some((model: \"cylinder\""), "{e}");
    // a drag law of another diameter
    let case = Case::load(
        &path,
        &[
            "fields.disks.representation=MassPoint".into(),
            "exchange.0.mass_point=Some((model: \"cylinder\", params: (diameter: 0.3)))".into(),
        ],
    )
    .unwrap();
    let e = Simulation::new(&case).err().unwrap().to_string();
    assert!(e.contains("diameter 0.25") && e.contains("`diameter: 0.25`"), "{e}");
    // diameter and viscosity default to the disk's and the water's
    let case = Case::load(
        &path,
        &["fields.disks.representation=MassPoint".into(), "exchange.0.mass_point=Some((model: \"cylinder\"))".into()],
    )
    .unwrap();
    let sim = Simulation::new(&case).unwrap();
    let p = &sim.case.exchange[0].mass_point.as_ref().unwrap().params;
    assert_eq!(p["diameter"], 0.25);
    assert_eq!(p["viscosity"], 0.01);
    // a rectangle cannot be a mass point
    let case = Case::load(
        &path,
        &[
            "fields.disks.representation=MassPoint".into(),
            "fields.disks.region=Bodies([(name: \"box\", shape: Rectangle(min: (0.9, 4.9), max: (1.1, 5.1)))])".into(),
        ],
    );
    let e = match case {
        Ok(c) => Simulation::new(&c).err().unwrap().to_string(),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("body `box` is not a disk") && e.contains("Resolved"), "{e}");
    // the mass-point frame is chosen by the representation, not named as a frame
    let case = Case::load(&path, &["fields.disks.frame=(model: \"mass_point\")".into()]).unwrap();
    let e = Simulation::new(&case).err().unwrap().to_string();
    assert!(e.contains("fields.disks.frame.model") && e.contains("representation: MassPoint"), "{e}");
}

#[test]
fn compare_runs_both_representations_and_the_point_releases_with_its_added_mass() {
    multifield::link_all();
    // one disk, ρ_s/ρ_f = 1.5, every step written: the point's first step accelerates at
    // (ρ_s − ρ_f) g/(ρ_s + C_A ρ_f) = 196.2 cm/s² (C_A = 1 in the example's drag law), not
    // (ρ_s − ρ_f) g/ρ_s = 327 without added mass. The point run is on a 4 × 12 grid
    // (d = h/2); the fluid left in the cells a larger point fills moves with it and adds
    // inertia: measured −7.0 % at d = 2h, −5.0 % at d = h, −2.1 % at d = h/2
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sedimentation.ron");
    let case =
        Case::load(&path, &["domain.cells=(32, 96)".into(), "time.end=0.004".into(), "output.interval=0".into()])
            .unwrap();
    let dir = std::env::temp_dir().join(format!("mf_compare_{}", std::process::id()));
    let c = multifield::compare::compare(&case, &["domain.cells=(4, 12)".into()], &dir, &RunOptions::quiet(), None)
        .unwrap();
    assert_eq!((c.resolved.status.as_str(), c.point.status.as_str()), ("completed", "completed"));
    assert!((c.resolved.cells_per_diameter - 4.0).abs() < 1e-9 && (c.point.cells_per_diameter - 0.5).abs() < 1e-9);
    let a = 0.5 * G / 2.5;
    let tracks = multifield::dkt::read_bodies(&dir.join("point").join("bodies.csv")).unwrap();
    let tr = &tracks["disk"];
    let measured = -tr.vy[1] / tr.t[1];
    eprintln!("point: first-step acceleration {measured:.2} against {a:.2} ({:+.2} %)", 100.0 * (measured / a - 1.0));
    assert!((measured / a - 1.0).abs() < 0.05, "{measured} vs {a}");
    assert_eq!((c.resolved.bodies.len(), c.point.bodies.len()), (1, 1));
    let d = c.terminal_speed_relative_difference["disk"];
    let (r, p) = (c.resolved.bodies[0].max_settling_speed, c.point.bodies[0].max_settling_speed);
    assert!(r > 0.0 && p > 0.0 && (d - (p - r) / r).abs() < 1e-12);
    assert_eq!(std::fs::read_to_string(dir.join("comparison.csv")).unwrap().lines().count(), 3);
    for f in ["comparison.json", "compare_position.png", "compare_velocity.svg"] {
        assert!(std::fs::metadata(dir.join(f)).unwrap().len() > 500, "{f}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
