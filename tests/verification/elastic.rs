//! Verification of MPM elasticity: the Lagrangian frame with the `linear_elastic` and
//! `neo_hookean` point-stress models, solids in vacuum (`pressure: None`, no gravity).
//!
//! - **Vibrating bar** (Bardenhagen's test, docs/method.md §7): a bar fixed at x = 0 and free at
//!   x = L = 25, E = 100, ρ = 1, started in its first mode v = v0 sin(βx), β = π/(2L),
//!   v0 = 0.1. The centre-of-mass velocity is v0/(βL) cos(ωt), ω = β sqrt(E/ρ): period 10.
//!   Measured from the zero crossings over two periods, and the drift of the total energy
//!   (kinetic + strain).
//! - **Two elastic disks colliding** (Sulsky, Chen & Schreyer, CMAME 118, 1994): kinetic
//!   energy turns into strain energy during contact and back; the total is conserved.
//!
//! Transfer: FLIP with α = 1 (the original MPM update, Sulsky et al. 1994: the point velocity
//! takes the grid increment, the position the grid velocity). PIC would damp the elastic
//! waves (the bar loses 23 % of its energy in two periods with PIC), which is what these
//! tests measure; APIC with linear shape functions is unstable here (see the report).
//!
//! Measured (cargo test --test verification elastic:: -- --nocapture), h = 0.25 for the bar,
//! 20 × 20 cells for the disks, 2 × 2 points per cell, linear shape functions:
//!   bar, linear_elastic:   period 10.040 (0.40 %), max energy drift 1.9 %
//!   bar, neo_hookean:      period 10.005 (0.05 %), max energy drift 2.8 %
//!   disks, neo_hookean:    max energy drift 3.0 %, min KE 3.7 % of the initial at t ≈ 1.97,
//!                          final KE 91 %, final total 99.6 %
//!   disks, linear_elastic: max energy drift 8.2 % (its small-strain stress is not the
//!                          derivative of its energy at finite strain: the error is O(ε) ≈ 0.1
//!                          at the peak of contact), min KE 2.9 %, final KE 94 %

use multifield_core::case::Case;
use multifield_core::math::Real;
use multifield_core::simulation::Simulation;
use multifield_frames::lagrangian::Lagrangian;
use std::path::Path;

fn link() {
    multifield_frames::link();
    multifield_physics::link();
}

/// One row of the energy and momentum history.
struct Sample {
    t: Real,
    kinetic: Real,
    strain: Real,
    /// Centre-of-mass velocity, x component.
    vx: Real,
}

impl Sample {
    fn total(&self) -> Real {
        self.kinetic + self.strain
    }
}

fn history(case: &Case) -> Vec<Sample> {
    let mut sim = Simulation::new(case).unwrap();
    let sample = |sim: &Simulation| {
        let f = &sim.fields[0];
        let points = f.frame.as_any().downcast_ref::<Lagrangian>().expect("a Lagrangian field");
        Sample {
            t: sim.time,
            kinetic: f.frame.kinetic_energy(),
            strain: points.strain_energy(&f.stress),
            vx: f.frame.momentum().x / f.frame.mass(),
        }
    };
    let mut out = vec![sample(&sim)];
    while sim.time < case.time.end - 1e-12 {
        sim.step().unwrap();
        out.push(sample(&sim));
    }
    out
}

/// Largest |E(t) − E(0)| / E(0) of the total energy.
fn max_energy_drift(s: &[Sample]) -> Real {
    let e0 = s[0].total();
    s.iter().map(|x| (x.total() - e0).abs() / e0).fold(0.0, Real::max)
}

fn bar(model: &str) -> Case {
    // h = 0.25: 100 cells along the bar, 2 across; the domain is 5 longer than the bar
    let text = format!(
        r#"(
        name: "elastic_bar", domain: (size: (30.0, 0.5), cells: (120, 2)),
        boundaries: (left: NoSlip, right: FreeSlip, bottom: FreeSlip, top: FreeSlip),
        time: (end: 20.0, cfl: 0.4, max_dt: 0.1),
        fields: [(
            name: "bar", density: 1.0,
            frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "flip", flip_blend: 1.0)),
            region: Rectangle(min: (0.0, 0.0), max: (25.0, 0.5)),
            velocity: SineX(amplitude: 0.1, wavenumber: {beta}),
            stress: [(model: "{model}", params: (young_modulus: 100.0, poisson_ratio: 0.0))],
        )],
        pressure: None,
    )"#,
        beta = std::f64::consts::PI / 50.0
    );
    Case::from_ron(&text, Path::new("elastic_bar.ron")).unwrap()
}

