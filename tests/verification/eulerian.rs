//! Verification of the Eulerian frame against analytic solutions of the incompressible
//! Navier–Stokes equations `∂u/∂t + ∇·(u⊗u) = −∇p/ρ + ν∇²u + g`, `∇·u = 0`
//! (docs/method.md §7), on small grids, through the whole step of the core (predictor,
//! viscosity, projection).

use multifield_core::boundary::{Boundaries, Boundary, Profile};
use multifield_core::case::{Case, InitialVelocity, PluginSpec};
use multifield_core::grid::Lattice;
use multifield_core::math::Real;
use multifield_core::simulation::Simulation;
use multifield_frames::eulerian::Eulerian;
use serde_json::json;
use std::f64::consts::PI;
use std::path::Path;

/// A one-field Eulerian case of density `rho` and dynamic viscosity `mu`: a RON skeleton
/// (so that new case keys with defaults need no change here) filled in from code.
#[allow(clippy::too_many_arguments)]
fn case(
    size: [Real; 2],
    cells: [usize; 2],
    boundaries: Boundaries,
    gravity: [Real; 2],
    end: Real,
    fixed_dt: Option<Real>,
    velocity: InitialVelocity,
    rho: Real,
    mu: Real,
) -> Case {
    multifield_frames::link();
    multifield_physics::link();
    let skeleton = r#"(
        name: "eulerian_verification",
        domain: (size: (1.0, 1.0), cells: (2, 2)),
        time: (end: 1.0, max_dt: 1.0),
        fields: [(name: "fluid", density: 1.0, frame: (model: "eulerian"), region: All)],
    )"#;
    let mut c = Case::from_ron(skeleton, Path::new("eulerian_verification.rs")).expect("skeleton case");
    c.domain.size = size;
    c.domain.cells = cells;
    c.boundaries = boundaries;
    c.gravity = gravity;
    c.time.end = end;
    c.time.fixed_dt = fixed_dt;
    let f = &mut c.fields[0];
    f.density = rho;
    f.velocity = velocity;
    f.stress = vec![PluginSpec::with("newtonian", json!({ "viscosity": mu }))];
    c.pressure = Some(PluginSpec::with("pcg", json!({ "tolerance": 1e-10 })));
    c
}

fn run(case: &Case) -> Simulation {
    let mut sim = Simulation::new(case).expect("valid case");
    while sim.time < case.time.end * (1.0 - 1e-12) {
        sim.step().expect("step");
    }
    sim
}

fn eulerian(sim: &Simulation) -> &Eulerian {
    sim.fields[0].frame.as_any().downcast_ref::<Eulerian>().expect("an Eulerian field")
}

