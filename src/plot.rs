//! Line charts written as PNG and SVG (plotters), with an embedded font so that they
//! render the same on a machine without system fonts.

use crate::core::error::Error;
use crate::core::math::Real;
use plotters::prelude::*;
use std::path::Path;

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

fn register_font() {
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

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(90, 90, 90),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

fn bounds(chart: &Chart) -> ((Real, Real), (Real, Real)) {
    let pts = chart.series.iter().flat_map(|s| s.points.iter()).filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (Real::INFINITY, Real::NEG_INFINITY, Real::INFINITY, Real::NEG_INFINITY);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    let pad = |a: Real, b: Real| {
        let d = if b > a { 0.05 * (b - a) } else { 0.5 * a.abs().max(1.0) };
        (a - d, b + d)
    };
    let (x, y) = (pad(x0, x1), pad(y0, y1));
    let pos = |r: (Real, Real), lo: Real| (r.0.max(lo * 0.8), r.1);
    (if chart.log.0 { pos(x, x0) } else { x }, if chart.log.1 { pos(y, y0) } else { y })
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, plotters::coord::Shift>, chart: &Chart) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let ((x0, x1), (y0, y1)) = bounds(chart);
    let mut builder = ChartBuilder::on(&root);
    builder.caption(&chart.title, ("sans-serif", 22)).margin(12).x_label_area_size(45).y_label_area_size(70);
    macro_rules! body {
        ($ctx:expr) => {{
            let mut ctx = $ctx;
            ctx.configure_mesh()
                .x_desc(&chart.x_label)
                .y_desc(&chart.y_label)
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(|e| e.to_string())?;
            for s in &chart.series {
                let color = PALETTE[s.color % PALETTE.len()];
                let pts: Vec<(Real, Real)> =
                    s.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
                let anno = if s.markers {
                    ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 2, color.filled())))
                        .map_err(|e| e.to_string())?
                } else {
                    ctx.draw_series(LineSeries::new(pts, color.stroke_width(2))).map_err(|e| e.to_string())?
                };
                anno.label(s.label.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3)));
            }
            ctx.configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(|e| e.to_string())?;
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
    root.present().map_err(|e| e.to_string())
}

/// Writes `stem.png` and `stem.svg`. Each file is written under a temporary name and
/// renamed, so an interrupted run never leaves a half-written picture.
pub fn write_chart(stem: &Path, chart: &Chart) -> Result<(), Error> {
    register_font();
    for ext in ["png", "svg"] {
        let path = stem.with_extension(ext);
        let tmp = stem.with_extension(format!("partial.{ext}"));
        let result = if ext == "png" {
            draw(BitMapBackend::new(&tmp, (960, 640)).into_drawing_area(), chart)
        } else {
            draw(SVGBackend::new(&tmp, (960, 640)).into_drawing_area(), chart)
        };
        result.map_err(|m| Error::Model(format!("cannot draw {}: {m}", path.display())))?;
        std::fs::rename(&tmp, &path).map_err(|source| Error::Io { path: path.clone(), source })?;
    }
    Ok(())
}
