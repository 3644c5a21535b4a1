//! The momentum exchange in 3D (issue 17, P1): two interpenetrating Eulerian fields relax
//! their slip as e^{−t/τ} (as the 2D test in tests/verification/multifield_coupling.rs), and
//! a slip-dependent drag law reads the slip of all three components on every face lattice.

use super::eulerian::link;
use multifield_core3d::case::Case;
use multifield_core3d::field::FieldState;
use multifield_core3d::grid::{FaceArrays, Grid, Lattice};
use multifield_core3d::math::{vector, Real, Vector, AXES};
use multifield_core3d::plugin::ExchangeContext;
use multifield_core3d::registry::build_exchange;
use multifield_core3d::simulation::Simulation;
use multifield_physics3d::exchange::drag::Drag;
use multifield_physics3d::exchange::schiller_naumann::SchillerNaumann;
use std::path::Path;

/// Two fields in the periodic unit cube of 8³ cells: `a` (ρ⁰ = 1, θ = ½, velocity
/// (1, 0.5, −0.25)) and `b` (ρ⁰ = 2, the rest, velocity (−1, 0, 0.5)), a constant K.
fn two_field_box(k: Real, dt: Real, steps: usize, integration: &str) -> Case {
    let text = format!(
        r#"(
        name: "exchange_box3d", domain: (size: (1.0, 1.0, 1.0), cells: (8, 8, 8)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic, back: Periodic, front: Periodic),
        time: (end: {end}, max_dt: {dt}, fixed_dt: Some({dt})),
        fields: [
            (name: "a", density: 1.0, frame: (model: "eulerian"), region: All, volume_fraction: 0.5,
             velocity: Uniform((1.0, 0.5, -0.25))),
            (name: "b", density: 2.0, frame: (model: "eulerian"), region: Rest, velocity: Uniform((-1.0, 0.0, 0.5))),
        ],
        exchange: [(between: ("a", "b"), model: "constant", params: (coefficient: {k}), integration: {integration})],
        pressure: Some((model: "pcg", params: {{"preconditioner": "jacobi", "tolerance": 1e-12}})),
    )"#,
        end = dt * steps as Real
    );
    Case::from_ron(&text, Path::new("exchange_box3d.ron")).unwrap()
}

/// Mean velocity of a field over its faces, per component.
fn mean(sim: &Simulation, field: usize) -> Vector {
    let v = &sim.fields[field].state.velocity;
    let g = &sim.grid;
    Vector::from_fn(|a, _| {
        // the faces of the lattice but the periodic copies at n
        let faces: Vec<Real> =
            g.nodes(Lattice::face(a)).filter(|(_, at)| at[a] < g.n()[a]).map(|(k, _)| v[a][k]).collect();
        faces.iter().sum::<Real>() / faces.len() as Real
    })
}

fn total_momentum(sim: &Simulation) -> Vector {
    sim.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b)
}

/// Bulk densities ρa = 0.5, ρb = 1, θaθb = ¼: τ = 1/(θaθb K (1/ρa + 1/ρb)) = 1 for K = 4/3.
/// Δt = τ/200: every component of the slip follows e^{−t/τ} within 1 % of the initial slip at
/// t = τ and 2τ, implicit and explicit, and the momentum is conserved to round-off. At
/// Δt = 10τ the implicit step multiplies the slip by 1/(1 + Δt/τ) = 1/11 exactly.
#[test]
fn two_field_slip_decays_as_exp_minus_t_over_tau() {
    link();
    let k = 4.0 / 3.0;
    let tau = 1.0;
    let slip0 = vector([2.0, 0.5, -0.75]);
    for integration in ["Implicit", "Explicit"] {
        let case = two_field_box(k, tau / 200.0, 400, integration);
        let mut sim = Simulation::new(&case).unwrap();
        let p0 = total_momentum(&sim);
        let mut worst: Real = 0.0;
        for step in 1..=400 {
            sim.step().unwrap();
            if step % 200 == 0 {
                let slip = mean(&sim, 0) - mean(&sim, 1);
                let exact = slip0 * (-sim.time / tau).exp();
                for a in AXES {
                    worst = worst.max((slip[a] - exact[a]).abs() / slip0[a].abs());
                }
            }
        }
        eprintln!("{integration}: slip off e^(-t/τ) by at most {worst:.2e} of the initial slip");
        assert!(worst < 0.01, "{integration}: slip off e^(-t/τ) by {worst:.4} of the initial slip");
        let p1 = total_momentum(&sim);
        assert!((p1 - p0).norm() / p0.norm() < 1e-12, "{integration}: momentum drift {:e}", (p1 - p0).norm());
    }
    let case = two_field_box(k, 10.0 * tau, 3, "Implicit");
    let mut sim = Simulation::new(&case).unwrap();
    let mut slip = slip0;
    for _ in 0..3 {
        sim.step().unwrap();
        let s = mean(&sim, 0) - mean(&sim, 1);
        for a in AXES {
            assert!((s[a] - slip[a] / 11.0).abs() < 1e-12, "component {a}: {} vs {}", s[a], slip[a] / 11.0);
        }
        slip = s;
    }
}

/// Schiller–Naumann's K on every face of the three lattices is the law at the face's slip
/// |Δu| = |(1, 2, 2)| = 3 for a uniform slip (the normal component and the other two each
/// averaged from four faces), and 0 where the particles put nothing.
#[test]
fn a_drag_law_reads_the_slip_of_the_three_components() {
    link();
    let g = Grid::from_cells([5, 4, 3], 0.1, vector([0.0; 3]));
    let (mut a, mut b) = (FieldState::new(&g), FieldState::new(&g));
    let du = [1.0, 2.0, -2.0];
    for c in AXES {
        a.velocity[c].iter_mut().for_each(|u| *u = 0.5 + du[c]);
        b.velocity[c].iter_mut().for_each(|u| *u = 0.5);
        a.theta_face[c].iter_mut().for_each(|t| *t = 0.8);
        // the particles on every other face
        for (k, (m, t)) in b.mass_face[c].iter_mut().zip(b.theta_face[c].iter_mut()).enumerate() {
            if k % 2 == 0 {
                (*m, *t) = (1e-4, 0.2);
            }
        }
    }
    let (d, mu) = (0.01, 1e-3);
    let params = serde_json::json!({"diameter": d, "viscosity": mu});
    let model = build_exchange("schiller_naumann", &params, "exchange.0").unwrap();
    let ctx = ExchangeContext { grid: &g, a: &a, b: &b, density: [1000.0, 2500.0], periodic: [false; 3] };
    let mut k = FaceArrays::zeros(&g);
    model.coefficients(&ctx, &mut k);
    let law = Drag::<SchillerNaumann>::new(d, mu);
    // Re = ρ_f |Δu| d / μ = 1000 · 3 · 0.01 / 10⁻³ = 3·10⁴ (the law's K, not its validity)
    let expected = law.coefficient(3.0, 1000.0, 0.8);
    let mut worst: Real = 0.0;
    for c in AXES {
        for (f, k) in k[c].iter().enumerate() {
            if f % 2 == 0 {
                worst = worst.max((k / expected - 1.0).abs());
            } else {
                assert_eq!(*k, 0.0, "lattice {c}, face {f}: no particles, K = {k}");
            }
        }
    }
    assert!(expected > 0.0 && worst < 1e-14, "K off the law at |Δu| = 3 by {worst:e}");
    // at a slip of 1 (the x component alone) K is the law's at 1: the other components count
    assert!((law.coefficient(1.0, 1000.0, 0.8) / expected - 1.0).abs() > 0.1);
}
