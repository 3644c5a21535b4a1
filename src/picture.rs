//! PNG pictures of the flow at output times (`output.pictures` in the case), for looking
//! at a run and for an animation.
//!
//! The run writes `frames/frame_000000.png`, `frame_000001.png`, … numbered by frame: the
//! first at t = 0, then every `output.pictures.interval` of simulated time, and always the
//! last step of the run; or, as for snapshots, at exact `times: [...]` (the step lands on
//! each) and `at_end: true`, with or without an interval. Each picture is `width` pixels wide: the domain with its aspect
//! (y up), a band above it with the case name and the time, and a band below with the
//! colour bar and its numeric range. What the colours show is a cell quantity of the
//! registry ([`crate::core::quantity`]; `multifield quantities` lists them, plugins add
//! more): `quantity: "vorticity"` (the default), `"speed"`, `"pressure"`, `"divergence"`,
//! … of the mixture, or of one field with `field: Some("water")`. A quantity that only
//! fields have (`"theta"`) without a `field` is drawn for the field that fills the rest
//! (or the first field). The former identifiers are still read: `Vorticity`, `Speed` (as
//! `"velocity"`) and `VolumeFraction` (as `"theta"`). The colour map is the quantity's:
//!
//! - signed quantities (vorticity, divergence): a diverging blue–white–red map symmetric
//!   about 0; the range ± the frame's 99.5th percentile of |x| (the thin layers on body
//!   surfaces would wash out the wakes with the maximum), brighter values saturate;
//! - magnitudes (speed, density): viridis from 0 to the frame's largest value; a vector
//!   (velocity) is drawn as its magnitude, its components interpolated to the pixel and
//!   then combined, so that zeros stay sharp;
//! - fractions (θ): viridis from 0 to 1; other quantities (pressure): viridis from the
//!   smallest to the largest value.
//!
//! Cells that no field occupies (Σθ ≤ 1e-6, e.g. the vacuum around colliding disks) are
//! grey. Material points are drawn as dots (at most [`MAX_POINTS`], a deterministic
//! sample), bodies as black circles of their radius at their centroid. The cell values are
//! those a snapshot holds ([`crate::core::quantity::Sample`]: the grid state after a step,
//! reconstructed from the initial condition at t = 0), so the frame at t = 0 shows the
//! initial state.
//!
//! A 3D case is drawn on planes of cells, its `slice`s ([`Plane`]): each slice has a
//! writer and a folder of its own, `frames/<axis>_<at>/` ([`Slice::folder`]), and is drawn
//! as a 2D picture of the plane (the in-plane axes across and up: (x, y) normal to z,
//! (x, z) normal to y, (y, z) normal to x, named in the title with the slice), with the
//! same quantities and colour maps; a vector is drawn as its magnitude, a signed vector
//! (the vorticity) as its component normal to the plane. Points and bodies are 2D only.
//!
//! Make an animation of the frames with ffmpeg:
//!
//! ```text
//! ffmpeg -framerate 20 -i frames/frame_%06d.png -pix_fmt yuv420p dkt.mp4
//! ```
//!
//! The height is always even; yuv420p needs an even width too, so give `width` an even
//! number (or add `-vf pad=ceil(iw/2)*2:ih`).
//!
//! `frames/frames.csv` lists every frame drawn (`step,time,frame`, a row per frame,
//! flushed as it is drawn). A run from t = 0 first removes the frames an earlier run left
//! in `frames/`; a run continued from a checkpoint keeps the frames drawn up to its step
//! (read from `frames.csv`) and draws on from there ([`Pictures::create`]). A frame of a domain 320 × 1280 cells, 640 pixels wide, takes
//! 0.08–0.17 s on two cores (most of it the PNG encoder).

use crate::core::case::{PictureSpec, Representation, Slice};
use crate::core::driver::{Step, Writer};
use crate::core::error::Error;
use crate::core::grid::{Grid, Lattice};
use crate::core::math::{Real, DIM};
use crate::core::quantity::{self, Colours, Place, PointSet, Quantity, Sample};
use crate::core::simulation::Simulation;
use crate::output::{Due, Moments};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// At most this many material points are drawn per frame (a deterministic sample beyond).
pub const MAX_POINTS: usize = 20_000;

/// Largest picture, in pixels.
const MAX_PIXELS: u64 = 64 << 20;

/// Percentile of |ω| that sets the vorticity range.
const VORTICITY_PERCENTILE: f64 = 0.995;

/// Colour of cells no field occupies.
const EMPTY: [u8; 3] = [200, 200, 200];

