//! The statistics of a `Suspension` monitor: one row of scalars per sample and a profile
//! along an axis, from the bodies of one field (docs/monitors.md, "Suspension").
//!
//! Every body counts as the disk of its radius (`BodyState::radius`: a disk's own, the
//! disk of equal area for a rectangle), of area a = πr². With A the domain's area and the
//! sums over the field's bodies:
//!
//! - `bodies`: their number N;
//! - `solid_fraction`: Σ a / A;
//! - `u_x, u_y`: the area-weighted mean velocity U = Σ a u / Σ a (mass-weighted when the
//!   bodies share a density, as a field's do by default);
//! - `settling_velocity`: U·ĝ, ĝ = g/|g| the direction of gravity (positive when the
//!   bodies move with gravity, down); without gravity ĝ is minus the monitor's axis;
//! - `temperature`: the granular temperature per unit mass,
//!   T = Σ a |u − U|² / (2 Σ a) (two translational degrees of freedom; rotation excluded);
//! - `bed_height`: the level z along the axis (a coordinate, y for `Y`) below which the
//!   fraction `bed_fraction` of the solid area lies, each disk split exactly by the line
//!   z = const (circular segments), found by bisection to round-off;
//! - `contacts`: the pairs of bodies whose gap |x_i − x_j| − r_i − r_j is at most
//!   `contact_gap` + 10⁻⁹ (r_i + r_j) (the nearest image across a periodic side), found on
//!   a grid of cells at least as wide as the largest contact distance: O(N);
//! - `wall_contacts`: the (body, wall) pairs with gap at most `contact_gap` + 10⁻⁹ r, for
//!   the sides that are walls for bodies (every side but a `Periodic` one, as for the
//!   contact models: an inflow or an outflow of the fluid too); a body in a corner touches
//!   two.
//!
//! The profiles cut the domain into `bins` slabs of equal width across the axis; per slab,
//! `solid_fraction` is the area of the disks inside it (each disk's exact circular
//! segments; across a periodic side along the axis, its image's) over the slab's area,
//! and `u_x, u_y` the velocity weighted by that area (empty where the slab holds no solid).

use crate::boundary::{Boundaries, Boundary, Side};
use crate::math::{vector, Real, Vector, DIM};
use crate::monitor::Axis;
use crate::neighbours::{pairs_within, SearchDomain};
use crate::plugin::BodyState;
use std::f64::consts::PI;

/// The row's columns (after `step,time`).
pub const COLUMNS: [&str; 9] = [
    "bodies",
    "solid_fraction",
    "u_x",
    "u_y",
    "settling_velocity",
    "temperature",
    "bed_height",
    "contacts",
    "wall_contacts",
];

/// The columns of `monitors/<name>_profiles.csv`, one row per slab and sample.
pub const PROFILE_COLUMNS: [&str; 7] = ["step", "time", "bin", "centre", "solid_fraction", "u_x", "u_y"];

/// What the statistics need of the case.
#[derive(Clone, Debug)]
pub struct Geometry {
    /// Lower-left corner of the domain.
    pub origin: [Real; DIM],
    /// Its size.
    pub size: [Real; DIM],
    /// Periodic along each axis.
    pub periodic: [bool; DIM],
    /// Whether the left, right, bottom and top sides are walls.
    pub walls: [bool; 4],
    /// The unit vector of gravity (minus the axis without gravity).
    pub down: [Real; 2],
    /// The axis of the profiles and the bed height.
    pub axis: Axis,
    /// Slabs of the profiles.
    pub bins: usize,
    /// Fraction of the solid area below the bed height.
    pub bed_fraction: Real,
    /// Largest gap of a contact.
    pub contact_gap: Real,
}

impl Geometry {
    /// The geometry of a monitor on a domain with these boundaries and gravity.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        origin: [Real; DIM],
        size: [Real; DIM],
        boundaries: &Boundaries,
        gravity: [Real; DIM],
        axis: Axis,
        bins: usize,
        bed_fraction: Real,
        contact_gap: Real,
    ) -> Self {
        let wall = |s: Side| boundaries.side(s) != Boundary::Periodic;
        let g = gravity[0].hypot(gravity[1]);
        let down = if g > 0.0 {
            [gravity[0] / g, gravity[1] / g]
        } else if axis == Axis::X {
            [-1.0, 0.0]
        } else {
            [0.0, -1.0]
        };
        Self {
            origin,
            size,
            periodic: boundaries.periodic_axes(),
            walls: [wall(Side::Left), wall(Side::Right), wall(Side::Bottom), wall(Side::Top)],
            down,
            axis,
            bins,
            bed_fraction,
            contact_gap,
        }
    }

    fn a(&self) -> usize {
        if self.axis == Axis::X {
            0
        } else {
            1
        }
    }
}

