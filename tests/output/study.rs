//! `multifield study`: a small study end to end (the table, the error against a closed
//! form computed here independently, a deliberately unstable run, resuming, the charts),
//! and bad study files rejected up front with exit code 2.
//!
//! The scene is the exchange box of tests/verification/multifield_coupling.rs: two interpenetrating
//! fields (θ = ½ each, ρa = 1, ρb = 2) in a periodic box with a constant K = 4/3, so that the
//! slip relaxes with τ = 1: the kinetic energy is E(t) = E_cm + (E₀ − E_cm) e^(−2t/τ). A step
//! multiplies the slip by 1/(1 + Δt/τ) (implicit) or 1 − Δt/τ (explicit), which blows up
//! for Δt > 2τ.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BOX: &str = r#"(
    name: "exchange_box", domain: (size: (1.0, 1.0), cells: (8, 8)),
    boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
    time: (end: 40.0, max_dt: 100.0, fixed_dt: Some(0.1)),
    fields: [
        (name: "a", density: 1.0, frame: (model: "eulerian"), region: All, volume_fraction: 0.5,
         velocity: Uniform((1.0, 0.5))),
        (name: "b", density: 2.0, frame: (model: "eulerian"), region: Rest, velocity: Uniform((-1.0, 0.0))),
    ],
    exchange: [(between: ("a", "b"), model: "constant", params: (coefficient: 1.3333333333333333))],
    pressure: Some((model: "pcg", params: (tolerance: 1e-12))),
    output: (interval: 0.0, charts: false),
)
"#;

/// E₀ and E_cm of the box: masses 0.5 and 1.0, velocities (1, 0.5) and (−1, 0).
const E0: f64 = 0.5 * 0.5 * (1.0 + 0.25) + 0.5 * 1.0 * 1.0;
const ECM: f64 = 0.5 * 1.5 * ((1.0 / 3.0) * (1.0 / 3.0) + (1.0 / 6.0) * (1.0 / 6.0));

const STUDY: &str = r#"// a small study: exchange integration × Δt/τ
(
    name: "tiny",
    base: "box.ron",
    set: ["time.end=40"],
    axes: [
        (name: "integration", values: List(path: "exchange.0.integration", values: ["Implicit", "Explicit"])),
        (name: "dt", values: List(path: "time.fixed_dt", values: [0.1, 0.4, 10.0])),
    ],
    metrics: [Final("kinetic_energy"), Summary("pressure_iterations_total")],
    reference: Analytic(column: "kinetic_energy", law: Exponential(rate: 2.0, floor: 0.10416666666666667)),
    charts: [
        AccuracyCost(series: ["integration"]),
        StabilityMap(x: "dt", y: "integration"),
    ],
)
"#;

fn scratch(name: &str) -> PathBuf {
    super::common::created_dir("study", name)
}

pub(crate) fn multifield(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_multifield")).args(args).output().expect("the binary runs")
}

pub(crate) fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// results.csv as a list of rows, each a map from column to text.
pub(crate) fn table(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let t = std::fs::read_to_string(path).unwrap();
    let mut lines = t.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    lines
        .map(|l| {
            // the reason may be quoted (it holds commas): split outside quotes
            let (mut fields, mut cur, mut quoted) = (Vec::new(), String::new(), false);
            for c in l.chars() {
                match c {
                    '"' => quoted = !quoted,
                    ',' if !quoted => fields.push(std::mem::take(&mut cur)),
                    c => cur.push(c),
                }
            }
            fields.push(cur);
            assert_eq!(fields.len(), header.len(), "row `{l}`");
            header.iter().cloned().zip(fields).collect()
        })
        .collect()
}

