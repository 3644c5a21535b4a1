//! Exact areas of a disk on the grid: how a single-mass-point body spreads its volume
//! (docs/method.md §4). A bilinear kernel of a point whose disk is larger than a cell puts
//! θ ≫ 1 in four cells; the exact disk ∩ cell area never exceeds the cell and sums to the
//! disk's area, whatever the disk's size and position.

use crate::grid::Grid;
use crate::math::Real;

/// Signed area of the intersection of the disk of radius `r` centred at the origin with
/// the triangle (origin, `a`, `b`): positive when `a → b` turns counter-clockwise.
///
/// The segment `a b` is cut where it crosses the circle; its pieces inside the disk give
/// triangles ½ (p × q), its pieces outside give circular sectors ½ r² ∠(p, q).
fn circle_triangle(a: [Real; 2], b: [Real; 2], r: Real) -> Real {
    let cross = |p: [Real; 2], q: [Real; 2]| p[0] * q[1] - p[1] * q[0];
    let dot = |p: [Real; 2], q: [Real; 2]| p[0] * q[0] + p[1] * q[1];
    let sector = |p: [Real; 2], q: [Real; 2]| 0.5 * r * r * cross(p, q).atan2(dot(p, q));
    let d = [b[0] - a[0], b[1] - a[1]];
    let dd = dot(d, d);
    if dd == 0.0 {
        return 0.0;
    }
    // |a + t d|² = r²:  dd t² + 2 (a·d) t + (a·a − r²) = 0
    let half_b = dot(a, d);
    let c = dot(a, a) - r * r;
    let disc = half_b * half_b - dd * c;
    if disc <= 0.0 {
        return sector(a, b);
    }
    let s = disc.sqrt();
    let (t1, t2) = ((-half_b - s) / dd, (-half_b + s) / dd);
    if t2 <= 0.0 || t1 >= 1.0 {
        return sector(a, b);
    }
    let at = |t: Real| [a[0] + t * d[0], a[1] + t * d[1]];
    let (p, q) = (at(t1.max(0.0)), at(t2.min(1.0)));
    sector(a, p) + 0.5 * cross(p, q) + sector(q, b)
}

/// How a disk meets a rectangle, decided without any area: missed, covered, or cut.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Overlap {
    Missed,
    Covered,
    Cut,
}

/// [`Overlap`] of the disk (centre `c`, radius `r`) and the rectangle `[x0, x1] × [y0, y1]`.
#[inline]
fn overlap(c: [Real; 2], r: Real, x0: Real, x1: Real, y0: Real, y1: Real) -> Overlap {
    // nearest point of the rectangle to the centre: beyond r, no overlap
    let nx = c[0].clamp(x0, x1) - c[0];
    let ny = c[1].clamp(y0, y1) - c[1];
    if nx * nx + ny * ny >= r * r {
        return Overlap::Missed;
    }
    // farthest corner within r: the whole rectangle is inside
    let fx = (x0 - c[0]).abs().max((x1 - c[0]).abs());
    let fy = (y0 - c[1]).abs().max((y1 - c[1]).abs());
    if fx * fx + fy * fy <= r * r {
        return Overlap::Covered;
    }
    Overlap::Cut
}

/// Area of the disk (centre `c`, radius `r`) inside the rectangle `[x0, x1] × [y0, y1]`.
pub fn disk_rectangle_area(c: [Real; 2], r: Real, x0: Real, x1: Real, y0: Real, y1: Real) -> Real {
    match overlap(c, r, x0, x1, y0, y1) {
        Overlap::Missed => return 0.0,
        Overlap::Covered => return (x1 - x0) * (y1 - y0),
        Overlap::Cut => {}
    }
    // the disk wholly inside the rectangle
    if c[0] - r >= x0 && c[0] + r <= x1 && c[1] - r >= y0 && c[1] + r <= y1 {
        return std::f64::consts::PI * r * r;
    }
    let corners = [[x0 - c[0], y0 - c[1]], [x1 - c[0], y0 - c[1]], [x1 - c[0], y1 - c[1]], [x0 - c[0], y1 - c[1]]];
    let mut area = 0.0;
    for k in 0..4 {
        area += circle_triangle(corners[k], corners[(k + 1) % 4], r);
    }
    area.clamp(0.0, (x1 - x0) * (y1 - y0))
}

