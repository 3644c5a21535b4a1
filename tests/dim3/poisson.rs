//! The 7-point pressure operator of the 3D compile.

use multifield_core3d::boundary::{Boundaries, Boundary, Side};
use multifield_core3d::grid::{FaceArrays, Grid, Lattice};
use multifield_core3d::math::{vector, Real};
use multifield_core3d::poisson::PoissonProblem;
use std::f64::consts::PI;

/// The eigenvalue of the operator on p = sin 2πx sin 2πy sin 2πz on the periodic unit cube
/// of n³ cells (unit coefficients), as the Rayleigh quotient p·Ap / p·p.
fn eigenvalue(n: usize) -> Real {
    let h = 1.0 / n as Real;
    let g = Grid::from_cells([n, n, n], h, vector([0.0; 3]));
    let periodic = Boundaries {
        left: Boundary::Periodic,
        right: Boundary::Periodic,
        bottom: Boundary::Periodic,
        top: Boundary::Periodic,
        back: Boundary::Periodic,
        front: Boundary::Periodic,
    };
    let mut c = FaceArrays::zeros(&g);
    for a in 0..3 {
        c[a].iter_mut().for_each(|c| *c = 1.0);
    }
    let problem = PoissonProblem::new(&g, &periodic, c, vec![0.0; g.n_cells()]);
    let p: Vec<Real> = g
        .nodes(Lattice::Cell)
        .map(|(_, at)| {
            let x = g.position(Lattice::Cell, at);
            (2.0 * PI * x.x).sin() * (2.0 * PI * x.y).sin() * (2.0 * PI * x.z).sin()
        })
        .collect();
    let mut ap = vec![0.0; p.len()];
    problem.apply(&p, &mut ap);
    // p is an eigenvector: A p − λ p vanishes to round-off
    let lambda = ap.iter().zip(&p).map(|(a, p)| a * p).sum::<Real>() / p.iter().map(|p| p * p).sum::<Real>();
    let residual = ap.iter().zip(&p).map(|(a, p)| (a - lambda * p).abs()).fold(0.0, Real::max);
    assert!(residual < 1e-10 * lambda, "n = {n}: |Ap − λp| = {residual}");
    lambda
}

#[test]
fn the_seven_point_operator_is_second_order() {
    let lambdas = [8, 16, 32].map(eigenvalue);
    for (n, lambda) in [8, 16, 32].iter().zip(lambdas) {
        // the discrete eigenvalue of the 7-point Laplacian: 3 · 4 sin²(πh)/h²
        let h = 1.0 / *n as Real;
        let exact = 12.0 * (PI * h).sin().powi(2) / (h * h);
        assert!((lambda / exact - 1.0).abs() < 1e-12, "n = {n}: λ = {lambda}, 12 sin²(πh)/h² = {exact}");
    }
    // against −∇²'s 12π²: error π⁴h² (1 + O(h²)), order 2
    let e = lambdas.map(|l| (l - 12.0 * PI * PI).abs());
    let orders: Vec<Real> = e.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    for o in &orders {
        assert!((o - 2.0).abs() < 0.05, "orders {orders:?}, errors {e:?}");
    }
}

#[test]
fn a_row_has_seven_entries_and_an_outflow_side_a_dirichlet_term() {
    let n = 4;
    let g = Grid::from_cells([n, n, n], 0.25, vector([0.0; 3]));
    let bc = Boundaries { front: Boundary::Outflow { pressure: 3.0 }, ..Boundaries::default() };
    let mut c = FaceArrays::zeros(&g);
    for a in 0..3 {
        for (k, at) in g.nodes(Lattice::face(a)) {
            c[a][k] = (1 + a + at[a]) as Real * 0.0625;
        }
    }
    let problem = PoissonProblem::new(&g, &bc, c.clone(), vec![0.0; g.n_cells()]);
    assert!(!problem.is_singular());
    assert_eq!(problem.dirichlet, [false, false, false, false, false, true]);
    // an inside cell: its six faces, divided by h²
    let (diag, nb) = problem.row([1, 2, 1]);
    let coefficients: Vec<Real> = nb.iter().map(|(c, _)| *c).collect();
    assert_eq!(coefficients, [2.0, 3.0, 4.0, 5.0, 4.0, 5.0]);
    assert_eq!(diag, 23.0);
    assert_eq!(nb[4].1, Some(g.index(Lattice::Cell, [1, 2, 0])));
    assert_eq!(nb[5].1, Some(g.index(Lattice::Cell, [1, 2, 2])));
    // a cell at the walls of x = 0 and the outflow front: no neighbour there, the front
    // face counted twice, and its share of the side's pressure in the right-hand side
    let (diag, nb) = problem.row([0, 1, 3]);
    assert_eq!((nb[0], nb[5]), ((0.0, None), (2.0 * 7.0, None)));
    assert_eq!(diag, 2.0 + 3.0 + 4.0 + 6.0 + 14.0);
    let k = g.index(Lattice::Cell, [0, 1, 3]);
    assert_eq!(problem.rhs[k], 2.0 * 7.0 * 3.0);
    assert_eq!(problem.rhs.iter().filter(|&&b| b != 0.0).count(), n * n);
    assert_eq!(Side::ALL[5], Side::Front);
}
