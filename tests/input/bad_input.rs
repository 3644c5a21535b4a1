//! Bad input is rejected before step 0 with a message that names the place and the fix,
//! and the binary exits with code 2 instead of panicking.

use multifield::core::case::Case;
use multifield::core::simulation::Simulation;
use std::path::{Path, PathBuf};
use std::process::Command;

const GOOD: &str = r#"(
    name: "box",
    domain: (size: (1.0, 1.0), cells: (8, 8)),
    time: (end: 0.1, cfl: 0.4, max_dt: 0.01),
    fields: [
        (
            name: "water",
            density: 1.0,
            frame: (model: "eulerian"),
            region: All,
            stress: [(model: "newtonian", params: (viscosity: 0.01))],
        ),
    ],
    pressure: Some((model: "pcg")),
)
"#;

/// Writes `text` to a file named `name` in this test binary's scratch directory.
fn case_file(name: &str, text: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_input").join(name);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, text).unwrap();
    path
}

/// The error message of loading (and, if that passes, building) `text` with `overrides`.
fn error_of(name: &str, text: &str, overrides: &[&str]) -> String {
    multifield::link_all();
    let path = case_file(name, text);
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let e = match Case::load(&path, &overrides) {
        Err(e) => e,
        Ok(case) => match Simulation::new(&case) {
            Err(e) => e,
            Ok(_) => panic!("{name}: accepted"),
        },
    };
    e.to_string()
}

fn assert_contains(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "message lacks `{p}`:\n{message}");
    }
}

#[test]
fn the_good_case_is_accepted() {
    multifield::link_all();
    let case = Case::load(&case_file("good.ron", GOOD), &[]).unwrap();
    Simulation::new(&case).unwrap();
}

#[test]
fn a_syntax_error_names_file_line_and_column() {
    // line 4: the `,` after `max_dt: 0.01` became `;`
    let text = GOOD.replace("max_dt: 0.01)", "max_dt: 0.01;)");
    let m = error_of("syntax.ron", &text, &[]);
    let path = case_file("syntax.ron", &text);
    assert!(m.starts_with(&format!("{}:4:", path.display())), "no file:line:column at the start: {m}");
    let column: usize = m[path.display().to_string().len() + 3..].split(':').next().unwrap().parse().unwrap();
    assert!((40..=50).contains(&column), "column {column} should point at the `;` (col 44): {m}");
}

#[test]
fn an_unknown_key_lists_the_valid_ones() {
    let m = error_of("key.ron", &GOOD.replace("density: 1.0", "densty: 1.0"), &[]);
    assert_contains(
        &m,
        &[
            "key.ron:8:13: ",
            "unknown key `densty`",
            "valid keys:",
            "name",
            "density",
            "frame",
            "did you mean `density`?",
        ],
    );
}

#[test]
fn an_unknown_plugin_lists_the_registered_ones_and_the_close_one() {
    let m = error_of("plugin.ron", &GOOD.replace("\"newtonian\"", "\"newtonain\""), &[]);
    assert_contains(
        &m,
        &[
            "unknown stress model `newtonain`",
            "fields.water.stress.0",
            "registered stress models: ",
            "newtonian",
            "did you mean `newtonian`?",
        ],
    );
    let m = error_of("frame.ron", &GOOD.replace("\"eulerian\"", "\"eulerain\""), &[]);
    assert_contains(&m, &["unknown frame model `eulerain`", "eulerian, lagrangian", "did you mean `eulerian`?"]);
}

#[test]
fn a_negative_density_is_rejected_with_the_fix() {
    let m = error_of("density.ron", &GOOD.replace("density: 1.0", "density: -1.0"), &[]);
    assert_contains(&m, &["density.ron", "fields.water.density", "-1", "the material density must be positive"]);
}

#[test]
fn a_cfl_number_of_zero_or_less_is_rejected_with_the_fix() {
    for cfl in ["0.0", "-0.5"] {
        let m = error_of("cfl.ron", &GOOD.replace("cfl: 0.4", &format!("cfl: {cfl}")), &[]);
        assert_contains(&m, &["time.cfl", "the CFL number must lie in (0, 1]; 0.25–0.5 is usual"]);
    }
}