/// Where things are in a picture (pixels; rows from the top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Width of the picture (and of the domain).
    pub width: u32,
    /// Height of the picture.
    pub height: u32,
    /// First row of the domain.
    pub field_top: u32,
    /// Rows of the domain: `round(width × Ly / Lx)`.
    pub field_height: u32,
    /// Row of the middle of the colour bar.
    pub bar_row: u32,
    /// Columns of the colour bar's ends (first and last column).
    pub bar_columns: (u32, u32),
    /// Text size (pixels).
    pub font: u32,
}

impl Layout {
    /// The layout of a picture `width` pixels wide of a domain of size `size`.
    pub fn new(size: [Real; 2], width: u32) -> Self {
        let field_height = ((width as Real) * size[1] / size[0]).round().max(1.0) as u32;
        let font = ((width as f64) / 28.0).round().clamp(10.0, 18.0) as u32;
        let top = 2 * font;
        let pad = font / 2;
        let bar = font;
        // bar, labels under it; the whole height even (yuv420p)
        let mut bottom = pad + bar + pad + font + pad + font / 3;
        if (top + field_height + bottom) % 2 == 1 {
            bottom += 1;
        }
        let margin = (2 * font).min(width / 8);
        Layout {
            width,
            height: top + field_height + bottom,
            field_top: top,
            field_height,
            bar_row: top + field_height + pad + bar / 2,
            bar_columns: (margin, width.saturating_sub(margin + 1).max(margin)),
            font,
        }
    }

    /// Pixel (column, row) of the point (x, y) of a domain with lower-left corner `origin`
    /// and size `size`.
    pub fn pixel(&self, origin: [Real; 2], size: [Real; 2], x: Real, y: Real) -> (i64, i64) {
        let px = ((x - origin[0]) / size[0] * self.width as Real).floor() as i64;
        let py = self.field_top as i64 + ((1.0 - (y - origin[1]) / size[1]) * self.field_height as Real).floor() as i64;
        (px, py)
    }
}

/// Piecewise-linear interpolation between evenly spaced colours, `t` in [0, 1].
fn ramp(stops: &[[u8; 3]], t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.5 } else { t.clamp(0.0, 1.0) };
    let s = t * (stops.len() - 1) as f64;
    let k = (s.floor() as usize).min(stops.len() - 2);
    let f = s - k as f64;
    let (a, b) = (stops[k], stops[k + 1]);
    std::array::from_fn(|c| (a[c] as f64 + f * (b[c] as f64 - a[c] as f64)).round() as u8)
}

const DIVERGING: [[u8; 3]; 11] = [
    [5, 48, 97],
    [33, 102, 172],
    [67, 147, 195],
    [146, 197, 222],
    [209, 229, 240],
    [255, 255, 255],
    [253, 219, 199],
    [244, 165, 130],
    [214, 96, 77],
    [178, 24, 43],
    [103, 0, 31],
];

const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

/// The diverging map (vorticity): `s` in [−1, 1], dark blue at −1, white at 0, dark red at 1.
pub fn diverging(s: f64) -> [u8; 3] {
    ramp(&DIVERGING, 0.5 * (s + 1.0))
}

/// The sequential map (speed, volume fraction): `t` in [0, 1], viridis.
pub fn sequential(t: f64) -> [u8; 3] {
    ramp(&VIRIDIS, t)
}

/// The cells a picture draws, row-major (`i + j·cells[0]`, j up): the whole grid in 2D; in
/// 3D a plane normal to an axis ([`Slice`]), its values interpolated linearly between the
/// two layers of cell centres nearest the plane.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// Cells across (left to right) and up.
    pub cells: [usize; 2],
    /// Lower-left corner of the plane, in its two axes' coordinates.
    pub origin: [Real; 2],
    /// Width and height.
    pub size: [Real; 2],
    /// The axes across, up and normal to the plane (0, 1 and 2 in 2D: x across, y up).
    pub axes: [usize; 3],
    /// The slice: its layers of cells along the normal axis and the weight of the second.
    cut: Option<(Slice, usize, usize, Real)>,
}

