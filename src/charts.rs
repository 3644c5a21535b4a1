//! Charts of a finished run, drawn from its CSV files into `charts/` (PNG and SVG, with
//! [`crate::plot`]) when `output.charts` is on (the default):
//!
//! - `diagnostics.{png,svg}` from `diagnostics.csv`: kinetic energy, Δt (log), the largest
//!   divergence (log; steps with none left out) and the pressure iterations, over time;
//! - `bodies.{png,svg}` from `bodies.csv` (cases with bodies): the trajectories in the
//!   x–y plane inside the domain's box (from `case.ron`), and vx, vy over time;
//! - `monitor_<name>.{png,svg}` from each `monitors/<name>.csv` (the monitors of
//!   `case.ron`): a `Line`'s last profile against the distance along the line; a `Forces`
//!   monitor's forces (and coefficients) over time; a `Suspension`'s figures over time (the
//!   solid fraction, the mean and settling velocity, the granular temperature, the bed
//!   height, the contacts) and its last profiles of the solid fraction and of the solid's
//!   mean velocity (`monitors/<name>_profiles.csv`); the other
//!   kinds' columns over time (the first eight).
//!
//! A missing or empty CSV file gives no chart and no error; a chart that cannot be drawn
//! is an error that names the file. Long runs are thinned to the smallest and largest
//! value of each of 2000 time buckets, so spikes stay visible.

use crate::core::case::Case;
use crate::core::error::Error;
use crate::core::math::Real;
use crate::core::monitor::{MonitorSpec, Monitored};
use crate::plot::{write_figure, Chart, Figure, Series};
use std::path::Path;

/// Curves longer than this are thinned (module doc).
const MAX_POINTS: usize = 4000;

/// Colour index of the domain's box.
const BOX_COLOR: usize = 5;

/// A CSV file ([`crate::core::table::Table`]), for charts: its complete rows.
struct Table(crate::core::table::Table);

impl Table {
    /// The file at `path`: `None` when it does not exist or has no data row. A table the
    /// run wrote that does not read back is [`Error::Io`] of the file, like one that
    /// cannot be read.
    fn read(path: &Path) -> Result<Option<Table>, Error> {
        let table = crate::core::table::Table::read(path).map_err(|e| match e {
            e @ Error::Io { .. } => e,
            e => Error::Io { path: path.to_path_buf(), source: std::io::Error::other(e.to_string()) },
        })?;
        Ok(table.filter(|t| !t.rows.is_empty()).map(Table))
    }

    /// Column `name` as numbers (NaN where a cell is not one; all NaN when missing).
    fn numbers(&self, name: &str) -> Vec<Real> {
        self.0.numbers(name).unwrap_or_else(|| vec![Real::NAN; self.0.rows.len()])
    }

    /// Column `name` as text.
    fn text(&self, name: &str) -> Vec<String> {
        match self.0.index(name) {
            Some(k) => self.0.rows.iter().map(|r| r[k].to_string()).collect(),
            None => vec![String::new(); self.0.rows.len()],
        }
    }
}

/// At most about [`MAX_POINTS`] points: the lowest and highest of each of
/// `MAX_POINTS / 2` buckets of consecutive points, in order.
fn thin(points: Vec<(Real, Real)>) -> Vec<(Real, Real)> {
    if points.len() <= MAX_POINTS {
        return points;
    }
    let per = points.len().div_ceil(MAX_POINTS / 2);
    let mut out = Vec::with_capacity(MAX_POINTS + 2);
    for chunk in points.chunks(per) {
        let finite = |p: &&(Real, Real)| p.1.is_finite();
        let lo = chunk.iter().enumerate().filter(|(_, p)| finite(p)).min_by(|a, b| a.1 .1.total_cmp(&b.1 .1));
        let hi = chunk.iter().enumerate().filter(|(_, p)| finite(p)).max_by(|a, b| a.1 .1.total_cmp(&b.1 .1));
        match (lo, hi) {
            (Some((a, pa)), Some((b, pb))) if a != b => {
                if a < b {
                    out.extend([*pa, *pb]);
                } else {
                    out.extend([*pb, *pa]);
                }
            }
            (Some((_, p)), _) => out.push(*p),
            _ => {}
        }
    }
    out
}

fn curve(label: &str, color: usize, x: &[Real], y: &[Real]) -> Series {
    Series {
        label: label.into(),
        points: thin(x.iter().copied().zip(y.iter().copied()).collect()),
        color,
        markers: false,
    }
}

fn chart(title: &str, y_label: &str, log_y: bool, series: Vec<Series>) -> Chart {
    Chart { title: title.into(), x_label: "time".into(), y_label: y_label.into(), series, log: (false, log_y) }
}

/// The case of the run (`case.ron`), if it can be read.
fn case_of(dir: &Path) -> Option<Case> {
    let path = dir.join("case.ron");
    let text = std::fs::read_to_string(&path).ok()?;
    Case::from_ron(&text, &path).ok()
}

