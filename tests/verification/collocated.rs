//! The Lagrangian frame's collocated grid (`grid: "collocated"`), which steps a field that
//! is alone in its case in one scatter and one gather:
//!
//! - the portable and AVX loops, on 1, 2 and 3 threads (3: each part's scatter cut into
//!   strips of rows), give the same bits;
//! - an affine velocity field (rigid rotation) is transferred exactly by APIC, and a
//!   falling block keeps its free-fall kinetic energy to round-off;
//! - the grid state it refreshes for output holds the points' volume and momentum;
//! - a case it cannot step alone is refused with the entry to change.

use multifield::core::case::Case;
use multifield::core::math::{Real, Vector};
use multifield::core::plugin::{PointStressContext, StressKind, StressModel};
use multifield::core::simulation::Simulation;
use multifield::frames::lagrangian::collocated::Simd;
use multifield::frames::lagrangian::Lagrangian;
use std::path::Path;

fn mpm88(overrides: &[&str]) -> Case {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mpm88.ron");
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Case::load(&file, &overrides).unwrap()
}

fn frame(sim: &Simulation) -> &Lagrangian {
    sim.fields[0].frame.as_any().downcast_ref::<Lagrangian>().unwrap()
}

fn frame_mut(sim: &mut Simulation) -> &mut Lagrangian {
    sim.fields[0].frame.as_any_mut().downcast_mut::<Lagrangian>().unwrap()
}

/// The points' state as bits: positions, velocities, APIC matrices, J and ∇v.
fn state_bits(sim: &Simulation) -> Vec<u64> {
    let p = &frame(sim).points;
    let mut out = Vec::new();
    for k in 0..p.len() {
        out.extend([p.x[k].x, p.x[k].y, p.v[k].x, p.v[k].y, p.c_u[k].x, p.c_u[k].y, p.c_v[k].x, p.c_v[k].y]);
        out.push(p.f[k].determinant());
        out.extend(p.grad_v[k].iter());
    }
    out.iter().map(|x| x.to_bits()).collect()
}

/// `steps` steps of `case` on `threads` threads with at most the lanes `simd`: the points'
/// state and every step's figures as bits, and the lanes in use.
fn run(case: &Case, steps: u64, threads: usize, simd: Simd) -> (Vec<u64>, Vec<u64>, Simd) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let mut sim = Simulation::new(case).unwrap();
        let used = frame_mut(&mut sim).set_simd(simd);
        let mut figures = Vec::new();
        for _ in 0..steps {
            let d = sim.step().unwrap();
            figures.extend([d.kinetic_energy, d.momentum.x, d.momentum.y, d.max_speed].map(Real::to_bits));
        }
        (state_bits(&sim), figures, used)
    })
}

/// The portable loops on 1 thread against 2 and 3 threads (more threads than the scatter's
/// two parts: each part cut into strips of rows), and the AVX lanes (if this CPU has them)
/// on 1, 2 and 3.
fn assert_same_bits(name: &str, case: &Case, steps: u64) {
    let (reference, figures, used) = run(case, steps, 1, Simd::Portable);
    assert_eq!(used, Simd::Portable);
    for simd in [Simd::Portable, Simd::Avx] {
        for threads in [1, 2, 3] {
            if (simd == Simd::Portable && threads == 1) || simd > Simd::available() {
                continue;
            }
            let (bits, f, used) = run(case, steps, threads, simd);
            assert_eq!(used, simd, "the lanes in use");
            assert!(bits == reference, "{name}, {threads} thread(s), {simd:?}: the points differ");
            assert!(f == figures, "{name}, {threads} thread(s), {simd:?}: the step figures differ");
        }
    }
}