/// ∫ √(r² − t²) dt from −r to `u` (clamped to [−r, r]): half the area of the disk of
/// radius `r` (centred at 0) left of x = u.
fn half_area_left(u: Real, r: Real) -> Real {
    let u = u.clamp(-r, r);
    // the half-chord from (r − u)(r + u), and the angle by atan2: both accurate near ±r,
    // where r² − u² and asin(u/r) lose digits
    let q = ((r - u) * (r + u)).sqrt();
    0.5 * (u * q + r * r * u.atan2(q)) + 0.25 * std::f64::consts::PI * r * r
}

/// A horizontal lattice line at height `y` above the disk's centre, with what the quadrant
/// areas along it share: the half-chord `w` = √(r² − y²) and [`half_area_left`] at ±w.
#[derive(Clone, Copy)]
struct Line {
    y: Real,
    w: Real,
    left: Real,
    right: Real,
}

impl Line {
    fn new(y: Real, r: Real) -> Self {
        let w = if y.abs() < r { ((r - y) * (r + y)).sqrt() } else { 0.0 };
        Line { y, w, left: half_area_left(-w, r), right: half_area_left(w, r) }
    }

    /// Area of the disk in the quadrant {X ≤ x, Y ≤ y} (centre at 0), from `xb` = x clamped
    /// to [−r, r] and `sx` = [`half_area_left`]`(xb)`: each column of the disk left of x
    /// contributes the length of its chord below y.
    fn quadrant(&self, xb: Real, sx: Real, r: Real) -> Real {
        let (y, w) = (self.y, self.w);
        if y <= -r || xb <= -r {
            return 0.0;
        }
        if y >= r {
            return 2.0 * sx;
        }
        if y >= 0.0 {
            // whole chords where |t| > w, the chord's part below y where |t| < w
            if xb <= -w {
                2.0 * sx
            } else if xb <= w {
                2.0 * self.left + y * (xb + w) + (sx - self.left)
            } else {
                2.0 * self.left + 2.0 * y * w + (self.right - self.left) + 2.0 * (sx - self.right)
            }
        } else if xb <= -w {
            0.0
        } else if xb <= w {
            y * (xb + w) + (sx - self.left)
        } else {
            2.0 * y * w + (self.right - self.left)
        }
    }
}

/// The cells `(i0..=i1, j0..=j1)` a disk's bounding box touches, in the grid's numbering
/// (beyond the grid where the disk is).
fn footprint(grid: &Grid, center: [Real; 2], r: Real) -> [i64; 4] {
    let (h, ox, oy) = (grid.h, grid.origin.x, grid.origin.y);
    [
        ((center[0] - r - ox) / h).floor() as i64,
        ((center[0] + r - ox) / h).floor() as i64,
        ((center[1] - r - oy) / h).floor() as i64,
        ((center[1] + r - oy) / h).floor() as i64,
    ]
}

/// The cell index along an axis of `n` cells that `i` stands for: wrapped on a periodic
/// axis, `None` beyond a side that is not.
#[inline]
fn wrapped(i: i64, n: usize, periodic: bool) -> Option<usize> {
    let i = if periodic { i.rem_euclid(n as i64) } else { i };
    (0..n as i64).contains(&i).then_some(i as usize)
}

/// Lattice lines a footprint's quadrant areas are kept for on the stack; wider disks (more
/// than 62 cells across, far beyond the mass-point model's d ≲ h) take the per-cell path.
const MAX_LINES: usize = 64;