/// Draws the charts of the run in `dir` into `dir/charts/` (module doc). Every error is
/// [`Error::Io`] of the file that could not be read or written (an output failure).
pub fn write(dir: &Path) -> Result<(), Error> {
    let diagnostics = Table::read(&dir.join("diagnostics.csv"))?;
    let bodies = Table::read(&dir.join("bodies.csv"))?;
    if diagnostics.is_none() && bodies.is_none() {
        return Ok(());
    }
    let out = dir.join("charts");
    std::fs::create_dir_all(&out).map_err(|source| Error::Io { path: out.clone(), source })?;
    let case = case_of(dir);
    let name = case
        .as_ref()
        .map(|c| c.name.clone())
        .unwrap_or_else(|| dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "run".into()));
    if let Some(t) = diagnostics {
        write_diagnostics(&out.join("diagnostics"), &name, &t)?;
    }
    if let Some(b) = bodies {
        write_bodies(
            &out.join("bodies"),
            &name,
            case.as_ref().map(|c| {
                let d = &c.domain;
                ([d.origin[0], d.origin[1]], [d.size[0], d.size[1]])
            }),
            &b,
        )?;
    }
    for m in case.as_ref().map(|c| c.monitors.as_slice()).unwrap_or_default() {
        let file = dir.join(crate::core::monitor::FOLDER).join(format!("{}.csv", m.name));
        if let Some(t) = Table::read(&file)? {
            let profiles = match m.of {
                Monitored::Suspension { .. } => {
                    Table::read(&dir.join(crate::core::monitor::FOLDER).join(format!("{}_profiles.csv", m.name)))?
                }
                _ => None,
            };
            write_monitor(&out.join(format!("monitor_{}", m.name)), &name, m, &t, profiles.as_ref())?;
        }
    }
    Ok(())
}

fn write_monitor(stem: &Path, name: &str, m: &MonitorSpec, t: &Table, profiles: Option<&Table>) -> Result<(), Error> {
    let time = t.numbers("time");
    let columns: Vec<String> = t.0.header.iter().skip(2).cloned().collect();
    let over_time = |title: &str, cols: &[&str]| -> Chart {
        let series = cols.iter().enumerate().map(|(k, c)| curve(c, k, &time, &t.numbers(c))).collect();
        chart(title, "value", false, series)
    };
    let charts: Vec<Chart> = match &m.of {
        Monitored::Line { .. } => {
            let points = m.points();
            let (a, b) = (points[0], points[points.len() - 1]);
            let length = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let s: Vec<Real> = (0..points.len()).map(|k| length * k as Real / (points.len() - 1) as Real).collect();
            let last = t.0.rows.len() - 1;
            let vector = columns.first().is_some_and(|c| c.ends_with("_x"));
            let parts: Vec<(&str, String)> =
                if vector { vec![("_x", "x".into()), ("_y", "y".into())] } else { vec![("", m.name.clone())] };
            let series = parts
                .iter()
                .enumerate()
                .map(|(c, (suffix, label))| {
                    let v: Vec<Real> = (0..points.len()).map(|k| t.numbers(&format!("s{k}{suffix}"))[last]).collect();
                    curve(label, c, &s, &v)
                })
                .collect();
            let time = time.last().copied().unwrap_or(0.0);
            vec![Chart {
                title: format!("{} at t = {time:.6}", m.name),
                x_label: "distance along the line".into(),
                y_label: "value".into(),
                series,
                log: (false, false),
            }]
        }
        Monitored::Suspension { axis, .. } => {
            let mut v = vec![
                over_time("solid fraction", &["solid_fraction"]),
                over_time("mean and settling velocity", &["u_x", "u_y", "settling_velocity"]),
                over_time("granular temperature", &["temperature"]),
                over_time("bed height", &["bed_height"]),
                over_time("contacts", &["contacts", "wall_contacts"]),
            ];
            if let Some(p) = profiles {
                // the last sample's profile of the solid fraction
                let (step, centre, phi) = (p.numbers("step"), p.numbers("centre"), p.numbers("solid_fraction"));
                let last = step.last().copied().unwrap_or(0.0);
                let pick = |v: &[Real]| -> Vec<Real> {
                    step.iter().zip(v).filter(|(s, _)| **s == last).map(|(_, x)| *x).collect()
                };
                let time = time.last().copied().unwrap_or(0.0);
                v.push(Chart {
                    title: format!("solid fraction across {axis:?} at t = {time:.6}"),
                    x_label: format!("{axis:?}").to_lowercase(),
                    y_label: "solid fraction".into(),
                    series: vec![curve("solid fraction", 0, &pick(&centre), &pick(&phi))],
                    log: (false, false),
                });
                // and of the mean velocity (slabs without solid have none: left out)
                let (u, w) = (pick(&p.numbers("u_x")), pick(&p.numbers("u_y")));
                let c = pick(&centre);
                let solid = |v: &[Real]| -> (Vec<Real>, Vec<Real>) {
                    c.iter().zip(v).filter(|(_, x)| x.is_finite()).map(|(c, x)| (*c, *x)).unzip()
                };
                let ((cu, u), (cw, w)) = (solid(&u), solid(&w));
                v.push(Chart {
                    title: format!("mean velocity of the solid across {axis:?} at t = {time:.6}"),
                    x_label: format!("{axis:?}").to_lowercase(),
                    y_label: "velocity".into(),
                    series: vec![curve("u_x", 0, &cu, &u), curve("u_y", 1, &cw, &w)],
                    log: (false, false),
                });
            }
            v
        }
        Monitored::Forces { reference, .. } => {
            let mut v = vec![over_time("force", &["fx", "fy"]), over_time("torque", &["torque"])];
            if reference.is_some() {
                v.push(over_time("coefficients", &["c_D", "c_L", "c_M"]));
            }
            v
        }
        _ => {
            let cols: Vec<&str> = columns.iter().take(8).map(String::as_str).collect();
            vec![over_time(&m.name, &cols)]
        }
    };
    write_figure(
        stem,
        &Figure {
            title: format!("{name}: monitor {} ({})", m.name, m.of.kind()),
            size: (1000, 300 + 250 * charts.len() as u32),
            columns: vec![(1.0, charts.iter().collect())],
        },
    )
}

