//! Studies: many runs of one case over a grid of parameters, one results table, charts.
//!
//! A study file (RON) names a base case, the axes to sweep, the metrics to record, the
//! reference to measure error against and the charts to draw (docs/studies.md has every
//! key). `multifield study STUDY.ron` runs the cartesian product of the axes, each
//! combination in its own directory `<out>/runs/<axis>-<label>__…`, in parallel, and writes
//! `<out>/results.csv` (rewritten atomically after every run, so it is readable at any time)
//! and the charts (`<out>/<chart name>.{png,svg}`, [`crate::study_chart`]).
//!
//! A run whose `summary.json` says `completed` or `unstable` and whose `study_case.ron` is
//! the case the study would run now is not run again; a `failed`, missing or changed one is.
//! Unstable and failed runs are data: the study carries on with the next run.
//!
//! Every combination is built, overridden, validated and its plugins constructed before the
//! first run starts, so a bad override path or parameter stops the study up front with the
//! combination named.

use crate::core::case::Case;
use crate::core::error::Error;
use crate::core::math::Real;
use crate::core::simulation::Simulation;
use crate::dkt::ReferenceCurves;
use crate::run::{self, RunOptions};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// A study file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Study {
    /// Name; the default output directory is `out/studies/<name>`.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// The base case file, relative to the study file.
    pub base: PathBuf,
    /// Overrides applied to the base case before the axes' (`PATH=VALUE`, as `run --set`).
    #[serde(default)]
    pub set: Vec<String>,
    /// The parameters to sweep; the study runs every combination.
    pub axes: Vec<Axis>,
    /// Extra columns of the results table.
    #[serde(default)]
    pub metrics: Vec<Metric>,
    /// What the `error` column measures against.
    #[serde(default)]
    pub reference: Reference,
    /// Charts drawn from the results table.
    #[serde(default)]
    pub charts: Vec<ChartSpec>,
    /// Where the runs go: here (default) or a Slurm cluster ([`crate::slurm`]); the command
    /// line's `--scheduler`, `--partition`, … override each entry.
    #[serde(default)]
    pub scheduler: crate::slurm::SchedulerSpec,
}

/// One swept parameter.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// Name: a column of the results table, and how charts refer to the axis.
    pub name: String,
    /// Its values.
    pub values: Values,
}

/// The values of an axis.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Values {
    /// Values set at one override path: `List(path: "time.cfl", values: [0.2, 0.4])`.
    /// A text value is RON (`"Explicit"`, `"(160, 640)"`), or a plain string if it is not.
    List {
        /// Override path, e.g. `fields.disks.frame.params.transfer`.
        path: String,
        /// The values.
        values: Vec<Scalar>,
    },
    /// `steps` numbers from `from` to `to`, evenly spaced (or geometrically with `log: true`).
    Range {
        /// Override path.
        path: String,
        /// First value.
        from: Real,
        /// Last value.
        to: Real,
        /// How many values (at least 2).
        steps: usize,
        /// Geometric spacing (both ends positive).
        #[serde(default)]
        log: bool,
    },
    /// Labelled sets of overrides, for a parameter that sets several entries at once.
    Sets(Vec<LabelledSet>),
}

/// One value of a [`Values::Sets`] axis.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabelledSet {
    /// Label (directory names, legend, table).
    pub label: String,
    /// Its position on a chart's axis; default: the label read as a number, else its rank.
    #[serde(default)]
    pub value: Option<Real>,
    /// The overrides, e.g. `["domain.cells=(160, 480)"]`.
    pub set: Vec<String>,
}

/// A scalar value of a [`Values::List`] axis.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum Scalar {
    /// A number.
    Number(Real),
    /// A boolean.
    Bool(bool),
    /// RON text (or a plain string).
    Text(String),
}

/// An extra column of the results table, from each run's output.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Metric {
    /// Last row of a `diagnostics.csv` column: column `final_<name>`.
    Final(String),
    /// Largest value of a `diagnostics.csv` column: column `max_<name>`.
    Max(String),
    /// Mean of a `diagnostics.csv` column over its rows: column `mean_<name>`.
    Mean(String),
    /// A number of `summary.json`, e.g. `"pressure_iterations_total"`: column `<name>`.
    Summary(String),
    /// Drafting–kissing–tumbling of two disks ([`crate::dkt`]): columns `kiss_time`,
    /// `tumble_time`, `min_gap_over_d`.
    Dkt,
    /// The last row of a `bodies.csv` column for one body, times `scale` (default 1; e.g.
    /// 2/(ρU²D) for a drag coefficient): column `<body>_<column>`.
    Body {
        /// The body's name.
        body: String,
        /// One of [`BODY_COLUMNS`].
        column: String,
        /// Factor applied to the value.
        #[serde(default)]
        scale: Option<Real>,
    },
    /// A column of a monitor's `monitors/<monitor>.csv` (docs/monitors.md), reduced over its
    /// rows by `of` (default `Final`): column `<monitor>_<column>` for `Final`,
    /// `mean_<monitor>_<column>`, `max_…`, `min_…` for the others.
    Monitor {
        /// The monitor's name, as in the case's `monitors`.
        monitor: String,
        /// One of its columns (e.g. `c_D`), or `time`.
        column: String,
        /// How the rows are reduced.
        #[serde(default)]
        of: Reduce,
        /// Only the rows with `from ≤ time ≤ to` (e.g. the steady regime of a settling
        /// suspension); default every row. The column's name then ends in
        /// `_in_<from>_<to>`.
        #[serde(default)]
        window: Option<(Real, Real)>,
    },
    /// The simulated time at which a stop condition of the case (`stop: [...]`) ended the
    /// run: column `stop_time`, empty when no condition fired (the run reached `time.end`,
    /// or ended otherwise). Which condition fired is the `reason` column.
    Stopped,
}

/// How a [`Metric::Monitor`] reduces a monitor's rows to one number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum Reduce {
    /// The last row.
    #[default]
    Final,
    /// The time-weighted mean over the rows: the trapezoidal integral over the `time`
    /// column divided by the time spanned (the value itself for a single row).
    Mean,
    /// The largest value.
    Max,
    /// The smallest value.
    Min,
}

/// Columns of `bodies.csv` a [`Metric::Body`] can name.
pub const BODY_COLUMNS: [&str; 12] =
    ["x", "y", "vx", "vy", "omega", "fx", "fy", "torque", "fx_pressure", "fy_pressure", "fx_viscous", "fy_viscous"];

/// Numbers of `summary.json` a [`Metric::Summary`] can name.
pub const SUMMARY_NUMBERS: [&str; 11] = [
    "steps",
    "simulated_time",
    "end_time",
    "wall_seconds",
    "initial_kinetic_energy",
    "final_kinetic_energy",
    "kinetic_energy_bound",
    "max_divergence",
    "max_volume_fraction_error",
    "pressure_iterations_total",
    "min_dt",
];

