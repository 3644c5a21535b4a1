//! The 3D MAC grid, its sides and its face arrays.

use multifield_core3d::boundary::{Boundaries, Boundary, Side};
use multifield_core3d::field::FieldState;
use multifield_core3d::grid::{FaceArrays, Grid, Lattice};
use multifield_core3d::math::{cross, vector, Real, Vector, AXES, DIM, SIDES};

fn grid() -> Grid {
    Grid::from_cells([4, 3, 5], 0.5, vector([1.0, 2.0, 3.0]))
}

#[test]
fn lattices_count_and_index_their_nodes_x_fastest() {
    let g = grid();
    assert_eq!((DIM, SIDES), (3, 6));
    assert_eq!(g.n_cells(), 60);
    assert_eq!([g.n_faces(0), g.n_faces(1), g.n_faces(2)], [5 * 3 * 5, 4 * 4 * 5, 4 * 3 * 6]);
    assert_eq!(g.cell_volume(), 0.125);
    assert_eq!(g.size(), Vector::new(2.0, 1.5, 2.5));
    for lattice in [Lattice::Cell, Lattice::XFace, Lattice::YFace, Lattice::ZFace] {
        let s = g.shape(lattice);
        let nodes: Vec<_> = g.nodes(lattice).collect();
        assert_eq!(nodes.len(), s[0] * s[1] * s[2]);
        for &(k, at) in &nodes {
            assert_eq!(k, at[0] + s[0] * (at[1] + s[1] * at[2]));
            assert_eq!(g.index(lattice, at), k);
            assert_eq!(g.node(lattice, k), at);
        }
    }
    // a z-face sits on the cell's lower z side, centred in x and y
    assert_eq!(g.position(Lattice::ZFace, [1, 2, 3]), Vector::new(1.75, 3.25, 4.5));
    assert_eq!(g.position(Lattice::Cell, [1, 2, 3]), Vector::new(1.75, 3.25, 4.75));
    assert!(g.contains(Vector::new(3.0, 3.5, 5.5)) && !g.contains(Vector::new(3.0, 3.5, 5.6)));
}

#[test]
fn the_six_sides_and_their_axes() {
    let names: Vec<_> = Side::ALL.iter().map(|s| (s.name(), s.axis(), s.high())).collect();
    assert_eq!(
        names,
        [
            ("left", 0, false),
            ("right", 0, true),
            ("bottom", 1, false),
            ("top", 1, true),
            ("back", 2, false),
            ("front", 2, true)
        ]
    );
    for s in Side::ALL {
        assert_eq!(Side::of(s.axis(), s.high()), s);
        assert_eq!(s.opposite().opposite(), s);
        assert_eq!(s.opposite().axis(), s.axis());
    }
    assert_eq!(cross(Vector::x(), Vector::y()), Vector::z());
}

#[test]
fn walls_inflows_and_periodic_sides_set_the_boundary_faces() {
    let g = grid();
    let bc = Boundaries {
        left: Boundary::Periodic,
        right: Boundary::Periodic,
        back: Boundary::Velocity { velocity: [0.0, 0.0, 2.0], profile: Default::default() },
        front: Boundary::Outflow { pressure: 0.0 },
        ..Boundaries::default()
    };
    assert!(bc.validate().is_ok());
    assert_eq!(bc.periodic_axes(), [true, false, false]);
    assert!(bc.is_inflow(Side::Back) && !bc.is_inflow(Side::Front));
    let mut vel = FaceArrays::zeros(&g);
    for a in AXES {
        for (k, _) in g.nodes(Lattice::face(a)) {
            vel[a][k] = 1.0 + k as Real;
        }
    }
    bc.enforce(&g, &mut vel);
    for (k, at) in g.nodes(Lattice::XFace) {
        // periodic along x: face n is face 0
        let expect =
            if at[0] == 4 { 1.0 + g.index(Lattice::XFace, [0, at[1], at[2]]) as Real } else { 1.0 + k as Real };
        assert_eq!(vel[0][k], expect);
    }
    for (k, at) in g.nodes(Lattice::YFace) {
        let wall = at[1] == 0 || at[1] == 3;
        assert_eq!(vel[1][k], if wall { 0.0 } else { 1.0 + k as Real });
    }
    for (k, at) in g.nodes(Lattice::ZFace) {
        // the inflow at the back, the outflow at the front free
        assert_eq!(vel[2][k], if at[2] == 0 { 2.0 } else { 1.0 + k as Real });
    }
    // the no-slip bottom's ghost of a tangential component mirrors it; the inflow's
    // tangential components are zero
    assert_eq!(bc.ghost(Side::Bottom, 2, 0.25, [0.5, 0.5]), -0.25);
    assert_eq!(bc.ghost(Side::Back, 0, 0.25, [0.5, 0.5]), -0.25);
    assert!(bc.face_fixed(&g, 2, 0) && !bc.face_fixed(&g, 2, 5) && !bc.face_fixed(&g, 0, 0));
}

#[test]
fn face_fractions_are_the_mean_of_the_two_cells() {
    let g = grid();
    let mut state = FieldState::new(&g);
    for (c, at) in g.nodes(Lattice::Cell) {
        state.theta[c] = (at[0] + 10 * at[1] + 100 * at[2]) as Real;
    }
    state.update_face_fractions(&g, [false, false, true]);
    // inside: the mean; at a wall: the inside cell; across the periodic z sides: the mean
    // of the first and last layers
    assert_eq!(state.theta_face[0][g.index(Lattice::XFace, [2, 1, 1])], 111.5);
    assert_eq!(state.theta_face[1][g.index(Lattice::YFace, [3, 0, 2])], 203.0);
    assert_eq!(state.theta_face[2][g.index(Lattice::ZFace, [1, 1, 0])], 0.5 * (11.0 + 411.0));
    assert_eq!(state.theta_face[2][g.index(Lattice::ZFace, [1, 1, 5])], 0.5 * (11.0 + 411.0));
}
