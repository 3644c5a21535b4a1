//! A checkpoint with a recomputed checksum but impossible point state panicked inside a
//! frame ("a stencil off the padded lattice", "range start index 18446744073709548127")
//! and the run ended `failed` (issue 20). The state is now checked on loading: the
//! restart is refused (exit code 2) with the point and the reason. So is every other
//! class of state: an Eulerian field's grid arrays, bodies, mass points and the stress
//! models' per-point state, each naming the field, the array, the index and the value.

use crate::hostile_input::{example, multifield, scratch};
use multifield::checkpoint::{self, RunnerState};
use multifield::core::case::Case;
use multifield::core::driver::RunState;
use multifield::core::math::Vector;
use multifield::core::simulation::Simulation;
use multifield::frames::lagrangian::Lagrangian;
use multifield::frames::mass_point::MassPoint;

/// A checkpoint of `case` at step 0 whose first point is moved by `forge`, encoded with a
/// valid header and CRC-32.
fn forged(case: &Case, forge: impl Fn(&mut Lagrangian)) -> Vec<u8> {
    forged_simulation(case, |sim| forge(lagrangian(sim, 0)))
}

/// A checkpoint of `case` at step 0 changed by `forge`, encoded with a valid header and
/// CRC-32.
fn forged_simulation(case: &Case, forge: impl Fn(&mut Simulation)) -> Vec<u8> {
    let mut sim = Simulation::new(case).unwrap();
    forge(&mut sim);
    checkpoint::encode(&sim, &RunnerState::of(&RunState::new(&sim))).unwrap()
}

/// The Lagrangian frame of field `k`.
fn lagrangian(sim: &mut Simulation, k: usize) -> &mut Lagrangian {
    sim.fields[k].frame.as_any_mut().downcast_mut::<Lagrangian>().expect("a Lagrangian field")
}

