//! Resolved against point bodies on one scene (`multifield compare CASE`): runs the case
//! with every body list `Resolved` and again as `MassPoint` (optionally with overrides for
//! the point run alone, e.g. a coarser grid), then reports per body the settling speed at
//! the end and its largest value (the terminal velocity, when it is reached before landing), for two-disk scenes the kiss and tumble times (and the
//! RMS distance to Uhlmann 2005 on its scene), the differences point − resolved, and the
//! wall time and steps of each; overlays the trajectories (PNG and SVG).
//!
//! Output in the comparison directory: `resolved/` and `point/` (two ordinary runs),
//! `comparison.json`, `comparison.csv` (one row per run and body), `compare_position` and
//! `compare_velocity` charts, and for two disks `dkt_position`/`dkt_lateral`.
//!
//! A case with `Suspension` monitors (docs/monitors.md) is also compared on their
//! statistics ([`suspension_differences`]): the mean settling velocity, the bed height and
//! the granular temperature over time, and the last profile of the solid fraction, each as
//! the L2 (root mean square) and L∞ norms of point − resolved, in `comparison.json`
//! (`suspension`) and `suspension_comparison.csv` (one row per monitor and statistic), and
//! drawn in `compare_suspension_<monitor>` (settling velocity and bed height over time, the
//! last profiles).

use crate::core::case::{Case, Region, Representation};
use crate::core::error::Error;
use crate::core::math::Real;
use crate::core::monitor::Monitored;
use crate::dkt::{self, Track};
use crate::plot::{write_chart, write_figure, Chart, Figure, Series};
use crate::run::{self, RunOptions};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One body of one run.
#[derive(Clone, Debug, Serialize)]
pub struct BodyFigures {
    /// Body name.
    pub body: String,
    /// Settling speed along gravity at the end of the run.
    pub final_settling_speed: Real,
    /// Largest settling speed along gravity.
    pub max_settling_speed: Real,
    /// Position along gravity at the end (from the upstream wall).
    pub final_position: Real,
}

/// One run of the comparison.
#[derive(Clone, Debug, Serialize)]
pub struct RunFigures {
    /// `resolved` or `point`.
    pub representation: String,
    /// How it ended.
    pub status: String,
    /// Cells per body diameter.
    pub cells_per_diameter: Real,
    /// Steps taken.
    pub steps: u64,
    /// Wall time of the time loop (s).
    pub wall_seconds: f64,
    /// Per body.
    pub bodies: Vec<BodyFigures>,
    /// Kiss time (two disks).
    pub kiss_time: Option<Real>,
    /// Tumble time (two disks).
    pub tumble_time: Option<Real>,
    /// RMS distance to Uhlmann 2005 in d (its scene only).
    pub rms_to_uhlmann_over_d: Option<Real>,
    /// The run's validity warnings.
    pub warnings: Vec<String>,
}

/// What `comparison.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// The case.
    pub case: String,
    /// The two runs.
    pub resolved: RunFigures,
    /// The point run.
    pub point: RunFigures,
    /// Point − resolved kiss time.
    pub kiss_time_difference: Option<Real>,
    /// Point − resolved tumble time.
    pub tumble_time_difference: Option<Real>,
    /// Per body, (point − resolved)/resolved largest settling speed (the terminal velocity
    /// of a body that reaches it before it lands).
    pub terminal_speed_relative_difference: BTreeMap<String, Real>,
    /// Wall time ratio resolved/point.
    pub speedup: f64,
    /// The differences point − resolved of the statistics of each `Suspension` monitor of
    /// the case (empty without one).
    pub suspension: Vec<StatisticDifference>,
}

/// The statistics of a `Suspension` monitor compared: over time, and the profile.
pub const COMPARED_OVER_TIME: [&str; 3] = ["settling_velocity", "bed_height", "temperature"];

