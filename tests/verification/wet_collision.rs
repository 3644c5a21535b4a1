//! Wet collisions (issue 15): a resolved disk (direct forcing) launched at a wall through a
//! viscous fluid rebounds less the more viscous the fluid, and not at all below a critical
//! Stokes number St = ρs U d/(9μ); the `dem` contact's lubrication (docs/method.md §4,
//! "Lubrication below the grid scale") carries the film the grid cannot resolve.

use multifield_core::case::Case;
use multifield_core::math::Real;
use multifield_core::simulation::Simulation;
use std::path::Path;

/// Disk diameter, its density, the fluid's, the launch speed.
const D: Real = 0.25;
const RHO_S: Real = 8.0;
const RHO_F: Real = 1.0;
const U: Real = 1.0;
/// The dry restitution and the roughness (over the radius) of every run.
const E_DRY: Real = 0.97;
const ROUGHNESS: Real = 1e-3;

/// The viscosity that gives the Stokes number `st` at the launch speed.
fn viscosity(st: Real) -> Real {
    RHO_S * U * D / (9.0 * st)
}

/// A disk of diameter D in a closed 6 D × 4 D box at `cells` per diameter, its surface
/// 1 D above the bottom wall, launched down at U into fluid at rest (no gravity), `dem`
/// contact with e_dry and t_c = 1e-3 in sub-steps, with or without lubrication.
fn case(st: Real, cells: usize, lubrication: bool) -> Case {
    let mu = viscosity(st);
    let (nx, ny) = (6 * cells, 4 * cells);
    let y = 0.5 * D + D;
    let text = format!(
        r#"(
        name: "wet_collision",
        domain: (size: ({w}, {h}), cells: ({nx}, {ny})),
        boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
        gravity: (0.0, 0.0),
        time: (end: 0.8, cfl: 0.4, max_dt: 2e-3, contact_substeps: true),
        fields: [
            (name: "fluid", density: {RHO_F}, frame: (model: "eulerian"), region: Rest,
             stress: [(model: "newtonian", params: (viscosity: {mu}))]),
            (name: "disk", density: {RHO_S}, frame: (model: "lagrangian"),
             region: Bodies([(name: "disk", shape: Disk(center: ({x}, {y}), radius: {r}), velocity: (0.0, -{U}))]),
             stress: [(model: "rigid")]),
        ],
        exchange: [(between: ("fluid", "disk"), model: "direct_forcing")],
        contact: Some((model: "dem", params: (restitution: {E_DRY}, collision_time: 1e-3,
                       lubrication: {lubrication}, roughness: {ROUGHNESS}))),
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid", tolerance: 1e-10))),
    )"#,
        w = 6.0 * D,
        h = 4.0 * D,
        x = 3.0 * D,
        r = 0.5 * D,
    );
    Case::from_ron(&text, Path::new("wet_collision.ron")).unwrap()
}

/// One collision's figures.
#[derive(Debug)]
struct Bounce {
    /// The approach speed where the gap is D/2 (interpolated between steps).
    u_in: Real,
    /// The largest upward speed after the smallest gap (0 if none).
    u_out: Real,
    /// The smallest gap over the radius.
    min_gap: Real,
}

impl Bounce {
    fn restitution(&self) -> Real {
        self.u_out.max(0.0) / self.u_in
    }
}

/// Runs `case` on one thread until 0.15 after the smallest gap (or its end).
fn bounce(case: &Case) -> Bounce {
    multifield::link_all();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    pool.install(|| {
        let mut sim = Simulation::new(case).expect("builds");
        let a = 0.5 * D;
        let state = |sim: &Simulation| {
            let b = &sim.bodies()[0].1;
            (sim.time, b.position.y - a, b.velocity.y)
        };
        let mut rows = vec![state(&sim)];
        let (mut t_min, mut min_gap) = (0.0, Real::INFINITY);
        while sim.time < case.time.end * (1.0 - 1e-12) && sim.time < t_min + 0.15 {
            sim.step().expect("steps");
            let (t, gap, v) = state(&sim);
            rows.push((t, gap, v));
            if gap < min_gap {
                (t_min, min_gap) = (t, gap);
            } else if v <= 0.0 && t_min > 0.0 && sim.time > t_min + 0.05 {
                break;
            }
        }
        let k = rows.iter().position(|r| r.1 < 0.5 * D).expect("reaches D/2");
        let (p, q) = (rows[k - 1], rows[k]);
        let s = (p.1 - 0.5 * D) / (p.1 - q.1);
        let u_in = -(p.2 + s * (q.2 - p.2));
        let u_out = rows.iter().filter(|r| r.0 > t_min).map(|r| r.2).fold(0.0, Real::max);
        Bounce { u_in, u_out, min_gap: min_gap / a }
    })
}

/// The film alone (module docs of `dem`): the speed a disk of mass m = ρs π a² loses to
/// the lubrication 3π√2 μ v [(a/ε)^{3/2} − (a/ε_act)^{3/2}] between ε_act and the
/// roughness ε_0 (saturated below), ΔV = 3π√2 μ a^{3/2}/m [2(ε_0^{-1/2} − ε_act^{-1/2})
/// − ε_act^{-3/2}(ε_act − ε_0)]; it loses as much on the way out after the dry contact
/// returns e_dry of what is left: e = e_dry − (1 + e_dry) ΔV/U_in (0 when negative).
fn film_restitution(st: Real, cells: usize, u_in: Real) -> Real {
    let (a, mu) = (0.5 * D, viscosity(st));
    let (e0, act) = (ROUGHNESS * a, D / cells as Real);
    let m = RHO_S * std::f64::consts::PI * a * a;
    let c = 3.0 * std::f64::consts::PI * std::f64::consts::SQRT_2 * mu * a.powf(1.5) / m;
    let dv = c * (2.0 * (e0.powf(-0.5) - act.powf(-0.5)) - act.powf(-1.5) * (act - e0));
    (E_DRY - (1.0 + E_DRY) * dv / u_in).max(0.0)
}

