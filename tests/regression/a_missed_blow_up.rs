//! The elastic bar (examples/elastic_bar.ron, no pressure solve) at 10⁶ × its stable step
//! reported `completed` while max |Σθ − 1| reached 99 and the kinetic energy fell to
//! 8e-13 (issue 20): the energy it lost had gone into strain energy nobody counted, and Σθ
//! was watched only in cases with a pressure solve. Every run now watches the mechanical
//! energy (kinetic + strain, `diagnostics.csv`'s `strain_energy`), its collapse in one
//! step, and, without a pressure solve, material packed beyond Σθ = 2.

use crate::hostile_input::{example, scratch};
use multifield::core::case::Case;
use multifield::core::driver::{reference_energy, EnergyCollapse, StopCheck};
use multifield::core::simulation::{Simulation, Status, StepDiagnostics};
use multifield::core::table::Table;
use multifield::run::{run, RunOptions};

fn bar(sets: &[&str]) -> Case {
    let mut all = vec!["output.charts=false".to_string(), "output.snapshots=None".into()];
    all.extend(sets.iter().map(|s| s.to_string()));
    Case::load(&example("elastic_bar.ron"), &all).unwrap()
}

fn unstable(case: &Case, dir: &str) -> (String, u64) {
    let out = run(case, &scratch(dir), &RunOptions::quiet()).unwrap();
    let Status::Unstable(reason) = &out.status else { panic!("{dir}: not unstable: {:?}", out.status) };
    (reason.clone(), out.summary.steps)
}

#[test]
fn a_step_a_million_times_too_long_is_a_blow_up() {
    multifield::link_all();
    // Δt = 10⁴ (the stable step is 9.9e-3): the first step puts 4.18e4 into strain energy,
    // above 10⁶ × the initial 3.125e-2, while the kinetic energy falls to 4e-7
    let (reason, steps) = unstable(&bar(&["time.fixed_dt=Some(10000.0)", "time.end=100000"]), "million");
    assert_eq!(steps, 1, "{reason}");
    assert!(
        reason.starts_with("mechanical energy 4.182353566897338e4 (kinetic 4.0473100717951e-7, strain 4.18235"),
        "{reason}"
    );
    assert!(reason.contains("exceeds the bound 3.1250000000000007e4"), "{reason}");

    // Δt = 10 (10³ ×): the energy stays below the bound, but by step 3 one cell holds 87×
    // the material it has room for
    let (reason, steps) = unstable(&bar(&["time.fixed_dt=Some(10.0)", "time.end=1000"]), "thousand");
    assert_eq!(steps, 3, "{reason}");
    assert!(reason.starts_with("max Σθ = 8.7406e1 at step 3, t = 30:"), "{reason}");
    assert!(reason.contains("coupling.max_volume_fraction_error = 1"), "{reason}");

    // the bar at its stable step completes: max Σθ stays at 1.0076 and no step loses energy
    let dir = scratch("stable");
    let out = run(&bar(&["time.end=5"]), &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.status, Status::Completed, "{:?}", out.status);
    let table = Table::read(&dir.join("diagnostics.csv")).unwrap().unwrap();
    let column = |name: &str| table.numbers(name).unwrap();
    let (ke, se, theta) = (column("kinetic_energy"), column("strain_energy"), column("max_volume_fraction"));
    let max_theta = theta.iter().copied().fold(0.0, f64::max);
    assert!((1.0..1.01).contains(&max_theta), "{max_theta}");
    // the vibration trades kinetic for strain energy: their sum stays within 2 % of the start
    for (k, s) in ke.iter().zip(&se) {
        let e = k + s;
        assert!((e / 0.03125 - 1.0).abs() < 0.02, "mechanical energy {e}");
    }
    assert!(se.iter().copied().fold(0.0, f64::max) > 0.5 * 0.03125, "the strain energy is counted");
}

#[test]
fn a_collapse_of_the_mechanical_energy_in_one_step_is_a_blow_up() {
    multifield::link_all();
    let sim = Simulation::new(&bar(&[])).unwrap();
    let step = |step: u64, kinetic: f64, strain: f64| StepDiagnostics {
        step,
        time: 0.01 * step as f64,
        dt: 0.01,
        dt_limit: "fixed".into(),
        kinetic_energy: kinetic,
        strain_energy: strain,
        ..Default::default()
    };
    let mut check = EnergyCollapse::of(&sim);
    assert_eq!(check.previous, sim.initial_energy);
    assert!((check.previous / 0.03125 - 1.0).abs() < 1e-14);
    // kinetic energy turned into strain energy is no loss
    assert_eq!(check.check(&sim, &step(1, 1e-12, 0.031)), None);
    // a fall by 10⁵ in one step is judged dissipation; by more than 10⁶, a collapse
    assert_eq!(check.check(&sim, &step(2, 3.1e-7, 0.0)), None);
    let reason = check.check(&sim, &step(3, 3.0e-13, 0.0)).expect("a collapse by 1.03e6");
    assert!(
        reason.starts_with("mechanical energy (kinetic + strain) collapsed from 3.1e-7 to 3e-13 in step 3"),
        "{reason}"
    );
    // energies at the round-off of a state at rest (below 10⁻¹² × the reference energy)
    // are not judged
    let mut check = EnergyCollapse::of(&sim);
    assert_eq!(check.floor, 1e-12 * reference_energy(&sim));
    check.previous = 0.9 * check.floor;
    assert_eq!(check.check(&sim, &step(4, 0.0, 0.0)), None);
}