/// mpm88 through the impact (the AVX loops of four points, a `volumetric_only` stress, walls),
/// a soft elastic block dropped in its place (the full F, the portable end of the gather),
/// and a block crossing a periodic side with an odd number of points (the loops' tails).
#[test]
fn portable_and_simd_loops_and_thread_counts_give_the_same_bits() {
    eprintln!("lanes available here: {:?}", Simd::available());
    assert_same_bits("mpm88", &mpm88(&["time.end=0.08"]), 400);
    let elastic =
        "fields.fluid.stress=[(model: \"linear_elastic\", params: (young_modulus: 400.0, poisson_ratio: 0.3))]";
    assert_same_bits("elastic block", &mpm88(&[elastic]), 800);
    // ∇v written by the lanes' end of the gather (a volumetric stress that reads it)
    let probe = "fields.fluid.stress=[(model: \"weakly_compressible\", params: (stiffness: 400.0)), \
                 (model: \"rate_probe\", params: (volumetric: true))]";
    assert_same_bits("mpm88 with ∇v", &mpm88(&["time.end=0.08", probe]), 400);
    // a periodic side along x: whole rows cleared, node n merged into node 0
    let case = crossing("left: Periodic, right: Periodic, bottom: FreeSlip, top: FreeSlip", [2.0, 0.0]);
    assert_same_bits("periodic crossing along x", &case, 200);
    let periodic = "left: FreeSlip, right: FreeSlip, bottom: Periodic, top: Periodic";
    let case = crossing_in(periodic, [0.0, 2.0], "(min: (0.31, 0.62), max: (0.71, 0.93))");
    let n = Simulation::new(&case).map(|s| frame(&s).points.len()).unwrap();
    // the tails of the four-point loops: the scatter's parts [0, n/2) and [n/2, n), the
    // gather's last block of n mod 512 points
    let tails = (!(n / 2).is_multiple_of(4) || !(n - n / 2).is_multiple_of(4)) && !(n % 512).is_multiple_of(4);
    assert!(tails, "{n} points: the loops' tails would go untested");
    assert_same_bits("periodic crossing", &case, 200);
}

/// A block of weakly compressible fluid in a 32 × 32 box translating at `velocity` (no
/// gravity), starting near the side it crosses.
fn crossing(boundaries: &str, velocity: [Real; 2]) -> Case {
    let region = if velocity[1] != 0.0 {
        "(min: (0.31, 0.62), max: (0.7, 0.93))"
    } else {
        "(min: (0.62, 0.31), max: (0.93, 0.7))"
    };
    crossing_in(boundaries, velocity, region)
}

/// `crossing` with the block in `region`.
fn crossing_in(boundaries: &str, velocity: [Real; 2], region: &str) -> Case {
    let velocity = format!("Uniform(({}, {}))", velocity[0], velocity[1]);
    let stress = "[(model: \"weakly_compressible\", params: (stiffness: 400.0))]";
    lone_block("crossing", boundaries, 0.2, 3, region, &velocity, stress)
}

/// A block of fluid alone in a unit box of 32 × 32 cells on the collocated grid, with no
/// gravity and Δt = 1e-3: `points_per_cell` along each axis, in the rectangle `region`
/// (RON), with initial `velocity` and `stress` (RON).
fn lone_block(
    name: &str,
    boundaries: &str,
    end: Real,
    points_per_cell: usize,
    region: &str,
    velocity: &str,
    stress: &str,
) -> Case {
    multifield::link_all();
    let text = format!(
        r#"(
    name: "{name}",
    domain: (size: (1.0, 1.0), cells: (32, 32)),
    boundaries: ({boundaries}),
    gravity: (0.0, 0.0),
    time: (end: {end}, max_dt: 1e-3, fixed_dt: Some(1e-3)),
    fields: [(
        name: "fluid",
        density: 1.0,
        frame: (model: "lagrangian", params: (points_per_cell: {points_per_cell}, shape: "quadratic", transfer: "apic", grid: "collocated")),
        region: Rectangle{region},
        velocity: {velocity},
        stress: {stress},
    )],
    pressure: None,
    output: (interval: 0.01),
)"#
    );
    Case::from_ron(&text, Path::new(&format!("{name}.ron"))).unwrap()
}

