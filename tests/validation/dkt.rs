//! Drafting–kissing–tumbling of two rigid disks (Uhlmann 2005's case) at resolutions CI
//! can afford. Resolved by direct forcing (`examples/dkt_uhlmann2005.ron`), on 8 and 16
//! cells per diameter: the settling speeds converge to the published curves
//! (`validation/reference/dkt-uhlmann2005`, copied below at the times the test reads them),
//! the trailing disk drafts, and at 16 the pair kisses and tumbles near the published
//! times. With the seed's `no_slip` (`examples/dkt_uhlmann2005_no_slip.ron`), on 8: the
//! same events before 0.35 s; and at 16, a lone disk off the axis barely spins.
//! Full-resolution runs and their figures: `docs/validation.md`.

use multifield::core::case::Case;
use multifield::core::math::Real;
use multifield::core::simulation::Simulation;
use std::path::Path;

/// Uhlmann (2005) fig. 6b, settling speed (cm/s) at t = 0.05, 0.10, 0.15 s, by linear
/// interpolation of the digitized curves: (leading, trailing).
const UHLMANN_SPEED: [(Real, Real, Real); 3] = [(0.05, 8.04, 7.86), (0.10, 11.66, 11.81), (0.15, 13.05, 18.88)];

/// With the seed's `no_slip` exchange at 8 cells per diameter.
#[test]
fn under_no_slip_the_trailing_disk_drafts_kisses_and_tumbles_and_speeds_follow_uhlmann() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005_no_slip.ron");
    let end = 0.35;
    let case = Case::load(&file, &["domain.cells=(64, 192)".into(), format!("time.end={end}")]).unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let d = 0.25;
    let along = |sim: &Simulation, name: &str| {
        let b = sim.bodies().into_iter().find(|(_, b)| b.name == name).unwrap().1;
        (6.0 - b.position.y, -b.velocity.y)
    };
    let mut min_gap = Real::INFINITY;
    let (mut kiss, mut tumble) = (None, None);
    let mut speeds = Vec::new();
    let mut next = 0;
    while sim.time < end - 1e-12 {
        sim.step().unwrap();
        let (sl, _) = along(&sim, "leading");
        let (st, _) = along(&sim, "trailing");
        let gap = (sl - st) / d;
        if sim.time <= 0.2 {
            min_gap = min_gap.min(gap);
        }
        if kiss.is_none() && gap <= 1.0 {
            kiss = Some(sim.time);
        }
        if tumble.is_none() && gap < 0.0 {
            tumble = Some(sim.time);
        }
        if next < UHLMANN_SPEED.len() && sim.time >= UHLMANN_SPEED[next].0 {
            speeds.push((sim.time, along(&sim, "leading").1, along(&sim, "trailing").1));
            next += 1;
        }
    }
    eprintln!(
        "smallest gap along gravity to t = 0.2 s {min_gap:.3} d; kiss {kiss:?}, tumble {tumble:?}; \
         speeds (t, leading, trailing) {speeds:?}"
    );
    assert!(min_gap < 1.5, "no drafting: the gap along gravity stayed above {min_gap:.3} d (starts at 2 d)");
    // the order along gravity swaps before 0.35 s; measured at 8 cells per diameter: kiss
    // 0.236 s, tumble 0.285 s (published 0.171–0.208 s and 0.261–0.280 s; at 24 cells per
    // diameter 0.210 s and 0.260 s, docs/validation.md)
    let (kiss, tumble) = (kiss.expect("the gap along gravity never fell to d"), tumble.expect("no tumble by 0.35 s"));
    assert!(kiss < 0.27 && tumble < 0.32, "kiss at {kiss} s, tumble at {tumble} s (measured 0.236 s, 0.285 s)");
    for ((t, l, tr), (tr_, ul, ut)) in speeds.iter().zip(UHLMANN_SPEED) {
        let (el, et) = ((l - ul) / ul, (tr - ut) / ut);
        eprintln!(
            "t = {t:.4} (reference at {tr_}): leading {l:.2} vs {ul} ({:+.1} %), trailing {tr:.2} vs {ut} ({:+.1} %)",
            100.0 * el,
            100.0 * et
        );
        // measured at 8 cells per diameter: −11 % to −18 % (the smeared interface adds
        // drag); at t = 0.1 s the leading disk's −16 % becomes −6.5 % and −2.2 % at 16 and
        // 24 cells per diameter (docs/validation.md)
        assert!(el.abs() < 0.25 && et.abs() < 0.25, "t = {t}: speeds {l}, {tr} against Uhlmann's {ul}, {ut}");
    }
    // drafting: in the wake the trailing disk settles faster; Uhlmann 18.88/13.05 = 1.447
    // at t = 0.15 s, measured 1.477 here
    let (_, l, tr) = speeds[2];
    let ratio = tr / l;
    assert!((ratio - 1.447).abs() < 0.1 * 1.447, "trailing/leading speed at t = 0.15 s: {ratio:.3}, Uhlmann 1.447");
}

