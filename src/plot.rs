//! Line charts written as PNG and SVG (plotters), with an embedded font so that they
//! render the same on a machine without system fonts.

use crate::core::error::Error;
use crate::core::math::Real;
use plotters::prelude::*;
use std::path::Path;

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// Registers the embedded DejaVu Sans as the `sans-serif` family (once per process).
pub(crate) fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // registering an embedded, valid font cannot fail; ignore the Result's unit error
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One curve of a chart.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points (x, y).
    pub points: Vec<(Real, Real)>,
    /// Colour index into the palette.
    pub color: usize,
    /// Dashed (reference data) or solid (computed).
    pub markers: bool,
}

/// A chart: title, axis labels and curves.
pub struct Chart {
    /// Title.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Curves.
    pub series: Vec<Series>,
    /// Logarithmic axes (x, y).
    pub log: (bool, bool),
}

pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(90, 90, 90),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

/// A figure of several charts: columns side by side (each `width` a fraction of the
/// figure's width), each column's charts stacked evenly.
pub struct Figure<'a> {
    /// Title over the whole figure.
    pub title: String,
    /// Size in pixels (PNG) and in SVG user units.
    pub size: (u32, u32),
    /// Columns: relative width and the charts from top to bottom.
    pub columns: Vec<(f64, Vec<&'a Chart>)>,
}

/// The points of a series that can be drawn on the chart's axes: finite, and positive on
/// a logarithmic axis.
fn drawable(chart: &Chart, s: &Series) -> Vec<(Real, Real)> {
    s.points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && (!chart.log.0 || *x > 0.0) && (!chart.log.1 || *y > 0.0))
        .collect()
}

fn bounds(chart: &Chart) -> ((Real, Real), (Real, Real)) {
    let (mut x0, mut x1, mut y0, mut y1) = (Real::INFINITY, Real::NEG_INFINITY, Real::INFINITY, Real::NEG_INFINITY);
    for s in &chart.series {
        for (x, y) in drawable(chart, s) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    let pad = |a: Real, b: Real, log: bool| {
        if !a.is_finite() {
            return if log { (1e-3, 1.0) } else { (0.0, 1.0) };
        }
        if log {
            // whole decades: plotters labels a log axis from the first power of 10 on
            let (lo, hi) = (a.log10().floor(), b.log10().ceil());
            // (a hair beyond them, so that rounding keeps both end decades on the axis)
            let hi = if hi > lo { hi } else { lo + 1.0 };
            (10.0_f64.powf(lo) * (1.0 - 1e-9), 10.0_f64.powf(hi) * (1.0 + 1e-9))
        } else {
            let d = if b > a { 0.05 * (b - a) } else { 0.5 * a.abs().max(1.0) };
            (a - d, b + d)
        }
    };
    (pad(x0, x1, chart.log.0), pad(y0, y1, chart.log.1))
}

/// A tick label of a log axis: 1, 2 and 5 × 10ᵏ (the other ticks unlabelled, so that the
/// top of a decade is not crowded), without rounding noise (0.002, not 0.0020000000000000005).
fn tick_label(v: Real) -> String {
    if v <= 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = v.log10().floor();
    let mantissa = (v / 10f64.powf(e) * 1e6).round() / 1e6;
    if ![1.0, 2.0, 5.0, 10.0].contains(&mantissa) {
        return String::new();
    }
    let k = 5 - v.abs().log10().floor() as i32;
    let r = if k >= 0 { (v * 10f64.powi(k)).round() / 10f64.powi(k) } else { v };
    if (1e-3..1e5).contains(&r.abs()) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

/// The corner of the plot with the fewest points of the curves, for the legend.
fn legend_corner(chart: &Chart, ((x0, x1), (y0, y1)): ((Real, Real), (Real, Real))) -> SeriesLabelPosition {
    let unit = |v: Real, a: Real, b: Real, log: bool| {
        if log {
            (v.ln() - a.ln()) / (b.ln() - a.ln())
        } else {
            (v - a) / (b - a)
        }
    };
    // upper right, upper left, lower right, lower left
    let mut count = [0usize; 4];
    for s in &chart.series {
        for (x, y) in drawable(chart, s) {
            let (u, v) = (unit(x, x0, x1, chart.log.0), unit(y, y0, y1, chart.log.1));
            // the legend box covers about a third of the width and a quarter of the height
            let (left, right, low, high) = (u < 0.35, u > 0.65, v < 0.3, v > 0.7);
            count[0] += usize::from(right && high);
            count[1] += usize::from(left && high);
            count[2] += usize::from(right && low);
            count[3] += usize::from(left && low);
        }
    }
    match (0..4).min_by_key(|&k| count[k]).unwrap_or(0) {
        0 => SeriesLabelPosition::UpperRight,
        1 => SeriesLabelPosition::UpperLeft,
        2 => SeriesLabelPosition::LowerRight,
        _ => SeriesLabelPosition::LowerLeft,
    }
}

/// Draws `chart` into `area` (axes, curves, legend when a curve has a label).
fn draw_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
    caption: u32,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let ((x0, x1), (y0, y1)) = bounds(chart);
    let mut builder = ChartBuilder::on(area);
    builder.caption(&chart.title, ("sans-serif", caption)).margin(12).x_label_area_size(45).y_label_area_size(70);
    let legend = chart.series.iter().any(|s| !s.label.is_empty());
    let corner = legend_corner(chart, ((x0, x1), (y0, y1)));
    // fewer tick labels on a small panel, so that they do not run into each other
    let (w, h) = area.dim_in_pixel();
    // (a log axis labels 2…9 × 10ᵏ only when asked for 10 labels per decade)
    let x_labels = if chart.log.0 { 10 } else { ((w as usize).saturating_sub(100) / 70).clamp(2, 10) };
    let y_labels = if chart.log.1 { 10 } else { ((h as usize).saturating_sub(80) / 40).clamp(3, 10) };
    macro_rules! body {
        ($ctx:expr) => {{
            let mut ctx = $ctx;
            let mut mesh = ctx.configure_mesh();
            if chart.log.0 {
                mesh.x_label_formatter(&|v| tick_label(*v));
            }
            if chart.log.1 {
                mesh.y_label_formatter(&|v| tick_label(*v));
            }
            mesh.x_labels(x_labels)
                .y_labels(y_labels)
                .x_desc(&chart.x_label)
                .y_desc(&chart.y_label)
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(|e| e.to_string())?;
            for s in &chart.series {
                let color = PALETTE[s.color % PALETTE.len()];
                let pts = drawable(chart, s);
                let anno = if s.markers {
                    ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 2, color.filled())))
                        .map_err(|e| e.to_string())?
                } else {
                    ctx.draw_series(LineSeries::new(pts, color.stroke_width(2))).map_err(|e| e.to_string())?
                };
                if !s.label.is_empty() {
                    anno.label(s.label.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3)));
                }
            }
            if legend {
                ctx.configure_series_labels()
                    .position(corner)
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 14))
                    .draw()
                    .map_err(|e| e.to_string())?;
            }
        }};
    }
    match chart.log {
        (false, false) => body!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(|e| e.to_string())?),
        (true, true) => {
            body!(builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()).map_err(|e| e.to_string())?)
        }
        (true, false) => body!(builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1).map_err(|e| e.to_string())?),
        (false, true) => body!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(|e| e.to_string())?),
    }
    Ok(())
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, plotters::coord::Shift>, chart: &Chart) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    draw_chart(&root, chart, 22)?;
    root.present().map_err(|e| e.to_string())
}

