//! Drag laws as exchange plugins: a periodic box of two interpenetrating Eulerian fields,
//! fluid "a" (θ = 0.9, ρ⁰ = 1, the first field of `between`) and particles "b" (θ = 0.1,
//! ρ⁰ = 2), no gravity, a uniform initial slip. Uniform fields keep no pressure gradient, so
//! the slip s = u_a − u_b obeys ds/dt = −θ_aθ_b K(|s|) (1/ρ_a + 1/ρ_b) s, ρ the bulk densities.
//!
//! - `stokes`: K = 18μ/(d²θ_f) is constant: s(t) = s(0) e^(−t/τ), τ = 1/(θ_aθ_bK(1/ρ_a + 1/ρ_b)).
//! - `schiller_naumann` (with and without Di Felice's factor): K depends on |s|; the reference
//!   is the ODE integrated with RK4 at small steps, K written out here from the formulas.

use multifield_core::case::Case;
use multifield_core::math::{Real, Vector};
use multifield_core::simulation::Simulation;
use std::path::Path;

const THETA_F: Real = 0.9;
const THETA_S: Real = 0.1;
const RHO_F: Real = 1.0;
const RHO_S: Real = 2.0;

fn drag_box(model: &str, params: &str, dt: Real, steps: usize) -> Case {
    let text = format!(
        r#"(
        name: "drag_box", domain: (size: (1.0, 1.0), cells: (8, 8)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: {end}, max_dt: {dt}, fixed_dt: Some({dt})),
        fields: [
            (name: "a", density: {RHO_F}, frame: (model: "eulerian"), region: All, volume_fraction: {THETA_F},
             velocity: Uniform((1.0, 0.5))),
            (name: "b", density: {RHO_S}, frame: (model: "eulerian"), region: Rest, velocity: Uniform((-1.0, 0.0))),
        ],
        exchange: [(between: ("a", "b"), model: "{model}", params: ({params}), integration: Implicit)],
        pressure: Some((model: "pcg", params: (tolerance: 1e-12))),
    )"#,
        end = dt * steps as Real
    );
    Case::from_ron(&text, Path::new("drag_box.ron")).unwrap()
}

/// Mean velocity of a field over its x-faces (x) and y-faces (y).
fn mean_velocity(sim: &Simulation, field: usize) -> Vector {
    let s = &sim.fields[field].state.velocity;
    let g = &sim.grid;
    let n = (g.nx * g.ny) as Real;
    let u = (0..g.ny).flat_map(|j| (0..g.nx).map(move |i| (i, j))).map(|(i, j)| s.u[g.xface(i, j)]).sum::<Real>();
    let v = (0..g.ny).flat_map(|j| (0..g.nx).map(move |i| (i, j))).map(|(i, j)| s.v[g.yface(i, j)]).sum::<Real>();
    Vector::new(u / n, v / n)
}

fn slip(sim: &Simulation) -> Vector {
    mean_velocity(sim, 0) - mean_velocity(sim, 1)
}

/// 1/ρ_a + 1/ρ_b with bulk densities, times θ_aθ_b.
fn rate_factor() -> Real {
    THETA_F * THETA_S * (1.0 / (THETA_F * RHO_F) + 1.0 / (THETA_S * RHO_S))
}

#[test]
fn stokes_drag_relaxes_the_slip_exponentially() {
    multifield::link_all();
    let (d, mu) = (0.1, 1e-3);
    let k = 18.0 * mu / (d * d * THETA_F); // = 2
    let tau = 1.0 / (rate_factor() * k);
    let steps = 400;
    let case = drag_box("stokes", &format!("diameter: {d}, viscosity: {mu}"), tau / 200.0, steps);
    let mut sim = Simulation::new(&case).unwrap();
    let s0 = Vector::new(2.0, 0.5); // (1, 0.5) − (−1, 0)
    let p0 = sim.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
    let mut worst: Real = 0.0;
    for step in 1..=steps {
        sim.step().unwrap();
        if step % 100 == 0 {
            let exact = s0 * (-sim.time / tau).exp();
            let err = (slip(&sim) - exact).norm() / exact.norm();
            worst = worst.max(err);
        }
    }
    eprintln!("stokes: τ = {tau:.5}, worst relative error of the slip at t = τ/2 … 2τ: {worst:.3e}");
    assert!(worst < 0.01, "slip off s(0)e^(−t/τ) by {worst:.4} (relative)");
    let p1 = sim.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
    assert!((p1 - p0).norm() / p0.norm() < 1e-12, "momentum drift {:e}", (p1 - p0).norm() / p0.norm());
}

