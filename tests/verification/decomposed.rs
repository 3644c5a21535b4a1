//! A decomposed run (issue 19, docs/design/mpi.md) gives the serial run's bits: the
//! Taylor–Green vortex at 64² on 1, 2, 3 and 4 ranks (as threads of this process with the
//! in-process `fake` communicator; `tests/mpi` runs the same under `mpirun`), 20 steps of
//! the Eulerian frame with Crank–Nicolson viscosity and the PCG (Jacobi, and the multigrid
//! V-cycle with its finest level on the blocks).
//! Every step's diagnostics on every rank, and at the end every owned node of θ, u, v and
//! p and every array of the snapshot gathered from the ranks (the cell quantities of the
//! mixture and of each field: pressure, velocity, vorticity, θ, … and the face
//! velocities), equal the serial run's to the bit; the ranks' owned nodes cover the domain
//! once.

use multifield::snapshot::Snapshot;
use multifield_core::case::{Case, SnapshotSpec};
use multifield_core::grid::{Grid, Lattice};
use multifield_core::math::{Real, Vector, AXES, DIM};
use multifield_core::parallel::{fake, Comm};
use multifield_core::simulation::{Simulation, StepDiagnostics};
use multifield_frames::lagrangian::Lagrangian;
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

/// Every body's state (position, velocity, rotation, force, torque), as bits.
fn body_bits(sim: &Simulation) -> Vec<u64> {
    let mut out = Vec::new();
    for f in &sim.fields {
        for b in f.frame.body_states() {
            out.extend([b.position.x, b.position.y, b.velocity.x, b.velocity.y].map(Real::to_bits));
            out.extend([b.angular_velocity, b.force.x, b.force.y, b.torque, b.mass, b.inertia].map(Real::to_bits));
        }
    }
    out
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
        // a Lagrangian field's points, every rank's in id order
        if let Some(p) = &f.points {
            snapshot.extend(p.values.iter().map(|(k, v)| (format!("{}/points/{k}", f.name), bits(v))));
            snapshot.push((format!("{}/points/body", f.name), p.body.iter().map(|&b| b as u64).collect()));
        }
    }
    snapshot.push(("cells".into(), vec![snap.nx as u64, snap.ny as u64]));
    snapshot
}