/// The error the study should report, from the discrete amplification factor: the RMS over
/// the rows of diagnostics.csv of (E_n − E(t_n)) / E₀.
fn expected_error(run: &Path, explicit: bool) -> f64 {
    let d = std::fs::read_to_string(run.join("diagnostics.csv")).unwrap();
    let (mut factor, mut sum, mut n) = (1.0, 0.0, 0.0);
    for line in d.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|s| s.parse().unwrap_or(f64::NAN)).collect();
        let (t, dt) = (f[1], f[2]);
        factor *= if explicit { (1.0 - dt).powi(2) } else { (1.0 + dt).powi(-2) };
        let discrete = ECM + (E0 - ECM) * factor;
        let exact = ECM + (E0 - ECM) * (-2.0 * t).exp();
        sum += ((discrete - exact) / E0).powi(2);
        n += 1.0;
    }
    (sum / n).sqrt()
}

fn num(row: &std::collections::HashMap<String, String>, column: &str) -> f64 {
    row[column].parse().unwrap_or_else(|_| panic!("{column} = `{}` is not a number", row[column]))
}

#[test]
fn a_small_study_runs_end_to_end_resumes_and_draws_its_charts() {
    let dir = scratch("tiny");
    std::fs::write(dir.join("box.ron"), BOX).unwrap();
    std::fs::write(dir.join("tiny.ron"), STUDY).unwrap();
    let study = dir.join("tiny.ron");
    let out = dir.join("out");
    let args = ["study", study.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "2"];
    let first = multifield(&args);
    assert!(first.status.success(), "{}", text(&first));
    assert!(
        text(&first).contains("6 runs: 5 completed, 1 unstable, 0 failed (6 run now, 0 skipped"),
        "{}",
        text(&first)
    );

    let rows = table(&out.join("results.csv"));
    assert_eq!(rows.len(), 6, "one row per combination");
    let header = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(header.starts_with(
        "integration,dt,status,reason,wall_seconds,steps,error,max_divergence,max_volume_fraction_error,\
         energy_drift,final_kinetic_energy,pressure_iterations_total,directory\n"
    ));
    let row = |i: &str, dt: &str| rows.iter().find(|r| r["integration"] == i && r["dt"] == dt).unwrap();
    for r in &rows {
        let run = out.join(&r["directory"]);
        assert!(run.join("summary.json").is_file(), "{}", run.display());
        for c in ["wall_seconds", "steps", "max_divergence", "max_volume_fraction_error", "energy_drift"] {
            assert!(num(r, c).is_finite(), "{c} of {:?}", r);
        }
        assert!(num(r, "max_volume_fraction_error") < 1e-12, "θa + θb = 1 exactly in this box");
        if r["status"] == "completed" {
            let want = expected_error(&run, r["integration"] == "Explicit");
            let got = num(r, "error");
            assert!((got - want).abs() <= 1e-6 * want, "{}/{}: error {got} vs {want}", r["integration"], r["dt"]);
            // the slip is gone by t = 40: the energy left is that of the centre of mass
            assert!((num(r, "final_kinetic_energy") - ECM).abs() < 1e-8, "{:?}", r);
            assert!((num(r, "energy_drift") - (ECM - E0) / E0).abs() < 1e-8);
        }
    }
    // finer steps are more accurate (first order: about 4 × smaller for 4 × smaller Δt)
    let (fine, coarse) = (num(row("Implicit", "0.1"), "error"), num(row("Implicit", "0.4"), "error"));
    assert!(fine < coarse && coarse / fine > 3.0, "implicit errors {fine} (Δt = 0.1) and {coarse} (Δt = 0.4)");
    assert_eq!(num(row("Implicit", "0.1"), "steps"), 400.0);
    // implicit is stable at Δt = 10 τ; explicit is not, and says why
    assert_eq!(row("Implicit", "10")["status"], "completed");
    let bad = row("Explicit", "10");
    assert_eq!(bad["status"], "unstable");
    assert!(
        bad["reason"].contains("mechanical energy") && bad["reason"].contains("exceeds the bound"),
        "{}",
        bad["reason"]
    );
    assert_eq!(bad["error"], "", "an unstable run has no error");
    assert!(num(bad, "steps") < 5.0);

    // the charts, PNG and SVG, with something drawn
    for stem in ["accuracy_cost", "stability_dt_integration"] {
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert!(png.len() > 20_000, "{stem}.png: {} bytes", png.len());
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.len() > 3_000, "{stem}.svg: {} bytes", svg.len());
    }
    let svg = std::fs::read_to_string(out.join("accuracy_cost.svg")).unwrap();
    assert!(svg.contains("integration=Implicit") && svg.contains("Pareto front"));
    let svg = std::fs::read_to_string(out.join("stability_dt_integration.svg")).unwrap();
    assert!(svg.contains("stability boundary") && svg.contains("unstable"));

    // a rerun skips every finished run (the unstable one too) and leaves them untouched
    let mtimes = |rows: &[std::collections::HashMap<String, String>]| -> Vec<std::time::SystemTime> {
        rows.iter()
            .map(|r| std::fs::metadata(out.join(&r["directory"]).join("summary.json")).unwrap().modified().unwrap())
            .collect()
    };
    let before = mtimes(&rows);
    let again = multifield(&args);
    assert!(again.status.success(), "{}", text(&again));
    assert!(text(&again).contains("(0 run now, 6 skipped as finished)"), "{}", text(&again));
    assert_eq!(mtimes(&rows), before);
    assert_eq!(table(&out.join("results.csv")), rows, "the same table");

    // a run whose summary is gone (killed) is run again, alone
    let lost = out.join(&row("Implicit", "0.4")["directory"]);
    std::fs::remove_file(lost.join("summary.json")).unwrap();
    let third = multifield(&args);
    assert!(text(&third).contains("(1 run now, 5 skipped as finished)"), "{}", text(&third));
    assert_eq!(num(&table(&out.join("results.csv"))[1], "steps"), 100.0);
}

