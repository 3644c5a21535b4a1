//! Charts of a study's results (PNG and SVG, the look of [`crate::plot`]):
//!
//! - accuracy against cost: error against wall time, log–log, one series (colour) per
//!   method, each point labelled with the run's other axes, the Pareto front (no other run
//!   both cheaper and more accurate) drawn as a black staircase through ringed points;
//! - stability map: two axes (logarithmic when numeric, positive and spanning a factor 5
//!   or more; by rank with the labels otherwise), each run a marker (stable ●, unstable ✕,
//!   failed ▲, not run yet ○), and the boundary drawn along the cell edges between
//!   neighbouring stable and unstable runs; one panel per combination of the other axes.

use crate::core::error::Error;
use crate::core::math::Real;
use crate::plot::{register_font, write_both, PALETTE};
use crate::study::{ChartSpec, Plan, Row};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::{Path, PathBuf};

/// Draws every chart of the study into its output directory; returns the PNG paths (the
/// SVG is beside each).
pub fn write(plan: &Plan, rows: &[Row]) -> Result<Vec<PathBuf>, Error> {
    register_font();
    let mut written = Vec::new();
    for spec in &plan.study.charts {
        let stem = plan.out.join(spec.file_name());
        match spec {
            ChartSpec::AccuracyCost { series, .. } => {
                let data = accuracy_data(plan, rows, series);
                let size = (1000, 700);
                let png = |p: &Path| draw_accuracy(&BitMapBackend::new(p, size).into_drawing_area(), &data);
                let svg = |p: &Path| draw_accuracy(&SVGBackend::new(p, size).into_drawing_area(), &data);
                write_both(&stem, png, svg)?;
            }
            ChartSpec::StabilityMap { x, y, .. } => {
                let map = stability_data(plan, rows, x, y);
                let cols = map.panels.len().clamp(1, 3);
                let lines = map.panels.len().div_ceil(3).max(1);
                let size = (40 + 540 * cols as u32, 50 + 470 * lines as u32);
                let png = |p: &Path| draw_stability(&BitMapBackend::new(p, size).into_drawing_area(), &map);
                let svg = |p: &Path| draw_stability(&SVGBackend::new(p, size).into_drawing_area(), &map);
                write_both(&stem, png, svg)?;
            }
        }
        written.push(stem.with_extension("png"));
    }
    Ok(written)
}

/// The points of one method: (wall time, error, label).
type MethodPoints = Vec<(Real, Real, String)>;

/// Points of the accuracy–cost chart.
struct Accuracy {
    title: String,
    /// (legend, points (wall, error, label)) per method.
    series: Vec<(String, MethodPoints)>,
    /// The Pareto front, by increasing cost.
    front: Vec<(Real, Real)>,
    /// Runs without a drawable error (unstable, failed, pending, or error 0: the reference).
    left_out: usize,
}

/// The Pareto front of (cost, error) points: by increasing cost, each point more accurate
/// than every cheaper one (by more than a relative 1e-9, so that runs with the same error
/// up to round-off do not all count).
pub fn pareto_front(points: &[(Real, Real)]) -> Vec<(Real, Real)> {
    let mut p: Vec<(Real, Real)> = points.to_vec();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(Real, Real)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|f| q.1 < f.1 * (1.0 - 1e-9)) {
            front.push(q);
        }
    }
    front
}

