//! Drafting–kissing–tumbling of two rigid disks (Uhlmann 2005's case,
//! `examples/dkt_uhlmann2005.ron`) at a resolution CI can afford, 8 cells per diameter:
//! the trailing disk drafts in the leading one's wake, and the settling speeds follow the
//! published curves (`../shared/reference/dkt-uhlmann2005`, embedded below at the times
//! the test reads them). Full-resolution runs and their figures: `docs/validation.md`.

use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::simulation::Simulation;
use std::path::Path;

/// Uhlmann (2005) fig. 6b, settling speed (cm/s) at t = 0.05, 0.10, 0.15 s, by linear
/// interpolation of the digitized curves: (leading, trailing).
const UHLMANN_SPEED: [(Real, Real, Real); 3] = [(0.05, 8.04, 7.86), (0.10, 11.66, 11.81), (0.15, 13.05, 18.88)];

#[test]
fn the_trailing_disk_drafts_and_speeds_follow_uhlmann() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005.ron");
    let case = Case::load(&file, &["domain.cells=(64, 192)".into(), "time.end=0.2".into()]).unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let d = 0.25;
    let along = |sim: &Simulation, name: &str| {
        let b = sim.bodies().into_iter().find(|(_, b)| b.name == name).unwrap().1;
        (6.0 - b.position.y, -b.velocity.y)
    };
    let mut min_gap = Real::INFINITY;
    let mut speeds = Vec::new();
    let mut next = 0;
    while sim.time < 0.2 - 1e-12 {
        sim.step().unwrap();
        let (sl, _) = along(&sim, "leading");
        let (st, _) = along(&sim, "trailing");
        min_gap = min_gap.min((sl - st) / d);
        if next < UHLMANN_SPEED.len() && sim.time >= UHLMANN_SPEED[next].0 {
            speeds.push((sim.time, along(&sim, "leading").1, along(&sim, "trailing").1));
            next += 1;
        }
    }
    eprintln!("smallest gap along gravity {min_gap:.3} d; speeds (t, leading, trailing) {speeds:?}");
    assert!(min_gap < 1.5, "no drafting: the gap along gravity stayed above {min_gap:.3} d (starts at 2 d)");
    for ((t, l, tr), (tr_, ul, ut)) in speeds.iter().zip(UHLMANN_SPEED) {
        let (el, et) = ((l - ul) / ul, (tr - ut) / ut);
        eprintln!(
            "t = {t:.4} (reference at {tr_}): leading {l:.2} vs {ul} ({:+.1} %), trailing {tr:.2} vs {ut} ({:+.1} %)",
            100.0 * el,
            100.0 * et
        );
        // measured at 8 cells per diameter: −10 % to −17 % (the smeared interface adds
        // drag); at t = 0.1 s the leading disk's −16 % becomes −6.5 % and −2.2 % at 16 and
        // 24 cells per diameter (docs/validation.md)
        assert!(el.abs() < 0.25 && et.abs() < 0.25, "t = {t}: speeds {l}, {tr} against Uhlmann's {ul}, {ut}");
    }
    // drafting: in the wake the trailing disk settles faster; Uhlmann 18.88/13.05 = 1.447
    // at t = 0.15 s, measured 1.450 here
    let (_, l, tr) = speeds[2];
    let ratio = tr / l;
    assert!((ratio - 1.447).abs() < 0.1 * 1.447, "trailing/leading speed at t = 0.15 s: {ratio:.3}, Uhlmann 1.447");
}

/// The coupled scene (Eulerian water, Lagrangian rigid disks, no-slip exchange, contact,
/// MG-PCG) gives bit-identical bodies, water velocities and pressure with 1 and 2 threads.
#[test]
fn the_coupled_scene_is_bit_identical_with_one_and_two_threads() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005.ron");
    // disks start 0.1 d apart so that contact acts from the first step
    let case = Case::load(
        &file,
        &[
            "domain.cells=(32, 96)".into(),
            "time.max_steps=30".into(),
            "fields.disks.region.Bodies.1.shape.Disk.center=(0.999, 4.725)".into(),
            "contact.params.dt_factor=0.1".into(),
        ],
    )
    .unwrap();
    let run_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut sim = Simulation::new(&case).unwrap();
            for _ in 0..30 {
                sim.step().unwrap();
            }
            let mut bits: Vec<u64> = Vec::new();
            for (_, b) in sim.bodies() {
                bits.extend(
                    [b.position.x, b.position.y, b.velocity.x, b.velocity.y, b.angular_velocity].map(Real::to_bits),
                );
            }
            let water = &sim.fields[0].state.velocity;
            bits.extend(water.u.iter().chain(&water.v).chain(&sim.pressure).map(|x| x.to_bits()));
            (bits, sim.last.dt_limit.clone())
        })
    };
    let (a, b) = (run_with(1), run_with(2));
    assert_eq!(a.1, b.1);
    assert_eq!(a.1, "contact(repulsion)", "the test must exercise contact");
    assert!(a.0 == b.0, "the state differs between 1 and 2 threads");
}
