//! A rigid body that reached a periodic side left the domain silently (its points are not
//! wrapped), and a direct forcing then dropped its markers. Now the run stops with an error
//! naming the body, the side and the fix.

use multifield::core::case::Case;
use multifield::core::simulation::Simulation;

fn assert_contains(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "message lacks `{p}`:\n{message}");
    }
}

/// A rigid body that reaches a periodic side stops the run with an error naming the body
/// and the side (its points are not wrapped: it used to leave the domain silently, and a
/// direct forcing then dropped its markers).
#[test]
fn a_rigid_body_left_the_domain_through_a_periodic_side_silently() {
    multifield::link_all();
    let text = r#"(
        name: "crossing",
        domain: (size: (1.0, 1.0), cells: (16, 16)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 1.0, cfl: 0.4, max_dt: 0.01),
        fields: [
            (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: 0.01))]),
            (name: "disks", density: 1.5, frame: (model: "lagrangian"), stress: [(model: "rigid")],
             region: Bodies([(name: "d", shape: Disk(center: (0.5, 0.5), radius: 0.1),
                              motion: Prescribed(velocity: (0.0, -1.0)))])),
        ],
        exchange: [(between: ("water", "disks"), model: "no_slip")],
        pressure: Some((model: "pcg")),
    )"#;
    let case = Case::from_ron(text, std::path::Path::new("crossing.ron")).expect("valid case");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let (time, e) = pool.install(|| {
        let mut sim = Simulation::new(&case).expect("builds");
        loop {
            if let Err(e) = sim.step() {
                return (sim.time, e.to_string());
            }
            assert!(sim.time < 1.0, "the body crossed y = 0 without an error");
        }
    });
    // the lowest points, 0.4 + 1/64 (half the 2-per-cell spacing) high, pass y = 0 in the
    // step of Δt = 0.01 that ends after t = 0.4156
    assert!((0.4156..0.4257).contains(&time), "stopped at t = {time}");
    assert_contains(&e, &["rigid body `d` reached the periodic low y side (y = 0)", "lengthen the domain along y"]);
}
