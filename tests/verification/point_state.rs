//! The stress models' per-point state (`StressModel::point_state`,
//! `PointStressContext::state`):
//!
//! - a model that integrates the strain rate |D| = |sym ∇v| (Frobenius) over time at each
//!   point gives γ̇Δt/√2 a step under a uniform shear u = (γ̇ y, 0), on the staggered and on
//!   the collocated grid, each point's value carried with it;
//! - a run continued from a checkpoint ends with the same state, bit for bit.
use multifield::checkpoint;
use multifield::core::case::Case;
use multifield::core::math::{Matrix, Real, Vector};
use multifield::core::plugin::{PointStressContext, StressKind, StressModel};
use multifield::core::simulation::{Simulation, Status};
use multifield::frames::lagrangian::Lagrangian;
use multifield::run::{run, RunOptions};
use std::path::Path;

/// A zero point stress that accumulates ∫|D| dt at each point (one state component).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct StrainMeter {}

impl StrainMeter {
    fn validate(&mut self) -> Result<(), String> {
        Ok(())
    }
}

impl StressModel for StrainMeter {
    fn model(&self) -> &'static str {
        "strain_meter"
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({})
    }
    fn kind(&self) -> StressKind {
        StressKind::Points { volumetric_only: true, velocity_gradient: true }
    }
    fn decomposed(&self) -> bool {
        true
    }
    fn point_state(&self) -> &'static [&'static str] {
        &["equivalent_strain"]
    }
    fn point_stress(&self, ctx: &mut PointStressContext) {
        assert_eq!(ctx.state.len(), ctx.velocity_gradient.len(), "one value per point");
        for (s, l) in ctx.state.iter_mut().zip(ctx.velocity_gradient) {
            let d = 0.5 * (l + l.transpose());
            *s += ctx.dt * d.norm();
        }
    }
}

multifield::core::register!(Stress, "strain_meter", StrainMeter, "test: ∫|D| dt per point, no stress", &[]);

fn frame(sim: &Simulation) -> &Lagrangian {
    sim.fields[0].frame.as_any().downcast_ref::<Lagrangian>().unwrap()
}

fn frame_mut(sim: &mut Simulation) -> &mut Lagrangian {
    sim.fields[0].frame.as_any_mut().downcast_mut::<Lagrangian>().unwrap()
}

/// A block of [0.3, 0.7]² in a walled unit box (32², Δt = 1e-3, no gravity, no pressure),
/// APIC on the quadratic B-spline, on `grid`, with the strain meter.
fn block(grid: &str) -> Case {
    multifield::link_all();
    let text = format!(
        r#"(
    name: "shear",
    domain: (size: (1.0, 1.0), cells: (32, 32)),
    boundaries: (left: FreeSlip, right: FreeSlip, bottom: FreeSlip, top: FreeSlip),
    gravity: (0.0, 0.0),
    time: (end: 0.1, max_dt: 1e-3, fixed_dt: Some(1e-3)),
    fields: [(
        name: "block",
        density: 1.0,
        frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "quadratic", transfer: "apic", grid: "{grid}")),
        region: Rectangle(min: (0.3, 0.3), max: (0.7, 0.7)),
        stress: [(model: "strain_meter")],
    )],
    pressure: None,
    output: (interval: 0.01),
)"#
    );
    Case::from_ron(&text, Path::new("shear.ron")).unwrap()
}