/// One statistic of one `Suspension` monitor, point − resolved (module doc of
/// [`suspension_differences`]).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct StatisticDifference {
    /// The monitor's name.
    pub monitor: String,
    /// A column of its file (`settling_velocity`, `bed_height`, `temperature`), or
    /// `solid_fraction_profile`.
    pub quantity: String,
    /// The samples (times, or slabs of the profile) compared.
    pub samples: usize,
    /// Root mean square of the difference over the samples.
    pub l2: Real,
    /// Largest absolute difference.
    pub linf: Real,
    /// Mean of the resolved run's values over the samples.
    pub resolved_mean: Real,
    /// Mean of the point run's values over the samples.
    pub point_mean: Real,
}

/// `y(t)` of the piecewise linear curve through `(ts, ys)` (increasing `ts`), `None`
/// outside `[ts[0], ts[last]]`.
fn interpolate(ts: &[Real], ys: &[Real], t: Real) -> Option<Real> {
    let n = ts.len();
    if n == 0 || t < ts[0] || t > ts[n - 1] {
        return None;
    }
    let k = ts.partition_point(|&s| s < t);
    if ts[k] == t {
        return Some(ys[k]);
    }
    let (t0, t1) = (ts[k - 1], ts[k]);
    let w = (t - t0) / (t1 - t0);
    Some(ys[k - 1] + w * (ys[k] - ys[k - 1]))
}

/// The L2 (root mean square) and L∞ norms of the differences `b − a` and the means of `a`
/// and `b`.
fn norms(monitor: &str, quantity: &str, a: &[Real], b: &[Real]) -> StatisticDifference {
    let n = a.len().max(1) as Real;
    let d: Vec<Real> = a.iter().zip(b).map(|(a, b)| b - a).collect();
    StatisticDifference {
        monitor: monitor.into(),
        quantity: quantity.into(),
        samples: a.len(),
        l2: (d.iter().map(|d| d * d).sum::<Real>() / n).sqrt(),
        linf: d.iter().fold(0.0, |m: Real, d| m.max(d.abs())),
        resolved_mean: a.iter().sum::<Real>() / n,
        point_mean: b.iter().sum::<Real>() / n,
    }
}

/// A `Suspension` monitor's file and profiles of the run in `dir`.
fn suspension_tables(
    dir: &Path,
    monitor: &str,
) -> Result<(crate::core::table::Table, crate::core::table::Table), Error> {
    let folder = dir.join(crate::core::monitor::FOLDER);
    let read = |name: String| -> Result<crate::core::table::Table, Error> {
        let path = folder.join(name);
        crate::core::table::Table::read(&path)?
            .ok_or_else(|| Error::Model(format!("{}: no rows: the run wrote no statistics to compare", path.display())))
    };
    Ok((read(format!("{monitor}.csv"))?, read(format!("{monitor}_profiles.csv"))?))
}

/// The last sample's profile (`column` per slab) of a profiles table.
fn last_profile(p: &crate::core::table::Table, column: &str) -> (Vec<Real>, Vec<Real>) {
    let step = p.numbers("step").unwrap_or_default();
    let last = step.last().copied().unwrap_or(Real::NAN);
    let pick =
        |v: Vec<Real>| -> Vec<Real> { step.iter().zip(v).filter(|(s, _)| **s == last).map(|(_, x)| x).collect() };
    (pick(p.numbers("centre").unwrap_or_default()), pick(p.numbers(column).unwrap_or_default()))
}