/// Writes the study `text` (and the box) and runs it; returns the output.
fn study_error(name: &str, text_of_study: &str) -> String {
    let dir = scratch(name);
    std::fs::write(dir.join("box.ron"), BOX).unwrap();
    std::fs::write(dir.join("channel.ron"), CHANNEL).unwrap();
    let file = dir.join("s.ron");
    std::fs::write(&file, text_of_study).unwrap();
    let o = multifield(&["study", file.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
    assert!(!dir.join("out").join("runs").exists(), "{name}: nothing is run");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn an_unknown_key_is_reported_with_its_line_and_column() {
    let e = study_error("unknown_key", "(\n    name: \"s\",\n    base: \"box.ron\",\n    axis: [],\n)\n");
    assert!(e.contains("s.ron:4:5") && e.contains("unknown key `axis`") && e.contains("did you mean `axes`?"), "{e}");
}

#[test]
fn an_unknown_override_path_names_the_combination() {
    let e = study_error(
        "unknown_path",
        r#"(name: "s", base: "box.ron", axes: [
            (name: "k", values: List(path: "exchange.0.params.coefficient", values: [1.0])),
            (name: "cfl", values: List(path: "time.cfll", values: [0.2, 0.4])),
        ])"#,
    );
    assert!(e.contains("the combination k=1, cfl=0.2 (run 1 of 2)"), "{e}");
    assert!(e.contains("`cfll` is not an entry of `time`") && e.contains("did you mean `cfl`?"), "{e}");
}

#[test]
fn a_chart_of_an_unknown_axis_is_refused() {
    let e = study_error(
        "unknown_axis",
        r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1]))],
            charts: [StabilityMap(x: "dt", y: "density_ratio")])"#,
    );
    assert!(e.contains("charts.0.y") && e.contains("no axis is named `density_ratio`; axes: dt"), "{e}");
}