#[test]
fn a_region_outside_the_domain_is_rejected_with_the_fix() {
    let m = error_of("region.ron", &GOOD.replace("region: All", "region: Disk(center: (0.9, 0.5), radius: 0.2)"), &[]);
    assert_contains(&m, &["fields.water.region", "reaches outside the domain [0, 1] × [0, 1]", "move it inside"]);
    let text = GOOD.replace("region: All", "region: Rectangle(min: (0.5, 0.5), max: (1.5, 1.0))");
    let m = error_of("rectangle.ron", &text, &[]);
    assert_contains(&m, &["fields.water.region", "reaches outside the domain", "move it inside"]);
}

#[test]
fn a_periodic_side_paired_with_a_wall_is_rejected_with_the_fix() {
    let text =
        GOOD.replace("time:", "boundaries: (left: Periodic, right: NoSlip, bottom: NoSlip, top: NoSlip),\n    time:");
    let m = error_of("periodic.ron", &text, &[]);
    assert_contains(
        &m,
        &["boundaries.left is Periodic but boundaries.right is NoSlip", "make both Periodic or neither"],
    );
}

#[test]
fn an_override_of_an_unknown_entry_lists_the_entries() {
    let m = error_of("override.ron", GOOD, &["tme.end=1.0"]);
    assert_contains(&m, &["--set tme.end=1.0", "`tme` is not an entry of `the case`", "time", "did you mean `time`?"]);
    let m = error_of("override2.ron", GOOD, &["time.ned=1.0"]);
    assert_contains(
        &m,
        &["`ned` is not an entry of `time`", "cfl, end, fixed_dt, max_dt, max_steps, min_dt", "did you mean `end`?"],
    );
    let m = error_of("override3.ron", GOOD, &["fields.air.density=1.0"]);
    assert_contains(&m, &["`fields` has 1 entries", "an entry's name (water), not `air`"]);
    let m = error_of("override4.ron", GOOD, &["time.cfl=-1"]);
    assert_contains(&m, &["time.cfl", "the CFL number must lie in (0, 1]"]);
}

#[test]
fn invalid_plugin_parameters_say_which_and_why() {
    let m = error_of("params.ron", &GOOD.replace("viscosity: 0.01", "viscosity: 0.01, viscsity: 2.0"), &[]);
    assert_contains(&m, &["fields.water.stress.0", "newtonian", "unknown parameter `viscsity`", "viscosity"]);
    let m = error_of("params2.ron", &GOOD.replace("viscosity: 0.01", "viscosity: -0.01"), &[]);
    assert_contains(&m, &["fields.water.stress.0", "viscosity -0.01: must be zero or positive"]);
}