impl Plane {
    /// The plane of `slice` (required in 3D, refused in 2D).
    pub fn of(grid: &Grid, periodic: [bool; DIM], slice: Option<&Slice>) -> Result<Plane, Error> {
        let n = grid.n();
        let size = grid.size();
        let origin = grid.origin;
        match slice {
            None if DIM == 2 => Ok(Plane {
                cells: [n[0], n[1]],
                origin: [origin[0], origin[1]],
                size: [size[0], size[1]],
                axes: [0, 1, 2],
                cut: None,
            }),
            None => Err(Error::invalid(
                "output.pictures.slice",
                "a 3D picture needs a slice, e.g. `slice: (axis: z, at: 0.5)`",
            )),
            Some(_) if DIM == 2 => {
                Err(Error::invalid("output.pictures.slice", "a 2D case is drawn whole: leave `slice` out"))
            }
            Some(s) => {
                let normal = s.axis.index();
                let axes = match normal {
                    0 => [1, 2, 0],
                    1 => [0, 2, 1],
                    _ => [0, 1, 2],
                };
                // cell centres of the normal axis at (k + ½) h: `at` between centres k0 and k0 + 1
                let m = n[normal];
                // (a coordinate within 10⁻⁹ cells of a centre is that centre)
                let f = (s.at - origin[normal]) / grid.h - 0.5;
                let f = if (f - f.round()).abs() < 1e-9 { f.round() } else { f };
                let (k0, k1, w) = if f < 0.0 {
                    if periodic[normal] {
                        (m - 1, 0, f + 1.0)
                    } else {
                        (0, 0, 0.0)
                    }
                } else if f >= (m - 1) as Real {
                    if periodic[normal] {
                        (m - 1, 0, (f - (m - 1) as Real).min(1.0))
                    } else {
                        (m - 1, m - 1, 0.0)
                    }
                } else {
                    let k = f.floor() as usize;
                    (k, k + 1, f - k as Real)
                };
                Ok(Plane {
                    cells: [n[axes[0]], n[axes[1]]],
                    origin: [origin[axes[0]], origin[axes[1]]],
                    size: [size[axes[0]], size[axes[1]]],
                    axes,
                    cut: Some((*s, k0, k1, w)),
                })
            }
        }
    }

    /// The slice drawn (None in 2D).
    pub fn slice(&self) -> Option<Slice> {
        self.cut.map(|c| c.0)
    }

    /// The layers of cells along the normal axis the plane lies between, and the weight of
    /// the second (None in 2D).
    pub fn layers(&self) -> Option<(usize, usize, Real)> {
        self.cut.map(|(_, k0, k1, w)| (k0, k1, w))
    }

    /// The plane's values of a cell array of the grid: the array itself in 2D; in 3D
    /// (1 − w) a + w b of the two layers' values a and b (a where w = 0, b where w = 1,
    /// a where a = b, the finite one where one is not).
    pub fn cut(&self, grid: &Grid, values: Vec<Real>) -> Vec<Real> {
        let Some((_, k0, k1, w)) = self.cut else { return values };
        let [h, v, normal] = self.axes;
        let mut out = Vec::with_capacity(self.cells[0] * self.cells[1]);
        for j in 0..self.cells[1] {
            for i in 0..self.cells[0] {
                let at = |k: usize| {
                    let mut c = [0; DIM];
                    c[h] = i;
                    c[v] = j;
                    c[normal] = k;
                    values[grid.index(Lattice::Cell, c)]
                };
                let (a, b) = (at(k0), at(k1));
                out.push(if w == 0.0 || a == b || !b.is_finite() {
                    a
                } else if w == 1.0 || !a.is_finite() {
                    b
                } else {
                    (1.0 - w) * a + w * b
                });
            }
        }
        out
    }

    /// "x", "y" or "z" of an axis.
    fn axis_name(a: usize) -> &'static str {
        ["x", "y", "z"][a]
    }

    /// The slice and the axes of the picture for its title: "z = 3.14 (x →, y ↑)"; empty
    /// in 2D.
    pub fn title(&self) -> String {
        match self.cut {
            None => String::new(),
            Some((s, ..)) => format!(
                "{} = {} ({} →, {} ↑)",
                s.axis.name(),
                format_number(s.at),
                Self::axis_name(self.axes[0]),
                Self::axis_name(self.axes[1])
            ),
        }
    }
}

/// The values a picture colours and their colour range, on the cells of its [`Plane`]. A
/// vector is held as its components (two in 2D, three in 3D), interpolated apart and then
/// combined, so that a zero of the vector stays a zero between cell centres; a signed
/// vector (the vorticity in 3D) is drawn as its component normal to the plane.
pub struct Scalar {
    /// The first component (or the scalar) on the plane's cells; NaN where no field is.
    pub values: Vec<Real>,
    /// The other components of a vector.
    pub rest: Vec<Vec<Real>>,
    /// Lower end of the colour range.
    pub lo: Real,
    /// Upper end of the colour range.
    pub hi: Real,
    diverging: bool,
    /// The colour bar's label.
    pub label: String,
}