/// Taylor–Green vortex on the periodic square [0, 2π]²:
/// `u = sin x cos y e^(−2νt)`, `v = −cos x sin y e^(−2νt)`, `p = (ρ/4)(cos 2x + cos 2y) e^(−4νt)`.
///
/// Δt = 2/N = h/π (Courant number 0.32 at the peak speed 1), so time and space errors
/// shrink together and a first-order-in-time scheme would show order 1. The error is the
/// discrete L2 norm over all faces, sqrt(Σ (u − u_exact)² / N_faces): a limiter clips the
/// slopes at the extrema of the velocity, a first-order error on a set of measure → 0 that
/// the L2 norm weighs by its area, which is the norm the convergence theory of limited
/// schemes gives. The max norm over faces, which such clipping could spoil, is asserted too.
#[test]
fn taylor_green_vortex_converges_at_second_order() {
    let (nu, end) = (0.05, 1.0);
    let periodic = Boundaries {
        left: Boundary::Periodic,
        right: Boundary::Periodic,
        bottom: Boundary::Periodic,
        top: Boundary::Periodic,
    };
    let mut l2 = vec![];
    let mut linf = vec![];
    let grids = [16, 32, 64];
    for n in grids {
        let steps = n / 2;
        let c = case(
            [2.0 * PI, 2.0 * PI],
            [n, n],
            periodic,
            [0.0, 0.0],
            end,
            Some(end / steps as Real),
            InitialVelocity::TaylorGreen { amplitude: 1.0 },
            1.0,
            nu,
        );
        let sim = run(&c);
        assert_eq!(sim.steps as usize, steps);
        let g = &sim.grid;
        let vel = eulerian(&sim).velocity();
        let decay = (-2.0 * nu * sim.time).exp();
        let (mut sum2, mut max, mut count) = (0.0, 0.0 as Real, 0);
        for j in 0..g.ny {
            for i in 0..g.nx {
                let p = g.node_position(Lattice::XFace, i, j);
                let e = vel.u[g.xface(i, j)] - p.x.sin() * p.y.cos() * decay;
                let p = g.node_position(Lattice::YFace, i, j);
                let f = vel.v[g.yface(i, j)] + p.x.cos() * p.y.sin() * decay;
                sum2 += e * e + f * f;
                max = max.max(e.abs()).max(f.abs());
                count += 2;
            }
        }
        l2.push((sum2 / count as Real).sqrt());
        linf.push(max);
    }
    let order = |e: &[Real], k: usize| (e[k] / e[k + 1]).log2();
    eprintln!(
        "Taylor–Green ν = {nu}, t = {end}, grids {grids:?}: L2 errors {l2:?} (orders {:.2}, {:.2}); \
         max errors {linf:?} (orders {:.2}, {:.2})",
        order(&l2, 0),
        order(&l2, 1),
        order(&linf, 0),
        order(&linf, 1)
    );
    assert!(order(&l2, 1) >= 1.8, "observed L2 order {:.2} on 32→64 (errors {l2:?})", order(&l2, 1));
    assert!(order(&linf, 1) >= 1.8, "observed max-norm order {:.2} on 32→64 (errors {linf:?})", order(&linf, 1));
    assert!(l2[2] < 1e-3, "L2 error {:.2e} on 64² too large", l2[2]);
}

/// Plane Poiseuille flow between no-slip walls y = 0 and y = H driven by a body force g
/// along x (periodic in x): steady `u(y) = g/(2ν) y (H − y)`.
#[test]
fn poiseuille_flow_reaches_the_parabola() {
    let (n, h_channel, nu, gx) = (32, 1.0, 1.0, 1.0);
    let hcell = h_channel / n as Real;
    let bc = Boundaries {
        left: Boundary::Periodic,
        right: Boundary::Periodic,
        bottom: Boundary::NoSlip,
        top: Boundary::NoSlip,
    };
    // 1.2 H²/ν: the slowest mode has decayed by e^(−1.2π²) ≈ 7e-6
    let c = case([4.0 * hcell, h_channel], [4, n], bc, [gx, 0.0], 1.2, None, InitialVelocity::default(), 1.0, nu);
    let sim = run(&c);
    let g = &sim.grid;
    let vel = eulerian(&sim).velocity();
    let umax = gx * h_channel * h_channel / (8.0 * nu);
    let mut err: Real = 0.0;
    for j in 0..g.ny {
        for i in 0..=g.nx {
            let y = g.node_position(Lattice::XFace, i, j).y;
            err = err.max((vel.u[g.xface(i, j)] - gx / (2.0 * nu) * y * (h_channel - y)).abs());
        }
    }
    let vmax = vel.v.iter().fold(0.0 as Real, |m, v| m.max(v.abs()));
    eprintln!(
        "Poiseuille {n} cells across, {} steps: max |u − parabola|/u_max = {:.3e}, max |v| = {vmax:.1e}",
        sim.steps,
        err / umax
    );
    assert!(err / umax < 0.01, "max error {:.3e} of u_max", err / umax);
    assert!(vmax < 1e-10 * umax, "spurious cross-flow {vmax:e}");
}

