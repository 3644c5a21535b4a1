//! The `dem` contact through whole runs with no fluid: two mass-point disks (a Lagrangian
//! field with `representation: MassPoint`, alone) collide, the frame integrating the
//! contact force and torque over each step (symplectic Euler: v += Δt F/m, then
//! x += Δt v).

use multifield::run::{run, RunOptions};
use multifield_core::case::Case;
use multifield_core::math::Real;
use std::path::Path;

/// Two disks (radius 0.1, mass 2π·0.01·2) in a periodic box, their centres `gap` apart
/// along x and `offset` along y, approaching at ±`speed` along x until `end`; contact
/// `contact`. Returns the rows of bodies.csv as (time, body, [x, y, vx, vy, ω]).
fn collide(
    name: &str,
    gap: Real,
    offset: Real,
    speed: Real,
    end: Real,
    contact: &str,
) -> Vec<(Real, String, [Real; 5])> {
    multifield::link_all();
    let text = format!(
        r#"(
        name: "dem_{name}",
        domain: (size: (1.0, 1.0), cells: (10, 10)),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        gravity: (0.0, 0.0),
        time: (end: {end}, cfl: 0.4, max_dt: 1.0),
        fields: [(
            name: "disks",
            density: 2.0,
            representation: MassPoint,
            frame: (model: "lagrangian"),
            region: Bodies([
                (name: "a", shape: Disk(center: ({x0}, {y0}), radius: 0.1), velocity: ({speed}, 0.0)),
                (name: "b", shape: Disk(center: ({x1}, {y1}), radius: 0.1), velocity: (-{speed}, 0.0)),
            ]),
        )],
        contact: Some({contact}),
        output: (interval: 0.0, charts: false),
    )"#,
        x0 = 0.5 - 0.5 * gap,
        x1 = 0.5 + 0.5 * gap,
        y0 = 0.5 - 0.5 * offset,
        y1 = 0.5 + 0.5 * offset,
    );
    let case = Case::from_ron(&text, Path::new("dem.ron")).unwrap();
    let dir = std::env::temp_dir().join(format!("mf_dem_{name}_{}", std::process::id()));
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.summary.status, "completed", "{}", out.summary.reason);
    let text = std::fs::read_to_string(dir.join("bodies.csv")).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    text.lines()
        .skip(1)
        .map(|line| {
            let c: Vec<&str> = line.split(',').collect();
            (c[1].parse().unwrap(), c[2].to_string(), std::array::from_fn(|k| c[3 + k].parse().unwrap()))
        })
        .collect()
}

/// Head-on, t_c = 0.01 in 1000 steps: the disks leave with e times their approach speed
/// (within 1 %; the explicit dashpot errs by O(|ln e| Δt/t_c), depending on where the
/// contact begins within a step: at e = 0.1, −2 %, −1 %, −1.6 %, −0.2 % with 100, 200,
/// 400, 1000 steps per collision), the contact (the rows where the centres are closer than 2R) lasts t_c to a
/// step, and the momentum stays zero.
#[test]
fn two_disks_rebound_with_the_prescribed_restitution_in_a_run() {
    for e in [0.9, 0.5, 0.1] {
        let contact =
            format!(r#"(model: "dem", params: (restitution: {e}, collision_time: 0.01, steps_per_collision: 1000))"#);
        let rows = collide(&format!("head_on_{e}"), 0.204, 0.0, 1.0, 0.015, &contact);
        let last = &rows[rows.len() - 2..];
        let (a, b) = (&last[0].2, &last[1].2);
        let ratio = (b[2] - a[2]) / 2.0;
        eprintln!("e = {e}: rebound/approach {ratio:.5}");
        assert!((ratio / e - 1.0).abs() < 1e-2, "e = {e}: rebound/approach {ratio}");
        assert!((a[2] + b[2]).abs() < 1e-12, "momentum {}", a[2] + b[2]);
        // contact: the steps whose start has the disks overlapping
        let dt = 0.01 / 1000.0;
        let touching = rows.chunks(2).filter(|p| (p[1].2[0] - p[0].2[0]) < 0.2).count();
        let duration = touching as Real * dt;
        eprintln!("e = {e}: contact {duration:.5} s");
        assert!((duration - 0.01).abs() <= 1.5 * dt, "e = {e}: contact {duration} s against t_c = 0.01");
    }
}

/// Off-centre (the line of centres at 30° to the motion at contact) with friction μ = 0.05:
/// ψ = v_t/v_n = 0.58 at the contact point, twice Walton's 3μ(1 + e), so the contact slides
/// throughout. Each disk's velocity across the line of centres changes by μ(1 + e) times
/// its normal approach speed, and its spin by 2μ(1 + e)v_n/R, Walton's sliding branch
/// (Foerster et al. 1994), within 1 %. A short contact (t_c = 10⁻⁴: the disks move 5 · 10⁻⁴
/// diameters meanwhile), as the textbook's instantaneous collision assumes: with
/// t_c = 0.01 the line of centres turns 4° during the contact and Δv_t is off by half.
#[test]
fn an_oblique_collision_with_friction_gives_the_sliding_impulse_in_a_run() {
    let (e, mu) = (0.9, 0.05);
    let contact = format!(
        r#"(model: "dem", params: (restitution: {e}, collision_time: 1e-4, friction: {mu}, steps_per_collision: 100))"#
    );
    // centres 0.1772 apart along x at first, 0.1 along y: contact at sin 30° = 0.1/0.2
    let rows = collide("oblique", 0.1772, 0.1, 1.0, 0.0025, &contact);
    let last = &rows[rows.len() - 2..];
    let a = &last[0].2;
    // the line of centres at contact: n = (cos 30°, sin 30°) from a to b
    let (c, s) = ((3.0 as Real).sqrt() / 2.0, 0.5);
    let vn0 = 1.0 * c; // each disk's normal speed; relative 2 v_n0
    let vt0 = -s; // a's velocity along t = (−sin, cos)
    let vn = a[2] * c + a[3] * s;
    let vt = -a[2] * s + a[3] * c;
    let impulse = mu * (1.0 + e) * vn0; // per unit mass: μ (1 + e) m_eff 2 v_n0 / m
    eprintln!(
        "oblique: v_n {vn:.5} (expected {:.5}), v_t {vt:.5} (expected {:.5}), ω {:.4}",
        -e * vn0,
        vt0 + impulse,
        a[4]
    );
    assert!((vn / (-e * vn0) - 1.0).abs() < 1e-2, "normal: {vn}");
    assert!(((vt - vt0) / impulse - 1.0).abs() < 1e-2, "tangential change {} against {impulse}", vt - vt0);
    assert!((a[4] / (2.0 * impulse / 0.1) - 1.0).abs() < 1e-2, "spin {} against {}", a[4], 2.0 * impulse / 0.1);
}
