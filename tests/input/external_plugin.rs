//! The power-law plugin defined outside multifield's crates (examples/plugins/power_law):
//! it registers once linked, reproduces the Newtonian model at n = 1, and gives the flatter
//! channel profile of a shear-thinning fluid at n = 0.5.

use multifield::core::case::Case;
use multifield::core::registry::{entries, Role};
use multifield::core::simulation::Simulation;
use std::path::Path;

const CASE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/plugins/power_law/channel.ron");

fn link() {
    multifield::link_all();
    multifield_power_law::link();
}

/// Runs the channel to `time.end` with `overrides`; returns the x-velocity averaged along x
/// in each row of cells (bottom to top).
fn profile(overrides: &[&str]) -> Vec<f64> {
    row_means(&run(overrides))
}

/// The channel run to `time.end` with `overrides`.
fn run(overrides: &[&str]) -> Simulation {
    link();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let case = Case::load(Path::new(CASE), &overrides).expect("valid case");
    let mut sim = Simulation::new(&case).expect("builds");
    while sim.time < case.time.end * (1.0 - 1e-12) {
        let d = sim.step().expect("steps");
        assert!(d.kinetic_energy.is_finite(), "blew up at step {}", d.step);
    }
    sim
}

fn row_means(sim: &Simulation) -> Vec<f64> {
    let g = &sim.grid;
    let u = &sim.fields[0].state.velocity.u;
    (0..g.ny).map(|j| (0..g.nx).map(|i| u[g.xface(i, j)]).sum::<f64>() / g.nx as f64).collect()
}

fn mean_over_max(p: &[f64]) -> f64 {
    let max = p.iter().cloned().fold(f64::MIN, f64::max);
    p.iter().sum::<f64>() / p.len() as f64 / max
}

#[test]
fn the_plugin_registers_once_linked() {
    link();
    let e = entries(Role::Stress).into_iter().find(|e| e.name == "power_law").expect("power_law is registered");
    let names: Vec<&str> = e.params.iter().map(|p| p.name).collect();
    assert_eq!(names, ["consistency", "index", "max_viscosity", "safety"]);
}

#[test]
fn index_one_reproduces_the_newtonian_model() {
    let set =
        ["time.end=1.0", "fields.fluid.stress.0.params.index=1.0", "fields.fluid.stress.0.params.max_viscosity=0.2"];
    let power_law = profile(&set);
    // the power law is explicit: so must the Newtonian model be here (the Eulerian frame
    // integrates a Newtonian viscosity by Crank–Nicolson by default)
    let newtonian = profile(&[
        "time.end=1.0",
        "fields.fluid.stress.0=(model: \"newtonian\", params: (viscosity: 0.2, safety: 0.9))",
        "fields.fluid.frame.params.diffusion=\"explicit\"",
    ]);
    let scale = newtonian.iter().fold(0.0_f64, |m, u| m.max(u.abs()));
    assert!(scale > 0.3, "the flow developed: max u = {scale}");
    let diff = power_law.iter().zip(&newtonian).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff < 1e-10 * scale, "power_law(n = 1) − newtonian = {diff:e} (max u {scale})");
}

#[test]
fn shear_thinning_flattens_the_channel_profile() {
    // Steady analytic values (the power-law flow settles more slowly: t = 15 vs 5): Newtonian (n = 1, μ = k = 0.2) u_max = ρgH²/(8μ) = 0.625 and
    // mean/max = 2/3; n = 0.5: u_max = n/(n+1) (ρg/k)^(1/n) (H/2)^(1+1/n) = 1.0417 and
    // mean/max = (n+1)/(2n+1) = 0.75 (the cap μ_max = 1 binds only where γ̇ < 0.04).
    // Row means at cell centres: the discrete mean/max on 16 rows differs from the
    // continuous one by O(h²).
    let newtonian = profile(&["time.end=5.0", "fields.fluid.stress.0.params.index=1.0"]);
    let sim = run(&[]);
    let thinning = row_means(&sim);
    let (rn, rt) = (mean_over_max(&newtonian), mean_over_max(&thinning));
    let (un, ut) = (newtonian.iter().cloned().fold(0.0, f64::max), thinning.iter().cloned().fold(0.0, f64::max));
    println!("newtonian: u_max {un:.4}, mean/max {rn:.4}; power law n = 0.5: u_max {ut:.4}, mean/max {rt:.4}");
    assert!((un - 0.625).abs() < 0.01 * 0.625, "Newtonian u_max {un} vs 0.625");
    assert!((rn - 2.0 / 3.0).abs() < 0.01, "Newtonian mean/max {rn} vs 2/3");
    assert!((ut - 1.0417).abs() < 0.015 * 1.0417, "power-law u_max {ut} vs 1.0417");
    assert!((rt - 0.75).abs() < 0.015, "power-law mean/max {rt} vs 0.75");
    assert!(rt > rn + 0.07, "the shear-thinning profile is flatter: mean/max {rt} vs {rn}");
    for (a, b) in thinning.iter().zip(thinning.iter().rev()) {
        assert!((a - b).abs() < 1e-6 * ut, "asymmetric profile: {a} vs {b}");
    }
}

/// The plugin's output quantity, computed through the registry as a snapshot computes it,
/// against the steady power-law flow's shear rate γ̇ = |du/dy| = (ρg/k)^(1/n) |y − H/2|^(1/n)
/// = 25 (y − 1/2)² (n = 0.5, k = 0.2, ρg = 1), away from the walls, where the
/// differences are one-sided.
#[test]
fn the_plugin_quantity_is_listed_and_gives_the_shear_rate() {
    use multifield::core::quantity::{find, quantities, Place, Sample};
    link();
    assert!(quantities().iter().any(|q| q.name == "shear_rate"), "listed by `multifield quantities`");
    let q = find("shear_rate", Place::Field).expect("a field quantity");
    assert!(find("shear_rate", Place::Mixture).is_err(), "no mixture form");
    let sim = run(&[]);
    let g = &sim.grid;
    let rate = Sample::of(&sim).cells(q, Some(0)).unwrap();
    let mut worst: f64 = 0.0;
    for j in 2..g.ny - 2 {
        let y = g.origin.y + (j as f64 + 0.5) * g.h;
        let exact = 25.0 * (y - 0.5) * (y - 0.5);
        for i in 0..g.nx {
            worst = worst.max((rate[g.cell(i, j)] - exact).abs());
        }
    }
    // the peak is 25 (1/2 − 2.5 h)² = 15.3; a central difference over 2h of the cubic
    // u(y) errs by h² u‴/6 = 50 h²/6 = 0.033, and the discrete profile by about as much
    println!("shear rate: worst error {worst:.4} against 25 (y − 1/2)² (peak 15.3)");
    assert!(worst < 0.1, "shear rate off by {worst}");
    // and it goes into a snapshot under its name, with its units
    let spec = multifield::core::case::SnapshotSpec {
        fields: vec![multifield::core::case::QuantityName("shear_rate".into())],
        ..multifield::core::case::SnapshotSpec::every(1.0)
    };
    let snap = multifield::snapshot::Snapshot::with(&sim, &spec).unwrap();
    assert_eq!(snap.fields[0].cells.keys().collect::<Vec<_>>(), ["shear_rate"]);
    assert_eq!(snap.fields[0].get("shear_rate").unwrap(), rate.as_slice());
}