/// Under the shear u = (γ̇ (y − ½), 0), set on the points with its exact APIC matrix and
/// ∇v, APIC on the quadratic B-spline carries the linear field exactly and the gather
/// gives ∇v = [[0, γ̇], [0, 0]]: |D| = γ̇/√2 at every point. Starting from the point's index
/// (so that a state handed to the wrong point would show), each point's state after N
/// steps is p + N Δt γ̇/√2 = p + 0.1/√2 for γ̇ = 1, N = 100.
#[test]
fn the_state_integrates_the_strain_rate_of_a_uniform_shear() {
    let rate: Real = 1.0;
    for grid in ["staggered", "collocated"] {
        let mut sim = Simulation::new(&block(grid)).unwrap();
        {
            let p = &mut frame_mut(&mut sim).points;
            let n = p.len();
            for k in 0..n {
                p.v[k] = Vector::new(rate * (p.x[k].y - 0.5), 0.0);
                p.c_u[k] = Vector::new(0.0, rate);
                p.c_v[k] = Vector::zeros();
                p.grad_v[k] = Matrix::new(0.0, rate, 0.0, 0.0);
            }
            p.model_state = vec![(0..n).map(|k| k as Real).collect()];
        }
        let steps = 100;
        for _ in 0..steps {
            sim.step().unwrap();
        }
        let p = &frame(&sim).points;
        let expected = steps as Real * 1e-3 * rate / Real::sqrt(2.0);
        assert!((expected - 0.070_710_678).abs() < 1e-9);
        let worst =
            p.model_state[0].iter().enumerate().map(|(k, s)| (s - k as Real - expected).abs()).fold(0.0, Real::max);
        eprintln!("{grid}: {} points, ∫|D| dt off {expected} by at most {worst:e}", p.len());
        assert_eq!(p.model_state[0].len(), p.len());
        // ∇v from the gather of an exact linear field: round-off only (a missed step or a
        // state lost between steps is off by 7e-4 or more; a point given another's, by 1)
        assert!(worst < 1e-9, "{grid}: equivalent strain off by {worst:e}");
        let shear = p.grad_v.iter().map(|l| (l - Matrix::new(0.0, rate, 0.0, 0.0)).norm()).fold(0.0, Real::max);
        assert!(shear < 1e-9, "{grid}: ∇v off the shear by {shear:e}");
        // a snapshot holds the state under `<model>_<component>`, point for point
        let spec = multifield::core::case::SnapshotSpec::every(1.0);
        let snap = multifield::snapshot::Snapshot::with(&sim, &spec).unwrap();
        let points = snap.fields[0].points.as_ref().unwrap();
        assert_eq!(points.get("strain_meter_equivalent_strain"), Some(p.model_state[0].as_slice()), "{grid}");
    }
}