/// What the `error` column measures against.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Reference {
    /// No error column values.
    #[default]
    None,
    /// A closed-form history of a `diagnostics.csv` column. The error is the RMS over the
    /// rows of (value − exact)/|exact(0)|.
    Analytic {
        /// The column, e.g. `"kinetic_energy"`.
        column: String,
        /// The exact history.
        law: Law,
    },
    /// Uhlmann (2005)'s DKT curves shipped with multifield
    /// (`validation/reference/dkt-uhlmann2005`, built into the program): the error is the RMS
    /// distance of the along-gravity positions over [0, 0.28] s, in diameters
    /// ([`crate::dkt::analyse`]); the run must be their scene.
    Uhlmann2005,
    /// As [`Reference::Uhlmann2005`], with the curves of this folder (relative to the study
    /// file), named and laid out as `validation/reference/dkt-uhlmann2005`.
    Uhlmann(PathBuf),
    /// The run of the same group (equal labels on every other axis) with the most cells,
    /// among the values of `axis`.
    Finest {
        /// The resolution axis.
        axis: String,
        /// What is compared.
        compare: Compare,
    },
    /// The run of the same group whose label on `axis` is `value`.
    Baseline {
        /// The axis.
        axis: String,
        /// The label of the baseline's value on it.
        value: String,
        /// What is compared.
        compare: Compare,
    },
    /// The run of the same group (equal labels on every axis not named here) whose labels
    /// on the named axes are these: e.g. `{"representation": "resolved", "cells_per_d":
    /// "16"}`, the finest resolved run at each solid fraction of a study that also sweeps
    /// the solid fraction. [`Reference::Baseline`] is the case of one axis.
    Run {
        /// Axis name → the label of the reference run on it.
        labels: BTreeMap<String, String>,
        /// What is compared.
        compare: Compare,
    },
    /// A known value of one of the study's metric columns for each label of one axis
    /// (published or analytic values that vary along the axis: a settling velocity per
    /// solid fraction, a bed height per inflow velocity): the error of a run is
    /// |metric − value| / |value| with the value of its own label on `axis`.
    Table {
        /// The metric's column, e.g. `mean_s_settling_velocity_in_0.1_0.3`.
        column: String,
        /// The axis whose labels the values belong to.
        axis: String,
        /// (label, value) for every label of the axis.
        values: Vec<(String, Real)>,
    },
    /// A known value of one of the study's metric columns (a published or analytic drag
    /// coefficient, torque, terminal velocity): the error is |metric − value| / |value|.
    Exact {
        /// The metric's column, e.g. `cylinder_fx`.
        column: String,
        /// The known value.
        value: Real,
    },
}

/// A closed-form history v(t).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Law {
    /// v(t) = floor + (v₀ − floor) e^(−rate t); v₀ = `initial`, or the run's initial kinetic
    /// energy when the column is `kinetic_energy` and `initial` is left out. The
    /// Taylor–Green vortex's energy decays with rate 4ν (unit wavenumbers).
    Exponential {
        /// Decay rate (1/time).
        rate: Real,
        /// v₀; see above.
        #[serde(default)]
        initial: Option<Real>,
        /// The value approached.
        #[serde(default)]
        floor: Real,
    },
}

/// What a run is compared with its reference run by.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Compare {
    /// The bodies' centroids (`bodies.csv`): RMS distance over the reference's output times
    /// and the bodies, in units of length.
    Bodies,
    /// A `diagnostics.csv` column: RMS of the difference at the reference's output times,
    /// over the largest |value| of the reference.
    Column(String),
    /// One of the study's metric columns: |m − m_ref| / |m_ref| (a bed height or a mean
    /// settling velocity over a window, against the reference run's).
    Metric(String),
}

/// A chart of the results.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ChartSpec {
    /// Error against wall time, log–log, one series per combination of the labels of
    /// `series`, the Pareto front marked.
    AccuracyCost {
        /// File name (without extension); default `accuracy_cost`.
        #[serde(default)]
        name: Option<String>,
        /// The axes whose labels make a method (one series each).
        series: Vec<String>,
    },
    /// Stable and unstable runs over two axes, the boundary drawn; one panel per
    /// combination of the other axes.
    StabilityMap {
        /// File name (without extension); default `stability_<x>_<y>`.
        #[serde(default)]
        name: Option<String>,
        /// The horizontal axis.
        x: String,
        /// The vertical axis.
        y: String,
    },
}

impl ChartSpec {
    /// The file stem of the chart.
    pub fn file_name(&self) -> String {
        match self {
            ChartSpec::AccuracyCost { name, .. } => name.clone().unwrap_or_else(|| "accuracy_cost".into()),
            ChartSpec::StabilityMap { name, x, y } => name.clone().unwrap_or_else(|| format!("stability_{x}_{y}")),
        }
    }
}

/// One value of one axis, resolved.
#[derive(Clone, Debug)]
pub struct Point {
    /// Label.
    pub label: String,
    /// Position on a chart's axis (NaN: categorical, placed by rank).
    pub value: Real,
    /// Overrides it applies.
    pub set: Vec<String>,
}

/// One combination of the axes' values: one run.
#[derive(Clone, Debug)]
pub struct Combination {
    /// Index of the value on every axis.
    pub index: Vec<usize>,
    /// The labels, one per axis.
    pub labels: Vec<String>,
    /// The chart positions, one per axis.
    pub values: Vec<Real>,
    /// Every override, the base's first.
    pub overrides: Vec<String>,
    /// The case to run.
    pub case: Case,
    /// Its directory.
    pub dir: PathBuf,
}

impl Combination {
    /// `axis=label, …`, for messages.
    pub fn describe(&self, axes: &[Axis]) -> String {
        axes.iter().zip(&self.labels).map(|(a, l)| format!("{}={l}", a.name)).collect::<Vec<_>>().join(", ")
    }
}

/// A study read and checked: its axes resolved and every combination built.
#[derive(Debug)]
pub struct Plan {
    /// The study as written.
    pub study: Study,
    /// The study file.
    pub file: PathBuf,
    /// Resolved values per axis.
    pub points: Vec<Vec<Point>>,
    /// Every combination (or those chosen with `--only`), the first axis varying slowest.
    pub runs: Vec<Combination>,
    /// Output directory.
    pub out: PathBuf,
}

/// How to run a study.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// Runs at a time; 0: cores / threads per run.
    pub jobs: usize,
    /// Worker threads of each run.
    pub threads_per_run: usize,
    /// No progress bar and no line per run.
    pub quiet: bool,
}

impl Default for StudyOptions {
    fn default() -> Self {
        Self { jobs: 0, threads_per_run: 1, quiet: true }
    }
}

/// What [`run_study`] did.
#[derive(Debug, Default)]
pub struct Report {
    /// Runs done now.
    pub ran: usize,
    /// Finished runs found and not rerun.
    pub skipped: usize,
    /// Status of every combination, in order.
    pub statuses: Vec<String>,
    /// The results table.
    pub results: PathBuf,
    /// The charts written (PNG; the SVG beside each).
    pub charts: Vec<PathBuf>,
}

/// That `axis` (whose values are `points`) has a value labelled `label`, or the error
/// at `path` listing the labels it has.
fn check_label(file: &Path, path: &str, axis: &str, label: &str, points: &[Point]) -> Result<(), Error> {
    if points.iter().any(|p| p.label == label) {
        return Ok(());
    }
    let valid: Vec<&str> = points.iter().map(|p| p.label.as_str()).collect();
    Err(bad(
        file,
        path,
        format!(
            "axis `{axis}` has no value labelled `{label}`; labels: {}{}",
            valid.join(", "),
            crate::core::error::did_you_mean(label, valid.iter().copied())
        ),
    ))
}

fn bad(file: &Path, path: &str, message: String) -> Error {
    Error::Invalid { file: file.to_path_buf(), path: path.to_string(), message }
}

/// A number as a label: at most 6 significant digits, no trailing noise.
pub fn short(x: Real) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = 5 - x.abs().log10().floor() as i32;
    let r = if digits >= 0 { (x * 10f64.powi(digits)).round() / 10f64.powi(digits) } else { x };
    if (1e-4..1e6).contains(&r.abs()) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

impl Study {
    /// Parses a study from RON text; `file` is only used in messages.
    pub fn from_ron(text: &str, file: &Path) -> Result<Study, Error> {
        crate::core::input::ron_options().from_str::<Study>(text).map_err(|e| Error::Syntax {
            file: file.to_path_buf(),
            line: e.span.start.line,
            column: e.span.start.col,
            message: crate::core::case::explain_ron_error(&e.code),
        })
    }