#[test]
fn a_bad_metric_or_reference_is_refused() {
    let e = study_error(
        "bad_metric",
        r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1]))],
            metrics: [Final("kinetic_enrgy")])"#,
    );
    assert!(e.contains("metrics.0") && e.contains("did you mean `kinetic_energy`?"), "{e}");
    let e = study_error(
        "bad_baseline",
        r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1, 0.2]))],
            reference: Baseline(axis: "dt", value: "0.3", compare: Column("kinetic_energy")))"#,
    );
    assert!(e.contains("reference.value") && e.contains("labels: 0.1, 0.2"), "{e}");
    let e = study_error(
        "bad_body_column",
        r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1]))],
            metrics: [Body(body: "disk", column: "fxx")])"#,
    );
    assert!(e.contains("metrics.0.column") && e.contains("did you mean `fx`?"), "{e}");
    let e = study_error(
        "bad_exact",
        r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1]))],
            metrics: [Body(body: "disk", column: "fx")],
            reference: Exact(column: "disk_fy", value: 1.0))"#,
    );
    assert!(e.contains("reference.column") && e.contains("its metric columns: disk_fx"), "{e}");
    let e = study_error(
        "bad_uhlmann_folder",
        r#"(name: "s", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1]))],
            reference: Uhlmann("no_such_folder"))"#,
    );
    assert!(e.contains("no_such_folder: no Uhlmann2005-fig6a") && e.contains("or `Uhlmann2005`"), "{e}");
}

/// A body metric is the last row of its `bodies.csv` column, scaled; an exact reference
/// measures it: a disk moved at a prescribed (0, −0.1) from y = 0.7 for t = 1 ends at
/// y = 0.6 (×2 = 1.2), whatever Δt.
#[test]
fn a_body_metric_against_an_exact_value() {
    let dir = scratch("body_metric");
    std::fs::write(
        dir.join("disk.ron"),
        r#"(
            name: "disk",
            domain: (size: (1.0, 1.0), cells: (16, 16)),
            time: (end: 1.0, cfl: 0.4, max_dt: 0.1),
            fields: [
                (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
                 stress: [(model: "newtonian", params: (viscosity: 0.1))]),
                (name: "disk", density: 2.0, frame: (model: "lagrangian"), stress: [(model: "rigid")],
                 region: Bodies([(name: "disk", shape: Disk(center: (0.5, 0.7), radius: 0.15),
                                  motion: Prescribed(velocity: (0.0, -0.1)))])),
            ],
            exchange: [(between: ("water", "disk"), model: "direct_forcing")],
            pressure: Some((model: "pcg")),
            output: (interval: 0.25, charts: false),
        )"#,
    )
    .unwrap();
    let study = dir.join("s.ron");
    std::fs::write(
        &study,
        r#"(name: "s", base: "disk.ron",
            axes: [(name: "dt", values: List(path: "time.max_dt", values: [0.05, 0.1]))],
            metrics: [Body(body: "disk", column: "y", scale: Some(2.0)), Body(body: "disk", column: "vy")],
            reference: Exact(column: "disk_y", value: 1.2),
            charts: [AccuracyCost(series: [])])"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = multifield(&["study", study.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    for row in table(&out.join("results.csv")) {
        assert!((num(&row, "disk_y") - 1.2).abs() < 1e-12, "{row:?}");
        assert!((num(&row, "disk_vy") + 0.1).abs() < 1e-15, "{row:?}");
        assert!(num(&row, "error") < 1e-12, "{row:?}");
    }
}

#[test]
fn the_shipped_studies_are_valid() {
    multifield::link_all();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        // study files have axes; the other RON files there are their base cases
        if path.extension().is_none_or(|e| e != "ron") || !text.contains("axes:") {
            continue;
        }
        let plan = multifield::study::plan(&path, Some(scratch("shipped").join("unused")), &[])
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(plan.runs.len() >= 4, "{}: {} runs", path.display(), plan.runs.len());
        assert!(!plan.study.charts.is_empty(), "{}: no chart", path.display());
        seen += 1;
    }
    assert_eq!(seen, 10, "the ten shipped studies");
}