/// The coupled scene (Eulerian water, Lagrangian rigid disks, contact, MG-PCG) gives
/// bit-identical bodies, water velocities and pressure with 1 and 2 threads, with the
/// no-slip exchange and with direct forcing.
#[test]
fn the_coupled_scene_is_bit_identical_with_one_and_two_threads() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005.ron");
    for forcing in [&[][..], &["exchange.0.model=\"no_slip\"", "contact.params.range_cells=2.0"][..]] {
        // disks start 0.1 d apart so that contact acts from the first step
        let mut overrides: Vec<String> = [
            "domain.cells=(32, 96)",
            "time.max_steps=30",
            "fields.disks.region.Bodies.1.shape.Disk.center=(0.999, 4.725)",
            "contact.params.dt_factor=0.1",
        ]
        .map(String::from)
        .to_vec();
        overrides.extend(forcing.iter().map(|s| s.to_string()));
        let case = Case::load(&file, &overrides).unwrap();
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
                        [b.position.x, b.position.y, b.velocity.x, b.velocity.y, b.angular_velocity, b.force.y]
                            .map(Real::to_bits),
                    );
                }
                let water = &sim.fields[0].state.velocity;
                bits.extend(water.u.iter().chain(&water.v).chain(&sim.pressure).map(|x| x.to_bits()));
                (bits, sim.last.dt_limit.clone())
            })
        };
        let (a, b) = (run_with(1), run_with(2));
        assert_eq!(a.1, b.1);
        assert_eq!(a.1, "contact(repulsion)", "the test must exercise contact ({forcing:?})");
        assert!(a.0 == b.0, "the state differs between 1 and 2 threads ({forcing:?})");
    }
}

/// A lone disk settling 0.016 d off the channel's axis barely turns: at that offset the
/// walls, 4d away, give it next to no torque (Uhlmann's leading disk, 0.004 d off the axis
/// with the other disk 2d behind, stays below 0.05 rad/s to t = 0.15 s). What spin there is,
/// is the point sampling of the disk's smeared interface as it falls through the grid; it
/// seeds the DKT pair's asymmetry, so it must stay small. Measured at 16 cells per diameter,
/// every step of 0.02 s < t ≤ 0.12 s: 0.42 rad/s with the example's 3 × 3 points per cell,
/// 1.48 rad/s with 2 × 2 (ω d / U ≈ 0.01 against 0.04 at U ≈ 10 cm/s).
#[test]
fn a_lone_disk_off_the_axis_barely_spins() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005_no_slip.ron");
    let case = Case::load(
        &file,
        &[
            "time.end=0.12".into(),
            r#"fields.disks.region=Bodies([(name: "lone", shape: Disk(center: (0.996, 4.5), radius: 0.125))])"#.into(),
        ],
    )
    .unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    let (mut max_spin, mut speed) = (0.0 as Real, 0.0);
    while sim.time < 0.12 - 1e-12 {
        sim.step().unwrap();
        let b = sim.bodies().into_iter().next().unwrap().1;
        if sim.time > 0.02 {
            max_spin = max_spin.max(b.angular_velocity.abs());
        }
        speed = -b.velocity.y;
    }
    eprintln!("largest |ω| over 0.02 s < t ≤ 0.12 s: {max_spin:.3} rad/s; settling speed at 0.12 s {speed:.2} cm/s");
    assert!(speed > 8.0, "the disk settles at {speed} cm/s by t = 0.12 s (Uhlmann's leading disk: 12.3)");
    assert!(max_spin < 0.6, "a lone disk 0.016 d off the axis spins at {max_spin:.3} rad/s (measured 0.42)");
}