fn run_on(sim: &mut Simulation) -> RankRun {
    // the initial state's snapshot (computed from the case at step 0) and the last one's
    let mut snapshot: Vec<(String, Vec<u64>)> =
        snapshot_bits(sim).into_iter().map(|(k, v)| (format!("t = 0: {k}"), v)).collect();
    let diagnostics = (0..STEPS)
        .map(|_| {
            let mut b = bits(&sim.step().unwrap());
            b.extend(body_bits(sim));
            b
        })
        .collect();
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

/// `f` on each of `n` in-process ranks (threads), by rank.
fn on_ranks<R: Send>(n: usize, f: impl Fn(Arc<dyn Comm>) -> R + Sync) -> Vec<R> {
    std::thread::scope(|s| {
        let f = &f;
        let handles: Vec<_> = fake::world(n).into_iter().map(|c| s.spawn(move || f(Arc::new(c)))).collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// Runs `case` serially and on each of `ranks` (with the rank grid expected) in-process,
/// and asserts the serial bits everywhere (see the module's documentation).
fn check(case: &Case, ranks: &[(usize, Option<Vec<usize>>)]) -> Simulation {
    let mut serial = Simulation::new(case).unwrap();
    let reference = run_on(&mut serial);
    let domain = Grid::from_cells(serial.grid.n(), serial.grid.h, serial.grid.origin);
    let periodic = case.boundaries.periodic_axes();
    for (ranks, expected) in ranks.iter().cloned() {
        let runs = on_ranks(ranks, |comm| run_on(&mut Simulation::with_comm(case, comm).unwrap()));
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
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cases/exchange_box.ron");
    let case = Case::load(&path, &[]).unwrap();
    let serial = check(&case, &[(4, Some(vec![2, 2]))]);
    // the exchange has slowed the slip: momentum conserved, kinetic energy dissipated
    assert!(serial.last.kinetic_energy < 0.99 * serial.initial_energy);
}

/// The default pressure solver, PCG with the multigrid V-cycle (its finest level relaxed and
/// restricted on each block, the coarser levels whole on every rank), on the vortex:
/// 1 × 3 and 2 × 2 ranks (the periodic wraps cuts along y, and along x on 2 × 2).
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

/// The other pressure solvers on ranks on the cavity (walls: a singular problem): the
/// direct `cholesky` on the gathered problem on every rank, on 2 × 2 ranks; the
/// `multigrid` solver (V-cycles to tolerance, the V-cycle's levels on the blocks as the
/// PCG's) on 1 × 3 (cuts at 20 and 44: two levels on the blocks) and 2 × 2 (four).
#[test]
fn other_pressure_solvers_on_ranks_give_the_serial_bits() {
    for (model, ranks) in
        [("cholesky", vec![(4, Some(vec![2, 2]))]), ("multigrid", vec![(3, Some(vec![1, 3])), (4, Some(vec![2, 2]))])]
    {
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
        let serial = check(&case, &ranks);
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

/// A Lagrangian field (material points, APIC on the quadratic B-spline, the
/// `taylor_green_flip` example at 64²) on 1 to 4 ranks: the points migrate between the
/// blocks every step, and each rank's scatter reads its points and the neighbours' within
/// two cells; the snapshot's point arrays are every rank's in id order.
#[test]
fn taylor_green_on_material_points_on_ranks_gives_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green_flip.ron");
    let case = Case::load(&path, &["domain.cells=(64, 64)".into()]).unwrap();
    let serial = check(&case, &[(1, None), (2, Some(vec![1, 2])), (3, Some(vec![1, 3])), (4, Some(vec![2, 2]))]);
    let ke0 = serial.initial_energy;
    assert!(serial.last.kinetic_energy < 0.999 * ke0 && serial.last.kinetic_energy > 0.9 * ke0);
}

/// An MPM solid (linear elastic, FLIP on the linear shape: the MUSL update of F, a second
/// scatter and gather a step) at walls: the `elastic_bar` example on 2 and 3 ranks along x.
#[test]
fn elastic_bar_on_ranks_gives_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/elastic_bar.ron");
    // (four cells across: a block's least; the bar keeps its half of the height)
    let taller = ["domain.size=(30.0, 1.0)".to_string(), "domain.cells=(120, 4)".to_string()];
    let case = Case::load(&path, &taller).unwrap();
    let serial = check(&case, &[(2, Some(vec![2, 1])), (3, Some(vec![3, 1]))]);
    assert!(serial.last.strain_energy > 0.0);
}

/// A run's diagnostics, and the ids of the points it holds at the end and at the start.
type Held = (Vec<Vec<u64>>, Vec<u64>, Vec<u64>);

/// Points crossing the cuts (issue 19): an elastic disk of material points (neo-Hookean,
/// APIC on the quadratic B-spline, F by MUSL) turning rigidly about the corner that four
/// blocks share, 1,000 steps (a quarter turn: every point crosses a cut) on 2 × 2 ranks.
/// Every step's diagnostics are the serial run's bits; at the end the ranks hold every
/// point once (ids 0..N); the mass is the serial sum to the bit at every step and the
/// momentum, zero at the start, stays at round-off (|P| < 1e-14 M ω R): the transfers
/// conserve it, and no point is lost or counted twice.
#[test]
fn points_turning_across_four_ranks_are_conserved_over_a_thousand_steps() {
    let steps = 1000;
    let text = r#"(
        name: "rigid_rotation_ranks", domain: (size: (1.0, 1.0), cells: (64, 64)),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        time: (end: 100.0, cfl: 0.4, max_dt: 0.05),
        fields: [(name: "disk", density: 1.0,
                  frame: (model: "lagrangian", params: (shape: "quadratic", transfer: "apic")),
                  region: Disk(center: (0.5, 0.5), radius: 0.3),
                  velocity: RigidRotation(center: (0.5, 0.5), angular_velocity: 1.0),
                  stress: [(model: "neo_hookean", params: (young_modulus: 10.0, poisson_ratio: 0.3))])],
        pressure: None,
    )"#;
    let case = Case::from_ron(text, Path::new("rigid_rotation_ranks.ron")).unwrap();
    let (omega, radius) = (1.0, 0.3);
    let ids = |sim: &Simulation| sim.fields[0].frame.as_any().downcast_ref::<Lagrangian>().unwrap().points.id.clone();
    // the diagnostics, and the ids of the points held at the end and at the start
    let run = |sim: &mut Simulation| -> Held {
        let start = ids(sim);
        let d = (0..steps).map(|_| bits(&sim.step().unwrap())).collect();
        (d, ids(sim), start)
    };
    let mut serial = Simulation::new(&case).unwrap();
    let (reference, all, _) = run(&mut serial);
    let n = all.len();
    assert_eq!(all, (0..n as u64).collect::<Vec<_>>());
    let runs: Vec<Held> = on_ranks(4, |comm| {
        let mut sim = Simulation::with_comm(&case, comm).unwrap();
        assert_eq!(sim.grid.part.block().unwrap().0.p.to_vec(), vec![2, 2]);
        run(&mut sim)
    });
    let mut held: Vec<u64> = runs.iter().flat_map(|(_, id, _)| id.iter().copied()).collect();
    held.sort_unstable();
    assert_eq!(held, (0..n as u64).collect::<Vec<_>>(), "every point once on the ranks");
    // a quarter turn: every point has crossed a cut (the rank that holds it changed)
    let moved: usize =
        runs.iter().map(|(_, end, start)| end.iter().filter(|p| start.binary_search(p).is_err()).count()).sum();
    assert!(moved as Real > 0.95 * n as Real, "{moved} of {n} points changed rank");
    for (r, (d, _, _)) in runs.iter().enumerate() {
        for (step, (a, b)) in d.iter().zip(&reference).enumerate() {
            assert_eq!(a, b, "rank {r}: the diagnostics of step {}", step + 1);
        }
    }
    let mass0 = serial.fields[0].frame.mass();
    let scale = mass0 * omega * radius;
    let mut worst: Real = 0.0;
    for d in &reference {
        // bits(): [step, t, Δt, KE, mass, P_x, P_y, …]
        assert_eq!(d[4], mass0.to_bits(), "the mass at step {}", d[0]);
        let p = Real::from_bits(d[5]).hypot(Real::from_bits(d[6]));
        worst = worst.max(p / scale);
    }
    // measured 1.2e-16 (P = 0 at the start to the bit)
    assert!(worst < 1e-14, "|P| reached {worst:.2e} M ω R");
    let last = &reference[steps - 1];
    let (t, ke) = (Real::from_bits(last[1]), Real::from_bits(last[3]));
    assert!(t * omega > std::f64::consts::FRAC_PI_2, "t = {t}: less than a quarter turn");
    // the disk turns on (an elastic solid: its kinetic energy measured 0.6 % below the start's)
    let ke0 = serial.initial_energy;
    assert!((ke - ke0).abs() < 0.01 * ke0, "kinetic energy {ke} against {ke0} at the start");
    eprintln!(
        "{n} points, t = {t:.3}, {moved} changed rank, worst |P| / (M ω R) = {worst:.2e}, KE {:.4} of the start's",
        ke / ke0
    );
}

/// Resolved rigid bodies (`dkt_seed`: two disks under gravity in a channel, the `no_slip`
/// exchange, `repulsion` contact) at 32 cells per unit (3.2 per radius), the disks on the
/// cut x = 1 of 2 × 1 and 2 × 2 ranks: their mass, momentum, angular momentum and centroid
/// are exact sums over every rank's points; contact runs on every rank. The bodies' states
/// at every step (position, velocity, rotation, force, torque) are the serial bits.
#[test]
fn dkt_on_ranks_gives_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_seed.ron");
    for (ranks, p) in [(2, [2, 1]), (4, [2, 2])] {
        let sets = ["domain.cells=(64, 256)".to_string(), format!("domain.ranks=Some(({}, {}))", p[0], p[1])];
        let case = Case::load(&path, &sets).unwrap();
        let serial = check(&case, &[(ranks, Some(p.to_vec()))]);
        // the disks fall
        assert!(serial.fields[1].frame.body_states().iter().all(|b| b.velocity.y < 0.0));
    }
}

/// Deformable bodies (`colliding_disks`: neo-Hookean, periodic, each disk across the
/// periodic wrap) at 64² on 2 × 2 ranks.
#[test]
fn colliding_disks_on_ranks_give_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/colliding_disks.ron");
    let case = Case::load(&path, &["domain.cells=(64, 64)".into()]).unwrap();
    let serial = check(&case, &[(4, Some(vec![2, 2]))]);
    // the lower disk moves at its initial (0.1, 0.1) (they meet later)
    let b = serial.fields[0].frame.body_states()[0];
    let t = serial.time;
    assert!((b.position - Vector::new(0.2 + 0.1 * t, 0.2 + 0.1 * t)).norm() < 1e-6, "{:?} at t = {t}", b.position);
}

/// The rank grid given in the case (`domain.ranks`): 2 × 1 in place of the 1 × 2 of least
/// surface, the serial bits; a grid of another rank count is refused by its key, saying
/// what would fit; one process ignores it.
#[test]
fn the_rank_grid_given_in_the_case_is_used() {
    let mut case = taylor_green("");
    case.domain.ranks = Some([2, 1]);
    check(&case, &[(2, Some(vec![2, 1]))]);
    assert!(Simulation::new(&case).is_ok(), "one process ignores domain.ranks");
    case.domain.ranks = Some([3, 1]);
    let errors =
        on_ranks(2, |comm| Simulation::with_comm(&case, comm).err().map(|e| e.to_string()).unwrap_or_default());
    for e in errors {
        assert!(e.contains("domain.ranks") && e.contains("the rank grid 3 × 1 has 3 ranks but the run has 2"), "{e}");
    }
    case.domain.ranks = Some([0, 2]);
    let e = Simulation::new(&case).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("domain.ranks") && e.contains("at least 1 rank along each axis"), "{e}");
}

/// Mass points (issue 19): every rank holds every point; each sums onto the nodes it owns
/// and reads each footprint node's values from its owner. The `fluidized_bed` example as
/// mass points (200 disks, d = h on 20 × 60 cells, the 2D cylinder drag law with Di
/// Felice's voidage, `dem` contact in sub-steps, an inflow and an outflow) on 1 × 2 and
/// 1 × 3 ranks, and on 64 × 192 cells on 2 × 2 ranks, with walls and with the sides
/// periodic (the footprints, the drag's slip and the points' wrap across the cut there):
/// every step's diagnostics and bodies, and the snapshots, are the serial bits.
#[test]
fn mass_points_on_ranks_give_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/fluidized_bed.ron");
    let points = "fields.disks.representation=MassPoint".to_string();
    let case = Case::load(&path, std::slice::from_ref(&points)).unwrap();
    let serial = check(&case, &[(2, Some(vec![1, 2])), (3, Some(vec![1, 3]))]);
    assert_eq!(serial.grid.n(), [20, 60]);
    // the inflow drags the disks up: the hydrodynamic force on the bed points up
    let up = serial.fields[1].frame.body_states().iter().map(|b| b.force.y).sum::<Real>();
    assert!(up > 0.0, "{up}");
    // (x-cuts fall on multiples of 32 cells: at 64 across, d = 3.2 h, some 12 cells a
    // footprint)
    let square = [points, "domain.ranks=Some((2, 2))".into(), "domain.point_cells=Some((64, 192))".into()];
    let case = Case::load(&path, &square).unwrap();
    check(&case, &[(4, Some(vec![2, 2]))]);
    let mut periodic = square.to_vec();
    periodic.extend(["boundaries.left=Periodic".into(), "boundaries.right=Periodic".into()]);
    let case = Case::load(&path, &periodic).unwrap();
    check(&case, &[(4, Some(vec![2, 2]))]);
}

