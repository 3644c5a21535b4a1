//! What a run writes: `case.ron` (re-parseable to the case as run), `diagnostics.csv` (the
//! documented columns, one row per output interval and the last step), `summary.json`
//! (status, reason and figures), including for runs that go unstable or fail.

use multifield::core::case::Case;
use multifield::core::simulation::Simulation;
use multifield::run::{run, Outcome, RunOptions, CSV_HEADER};
use std::path::{Path, PathBuf};

/// A 16 × 16 periodic Taylor–Green vortex, Eulerian, Δt fixed at 0.01, rows every 0.02.
const CASE: &str = r#"(
    name: "contract",
    domain: (size: (6.283185307179586, 6.283185307179586), cells: (16, 16)),
    boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
    time: (end: 0.1, max_dt: 0.05, fixed_dt: Some(0.01)),
    fields: [
        (
            name: "fluid",
            density: 1.0,
            frame: (model: "eulerian"),
            region: All,
            velocity: TaylorGreen(amplitude: 1.0),
            stress: [(model: "newtonian", params: (viscosity: 0.01))],
        ),
    ],
    pressure: Some((model: "pcg")),
    output: (interval: 0.02),
)"#;

fn out_dir(name: &str) -> PathBuf {
    super::common::fresh_dir("output_contract", name)
}

fn run_with(name: &str, overrides: &[&str]) -> (Case, Outcome, serde_json::Value) {
    multifield::link_all();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let case = Case::from_ron(CASE, Path::new("contract.ron")).unwrap().with_overrides(&overrides).unwrap();
    case.validate().unwrap();
    let dir = out_dir(name);
    let outcome = run(&case, &dir, &RunOptions::quiet()).unwrap();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    (case, outcome, summary)
}

fn rows(dir: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(dir.join("diagnostics.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), CSV_HEADER);
    lines.map(|l| l.split(',').map(str::to_string).collect()).collect()
}

#[test]
fn the_header_has_the_documented_columns() {
    assert_eq!(
        CSV_HEADER,
        "step,time,dt,dt_limit,kinetic_energy,momentum_x,momentum_y,mass,max_speed,max_divergence,\
         volume_fraction_error,pressure_iterations,pressure_residual,strain_energy,max_volume_fraction"
    );
}

#[test]
fn a_short_run_writes_case_diagnostics_and_summary() {
    let (case, outcome, summary) = run_with("short", &[]);
    let dir = &outcome.output_dir;

    // case.ron: the case as run, defaults filled in, parses back to an equal case
    let written = Case::from_ron(&std::fs::read_to_string(dir.join("case.ron")).unwrap(), &dir.join("case.ron"))
        .expect("case.ron parses");
    let as_run = Simulation::new(&case).unwrap().case;
    assert_eq!(written, as_run);
    assert_eq!(written.fields[0].stress[0].params["safety"], 0.9, "plugin defaults are filled in");
    assert_eq!(written.time.min_dt, 1e-12, "case defaults are filled in");

    // diagnostics.csv: one row per 0.02 of simulated time (every second step of 0.01)
    let rows = rows(dir);
    assert_eq!(rows.len(), 5, "{rows:?}");
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 15);
        assert_eq!(r[0], (2 * k + 2).to_string());
        let t: f64 = r[1].parse().unwrap();
        assert!((t - 0.02 * (k + 1) as f64).abs() < 1e-12, "row {k} at t = {t}");
        assert_eq!(r[2].parse::<f64>().unwrap(), 0.01);
        assert_eq!(r[3], "fixed");
        // a fluid stores no strain energy; one field that fills the box has Σθ = 1 to the
        // divergence the pressure solve leaves (its θ is advected as every field's)
        assert_eq!(r[13], "0");
        assert!((r[14].parse::<f64>().unwrap() - 1.0).abs() < 1e-12, "max Σθ {}", r[14]);
        for c in (4..15).filter(|&c| c != 3) {
            assert!(r[c].parse::<f64>().unwrap().is_finite(), "column {c} of row {k}: {}", r[c]);
        }
        assert!((r[7].parse::<f64>().unwrap() - 4.0 * std::f64::consts::PI.powi(2)).abs() < 1e-9, "mass = (2π)²");
    }
    // the Taylor–Green energy decays as e^(−4νt) from E₀ = π²: within 1 % at t = 0.1 on 16²
    let e_end: f64 = rows[4][4].parse().unwrap();
    let exact = std::f64::consts::PI.powi(2) * (-4.0 * 0.01 * 0.1_f64).exp();
    assert!((e_end / exact - 1.0).abs() < 0.01, "E(0.1) = {e_end}, exact {exact}");

    // summary.json
    assert_eq!(summary["status"], "completed");
    assert_eq!(summary["reason"], "");
    assert_eq!(summary["case"], "contract");
    assert_eq!(summary["steps"], 10);
    assert!((summary["simulated_time"].as_f64().unwrap() - 0.1).abs() < 1e-12);
    assert!(summary["wall_seconds"].as_f64().unwrap() >= 0.0);
    assert!(summary["threads"].as_u64().unwrap() >= 1);
    // (serde_json's default float parsing may be one ulp off the shortest representation)
    assert!((summary["final_kinetic_energy"].as_f64().unwrap() / e_end - 1.0).abs() < 1e-15);
    assert!(summary["max_divergence"].as_f64().unwrap() < 1e-6);
    assert!(summary["max_volume_fraction_error"].as_f64().unwrap() < 1e-12);
    let iterations: u64 = rows.iter().map(|r| r[11].parse::<u64>().unwrap()).sum();
    assert!(summary["pressure_iterations_total"].as_u64().unwrap() >= iterations);
    assert_eq!(summary["diagnostics_rows"], 5);
}