/// The same shear at 64² on 2 × 2 in-process ranks (issue 19): the points that cross
/// the cut at x = ½ carry their state to the rank across it; the state of every point,
/// gathered in id order, is the serial run's to the bit and p + N Δt γ̇/√2 (id p).
#[test]
fn the_state_migrates_with_its_point_between_ranks() {
    use multifield::core::parallel::{fake, Comm};
    use std::sync::Arc;
    let rate: Real = 1.0;
    let mut case = block("staggered");
    case.domain.cells = [64, 64];
    let shear = |sim: &mut Simulation| {
        let p = &mut frame_mut(sim).points;
        for k in 0..p.len() {
            p.v[k] = Vector::new(rate * (p.x[k].y - 0.5), 0.0);
            p.c_u[k] = Vector::new(0.0, rate);
            p.c_v[k] = Vector::zeros();
            p.grad_v[k] = Matrix::new(0.0, rate, 0.0, 0.0);
        }
        p.model_state = vec![p.id.iter().map(|&i| i as Real).collect()];
    };
    let steps = 100;
    // the state of every point in id order, and the ids this rank held at the start and the end
    let run = |sim: &mut Simulation| {
        shear(sim);
        let start = frame(sim).points.id.clone();
        for _ in 0..steps {
            sim.step().unwrap();
        }
        let state = sim.fields[0].frame.points().unwrap().model_state[0].clone();
        (state, start, frame(sim).points.id.clone())
    };
    let mut serial = Simulation::new(&case).unwrap();
    let (reference, _, _) = run(&mut serial);
    let expected = steps as Real * 1e-3 * rate / Real::sqrt(2.0);
    let worst = reference.iter().enumerate().map(|(k, s)| (s - k as Real - expected).abs()).fold(0.0, Real::max);
    assert!(worst < 1e-9, "equivalent strain off by {worst:e}");
    let ranks: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = fake::world(4)
            .into_iter()
            .map(|c| {
                let (case, run) = (&case, &run);
                s.spawn(move || {
                    let comm: Arc<dyn Comm> = Arc::new(c);
                    run(&mut Simulation::with_comm(case, comm).unwrap())
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let crossed: usize =
        ranks.iter().map(|(_, start, end)| end.iter().filter(|i| start.binary_search(i).is_err()).count()).sum();
    eprintln!("{} points, {crossed} changed rank", reference.len());
    assert!(crossed > 0, "no point crossed a cut");
    for (r, (state, _, _)) in ranks.iter().enumerate() {
        let same =
            state.len() == reference.len() && state.iter().zip(&reference).all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same, "rank {r}: the gathered point state differs from the serial run's");
    }
}

/// mpm88 (collocated grid, the block falls and splashes: a different ∇v at every point)
/// with the strain meter: continued from its checkpoint at t = 0.08, it ends with the same
/// point state as the uninterrupted run, bit for bit, and the same final checkpoint.
#[test]
fn a_restarted_run_carries_the_point_state_bit_for_bit() {
    multifield::link_all();
    let overrides: Vec<String> = [
        "time.end=0.16",
        "output.interval=0.004",
        "output.checkpoints=Some((interval: 0.08))",
        "output.charts=false",
        "fields.fluid.stress=[(model: \"weakly_compressible\", params: (stiffness: 400.0)), (model: \"strain_meter\")]",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let case = Case::load(Path::new("examples/mpm88.ron"), &overrides).unwrap();
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("point_state");
    let (full, restarted) = (root.join("full"), root.join("restarted"));
    let _ = std::fs::remove_dir_all(&root);
    let a = run(&case, &full, &RunOptions::quiet()).unwrap();
    assert_eq!(a.status, Status::Completed);
    let list = checkpoint::list(&full);
    assert_eq!(list.len(), 2, "{list:?}");
    let options = RunOptions { restart: Some(list[0].1.clone()), ..RunOptions::quiet() };
    let b = run(&case, &restarted, &options).unwrap();
    assert_eq!(b.status, Status::Completed);
    let end_b = restarted.join("checkpoints").join(checkpoint::file_name(list[1].0));
    let (sa, _) = checkpoint::restore(&case, &list[1].1).unwrap();
    let (sb, _) = checkpoint::restore(&case, &end_b).unwrap();
    let bits = |s: &Simulation| frame(s).points.model_state.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    let state = &frame(&sa).points.model_state;
    assert_eq!(state.len(), 2, "one state array per stress model");
    assert!(state[0].is_empty(), "weakly_compressible keeps no state");
    let n = frame(&sa).points.len();
    assert_eq!(state[1].len(), n);
    // the block falls freely until t ≈ 0.12 (∇v = 0), then splashes: every point has strained
    let (lo, hi) = state[1].iter().fold((Real::MAX, 0.0 as Real), |(l, h), s| (l.min(*s), h.max(*s)));
    eprintln!("{n} points, ∫|D| dt from {lo:e} to {hi:e}");
    assert!(lo >= 0.0 && hi > 1e-3, "the splash strains the block: {lo:e} … {hi:e}");
    assert_eq!(bits(&sa), bits(&sb), "point state after the restart");
    assert!(std::fs::read(&list[1].1).unwrap() == std::fs::read(&end_b).unwrap(), "final checkpoints differ");
}

/// A checkpoint whose point state does not fit the strain meter (a value that is not
/// finite, another length) is refused on loading, naming the field, the model, the point
/// and the value (issue 20; tests/regression/forged_checkpoint.rs has the other classes).
#[test]
fn a_restored_point_state_that_is_not_finite_or_does_not_fit_is_refused() {
    let case = block("staggered");
    let mut sim = Simulation::new(&case).unwrap();
    let n = frame(&sim).points.len();
    let refusal = |sim: &Simulation| {
        let bytes = sim.save_state().unwrap();
        Simulation::new(&case).unwrap().load_state(&bytes).unwrap_err().to_string()
    };
    frame_mut(&mut sim).points.model_state = vec![vec![0.25; n]];
    frame_mut(&mut sim).points.model_state[0][5] = Real::NAN;
    let e = refusal(&sim);
    assert!(
        e.contains(
            "field `block`: point state of stress `strain_meter` (1 values per point)[5] is NaN, not a finite number"
        ),
        "{e}"
    );
    frame_mut(&mut sim).points.model_state = vec![vec![0.25; n + 1]];
    let e = refusal(&sim);
    let want = format!(
        "point state of stress `strain_meter` (1 values per point): {} values in the checkpoint, {n} here",
        n + 1
    );
    assert!(e.contains(&want), "{e}");
    frame_mut(&mut sim).points.model_state = vec![vec![0.25; n]];
    let bytes = sim.save_state().unwrap();
    Simulation::new(&case).unwrap().load_state(&bytes).expect("a state that fits is restored");
}