/// The `q` quantile of the finite values (0 when there are none).
fn quantile(values: &[Real], q: f64) -> Real {
    let mut v: Vec<Real> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    let k = ((q * (v.len() - 1) as f64).round() as usize).min(v.len() - 1);
    *v.select_nth_unstable_by(k, |a, b| a.total_cmp(b)).1
}

/// A usable positive range end.
fn range_end(x: Real) -> Real {
    if x.is_finite() && x > 0.0 {
        x
    } else {
        1.0
    }
}

/// The quantity a picture draws and the field it draws it for (None: the mixture).
pub fn picked(sim: &Simulation, spec: &PictureSpec) -> Result<(&'static Quantity, Option<usize>), Error> {
    let bad = |m: String| Error::invalid("output.pictures.quantity", m);
    let name = spec.quantity.as_str();
    match &spec.field {
        Some(f) => {
            let k = sim
                .fields
                .iter()
                .position(|x| &x.name == f)
                .ok_or_else(|| Error::invalid("output.pictures.field", format!("no field `{f}`")))?;
            Ok((quantity::find(name, Place::Field).map_err(bad)?, Some(k)))
        }
        None => match quantity::find(name, Place::Mixture) {
            Ok(q) => Ok((q, None)),
            Err(_) => {
                let k = sim.fields.iter().position(|f| f.fills_rest).unwrap_or(0);
                Ok((quantity::find(name, Place::Field).map_err(bad)?, Some(k)))
            }
        },
    }
}