/// The area of the disk of radius `r` centred at `c` (along the axis) below the level `z`:
/// r² (asin s + s √(1 − s²)) + πr²/2 with s = (z − c)/r; 0 and πr² exactly beyond it.
pub fn area_below(c: Real, r: Real, z: Real) -> Real {
    let s = (z - c) / r;
    if s <= -1.0 {
        0.0
    } else if s >= 1.0 {
        PI * r * r
    } else {
        r * r * (s.asin() + s * (1.0 - s * s).sqrt()) + 0.5 * PI * r * r
    }
}

/// One sample: the row (in the order of [`COLUMNS`]) and the profile, per slab
/// (centre, solid fraction, u_x, u_y).
pub fn sample(geometry: &Geometry, bodies: &[&BodyState]) -> (Vec<Real>, Vec<[Real; 4]>) {
    let g = geometry;
    let area: Real = g.size[0] * g.size[1];
    let (mut sa, mut su, mut sv) = (0.0, 0.0, 0.0);
    for b in bodies {
        let a = PI * b.radius * b.radius;
        sa += a;
        su += a * b.velocity.x;
        sv += a * b.velocity.y;
    }
    let (ux, uy) = if sa > 0.0 { (su / sa, sv / sa) } else { (Real::NAN, Real::NAN) };
    let mut fluct = 0.0;
    for b in bodies {
        let a = PI * b.radius * b.radius;
        let (dx, dy) = (b.velocity.x - ux, b.velocity.y - uy);
        fluct += a * (dx * dx + dy * dy);
    }
    let temperature = if sa > 0.0 { 0.5 * fluct / sa } else { Real::NAN };
    let settling = ux * g.down[0] + uy * g.down[1] + 0.0;
    let (contacts, walls) = contacts(g, bodies);
    let row = vec![
        bodies.len() as Real,
        sa / area,
        ux,
        uy,
        settling,
        temperature,
        bed_height(g, bodies, sa),
        contacts as Real,
        walls as Real,
    ];
    (row, profile(g, bodies))
}