/// APIC carries a uniform velocity exactly, so a block translating through a periodic side
/// (walls on the other two) keeps its velocity and J = 1 while its ghosts wrap across the
/// side. A wrapped node left out of the grid update would feed the points stale sums.
#[test]
fn a_block_crossing_a_periodic_side_keeps_its_uniform_velocity() {
    for (boundaries, velocity) in [
        ("left: FreeSlip, right: FreeSlip, bottom: Periodic, top: Periodic", [0.0, 2.0]),
        ("left: Periodic, right: Periodic, bottom: FreeSlip, top: FreeSlip", [2.0, 0.0]),
    ] {
        let mut sim = Simulation::new(&crossing(boundaries, velocity)).unwrap();
        let u = Vector::new(velocity[0], velocity[1]);
        let (mut dv, mut dj): (Real, Real) = (0.0, 0.0);
        for _ in 0..200 {
            sim.step().unwrap();
            let p = &frame(&sim).points;
            for k in 0..p.len() {
                dv = dv.max((p.v[k] - u).norm());
                dj = dj.max((p.f[k].determinant() - 1.0).abs());
            }
        }
        // the block (0.31 wide) moved 0.4: it crossed the side whole
        eprintln!("{boundaries}: |v − U| at most {dv:e}, |J − 1| at most {dj:e}");
        assert!(dv < 1e-10 && dj < 1e-12, "{boundaries}: |v − U| {dv:e}, |J − 1| {dj:e}");
    }
}

/// A point stress of zero that reads the points' velocity gradient, so that the
/// collocated grid writes ∇v at the points (no built-in point stress reads it);
/// `volumetric`: whether it says it depends on F through J only (then the lanes end the
/// gather themselves).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RateProbe {
    #[serde(default)]
    volumetric: bool,
}

impl RateProbe {
    fn validate(&mut self) -> Result<(), String> {
        Ok(())
    }
}

impl StressModel for RateProbe {
    fn model(&self) -> &'static str {
        "rate_probe"
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({ "volumetric": self.volumetric })
    }
    fn kind(&self) -> StressKind {
        StressKind::Points { volumetric_only: self.volumetric, velocity_gradient: true }
    }
    fn point_stress(&self, _ctx: &mut PointStressContext) {}
}

multifield::core::register!(Stress, "rate_probe", RateProbe, "test: a zero point stress that reads ∇v", &[]);

/// A block in rigid rotation with no gravity and no stress (or the zero `rate_probe`):
/// APIC on the quadratic B-spline carries an affine field exactly (the nodes get
/// ω × (x_i − c) from every point, the gather reproduces linear fields), so after a step
/// every point moves with ω × (x − c) of its old position, C = [[0, −ω], [ω, 0]] and
/// J = det(I + Δt ∇v) = 1 + (ωΔt)²; with a stress that reads it, ∇v = C is written at the
/// points, with the same bits by the portable loops and the lanes.
#[test]
#[allow(clippy::needless_range_loop)] // indexes the points and their start positions
fn apic_carries_a_rigid_rotation_exactly() {
    for stress in
        ["[]", "[(model: \"rate_probe\", params: ())]", "[(model: \"rate_probe\", params: (volumetric: true))]"]
    {
        let mut grad_v_bits = Vec::new();
        for simd in [Simd::Portable, Simd::available()] {
            let gv = rotation_step(stress, simd);
            grad_v_bits
                .push(gv.iter().flat_map(|m| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>()).collect::<Vec<_>>());
            let probe = stress != "[]";
            let w: Real = 2.0;
            let dg = gv.iter().map(|m| (m - nalgebra::Matrix2::new(0.0, -w, w, 0.0)).norm()).fold(0.0, Real::max);
            eprintln!("{stress}, {simd:?}: |∇v − [[0, −ω], [ω, 0]]| at most {dg:e}");
            if probe {
                // as C: the initial C's rounding (about 1e-9); a wrong ∇S would be off by O(ω)
                assert!(dg < 5e-9, "∇v off the rotation by {dg:e}");
            } else {
                // nothing reads ∇v: the points keep the zero they started with
                assert!(gv.iter().all(|m| *m == nalgebra::Matrix2::zeros()), "∇v written though no stress reads it");
            }
        }
        assert!(grad_v_bits[0] == grad_v_bits[1], "{stress}: ∇v differs between the portable loops and the lanes");
    }
}