#[test]
fn a_baseline_reference_compares_columns_at_the_baselines_times() {
    let dir = scratch("baseline");
    std::fs::write(dir.join("box.ron"), BOX).unwrap();
    let study = dir.join("b.ron");
    std::fs::write(
        &study,
        r#"(name: "b", base: "box.ron",
            axes: [(name: "dt", values: List(path: "time.fixed_dt", values: [0.1, 0.4]))],
            reference: Baseline(axis: "dt", value: "0.1", compare: Column("kinetic_energy")),
            charts: [AccuracyCost(series: [])])"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = multifield(&["study", study.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let rows = table(&out.join("results.csv"));
    assert_eq!(num(&rows[0], "error"), 0.0, "the baseline against itself");
    // independently: implicit steps multiply E − E_cm by (1 + Δt)^−2; the Δt = 0.4 run is
    // interpolated linearly at the baseline's times t = 0.1 k inside its own rows (t ≥ 0.4;
    // its last row, at 40 − 8e-14 by round-off, counts as t = 40)
    let e = |dt: f64, n: f64| ECM + (E0 - ECM) * (1.0 + dt).powf(-2.0 * n);
    let scale = e(0.1, 1.0);
    let (mut sum, mut count) = (0.0, 0.0);
    for k in 4..=400 {
        let t = 0.1 * k as f64;
        let j = (t / 0.4 + 1e-9).floor();
        let w = t / 0.4 - j;
        let coarse = if w < 1e-9 { e(0.4, j) } else { (1.0 - w) * e(0.4, j) + w * e(0.4, j + 1.0) };
        sum += (coarse - e(0.1, k as f64)).powi(2);
        count += 1.0;
    }
    let want = (sum / count).sqrt() / scale;
    let got = num(&rows[1], "error");
    assert!((got - want).abs() < 1e-6 * want, "error {got} vs {want}");
}

/// A fixed disk in a short channel at Re 2 (U = 1, D = 0.2, ν = 0.1): a Forces monitor with
/// coefficients and a Steady stop on its c_D.
const CHANNEL: &str = r#"(
    name: "channel", domain: (size: (1.0, 0.5), cells: (32, 16)),
    boundaries: (left: Velocity(velocity: (1.0, 0.0)), right: Outflow(pressure: 0.0), bottom: NoSlip, top: NoSlip),
    time: (end: 5.0, cfl: 0.4, max_dt: 0.05),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.1))]),
        (name: "cylinder", density: 1.0, frame: (model: "lagrangian"), stress: [(model: "rigid")],
         region: Bodies([(name: "cylinder", shape: Disk(center: (0.3, 0.25), radius: 0.1), motion: Fixed)])),
    ],
    exchange: [(between: ("water", "cylinder"), model: "direct_forcing")],
    pressure: Some((model: "pcg", params: (tolerance: 1e-10))),
    output: (interval: 0.5, charts: false),
    monitors: [(name: "drag", of: Forces(bodies: ["cylinder"], reference: Some((velocity: 1.0, length: 0.2, density: 1.0))))],
    stop: [Steady(monitor: "drag", column: "c_D", tolerance: 1e-3, window: 0.2)],
)
"#;

/// The numbers of column `name` of a CSV file.
fn csv_column(path: &Path, name: &str) -> Vec<f64> {
    let t = std::fs::read_to_string(path).unwrap();
    let mut lines = t.lines();
    let k = lines.next().unwrap().split(',').position(|h| h == name).unwrap();
    lines.map(|l| l.split(',').nth(k).unwrap().parse().unwrap()).collect()
}