/// At 8 cells per diameter, St = 20 to 640 at launch (13.6 to 503 at the approach speed
/// U_in): where the film alone leaves no rebound (St ≤ 80; its critical St ≈ 140 here, far
/// above the 3D experiments' ≈ 10, the 2D film being the stiffer) the disk never reaches the
/// roughness and comes back at under 5 % of U_in (measured 2.3–3.3 %: the fluid's push-back,
/// no contact); from there e rises strictly with St, and at St 160, the first rebound, it is
/// the film's within 0.03 (measured 0.122 against 0.110). Above, the grid's own film
/// dissipates more than the theory's: e/e_dry = 0.18 at St 640 against the film's 0.78 and
/// the 3D fit exp(−35/St)'s 0.93 (docs/validation.md, "Wet collisions").
#[test]
fn the_wet_restitution_falls_with_the_stokes_number() {
    let mut rows = Vec::new();
    for st in [20.0, 40.0, 80.0, 160.0, 320.0, 640.0] {
        let b = bounce(&case(st, 8, true));
        let e = b.restitution();
        let st_in = RHO_S * b.u_in * D / (9.0 * viscosity(st));
        let film = film_restitution(st, 8, b.u_in);
        eprintln!(
            "St {st} (at impact {st_in:.1}): U_in {:.4}, U_out {:.4}, e {e:.4} (e/e_dry {:.4}; film alone {film:.4}; \
             3D fit exp(-35/St) {:.4}), smallest gap {:.2e} a",
            b.u_in,
            b.u_out,
            e / E_DRY,
            (-35.0 / st_in).exp(),
            b.min_gap
        );
        rows.push((st, e, film, b.min_gap));
    }
    for &(st, e, film, gap) in &rows {
        if film == 0.0 {
            assert!(e < 0.05 && gap > ROUGHNESS, "St {st}: e {e}, smallest gap {gap} a, and the film stops it");
        }
    }
    let first = rows.iter().position(|r| r.2 > 0.0).expect("a rebound in the sweep");
    assert_eq!(rows[first].0, 160.0, "the film's first rebound");
    assert!(
        (rows[first].1 - rows[first].2).abs() < 0.03,
        "St 160: e {} against the film's {}",
        rows[first].1,
        rows[first].2
    );
    for w in rows[first - 1..].windows(2) {
        assert!(w[1].1 > w[0].1, "e falls from St {} to {}: {} to {}", w[0].0, w[1].0, w[0].1, w[1].1);
    }
}

/// 8 and 16 cells per diameter at St 160 and 640: without lubrication the rebound depends
/// on the grid's film (measured e 0.20 → 0.66 and 0.27 → 0.76, the disk turned back by the
/// unresolved film before it touched), with it the spread is under half as large (measured
/// 0.12 → 0.01 and 0.18 → 0.36).
#[test]
fn the_lubrication_makes_the_wet_restitution_less_grid_dependent() {
    for st in [160.0, 640.0] {
        let mut spread = [0.0; 2];
        for (k, lubrication) in [false, true].into_iter().enumerate() {
            let e: Vec<Real> = [8, 16]
                .iter()
                .map(|&cells| {
                    let b = bounce(&case(st, cells, lubrication));
                    eprintln!(
                        "St {st}, {cells} cells per d, lubrication {lubrication}: {b:?}, e {:.4}",
                        b.restitution()
                    );
                    b.restitution()
                })
                .collect();
            eprintln!("St {st}, lubrication {lubrication}: e {:.4} (8), {:.4} (16)", e[0], e[1]);
            spread[k] = (e[1] - e[0]).abs();
        }
        assert!(spread[1] < 0.5 * spread[0], "St {st}: spread {} with lubrication, {} without", spread[1], spread[0]);
    }
}

/// Lubrication takes the viscosity from the case: without a Newtonian ambient fluid the
/// case is refused, saying why and what to do.
#[test]
fn lubrication_without_a_newtonian_fluid_is_refused() {
    multifield::link_all();
    let mut case = case(100.0, 8, true);
    case.fields[0].stress.clear();
    let err = Simulation::new(&case).err().expect("refused").to_string();
    assert!(err.contains("contact.params.lubrication"), "{err}");
    assert!(err.contains("the ambient fluid `fluid` has no Newtonian stress"), "{err}");
    assert!(err.contains("or set lubrication: false"), "{err}");
}

/// The activation gap ε_act (`lubrication_range`, in cells) against the grid: the spread of
/// e between 8 and 16 cells per diameter at St 640 for ranges ½, 1 and 2 cells (a
/// measurement for docs/defaults.md; `--ignored`).
#[test]
#[ignore]
fn the_activation_gap_against_the_grid() {
    for range in [0.5, 1.0, 2.0] {
        let e: Vec<Real> = [8, 16]
            .iter()
            .map(|&cells| {
                let mut c = case(640.0, cells, true);
                c.contact.as_mut().unwrap().params["lubrication_range"] = serde_json::json!(range);
                bounce(&c).restitution()
            })
            .collect();
        eprintln!(
            "St 640, ε_act = {range} h: e {:.4} (8 cells), {:.4} (16), spread {:.4}",
            e[0],
            e[1],
            (e[1] - e[0]).abs()
        );
    }
}
