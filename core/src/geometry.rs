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

/// Area of the disk (centre `c`, radius `r`) inside the rectangle `[x0, x1] × [y0, y1]`.
pub fn disk_rectangle_area(c: [Real; 2], r: Real, x0: Real, x1: Real, y0: Real, y1: Real) -> Real {
    // nearest point of the rectangle to the centre: beyond r, no overlap
    let nx = c[0].clamp(x0, x1) - c[0];
    let ny = c[1].clamp(y0, y1) - c[1];
    if nx * nx + ny * ny >= r * r {
        return 0.0;
    }
    // farthest corner within r: the whole rectangle is inside
    let fx = (x0 - c[0]).abs().max((x1 - c[0]).abs());
    let fy = (y0 - c[1]).abs().max((y1 - c[1]).abs());
    if fx * fx + fy * fy <= r * r {
        return (x1 - x0) * (y1 - y0);
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

/// The cells a disk covers and the fraction θ of each it fills (disk ∩ cell area / h²),
/// appended to `out` as `(cell index, θ)`. On a periodic side the disk wraps around; on
/// any other side the part beyond the domain is not counted (a body inside the domain
/// loses nothing: Σ θ h² = π r² to round-off).
pub fn disk_cell_fractions(
    grid: &Grid,
    center: [Real; 2],
    radius: Real,
    periodic: [bool; 2],
    out: &mut Vec<(usize, Real)>,
) {
    let h = grid.h;
    let (ox, oy) = (grid.origin.x, grid.origin.y);
    let i0 = ((center[0] - radius - ox) / h).floor() as i64;
    let i1 = ((center[0] + radius - ox) / h).floor() as i64;
    let j0 = ((center[1] - radius - oy) / h).floor() as i64;
    let j1 = ((center[1] + radius - oy) / h).floor() as i64;
    let (nx, ny) = (grid.nx as i64, grid.ny as i64);
    let area = grid.cell_volume();
    for j in j0..=j1 {
        let jj = if periodic[1] { j.rem_euclid(ny) } else { j };
        if !(0..ny).contains(&jj) {
            continue;
        }
        for i in i0..=i1 {
            let ii = if periodic[0] { i.rem_euclid(nx) } else { i };
            if !(0..nx).contains(&ii) {
                continue;
            }
            let (x0, y0) = (ox + i as Real * h, oy + j as Real * h);
            let a = disk_rectangle_area(center, radius, x0, x0 + h, y0, y0 + h);
            if a > 0.0 {
                // a covered cell is exactly 1 (x0 + h − x0 is h only to round-off)
                out.push((grid.cell(ii as usize, jj as usize), (a / area).min(1.0)));
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
