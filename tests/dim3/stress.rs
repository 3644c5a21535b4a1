//! The Newtonian stress in 3D (issue 17, P1): its explicit 7-point Laplacian per face
//! lattice, with the ghosts of no-slip walls, against its discrete eigenvalue, and its
//! explicit stability limit h²ρ/(6μ).

use super::eulerian::link;
use multifield_core3d::boundary::{Boundaries, Boundary};
use multifield_core3d::field::FieldState;
use multifield_core3d::grid::{Grid, Lattice};
use multifield_core3d::math::{vector, Real};
use multifield_core3d::plugin::{GridStressContext, TimeStepContext};
use multifield_core3d::registry::build_stress;
use std::f64::consts::PI;

/// On the unit cube (periodic along x, no-slip walls on y and z) u = sin πy sin πz on the
/// x-faces (at cell centres in y, z) is an eigenvector of the 7-point Laplacian with the
/// no-slip ghosts −u: L u = −2 · 4 sin²(πh/2)/h² u. One explicit step of `newtonian` with
/// k = Δt μ/(ρh²) multiplies it by 1 − 8k sin²(πh/2), to round-off, on the x-faces and
/// leaves the other components at 0. Likewise w = sin πx sin πy on the z-faces of a box
/// with walls on x and y and periodic along z.
#[test]
fn the_explicit_laplacian_has_the_seven_point_eigenvalue_at_walls() {
    link();
    let n = 12;
    let h = 1.0 / n as Real;
    let g = Grid::from_cells([n, n, n], h, vector([0.0; 3]));
    let (mu, rho, dt) = (0.3, 2.0, 0.01);
    let k = dt * mu / (rho * h * h);
    let factor = 1.0 - 8.0 * k * (PI * h / 2.0).sin().powi(2);
    let model = build_stress("newtonian", &serde_json::json!({"viscosity": mu}), "stress.0").unwrap();
    for axis in [0, 2] {
        let periodic_along = |a: usize| if a == axis { Boundary::Periodic } else { Boundary::NoSlip };
        let bc = Boundaries {
            left: periodic_along(0),
            right: periodic_along(0),
            bottom: periodic_along(1),
            top: periodic_along(1),
            back: periodic_along(2),
            front: periodic_along(2),
        };
        let lattice = Lattice::face(axis);
        let mode = |at: [usize; 3]| {
            let p = g.position(lattice, at);
            (0..3).filter(|&a| a != axis).map(|a| (PI * p[a]).sin()).product::<Real>()
        };
        let mut state = FieldState::new(&g);
        for (f, at) in g.nodes(lattice) {
            state.velocity[axis][f] = mode(at);
        }
        let before = state.velocity[axis].clone();
        let mut ctx = GridStressContext { grid: &g, boundaries: &bc, dt, density: rho, state: &mut state };
        model.apply_on_grid(&mut ctx).unwrap();
        let worst = before.iter().zip(&state.velocity[axis]).map(|(b, a)| (a - factor * b).abs()).fold(0.0, Real::max);
        assert!(worst < 1e-14, "axis {axis}: |u¹ − (1 − 8k sin²(πh/2)) u⁰| up to {worst:e}");
        for c in (0..3).filter(|&c| c != axis) {
            assert!(state.velocity[c].iter().all(|&v| v == 0.0), "component {c} moved");
        }
    }
    // the explicit limit Δt ≤ safety h²ρ/(2·DIM μ) = 0.9 h²ρ/(6μ)
    let ctx = TimeStepContext { grid: &g, density: rho, max_speed: 0.0, implicit_viscosity: None };
    let limit = model.stable_dt(&ctx).unwrap();
    assert!((limit / (0.9 * h * h * rho / (6.0 * mu)) - 1.0).abs() < 1e-15, "stable_dt {limit}");
}