/// Couette flow: a wall moving at U on top of a fluid at rest on a wall at y = 0, periodic
/// in x: steady `u(y) = U y / H` (which the discrete operator reproduces exactly).
#[test]
fn couette_flow_is_linear() {
    let (n, h_channel, nu, u_wall) = (16, 1.0, 1.0, 2.0);
    let hcell = h_channel / n as Real;
    let bc = Boundaries {
        left: Boundary::Periodic,
        right: Boundary::Periodic,
        bottom: Boundary::NoSlip,
        top: Boundary::Velocity { velocity: [u_wall, 0.0], profile: Profile::Uniform },
    };
    // 2 H²/ν: the slowest mode has decayed by e^(−2π²) ≈ 3e-9
    let c = case([4.0 * hcell, h_channel], [4, n], bc, [0.0, 0.0], 2.0, None, InitialVelocity::default(), 1.0, nu);
    let sim = run(&c);
    let g = &sim.grid;
    let vel = eulerian(&sim).velocity();
    let mut err: Real = 0.0;
    for j in 0..g.ny {
        for i in 0..=g.nx {
            let y = g.node_position(Lattice::XFace, i, j).y;
            err = err.max((vel.u[g.xface(i, j)] - u_wall * y / h_channel).abs());
        }
    }
    eprintln!("Couette {n} cells across, {} steps: max |u − Uy/H|/U = {:.3e}", sim.steps, err / u_wall);
    assert!(err / u_wall < 1e-6, "max relative error {:.3e}", err / u_wall);
}

/// Hydrostatic rest: a closed box of fluid under gravity stays at rest, `u = 0`, and the
/// pressure balances gravity, `∂p/∂y = −ρg`, `∂p/∂x = 0`.
#[test]
fn hydrostatic_box_stays_at_rest() {
    let (n, l, g, rho) = (16, 1.0, 981.0, 1.0);
    let mut c =
        case([l, l], [n, n], Boundaries::default(), [0.0, -g], 0.5, None, InitialVelocity::default(), rho, 0.01);
    // the pressure's low modes are only as exact as the solve: ask for a tight one
    c.pressure = Some(PluginSpec::with("pcg", json!({ "tolerance": 1e-13 })));
    let sim = run(&c);
    let umax = eulerian(&sim).velocity().max_abs();
    let gr = &sim.grid;
    let p = &sim.pressure;
    let (mut dy, mut dx): (Real, Real) = (0.0, 0.0);
    for j in 0..gr.ny {
        for i in 0..gr.nx {
            if j + 1 < gr.ny {
                let grad = (p[gr.cell(i, j + 1)] - p[gr.cell(i, j)]) / gr.h;
                dy = dy.max((grad + rho * g).abs() / (rho * g));
            }
            if i + 1 < gr.nx {
                dx = dx.max((p[gr.cell(i + 1, j)] - p[gr.cell(i, j)]).abs() / (gr.h * rho * g));
            }
        }
    }
    eprintln!(
        "hydrostatic box {n}², {} steps: max|u|/sqrt(gL) = {:.2e}, max |dp/dy + ρg|/ρg = {dy:.2e}, max |dp/dx|/ρg = {dx:.2e}",
        sim.steps,
        umax / (g * l).sqrt()
    );
    assert!(umax < 1e-8 * (g * l).sqrt(), "max |u| = {umax:e}");
    assert!(dy < 1e-8 && dx < 1e-8, "pressure not hydrostatic: {dy:e} {dx:e}");
}