/// The cells a disk covers and the fraction θ of each it fills (disk ∩ cell area / h²),
/// appended to `out` as `(cell index, θ)`. On a periodic side the disk wraps around; on
/// any other side the part beyond the domain is not counted (a body inside the domain
/// loses nothing: Σ θ h² = π r² to round-off).
///
/// A cell's area is the inclusion–exclusion of the quadrant areas F(x, y) (the disk in
/// {X ≤ x, Y ≤ y}) at its four corners; F is evaluated once per lattice corner of the
/// footprint from one arctangent per lattice line, instead of four triangle–circle areas with
/// their arctangents per cell ([`disk_rectangle_area`]). A cell the disk misses is skipped
/// and a cell it covers is exactly 1, as before.
pub fn disk_cell_fractions(
    grid: &Grid,
    center: [Real; 2],
    radius: Real,
    periodic: [bool; 2],
    out: &mut Vec<(usize, Real)>,
) {
    let h = grid.h;
    let r = radius;
    let (ox, oy) = (grid.origin.x, grid.origin.y);
    let [i0, i1, j0, j1] = footprint(grid, center, r);
    let area = grid.cell_volume();
    let lines = (i1 - i0 + 2) as usize;
    if lines > MAX_LINES {
        return disk_cell_fractions_by_cell(grid, center, r, periodic, out);
    }
    // the vertical lattice lines: x clamped to the disk, and the half-area left of each
    let (mut xb, mut sx) = ([0.0; MAX_LINES], [0.0; MAX_LINES]);
    for k in 0..lines {
        xb[k] = (ox + (i0 + k as i64) as Real * h - center[0]).clamp(-r, r);
        sx[k] = half_area_left(xb[k], r);
    }
    let quadrants = |j: i64, f: &mut [Real; MAX_LINES]| {
        let line = Line::new(oy + j as Real * h - center[1], r);
        for k in 0..lines {
            f[k] = line.quadrant(xb[k], sx[k], r);
        }
    };
    let (mut below, mut above) = ([0.0; MAX_LINES], [0.0; MAX_LINES]);
    quadrants(j0, &mut below);
    let inside_one_cell = i0 == i1 && j0 == j1;
    for j in j0..=j1 {
        quadrants(j + 1, &mut above);
        if let Some(jj) = wrapped(j, grid.ny, periodic[1]) {
            for (k, i) in (i0..=i1).enumerate() {
                let Some(ii) = wrapped(i, grid.nx, periodic[0]) else { continue };
                let (x0, y0) = (ox + i as Real * h, oy + j as Real * h);
                let a = match overlap(center, r, x0, x0 + h, y0, y0 + h) {
                    Overlap::Missed => continue,
                    Overlap::Covered => area,
                    Overlap::Cut if inside_one_cell => std::f64::consts::PI * r * r,
                    Overlap::Cut => above[k + 1] - above[k] - below[k + 1] + below[k],
                };
                if a > 0.0 {
                    out.push((grid.cell(ii, jj), (a / area).min(1.0)));
                }
            }
        }
        std::mem::swap(&mut below, &mut above);
    }
}