fn write_diagnostics(stem: &Path, name: &str, t: &Table) -> Result<(), Error> {
    let time = t.numbers("time");
    let one = |col: &str| vec![curve("", 0, &time, &t.numbers(col))];
    let energy = chart("kinetic energy", "kinetic energy", false, one("kinetic_energy"));
    let dt = chart("time step Δt", "Δt", true, one("dt"));
    let div = chart("largest divergence after the projection", "max divergence", true, one("max_divergence"));
    let iters = chart("pressure iterations per step", "pressure iterations", false, one("pressure_iterations"));
    write_figure(
        stem,
        &Figure {
            title: format!("{name}: diagnostics"),
            size: (1200, 800),
            columns: vec![(1.0, vec![&energy, &dt]), (1.0, vec![&div, &iters])],
        },
    )
}

fn write_bodies(stem: &Path, name: &str, domain: Option<([Real; 2], [Real; 2])>, t: &Table) -> Result<(), Error> {
    let time = t.numbers("time");
    let (x, y, vx, vy) = (t.numbers("x"), t.numbers("y"), t.numbers("vx"), t.numbers("vy"));
    let names = t.text("body");
    let mut order: Vec<String> = Vec::new();
    for n in &names {
        if !order.contains(n) {
            order.push(n.clone());
        }
    }
    let pick = |body: &str, v: &[Real]| -> Vec<Real> {
        names.iter().zip(v).filter(|(n, _)| n.as_str() == body).map(|(_, v)| *v).collect()
    };
    let (mut path, mut vel_x, mut vel_y) = (Vec::new(), Vec::new(), Vec::new());
    for (k, body) in order.iter().enumerate() {
        let tb = pick(body, &time);
        path.push(curve(body, k, &pick(body, &x), &pick(body, &y)));
        vel_x.push(curve(body, k, &tb, &pick(body, &vx)));
        vel_y.push(curve(body, k, &tb, &pick(body, &vy)));
    }
    // the domain's box, and a column about as wide as the box at the chart's height
    let mut aspect = None;
    if let Some((o, s)) = domain {
        let corners =
            [(o[0], o[1]), (o[0] + s[0], o[1]), (o[0] + s[0], o[1] + s[1]), (o[0], o[1] + s[1]), (o[0], o[1])];
        path.push(Series { label: "domain".into(), points: corners.to_vec(), color: BOX_COLOR, markers: false });
        aspect = Some(s[0] / s[1]);
    }
    let trajectories = Chart {
        title: "trajectories".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        series: path,
        log: (false, false),
    };
    let (w, h) = (1200.0, 800.0);
    // plot height ≈ figure − title − caption − x labels − margins; plus y labels and margins
    let plot_h = h - 30.0 - 30.0 - 45.0 - 24.0;
    let left = aspect.map_or(0.4, |a| ((plot_h * a + 94.0) / w).clamp(0.2, 0.6));
    let vel_x = chart("velocity vx", "vx", false, vel_x);
    let vel_y = chart("velocity vy", "vy", false, vel_y);
    write_figure(
        stem,
        &Figure {
            title: format!("{name}: bodies"),
            size: (w as u32, h as u32),
            columns: vec![(left, vec![&trajectories]), (1.0 - left, vec![&vel_x, &vel_y])],
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_the_extremes_in_order() {
        let pts: Vec<(Real, Real)> = (0..10_000).map(|k| (k as Real, if k == 5_000 { 100.0 } else { 0.0 })).collect();
        let t = thin(pts);
        assert!(t.len() <= MAX_POINTS + 2, "{}", t.len());
        assert!(t.iter().any(|p| p.1 == 100.0));
        assert!(t.windows(2).all(|w| w[0].0 < w[1].0));
    }
}