#[test]
fn interval_zero_writes_every_step_and_an_odd_interval_still_writes_the_last() {
    let (_, outcome, _) = run_with("every_step", &["output.interval=0"]);
    assert_eq!(rows(&outcome.output_dir).len(), 10);
    let (_, outcome, _) = run_with("odd_interval", &["output.interval=0.03"]);
    let r = rows(&outcome.output_dir);
    // rows at the first steps at or after 0.03, 0.06, 0.09, and the last step (t = 0.1)
    let steps: Vec<&str> = r.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(steps, ["3", "6", "9", "10"]);
}

#[test]
fn setting_the_end_time_changes_the_simulated_time() {
    let (_, _, summary) = run_with("end", &["time.end=0.05"]);
    assert_eq!(summary["status"], "completed");
    assert!((summary["simulated_time"].as_f64().unwrap() - 0.05).abs() < 1e-12, "{summary}");
    assert_eq!(summary["steps"], 5);
}

#[test]
fn a_huge_fixed_step_on_a_fast_flow_ends_unstable_with_a_reason() {
    // Δt = 1 with |u| = 100 on h = 0.39: a Courant number of 250, and 64× the viscous limit
    let (_, outcome, summary) = run_with(
        "unstable",
        &["time.fixed_dt=1.0", "time.end=1000", "fields.fluid.velocity.TaylorGreen.amplitude=100.0"],
    );
    assert_eq!(summary["status"], "unstable", "{summary}");
    let reason = summary["reason"].as_str().unwrap();
    assert!(
        reason.contains("exceeds the bound") || reason.contains("non-finite") || reason.contains("collapsed"),
        "the reason says what blew up: {reason}"
    );
    assert!(summary["steps"].as_u64().unwrap() < 1000);
    // the step that blew up is the last row of diagnostics.csv
    let r = rows(&outcome.output_dir);
    assert_eq!(r.last().unwrap()[0], summary["steps"].to_string());
}

#[test]
fn a_step_below_min_dt_ends_unstable() {
    let (_, _, summary) = run_with("min_dt", &["time.fixed_dt=None", "time.min_dt=1.0"]);
    assert_eq!(summary["status"], "unstable");
    let reason = summary["reason"].as_str().unwrap();
    assert!(reason.contains("fell below time.min_dt = 1e0"), "{reason}");
    assert_eq!(summary["steps"], 0);
}

