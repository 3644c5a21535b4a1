//! A decomposed run (issue 19, docs/design/mpi.md) gives the serial run's bits: the
//! Taylor–Green vortex at 64² on 1, 2, 3 and 4 ranks (as threads of this process with the
//! in-process `fake` communicator; `tests/mpi` runs the same under `mpirun`), 20 steps of
//! the Eulerian frame with Crank–Nicolson viscosity and the PCG (Jacobi, and the multigrid
//! V-cycle on the gathered residual).
//! Every step's diagnostics on every rank, and at the end every owned node of θ, u, v and
//! p and every array of the snapshot gathered from the ranks (the cell quantities of the
//! mixture and of each field: pressure, velocity, vorticity, θ, … and the face
//! velocities), equal the serial run's to the bit; the ranks' owned nodes cover the domain
//! once.

use multifield::snapshot::Snapshot;
use multifield_core::case::{Case, SnapshotSpec};
use multifield_core::grid::{Grid, Lattice};
use multifield_core::math::{Real, AXES, DIM};
use multifield_core::parallel::{fake, Comm};
use multifield_core::simulation::{Simulation, StepDiagnostics};
use std::path::Path;
use std::sync::Arc;

const STEPS: usize = 20;

fn taylor_green(extra: &str) -> Case {
    let text = format!(
        r#"(
        name: "taylor_green_ranks",
        domain: (size: (6.283185307179586, 6.283185307179586), cells: (64, 64)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 2.0, cfl: 0.4, max_dt: 0.05),
        fields: [(name: "fluid", density: 1.0, frame: (model: "eulerian"), region: All,
                  velocity: TaylorGreen(amplitude: 1.0),
                  stress: [(model: "newtonian", params: (viscosity: 0.01))])],
        pressure: Some((model: "pcg", params: (preconditioner: "jacobi"))),
        {extra}
    )"#
    );
    Case::from_ron(&text, Path::new("taylor_green_ranks.ron")).unwrap()
}

/// Every figure of a step, as bits.
fn bits(d: &StepDiagnostics) -> Vec<u64> {
    let mut v = vec![d.step, d.time.to_bits(), d.dt.to_bits(), d.kinetic_energy.to_bits(), d.mass.to_bits()];
    v.extend(d.momentum.iter().map(|m| m.to_bits()));
    v.extend(
        [d.max_speed, d.max_divergence, d.volume_fraction_error, d.max_volume_fraction, d.pressure_residual]
            .map(Real::to_bits),
    );
    v.push(d.pressure_iterations as u64);
    v
}

/// The arrays compared at the end: θ, u, v, p.
fn arrays(sim: &Simulation) -> Vec<(Lattice, Vec<Real>)> {
    let s = &sim.fields[0].state;
    let mut out = vec![(Lattice::Cell, s.theta.clone())];
    out.extend(AXES.map(|a| (Lattice::face(a), s.velocity[a].clone())));
    out.push((Lattice::Cell, sim.pressure.clone()));
    out
}

/// The owned nodes of a lattice on `grid`: (storage index, global index in the domain).
fn owned(grid: &Grid, lattice: Lattice, periodic: [bool; DIM]) -> Vec<(usize, usize)> {
    let domain = Grid::from_cells(grid.domain, grid.h, grid.origin);
    grid.groups(lattice)
        .rows()
        .flatten()
        .map(|k| {
            let at = grid.node(lattice, k);
            // global indices wrap on a periodic axis (face n is face 0)
            let g: [usize; DIM] = std::array::from_fn(|a| {
                let g = at[a] as isize + grid.start[a];
                if periodic[a] {
                    g.rem_euclid(grid.domain[a] as isize) as usize
                } else {
                    g as usize
                }
            });
            (k, domain.index(lattice, g))
        })
        .collect()
}

struct RankRun {
    diagnostics: Vec<Vec<u64>>,
    /// Every array of the snapshot (gathered from the ranks), as bits, by name.
    snapshot: Vec<(String, Vec<u64>)>,
    /// Per array: (global index, value bits) of the owned nodes.
    owned: Vec<Vec<(usize, u64)>>,
    rank_grid: Option<Vec<usize>>,
}

/// Every array of the snapshot of `sim` (gathered from the ranks), as bits, by name.
fn snapshot_bits(sim: &Simulation) -> Vec<(String, Vec<u64>)> {
    let spec = SnapshotSpec { faces: true, ..SnapshotSpec::every(1.0) };
    let snap = Snapshot::with(sim, &spec).unwrap().gathered(&sim.grid);
    let bits = |a: &[Real]| a.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let mut snapshot: Vec<(String, Vec<u64>)> = snap.cells.iter().map(|(k, v)| (k.clone(), bits(v))).collect();
    for f in &snap.fields {
        snapshot.extend(f.cells.iter().map(|(k, v)| (format!("{}/{k}", f.name), bits(v))));
        for (a, v) in f.faces.iter().flatten().enumerate() {
            snapshot.push((format!("{}/faces/{a}", f.name), bits(v)));
        }
    }
    snapshot.push(("cells".into(), vec![snap.nx as u64, snap.ny as u64]));
    snapshot
}