fn accuracy_data(plan: &Plan, rows: &[Row], series_axes: &[String]) -> Accuracy {
    let axes = &plan.study.axes;
    let in_series: Vec<bool> = axes.iter().map(|a| series_axes.contains(&a.name)).collect();
    let mut series: Vec<(String, MethodPoints)> = Vec::new();
    let mut left_out = 0;
    for (c, r) in plan.runs.iter().zip(rows) {
        let (Some(w), Some(e)) = (r.wall_seconds, r.error) else {
            left_out += 1;
            continue;
        };
        if r.status != "completed" || !(w > 0.0 && e > 0.0 && w.is_finite() && e.is_finite()) {
            left_out += 1;
            continue;
        }
        let pick = |want: bool| -> Vec<String> {
            axes.iter()
                .zip(&c.labels)
                .zip(&in_series)
                .filter(|(_, &s)| s == want)
                .map(|((a, l), _)| format!("{}={l}", a.name))
                .collect()
        };
        let name = if series_axes.is_empty() { "runs".to_string() } else { pick(true).join(", ") };
        let label = pick(false).into_iter().map(|s| s.split_once('=').map_or(s.clone(), |p| p.1.to_string()));
        let label = label.collect::<Vec<_>>().join(" ");
        match series.iter_mut().find(|s| s.0 == name) {
            Some(s) => s.1.push((w, e, label)),
            None => series.push((name, vec![(w, e, label)])),
        }
    }
    for s in &mut series {
        s.1.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let all: Vec<(Real, Real)> = series.iter().flat_map(|s| s.1.iter().map(|p| (p.0, p.1))).collect();
    let others: Vec<&str> = axes.iter().zip(&in_series).filter(|(_, &s)| !s).map(|(a, _)| a.name.as_str()).collect();
    let title = format!(
        "{}: error against cost{}",
        plan.study.name,
        if others.is_empty() { String::new() } else { format!(" (points labelled by {})", others.join(", ")) }
    );
    Accuracy { title, front: pareto_front(&all), series, left_out }
}

/// Whole decades around `lo..hi`.
fn decades(lo: Real, hi: Real) -> (Real, Real) {
    if !(lo > 0.0 && lo.is_finite() && hi >= lo && hi.is_finite()) {
        // nothing to draw (every run without an error): an empty decade chart
        return (1e-3, 1.0);
    }
    let (a, b) = (lo.log10().floor(), hi.log10().ceil());
    let b = if b > a { b } else { a + 1.0 };
    (10f64.powf(a) * (1.0 - 1e-9), 10f64.powf(b) * (1.0 + 1e-9))
}

/// Tick labels of a log axis: 1, 2 and 5 × 10ᵏ.
fn log_tick(v: Real) -> String {
    if !(v > 0.0 && v.is_finite()) {
        return String::new();
    }
    let e = v.log10().floor();
    let m = (v / 10f64.powf(e) * 1e6).round() / 1e6;
    if ![1.0, 2.0, 5.0, 10.0].contains(&m) {
        return String::new();
    }
    crate::study::short(v)
}

fn draw_accuracy<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, data: &Accuracy) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let s = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(s)?;
    let pts: Vec<(Real, Real)> = data.series.iter().flat_map(|s| s.1.iter().map(|p| (p.0, p.1))).collect();
    let lo = |f: fn(&(Real, Real)) -> Real| pts.iter().map(f).fold(Real::INFINITY, Real::min);
    let hi = |f: fn(&(Real, Real)) -> Real| pts.iter().map(f).fold(0.0, Real::max);
    let (x0, x1) = decades(lo(|p| p.0), hi(|p| p.0));
    let (y0, y1) = decades(lo(|p| p.1), hi(|p| p.1));
    let mut chart = ChartBuilder::on(root)
        .caption(&data.title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(s)?;
    let note = if data.left_out > 0 {
        format!(" ({} run{} without an error not shown)", data.left_out, if data.left_out == 1 { "" } else { "s" })
    } else {
        String::new()
    };
    chart
        .configure_mesh()
        .x_labels(10)
        .y_labels(10)
        .x_label_formatter(&|v| log_tick(*v))
        .y_label_formatter(&|v| log_tick(*v))
        .x_desc(format!("wall time (s){note}"))
        .y_desc("error against the reference")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(s)?;
    // the front first, under the points: a staircase (cost buys accuracy in steps)
    if !data.front.is_empty() {
        let mut stairs = Vec::new();
        for (k, p) in data.front.iter().enumerate() {
            if k > 0 {
                stairs.push((p.0, data.front[k - 1].1));
            }
            stairs.push(*p);
        }
        chart
            .draw_series(LineSeries::new(stairs, BLACK.stroke_width(1)))
            .map_err(s)?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(1)));
        chart.draw_series(data.front.iter().map(|&p| Circle::new(p, 8, BLACK.stroke_width(1)))).map_err(s)?;
    }
    for (k, (name, points)) in data.series.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        chart
            .draw_series(LineSeries::new(points.iter().map(|p| (p.0, p.1)), color.mix(0.5).stroke_width(1)))
            .map_err(s)?;
        chart
            .draw_series(points.iter().map(|p| Circle::new((p.0, p.1), 5, color.filled())))
            .map_err(s)?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x + 9, y), 5, color.filled()));
        chart
            .draw_series(points.iter().filter(|p| !p.2.is_empty()).map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Text::new(
                        p.2.clone(),
                        (8, -4),
                        ("sans-serif", 13).into_font().color(&color).pos(Pos::new(HPos::Left, VPos::Bottom)),
                    )
            }))
            .map_err(s)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(s)?;
    root.present().map_err(s)
}