    /// The number of values of each axis and of runs (their product), counted in checked
    /// arithmetic before any list is built; refused beyond `max_runs` (the entry named: the
    /// axis that passes the cap).
    pub fn count_runs(&self, file: &Path, max_runs: u64) -> Result<u64, Error> {
        let counts: Vec<u64> = self
            .axes
            .iter()
            .map(|axis| match &axis.values {
                Values::List { values, .. } => values.len() as u64,
                Values::Range { steps, .. } => *steps as u64,
                Values::Sets(sets) => sets.len() as u64,
            })
            .collect();
        let total = counts.iter().try_fold(1u64, |t, &n| t.checked_mul(n));
        if total.is_none_or(|t| t > max_runs) {
            let product = counts.iter().map(u64::to_string).collect::<Vec<_>>().join(" × ");
            let runs = match total {
                Some(t) if counts.len() > 1 => format!("{product} = {t} runs"),
                Some(t) => format!("{t} runs"),
                None => format!("{product}: more than {} runs", u64::MAX),
            };
            // the entry named: the longest axis
            let k = (0..counts.len()).max_by_key(|&k| (counts[k], std::cmp::Reverse(k))).unwrap_or(0);
            let name = if self.axes[k].name.is_empty() { k.to_string() } else { self.axes[k].name.clone() };
            return Err(bad(
                file,
                &format!("axes.{name}"),
                format!("the axes make {runs}; at most {max_runs} (`--max-runs N` raises the cap); use fewer values"),
            ));
        }
        Ok(total.unwrap_or(0))
    }