#[test]
fn vibrating_bar_period_and_energy() {
    link();
    for model in ["linear_elastic", "neo_hookean"] {
        let s = history(&bar(model));
        // v_cm(0) = v0/(βL) = 0.2/π
        assert!((s[0].vx - 0.2 / std::f64::consts::PI).abs() < 1e-3 * s[0].vx, "{}", s[0].vx);
        let crossings: Vec<Real> = s
            .windows(2)
            .filter(|w| w[0].vx > 0.0 && w[1].vx <= 0.0 || w[0].vx < 0.0 && w[1].vx >= 0.0)
            .map(|w| w[0].t + (w[1].t - w[0].t) * w[0].vx / (w[0].vx - w[1].vx))
            .collect();
        assert_eq!(crossings.len(), 4, "{model}: zero crossings {crossings:?} (expected 2.5, 7.5, 12.5, 17.5)");
        let period = 2.0 * (crossings[3] - crossings[0]) / 3.0;
        let drift = max_energy_drift(&s);
        println!(
            "bar {model}: crossings {crossings:.3?}, period {period:.4} (error {:.2} %), max energy drift {:.2} %",
            100.0 * (period / 10.0 - 1.0),
            100.0 * drift
        );
        assert!((period - 10.0).abs() < 0.2, "{model}: period {period}, expected 10 within 2 %");
        assert!(drift < 0.04, "{model}: total energy drifts by {:.2} %", 100.0 * drift);
    }
}

fn disks(model: &str) -> Case {
    // The disks touch the walls of the unit square at t = 0; periodic sides keep a wall node
    // from holding their outer points (the images never meet within the run).
    let text = format!(
        r#"(
        name: "colliding_disks", domain: (size: (1.0, 1.0), cells: (20, 20)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 3.5, cfl: 0.4, max_dt: 0.1),
        fields: [(
            name: "disks", density: 1000.0,
            frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "flip", flip_blend: 1.0)),
            region: Bodies([
                (name: "lower", shape: Disk(center: (0.2, 0.2), radius: 0.2), velocity: (0.1, 0.1)),
                (name: "upper", shape: Disk(center: (0.8, 0.8), radius: 0.2), velocity: (-0.1, -0.1)),
            ]),
            stress: [(model: "{model}", params: (young_modulus: 1000.0, poisson_ratio: 0.3))],
        )],
        pressure: None,
    )"#
    );
    Case::from_ron(&text, Path::new("colliding_disks.ron")).unwrap()
}

#[test]
fn colliding_disks_exchange_kinetic_and_strain_energy() {
    link();
    // (model, bound on the total-energy drift)
    for (model, tolerance) in [("neo_hookean", 0.05), ("linear_elastic", 0.10)] {
        let s = history(&disks(model));
        let (k0, e0) = (s[0].kinetic, s[0].total());
        assert_eq!(s[0].strain, 0.0);
        let min = s.iter().min_by(|a, b| a.kinetic.total_cmp(&b.kinetic)).unwrap();
        let last = s.last().unwrap();
        let drift = max_energy_drift(&s);
        println!(
            "disks {model}: max energy drift {:.2} %, min KE {:.1} % of the initial at t = {:.2} (strain energy then \
             {:.1} %), final KE {:.1} %, final total {:.2} %",
            100.0 * drift,
            100.0 * min.kinetic / k0,
            min.t,
            100.0 * min.strain / e0,
            100.0 * last.kinetic / k0,
            100.0 * last.total() / e0
        );
        assert!(drift < tolerance, "{model}: total energy drifts by {:.2} %", 100.0 * drift);
        // contact: nearly all the kinetic energy is stored as strain energy, at t ≈ 2
        assert!(min.kinetic < 0.1 * k0, "{model}: KE only dips to {:.3} of the initial", min.kinetic / k0);
        assert!(min.strain > 0.8 * e0, "{model}: strain energy at contact {:.3}", min.strain / e0);
        assert!((1.7..2.3).contains(&min.t), "{model}: deepest contact at t = {}", min.t);
        // rebound: the kinetic energy comes back (the rest rings as free vibration)
        assert!(last.kinetic > 0.85 * k0, "{model}: final KE {:.3} of the initial", last.kinetic / k0);
    }
}