/// [`disk_cell_fractions`] cell by cell with [`disk_rectangle_area`].
fn disk_cell_fractions_by_cell(
    grid: &Grid,
    center: [Real; 2],
    radius: Real,
    periodic: [bool; 2],
    out: &mut Vec<(usize, Real)>,
) {
    let h = grid.h;
    let (ox, oy) = (grid.origin.x, grid.origin.y);
    let [i0, i1, j0, j1] = footprint(grid, center, radius);
    let area = grid.cell_volume();
    for j in j0..=j1 {
        let Some(jj) = wrapped(j, grid.ny, periodic[1]) else { continue };
        for i in i0..=i1 {
            let Some(ii) = wrapped(i, grid.nx, periodic[0]) else { continue };
            let (x0, y0) = (ox + i as Real * h, oy + j as Real * h);
            let a = disk_rectangle_area(center, radius, x0, x0 + h, y0, y0 + h);
            if a > 0.0 {
                // a covered cell is exactly 1 (x0 + h − x0 is h only to round-off)
                out.push((grid.cell(ii, jj), (a / area).min(1.0)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector;
    use std::f64::consts::PI;

    #[test]
    fn hand_values() {
        // a unit disk centred on a corner of a large square: a quarter
        assert!((disk_rectangle_area([0.0, 0.0], 1.0, 0.0, 5.0, 0.0, 5.0) - PI / 4.0).abs() < 1e-15);
        // centred on an edge: a half
        assert!((disk_rectangle_area([0.0, 0.0], 1.0, -5.0, 5.0, 0.0, 5.0) - PI / 2.0).abs() < 1e-15);
        // a segment: the part of the unit disk above y = 0.5 is π/3 − √3/4
        let seg = PI / 3.0 - 3f64.sqrt() / 4.0;
        assert!((disk_rectangle_area([0.0, 0.0], 1.0, -2.0, 2.0, 0.5, 2.0) - seg).abs() < 1e-15);
        // inside the disk: the square itself
        assert_eq!(disk_rectangle_area([0.0, 0.0], 1.0, -0.5, 0.5, -0.5, 0.5), 1.0);
        // apart
        assert_eq!(disk_rectangle_area([0.0, 0.0], 1.0, 1.0, 2.0, 1.0, 2.0), 0.0);
        // the square [0, 1]² cut by the unit disk: π/4
        assert!((disk_rectangle_area([0.0, 0.0], 1.0, 0.0, 1.0, 0.0, 1.0) - PI / 4.0).abs() < 1e-15);
    }

    #[test]
    fn quadrant_areas_give_the_per_cell_areas() {
        // the lattice path against the four triangle–circle areas of each cell, for disks from
        // a tenth of a cell to five cells across, anywhere, on periodic and walled sides
        let g = Grid::new(16, 12, 0.125, Vector::new(-0.3, 0.2));
        let mut worst: Real = 0.0;
        for (k, r) in [0.006, 0.05, 0.0625, 0.13, 0.31].into_iter().enumerate() {
            for s in 0..200 {
                let t = s as Real * 0.61803398875 + k as Real;
                let c = [-0.3 + 2.0 * (0.5 + 0.5 * t.sin()), 0.2 + 1.5 * (0.5 + 0.5 * (1.7 * t).cos())];
                for periodic in [[false, false], [true, true], [true, false]] {
                    let (mut fast, mut slow) = (Vec::new(), Vec::new());
                    disk_cell_fractions(&g, c, r, periodic, &mut fast);
                    disk_cell_fractions_by_cell(&g, c, r, periodic, &mut slow);
                    // the same cells (a sliver of 1e-15 may fall on either side of zero)
                    let big =
                        |v: &Vec<(usize, Real)>| v.iter().filter(|e| e.1 > 1e-13).map(|e| e.0).collect::<Vec<_>>();
                    assert_eq!(big(&fast), big(&slow), "r {r} at {c:?}");
                    for (a, b) in fast.iter().zip(&slow).filter(|(a, b)| a.0 == b.0) {
                        worst = worst.max((a.1 - b.1).abs());
                    }
                    assert!(fast.iter().all(|e| e.1 > 0.0 && e.1 <= 1.0));
                }
            }
        }
        // fractions of a cell: agreement to a few ulps of the disk's area
        assert!(worst < 2e-14, "largest difference {worst:e}");
    }

    #[test]
    fn fractions_sum_to_the_disk_and_never_exceed_one() {
        let g = Grid::new(16, 16, 0.125, Vector::zeros());
        for (k, r) in [0.01, 0.0625, 0.2, 0.37].into_iter().enumerate() {
            for s in 0..50 {
                let t = s as Real * 0.61803398875 + k as Real;
                let c = [1.0 + 0.5 * t.sin(), 1.0 + 0.5 * (1.3 * t).cos()];
                let mut out = Vec::new();
                disk_cell_fractions(&g, c, r, [false, false], &mut out);
                let sum: Real = out.iter().map(|(_, th)| th * g.cell_volume()).sum();
                assert!((sum - PI * r * r).abs() < 1e-14, "r {r} at {c:?}: {sum} vs {}", PI * r * r);
                assert!(out.iter().all(|(_, th)| *th > 0.0 && *th <= 1.0));
            }
        }
    }
}