/// Monitor metrics are the monitor's CSV reduced as documented, and `stop_time` is the
/// simulated time of a run a stop condition ended (empty for the run that reached its end).
#[test]
fn monitor_metrics_and_the_stop_time_are_read_from_each_run() {
    let dir = scratch("monitor_metrics");
    std::fs::write(dir.join("channel.ron"), CHANNEL).unwrap();
    let study = dir.join("s.ron");
    std::fs::write(
        &study,
        r#"(name: "s", base: "channel.ron",
            axes: [(name: "end", values: List(path: "time.end", values: [0.3, 5.0]))],
            metrics: [
                Monitor(monitor: "drag", column: "c_D"),
                Monitor(monitor: "drag", column: "c_D", of: Mean),
                Monitor(monitor: "drag", column: "fx", of: Max),
                Monitor(monitor: "drag", column: "c_L", of: Min),
                Stopped,
            ],
            charts: [AccuracyCost(series: [])])"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = multifield(&["study", study.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", text(&o));
    let rows = table(&out.join("results.csv"));
    assert_eq!(rows.len(), 2);
    for row in &rows {
        let run = out.join(&row["directory"]);
        let csv = run.join("monitors").join("drag.csv");
        let (t, cd, fx, cl) =
            (csv_column(&csv, "time"), csv_column(&csv, "c_D"), csv_column(&csv, "fx"), csv_column(&csv, "c_L"));
        assert!(cd.len() > 3, "{} rows", cd.len());
        assert_eq!(num(row, "drag_c_D"), *cd.last().unwrap(), "{row:?}");
        let mut area = 0.0;
        for k in 1..t.len() {
            area += (t[k] - t[k - 1]) * (cd[k] + cd[k - 1]) / 2.0;
        }
        let mean = area / (t[t.len() - 1] - t[0]);
        let got = num(row, "mean_drag_c_D");
        assert!((got - mean).abs() <= 1e-12 * mean.abs(), "mean {got} vs {mean}");
        // a time-weighted mean, not the mean of the rows
        let rows_mean = cd.iter().sum::<f64>() / cd.len() as f64;
        assert!((got - rows_mean).abs() > 1e-9, "mean {got} vs the rows' {rows_mean}");
        assert_eq!(num(row, "max_drag_fx"), fx.iter().copied().fold(f64::MIN, f64::max));
        assert_eq!(num(row, "min_drag_c_L"), cl.iter().copied().fold(f64::MAX, f64::min));
        let summary: String = std::fs::read_to_string(run.join("summary.json")).unwrap();
        let simulated: f64 = summary
            .split("\"simulated_time\":")
            .nth(1)
            .unwrap()
            .split([',', '\n', '}'])
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        if row["end"] == "5" {
            assert!(row["reason"].starts_with("steady: drag.c_D changed"), "{row:?}");
            assert!(simulated < 5.0 && simulated > 0.3, "stopped at {simulated}");
            assert_eq!(num(row, "stop_time"), simulated);
        } else {
            assert!((simulated - 0.3).abs() < 1e-9, "the short run reaches its end: {simulated}");
            assert_eq!(row["stop_time"], "", "no stop condition fired: {row:?}");
        }
    }
}

#[test]
fn a_monitor_metric_of_an_unknown_monitor_or_column_is_refused() {
    let e = study_error(
        "unknown_monitor",
        r#"(name: "s", base: "channel.ron",
            axes: [(name: "end", values: List(path: "time.end", values: [1.0]))],
            metrics: [Monitor(monitor: "drg", column: "c_D", of: Final)])"#,
    );
    assert!(
        e.contains("metrics.0.monitor")
            && e.contains("no monitor named `drg`; its monitors: drag")
            && e.contains("did you mean `drag`?"),
        "{e}"
    );
    let e = study_error(
        "unknown_monitor_column",
        r#"(name: "s", base: "channel.ron",
            axes: [(name: "end", values: List(path: "time.end", values: [1.0]))],
            metrics: [Stopped, Monitor(monitor: "drag", column: "cD", of: Mean)])"#,
    );
    assert!(
        e.contains("metrics.1.column")
            && e.contains("`cD` is not a column of monitors/drag.csv")
            && e.contains("c_D, c_L, c_M"),
        "{e}"
    );
    // a combination whose overrides drop the coefficients: named with its combination
    let e = study_error(
        "monitor_column_of_a_combination",
        r#"(name: "s", base: "channel.ron",
            axes: [(name: "reference", values: List(path: "monitors.0.of.Forces.reference", values: ["Some((velocity: 1.0, length: 0.2, density: 1.0))", "None"]))],
            set: ["stop=[]"],
            metrics: [Monitor(monitor: "drag", column: "c_D")])"#,
    );
    assert!(e.contains("run 2 of 2") && e.contains("`c_D` is not a column of monitors/drag.csv"), "{e}");
}