    /// The resolved values of every axis; checks the axes.
    pub fn points(&self, file: &Path) -> Result<Vec<Vec<Point>>, Error> {
        if self.axes.is_empty() {
            return Err(bad(file, "axes", "a study needs at least one axis".into()));
        }
        // no axis longer than a list can hold, whatever the caller checked
        self.count_runs(file, isize::MAX as u64 / 64)?;
        let mut all = Vec::new();
        for (k, axis) in self.axes.iter().enumerate() {
            let here = format!("axes.{}", axis.name);
            if axis.name.is_empty() || !axis.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(bad(
                    file,
                    &format!("axes.{k}.name"),
                    format!("`{}`: an axis name is letters, digits and `_` (a results column)", axis.name),
                ));
            }
            if self.axes[..k].iter().any(|a| a.name == axis.name) {
                return Err(bad(file, &here, format!("two axes are named `{}`", axis.name)));
            }
            let points: Vec<Point> = match &axis.values {
                Values::List { path, values } => values
                    .iter()
                    .map(|v| {
                        let (text, value) = match v {
                            Scalar::Number(x) => (format!("{x}"), *x),
                            Scalar::Bool(b) => (b.to_string(), Real::NAN),
                            Scalar::Text(s) => (s.clone(), s.trim().parse().unwrap_or(Real::NAN)),
                        };
                        let label = match v {
                            Scalar::Number(x) => short(*x),
                            _ => text.trim().trim_matches('"').to_string(),
                        };
                        Point { label, value, set: vec![format!("{path}={text}")] }
                    })
                    .collect(),
                Values::Range { path, from, to, steps, log } => {
                    if *steps < 2 || !from.is_finite() || !to.is_finite() || (*log && !(*from > 0.0 && *to > 0.0)) {
                        return Err(bad(
                            file,
                            &here,
                            format!(
                                "Range(from: {from}, to: {to}, steps: {steps}, log: {log}): give at least 2 steps \
                                 between finite ends, both positive with log: true"
                            ),
                        ));
                    }
                    (0..*steps)
                        .map(|i| {
                            let s = i as Real / (*steps - 1) as Real;
                            let x = if *log { from * (to / from).powf(s) } else { from + (to - from) * s };
                            let x = if i + 1 == *steps { *to } else { x };
                            Point { label: short(x), value: x, set: vec![format!("{path}={x}")] }
                        })
                        .collect()
                }
                Values::Sets(sets) => sets
                    .iter()
                    .map(|s| Point {
                        label: s.label.clone(),
                        value: s.value.unwrap_or_else(|| s.label.trim().parse().unwrap_or(Real::NAN)),
                        set: s.set.clone(),
                    })
                    .collect(),
            };
            if points.is_empty() {
                return Err(bad(file, &here, "an axis needs at least one value".into()));
            }
            for (i, p) in points.iter().enumerate() {
                if p.label.is_empty() || points[..i].iter().any(|q| q.label == p.label) {
                    return Err(bad(
                        file,
                        &here,
                        format!("the label `{}` is empty or repeated; labels must be unique", p.label),
                    ));
                }
            }
            all.push(points);
        }
        Ok(all)
    }

    fn axis_index(&self, file: &Path, path: &str, name: &str) -> Result<usize, Error> {
        self.axes.iter().position(|a| a.name == name).ok_or_else(|| {
            let names: Vec<&str> = self.axes.iter().map(|a| a.name.as_str()).collect();
            bad(
                file,
                path,
                format!(
                    "no axis is named `{name}`; axes: {}{}",
                    names.join(", "),
                    crate::core::error::did_you_mean(name, names.iter().copied())
                ),
            )
        })
    }

    /// Checks the metrics, the reference and the charts against the axes.
    fn check_specs(&self, file: &Path, points: &[Vec<Point>]) -> Result<(), Error> {
        let columns: Vec<&str> = run::CSV_HEADER.split(',').collect();
        let column = |path: &str, c: &str| -> Result<(), Error> {
            if columns.contains(&c) {
                Ok(())
            } else {
                Err(bad(
                    file,
                    path,
                    format!(
                        "`{c}` is not a column of diagnostics.csv; columns: {}{}",
                        columns.join(", "),
                        crate::core::error::did_you_mean(c, columns.iter().copied())
                    ),
                ))
            }
        };
        for (k, m) in self.metrics.iter().enumerate() {
            let path = format!("metrics.{k}");
            match m {
                Metric::Final(c) | Metric::Max(c) | Metric::Mean(c) => column(&path, c)?,
                Metric::Summary(s) if !SUMMARY_NUMBERS.contains(&s.as_str()) => {
                    return Err(bad(
                        file,
                        &path,
                        format!(
                            "`{s}` is not a number of summary.json; numbers: {}{}",
                            SUMMARY_NUMBERS.join(", "),
                            crate::core::error::did_you_mean(s, SUMMARY_NUMBERS.iter().copied())
                        ),
                    ))
                }
                Metric::Body { column: c, scale, .. } => {
                    if !BODY_COLUMNS.contains(&c.as_str()) {
                        return Err(bad(
                            file,
                            &format!("{path}.column"),
                            format!(
                                "`{c}` is not a column of bodies.csv; columns: {}{}",
                                BODY_COLUMNS.join(", "),
                                crate::core::error::did_you_mean(c, BODY_COLUMNS.iter().copied())
                            ),
                        ));
                    }
                    if scale.is_some_and(|x| !x.is_finite()) {
                        return Err(bad(file, &format!("{path}.scale"), "must be a finite number".to_string()));
                    }
                }
                _ => {}
            }
        }
        match &self.reference {
            Reference::None => {}
            Reference::Exact { column: c, value } => {
                self.check_metric_column(file, "reference.column", c)?;
                if !(value.is_finite() && *value != 0.0) {
                    return Err(bad(file, "reference.value", format!("{value}: must be finite and not 0")));
                }
            }
            Reference::Analytic { column: c, law: Law::Exponential { rate, initial, .. } } => {
                column("reference.column", c)?;
                if !rate.is_finite() {
                    return Err(bad(file, "reference.law.rate", format!("{rate}: must be finite")));
                }
                if initial.is_none() && c != "kinetic_energy" {
                    return Err(bad(
                        file,
                        "reference.law.initial",
                        format!("give `initial: Some(v0)`: the value of `{c}` at t = 0 is not recorded"),
                    ));
                }
            }
            Reference::Uhlmann2005 => {}
            Reference::Uhlmann(dir) => {
                let d = self.relative(file, dir);
                if !d.join("Uhlmann2005-fig6a-leading-particle.csv").is_file() {
                    return Err(bad(
                        file,
                        "reference",
                        format!(
                            "{}: no Uhlmann2005-fig6a-*-particle.csv there; give the folder of the reference \
                             curves relative to the study file, or `Uhlmann2005` for the curves built \
                             into multifield",
                            d.display()
                        ),
                    ));
                }
            }
            Reference::Finest { axis, compare } | Reference::Baseline { axis, compare, .. } => {
                let a = self.axis_index(file, "reference.axis", axis)?;
                if let Reference::Baseline { value, .. } = &self.reference {
                    check_label(file, "reference.value", axis, value, &points[a])?;
                }
                self.check_compare(file, compare, &column)?;
            }
            Reference::Run { labels, compare } => {
                if labels.is_empty() {
                    let names: Vec<&str> = self.axes.iter().map(|a| a.name.as_str()).collect();
                    let example = match (names.first(), points.first().and_then(|p| p.first())) {
                        (Some(axis), Some(p)) => format!(", e.g. labels: {{\"{axis}\": \"{}\"}}", p.label),
                        _ => String::new(),
                    };
                    return Err(bad(
                        file,
                        "reference.labels",
                        format!(
                            "name the reference run by a label on one axis or more{example}; axes: {}",
                            names.join(", ")
                        ),
                    ));
                }
                for (axis, label) in labels {
                    let a = self.axis_index(file, "reference.labels", axis)?;
                    check_label(file, &format!("reference.labels.{axis}"), axis, label, &points[a])?;
                }
                self.check_compare(file, compare, &column)?;
            }
            Reference::Table { column: c, axis, values } => {
                self.check_metric_column(file, "reference.column", c)?;
                let a = self.axis_index(file, "reference.axis", axis)?;
                for (k, (label, value)) in values.iter().enumerate() {
                    let path = format!("reference.values.{k}");
                    check_label(file, &path, axis, label, &points[a])?;
                    if values[..k].iter().any(|(l, _)| l == label) {
                        return Err(bad(file, &path, format!("`{label}` is given twice: give one value per label")));
                    }
                    if !(value.is_finite() && *value != 0.0) {
                        return Err(bad(file, &path, format!("`{label}`: {value} must be finite and not 0")));
                    }
                }
                let valid: Vec<&str> = points[a].iter().map(|p| p.label.as_str()).collect();
                let missing: Vec<&str> =
                    valid.iter().copied().filter(|l| !values.iter().any(|(v, _)| v == l)).collect();
                if !missing.is_empty() {
                    return Err(bad(
                        file,
                        "reference.values",
                        format!(
                            "no value for the label{} {} of axis `{axis}`: give (label, value) for every label \
                             ({})",
                            if missing.len() == 1 { "" } else { "s" },
                            missing.join(", "),
                            valid.join(", ")
                        ),
                    ));
                }
            }
        }
        for (k, c) in self.charts.iter().enumerate() {
            let path = format!("charts.{k}");
            match c {
                ChartSpec::AccuracyCost { series, .. } => {
                    for s in series {
                        self.axis_index(file, &format!("{path}.series"), s)?;
                    }
                }
                ChartSpec::StabilityMap { x, y, .. } => {
                    self.axis_index(file, &format!("{path}.x"), x)?;
                    self.axis_index(file, &format!("{path}.y"), y)?;
                    if x == y {
                        return Err(bad(file, &path, format!("x and y are both `{x}`: give two different axes")));
                    }
                }
            }
            let name = c.file_name();
            if name.is_empty() || !name.chars().all(|ch| ch.is_ascii_alphanumeric() || "-_".contains(ch)) {
                return Err(bad(file, &format!("{path}.name"), format!("`{name}`: letters, digits, `-` and `_`")));
            }
            if self.charts[..k].iter().any(|o| o.file_name() == name) {
                return Err(bad(file, &format!("{path}.name"), format!("two charts are named `{name}`")));
            }
        }
        Ok(())
    }

    /// Checks that `c` is one of the study's metric columns.
    fn check_metric_column(&self, file: &Path, path: &str, c: &str) -> Result<(), Error> {
        let columns = metric_columns(&self.metrics);
        if columns.iter().any(|m| m == c) {
            return Ok(());
        }
        Err(bad(
            file,
            path,
            format!(
                "`{c}` is not a metric column of this study; its metric columns: {}{}",
                if columns.is_empty() { "none (add `metrics`)".to_string() } else { columns.join(", ") },
                crate::core::error::did_you_mean(c, columns.iter().map(String::as_str))
            ),
        ))
    }

    /// Checks what a reference run is compared by.
    fn check_compare(
        &self,
        file: &Path,
        compare: &Compare,
        column: &dyn Fn(&str, &str) -> Result<(), Error>,
    ) -> Result<(), Error> {
        match compare {
            Compare::Bodies => Ok(()),
            Compare::Column(c) => column("reference.compare", c),
            Compare::Metric(c) => self.check_metric_column(file, "reference.compare", c),
        }
    }

    /// Checks the [`Metric::Monitor`] entries against the monitors of `case`.
    fn check_monitor_metrics(&self, file: &Path, case: &Case) -> Result<(), Error> {
        for (k, m) in self.metrics.iter().enumerate() {
            let Metric::Monitor { monitor, column, window, .. } = m else { continue };
            if let Some((from, to)) = window {
                if !(from.is_finite() && to.is_finite() && from <= to) {
                    return Err(bad(
                        file,
                        &format!("metrics.{k}.window"),
                        format!(
                            "the window ({from}, {to}) is not a span of time: give (from, to) with from ≤ to, \
                             e.g. window: Some((0.1, 0.3))"
                        ),
                    ));
                }
            }
            let names = case.monitors.iter().map(|m| m.name.as_str());
            let Some(spec) = case.monitors.iter().find(|m| &m.name == monitor) else {
                let list: Vec<&str> = names.clone().collect();
                return Err(bad(
                    file,
                    &format!("metrics.{k}.monitor"),
                    format!(
                        "the case has no monitor named `{monitor}`; its monitors: {}{}",
                        if list.is_empty() {
                            "none (add `monitors: [...]` to the case)".to_string()
                        } else {
                            list.join(", ")
                        },
                        crate::core::error::did_you_mean(monitor, names)
                    ),
                ));
            };
            let mut columns = vec!["time".to_string()];
            columns.extend(spec.columns().map_err(|e| bad(file, &format!("metrics.{k}.monitor"), e))?);
            if !columns.contains(column) {
                return Err(bad(
                    file,
                    &format!("metrics.{k}.column"),
                    format!(
                        "`{column}` is not a column of monitors/{monitor}.csv; columns: {}{}",
                        columns.join(", "),
                        crate::core::error::did_you_mean(column, columns.iter().map(String::as_str))
                    ),
                ));
            }
        }
        Ok(())
    }

    fn relative(&self, file: &Path, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            file.parent().unwrap_or(Path::new("")).join(p)
        }
    }
}

/// Reads and checks a study file, and builds every combination's case (overrides applied,
/// validated, plugins constructed): any error names the combination. With `only`
/// (`axis=label`, e.g. `representation=resolved`), just the combinations with those labels
/// (several labels of one axis: any of them).
pub fn plan(file: &Path, out: Option<PathBuf>, only: &[String]) -> Result<Plan, Error> {
    plan_within(file, out, only, &Limits::default())
}

/// The most runs a study may have unless `--max-runs` says otherwise.
pub const MAX_RUNS: u64 = 10_000;

/// What a study may use: runs, and memory per run.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// The most runs (`--max-runs`; default [`MAX_RUNS`]).
    pub max_runs: u64,
    /// The memory a run may use ([`crate::core::limits::MemoryLimit`]).
    pub memory: crate::core::limits::MemoryLimit,
}