/// The values a picture of `spec` colours on the cells of `plane`, and their range.
pub fn scalar(sim: &Simulation, spec: &PictureSpec, plane: &Plane) -> Result<Scalar, Error> {
    let (q, field) = picked(sim, spec)?;
    let sample = Sample::of(sim);
    let g = &sim.grid;
    let n = g.n_cells();
    let values = sample.cells(q, field).unwrap_or_else(|| vec![0.0; q.components * n]);
    let empty = |c: usize| sample.theta[c] <= 1e-6;
    let part = |k: usize| {
        let v = (0..n).map(|c| if empty(c) { Real::NAN } else { values[3 * c + k] }).collect::<Vec<_>>();
        plane.cut(g, v)
    };
    let vector = q.components == 3 && values.len() == 3 * n;
    // a signed vector in 3D: its component normal to the plane
    let normal = vector && DIM == 3 && q.colours == Colours::Diverging;
    let (values, rest) = if normal {
        (part(plane.axes[2]), Vec::new())
    } else if vector {
        (part(0), (1..DIM).map(part).collect())
    } else {
        let v = (0..n).map(|c| if empty(c) { Real::NAN } else { values.get(c).copied().unwrap_or(0.0) }).collect();
        (plane.cut(g, v), Vec::new())
    };
    let magnitude: Vec<Real> = match rest.as_slice() {
        [] => values.clone(),
        [v] => values.iter().zip(v).map(|(u, v)| u.hypot(*v)).collect(),
        [v, w] => (0..values.len()).map(|c| values[c].hypot(v[c]).hypot(w[c])).collect(),
        _ => unreachable!("at most three components"),
    };
    let finite = || magnitude.iter().copied().filter(|x| x.is_finite());
    let (lo, hi) = match q.colours {
        Colours::Diverging => {
            let abs: Vec<Real> = magnitude.iter().map(|x| x.abs()).collect();
            let m = range_end(quantile(&abs, VORTICITY_PERCENTILE));
            (-m, m)
        }
        Colours::FromZero => (0.0, range_end(finite().fold(0.0, Real::max))),
        Colours::Fraction => (0.0, 1.0),
        Colours::Range => {
            let (lo, hi) = finite().fold((Real::INFINITY, Real::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
            if lo.is_finite() && hi > lo {
                (lo, hi)
            } else if lo.is_finite() {
                (lo - 0.5, lo + 0.5)
            } else {
                (0.0, 1.0)
            }
        }
    };
    let name = if normal { format!("{}_{}", q.name, Plane::axis_name(plane.axes[2])) } else { q.name.to_string() };
    let label = match field {
        Some(k) if spec.field.is_some() || !q.has_mixture() => format!("{name} of {}", sim.fields[k].name),
        _ => name,
    };
    let label = if rest.is_empty() { label } else { format!("|{label}|") };
    Ok(Scalar { values, rest, lo, hi, diverging: q.colours == Colours::Diverging, label })
}

/// Colour of a value of `s`.
fn colour(s: &Scalar, x: Real) -> [u8; 3] {
    if !x.is_finite() {
        return EMPTY;
    }
    if s.diverging {
        diverging(x / s.hi)
    } else {
        sequential((x - s.lo) / (s.hi - s.lo))
    }
}

/// Paints the domain: the scalar interpolated bilinearly between cell centres at every
/// pixel centre (cells without a value left out of the weights).
fn paint_field(rgb: &mut [u8], lay: &Layout, plane: &Plane, s: &Scalar) {
    let w = lay.width as usize;
    let start = lay.field_top as usize * w * 3;
    let rows = &mut rgb[start..start + lay.field_height as usize * w * 3];
    let [nx, ny] = plane.cells;
    let (fw, fh) = (lay.width as Real, lay.field_height as Real);
    rows.par_chunks_mut(w * 3).enumerate().for_each(|(r, row)| {
        let fy = (1.0 - (r as Real + 0.5) / fh) * ny as Real - 0.5;
        let j0 = fy.floor().clamp(0.0, (ny - 1) as Real) as usize;
        let j1 = (j0 + 1).min(ny - 1);
        let b = (fy - j0 as Real).clamp(0.0, 1.0);
        for (col, px) in row.chunks_mut(3).enumerate() {
            let fx = (col as Real + 0.5) / fw * nx as Real - 0.5;
            let i0 = fx.floor().clamp(0.0, (nx - 1) as Real) as usize;
            let i1 = (i0 + 1).min(nx - 1);
            let a = (fx - i0 as Real).clamp(0.0, 1.0);
            let (mut sum, mut sums, mut wsum) = (0.0, [0.0; 2], 0.0);
            for (i, j, wt) in
                [(i0, j0, (1.0 - a) * (1.0 - b)), (i1, j0, a * (1.0 - b)), (i0, j1, (1.0 - a) * b), (i1, j1, a * b)]
            {
                let x = s.values[i + j * nx];
                if x.is_finite() && wt > 0.0 {
                    sum += wt * x;
                    for (acc, y) in sums.iter_mut().zip(&s.rest) {
                        *acc += wt * y[i + j * nx];
                    }
                    wsum += wt;
                }
            }
            let value = match s.rest.len() {
                0 => sum,
                1 => sum.hypot(sums[0]),
                _ => sum.hypot(sums[0]).hypot(sums[1]),
            };
            let c = if wsum > 1e-12 { colour(s, value / wsum) } else { EMPTY };
            px.copy_from_slice(&c);
        }
    });
}

/// Blends `c` with opacity `alpha` into pixel (x, y) when it lies in the domain's rows.
fn blend(rgb: &mut [u8], lay: &Layout, x: i64, y: i64, c: [u8; 3], alpha: f64) {
    let (y0, y1) = (lay.field_top as i64, (lay.field_top + lay.field_height) as i64);
    if x < 0 || x >= lay.width as i64 || y < y0 || y >= y1 || alpha <= 0.0 {
        return;
    }
    let k = 3 * (y as usize * lay.width as usize + x as usize);
    let a = alpha.min(1.0);
    for ch in 0..3 {
        let d = rgb[k + ch] as f64;
        rgb[k + ch] = (d + a * (c[ch] as f64 - d)).round() as u8;
    }
}

/// Material points as one-pixel dots, a deterministic sample of at most [`MAX_POINTS`].
fn paint_points(rgb: &mut [u8], lay: &Layout, sim: &Simulation) {
    // material points only: a mass point is drawn as its body
    let sets: Vec<PointSet> = sim
        .fields
        .iter()
        .filter(|f| f.frame.representation() == Representation::Resolved)
        .filter_map(|f| f.frame.points())
        .collect();
    let total: usize = sets.iter().map(PointSet::len).sum();
    if total == 0 {
        return;
    }
    let size = sim.grid.size();
    let (origin, size) = ([sim.grid.origin.x, sim.grid.origin.y], [size.x, size.y]);
    let keep = (MAX_POINTS as f64 / total as f64).min(1.0);
    let threshold = (keep * u32::MAX as f64) as u64;
    let mut k_all: u64 = 0;
    for p in &sets {
        for x in &p.position {
            k_all += 1;
            let h = (k_all.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) & 0xFFFF_FFFF;
            if keep < 1.0 && h > threshold {
                continue;
            }
            let (px, py) = lay.pixel(origin, size, x.x, x.y);
            blend(rgb, lay, px, py, [40, 40, 40], 0.55);
        }
    }
}

fn paint_bodies(rgb: &mut [u8], lay: &Layout, sim: &Simulation) {
    let size = sim.grid.size();
    let scale = lay.width as Real / size.x;
    let line = (lay.width as Real / 300.0).clamp(1.2, 3.0);
    for (_, b) in sim.bodies() {
        let cx = (b.position.x - sim.grid.origin.x) * scale;
        let cy = lay.field_top as Real + (size.y - (b.position.y - sim.grid.origin.y)) * scale;
        let r = b.radius * scale;
        if !(cx.is_finite() && cy.is_finite() && r.is_finite()) {
            continue;
        }
        let reach = r + line;
        let (x0, x1) = ((cx - reach).floor() as i64, (cx + reach).ceil() as i64);
        let (y0, y1) = ((cy - reach).floor() as i64, (cy + reach).ceil() as i64);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = ((x as Real + 0.5 - cx).hypot(y as Real + 0.5 - cy) - r).abs();
                let cover = (0.5 * line + 0.5 - d).clamp(0.0, 1.0);
                blend(rgb, lay, x, y, [0, 0, 0], cover);
            }
        }
    }
}