fn run_on(sim: &mut Simulation) -> RankRun {
    // the initial state's snapshot (computed from the case at step 0) and the last one's
    let mut snapshot: Vec<(String, Vec<u64>)> =
        snapshot_bits(sim).into_iter().map(|(k, v)| (format!("t = 0: {k}"), v)).collect();
    let diagnostics = (0..STEPS).map(|_| bits(&sim.step().unwrap())).collect();
    let owned = arrays(sim)
        .iter()
        .map(|(lattice, a)| {
            let periodic = sim.case.boundaries.periodic_axes();
            owned(&sim.grid, *lattice, periodic).into_iter().map(|(k, g)| (g, a[k].to_bits())).collect()
        })
        .collect();
    let rank_grid = sim.grid.part.block().map(|(g, _)| g.p.to_vec());
    snapshot.extend(snapshot_bits(sim));
    RankRun { diagnostics, snapshot, owned, rank_grid }
}

/// Runs `case` serially and on each of `ranks` (with the rank grid expected) in-process,
/// and asserts the serial bits everywhere (see the module's documentation).
fn check(case: &Case, ranks: &[(usize, Option<Vec<usize>>)]) -> Simulation {
    let mut serial = Simulation::new(case).unwrap();
    let reference = run_on(&mut serial);
    let domain = Grid::from_cells(serial.grid.n(), serial.grid.h, serial.grid.origin);
    let periodic = case.boundaries.periodic_axes();
    for (ranks, expected) in ranks.iter().cloned() {
        let runs: Vec<RankRun> = std::thread::scope(|s| {
            let handles: Vec<_> = fake::world(ranks)
                .into_iter()
                .map(|c| {
                    s.spawn(move || {
                        let comm: Arc<dyn Comm> = Arc::new(c);
                        run_on(&mut Simulation::with_comm(case, comm).unwrap())
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for (r, run) in runs.iter().enumerate() {
            assert_eq!(run.rank_grid, expected, "{ranks} ranks: the rank grid");
            for (step, (d, e)) in run.diagnostics.iter().zip(&reference.diagnostics).enumerate() {
                assert_eq!(d, e, "{ranks} ranks, rank {r}: the diagnostics of step {}", step + 1);
            }
            assert_eq!(run.snapshot.len(), reference.snapshot.len());
            for ((name, a), (_, b)) in run.snapshot.iter().zip(&reference.snapshot) {
                assert!(a == b, "{ranks} ranks, rank {r}: the snapshot's {name} differs from the serial one");
            }
        }
        for (k, serial_owned) in reference.owned.iter().enumerate() {
            let lattice = arrays(&serial)[k].0;
            let mut seen = vec![0; domain.shape(lattice).iter().product()];
            let values: std::collections::HashMap<usize, u64> = serial_owned.iter().copied().collect();
            for run in &runs {
                for &(g, v) in &run.owned[k] {
                    seen[g] += 1;
                    assert_eq!(v, values[&g], "{ranks} ranks: array {k} at global node {g}");
                }
            }
            // every node of the domain owned, once on several ranks (one rank's storage is
            // the serial one, with face n of a periodic axis, face 0's copy)
            let shape = domain.shape(lattice);
            let n = domain.n();
            for (g, at) in domain.nodes(lattice).filter(|(_, at)| AXES.iter().all(|&a| at[a] < n[a] || !periodic[a])) {
                assert!(at[0] < shape[0]);
                assert!(seen[g] >= 1, "{ranks} ranks: array {k}'s node {at:?} owned by nobody");
                assert!(ranks == 1 || seen[g] == 1, "{ranks} ranks: array {k}'s node {at:?} owned twice");
            }
        }
    }
    serial
}

#[test]
fn taylor_green_on_one_to_four_ranks_gives_the_serial_bits() {
    let case = taylor_green("");
    let serial = check(&case, &[(1, None), (2, Some(vec![1, 2])), (3, Some(vec![1, 3])), (4, Some(vec![2, 2]))]);
    // the vortex decays (the run is not trivially at rest)
    let ke0 = serial.initial_energy;
    assert!(serial.last.kinetic_energy < 0.999 * ke0 && serial.last.kinetic_energy > 0.9 * ke0);
}

/// Walls, a moving lid and face n owned by the last block along each axis: the
/// lid-driven cavity at 64² (Re 100) on 2 × 2 and 1 × 3 ranks.
#[test]
fn lid_driven_cavity_on_ranks_gives_the_serial_bits() {
    let text = r#"(
        name: "cavity_ranks", domain: (size: (1.0, 1.0), cells: (64, 64)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: Velocity(velocity: (1.0, 0.0))),
        time: (end: 10.0, cfl: 0.4, max_dt: 0.05),
        fields: [(name: "fluid", density: 1.0, frame: (model: "eulerian"), region: All,
                  stress: [(model: "newtonian", params: (viscosity: 0.01))])],
        pressure: Some((model: "pcg", params: (tolerance: 1e-8, preconditioner: "jacobi"))),
    )"#;
    let case = Case::from_ron(text, Path::new("cavity_ranks.ron")).unwrap();
    let serial = check(&case, &[(3, Some(vec![1, 3])), (4, Some(vec![2, 2]))]);
    // the lid has set the fluid moving
    assert!(serial.last.kinetic_energy > 1e-3, "{}", serial.last.kinetic_energy);
}

/// Two interpenetrating Eulerian fields with a constant exchange coefficient (the one of
/// `Rest` taking what the other leaves), periodic, at 64² on 2 × 2 ranks.
#[test]
fn two_field_exchange_box_on_ranks_gives_the_serial_bits() {
    let text = r#"(
        name: "exchange_box_ranks", domain: (size: (1.0, 1.0), cells: (64, 64)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 1.0, cfl: 0.4, max_dt: 0.002),
        fields: [
            (name: "a", density: 1.0, frame: (model: "eulerian"), region: Disk(center: (0.5, 0.5), radius: 0.3),
             volume_fraction: 0.5, velocity: Uniform((1.0, 0.5))),
            (name: "b", density: 2.0, frame: (model: "eulerian"), region: Rest, velocity: Uniform((-1.0, 0.0))),
        ],
        exchange: [(between: ("a", "b"), model: "constant", params: (coefficient: 50.0))],
        pressure: Some((model: "pcg", params: (tolerance: 1e-10, preconditioner: "jacobi"))),
    )"#;
    let case = Case::from_ron(text, Path::new("exchange_box_ranks.ron")).unwrap();
    let serial = check(&case, &[(4, Some(vec![2, 2]))]);
    // the exchange has slowed the slip: momentum conserved, kinetic energy dissipated
    assert!(serial.last.kinetic_energy < 0.99 * serial.initial_energy);
}

/// The default pressure solver, PCG with the multigrid V-cycle (on the gathered residual,
/// whole on every rank), on the vortex: 2 × 2 and 1 × 3 ranks.
#[test]
fn multigrid_pcg_on_ranks_gives_the_serial_bits() {
    let case = taylor_green("");
    let mut case = case;
    case.pressure.as_mut().unwrap().params = serde_json::json!({ "preconditioner": "multigrid" });
    let serial = check(&case, &[(3, Some(vec![1, 3])), (4, Some(vec![2, 2]))]);
    assert!(serial.last.pressure_iterations > 0);
}

/// An inflow with a parabolic profile (fractions along the side by global index), an
/// outflow that fixes the pressure on the ranks at the right side only (the gathered
/// problem's Dirichlet side), walls: the Poiseuille channel at 64 × 16 on 2 × 1 and 2 × 2
/// ranks, with the multigrid PCG.
#[test]
fn channel_with_inflow_and_outflow_on_ranks_gives_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/poiseuille_channel.ron");
    let case = Case::load(&path, &[]).unwrap();
    let serial = check(&case, &[(2, Some(vec![2, 1])), (4, Some(vec![2, 2]))]);
    // fully developed: the outflow carries the inflow's flux (mass of the water constant)
    assert!(serial.last.max_divergence < 1e-6, "{}", serial.last.max_divergence);
}

/// The whole-domain pressure solvers on ranks, each on the gathered problem on every
/// rank: the direct `cholesky` on the cavity (walls: a singular problem) on 2 × 2 ranks,
/// the `multigrid` solver (V-cycles to tolerance) on 1 × 3.
#[test]
fn whole_domain_pressure_solvers_on_ranks_give_the_serial_bits() {
    for (model, ranks) in [("cholesky", (4, vec![2, 2])), ("multigrid", (3, vec![1, 3]))] {
        let text = format!(
            r#"(
            name: "cavity_{model}", domain: (size: (1.0, 1.0), cells: (64, 64)),
            boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: Velocity(velocity: (1.0, 0.0))),
            time: (end: 10.0, cfl: 0.4, max_dt: 0.05),
            fields: [(name: "fluid", density: 1.0, frame: (model: "eulerian"), region: All,
                      stress: [(model: "newtonian", params: (viscosity: 0.01))])],
            pressure: Some((model: "{model}")),
        )"#
        );
        let case = Case::from_ron(&text, Path::new("cavity.ron")).unwrap();
        let serial = check(&case, &[(ranks.0, Some(ranks.1))]);
        assert!(serial.last.max_divergence < 1e-6, "{model}: {}", serial.last.max_divergence);
    }
}

/// The explicit viscous stencil (`diffusion: "explicit"`: the `newtonian` stress's own
/// stencil on the grid, after a halo exchange of u*) on 2 × 2 ranks.
#[test]
fn explicit_viscosity_on_ranks_gives_the_serial_bits() {
    let mut case = taylor_green("");
    case.fields[0].frame.params = serde_json::json!({ "diffusion": "explicit" });
    let serial = check(&case, &[(4, Some(vec![2, 2]))]);
    assert!(serial.last.kinetic_energy < 0.999 * serial.initial_energy);
}