impl Default for Limits {
    fn default() -> Self {
        let memory = crate::core::limits::MemoryLimit::resolve(None).unwrap_or(crate::core::limits::MemoryLimit {
            bytes: u64::MAX,
            source: crate::core::limits::LimitSource::None,
        });
        Self { max_runs: MAX_RUNS, memory }
    }
}

/// [`plan`] within `limits`: the runs are counted (and refused beyond the cap) before any
/// is built, and every combination's memory is estimated before its simulation is.
pub fn plan_within(file: &Path, out: Option<PathBuf>, only: &[String], limits: &Limits) -> Result<Plan, Error> {
    plan_to(file, out, only, limits, true)
}

/// [`plan_within`], building every combination's simulation only with `build` (without,
/// every case is still overridden, validated and its memory estimated: what the fuzz
/// targets check first).
pub fn plan_to(
    file: &Path,
    out: Option<PathBuf>,
    only: &[String],
    limits: &Limits,
    build: bool,
) -> Result<Plan, Error> {
    let text = crate::core::input::read_text(file)?;
    let study = Study::from_ron(&text, file)?;
    study.count_runs(file, limits.max_runs)?;
    let points = study.points(file)?;
    study.check_specs(file, &points)?;
    let base_file = study.relative(file, &study.base);
    let base_text = crate::core::input::read_text(&base_file)?;
    let base = Case::from_ron(&base_text, &base_file)?;
    study.check_monitor_metrics(file, &base)?;
    let out = out.unwrap_or_else(|| Path::new("out/studies").join(run::directory_name(&study.name)));
    let mut wanted: Vec<(usize, String)> = Vec::new();
    for o in only {
        let (axis, label) = o.split_once('=').ok_or_else(|| {
            Error::Model(format!("--only {o}: expected axis=label, e.g. --only {}=…", study.axes[0].name))
        })?;
        let a = study.axis_index(file, &format!("--only {o}"), axis.trim())?;
        let labels: Vec<&str> = points[a].iter().map(|p| p.label.as_str()).collect();
        if !labels.contains(&label.trim()) {
            return Err(Error::Model(format!(
                "--only {o}: axis `{axis}` has no value labelled `{label}`; labels: {}",
                labels.join(", ")
            )));
        }
        wanted.push((a, label.trim().to_string()));
    }
    let mut runs: Vec<Combination> = Vec::new();
    let mut dirs: std::collections::HashMap<PathBuf, usize> = std::collections::HashMap::new();
    let counts: Vec<usize> = points.iter().map(Vec::len).collect();
    // counted above: at most limits.max_runs, no overflow
    let total: usize = counts.iter().product();
    for n in 0..total {
        let mut index = vec![0; counts.len()];
        let mut rest = n;
        for k in (0..counts.len()).rev() {
            index[k] = rest % counts[k];
            rest /= counts[k];
        }
        let chosen: Vec<&Point> = index.iter().enumerate().map(|(k, &i)| &points[k][i]).collect();
        let labels: Vec<String> = chosen.iter().map(|p| p.label.clone()).collect();
        let selected = |a: usize| {
            let of_axis: Vec<&String> = wanted.iter().filter(|w| w.0 == a).map(|w| &w.1).collect();
            of_axis.is_empty() || of_axis.contains(&&labels[a])
        };
        if !(0..labels.len()).all(selected) {
            continue;
        }
        let mut overrides = study.set.clone();
        for p in &chosen {
            overrides.extend(p.set.iter().cloned());
        }
        let name: Vec<String> = study.axes.iter().zip(&labels).map(|(a, l)| format!("{}-{l}", a.name)).collect();
        let dir = out.join("runs").join(run::directory_name(&name.join("__")));
        let combination = Combination {
            index,
            labels,
            values: chosen.iter().map(|p| p.value).collect(),
            overrides,
            case: base.clone(),
            dir,
        };
        let what = combination.describe(&study.axes);
        // distinct labels can make one directory name (`a b` and `a_b`): two runs would
        // share their output and the second would count as finished
        if let Some(other) = dirs.get(&combination.dir).map(|&k| &runs[k]) {
            return Err(Error::Model(format!(
                "{}: the combinations {} and {what} would both run in {}: their labels differ only in \
                 characters a directory name cannot hold (letters, digits, `-`, `_` and `.` are kept, \
                 others become `_`); give the axis values labels that differ in those",
                file.display(),
                other.describe(&study.axes),
                combination.dir.display()
            )));
        }
        let context = |e: Error| {
            Error::Model(format!("{}: the combination {what} (run {} of {total}): {}", file.display(), n + 1, e))
        };
        let mut case = base.with_overrides(&combination.overrides).map_err(context)?;
        case.validate().map_err(|e| context(e.in_file(&base_file)))?;
        case.name = format!("{}: {what}", study.name);
        // the overrides may change the monitors: their metrics are checked again
        study.check_monitor_metrics(file, &case).map_err(context)?;
        // the memory before anything is allocated, then the plugins: unknown models and
        // bad parameters are found now, not mid-study
        case.check_resources(&limits.memory).map_err(|e| context(e.in_file(&base_file)))?;
        if build {
            Simulation::new(&case).map_err(context)?;
        }
        dirs.insert(combination.dir.clone(), runs.len());
        runs.push(Combination { case, ..combination });
    }
    Ok(Plan { study, file: file.to_path_buf(), points, runs, out })
}

/// Whether the run in `dir` finished (completed or unstable) as the case `case_text`.
pub fn finished(dir: &Path, case_text: &str) -> bool {
    let same = std::fs::read_to_string(dir.join(STUDY_CASE)).is_ok_and(|t| t == case_text);
    same && read_summary(dir).is_some_and(|s| matches!(s["status"].as_str(), Some("completed" | "unstable")))
}

/// The case as the study ran it, kept in each run directory to tell a finished run of the
/// same case from a stale one.
pub const STUDY_CASE: &str = "study_case.ron";

fn read_summary(dir: &Path) -> Option<serde_json::Value> {
    std::fs::read_to_string(dir.join("summary.json")).ok().and_then(|t| serde_json::from_str(&t).ok())
}

/// The last checkpoint of an unfinished run of the case `case_text` in `dir` (killed, or
/// interrupted: no `summary.json`, or one that says `interrupted`), to continue it from.
pub fn resume_point(dir: &Path, case_text: &str) -> Option<PathBuf> {
    let same = std::fs::read_to_string(dir.join(STUDY_CASE)).is_ok_and(|t| t == case_text);
    let status = read_summary(dir).and_then(|s| s["status"].as_str().map(str::to_string));
    if !same || status.is_some_and(|s| s != "interrupted") {
        return None;
    }
    crate::checkpoint::list(dir).pop().map(|(_, path)| path)
}

/// Runs one combination (whose case is `case_text`) into its directory with `threads`
/// worker threads: from its last checkpoint when an earlier attempt of the same case was
/// killed or interrupted after writing one ([`resume_point`]), else from t = 0. `task`: the
/// scheduler's record of this attempt ([`crate::slurm::TASK`]), written before the run
/// starts; without it an earlier attempt's record is removed.
pub fn run_one(c: &Combination, case_text: &str, threads: usize, task: Option<&[u8]>) -> Result<run::Outcome, Error> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path: path.clone(), source }
    };
    std::fs::create_dir_all(&c.dir).map_err(io(&c.dir))?;
    let restart = resume_point(&c.dir, case_text);
    // a run directory of an earlier case (or attempt) is cleared of its results first
    let _ = std::fs::remove_file(c.dir.join("summary.json"));
    let _ = std::fs::remove_file(c.dir.join(crate::slurm::ENDED));
    match task {
        Some(record) => crate::output::write_atomically(&c.dir.join(crate::slurm::TASK), record)?,
        None => {
            let _ = std::fs::remove_file(c.dir.join(crate::slurm::TASK));
        }
    }
    crate::output::write_atomically(&c.dir.join(STUDY_CASE), case_text.as_bytes())?;
    let options = RunOptions { threads, quiet: true, restart, case_file: None, ranks: None };
    run::run(&c.case, &c.dir, &options)
}