/// A mass point much larger than a cell (`sedimentation` as a mass point: d = 8 h, its
/// volume spread over some 60 cells across the cut x = 1 of 2 × 1 and 2 × 2 ranks; the
/// cylinder law with added mass and the fluid's rotation, whose vorticity each footprint
/// cell's owner computes): the serial bits.
#[test]
fn a_mass_point_across_ranks_gives_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sedimentation.ron");
    for (ranks, p) in [(2, [2, 1]), (4, [2, 2])] {
        let sets =
            ["fields.disks.representation=MassPoint".to_string(), format!("domain.ranks=Some(({}, {}))", p[0], p[1])];
        let case = Case::load(&path, &sets).unwrap();
        let serial = check(&case, &[(ranks, Some(p.to_vec()))]);
        let b = serial.fields[1].frame.body_states()[0];
        assert!(b.velocity.y < 0.0, "the disk falls: {:?}", b.velocity);
    }
}

/// Many resolved bodies (`fluidized_bed`: 200 rigid disks, `no_slip`, `dem` contact in
/// sub-steps, inflow and outflow, 80 × 240 cells) on 1 × 2 ranks, where every disk is on
/// one rank (the bed below the cut y = 3: each body's sums are its rank's), and on 2 × 2,
/// where the cut x = 0.8 crosses disks (their terms gathered from both ranks): the serial
/// bits.
#[test]
fn many_bodies_on_ranks_give_the_serial_bits() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/fluidized_bed.ron");
    for (ranks, p) in [(2, [1, 2]), (4, [2, 2])] {
        let sets = [format!("domain.ranks=Some(({}, {}))", p[0], p[1]), "monitors=[]".to_string()];
        let case = Case::load(&path, &sets).unwrap();
        check(&case, &[(ranks, Some(p.to_vec()))]);
    }
}