/// Lid-driven cavity at Re = ρUL/μ = 100 (a validation, not an exact solution): the
/// extrema of u on the vertical centreline and of v on the horizontal one against Ghia,
/// Ghia & Shin (J. Comput. Phys. 48, 1982, Tables I–II, 129² grid): u_min = −0.21090 at
/// y = 0.4531, v_max = 0.17527 at x = 0.2344, v_min = −0.24533 at x = 0.8047. 32² cells,
/// t = 10 (steady to the digits checked).
#[test]
fn lid_driven_cavity_matches_ghia_at_re_100() {
    let n = 32;
    let bc = Boundaries {
        top: Boundary::Velocity { velocity: [1.0, 0.0], profile: Profile::Uniform },
        ..Boundaries::default()
    };
    let mut c = case([1.0, 1.0], [n, n], bc, [0.0, 0.0], 10.0, None, InitialVelocity::default(), 1.0, 0.01);
    c.pressure = Some(PluginSpec::with("pcg", json!({ "tolerance": 1e-8 })));
    let sim = run(&c);
    let g = &sim.grid;
    let vel = eulerian(&sim).velocity();
    let extremum = |values: Vec<(Real, Real)>, sign: Real| {
        values.into_iter().fold((0.0, 0.0), |best, (x, v)| if sign * v > sign * best.1 { (x, v) } else { best })
    };
    let u_centre: Vec<(Real, Real)> =
        (0..g.ny).map(|j| (g.node_position(Lattice::XFace, n / 2, j).y, vel.u[g.xface(n / 2, j)])).collect();
    let v_centre: Vec<(Real, Real)> =
        (0..g.nx).map(|i| (g.node_position(Lattice::YFace, i, n / 2).x, vel.v[g.yface(i, n / 2)])).collect();
    let found = [extremum(u_centre, -1.0), extremum(v_centre.clone(), 1.0), extremum(v_centre, -1.0)];
    let ghia = [(0.4531, -0.21090), (0.2344, 0.17527), (0.8047, -0.24533)];
    eprintln!("cavity Re 100, {n}², {} steps: (position, extremum) {found:.4?} vs Ghia {ghia:?}", sim.steps);
    for ((x, v), (xg, vg)) in found.iter().zip(ghia) {
        assert!(((v - vg) / vg).abs() < 0.03, "extremum {v} vs Ghia {vg}");
        assert!((x - xg).abs() <= g.h, "position {x} vs Ghia {xg}");
    }
}

/// Ghia, Ghia & Shin (1982), Re = 100: u on the vertical centre-line (Table I, (y, u)) and
/// v on the horizontal one (Table II, (x, v)), without the wall rows.
const GHIA_U: [(Real, Real); 15] = [
    (0.9766, 0.84123),
    (0.9688, 0.78871),
    (0.9609, 0.73722),
    (0.9531, 0.68717),
    (0.8516, 0.23151),
    (0.7344, 0.00332),
    (0.6172, -0.13641),
    (0.5000, -0.20581),
    (0.4531, -0.21090),
    (0.2813, -0.15662),
    (0.1719, -0.10150),
    (0.1016, -0.06434),
    (0.0703, -0.04775),
    (0.0625, -0.04192),
    (0.0547, -0.03717),
];
const GHIA_V: [(Real, Real); 15] = [
    (0.9688, -0.05906),
    (0.9609, -0.07391),
    (0.9531, -0.08864),
    (0.9453, -0.10313),
    (0.9063, -0.16914),
    (0.8594, -0.22445),
    (0.8047, -0.24533),
    (0.5000, 0.05454),
    (0.2344, 0.17527),
    (0.2266, 0.17507),
    (0.1563, 0.16077),
    (0.0938, 0.12317),
    (0.0781, 0.10890),
    (0.0703, 0.10091),
    (0.0625, 0.09233),
];

/// Linear interpolation of the samples `(s, q)` (sorted by s) at `s0`.
fn interpolate(samples: &[(Real, Real)], s0: Real) -> Real {
    let k = samples.partition_point(|(s, _)| *s < s0).clamp(1, samples.len() - 1);
    let ((s1, q1), (s2, q2)) = (samples[k - 1], samples[k]);
    q1 + (q2 - q1) * (s0 - s1) / (s2 - s1)
}

/// Samples (position, value) along a line.
type Profile1 = Vec<(Real, Real)>;