/// The colour bar's gradient.
fn paint_bar(rgb: &mut [u8], lay: &Layout, s: &Scalar) {
    let (c0, c1) = lay.bar_columns;
    let half = lay.font / 2;
    let w = lay.width as usize;
    for row in lay.bar_row - half..lay.bar_row - half + lay.font {
        for col in c0..=c1 {
            let t = if c1 > c0 { (col - c0) as f64 / (c1 - c0) as f64 } else { 0.5 };
            let c = colour(s, s.lo + t * (s.hi - s.lo));
            let k = 3 * (row as usize * w + col as usize);
            rgb[k..k + 3].copy_from_slice(&c);
        }
    }
}

/// A number with three significant digits, with a true minus sign.
pub fn format_number(x: Real) -> String {
    let s = if x == 0.0 {
        "0".to_string()
    } else if x.abs() >= 1e4 || x.abs() < 1e-2 {
        format!("{x:.2e}")
    } else {
        let decimals = (2 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    };
    s.replace('-', "−")
}

/// Draws one picture of `sim` on `plane` into `path` (PNG, through `tmp` and a rename).
fn write_picture(
    sim: &Simulation,
    spec: &PictureSpec,
    plane: &Plane,
    lay: &Layout,
    path: &Path,
    tmp: &Path,
) -> Result<(), Error> {
    let s = scalar(sim, spec, plane)?;
    let mut rgb = vec![255u8; lay.width as usize * lay.height as usize * 3];
    paint_field(&mut rgb, lay, plane, &s);
    // (points and bodies are 2D so far)
    if plane.slice().is_none() {
        paint_points(&mut rgb, lay, sim);
        paint_bodies(&mut rgb, lay, sim);
    }
    paint_bar(&mut rgb, lay, &s);
    let title = match plane.slice() {
        None => sim.case.name.clone(),
        Some(_) => format!("{} · {}", sim.case.name, plane.title()),
    };
    crate::plot::register_font();
    let draw = || -> Result<(), String> {
        let root = BitMapBackend::new(tmp, (lay.width, lay.height)).into_drawing_area();
        let image = BitMapElement::with_ref((0, 0), (lay.width, lay.height), &rgb)
            .ok_or_else(|| "picture buffer of the wrong size".to_string())?;
        root.draw(&image).map_err(|e| e.to_string())?;
        let f = lay.font as i32;
        let style = |h, v| ("sans-serif", f).into_font().color(&BLACK).pos(Pos::new(h, v));
        let top = lay.field_top as i32 / 2;
        root.draw(&Text::new(title.clone(), (f / 2, top), style(HPos::Left, VPos::Center)))
            .map_err(|e| e.to_string())?;
        root.draw(&Text::new(
            time_label(sim.time, spec.interval),
            (lay.width as i32 - f / 2, top),
            style(HPos::Right, VPos::Center),
        ))
        .map_err(|e| e.to_string())?;
        let (c0, c1) = (lay.bar_columns.0 as i32, lay.bar_columns.1 as i32);
        let bar_bottom = lay.bar_row as i32 - f / 2 + f;
        let label_row = bar_bottom + f / 4;
        root.draw(&Text::new(format_number(s.lo), (c0, label_row), style(HPos::Left, VPos::Top)))
            .map_err(|e| e.to_string())?;
        root.draw(&Text::new(format_number(s.hi), (c1, label_row), style(HPos::Right, VPos::Top)))
            .map_err(|e| e.to_string())?;
        root.draw(&Text::new(s.label.clone(), ((c0 + c1) / 2, label_row), style(HPos::Center, VPos::Top)))
            .map_err(|e| e.to_string())?;
        // the bar's frame, and a tick at 0 on a diverging map
        let top_row = lay.bar_row as i32 - f / 2;
        root.draw(&Rectangle::new([(c0 - 1, top_row - 1), (c1 + 1, bar_bottom)], BLACK.stroke_width(1)))
            .map_err(|e| e.to_string())?;
        if s.diverging {
            let mid = (c0 + c1) / 2;
            root.draw(&PathElement::new(vec![(mid, top_row - f / 4), (mid, top_row)], BLACK.stroke_width(1)))
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())
    };
    if let Err(m) = draw() {
        let _ = std::fs::remove_file(tmp);
        return Err(Error::Model(format!("cannot draw {}: {m}", path.display())));
    }
    std::fs::rename(tmp, path).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// "t = 2.40": two decimals more than the interval needs, at least one.
fn time_label(t: Real, interval: Real) -> String {
    let decimals = if interval > 0.0 { ((-interval.log10()).ceil() as i64 + 1).clamp(1, 9) as usize } else { 4 };
    format!("t = {t:.decimals$}")
}

/// The number of frames an uninterrupted run has drawn by a step at time `t` > 0 (when
/// every interval holds a step of its own): ⌊t/Δ⌋ + 1 on the interval, and one per exact
/// time reached by `t` that is not a multiple of the interval.
fn kept_frames(spec: &PictureSpec, t: Real) -> usize {
    let on_interval = if spec.interval > 0.0 { (t / spec.interval + 1e-9).floor() as usize + 1 } else { 0 };
    let multiple = |m: Real| spec.interval > 0.0 && ((m / spec.interval).round() * spec.interval - m).abs() <= 1e-9 * m;
    let exact = spec.times.iter().filter(|&&m| crate::core::case::moment_reached(m, t) && !multiple(m)).count();
    on_interval + exact
}

/// Name of frame `k`.
pub fn frame_name(k: usize) -> String {
    format!("frame_{k:06}.png")
}

/// The index of the frames drawn, in `frames/`.
pub const INDEX: &str = "frames.csv";
const INDEX_HEADER: &str = "step,time,frame";

/// Writer of `frames/`.
pub struct Pictures {
    dir: PathBuf,
    index: crate::core::driver::CsvWriter,
    spec: PictureSpec,
    plane: Plane,
    layout: Layout,
    due: Moments,
    next: usize,
    last_step: Option<u64>,
    resumed: bool,
}

impl Pictures {
    /// Prepares `dir/frames/`. A run from t = 0 removes the frames an earlier run left
    /// there (`frame_NNNNNN.png`), so that an animation never mixes two runs. A run
    /// continued from a checkpoint of step n keeps the K frames `frames.csv` lists at
    /// steps ≤ n (drawn before the checkpoint), removes the later ones, and draws on from
    /// frame K: the frames of the continued run are those of an uninterrupted one,
    /// however many output times a step crosses. (Frames of a run that wrote no
    /// `frames.csv` are counted from the schedule: ⌊T/Δ⌋ + 1 and the times reached, right
    /// when every interval holds a step.)
    ///
    /// In 3D each slice has a writer of its own, drawing into `frames/<axis>_<at>/`
    /// ([`Slice::folder`]) with its own `frames.csv`.
    pub fn create(sim: &Simulation, dir: &Path, spec: PictureSpec, slice: Option<&Slice>) -> Result<Self, Error> {
        if !(spec.interval >= 0.0 && spec.interval.is_finite())
            || (spec.interval == 0.0 && spec.times.is_empty() && !spec.at_end)
        {
            return Err(Error::invalid(
                "output.pictures.interval",
                format!("{}: must be a positive time (or give times or at_end)", spec.interval),
            ));
        }
        picked(sim, &spec)?;
        let plane = Plane::of(&sim.grid, sim.boundaries.periodic_axes(), slice)?;
        let layout = Layout::new(plane.size, spec.width);
        if layout.width as u64 * layout.height as u64 > MAX_PIXELS || spec.width < 16 {
            return Err(Error::invalid(
                "output.pictures.width",
                format!(
                    "{}: the picture would be {} × {} pixels; give a width between 16 and one that keeps it under {} megapixels",
                    spec.width,
                    layout.width,
                    layout.height,
                    MAX_PIXELS >> 20
                ),
            ));
        }
        let frames = match slice {
            None => dir.join("frames"),
            Some(s) => dir.join("frames").join(s.folder()),
        };
        std::fs::create_dir_all(&frames).map_err(|source| Error::Io { path: frames.clone(), source })?;
        let existing: Vec<(usize, PathBuf)> = std::fs::read_dir(&frames)
            .map_err(|source| Error::Io { path: frames.clone(), source })?
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let k = name.strip_prefix("frame_")?.strip_suffix(".png")?;
                if k.len() != 6 || !k.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                Some((k.parse().ok()?, e.path()))
            })
            .collect();
        let index_path = frames.join(INDEX);
        let (index, keep) = if sim.steps == 0 {
            (crate::core::driver::create_csv(&index_path, INDEX_HEADER)?, 0)
        } else if index_path.is_file() {
            let step = sim.steps;
            let (index, kept) = crate::core::driver::resume_csv(&index_path, None, INDEX_HEADER, |s| s <= step)?;
            (index, kept as usize)
        } else {
            let keep = kept_frames(&spec, sim.time);
            (crate::core::driver::create_csv(&index_path, INDEX_HEADER)?, keep)
        };
        for (_, p) in existing.iter().filter(|(k, _)| *k >= keep) {
            std::fs::remove_file(p).map_err(|source| Error::Io { path: p.clone(), source })?;
        }
        let next = keep;
        // a continued run's state at T is that of a step drawn (or not due) before
        let resumed = sim.steps > 0;
        let due =
            Moments::new((spec.interval > 0.0).then(|| Due::new(0.0, spec.interval)), &spec.times, spec.at_end, 0.0);
        Ok(Self { dir: frames, index, spec, plane, layout, due, next, last_step: None, resumed })
    }

    /// The layout of this run's pictures.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    fn draw(&mut self, sim: &Simulation) -> Result<(), Error> {
        let name = frame_name(self.next);
        let path = self.dir.join(&name);
        let tmp = self.dir.join(format!(".{}.partial.png", name.trim_end_matches(".png")));
        write_picture(sim, &self.spec, &self.plane, &self.layout, &path, &tmp)?;
        let row = [sim.steps.to_string(), crate::core::driver::number(sim.time), self.next.to_string()];
        crate::core::driver::append_row(&mut self.index, &self.dir.join(INDEX), &row)?;
        self.next += 1;
        self.last_step = Some(sim.steps);
        Ok(())
    }
}