const GREEN: RGBColor = RGBColor(44, 160, 44);
const RED: RGBColor = RGBColor(214, 39, 40);
const GREY: RGBColor = RGBColor(120, 120, 120);

/// One panel of a stability map.
struct Panel {
    title: String,
    /// (i, j, status) per run of the panel, by the values' ranks on x and y.
    cells: Vec<(usize, usize, String)>,
}

/// One axis of a stability map.
struct MapAxis {
    name: String,
    labels: Vec<String>,
    /// Positions: the values, or the ranks 0, 1, … when categorical.
    at: Vec<Real>,
    log: bool,
}

impl MapAxis {
    fn new(plan: &Plan, k: usize) -> Self {
        let points = &plan.points[k];
        let values: Vec<Real> = points.iter().map(|p| p.value).collect();
        let numeric = values.iter().all(|v| v.is_finite()) && values.windows(2).all(|w| w[1] > w[0]);
        let (lo, hi) = (values.first().copied().unwrap_or(0.0), values.last().copied().unwrap_or(0.0));
        let log = numeric && lo > 0.0 && hi / lo >= 5.0;
        Self {
            name: plan.study.axes[k].name.clone(),
            labels: points.iter().map(|p| p.label.clone()).collect(),
            at: if numeric { values } else { (0..points.len()).map(|i| i as Real).collect() },
            log,
        }
    }
    /// Cell edges: n + 1 positions around the n values (half a step beyond the ends).
    fn edges(&self) -> Vec<Real> {
        let f = |v: Real| if self.log { v.ln() } else { v };
        let g = |v: Real| if self.log { v.exp() } else { v };
        let t: Vec<Real> = self.at.iter().map(|&v| f(v)).collect();
        let n = t.len();
        if n == 1 {
            let d = if self.log { 1.0 } else { 0.5 * t[0].abs().max(1.0) };
            return vec![g(t[0] - d), g(t[0] + d)];
        }
        let mut e = vec![g(t[0] - 0.5 * (t[1] - t[0]))];
        for w in t.windows(2) {
            e.push(g(0.5 * (w[0] + w[1])));
        }
        e.push(g(t[n - 1] + 0.5 * (t[n - 1] - t[n - 2])));
        e
    }
}

struct Map {
    title: String,
    x: MapAxis,
    y: MapAxis,
    panels: Vec<Panel>,
}

fn stability_data(plan: &Plan, rows: &[Row], x: &str, y: &str) -> Map {
    let axes = &plan.study.axes;
    let (kx, ky) =
        (axes.iter().position(|a| a.name == x).unwrap_or(0), axes.iter().position(|a| a.name == y).unwrap_or(0));
    let mut panels: Vec<(Vec<usize>, Panel)> = Vec::new();
    for (c, r) in plan.runs.iter().zip(rows) {
        let mut key = c.index.clone();
        key[kx] = usize::MAX;
        key[ky] = usize::MAX;
        let cell = (c.index[kx], c.index[ky], r.status.clone());
        match panels.iter_mut().find(|p| p.0 == key) {
            Some(p) => p.1.cells.push(cell),
            None => {
                let title: Vec<String> = axes
                    .iter()
                    .zip(&c.labels)
                    .enumerate()
                    .filter(|(k, _)| *k != kx && *k != ky)
                    .map(|(_, (a, l))| format!("{} = {l}", a.name))
                    .collect();
                let title = if title.is_empty() { "all runs".into() } else { title.join(", ") };
                panels.push((key, Panel { title, cells: vec![cell] }));
            }
        }
    }
    Map {
        title: format!("{}: stability of {} against {}", plan.study.name, y, x),
        x: MapAxis::new(plan, kx),
        y: MapAxis::new(plan, ky),
        panels: panels.into_iter().map(|p| p.1).collect(),
    }
}