/// Runs the study: every combination not finished yet, `jobs` at a time; writes the results
/// table after every run and the charts at the end.
pub fn run_study(plan: &Plan, options: &StudyOptions) -> Result<Report, Error> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path: path.clone(), source }
    };
    std::fs::create_dir_all(plan.out.join("runs")).map_err(io(&plan.out))?;
    let texts: Vec<String> = plan.runs.iter().map(|c| c.case.to_ron()).collect();
    let todo: Vec<usize> = (0..plan.runs.len()).filter(|&k| !finished(&plan.runs[k].dir, &texts[k])).collect();
    let skipped = plan.runs.len() - todo.len();
    let threads = options.threads_per_run.max(1);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = if options.jobs == 0 { (cores / threads).max(1) } else { options.jobs }.min(todo.len().max(1));
    let results = plan.out.join("results.csv");
    write_results(plan)?;
    if !options.quiet {
        println!(
            "study {}: {} runs ({} finished before, {} to run, {jobs} at a time, {threads} thread{} each) into {}/",
            plan.study.name,
            plan.runs.len(),
            skipped,
            todo.len(),
            if threads == 1 { "" } else { "s" },
            plan.out.display()
        );
    }
    let bar = if options.quiet || !std::io::IsTerminal::is_terminal(&std::io::stdout()) {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(todo.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:30.cyan/blue} {pos}/{len} runs {msg} ETA {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    };
    let next = AtomicUsize::new(0);
    let table = Mutex::new(());
    let first_error: Mutex<Option<Error>> = Mutex::new(None);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(&r) = todo.get(k) else { break };
                let c = &plan.runs[r];
                let started = run_one(c, &texts[r], threads, None);
                let line = match &started {
                    Ok(o) => format!(
                        "{:<10} {:>8.2} s {:>7} steps  {}{}",
                        o.summary.status,
                        o.summary.wall_seconds,
                        o.summary.steps,
                        c.describe(&plan.study.axes),
                        if o.summary.reason.is_empty() { String::new() } else { format!(": {}", o.summary.reason) }
                    ),
                    Err(e) => format!("failed     {}: {e}", c.describe(&plan.study.axes)),
                };
                {
                    let _guard = table.lock().unwrap_or_else(|e| e.into_inner());
                    if let Err(e) = write_results(plan) {
                        first_error.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e);
                    }
                }
                if crate::run::interrupted() {
                    // an interrupt ends the runs under way after their step; none starts
                    next.store(todo.len(), Ordering::SeqCst);
                }
                if let Err(Error::Io { path, source }) = started {
                    // an output directory that cannot be written stops the study
                    first_error.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(Error::Io { path, source });
                    next.store(todo.len(), Ordering::SeqCst);
                }
                if !options.quiet {
                    bar.suspend(|| println!("{line}"));
                }
                bar.inc(1);
            });
        }
    });
    bar.finish_and_clear();
    if let Some(e) = first_error.into_inner().unwrap_or(None) {
        return Err(e);
    }
    let rows = write_results(plan)?;
    let charts = crate::study_chart::write(plan, &rows)?;
    let statuses = rows.iter().map(|r| r.status.clone()).collect();
    Ok(Report { ran: todo.len(), skipped, statuses, results, charts })
}

/// One row of the results table.
#[derive(Clone, Debug, Default)]
pub struct Row {
    /// `completed`, `unstable`, `failed`, `interrupted` or `pending`; for a run Slurm ended
    /// before it finished, its state in lower case (`cancelled`, `timeout`, `node_fail`,
    /// `preempted`, `out_of_memory`, …).
    pub status: String,
    /// Why the run stopped early.
    pub reason: String,
    /// Wall-clock seconds of the time loop.
    pub wall_seconds: Option<Real>,
    /// Steps taken.
    pub steps: Option<Real>,
    /// Error against the reference.
    pub error: Option<Real>,
    /// Largest constraint residual.
    pub max_divergence: Option<Real>,
    /// Largest max |Σθ − 1|.
    pub max_volume_fraction_error: Option<Real>,
    /// Relative change of the kinetic energy over the run (docs/studies.md).
    pub energy_drift: Option<Real>,
    /// The study's metrics, in the order of [`metric_columns`].
    pub metrics: Vec<Option<Real>>,
    /// The Slurm job (`<array job>_<task>`) that ran it last; empty when it ran here.
    pub job_id: String,
}

/// The columns of the study's metrics.
pub fn metric_columns(metrics: &[Metric]) -> Vec<String> {
    metrics
        .iter()
        .flat_map(|m| match m {
            Metric::Final(c) => vec![format!("final_{c}")],
            Metric::Max(c) => vec![format!("max_{c}")],
            Metric::Mean(c) => vec![format!("mean_{c}")],
            Metric::Summary(s) => vec![s.clone()],
            Metric::Dkt => vec!["kiss_time".into(), "tumble_time".into(), "min_gap_over_d".into()],
            Metric::Body { body, column, .. } => vec![format!("{body}_{column}")],
            Metric::Monitor { monitor, column, of, window } => {
                let name = match of {
                    Reduce::Final => format!("{monitor}_{column}"),
                    Reduce::Mean => format!("mean_{monitor}_{column}"),
                    Reduce::Max => format!("max_{monitor}_{column}"),
                    Reduce::Min => format!("min_{monitor}_{column}"),
                };
                // two windows of one column are two columns
                vec![match window {
                    Some((from, to)) => format!("{name}_in_{from}_{to}"),
                    None => name,
                }]
            }
            Metric::Stopped => vec!["stop_time".into()],
        })
        .collect()
}

/// A CSV file as numbers by column name.
struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<Real>>,
    /// The third field of every row (a body's name in `bodies.csv`).
    names: Vec<String>,
}

impl Csv {
    /// The complete rows of the table at `path` as numbers (NaN where a cell is not one).
    fn read(path: &Path) -> Option<Csv> {
        let table = crate::core::table::Table::read(path).ok()??;
        let names = table.rows.iter().map(|r| r.get(2).unwrap_or_default().to_string()).collect();
        let rows = table.rows.iter().map(|r| r.iter().map(|s| s.parse().unwrap_or(Real::NAN)).collect()).collect();
        Some(Csv { header: table.header, rows, names })
    }
    fn column(&self, name: &str) -> Option<Vec<Real>> {
        let k = self.header.iter().position(|h| h == name)?;
        Some(self.rows.iter().map(|r| r[k]).collect())
    }
}

/// The metrics of the run in `dir` (everything but the error).
fn row_of(dir: &Path, study: &Study) -> Row {
    let row = row_of_summary(dir, study);
    let task = crate::slurm::TaskRecord::read(dir);
    let job_id = task.map(|t| t.job_id).unwrap_or_default();
    // a run the scheduler ended before it finished: its state, not `pending` or `interrupted`
    match crate::slurm::Ended::read(dir) {
        Some(e) if matches!(row.status.as_str(), "pending" | "interrupted") => Row {
            status: e.state.to_lowercase(),
            reason: format!("Slurm ended job {} as {} ({})", e.job_id, e.state, e.how),
            job_id: e.job_id,
            ..row
        },
        _ => Row { job_id, ..row },
    }
}

