//! Taichi's mpm88 scene (`examples/mpm88.ron`): a weakly compressible fluid on material
//! points with no pressure solve. Past the first impact the flow stretches F without
//! bound; with the full F, det F lost its precision and the run went NaN at step 1,471.
//! The frame keeps F = diag(J, 1) for a `volumetric_only` model: the run stays finite,
//! and the mechanical energy KE + Σ m g y never grows (APIC and the impact dissipate,
//! the equation of state stores ψ(J) ≥ 0), while mass is conserved exactly.

use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::simulation::Simulation;
use multifield::frames::lagrangian::Lagrangian;
use std::path::Path;

#[test]
fn the_mpm88_fluid_stays_finite_and_loses_mechanical_energy() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mpm88.ron");
    let case = Case::load(&file, &["time.end=0.32".into()]).unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let g = 9.8;
    let energy = |sim: &Simulation| {
        let f = sim.fields[0].frame.as_any().downcast_ref::<Lagrangian>().unwrap();
        let p = &f.points;
        let potential: Real = p.m.iter().zip(&p.x).map(|(m, x)| m * g * x.y).sum();
        let mass: Real = p.m.iter().sum();
        let j =
            p.f.iter().map(|f| f.determinant()).fold((Real::INFINITY, 0.0 as Real), |(a, b), j| (a.min(j), b.max(j)));
        (sim.kinetic_energy() + potential, mass, j)
    };
    let (e0, m0, _) = energy(&sim);
    let mut worst_gain: Real = Real::NEG_INFINITY;
    let mut j_range: (Real, Real) = (Real::INFINITY, 0.0);
    while sim.time < 0.32 - 1e-9 {
        sim.step().unwrap();
        let (e, m, j) = energy(&sim);
        assert!(e.is_finite(), "non-finite energy at step {}", sim.steps);
        assert_eq!(m, m0, "mass changed at step {}", sim.steps);
        worst_gain = worst_gain.max((e - e0) / e0);
        j_range = (j_range.0.min(j.0), j_range.1.max(j.1));
    }
    eprintln!("steps {}, largest relative gain of KE + PE {worst_gain:e}, J in {j_range:?}", sim.steps);
    assert!(sim.steps >= 1600, "{} steps: past the step (1,471) where the full F broke down", sim.steps);
    assert!(worst_gain < 1e-3, "mechanical energy grew by {worst_gain:e} of its initial value");
    // the bulk stays nearly incompressible (c = sqrt(E/ρ) = 20 against speeds of ~1–3);
    // a few points pinned to a wall (sampling zero normal velocity) reach the extremes
    let f = sim.fields[0].frame.as_any().downcast_ref::<Lagrangian>().unwrap();
    let mut dev: Vec<Real> = f.points.f.iter().map(|f| (f.determinant() - 1.0).abs()).collect();
    dev.sort_by(Real::total_cmp);
    let (p50, p90) = (dev[dev.len() / 2], dev[dev.len() * 9 / 10]);
    eprintln!("|J − 1| at the end: median {p50:.4}, 90th percentile {p90:.4}");
    // measured: median 0.0075 (the hydrostatic ρgH/E at the bottom of the 0.25-deep pool is
    // 0.006), 90th percentile 0.040, J in [0.20, 1.41] over the run; energy gain at most
    // −5.2e-7 (it only falls). With J from the MUSL re-projection (before J came from the
    // transfer's own ∇v): median 0.0074, 90th percentile 0.053, J in [0.31, 1.91].
    assert!(p50 < 0.015 && p90 < 0.1, "|J − 1|: median {p50}, 90th percentile {p90}");
}