/// One step of the rotating block with `stress` and at most the lanes `simd`: checks the
/// velocity, C, J and positions (see `apic_carries_a_rigid_rotation_exactly`) and returns
/// the points' ∇v.
#[allow(clippy::needless_range_loop)] // indexes the points and their start positions
fn rotation_step(stress: &str, simd: Simd) -> Vec<nalgebra::Matrix2<Real>> {
    let walls = "left: FreeSlip, right: FreeSlip, bottom: FreeSlip, top: FreeSlip";
    let region = "(min: (0.3, 0.3), max: (0.7, 0.6))";
    let velocity = "RigidRotation(center: (0.45, 0.5), angular_velocity: 2.0)";
    let case = lone_block("spin", walls, 0.01, 2, region, velocity, stress);
    let mut sim = Simulation::new(&case).unwrap();
    assert_eq!(frame_mut(&mut sim).set_simd(simd), simd);
    let (w, c, dt) = (2.0, Vector::new(0.45, 0.5), 1e-3);
    let before = frame(&sim).points.x.clone();
    sim.step().unwrap();
    let p = &frame(&sim).points;
    let (mut dv, mut dc, mut dj): (Real, Real, Real) = (0.0, 0.0, 0.0);
    for k in 0..p.len() {
        let r = before[k] - c;
        let exact = Vector::new(-w * r.y, w * r.x);
        dv = dv.max((p.v[k] - exact).norm());
        dc = dc.max((p.c_u[k] - Vector::new(0.0, -w)).norm()).max((p.c_v[k] - Vector::new(w, 0.0)).norm());
        dj = dj.max((p.f[k].determinant() - (1.0 + (w * dt) * (w * dt))).abs());
        assert!((p.x[k] - (before[k] + dt * exact)).norm() < 1e-12, "point {k} moved off ω × r");
    }
    eprintln!("rigid rotation after a step: |Δv| {dv:e}, |ΔC| {dc:e}, |ΔJ| {dj:e}");
    // the initial C comes from central differences of the initial field over 1e-6 h: exact
    // for a linear field but for rounding, about 1e-9 (measured 1.2e-9), which enters v as
    // C (x_i − x_p) ~ 1e-9 h (measured 3.0e-11). A missing or wrong affine term would be off
    // by ω h = 0.06; a wrong gradient of the weights, by O(ω).
    assert!(dv < 2e-10, "velocity off the rigid rotation by {dv:e}");
    assert!(dc < 5e-9, "C off ∇v by {dc:e}");
    assert!(dj < 1e-12, "J off 1 + (ωΔt)² by {dj:e}");
    p.grad_v.clone()
}

/// Before it reaches the floor (t ≈ 0.12) mpm88's block falls freely: J stays 1, so no
/// stress, and the kinetic energy is ½ M (1 + g t)² to round-off.
#[test]
fn the_falling_block_keeps_its_free_fall_energy() {
    let mut sim = Simulation::new(&mpm88(&["time.end=0.1"])).unwrap();
    let mass: Real = frame(&sim).points.m.iter().sum();
    let mut worst: Real = 0.0;
    while sim.time < 0.1 - 1e-9 {
        let d = sim.step().unwrap();
        let exact = 0.5 * mass * (1.0 + 9.8 * d.time).powi(2);
        worst = worst.max((d.kinetic_energy - exact).abs() / exact);
        assert_eq!(d.mass, mass, "mass at step {}", d.step);
    }
    eprintln!("free fall to t = 0.1: kinetic energy off ½M(1 + gt)² by at most {worst:e}");
    assert!(worst < 1e-12, "free-fall kinetic energy off by {worst:e}");
}