/// The scene as shipped, the disks resolved by direct forcing (`examples/dkt_uhlmann2005.ron`),
/// on 8 and 16 cells per diameter. Before the disks interact, the settling speeds at
/// t = 0.05, 0.10 and 0.15 s against Uhlmann's fig. 6b: measured at most 9.0 % below at 8
/// cells per diameter and 4.8 % below at 16 (`no_slip`: 18 % and 8 %), the largest error
/// falling by half; the trailing disk drafts (1.45 times the leading one's speed at 0.15 s
/// at 8 cells per diameter, Uhlmann 1.447). At 16, the pair kisses at 0.230 s and tumbles
/// at 0.288 s (0.235 s and 0.290 s before disks within a cell were solved together, issue
/// 15; Uhlmann 0.171 s and 0.280 s, Koblitz et al. 0.208 s and 0.261 s; at 24 cells per
/// diameter 0.220 s and 0.290 s before that change, docs/validation.md).
#[test]
fn under_direct_forcing_the_settling_speeds_converge_to_uhlmann_and_the_pair_tumbles() {
    multifield::link_all();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005.ron");
    let mut worst = Vec::new();
    for (cells, end) in [("(64, 192)", 0.15), ("(128, 384)", 0.35)] {
        let case = Case::load(&file, &[format!("domain.cells={cells}"), format!("time.end={end}")]).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let (speeds, kiss, tumble) = pool.install(|| {
            let mut sim = Simulation::new(&case).unwrap();
            let along = |sim: &Simulation, name: &str| {
                let b = sim.bodies().into_iter().find(|(_, b)| b.name == name).unwrap().1;
                (6.0 - b.position.y, -b.velocity.y)
            };
            let (mut speeds, mut kiss, mut tumble) = (Vec::new(), None, None);
            while sim.time < end - 1e-12 {
                sim.step().unwrap();
                let ((sl, vl), (st, vt)) = (along(&sim, "leading"), along(&sim, "trailing"));
                if speeds.len() < UHLMANN_SPEED.len() && sim.time >= UHLMANN_SPEED[speeds.len()].0 - 1e-12 {
                    speeds.push((sim.time, vl, vt));
                }
                let gap = (sl - st) / 0.25;
                kiss = kiss.or((gap <= 1.0).then_some(sim.time));
                tumble = tumble.or((gap < 0.0).then_some(sim.time));
            }
            (speeds, kiss, tumble)
        });
        let mut w: Real = 0.0;
        for ((t, l, tr), (_, ul, ut)) in speeds.iter().zip(UHLMANN_SPEED) {
            let (el, et) = ((l - ul) / ul, (tr - ut) / ut);
            eprintln!(
                "{cells}, t = {t:.4}: leading {l:.2} vs {ul} ({:+.1} %), trailing {tr:.2} vs {ut} ({:+.1} %)",
                100.0 * el,
                100.0 * et
            );
            w = w.max(el.abs()).max(et.abs());
        }
        let (_, l, tr) = speeds[2];
        assert!((tr / l - 1.447).abs() < 0.1 * 1.447, "{cells}: trailing/leading speed at 0.15 s {:.3}", tr / l);
        worst.push(w);
        if end > 0.3 {
            eprintln!("{cells}: kiss {kiss:?}, tumble {tumble:?} (measured 0.230 s, 0.288 s)");
            let (kiss, tumble) = (kiss.expect("no kiss by 0.35 s"), tumble.expect("no tumble by 0.35 s"));
            // the kiss at most 0.03 s after the published ones (0.171–0.208 s), the tumble
            // within 0.02 s of them (0.261–0.280 s)
            assert!((0.16..0.24).contains(&kiss), "kiss at {kiss} s (measured 0.230 s)");
            assert!((0.24..0.30).contains(&tumble), "tumble at {tumble} s (measured 0.288 s)");
        }
    }
    eprintln!("largest speed errors: {worst:?}");
    assert!(worst[0] < 0.10 && worst[1] < 0.05 && worst[1] < 0.6 * worst[0], "{worst:?}");
}