fn multifield(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).args(args).output().expect("the binary runs");
    (
        out.status.code().expect("exited, not killed"),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_binary_exits_with_code_2_and_the_message_on_bad_input() {
    let path = case_file("binary.ron", &GOOD.replace("density: 1.0", "density: -1.0"));
    let p = path.to_str().unwrap();
    for command in ["run", "check"] {
        let (code, _, stderr) = multifield(&[command, p, "--out", env!("CARGO_TARGET_TMPDIR")]);
        if command == "check" {
            // `check` has no --out: clap rejects it, also with code 2
            assert_eq!(code, 2, "{stderr}");
            continue;
        }
        assert_eq!(code, 2, "{command}: {stderr}");
        assert_eq!(
            stderr.trim(),
            format!("error: {p}: fields.water.density: -1: the material density must be positive")
        );
    }
    let (code, _, stderr) = multifield(&["check", p]);
    assert_eq!(code, 2);
    assert!(stderr.starts_with("error: ") && stderr.contains("the material density must be positive"), "{stderr}");

    let syntax = case_file("binary_syntax.ron", &GOOD.replace("max_dt: 0.01)", "max_dt: 0.01;)"));
    let (code, _, stderr) = multifield(&["check", syntax.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(stderr.starts_with(&format!("error: {}:4:", syntax.display())), "{stderr}");

    let (code, _, stderr) = multifield(&["check", p, "--set", "time.nope=1"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("`nope` is not an entry of `time`"), "{stderr}");

    let (code, _, stderr) = multifield(&["run", "no/such/case.ron", "-q"]);
    assert_eq!(code, 2);
    assert!(stderr.starts_with("error: no/such/case.ron: "), "{stderr}");

    let plugin = case_file("binary_plugin.ron", &GOOD.replace("\"pcg\"", "\"pgc\""));
    let (code, _, stderr) = multifield(&["check", plugin.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(stderr.contains("unknown pressure model `pgc`") && stderr.contains("did you mean `pcg`?"), "{stderr}");
}

#[test]
fn an_unknown_key_inside_a_choice_lists_the_valid_ones() {
    // before `deny_unknown_fields` on the enums, `presure` was silently ignored (pressure 0)
    let text = GOOD.replace(
        "time:",
        "boundaries: (left: NoSlip, right: Outflow(presure: 1.0), bottom: NoSlip, top: NoSlip),\n    time:",
    );
    let m = error_of("variant_key.ron", &text, &[]);
    assert_contains(&m, &["variant_key.ron:", "unknown key `presure`", "pressure", "did you mean `pressure`?"]);
    let text = GOOD.replace("region: All", "region: Disk(centre: (0.5, 0.5), radius: 0.2)");
    let m = error_of("region_key.ron", &text, &[]);
    assert_contains(&m, &["unknown key `centre`", "center", "radius"]);
}

#[test]
fn an_unknown_choice_lists_the_valid_ones() {
    let text =
        GOOD.replace("time:", "boundaries: (left: Wall, right: NoSlip, bottom: NoSlip, top: NoSlip),\n    time:");
    let m = error_of("variant.ron", &text, &[]);
    assert_contains(&m, &["variant.ron:", "unknown choice `Wall`", "NoSlip", "FreeSlip", "Periodic", "Outflow"]);
    let text = GOOD.replace("region: All", "region: Circle(center: (0.5, 0.5), radius: 0.2)");
    let m = error_of("region.ron", &text, &[]);
    assert_contains(&m, &["unknown choice `Circle`", "Rectangle", "Disk", "Rest"]);
}

#[test]
fn overrides_choose_enum_variants_and_name_the_valid_entries() {
    multifield::link_all();
    let path = case_file("set_variant.ron", GOOD);
    let set = |s: &[&str]| Case::load(&path, &s.iter().map(|s| s.to_string()).collect::<Vec<_>>());
    let case = set(&[
        "boundaries.left=FreeSlip",
        "boundaries.top=Velocity(velocity: (1.0, 0.0), profile: Parabolic)",
        "fields.water.region=Disk(center: (0.5, 0.5), radius: 0.25)",
    ])
    .unwrap();
    use multifield::core::boundary::{Boundary, Profile};
    use multifield::core::case::Region;
    assert_eq!(case.boundaries.left, Boundary::FreeSlip);
    assert_eq!(case.boundaries.top, Boundary::Velocity { velocity: [1.0, 0.0], profile: Profile::Parabolic });
    assert_eq!(case.fields[0].region, Region::Disk { center: [0.5, 0.5], radius: 0.25 });
    let m = set(&["fields.air.density=2.0"]).unwrap_err().to_string();
    assert_contains(&m, &["`fields` has 1 entries", "(water)", "not `air`"]);
    let m = set(&["boundaries.left=Wall"]).unwrap_err().to_string();
    assert_contains(&m, &["boundaries.left=Wall", "not a valid case", "Wall"]);
}

#[test]
fn a_body_density_that_is_not_positive_and_finite_is_refused_with_the_body_entry() {
    let bodies = GOOD.replace("region: All,", "region: Rest,").replace(
        "    ],\n    pressure",
        r#"        (
            name: "disks",
            density: 1.5,
            frame: (model: "lagrangian"),
            region: Bodies([
                (name: "a", shape: Disk(center: (0.3, 0.5), radius: 0.1)),
                (name: "b", shape: Disk(center: (0.7, 0.5), radius: 0.1), density: Some(BAD)),
            ]),
            stress: [(model: "rigid")],
        ),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip")],
    pressure"#,
    );
    // a good own density is accepted
    multifield::link_all();
    let good = case_file("body_density_good.ron", &bodies.replace("BAD", "1.25"));
    Simulation::new(&Case::load(&good, &[]).unwrap()).unwrap();
    for (k, bad) in ["0.0", "-1.0", "NaN", "inf"].iter().enumerate() {
        let path = case_file(&format!("body_density{k}.ron"), &bodies.replace("BAD", bad));
        let (code, _, stderr) = multifield(&["run", path.to_str().unwrap(), "--out", env!("CARGO_TARGET_TMPDIR")]);
        assert_eq!(code, 2, "{bad}: {stderr}");
        // NaN and inf are caught by the finite check of every number (path
        // `fields.disks.region.Bodies.b.density`), 0 and −1 by the case's validation
        let named = if k < 2 { "fields.disks.region.b.density" } else { "fields.disks.region.Bodies.b.density" };
        assert_contains(&stderr, &[named, bad.trim_end_matches(".0")]);
    }
}

#[test]
fn from_inflow_without_an_inflow_side_is_refused_with_the_field_entry() {
    // the box has walls on every side
    let text = GOOD.replace("region: All,", "region: All, velocity: FromInflow,");
    let m = error_of("from_inflow.ron", &text, &[]);
    assert_contains(&m, &["fields.water.velocity", "no side is an inflow", "Uniform((1.0, 0.0))"]);
    // two inflow sides: which profile is ambiguous
    let two = ["boundaries.left=Velocity(velocity: (1.0, 0.0))", "boundaries.bottom=Velocity(velocity: (0.0, 1.0))"];
    let m = error_of("from_inflow2.ron", &text, &two);
    assert_contains(&m, &["fields.water.velocity", "left and bottom are inflows"]);
    // and through the binary: exit code 2
    let path = case_file("from_inflow3.ron", &text);
    let (code, _, stderr) = multifield(&["run", path.to_str().unwrap(), "--out", env!("CARGO_TARGET_TMPDIR")]);
    assert_eq!(code, 2, "{stderr}");
    assert_contains(&stderr, &["fields.water.velocity", "no side is an inflow"]);
}

/// A case with bodies, monitors and stop conditions (issue 22): `GOOD` with a fixed disk
/// and the lists given.
fn with_monitors(monitors: &str, stop: &str) -> String {
    let disk = r#"
        (
            name: "disks",
            density: 2.0,
            frame: (model: "lagrangian"),
            region: Bodies([(name: "disk", shape: Disk(center: (0.5, 0.5), radius: 0.2), motion: Fixed)]),
            stress: [(model: "rigid")],
        ),
    ],"#;
    GOOD.replace("region: All", "region: Rest")
        .replacen("    ],", disk, 1)
        .replace(
            "    pressure:",
            "    exchange: [(between: (\"water\", \"disks\"), model: \"direct_forcing\")],\n    pressure:",
        )
        .replace("\n)\n", &format!("\n    monitors: [{monitors}],\n    stop: [{stop}],\n)\n"))
}

#[test]
fn monitors_and_stop_conditions_are_accepted() {
    multifield::link_all();
    let text = with_monitors(
        r#"(name: "drag", of: Forces(bodies: ["disk"], reference: Some((velocity: 1.0, length: 0.4, density: 1.0)))),
           (name: "p", every: Time(0.01), of: Probes(quantity: "pressure", points: [(0.1, 0.1), (0.9, 0.9)]))"#,
        r#"Steady(monitor: "drag", column: "c_D", tolerance: 1e-4, window: 0.5), Steps(10)"#,
    );
    let case = Case::load(&case_file("monitors_good.ron", &text), &[]).unwrap();
    Simulation::new(&case).unwrap();
}

#[test]
fn monitors_naming_what_does_not_exist_are_refused_with_the_choices() {
    let m = error_of("monitor_body.ron", &with_monitors(r#"(name: "drag", of: Forces(bodies: ["dsk"]))"#, ""), &[]);
    assert_contains(&m, &["monitors.drag.of.bodies", "no body `dsk`", "the choices are: disk"]);
    let probe = r#"(name: "p", of: Probes(quantity: "presure", points: [(0.5, 0.1)]))"#;
    let m = error_of("monitor_quantity.ron", &with_monitors(probe, ""), &[]);
    assert_contains(&m, &["monitors.p.of.quantity", "no quantity `presure`", "pressure"]);
    let probe = r#"(name: "p", of: Probes(quantity: "pressure", points: [(0.5, 0.1)]))"#;
    let steady = r#"Steady(monitor: "q", column: "p0", tolerance: 1e-3, window: 1.0)"#;
    let m = error_of("stop_monitor.ron", &with_monitors(probe, steady), &[]);
    assert_contains(&m, &["stop.0.monitor", "no monitor `q`", "the choices are: p"]);
    let steady = r#"Steady(monitor: "p", column: "p1", tolerance: 1e-3, window: 1.0)"#;
    let m = error_of("stop_column.ron", &with_monitors(probe, steady), &[]);
    assert_contains(&m, &["stop.0.column", "monitor `p` has no column `p1`", "the choices are: p0"]);
    let reaches = r#"Reaches(body: "disc", coordinate: Y, value: 0.1, direction: Below)"#;
    let m = error_of("stop_body.ron", &with_monitors("", reaches), &[]);
    assert_contains(&m, &["stop.0.body", "no body `disc`", "disk"]);
}

#[test]
fn a_probe_outside_the_domain_and_a_tolerance_not_positive_are_refused() {
    let probe = r#"(name: "p", of: Probes(quantity: "velocity", points: [(0.1, 0.5), (1.25, 0.5)]))"#;
    let m = error_of("probe_outside.ron", &with_monitors(probe, ""), &[]);
    assert_contains(&m, &["monitors.p.of.points", "(1.25, 0.5) lies outside the domain [0, 1] × [0, 1]"]);
    let line = r#"(name: "l", of: Line(quantity: "pressure", from: (0.0, -0.1), to: (1.0, 0.5), points: 3))"#;
    let m = error_of("line_outside.ron", &with_monitors(line, ""), &[]);
    assert_contains(&m, &["monitors.l.of", "(0, -0.1) lies outside the domain"]);
    let probe = r#"(name: "p", of: Probes(quantity: "pressure", points: [(0.5, 0.1)]))"#;
    for (k, (tolerance, shown)) in [("0.0", "0"), ("-1e-3", "-0.001")].iter().enumerate() {
        let steady = format!(r#"Steady(monitor: "p", column: "p0", tolerance: {tolerance}, window: 1.0)"#);
        let m = error_of(&format!("tolerance{k}.ron"), &with_monitors(probe, &steady), &[]);
        assert_contains(&m, &["stop.0.tolerance", &format!("{shown}: a relative tolerance must be positive")]);
    }
    // the binary: exit code 2 and the entry, before step 0
    let outside = with_monitors(r#"(name: "p", of: Probes(quantity: "pressure", points: [(0.5, 1.5)]))"#, "");
    let path = case_file("probe_outside_binary.ron", &outside);
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_input").join("probe_outside_out");
    for args in
        [vec!["check", path.to_str().unwrap()], vec!["run", path.to_str().unwrap(), "--out", out.to_str().unwrap()]]
    {
        let (code, _, stderr) = multifield(&args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert_contains(&stderr, &["monitors.p.of.points", "(0.5, 1.5) lies outside the domain"]);
    }
}

#[test]
fn a_suspension_monitor_of_no_bodies_or_bad_bins_is_refused() {
    let cases = [
        (r#"field: "disk""#, vec!["monitors.s.of.field", "no field `disk`", "the choices are: disks"]),
        (r#"field: "water""#, vec!["monitors.s.of.field", "field `water` has no bodies", "the choices are: disks"]),
        (r#"field: "disks", bins: 0"#, vec!["monitors.s.of.bins", "0: give 1 to 10000 slabs"]),
        (r#"field: "disks", bins: 10001"#, vec!["monitors.s.of.bins", "10001: give 1 to 10000 slabs"]),
        (r#"field: "disks", bed_fraction: 1.5"#, vec!["monitors.s.of.bed_fraction", "0 < f ≤ 1"]),
        (r#"field: "disks", contact_gap: -0.1"#, vec!["monitors.s.of.contact_gap", "a length ≥ 0"]),
    ];
    for (k, (entry, expected)) in cases.iter().enumerate() {
        let text = with_monitors(&format!(r#"(name: "s", of: Suspension({entry}))"#), "");
        let path = case_file(&format!("suspension{k}.ron"), &text);
        let (code, _, stderr) = multifield(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 2, "{entry}: {stderr}");
        assert_contains(&stderr, expected);
    }
    let two = r#"(name: "s", of: Suspension(field: "disks")), (name: "s_profiles", of: Forces(bodies: ["disk"]))"#;
    let m = error_of("suspension_profiles.ron", &with_monitors(two, ""), &[]);
    assert_contains(&m, &["monitors.s_profiles.name", "the file of the profiles of monitor `s`"]);
    let good = with_monitors(r#"(name: "s", of: Suspension(field: "disks", axis: X, bins: 4))"#, "");
    let (code, stdout, stderr) = multifield(&["check", case_file("suspension_good.ron", &good).to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    assert_contains(&stdout, &["monitors/s.csv: Suspension", "profiles in 4 slabs along X", "monitors/s_profiles.csv"]);
}

#[test]
fn a_probe_inside_a_body_is_refused_unless_it_samples_the_body_s_own_field() {
    // the disk: centre (0.5, 0.5), radius 0.2, on 8 cells of 1/8
    let probe = r#"(name: "p", of: Probes(quantity: "pressure", points: [(0.1, 0.5), (0.6, 0.5)]))"#;
    let m = error_of("probe_inside.ron", &with_monitors(probe, ""), &[]);
    assert_contains(
        &m,
        &[
            "monitors.p.of.points",
            "(0.6, 0.5) lies inside body `disk` (field `disks`) at t = 0",
            "`pressure` of the mixture is not the fluid's",
            // radially out to r = 0.2 + h/2 = 0.2625
            "e.g. to (0.7625, 0.5) half a cell off the edge",
            "field: Some(\"disks\")",
        ],
    );
    let diff = r#"(name: "dp", of: Difference(quantity: "velocity", field: Some("water"), from: (0.5, 0.45), to: (0.95, 0.5)))"#;
    let m = error_of("difference_inside.ron", &with_monitors(diff, ""), &[]);
    assert_contains(&m, &["monitors.dp.of", "(0.5, 0.45) lies inside body `disk`", "of field `water`"]);
    // the body's own field, a point on the edge, and a line across the body are sampled
    multifield::link_all();
    for good in [
        r#"(name: "p", of: Probes(quantity: "velocity", field: Some("disks"), points: [(0.5, 0.5)]))"#,
        r#"(name: "p", of: Probes(quantity: "pressure", points: [(0.3, 0.5), (0.5, 0.7)]))"#,
        r#"(name: "l", of: Line(quantity: "pressure", from: (0.0, 0.5), to: (1.0, 0.5), points: 11))"#,
    ] {
        let case = Case::load(&case_file("probe_good.ron", &with_monitors(good, "")), &[]);
        assert!(case.is_ok(), "{good}: {:?}", case.err());
    }
}

#[test]
fn output_times_beyond_the_end_negative_nan_or_unordered_are_refused_with_the_entry() {
    let with = |output: &str| GOOD.replace("    pressure:", &format!("    output: ({output}),\n    pressure:"));
    // good: increasing times in (0, time.end], and at_end alone
    multifield::link_all();
    for good in ["snapshots: Some((times: [0.05, 0.1]))", "pictures: Some((at_end: true))"] {
        let path = case_file("times_good.ron", &with(good));
        Simulation::new(&Case::load(&path, &[]).unwrap()).unwrap();
    }
    let cases = [
        (
            "snapshots: Some((times: [0.05, 0.2]))",
            "output.snapshots.times.1",
            "0.2: must be a finite time in (0, time.end = 0.1]",
        ),
        ("snapshots: Some((times: [-0.05]))", "output.snapshots.times.0", "-0.05"),
        ("pictures: Some((times: [0.01, NaN]))", "output.pictures.times", "NaN"),
        ("pictures: Some((times: [0.05, 0.02]))", "output.pictures.times.1", "the times must increase"),
        ("snapshots: Some(())", "output.snapshots", "nothing to write"),
    ];
    for (k, (output, entry, what)) in cases.iter().enumerate() {
        let path = case_file(&format!("times{k}.ron"), &with(output));
        let (code, _, stderr) = multifield(&["run", path.to_str().unwrap(), "--out", env!("CARGO_TARGET_TMPDIR")]);
        assert_eq!(code, 2, "{output}: {stderr}");
        assert_contains(&stderr, &[entry, what]);
    }
    // more times than the list cap
    let many: Vec<String> = (1..=65).map(|k| format!("{}", k as f64 * 0.001)).collect();
    let m = error_of("times_many.ron", &with(&format!("snapshots: Some((times: [{}]))", many.join(", "))), &[]);
    assert_contains(&m, &["output.snapshots.times", "65 times; at most 64"]);
}