/// Schiller–Naumann K(|s|) written out (interstitial slip; Di Felice at the superficial one).
fn k_schiller_naumann(d: Real, mu: Real, speed: Real, di_felice: bool) -> Real {
    let f = |re: Real| if re <= 1000.0 { 1.0 + 0.15 * re.powf(0.687) } else { 0.44 * re / 24.0 };
    let re = RHO_F * speed * d / mu;
    if di_felice {
        let re_s = THETA_F * re;
        let chi = 3.7 - 0.65 * (-(1.5 - re_s.log10()).powi(2) / 2.0).exp();
        18.0 * mu / (d * d) * f(re_s) * THETA_F.powf(-chi)
    } else {
        18.0 * mu / (d * d * THETA_F) * f(re)
    }
}

/// RK4 of ds/dt = −θ_aθ_b K(|s|)(1/ρ_a + 1/ρ_b) s from s0 over t.
fn reference(s0: Vector, t: Real, k: impl Fn(Real) -> Real) -> Vector {
    let rhs = |s: Vector| -rate_factor() * k(s.norm()) * s;
    let n = 20_000;
    let h = t / n as Real;
    let mut s = s0;
    for _ in 0..n {
        let k1 = rhs(s);
        let k2 = rhs(s + 0.5 * h * k1);
        let k3 = rhs(s + 0.5 * h * k2);
        let k4 = rhs(s + h * k3);
        s += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    s
}

fn schiller_naumann_follows_the_ode(di_felice: bool) {
    multifield::link_all();
    // Re(0) = |(2, 0.5)| · 0.2 / 0.0036 = 114.5; K(0) ≈ 4.9 times the Stokes value
    let (d, mu) = (0.2, 0.0036);
    let (dt, steps) = (1e-3, 1000);
    let params = format!("diameter: {d}, viscosity: {mu}, di_felice: {di_felice}");
    let case = drag_box("schiller_naumann", &params, dt, steps);
    let mut sim = Simulation::new(&case).unwrap();
    let s0 = Vector::new(2.0, 0.5); // (1, 0.5) − (−1, 0)
    let k = |speed: Real| k_schiller_naumann(d, mu, speed, di_felice);
    let tau0 = 1.0 / (rate_factor() * k(s0.norm()));
    let mut worst: Real = 0.0;
    for step in 1..=steps {
        sim.step().unwrap();
        if step % 250 == 0 {
            let exact = reference(s0, sim.time, k);
            let err = (slip(&sim) - exact).norm() / exact.norm();
            eprintln!(
                "schiller_naumann (di_felice {di_felice}): t = {:.3}, |s| = {:.5}, reference {:.5}, relative error {err:.3e}",
                sim.time,
                slip(&sim).norm(),
                exact.norm()
            );
            worst = worst.max(err);
        }
    }
    eprintln!("schiller_naumann (di_felice {di_felice}): τ(0) = {tau0:.4}, worst relative error {worst:.3e}");
    assert!(worst < 0.01, "slip off the ODE by {worst:.4} (relative)");
}

#[test]
fn schiller_naumann_drag_follows_the_slip_ode() {
    schiller_naumann_follows_the_ode(false);
}

#[test]
fn schiller_naumann_with_di_felice_follows_the_slip_ode() {
    schiller_naumann_follows_the_ode(true);
}