/// The statistics of the `Suspension` monitor `monitor` of the runs in `resolved` and
/// `point`, compared: for each column of [`COMPARED_OVER_TIME`], the point run's values
/// interpolated linearly in time at the resolved run's sample times (those inside the
/// point run's span), the differences point − resolved there; for
/// `solid_fraction_profile`, the two runs' last profiles of the solid fraction, slab by
/// slab. L2 is the root mean square of the differences, L∞ the largest.
pub fn suspension_differences(resolved: &Path, point: &Path, monitor: &str) -> Result<Vec<StatisticDifference>, Error> {
    let (rt, rp) = suspension_tables(resolved, monitor)?;
    let (pt, pp) = suspension_tables(point, monitor)?;
    let col = |t: &crate::core::table::Table, c: &str| t.numbers(c).unwrap_or_default();
    let (tr, tp) = (col(&rt, "time"), col(&pt, "time"));
    let mut out = Vec::new();
    for q in COMPARED_OVER_TIME {
        let (yr, yp) = (col(&rt, q), col(&pt, q));
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for (t, y) in tr.iter().zip(&yr) {
            if let Some(z) = interpolate(&tp, &yp, *t) {
                a.push(*y);
                b.push(z);
            }
        }
        out.push(norms(monitor, q, &a, &b));
    }
    let ((cr, a), (cp, b)) = (last_profile(&rp, "solid_fraction"), last_profile(&pp, "solid_fraction"));
    if cr != cp {
        return Err(Error::Model(format!(
            "monitor `{monitor}`: the two runs' profiles have different slabs ({} and {}): nothing to compare",
            cr.len(),
            cp.len()
        )));
    }
    out.push(norms(monitor, "solid_fraction_profile", &a, &b));
    Ok(out)
}

/// The overlay of a `Suspension` monitor's statistics of both runs: settling velocity and
/// bed height over time, the last profiles of the solid fraction.
fn plot_suspension(out: &Path, case: &str, monitor: &str, dirs: &[PathBuf]) -> Result<(), Error> {
    let mut settling = Vec::new();
    let mut bed = Vec::new();
    let mut profile = Vec::new();
    for (k, (dir, label)) in dirs.iter().zip(["resolved", "mass points"]).enumerate() {
        let (t, p) = suspension_tables(dir, monitor)?;
        let time = t.numbers("time").unwrap_or_default();
        let series = |c: &str| Series {
            label: label.into(),
            points: time.iter().copied().zip(t.numbers(c).unwrap_or_default()).collect(),
            color: k,
            markers: false,
        };
        settling.push(series("settling_velocity"));
        bed.push(series("bed_height"));
        let (c, phi) = last_profile(&p, "solid_fraction");
        profile.push(Series { label: label.into(), points: c.into_iter().zip(phi).collect(), color: k, markers: true });
    }
    let chart = |title: &str, x: &str, y: &str, series| Chart {
        title: format!("{case}: {monitor}, {title}"),
        x_label: x.into(),
        y_label: y.into(),
        series,
        log: (false, false),
    };
    let charts = [
        chart("mean settling velocity", "time", "settling velocity", settling),
        chart("bed height", "time", "bed height", bed),
        chart("solid fraction at the end", "position along the axis", "solid fraction", profile),
    ];
    write_figure(
        &out.join(format!("compare_suspension_{monitor}")),
        &Figure {
            title: format!("{case}: resolved against mass points, monitor {monitor}"),
            size: (1000, 300 + 250 * charts.len() as u32),
            columns: vec![(1.0, charts.iter().collect())],
        },
    )
}

/// The case with every body list represented as `rep`.
pub fn with_representation(case: &Case, rep: Representation) -> Result<Case, Error> {
    let mut c = case.clone();
    let mut any = false;
    for f in &mut c.fields {
        if matches!(f.region, Region::Bodies(_)) {
            f.representation = rep;
            any = true;
        }
    }
    if !any {
        return Err(Error::invalid("fields", "no field has a body list (`region: Bodies([...])`): nothing to compare"));
    }
    Ok(c)
}