/// The segments between neighbouring stable and unstable (or failed) cells, as pairs of
/// points in the axes' positions.
fn boundary(panel: &Panel, ex: &[Real], ey: &[Real]) -> Vec<[(Real, Real); 2]> {
    let status = |i: usize, j: usize| panel.cells.iter().find(|c| c.0 == i && c.1 == j).map(|c| c.2.as_str());
    let stable = |s: &str| s == "completed";
    let known = |s: &str| matches!(s, "completed" | "unstable" | "failed");
    let mut segments = Vec::new();
    for &(i, j, ref s) in &panel.cells {
        if !known(s) {
            continue;
        }
        if let Some(r) = status(i + 1, j).filter(|r| known(r)) {
            if stable(s) != stable(r) {
                segments.push([(ex[i + 1], ey[j]), (ex[i + 1], ey[j + 1])]);
            }
        }
        if let Some(r) = status(i, j + 1).filter(|r| known(r)) {
            if stable(s) != stable(r) {
                segments.push([(ex[i], ey[j + 1]), (ex[i + 1], ey[j + 1])]);
            }
        }
    }
    segments
}

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, map: &Map, panel: &Panel) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let s = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (ex, ey) = (map.x.edges(), map.y.edges());
    let (x0, x1) = (ex[0], ex[ex.len() - 1]);
    let (y0, y1) = (ey[0], ey[ey.len() - 1]);
    let base = area.get_base_pixel();
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            // the axes' own ticks are the runs' values, labelled below and left of the plot
            chart
                .configure_mesh()
                .disable_mesh()
                .x_labels(0)
                .y_labels(0)
                .x_label_formatter(&|_| String::new())
                .y_label_formatter(&|_| String::new())
                .x_desc(&map.x.name)
                .y_desc(&map.y.name)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(s)?;
            let font = ("sans-serif", 13).into_font();
            // (a label too close to the one before it is left out; the tick stays)
            let mut last = i32::MIN / 2;
            for (k, label) in map.x.labels.iter().enumerate() {
                let (px, py) = chart.backend_coord(&(map.x.at[k], y0));
                let (px, py) = (px - base.0, py - base.1);
                area.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK)).map_err(s)?;
                let width = 8 * (label.chars().count() as i32 + 1);
                if px - last < width {
                    continue;
                }
                last = px;
                let style = font.clone().color(&BLACK).pos(Pos::new(HPos::Center, VPos::Top));
                area.draw(&Text::new(label.clone(), (px, py + 8), style)).map_err(s)?;
            }
            let mut last = i32::MAX / 2;
            for (k, label) in map.y.labels.iter().enumerate() {
                let (px, py) = chart.backend_coord(&(x0, map.y.at[k]));
                let (px, py) = (px - base.0, py - base.1);
                area.draw(&PathElement::new(vec![(px - 5, py), (px, py)], BLACK)).map_err(s)?;
                if last - py < 16 {
                    continue;
                }
                last = py;
                let style = font.clone().color(&BLACK).pos(Pos::new(HPos::Right, VPos::Center));
                area.draw(&Text::new(label.clone(), (px - 8, py), style)).map_err(s)?;
            }
            let at = |c: &(usize, usize, String)| (map.x.at[c.0], map.y.at[c.1]);
            let with = |want: &'static str| panel.cells.iter().filter(move |c| c.2 == want);
            chart.draw_series(with("completed").map(|c| Circle::new(at(c), 6, GREEN.filled()))).map_err(s)?;
            chart.draw_series(with("unstable").map(|c| Cross::new(at(c), 6, RED.stroke_width(3)))).map_err(s)?;
            chart.draw_series(with("failed").map(|c| TriangleMarker::new(at(c), 7, GREY.filled()))).map_err(s)?;
            // not run, or not to its end (pending, interrupted, Slurm's cancelled, timeout, …)
            let unfinished =
                panel.cells.iter().filter(|c| !matches!(c.2.as_str(), "completed" | "unstable" | "failed"));
            chart.draw_series(unfinished.map(|c| Circle::new(at(c), 6, GREY.stroke_width(1)))).map_err(s)?;
            for seg in boundary(panel, &ex, &ey) {
                chart.draw_series(LineSeries::new(seg, BLACK.stroke_width(3))).map_err(s)?;
            }
        }};
    }
    let mut b = ChartBuilder::on(area);
    b.caption(&panel.title, ("sans-serif", 16)).margin(12).x_label_area_size(45).y_label_area_size(70);
    match (map.x.log, map.y.log) {
        (false, false) => body!(b.build_cartesian_2d(x0..x1, y0..y1).map_err(s)?),
        (true, true) => body!(b.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()).map_err(s)?),
        (true, false) => body!(b.build_cartesian_2d((x0..x1).log_scale(), y0..y1).map_err(s)?),
        (false, true) => body!(b.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(s)?),
    }
    Ok(())
}