/// A forgery of a simulation and the parts of the message that refuses it.
type Forgery = (Box<dyn Fn(&mut Simulation)>, Vec<&'static str>);

/// Restarts the example `name` (with `overrides`) from each forged checkpoint and asserts
/// that it is refused as bad input (exit code 2) in under a second, naming the file and
/// every part, without a panic.
fn refused(test: &str, name: &str, overrides: &[&str], forgeries: Vec<Forgery>) {
    multifield::link_all();
    let dir = scratch(test);
    let file = example(name);
    let sets: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let case = Case::load(&file, &sets).unwrap();
    for (k, (forge, parts)) in forgeries.into_iter().enumerate() {
        let path = dir.join(format!("forged_{k}.bin"));
        std::fs::write(&path, forged_simulation(&case, forge)).unwrap();
        let out = dir.join(format!("out_{k}"));
        let mut args: Vec<std::ffi::OsString> =
            vec!["run".into(), file.clone().into(), "--quiet".into(), "--out".into(), out.into()];
        for s in overrides {
            args.extend(["--set".into(), (*s).into()]);
        }
        args.extend(["--restart".into(), path.clone().into()]);
        let ran = multifield(&args);
        let name = format!("forged_{k}.bin");
        let mut all = vec![name.as_str(), "does not fit the case"];
        all.extend(parts);
        ran.refused_with(&all);
        assert!(!ran.stderr.contains("panicked"), "{}", ran.stderr);
    }
}

#[test]
fn a_forged_eulerian_grid_state_is_refused_on_loading() {
    refused(
        "forged_eulerian",
        "taylor_green.ron",
        &[],
        vec![
            (
                Box::new(|s: &mut Simulation| s.fields[0].state.velocity.u[12] = Real::NAN),
                vec!["field `fluid`: velocity on x-faces[12] is NaN, not a finite number"],
            ),
            (
                Box::new(|s: &mut Simulation| s.fields[0].state.mass_face.v[7] = Real::NEG_INFINITY),
                vec!["field `fluid`: y-face mass[7] is -inf, not a finite number"],
            ),
            (
                Box::new(|s: &mut Simulation| {
                    s.fields[0].state.theta.pop();
                }),
                vec!["field `fluid`: volume fraction: 1023 values in the checkpoint, 1024 here"],
            ),
            (
                Box::new(|s: &mut Simulation| s.fields[0].state.theta[40] = -0.5),
                vec!["field `fluid`: volume fraction[40] is -0.5, outside [-0.000001, 2]"],
            ),
            (
                Box::new(|s: &mut Simulation| s.fields[0].state.theta_face.u[3] = 7.0),
                vec!["field `fluid`: x-face volume fraction[3] is 7, outside [-0.000001, 2]"],
            ),
            (
                Box::new(|s: &mut Simulation| s.fields[0].state.mass_face.u[5] = -1.0),
                vec!["field `fluid`: x-face mass[5] is -1, outside", "a mass is not negative"],
            ),
            (
                Box::new(|s: &mut Simulation| s.pressure[9] = Real::INFINITY),
                vec!["pressure[9] is inf, not a finite number"],
            ),
        ],
    );
}

#[test]
fn forged_body_states_are_refused_on_loading() {
    refused(
        "forged_bodies",
        "colliding_disks.ron",
        &[],
        vec![
            (
                Box::new(|s: &mut Simulation| lagrangian(s, 0).bodies[1].state.position = Vector::new(3.0, 0.5)),
                vec!["field `disks`: body `upper` has its centre at (3, 0.5), outside the domain [0, 1] × [0, 1]"],
            ),
            (
                Box::new(|s: &mut Simulation| lagrangian(s, 0).bodies[0].state.velocity.y = Real::NAN),
                vec!["field `disks`: body `lower`: velocity.1 is NaN, not a finite number"],
            ),
            (
                Box::new(|s: &mut Simulation| lagrangian(s, 0).bodies[0].state.angular_velocity = Real::INFINITY),
                vec!["field `disks`: body `lower`: angular_velocity is inf, not a finite number"],
            ),
            (
                Box::new(|s: &mut Simulation| {
                    lagrangian(s, 0).bodies.pop();
                }),
                vec!["field `disks`: 1 bodies in the checkpoint, 2 in the case"],
            ),
        ],
    );
}

#[test]
fn forged_mass_points_are_refused_on_loading() {
    fn point(s: &mut Simulation) -> &mut multifield::core::plugin::BodyState {
        let frame = s.fields[1].frame.as_any_mut().downcast_mut::<MassPoint>().expect("a mass-point field");
        &mut frame.points[0].state
    }
    refused(
        "forged_mass_points",
        "sedimentation.ron",
        &["fields.disks.representation=MassPoint"],
        vec![
            (
                Box::new(|s: &mut Simulation| point(s).position = Vector::new(1.0, -40.0)),
                vec!["field `disks`: body `disk` has its centre at (1, -40), outside the domain [0, 2] × [0, 6]"],
            ),
            (
                Box::new(|s: &mut Simulation| point(s).velocity.x = Real::NAN),
                vec!["field `disks`: body `disk`: velocity.0 is NaN, not a finite number"],
            ),
            (
                Box::new(|s: &mut Simulation| point(s).radius = -0.125),
                vec!["field `disks`: point `disk` has radius -0.125: not a positive number"],
            ),
            (
                Box::new(|s: &mut Simulation| {
                    s.fields[1].frame.as_any_mut().downcast_mut::<MassPoint>().unwrap().points.clear();
                }),
                vec!["field `disks`: 0 points in the checkpoint, 1 bodies in the case"],
            ),
        ],
    );
}

#[test]
fn a_forged_stress_state_is_refused_on_loading() {
    refused(
        "forged_stress_state",
        "elastic_bar.ron",
        &[],
        vec![
            (
                Box::new(|s: &mut Simulation| {
                    let n = lagrangian(s, 0).points.len();
                    lagrangian(s, 0).points.model_state = vec![vec![0.5; 3 * n]];
                }),
                vec![
                    "field `bar`: point state of stress `linear_elastic` (0 values per point): ",
                    " values in the checkpoint, 0 here",
                ],
            ),
            (
                Box::new(|s: &mut Simulation| lagrangian(s, 0).points.model_state = vec![Vec::new(), Vec::new()]),
                vec!["field `bar`: the points hold the state of 2 stress models, the field has 1"],
            ),
            (
                Box::new(|s: &mut Simulation| lagrangian(s, 0).points.f[17][(1, 0)] = Real::NAN),
                vec!["field `bar`: deformation gradient of point[17].", " is NaN, not a finite number"],
            ),
            (
                Box::new(|s: &mut Simulation| lagrangian(s, 0).points.stress[4][(0, 0)] = Real::INFINITY),
                vec!["field `bar`: point 4: stress[0] is inf, not a finite number"],
            ),
        ],
    );
}

#[test]
fn a_forged_checkpoint_is_refused_on_loading() {
    multifield::link_all();
    let dir = scratch("forged_checkpoint");
    let file = example("taylor_green_flip.ron");
    let case = Case::load(&file, &[]).unwrap();
    for (k, (forge, reason)) in [
        (
            Box::new(|f: &mut Lagrangian| f.points.x[0] = Vector::new(-1000.0, 3.0)) as Box<dyn Fn(&mut Lagrangian)>,
            "point 0 is at (-1000, 3), outside the domain",
        ),
        (
            Box::new(|f: &mut Lagrangian| f.points.x[0] = Vector::new(Real::NAN, 3.0)),
            "point 0 is at (NaN, 3), outside the domain",
        ),
        (
            Box::new(|f: &mut Lagrangian| f.points.v[0] = Vector::new(Real::INFINITY, 0.0)),
            "point 0 has velocity (inf, 0)",
        ),
        (
            Box::new(|f: &mut Lagrangian| {
                f.points.x.pop();
            }),
            "the point arrays have different lengths",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let path = dir.join(format!("forged_{k}.bin"));
        std::fs::write(&path, forged(&case, forge)).unwrap();
        let out = dir.join(format!("out_{k}"));
        let ran = multifield(&[
            "run".as_ref(),
            file.as_os_str(),
            "--quiet".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
            "--restart".as_ref(),
            path.as_os_str(),
        ]);
        ran.refused_with(&[&format!("forged_{k}.bin"), "field `fluid`", reason]);
        assert!(!ran.stderr.contains("panicked"), "{}", ran.stderr);
    }
}

use multifield::core::math::Real;