/// The level below which `bed_fraction` of the solid area lies (bisection on the exact
/// area below a level, which grows monotonically from 0 to the total).
fn bed_height(g: &Geometry, bodies: &[&BodyState], total: Real) -> Real {
    if bodies.is_empty() {
        return Real::NAN;
    }
    let a = g.a();
    let (mut lo, mut hi) = (Real::INFINITY, Real::NEG_INFINITY);
    for b in bodies {
        let c = b.position[a];
        lo = lo.min(c - b.radius);
        hi = hi.max(c + b.radius);
    }
    let target = g.bed_fraction * total;
    let below = |z: Real| -> Real { bodies.iter().map(|b| area_below(b.position[a], b.radius, z)).sum() };
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if below(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// The solid fraction and area-weighted velocity of each slab.
fn profile(g: &Geometry, bodies: &[&BodyState]) -> Vec<[Real; 4]> {
    let a = g.a();
    let (z0, length) = (g.origin[a], g.size[a]);
    let n = g.bins;
    let width = length / n as Real;
    let slab = width * g.size[1 - a];
    let mut sums = vec![[0.0; 3]; n];
    let images: &[Real] = if g.periodic[a] { &[-1.0, 0.0, 1.0] } else { &[0.0] };
    for b in bodies {
        let r = b.radius;
        for &k in images {
            let c = b.position[a] + k * length;
            if c + r <= z0 || c - r >= z0 + length {
                continue;
            }
            let first = (((c - r - z0) / width).floor().max(0.0) as usize).min(n - 1);
            let last = (((c + r - z0) / width).floor().max(0.0) as usize).min(n - 1);
            for (j, s) in sums.iter_mut().enumerate().take(last + 1).skip(first) {
                let lower = if j == 0 { z0 } else { z0 + j as Real * width };
                let upper = if j + 1 == n { z0 + length } else { z0 + (j + 1) as Real * width };
                let part = area_below(c, r, upper) - area_below(c, r, lower);
                if part > 0.0 {
                    s[0] += part;
                    s[1] += part * b.velocity.x;
                    s[2] += part * b.velocity.y;
                }
            }
        }
    }
    sums.iter()
        .enumerate()
        .map(|(j, s)| {
            let centre = z0 + (j as Real + 0.5) * width;
            let (u, v) = if s[0] > 0.0 { (s[1] / s[0], s[2] / s[0]) } else { (Real::NAN, Real::NAN) };
            [centre, s[0] / slab, u, v]
        })
        .collect()
}

/// The contacts between bodies (the pairs of the cell-list search,
/// [`crate::neighbours::pairs_within`], with the minimum image across periodic sides) and
/// with the walls.
fn contacts(g: &Geometry, bodies: &[&BodyState]) -> (u64, u64) {
    let tol = |r: Real| g.contact_gap + 1e-9 * r;
    let mut walls = 0u64;
    let (x0, y0) = (g.origin[0], g.origin[1]);
    let (x1, y1) = (x0 + g.size[0], y0 + g.size[1]);
    for b in bodies {
        let (x, y, r) = (b.position.x, b.position.y, b.radius);
        let gaps = [x - x0 - r, x1 - x - r, y - y0 - r, y1 - y - r];
        for (gap, wall) in gaps.iter().zip(g.walls) {
            if wall && *gap <= tol(r) {
                walls += 1;
            }
        }
    }
    let centres: Vec<Vector> = bodies.iter().map(|b| b.position).collect();
    let radii: Vec<Real> = bodies.iter().map(|b| b.radius).collect();
    let r_max = radii.iter().fold(0.0, |m: Real, &r| m.max(r));
    let domain = SearchDomain { origin: vector(g.origin), size: vector(g.size), periodic: g.periodic };
    // the search reaches the largest tolerance; the test is each pair's own
    let pairs = pairs_within(&centres, &radii, tol(2.0 * r_max), &domain)
        .iter()
        .filter(|p| {
            let sum = radii[p.i] + radii[p.j];
            p.distance - sum <= tol(sum)
        })
        .count();
    (pairs as u64, walls)
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;
    use crate::math::Vector;

    fn body(x: Real, y: Real, r: Real) -> BodyState {
        BodyState { radius: r, position: Vector::new(x, y), ..BodyState::default() }
    }

    /// The cell grid finds the pairs a loop over all pairs finds, on a random packing with
    /// touching pairs, walls and periodic sides.
    #[test]
    fn the_cell_grid_counts_the_pairs_of_the_brute_force_loop() {
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as Real / (1u64 << 53) as Real
        };
        let mut bodies = Vec::new();
        for _ in 0..600 {
            let r = 0.01 + 0.01 * next();
            bodies.push(body(next(), 2.0 * next(), r));
            if next() < 0.3 {
                // a touching partner
                let a = 2.0 * PI * next();
                let s = 0.012;
                let (x, y) = (bodies.last().unwrap().position.x, bodies.last().unwrap().position.y);
                bodies.push(body(x + (r + s) * a.cos(), y + (r + s) * a.sin(), s));
            }
        }
        for periodic in [[false, false], [true, false], [true, true]] {
            let g = Geometry {
                origin: [0.0, 0.0],
                size: [1.0, 2.0],
                periodic,
                walls: [true; 4],
                down: [0.0, -1.0],
                axis: Axis::Y,
                bins: 10,
                bed_fraction: 0.99,
                contact_gap: 0.001,
            };
            let refs: Vec<&BodyState> = bodies.iter().collect();
            let (pairs, _) = contacts(&g, &refs);
            let mut brute = 0;
            for i in 0..bodies.len() {
                for j in i + 1..bodies.len() {
                    let (a, b) = (&bodies[i], &bodies[j]);
                    let mut dx = b.position.x - a.position.x;
                    let mut dy = b.position.y - a.position.y;
                    if periodic[0] {
                        dx -= (dx / 1.0).round();
                    }
                    if periodic[1] {
                        dy -= 2.0 * (dy / 2.0).round();
                    }
                    let sum = a.radius + b.radius;
                    if dx.hypot(dy) - sum <= 0.001 + 1e-9 * sum {
                        brute += 1;
                    }
                }
            }
            eprintln!("{} bodies, periodic {periodic:?}: {brute} pairs", bodies.len());
            assert!(brute > 150, "{brute} touching pairs");
            assert_eq!(pairs, brute, "periodic {periodic:?}");
        }
    }

    /// The cost of a sample of 10,000 bodies (and 40,000: O(N)), printed:
    /// `cargo test --release -p multifield-core suspension_cost -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn suspension_cost() {
        for side in [100usize, 200] {
            let n = side * side;
            let h = 1.0 / side as Real;
            let bodies: Vec<BodyState> = (0..n)
                .map(|k| {
                    let (i, j) = (k % side, k / side);
                    let mut b = body((i as Real + 0.5) * h, (j as Real + 0.5) * h, 0.5 * h);
                    b.velocity = Vector::new((k % 7) as Real, (k % 5) as Real);
                    b
                })
                .collect();
            let refs: Vec<&BodyState> = bodies.iter().collect();
            let g = Geometry {
                origin: [0.0, 0.0],
                size: [1.0, 1.0],
                periodic: [false, false],
                walls: [true; 4],
                down: [0.0, -1.0],
                axis: Axis::Y,
                bins: 100,
                bed_fraction: 0.99,
                contact_gap: 0.0,
            };
            let start = std::time::Instant::now();
            let reps = 10;
            let mut row = Vec::new();
            for _ in 0..reps {
                row = sample(&g, &refs).0;
            }
            let each = start.elapsed().as_secs_f64() / reps as Real;
            eprintln!("{n} bodies: {:.2} ms per sample, {} contacts", 1e3 * each, row[7]);
            // a square lattice of touching disks: 2 side (side − 1) pairs
            assert_eq!(row[7], (2 * side * (side - 1)) as Real);
        }
    }
}