/// The speeds copied above are Uhlmann's fig. 6b in the repository's reference folder, and
/// the curves built into the program are that folder's files.
#[test]
fn the_copied_speeds_and_the_built_in_curves_are_the_reference_folders() {
    use multifield::dkt::{interpolate, read_reference, ReferenceCurves};
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/reference/dkt-uhlmann2005");
    let fig6b = |which: &str| read_reference(&dir.join(format!("Uhlmann2005-fig6b-{which}-particle.csv"))).unwrap();
    let ((tl, vl), (tt, vt)) = (fig6b("leading"), fig6b("trailing"));
    for (t, leading, trailing) in UHLMANN_SPEED {
        let (l, tr) = (interpolate(&tl, &vl, t).unwrap(), interpolate(&tt, &vt, t).unwrap());
        assert!((l - leading).abs() <= 0.005 && (tr - trailing).abs() <= 0.005, "t = {t}: {l:.4}, {tr:.4}");
    }
    let folder = ReferenceCurves::Folder(dir);
    for fig in ["Uhlmann2005-fig6a", "Uhlmann2005-fig6b", "Uhlmann2005-fig7a", "Uhlmann2005-fig8", "Koblitz2017-fig10c"]
    {
        for which in ["leading", "trailing"] {
            let file = format!("{fig}-{which}-particle.csv");
            let shipped = ReferenceCurves::Shipped.curve(&file).unwrap();
            assert!(shipped.0.len() > 40, "{file}: {} points", shipped.0.len());
            assert_eq!(shipped, folder.curve(&file).unwrap(), "{file}");
        }
    }
    assert!(ReferenceCurves::Shipped.curve("Uhlmann2005-fig7b-leading-particle.csv").is_err());
}

/// `multifield dkt`'s four distances to Uhlmann's curves, on runs made of those curves:
/// a run that follows them (sampled every 0.25 ms) is within interpolation error of
/// them, its mirror image about the axis too (lateral positions and spins), and a run
/// moved by 0.1 d across and 0.05 u_ref faster is 0.1 d and 0.05 u_ref from them.
#[test]
fn the_dkt_analysis_measures_a_run_made_of_uhlmanns_curves() {
    use multifield::dkt::{analyse, interpolate, ReferenceCurves};
    let case =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dkt_uhlmann2005.ron")).unwrap();
    let (d, u_ref) = (0.25, (std::f64::consts::PI * 0.25 * 0.5 * 981.0 / 2.0 as Real).sqrt());
    let curve = |fig: &str, which: &str| {
        let (t, v) = ReferenceCurves::Shipped.curve(&format!("Uhlmann2005-{fig}-{which}-particle.csv")).unwrap();
        let mut p: Vec<(Real, Real)> = t.into_iter().zip(v).collect();
        p.sort_by(|a, b| a.0.total_cmp(&b.0));
        p.into_iter().unzip::<Real, Real, Vec<Real>, Vec<Real>>()
    };
    let at =
        |c: &(Vec<Real>, Vec<Real>), t: Real| interpolate(&c.0, &c.1, t.clamp(c.0[0], *c.0.last().unwrap())).unwrap();
    let curves = ["trailing", "leading"].map(|w| (w, ["fig6a", "fig7a", "fig6b", "fig8"].map(|f| curve(f, w))));
    let write = |name: &str, mirror: Real, shift: Real, faster: Real| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dkt_analysis").join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("case.ron"), &case).unwrap();
        let mut csv = String::from("step,time,body,x,y,vx,vy,omega,fx,fy,torque\n");
        for k in 0..=1200 {
            let t = k as Real * 2.5e-4;
            for (which, [c6a, c7a, c6b, c8]) in &curves {
                let (s, x, v, w) = (at(c6a, t), at(c7a, t), at(c6b, t), at(c8, t));
                let x = 1.0 + mirror * (x + shift * d);
                csv += &format!("{k},{t},{which},{x},{},0,{},{},0,0,0\n", 6.0 - s, -(v + faster * u_ref), mirror * w);
            }
        }
        std::fs::write(dir.join("bodies.csv"), csv).unwrap();
        analyse(&dir, Some(&ReferenceCurves::Shipped)).unwrap().0
    };
    for mirror in [1.0, -1.0] {
        let r = write(if mirror > 0.0 { "same" } else { "mirrored" }, mirror, 0.0, 0.0);
        let e = [r.rms_position_error_over_d, r.rms_lateral_error_over_d, r.rms_speed_error_over_uref];
        let e = e.map(Option::unwrap);
        let w = r.rms_angular_velocity_error_tref.unwrap();
        eprintln!("mirror {mirror}: {e:?}, ω {w:.2e}");
        assert!(e.iter().all(|e| *e < 1e-3) && w < 1e-3, "mirror {mirror}: {e:?}, ω {w}");
    }
    let r = write("moved", 1.0, 0.1, 0.05);
    let (lateral, speed) = (r.rms_lateral_error_over_d.unwrap(), r.rms_speed_error_over_uref.unwrap());
    eprintln!("moved: lateral {lateral:.5} d, speed {speed:.5} u_ref");
    assert!((lateral - 0.1).abs() < 1e-3 && (speed - 0.05).abs() < 1e-3, "{lateral}, {speed}");
}