/// [`row_of`] from the run's own files, without the scheduler's records.
fn row_of_summary(dir: &Path, study: &Study) -> Row {
    let Some(s) = read_summary(dir) else {
        return Row {
            status: "pending".into(),
            metrics: vec![None; metric_columns(&study.metrics).len()],
            ..Row::default()
        };
    };
    let num = |k: &str| s[k].as_f64();
    let diagnostics = Csv::read(&dir.join("diagnostics.csv"));
    let column = |c: &str| diagnostics.as_ref().and_then(|d| d.column(c)).filter(|v| !v.is_empty());
    let e0 = num("initial_kinetic_energy").unwrap_or(Real::NAN);
    let e1 = num("final_kinetic_energy").unwrap_or(Real::NAN);
    let scale = if e0 > 0.0 {
        e0
    } else {
        column("kinetic_energy").map_or(Real::NAN, |v| v.iter().copied().fold(0.0, Real::max))
    };
    let energy_drift = Some((e1 - e0) / scale).filter(|x| x.is_finite());
    let bodies = Csv::read(&dir.join("bodies.csv"));
    let mut metrics = Vec::new();
    for m in &study.metrics {
        match m {
            Metric::Final(c) => metrics.push(column(c).and_then(|v| v.last().copied())),
            Metric::Max(c) => metrics.push(column(c).map(|v| v.iter().copied().fold(Real::NEG_INFINITY, Real::max))),
            Metric::Mean(c) => metrics.push(column(c).map(|v| v.iter().sum::<Real>() / v.len() as Real)),
            Metric::Summary(k) => metrics.push(num(k)),
            Metric::Dkt => match crate::dkt::analyse(dir, None) {
                Ok((r, _, _)) => metrics.extend([r.kiss_time, r.tumble_time, Some(r.min_gap_over_d)]),
                Err(_) => metrics.extend([None, None, None]),
            },
            Metric::Body { body, column, scale } => metrics
                .push(body_last(&bodies, body, column).map(|v| v * scale.unwrap_or(1.0)).filter(|v| v.is_finite())),
            Metric::Monitor { monitor, column, of, window } => {
                metrics.push(monitor_value(dir, monitor, column, *of, *window))
            }
            Metric::Stopped => metrics.push(
                (s["status"].as_str() == Some("completed")
                    && crate::core::monitor::is_stop_reason(s["reason"].as_str().unwrap_or_default()))
                .then(|| num("simulated_time"))
                .flatten(),
            ),
        }
    }
    Row {
        status: s["status"].as_str().unwrap_or("failed").to_string(),
        reason: s["reason"].as_str().unwrap_or_default().to_string(),
        wall_seconds: num("wall_seconds"),
        steps: num("steps"),
        error: None,
        max_divergence: num("max_divergence"),
        max_volume_fraction_error: num("max_volume_fraction_error"),
        energy_drift,
        metrics,
        job_id: String::new(),
    }
}

/// A column of the run's `monitors/<monitor>.csv` reduced over its rows ([`Reduce`]);
/// `None` when the file, the column or a value in it is missing or not finite.
pub fn monitor_value(
    dir: &Path,
    monitor: &str,
    column: &str,
    of: Reduce,
    window: Option<(Real, Real)>,
) -> Option<Real> {
    let csv = Csv::read(&dir.join(crate::core::monitor::FOLDER).join(format!("{monitor}.csv")))?;
    let (mut v, mut t) = (csv.column(column)?, csv.column("time")?);
    if let Some((from, to)) = window {
        let keep: Vec<bool> = t.iter().map(|&t| t >= from && t <= to).collect();
        let pick = |x: Vec<Real>| x.into_iter().zip(&keep).filter(|(_, k)| **k).map(|(x, _)| x).collect::<Vec<_>>();
        (v, t) = (pick(v), pick(t));
    }
    if v.is_empty() || v.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let value = match of {
        Reduce::Final => v[v.len() - 1],
        Reduce::Max => v.iter().copied().fold(Real::NEG_INFINITY, Real::max),
        Reduce::Min => v.iter().copied().fold(Real::INFINITY, Real::min),
        Reduce::Mean => {
            let span = t[t.len() - 1] - t[0];
            if v.len() == 1 || span <= 0.0 {
                v[v.len() - 1]
            } else {
                let area: Real = (1..v.len()).map(|k| 0.5 * (v[k] + v[k - 1]) * (t[k] - t[k - 1])).sum();
                area / span
            }
        }
    };
    Some(value).filter(|x| x.is_finite())
}

/// The last row of `column` in `bodies.csv` (read as `bodies`) for `body`.
fn body_last(bodies: &Option<Csv>, body: &str, column: &str) -> Option<Real> {
    // the body's name is text: find its rows by the raw file's order (Csv parses it as NaN)
    let b = bodies.as_ref()?;
    let k = b.header.iter().position(|h| h == column)?;
    b.names.iter().rposition(|n| n == body).map(|r| b.rows[r][k])
}

/// Error of a run against a closed-form law.
fn analytic_error(dir: &Path, column: &str, law: &Law) -> Option<Real> {
    let Law::Exponential { rate, initial, floor } = law;
    let v0 = match initial {
        Some(v) => *v,
        None => read_summary(dir)?["initial_kinetic_energy"].as_f64()?,
    };
    let d = Csv::read(&dir.join("diagnostics.csv"))?;
    let (t, v) = (d.column("time")?, d.column(column)?);
    let scale = v0.abs();
    if t.is_empty() || scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let sum: Real =
        t.iter().zip(&v).map(|(t, v)| ((v - (floor + (v0 - floor) * (-rate * t).exp())) / scale).powi(2)).sum();
    Some((sum / t.len() as Real).sqrt()).filter(|e| e.is_finite())
}

/// `interpolate` at `t`, with `t` a round-off (1e-9 relative) beyond either end taken at it:
/// runs of different steps end at `time.end` up to the round-off of their sums of Δt.
fn at(ts: &[Real], vs: &[Real], t: Real) -> Option<Real> {
    let (first, last) = (*ts.first()?, *ts.last()?);
    let slack = 1e-9 * t.abs().max(1e-300);
    let t = if t > last && t - last <= slack {
        last
    } else if t < first && first - t <= slack {
        first
    } else {
        t
    };
    crate::dkt::interpolate(ts, vs, t)
}

/// Error of the run in `dir` against the run in `reference`.
pub fn compare_runs(dir: &Path, reference: &Path, compare: &Compare) -> Option<Real> {
    match compare {
        Compare::Bodies => {
            let a = crate::dkt::read_bodies(&dir.join("bodies.csv")).ok()?;
            let b = crate::dkt::read_bodies(&reference.join("bodies.csv")).ok()?;
            let (mut sum, mut n) = (0.0, 0usize);
            for (name, rb) in &b {
                let ra = a.get(name)?;
                for k in 0..rb.t.len() {
                    let t = rb.t[k];
                    if let (Some(x), Some(y)) = (at(&ra.t, &ra.x, t), at(&ra.t, &ra.y, t)) {
                        sum += (x - rb.x[k]).powi(2) + (y - rb.y[k]).powi(2);
                        n += 1;
                    }
                }
            }
            (n > 0).then(|| (sum / n as Real).sqrt())
        }
        // the metrics are the rows' ([`rows`] compares them)
        Compare::Metric(_) => None,
        Compare::Column(c) => {
            let a = Csv::read(&dir.join("diagnostics.csv"))?;
            let b = Csv::read(&reference.join("diagnostics.csv"))?;
            let (ta, va, tb, vb) = (a.column("time")?, a.column(c)?, b.column("time")?, b.column(c)?);
            let scale = vb.iter().fold(0.0, |m: Real, v| m.max(v.abs()));
            let (mut sum, mut n) = (0.0, 0usize);
            for (t, r) in tb.iter().zip(&vb) {
                if let Some(v) = at(&ta, &va, *t) {
                    sum += (v - r).powi(2);
                    n += 1;
                }
            }
            (n > 0 && scale > 0.0).then(|| (sum / n as Real).sqrt() / scale)
        }
    }
}