/// The lid-driven cavity at Re 100 run to a steady state (max |uⁿ⁺¹ − uⁿ| / Δt < 1e-8 U²/L)
/// at Courant number `cfl` with the viscosity's `diffusion`: the centre-line profiles (u(½, y) on the x-faces of column n/2,
/// v(x, ½) on the y-faces of row n/2, walls included) and the steps taken.
fn steady_cavity(n: usize, cfl: Real, diffusion: &str) -> (Profile1, Profile1, u64) {
    let bc = Boundaries {
        top: Boundary::Velocity { velocity: [1.0, 0.0], profile: Profile::Uniform },
        ..Boundaries::default()
    };
    let mut c = case([1.0, 1.0], [n, n], bc, [0.0, 0.0], 100.0, None, InitialVelocity::default(), 1.0, 0.01);
    c.time.cfl = cfl;
    c.fields[0].frame.params = json!({ "diffusion": diffusion });
    c.pressure = Some(PluginSpec::with("pcg", json!({ "tolerance": 1e-12 })));
    let mut sim = Simulation::new(&c).expect("valid case");
    loop {
        let before = eulerian(&sim).velocity().clone();
        let d = sim.step().expect("step");
        let after = eulerian(&sim).velocity();
        let change = before.u.iter().zip(&after.u).chain(before.v.iter().zip(&after.v)).map(|(a, b)| (a - b).abs());
        let rate = change.fold(0.0, Real::max) / d.dt;
        if rate < 1e-8 {
            break;
        }
        assert!(sim.time < c.time.end * (1.0 - 1e-12), "CFL {cfl}: not steady by t = {} (rate {rate:e})", sim.time);
    }
    let g = &sim.grid;
    let vel = eulerian(&sim).velocity();
    let mut u: Vec<(Real, Real)> =
        (0..g.ny).map(|j| (g.node_position(Lattice::XFace, n / 2, j).y, vel.u[g.xface(n / 2, j)])).collect();
    u.insert(0, (0.0, 0.0));
    u.push((1.0, 1.0));
    let mut v: Vec<(Real, Real)> =
        (0..g.nx).map(|i| (g.node_position(Lattice::YFace, i, n / 2).x, vel.v[g.yface(i, n / 2)])).collect();
    v.insert(0, (0.0, 0.0));
    v.push((1.0, 0.0));
    (u, v, sim.steps)
}

/// A steady state is one of the discrete equations, not of the steps that reached it: the
/// cavity's steady centre-line profiles on 16² at CFL 0.1, 0.4 and 0.8 agree to 1e-8
/// with the Crank–Nicolson viscosity (which has no viscous Δt limit), and lie within 0.012
/// (RMS) of Ghia's table. The explicit split step (`diffusion: "explicit"`) leaves a
/// Δt ν∇²A(u) in its steady state: its profiles at CFL 0.1 and 0.4 differ by more than 1e-3.
#[test]
fn lid_driven_cavity_steady_state_does_not_depend_on_the_time_step() {
    let n = 16;
    let rms = |u: &[(Real, Real)], v: &[(Real, Real)]| {
        let e2: Real = GHIA_U.iter().map(|&(y, ug)| (interpolate(u, y) - ug).powi(2)).sum::<Real>()
            + GHIA_V.iter().map(|&(x, vg)| (interpolate(v, x) - vg).powi(2)).sum::<Real>();
        (e2 / (GHIA_U.len() + GHIA_V.len()) as Real).sqrt()
    };
    let difference = |a: &(Profile1, Profile1, u64), b: &(Profile1, Profile1, u64)| {
        a.0.iter().zip(&b.0).chain(a.1.iter().zip(&b.1)).map(|(x, y)| (x.1 - y.1).abs()).fold(0.0, Real::max)
    };
    let mut reference = None;
    for diffusion in ["crank_nicolson", "explicit"] {
        let cfls: &[Real] = if diffusion == "explicit" { &[0.1, 0.4] } else { &[0.1, 0.4, 0.8] };
        for &cfl in cfls {
            // one thread: a 16² grid is too small to share (the same bits on any number)
            let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
            let run = pool.install(|| steady_cavity(n, cfl, diffusion));
            let reference = reference.get_or_insert_with(|| run.clone());
            let (diff, err) = (difference(&run, reference), rms(&run.0, &run.1));
            eprintln!(
                "cavity Re 100, {n}², {diffusion}, CFL {cfl}: {} steps to steady; RMS error against Ghia {err:.5}; \
                 max |profile − Crank–Nicolson's at CFL 0.1| {diff:.2e}",
                run.2
            );
            if diffusion == "crank_nicolson" {
                assert!(diff < 1e-8, "CFL {cfl}: the steady profile moved by {diff:e} from CFL 0.1's");
                assert!(err < 0.012, "CFL {cfl}: RMS error {err} against Ghia");
            } else if cfl > 0.1 {
                assert!(diff > 1e-3, "the explicit step's steady state moved by only {diff:e}");
            }
        }
    }
}
