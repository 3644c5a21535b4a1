//! Since the per-field initial `volume_fraction` (Nov 22), the core handed every Eulerian
//! field its initial θ, and the frame took "given a θ" for "fills what the others leave"
//! (region `Rest`), whose θ the core sets each step: no Eulerian field advected its volume
//! fraction any more. A blob of an Eulerian phase in a stream stayed where it started. Now
//! only the field of region `Rest` leaves its θ to the core.
//!
//! The blob: a disk of half volume fraction in a periodic box, carried by a uniform stream
//! U = 1 (both fields move with it; no viscosity, no gravity), for t = 0.25: its centroid
//! moves by U t (the flux form moves the first moment by Δt U Σθ_face per step, the
//! limited face values differing from the cell values by a fraction of the blob's edge),
//! its mass is kept to round-off and its θ stays within [0, 0.5].

use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::simulation::Simulation;
use std::path::Path;

#[test]
fn an_eulerian_blob_moves_with_the_stream() {
    multifield::link_all();
    let text = r#"(
        name: "blob", domain: (size: (2.0, 1.0), cells: (64, 32)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 0.25, cfl: 0.4, max_dt: 0.01),
        fields: [
            (name: "blob", density: 1.0, frame: (model: "eulerian"), region: Disk(center: (0.5, 0.5), radius: 0.2),
             volume_fraction: 0.5, velocity: Uniform((1.0, 0.0))),
            (name: "carrier", density: 1.0, frame: (model: "eulerian"), region: Rest, velocity: Uniform((1.0, 0.0))),
        ],
        pressure: Some((model: "pcg")),
    )"#;
    let case = Case::from_ron(text, Path::new("blob.ron")).unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let g = sim.grid.clone();
    let moments = |sim: &Simulation| {
        let theta = &sim.fields[0].state.theta;
        let (mut m, mut mx, mut hi): (Real, Real, Real) = (0.0, 0.0, 0.0);
        for j in 0..g.ny {
            for i in 0..g.nx {
                let t = theta[g.cell(i, j)];
                m += t;
                mx += t * g.cell_center(i, j).x;
                hi = hi.max(t);
            }
        }
        (m, mx / m, hi)
    };
    let mass0 = sim.fields[0].frame.mass();
    // (the grid state holds the θ the first step starts from after it: the centroid of the
    // case's disk is x = 0.5)
    while sim.time < 0.25 - 1e-12 {
        sim.step().unwrap();
    }
    let (_, x1, hi) = moments(&sim);
    let moved = x1 - 0.5;
    assert!((moved - sim.time).abs() < 0.01 * sim.time, "the blob moved {moved}, the stream {}", sim.time);
    let mass = sim.fields[0].frame.mass();
    assert!((mass / mass0 - 1.0).abs() < 1e-12, "mass {mass} against {mass0}");
    assert!(hi <= 0.5 + 1e-12, "θ overshoots: {hi}");
}