#[test]
fn a_solver_error_ends_failed_with_the_message_and_a_summary() {
    let (_, outcome, summary) =
        run_with("failed", &["pressure=Some((model: \"pcg\", params: (tolerance: 1e-15, max_iterations: 1)))"]);
    assert_eq!(summary["status"], "failed");
    let reason = summary["reason"].as_str().unwrap();
    assert!(reason.contains("step 1") && reason.contains("did not reach the relative residual"), "{reason}");
    assert!(matches!(outcome.status, multifield::core::simulation::Status::Failed(_)));
}

#[test]
fn an_unknown_plugin_still_writes_a_failed_summary() {
    multifield::link_all();
    let case = Case::from_ron(&CASE.replace("\"pcg\"", "\"pgc\""), Path::new("x.ron")).unwrap();
    let dir = out_dir("unknown_plugin");
    let e = run(&case, &dir, &RunOptions::quiet()).unwrap_err();
    assert!(e.to_string().contains("unknown pressure model `pgc`"));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "failed");
    assert_eq!(summary["reason"], e.to_string());
}

#[test]
fn the_binary_runs_a_case_and_reports_where_the_output_went() {
    let dir = out_dir("binary");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("contract.ron");
    std::fs::write(&file, CASE).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["run", file.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap(), "--threads", "1"])
        .args(["--set", "time.end=0.04", "--quiet"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.starts_with("completed: 4 steps to t = 0.04"), "{stdout}");
    assert!(stdout.contains("on 1 thread "), "{stdout}");
    assert!(stdout.contains(&format!("output: {}/", dir.join("out").display())), "{stdout}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/summary.json")).unwrap()).unwrap();
    assert_eq!(summary["threads"], 1);

    // an unstable run exits with 1 and says why on stderr
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["run", file.to_str().unwrap(), "--out", dir.join("bad").to_str().unwrap(), "-q"])
        .args(["--set", "time.min_dt=1.0", "--set", "time.fixed_dt=None"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.starts_with("error: the run became unstable: Δt = "), "{stderr}");
}

/// A fixed Δt says in `dt_limit` when it exceeds a model's stable limit (and which), and
/// says plain `fixed` when it does not.
#[test]
fn a_fixed_step_beyond_a_stable_limit_is_reported() {
    multifield::link_all();
    // h = 2π/16 ≈ 0.393: viscous limit 0.9 h²/(4ν) = 0.9 · 0.1542 / (4 · 0.5) ≈ 0.0694 at ν = 0.5
    let case = Case::from_ron(CASE, Path::new("contract.ron"))
        .unwrap()
        .with_overrides(&["fields.fluid.stress.0.params.viscosity=0.5".into()])
        .unwrap();
    let sim = Simulation::new(&case).unwrap();
    assert_eq!(sim.choose_dt(), (0.01, "fixed".to_string()));
    // the explicit viscosity's limit; Crank–Nicolson's (the default) is an accuracy bound of
    // diffusion number νΔt/h² ≤ 2, 2 h²/ν ≈ 0.617 here
    let explicit = case
        .with_overrides(&[
            "time.fixed_dt=0.08".into(),
            "time.max_dt=0.08".into(),
            "fields.fluid.frame.params.diffusion=\"explicit\"".into(),
        ])
        .unwrap();
    let sim = Simulation::new(&explicit).unwrap();
    let (dt, label) = sim.choose_dt();
    assert_eq!(dt, 0.08);
    let h = std::f64::consts::TAU / 16.0;
    let limit = 0.9 * h * h / (4.0 * 0.5);
    assert_eq!(label, format!("fixed (exceeds the newtonian(fluid) limit {limit:.3e})"));
    let case = case.with_overrides(&["time.fixed_dt=0.08".into(), "time.max_dt=0.08".into()]).unwrap();
    assert_eq!(Simulation::new(&case).unwrap().choose_dt(), (0.08, "fixed".to_string()));
    // at ν = 5 the Crank–Nicolson bound 2 h²/ν ≈ 0.0617 binds before the CFL's
    let case = case.with_overrides(&["fields.fluid.stress.0.params.viscosity=5.0".into()]).unwrap();
    let (dt, label) = Simulation::new(&case).unwrap().choose_dt();
    assert_eq!(dt, 0.08);
    let limit = 2.0 * h * h / 5.0;
    assert_eq!(label, format!("fixed (exceeds the newtonian(fluid) limit {limit:.3e})"));
}
