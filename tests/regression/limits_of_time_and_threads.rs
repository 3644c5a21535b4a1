//! `time.end = inf` was accepted ("about inf steps to t = inf") and the run never ended;
//! `--threads 100000` spawned threads until the memory ran out; non-finite initial data
//! passed `check` and failed inside the pressure solver (issue 20). Now each is refused
//! before step 0 with the entry named.

use crate::hostile_input::{edited, example, multifield, scratch};

#[test]
fn a_time_end_that_is_not_finite_is_refused() {
    let dir = scratch("time_end_inf");
    let case = edited(&dir, "taylor_green.ron", "end: 2.0", "end: inf");
    for command in ["check", "run"] {
        multifield(&[command, case.to_str().unwrap(), "--quiet"][..if command == "run" { 3 } else { 2 }])
            .refused_with(&["taylor_green.ron: time.end: inf is not a finite number"]);
    }
    let tg = example("taylor_green.ron");
    for value in ["inf", "NaN", "1e400"] {
        let set = format!("time.end={value}");
        multifield(&["check", tg.to_str().unwrap(), "--set", &set])
            .refused_with(&[&format!("--set time.end={value}"), "is not a finite number"]);
    }
    multifield(&["check", tg.to_str().unwrap(), "--set", "time.end=-1"])
        .refused_with(&["time.end: -1: the end time must be positive"]);
}

#[test]
fn a_finite_time_end_beyond_the_clock_resolution_is_refused() {
    // 1e300 is finite, but t + Δt stops moving near t = 2⁵² Δt: the run would never end.
    // The bound is 10¹² steps of the first Δt (refused in under a second by `refused_with`).
    let tg = example("taylor_green.ron");
    let tg = tg.to_str().unwrap();
    multifield(&["check", tg, "--set", "time.end=1e300"]).refused_with(&[
        "time.end: 1e300:",
        "steps of the first Δt",
        "more than 1e12",
        "time.max_steps",
    ]);
    multifield(&[
        "run",
        tg,
        "--set",
        "time.end=1e300",
        "--quiet",
        "--out",
        scratch("time_end_1e300").to_str().unwrap(),
    ])
    .refused_with(&["time.end: 1e300:", "more than 1e12"]);
    // with time.max_steps the run is bounded, and such an end is only an upper bound
    let ran = multifield(&["check", tg, "--set", "time.end=1e300", "--set", "time.max_steps=Some(3)"]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
}

#[test]
fn a_hundred_thousand_threads_are_refused() {
    let case = example("taylor_green.ron");
    let ran = multifield(&["run", case.to_str().unwrap(), "--threads", "100000", "--quiet"]);
    ran.refused_with(&["--threads", "100000 threads: at most 1024"]);
}

#[test]
fn non_finite_initial_data_is_refused_before_step_0() {
    let dir = scratch("non_finite_initial_data");
    for (example, from, to, entry) in [
        ("taylor_green.ron", "amplitude: 1.0", "amplitude: NaN", "fields.fluid.velocity.TaylorGreen.amplitude: NaN"),
        ("dkt_seed.ron", "gravity: (0.0, -981.0)", "gravity: (0.0, -inf)", "gravity.1: -inf"),
        (
            "settling_disk.ron",
            "center: (1.0, 5.5)",
            "center: (NaN, 5.5)",
            "fields.disk.region.Bodies.disk.shape.Disk.center.0: NaN",
        ),
    ] {
        let case = edited(&dir, example, from, to);
        for command in ["check", "run"] {
            let out = dir.join(format!("out_{example}"));
            multifield(
                &[command.as_ref(), case.as_os_str(), "--out".as_ref(), out.as_os_str()]
                    [..if command == "run" { 4 } else { 2 }],
            )
            .refused_with(&[&format!("{example}: {entry} is not a finite number")]);
        }
    }
}

#[test]
fn a_plugin_parameter_that_is_not_finite_is_refused_at_its_place() {
    // serde_json's values have no NaN: it became `null` and the plugin said `invalid type: null`
    let dir = scratch("non_finite_parameter");
    let case = edited(&dir, "taylor_green.ron", "viscosity: 0.01", "viscosity: NaN");
    let text = std::fs::read_to_string(&case).unwrap();
    let line = text.lines().position(|l| l.contains("viscosity: NaN")).unwrap() + 1;
    let ran = multifield(&["check", case.to_str().unwrap()]);
    ran.refused_with(&[&format!("taylor_green.ron:{line}:"), "NaN is not a finite number"]);
    assert!(!ran.stderr.contains("null"), "{}", ran.stderr);
}
