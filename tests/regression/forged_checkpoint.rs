//! A checkpoint with a recomputed checksum but impossible point state panicked inside a
//! frame ("a stencil off the padded lattice", "range start index 18446744073709548127")
//! and the run ended `failed` (issue 20). The state is now checked on loading: the
//! restart is refused (exit code 2) with the point and the reason.

use crate::hostile_input::{example, multifield, scratch};
use multifield::checkpoint::{self, RunnerState};
use multifield::core::case::Case;
use multifield::core::driver::RunState;
use multifield::core::math::Vector;
use multifield::core::simulation::Simulation;
use multifield::frames::lagrangian::Lagrangian;

/// A checkpoint of `case` at step 0 whose first point is moved by `forge`, encoded with a
/// valid header and CRC-32.
fn forged(case: &Case, forge: impl Fn(&mut Lagrangian)) -> Vec<u8> {
    let mut sim = Simulation::new(case).unwrap();
    let frame = sim.fields[0].frame.as_any_mut().downcast_mut::<Lagrangian>().expect("a Lagrangian field");
    forge(frame);
    checkpoint::encode(&sim, &RunnerState::of(&RunState::new(&sim))).unwrap()
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