/// After the steps, the refreshed grid state holds the points' volume (Σθ h² = Σ J V⁰)
/// and momentum (Σ m_f u_f = Σ m v per component), and refreshing changes nothing the
/// next step depends on.
#[test]
fn the_refreshed_grid_state_holds_the_points_volume_and_momentum() {
    let case = mpm88(&["time.end=0.2"]);
    let mut sim = Simulation::new(&case).unwrap();
    let mut twin = Simulation::new(&case).unwrap();
    for _ in 0..600 {
        sim.step().unwrap();
        twin.step().unwrap();
    }
    assert!(sim.grid_state_stale());
    sim.refresh_grid_state().unwrap();
    assert!(!sim.grid_state_stale());
    let h2 = sim.grid.cell_volume();
    let s = &sim.fields[0].state;
    let p = &frame(&sim).points;
    let volume: Real = (0..p.len()).map(|k| p.vol0[k] * p.f[k].determinant()).sum();
    let theta: Real = s.theta.iter().sum::<Real>() * h2;
    let momentum = p.m.iter().zip(&p.v).fold(Vector::zeros(), |a, (m, v)| a + *m * v);
    let faces = |m: &[Real], u: &[Real]| m.iter().zip(u).map(|(m, u)| m * u).sum::<Real>();
    let (mx, my) = (faces(&s.mass_face.u, &s.velocity.u), faces(&s.mass_face.v, &s.velocity.v));
    eprintln!(
        "volume {volume:.12} against Σθh² {theta:.12}; momentum ({:.3e}, {:.6}) against faces ({mx:.3e}, {my:.6})",
        momentum.x, momentum.y
    );
    assert!((theta - volume).abs() < 1e-12 * volume, "Σθ h² {theta} against Σ V {volume}");
    // the walls' normal faces hold no momentum: only points that touch a wall differ
    // (measured: 1.9e-4 of Σ m |v| along y)
    let scale = p.m.iter().zip(&p.v).map(|(m, v)| m * v.norm()).sum::<Real>();
    let off = (mx - momentum.x).abs().max((my - momentum.y).abs()) / scale;
    eprintln!("face momentum off the points' by {off:.2e} of Σ m |v|");
    assert!(off < 1e-3, "face momentum off the points' by {off:e} of Σ m |v|");
    // stepping on after the refresh: the same bits as the twin that never refreshed
    for _ in 0..20 {
        sim.step().unwrap();
        twin.step().unwrap();
    }
    assert!(state_bits(&sim) == state_bits(&twin), "a refresh changed the trajectory");
}

/// What the collocated grid cannot step is refused before the first step, with the entry.
#[test]
fn cases_it_cannot_step_alone_are_refused_with_the_fix() {
    let err = |overrides: &[&str]| {
        Simulation::new(&mpm88(overrides)).err().map(|e| e.to_string()).expect("the case is refused")
    };
    let e = err(&["pressure=Some((model: \"pcg\"))"]);
    assert!(e.contains("fields.fluid.frame") && e.contains("pressure solve") && e.contains("`pressure: None`"), "{e}");
    assert!(e.contains("grid: \"staggered\""), "{e}");
    let e = err(&["contact=Some((model: \"repulsion\"))"]);
    assert!(e.contains("the case has a contact model: set `contact: None`"), "{e}");
    let e = err(&["fields.fluid.stress=[(model: \"rigid\")]"]);
    assert!(e.contains("stress `rigid` makes bodies rigid, and a field on this grid has none"), "{e}");
    let e = err(&["fields.fluid.stress=[(model: \"newtonian\", params: (viscosity: 1e-3))]"]);
    assert!(e.contains("stress `newtonian` acts on the staggered grid"), "{e}");
    let e = err(&["fields.fluid.frame.params.transfer=\"flip\""]);
    assert!(e.contains("grid \"collocated\" transfers by \"apic\" or \"pic\""), "{e}");
    let e = err(&["fields.fluid.frame.params.shape=\"linear\""]);
    assert!(e.contains("grid \"collocated\" needs shape \"quadratic\""), "{e}");
    let two = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mpm88.ron"))
        .unwrap()
        .replace("        ),\n    ],", "        ),\n        (name: \"water\", density: 1.0, frame: (model: \"lagrangian\"), region: Rectangle(min: (0.1, 0.7), max: (0.3, 0.9))),\n    ],");
    let case = Case::from_ron(&two, Path::new("two.ron")).unwrap();
    let e = Simulation::new(&case).err().map(|e| e.to_string()).expect("two fields are refused");
    assert!(e.contains("the case has other fields (`water`): remove them"), "{e}");
    let e = err(&["fields.fluid.region=Bodies([(name: \"disk\", shape: Disk(center: (0.5, 0.5), radius: 0.1))])"]);
    assert!(e.contains("a field of bodies needs grid \"staggered\""), "{e}");
}