/// The index of each run's reference run (Finest, Baseline, Run), `None` for other references.
pub fn reference_runs(plan: &Plan) -> Vec<Option<usize>> {
    if let Reference::Run { labels, .. } = &plan.study.reference {
        return named_reference_runs(plan, labels);
    }
    let axis = match &plan.study.reference {
        Reference::Finest { axis, .. } | Reference::Baseline { axis, .. } => axis,
        _ => return vec![None; plan.runs.len()],
    };
    let cells = |k: usize| plan.runs[k].case.cells()[0] * plan.runs[k].case.cells()[1];
    let a = plan.study.axes.iter().position(|x| &x.name == axis).unwrap_or(0);
    let mut groups: BTreeMap<Vec<usize>, Vec<usize>> = BTreeMap::new();
    for (k, c) in plan.runs.iter().enumerate() {
        let mut key = c.index.clone();
        key[a] = usize::MAX;
        groups.entry(key).or_default().push(k);
    }
    let mut out = vec![None; plan.runs.len()];
    for group in groups.values() {
        let r = match &plan.study.reference {
            Reference::Baseline { value, .. } => group.iter().copied().find(|&k| &plan.runs[k].labels[a] == value),
            _ => group.iter().copied().max_by_key(|&k| cells(k)),
        };
        for &k in group {
            out[k] = r;
        }
    }
    out
}

/// [`reference_runs`] for [`Reference::Run`]: the run with equal labels on every other axis
/// and the given labels on the named ones (`None` when `--only` left it out of the plan).
fn named_reference_runs(plan: &Plan, labels: &BTreeMap<String, String>) -> Vec<Option<usize>> {
    let named: Vec<(usize, &String)> = labels
        .iter()
        .filter_map(|(axis, label)| plan.study.axes.iter().position(|x| &x.name == axis).map(|a| (a, label)))
        .collect();
    let key = |k: usize| {
        let mut key = plan.runs[k].index.clone();
        for (a, _) in &named {
            key[*a] = usize::MAX;
        }
        key
    };
    let mut references: BTreeMap<Vec<usize>, usize> = BTreeMap::new();
    for k in 0..plan.runs.len() {
        if named.iter().all(|(a, label)| &plan.runs[k].labels[*a] == *label) {
            references.insert(key(k), k);
        }
    }
    (0..plan.runs.len()).map(|k| references.get(&key(k)).copied()).collect()
}

/// The relative difference |m − m_ref| / |m_ref| of metric column `column` between rows.
fn metric_error(study: &Study, row: &Row, reference: &Row, column: &str) -> Option<Real> {
    let i = metric_columns(&study.metrics).iter().position(|m| m == column)?;
    relative_error(row.metrics[i]?, reference.metrics[i]?)
}

/// |m − v| / |v|, `None` where that is not a finite number (v = 0, or a metric that is not).
fn relative_error(m: Real, v: Real) -> Option<Real> {
    Some(((m - v) / v).abs()).filter(|e| e.is_finite())
}

/// The rows of every combination as they stand.
pub fn rows(plan: &Plan) -> Vec<Row> {
    let refs = reference_runs(plan);
    let mut rows: Vec<Row> = plan.runs.iter().map(|c| row_of(&c.dir, &plan.study)).collect();
    let usable = |s: &str| s == "completed";
    let uhlmann = |dir: &Path, curves: ReferenceCurves| {
        crate::dkt::analyse(dir, Some(&curves)).ok().and_then(|(r, _, _)| r.rms_position_error_over_d)
    };
    for (k, c) in plan.runs.iter().enumerate() {
        if !usable(&rows[k].status) {
            continue;
        }
        rows[k].error = match &plan.study.reference {
            Reference::None => None,
            Reference::Analytic { column, law } => analytic_error(&c.dir, column, law),
            Reference::Uhlmann2005 => uhlmann(&c.dir, ReferenceCurves::Shipped),
            Reference::Uhlmann(d) => uhlmann(&c.dir, ReferenceCurves::Folder(plan.study.relative(&plan.file, d))),
            Reference::Finest { compare, .. }
            | Reference::Baseline { compare, .. }
            | Reference::Run { compare, .. } => {
                refs[k].filter(|&r| usable(&rows[r].status)).and_then(|r| match compare {
                    Compare::Metric(m) => metric_error(&plan.study, &rows[k], &rows[r], m),
                    _ => compare_runs(&c.dir, &plan.runs[r].dir, compare),
                })
            }
            Reference::Table { column, axis, values } => {
                let a = plan.study.axes.iter().position(|x| &x.name == axis);
                let value = a.and_then(|a| values.iter().find(|(l, _)| l == &c.labels[a])).map(|(_, v)| *v);
                let i = metric_columns(&plan.study.metrics).iter().position(|m| m == column);
                match (value, i.and_then(|i| rows[k].metrics[i])) {
                    (Some(v), Some(m)) => relative_error(m, v),
                    _ => None,
                }
            }
            Reference::Exact { column, value } => metric_columns(&plan.study.metrics)
                .iter()
                .position(|m| m == column)
                .and_then(|i| rows[k].metrics[i])
                .and_then(|m| relative_error(m, *value)),
        };
    }
    rows
}

/// The header of `results.csv` for this study.
pub fn header(study: &Study) -> Vec<String> {
    let mut h: Vec<String> = study.axes.iter().map(|a| a.name.clone()).collect();
    for c in [
        "status",
        "reason",
        "wall_seconds",
        "steps",
        "error",
        "max_divergence",
        "max_volume_fraction_error",
        "energy_drift",
    ] {
        h.push(c.into());
    }
    h.extend(metric_columns(&study.metrics));
    h.push("directory".into());
    h
}

/// Writes `results.csv` (atomically) and returns its rows: one per combination, built from
/// the runs' own files (so concurrent runs never write the same file). A study run through
/// Slurm has a last column `job_id`.
pub fn write_results(plan: &Plan) -> Result<Vec<Row>, Error> {
    let rows = rows(plan);
    let jobs = rows.iter().any(|r| !r.job_id.is_empty());
    let x = |v: Option<Real>| v.map(run::number).unwrap_or_default();
    let mut table = Vec::new();
    for (c, r) in plan.runs.iter().zip(&rows) {
        let mut f: Vec<String> = c.labels.clone();
        f.push(r.status.clone());
        // one line per run: a reason's line breaks become spaces
        f.push(r.reason.replace(['\n', '\r'], " "));
        for v in [r.wall_seconds, r.steps, r.error, r.max_divergence, r.max_volume_fraction_error, r.energy_drift] {
            f.push(x(v));
        }
        f.extend(r.metrics.iter().map(|v| x(*v)));
        let dir = c.dir.strip_prefix(&plan.out).unwrap_or(&c.dir);
        f.push(dir.display().to_string());
        if jobs {
            f.push(r.job_id.clone());
        }
        table.push(f);
    }
    let mut header = header(&plan.study);
    if jobs {
        header.push("job_id".into());
    }
    let text = crate::core::table::to_text(&header, table)?;
    crate::output::write_atomically(&plan.out.join("results.csv"), &text)?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_short_and_ranges_hit_their_ends() {
        assert_eq!(short(0.1 + 0.2), "0.3");
        assert_eq!(short(1e-7), "1e-7");
        let s = Study::from_ron(
            r#"(name: "s", base: "x.ron", axes: [(name: "dt", values: Range(path: "time.fixed_dt", from: 0.1, to: 10.0, steps: 3, log: true))])"#,
            Path::new("s.ron"),
        )
        .unwrap();
        let p = s.points(Path::new("s.ron")).unwrap();
        let labels: Vec<&str> = p[0].iter().map(|p| p.label.as_str()).collect();
        assert_eq!(labels, ["0.1", "1", "10"]);
        assert_eq!(p[0][2].set, ["time.fixed_dt=10"]);
    }

    #[test]
    fn csv_fields_with_commas_are_quoted() {
        let text = crate::core::table::to_text(&["a"], [vec!["a, b \"c\"".to_string()], vec!["plain".into()]]).unwrap();
        assert_eq!(String::from_utf8(text).unwrap(), "a\n\"a, b \"\"c\"\"\"\nplain\n");
    }
}