fn figures(
    dir: &Path,
    label: &str,
    reference: Option<&dkt::ReferenceCurves>,
) -> Result<(RunFigures, BTreeMap<String, Track>), Error> {
    let text = std::fs::read_to_string(dir.join("case.ron"))
        .map_err(|source| Error::Io { path: dir.join("case.ron"), source })?;
    let case = Case::from_ron(&text, &dir.join("case.ron"))?;
    let summary: serde_json::Value = std::fs::read_to_string(dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    let tracks = dkt::read_bodies(&dir.join("bodies.csv"))?;
    let fr = dkt::Frame::new(&case);
    let mut diameter: Real = 0.0;
    for f in &case.fields {
        if let Region::Bodies(b) = &f.region {
            for body in b {
                let (lo, hi) = body.shape.bounds();
                diameter = diameter.max(hi[0] - lo[0]);
            }
        }
    }
    let h = case.domain.size[0] / case.cells()[0] as Real;
    let bodies = tracks
        .iter()
        .map(|(name, tr)| {
            let v = if fr.axis == 1 { &tr.vy } else { &tr.vx };
            let n = tr.t.len();
            BodyFigures {
                body: name.clone(),
                final_settling_speed: v.last().map_or(0.0, |v| fr.sign * v),
                max_settling_speed: v.iter().map(|v| fr.sign * v).fold(0.0, Real::max),
                final_position: if n > 0 { fr.along(tr.x[n - 1], tr.y[n - 1]) } else { 0.0 },
            }
        })
        .collect();
    let (kiss, tumble, rms) = if tracks.len() == 2 {
        let (r, _, _) = dkt::analyse(dir, reference)?;
        (r.kiss_time, r.tumble_time, r.rms_position_error_over_d)
    } else {
        (None, None, None)
    };
    Ok((
        RunFigures {
            representation: label.into(),
            status: summary["status"].as_str().unwrap_or("unknown").into(),
            cells_per_diameter: diameter / h,
            steps: summary["steps"].as_u64().unwrap_or(0),
            wall_seconds: summary["wall_seconds"].as_f64().unwrap_or(0.0),
            bodies,
            kiss_time: kiss,
            tumble_time: tumble,
            rms_to_uhlmann_over_d: rms,
            warnings: summary["warnings"]
                .as_array()
                .map(|w| w.iter().filter_map(|s| s.as_str().map(String::from)).collect())
                .unwrap_or_default(),
        },
        tracks,
    ))
}

/// Runs `case` resolved and as points (with `point_overrides` on the point run) into
/// `out/resolved` and `out/point`, writes the comparison files and charts, and returns it.
pub fn compare(
    case: &Case,
    point_overrides: &[String],
    out: &Path,
    options: &RunOptions,
    reference: Option<&dkt::ReferenceCurves>,
) -> Result<Comparison, Error> {
    let resolved = with_representation(case, Representation::Resolved)?;
    let point = with_representation(case, Representation::MassPoint)?.with_overrides(point_overrides)?;
    let mut dirs = Vec::new();
    for (label, c) in [("resolved", &resolved), ("point", &point)] {
        let dir = out.join(label);
        let outcome = run::run(c, &dir, options)?;
        if !options.quiet {
            let s = &outcome.summary;
            println!(
                "{label}: {} after {} steps to t = {} in {:.2} s",
                s.status, s.steps, s.simulated_time, s.wall_seconds
            );
        }
        dirs.push(dir);
    }
    let (r, r_tracks) = figures(&dirs[0], "resolved", reference)?;
    let (p, p_tracks) = figures(&dirs[1], "point", reference)?;
    let diff = |a: Option<Real>, b: Option<Real>| a.zip(b).map(|(a, b)| b - a);
    let mut rel = BTreeMap::new();
    for (br, bp) in r.bodies.iter().zip(&p.bodies) {
        if br.max_settling_speed != 0.0 {
            rel.insert(br.body.clone(), (bp.max_settling_speed - br.max_settling_speed) / br.max_settling_speed);
        }
    }
    let mut suspension = Vec::new();
    for m in &case.monitors {
        if matches!(m.of, Monitored::Suspension { .. }) {
            suspension.extend(suspension_differences(&dirs[0], &dirs[1], &m.name)?);
            plot_suspension(out, &case.name, &m.name, &dirs)?;
        }
    }
    if !suspension.is_empty() {
        let header = ["monitor", "quantity", "samples", "l2", "linf", "resolved_mean", "point_mean"];
        let rows: Vec<Vec<String>> = suspension
            .iter()
            .map(|d| {
                vec![
                    d.monitor.clone(),
                    d.quantity.clone(),
                    d.samples.to_string(),
                    d.l2.to_string(),
                    d.linf.to_string(),
                    d.resolved_mean.to_string(),
                    d.point_mean.to_string(),
                ]
            })
            .collect();
        let path = out.join("suspension_comparison.csv");
        std::fs::write(&path, crate::core::table::to_text(&header, rows)?)
            .map_err(|source| Error::Io { path, source })?;
    }
    let cmp = Comparison {
        suspension,
        case: case.name.clone(),
        kiss_time_difference: diff(r.kiss_time, p.kiss_time),
        tumble_time_difference: diff(r.tumble_time, p.tumble_time),
        terminal_speed_relative_difference: rel,
        speedup: if p.wall_seconds > 0.0 { r.wall_seconds / p.wall_seconds } else { 0.0 },
        resolved: r,
        point: p,
    };
    let io = |path: PathBuf, e: std::io::Error| Error::Io { path, source: e };
    let json = serde_json::to_string_pretty(&cmp).map_err(|e| Error::Model(e.to_string()))?;
    std::fs::write(out.join("comparison.json"), json + "\n").map_err(|e| io(out.join("comparison.json"), e))?;
    let header = "representation,status,cells_per_diameter,steps,wall_seconds,body,final_settling_speed,\
                  max_settling_speed,kiss_time,tumble_time";
    let mut rows = Vec::new();
    for run in [&cmp.resolved, &cmp.point] {
        for b in &run.bodies {
            let opt = |t: Option<Real>| t.map_or(String::new(), |t| t.to_string());
            rows.push(vec![
                run.representation.to_string(),
                run.status.to_string(),
                run.cells_per_diameter.to_string(),
                run.steps.to_string(),
                run.wall_seconds.to_string(),
                b.body.clone(),
                b.final_settling_speed.to_string(),
                b.max_settling_speed.to_string(),
                opt(run.kiss_time),
                opt(run.tumble_time),
            ]);
        }
    }
    let csv = crate::core::table::to_text(&header.split(',').collect::<Vec<_>>(), rows)?;
    std::fs::write(out.join("comparison.csv"), csv).map_err(|e| io(out.join("comparison.csv"), e))?;
    // overlays: every body of both runs, along gravity and its speed
    let fr = dkt::Frame::new(case);
    let mut pos = Vec::new();
    let mut vel = Vec::new();
    for (k, (label, tracks)) in [("resolved", &r_tracks), ("point", &p_tracks)].into_iter().enumerate() {
        for (b, (name, tr)) in tracks.iter().enumerate() {
            let v = if fr.axis == 1 { &tr.vy } else { &tr.vx };
            let color = 2 * b + k;
            pos.push(Series {
                label: format!("{name}, {label}"),
                points: (0..tr.t.len()).map(|i| (tr.t[i], fr.along(tr.x[i], tr.y[i]))).collect(),
                color,
                markers: false,
            });
            vel.push(Series {
                label: format!("{name}, {label}"),
                points: tr.t.iter().zip(v).map(|(t, v)| (*t, fr.sign * v)).collect(),
                color,
                markers: false,
            });
        }
    }
    for (stem, title, y, series) in [
        ("compare_position", "position along gravity (from the upstream wall)", "position", pos),
        ("compare_velocity", "settling speed", "speed along gravity", vel),
    ] {
        write_chart(
            &out.join(stem),
            &Chart {
                title: format!("{}: resolved against mass points, {title}", case.name),
                x_label: "time".into(),
                y_label: y.into(),
                series,
                log: (false, false),
            },
        )?;
    }
    if r_tracks.len() == 2 && p_tracks.len() == 2 {
        let (rr, rt, rc) = dkt::analyse(&dirs[0], reference)?;
        let (pr, pt, pc) = dkt::analyse(&dirs[1], reference)?;
        dkt::plot_runs(
            out,
            &[
                dkt::Run { label: "resolved".into(), report: &rr, tracks: &rt, case: &rc },
                dkt::Run { label: "mass points".into(), report: &pr, tracks: &pt, case: &pc },
            ],
            reference,
        )?;
    }
    Ok(cmp)
}