/// Snapshots of a run on the collocated grid hold the grid state of their own time: each
/// one's Σθ h² is its points' volume Σ V, and a snapshot reads back as written.
#[test]
fn snapshots_hold_the_grid_state_of_their_time() {
    use multifield::run::{run, RunOptions};
    use multifield::snapshot::Snapshot;
    let case = mpm88(&["time.end=0.1", "output.snapshots=Some((interval: 0.05))", "output.charts=false"]);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("collocated_snapshots");
    let _ = std::fs::remove_dir_all(&dir);
    let outcome = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(outcome.summary.steps, 500);
    let mut files: Vec<_> = std::fs::read_dir(dir.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "h5"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 3, "t = 0, 0.05, 0.1: {files:?}");
    for f in &files {
        let snap = Snapshot::read(f).unwrap();
        let field = &snap.fields[0];
        let points = field.points.as_ref().unwrap();
        let volume: Real = points.get("volume").unwrap().iter().sum();
        let (theta_c, velocity) = (field.get("theta").unwrap(), field.get("velocity").unwrap());
        let theta = theta_c.iter().sum::<Real>() * snap.spacing * snap.spacing;
        eprintln!("{}: step {}, Σθh² {theta:.12}, Σ V {volume:.12}", f.display(), snap.step);
        assert!((theta - volume).abs() < 1e-12 * volume, "step {}: Σθh² {theta} against Σ V {volume}", snap.step);
        // the cell velocity of the block, which falls at 1 + g t with no shear
        let t = snap.time;
        let (n, mut worst) = (snap.nx * snap.ny, 0.0 as Real);
        for c in 0..n {
            if theta_c[c] > 0.999 {
                worst = worst.max((velocity[3 * c + 1] + 1.0 + 9.8 * t).abs());
            }
        }
        assert!(worst < 1e-9, "step {}: full cells' velocity off the free fall by {worst:e}", snap.step);
    }
}

/// A run that blows up (Δt 25× the sound-speed limit) goes on stepping without a panic:
/// once a step's kinetic energy is not finite, the next steps take the portable loops,
/// which keep a NaN or infinite point on the padded lattice.
#[test]
fn a_blown_up_state_steps_on_without_a_panic() {
    let mut sim = Simulation::new(&mpm88(&[])).unwrap();
    let mut first_bad = None;
    for k in 0..60 {
        let d = sim.step_with(5e-3, "test".into()).unwrap();
        if first_bad.is_none() && !(d.kinetic_energy.is_finite() && d.max_speed.is_finite()) {
            first_bad = Some(k);
        }
    }
    let first_bad = first_bad.expect("Δt = 5e-3 blows mpm88 up");
    eprintln!("non-finite from step {}; stepped on to step 60", first_bad + 1);
    assert!(first_bad < 50, "the blow-up came at step {}", first_bad + 1);
}