fn draw_stability<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, map: &Map) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let s = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(s)?;
    let inner = root.titled(&map.title, ("sans-serif", 20)).map_err(s)?;
    let height = inner.dim_in_pixel().1 as i32;
    let (panels, legend) = inner.split_vertically(height - 36);
    let cols = map.panels.len().clamp(1, 3);
    let lines = map.panels.len().div_ceil(3).max(1);
    for (area, panel) in panels.split_evenly((lines, cols)).iter().zip(&map.panels) {
        draw_panel(area, map, panel)?;
    }
    // one legend for every panel, in a strip under them
    let font = ("sans-serif", 15);
    let y = 16;
    let mut x = 80;
    let label = |x: &mut i32, text: &str| -> Result<(), String> {
        legend.draw(&Text::new(text.to_string(), (*x + 14, y - 8), font)).map_err(s)?;
        *x += 14 + 9 * text.chars().count() as i32 + 40;
        Ok(())
    };
    legend.draw(&Circle::new((x, y), 6, GREEN.filled())).map_err(s)?;
    label(&mut x, "stable (completed)")?;
    legend.draw(&Cross::new((x, y), 6, RED.stroke_width(3))).map_err(s)?;
    label(&mut x, "unstable")?;
    legend.draw(&TriangleMarker::new((x, y), 7, GREY.filled())).map_err(s)?;
    label(&mut x, "failed")?;
    legend.draw(&Circle::new((x, y), 6, GREY.stroke_width(1))).map_err(s)?;
    label(&mut x, "not run")?;
    legend.draw(&PathElement::new(vec![(x - 9, y), (x + 9, y)], BLACK.stroke_width(3))).map_err(s)?;
    label(&mut x, "stability boundary")?;
    root.present().map_err(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pareto_front_keeps_the_runs_no_other_beats_on_both() {
        let p = [(1.0, 0.5), (2.0, 0.6), (3.0, 0.1), (0.5, 0.9), (4.0, 0.1), (5.0, 0.05), (6.0, 0.05 * (1.0 - 1e-14))];
        assert_eq!(pareto_front(&p), vec![(0.5, 0.9), (1.0, 0.5), (3.0, 0.1), (5.0, 0.05)]);
    }

    #[test]
    fn a_chart_without_points_has_finite_axes() {
        assert_eq!(decades(Real::INFINITY, 0.0), (1e-3, 1.0));
        let (a, b) = decades(0.03, 0.3);
        assert!((a - 0.01).abs() < 1e-9 && (b - 1.0).abs() < 1e-6, "{a} {b}");
    }

    #[test]
    fn the_boundary_runs_between_stable_and_unstable_neighbours() {
        // 3 × 2 cells: x index 2 unstable on both rows → one vertical edge of two segments
        let cells = [(0, 0, "completed"), (1, 0, "completed"), (2, 0, "unstable")];
        let mut all: Vec<(usize, usize, String)> = cells.iter().map(|c| (c.0, c.1, c.2.to_string())).collect();
        all.extend(cells.iter().map(|c| (c.0, 1, c.2.to_string())));
        let panel = Panel { title: String::new(), cells: all };
        let ex = [0.0, 1.0, 2.0, 3.0];
        let ey = [0.0, 1.0, 2.0];
        let seg = boundary(&panel, &ex, &ey);
        assert_eq!(seg.len(), 2);
        assert!(seg.iter().all(|s| s[0].0 == 2.0 && s[1].0 == 2.0));
    }
}