impl Writer for Pictures {
    fn name(&self) -> &str {
        "pictures"
    }
    fn needs_grid_state_at_start(&self) -> bool {
        true
    }
    fn needs_grid_state(&self, step: &Step) -> bool {
        self.due.peek(step.sim.time, step.last) && self.last_step != Some(step.sim.steps)
    }
    fn start(&mut self, sim: &Simulation) -> Result<(), Error> {
        if self.due.check(sim.time, false) && !self.resumed {
            self.draw(sim)?;
        }
        Ok(())
    }
    fn after_step(&mut self, step: &Step) -> Result<(), Error> {
        let (sim, last) = (step.sim, step.last);
        let due = self.due.check(sim.time, last);
        if due && self.last_step != Some(sim.steps) {
            self.draw(sim)?;
        }
        Ok(())
    }
}

/// Draws the picture of `sim` now into `path` (PNG), as the run's frames are drawn (in 3D,
/// on the first of the spec's slices).
pub fn write_frame(sim: &Simulation, spec: &PictureSpec, path: &Path) -> Result<Layout, Error> {
    write_slice(sim, spec, spec.slice.first(), path).map(|(layout, _)| layout)
}

/// Draws the picture of `sim` on `slice` (None in 2D) now into `path` (PNG); returns its
/// layout and plane.
pub fn write_slice(
    sim: &Simulation,
    spec: &PictureSpec,
    slice: Option<&Slice>,
    path: &Path,
) -> Result<(Layout, Plane), Error> {
    let plane = Plane::of(&sim.grid, sim.boundaries.periodic_axes(), slice)?;
    let layout = Layout::new(plane.size, spec.width);
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{}.partial.png", name.trim_end_matches(".png")));
    write_picture(sim, spec, &plane, &layout, path, &tmp)?;
    Ok((layout, plane))
}
