//! The output quantities' registry (`core::quantity`): the shipped quantities against
//! analytic values, the names a case may give and the errors for the others. The plugin
//! quantity is tested with its plugin (tests/input/external_plugin.rs).

use multifield::core::case::{Case, PictureSpec, QuantityName};
use multifield::core::quantity::{find, quantities, Place, Sample};
use multifield::core::simulation::Simulation;
use std::f64::consts::PI;
use std::path::Path;

fn load(file: &str, sets: &[&str]) -> Case {
    multifield::link_all();
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    Case::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file), &sets).unwrap()
}

/// The Taylor–Green vortex u = (sin x cos y, −cos x sin y) has ω = 2 sin x sin y. The
/// vorticity of its cell-centred velocity (each component the mean of its two faces, then
/// central differences) errs by O(h²): the observed order is 2.
#[test]
fn the_vorticity_of_the_taylor_green_vortex_converges_at_second_order() {
    let q = find("vorticity", Place::Mixture).unwrap();
    let mut errors = Vec::new();
    for n in [16, 32, 64] {
        let sim = Simulation::new(&load("examples/taylor_green.ron", &[&format!("domain.cells=({n}, {n})")])).unwrap();
        let w = Sample::of(&sim).cells(q, None).unwrap();
        let g = &sim.grid;
        let mut worst: f64 = 0.0;
        for j in 0..g.ny {
            for i in 0..g.nx {
                let p = g.cell_center(i, j);
                worst = worst.max((w[g.cell(i, j)] - 2.0 * p.x.sin() * p.y.sin()).abs());
            }
        }
        errors.push(worst);
    }
    let orders: Vec<f64> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
    println!("vorticity errors on 16², 32², 64²: {errors:?}; orders {orders:.3?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    assert!((orders[1] - 2.0).abs() < 0.05 && orders[0] > 1.9, "orders {orders:?}");
}

/// After the projection, the field's MAC divergence is the pressure solve's residual; the
/// mixture's is the same with one field filling the domain (to round-off: its θ is
/// advected and stays 1 to the divergence the solve leaves). The speed is |u| of the
/// cell-centred velocity, and θ is 1 everywhere.
#[test]
fn after_a_projection_the_divergence_vanishes_and_the_quantities_agree() {
    let mut sim = Simulation::new(&load("examples/taylor_green.ron", &[])).unwrap();
    for _ in 0..3 {
        sim.step().unwrap();
    }
    let s = Sample::of(&sim);
    let field = s.cells(find("divergence", Place::Field).unwrap(), Some(0)).unwrap();
    let mixture = s.cells(find("divergence", Place::Mixture).unwrap(), None).unwrap();
    let scale = sim.fields[0].state.velocity.u.iter().fold(0.0_f64, |m, u| m.max(u.abs())) / sim.grid.h;
    let worst = field.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
    println!("max |∇·u| {worst:.3e} against max |u|/h = {scale:.3e}");
    assert!(scale > 1.0 && worst < 1e-8 * scale, "{worst:e}");
    // one field filling the domain: the same divergence, to the round-off by which its
    // advected θ differs from 1
    let apart = field.iter().zip(&mixture).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(apart < 1e-12 * scale, "the mixture's divergence differs by {apart:e}");
    let speed = s.cells(find("speed", Place::Mixture).unwrap(), None).unwrap();
    let velocity = s.cells(find("velocity", Place::Mixture).unwrap(), None).unwrap();
    for c in 0..speed.len() {
        assert_eq!(speed[c], velocity[3 * c].hypot(velocity[3 * c + 1]));
        assert_eq!(velocity[3 * c + 2], 0.0);
    }
    let theta = s.cells(find("theta", Place::Field).unwrap(), Some(0)).unwrap();
    assert!(theta.iter().all(|t| (t - 1.0).abs() < 1e-12));
    let density = s.cells(find("density", Place::Mixture).unwrap(), None).unwrap();
    assert!(density.iter().zip(&theta).all(|(d, t)| *d == t * sim.fields[0].density));
    // the analytic speed of the decaying vortex, |u| = e^(−2νt) √(sin²x cos²y + cos²x sin²y)
    let decay = (-2.0 * 0.01 * sim.time).exp();
    let g = &sim.grid;
    let mut worst: f64 = 0.0;
    for j in 0..g.ny {
        for i in 0..g.nx {
            let p = g.cell_center(i, j);
            let exact = decay * (p.x.sin() * p.y.cos()).hypot(p.x.cos() * p.y.sin());
            worst = worst.max((speed[g.cell(i, j)] - exact).abs());
        }
    }
    assert!(worst < 0.01, "speed off the analytic vortex by {worst}");
}

/// Point quantities come from the frames' point views: a mass-point field's one point per
/// body carries its body's volume πR² and mass, and a resolved disk's points sum to it.
#[test]
fn point_quantities_of_a_resolved_disk_and_of_its_mass_point() {
    let resolved = Simulation::new(&load("examples/settling_disk.ron", &[])).unwrap();
    let k = resolved.fields.iter().position(|f| f.frame.points().is_some()).unwrap();
    let volume = find("volume", Place::Points).unwrap();
    let v = multifield::core::quantity::points(&resolved, k, volume).unwrap();
    let body = &resolved.fields[k].frame.bodies()[0];
    let total: f64 = v.iter().sum();
    println!(
        "resolved disk: {} points, Σ V {total:.6e}, body volume {:.6e}, πR² {:.6e}",
        v.len(),
        body.volume,
        PI * body.radius.powi(2)
    );
    assert!((total - body.volume).abs() < 1e-12 * total, "Σ V {total} against the body's {}", body.volume);
    let points = resolved.fields[k].frame.points().unwrap();
    assert!(points.body.iter().all(|b| *b == 0));
    assert_eq!(points.bodies, std::slice::from_ref(&body.name));
    // the same disk as one mass point: one point that stands for the whole body
    let sets = [
        "fields.disk.representation=MassPoint",
        "exchange.0.mass_point=Some((model: \"cylinder\", params: (added_mass: 1.0)))",
    ];
    let point = Simulation::new(&load("examples/settling_disk.ron", &sets)).unwrap();
    let p = point.fields[k].frame.points().unwrap();
    let b = &point.fields[k].frame.bodies()[0];
    assert!(p.len() == 1 && p.body == [0] && p.bodies == std::slice::from_ref(&b.name));
    assert_eq!((p.volume[0], p.mass[0], p.position[0]), (b.volume, b.mass, b.position));
    println!("mass point: volume {:.6e} (πR² {:.6e})", b.volume, PI * b.radius.powi(2));
    assert!((b.volume - PI * b.radius.powi(2)).abs() < 1e-12 * b.volume, "a mass point carries the disk's volume");
}

#[test]
fn names_are_checked_against_the_registry_with_the_choices() {
    let err = |sets: &[&str]| {
        multifield::link_all();
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green.ron");
        Case::load(&file, &sets).err().map(|e| e.to_string()).unwrap_or_default()
    };
    let e = err(&["output.pictures=Some((interval: 0.1, quantity: \"vortcity\"))"]);
    assert!(e.contains("output.pictures.quantity") && e.contains("did you mean `vorticity`"), "{e}");
    let e = err(&["output.snapshots=Some((interval: 0.1, fields: [\"pressure\"]))"]);
    assert!(e.contains("output.snapshots.fields") && e.contains("theta"), "the choices are listed: {e}");
    let e = err(&["output.snapshots=Some((interval: 0.1, points: [\"volume\", \"volume\"]))"]);
    assert!(e.contains("listed twice"), "{e}");
    let e = err(&["output.pictures=Some((interval: 0.1, quantity: \"theta\", field: Some(\"water\")))"]);
    assert!(e.contains("no field `water`") && e.contains("fluid"), "{e}");
    // the former closed list's identifiers are still read, in a file and in --set
    let c = load("examples/taylor_green.ron", &["output.pictures=Some((interval: 0.1, quantity: Speed))"]);
    assert_eq!(c.output.pictures.unwrap().quantity, QuantityName("velocity".into()));
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/taylor_green.ron"))
        .unwrap()
        .replace(
            "output: (interval: 0.1)",
            "output: (interval: 0.1, pictures: Some((interval: 0.1, quantity: VolumeFraction)))",
        );
    let c = Case::from_ron(&text, Path::new("tg.ron")).unwrap();
    let p: PictureSpec = c.output.pictures.unwrap();
    assert_eq!((p.quantity.as_str(), p.field), ("theta", None));
    // a number is not a name
    let e = Case::from_ron(&text.replace("quantity: VolumeFraction", "quantity: 3"), Path::new("tg.ron")).unwrap_err();
    assert!(e.to_string().contains("tg.ron:") && e.to_string().contains("named by a string"), "{e}");
    // every shipped quantity is listed once per place
    let names: Vec<(&str, bool)> = quantities().iter().map(|q| (q.name, q.on_points())).collect();
    for (k, n) in names.iter().enumerate() {
        assert!(!names[..k].contains(n), "{n:?} registered twice");
    }
}