fn draw_figure<DB: DrawingBackend>(root: DrawingArea<DB, plotters::coord::Shift>, fig: &Figure) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let inner = root.titled(&fig.title, ("sans-serif", 22)).map_err(|e| e.to_string())?;
    let total: f64 = fig.columns.iter().map(|c| c.0.max(0.0)).sum::<f64>().max(1e-9);
    let width = inner.dim_in_pixel().0 as f64;
    let mut rest = inner;
    for (k, (w, charts)) in fig.columns.iter().enumerate() {
        let column = if k + 1 == fig.columns.len() {
            rest.clone()
        } else {
            let (left, right) = rest.split_horizontally((width * w.max(0.0) / total).round() as i32);
            rest = right;
            left
        };
        if charts.is_empty() {
            continue;
        }
        for (area, chart) in column.split_evenly((charts.len(), 1)).iter().zip(charts) {
            draw_chart(area, chart, 16)?;
        }
    }
    root.present().map_err(|e| e.to_string())
}

/// Draws `stem.png` and `stem.svg` with `png` and `svg` (each given its file), under
/// temporary names renamed at the end. A failure of the plotting backend (it draws and
/// writes the file in one go: a full disk, a folder that cannot be written) is
/// [`Error::Io`] of the file, as is a failed rename: an output failure, never bad input.
pub(crate) fn write_both(
    stem: &Path,
    png: impl Fn(&Path) -> Result<(), String>,
    svg: impl Fn(&Path) -> Result<(), String>,
) -> Result<(), Error> {
    register_font();
    for ext in ["png", "svg"] {
        let path = stem.with_extension(ext);
        let tmp = stem.with_extension(format!("partial.{ext}"));
        let result = if ext == "png" { png(&tmp) } else { svg(&tmp) };
        if let Err(m) = result {
            let _ = std::fs::remove_file(&tmp);
            let source = std::io::Error::other(format!("the plotting backend cannot draw and write it: {m}"));
            return Err(Error::Io { path, source });
        }
        std::fs::rename(&tmp, &path).map_err(|source| Error::Io { path: path.clone(), source })?;
    }
    Ok(())
}

/// Writes the figure as `stem.png` and `stem.svg` (temporary names, then renamed).
pub fn write_figure(stem: &Path, fig: &Figure) -> Result<(), Error> {
    write_both(
        stem,
        |p| draw_figure(BitMapBackend::new(p, fig.size).into_drawing_area(), fig),
        |p| draw_figure(SVGBackend::new(p, fig.size).into_drawing_area(), fig),
    )
}

/// Writes `stem.png` and `stem.svg`. Each file is written under a temporary name and
/// renamed, so an interrupted run never leaves a half-written picture.
pub fn write_chart(stem: &Path, chart: &Chart) -> Result<(), Error> {
    write_both(
        stem,
        |p| draw(BitMapBackend::new(p, (960, 640)).into_drawing_area(), chart),
        |p| draw(SVGBackend::new(p, (960, 640)).into_drawing_area(), chart),
    )
}
