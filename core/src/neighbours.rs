//! Neighbour search for contact models: the pairs of disks within reach of each other, by
//! a cell list, in O(N) for bounded size ratios.
//!
//! Given the centres x_i and radii R_i of N disks and a search distance s (how far beyond
//! contact a model looks), [`pairs_within`] returns every pair (i < j) with
//! |x_i − x_j| ≤ R_i + R_j + s, with the separation vector x_i − x_j (its minimum image
//! across periodic sides), sorted by (i, j). The disks are binned in square cells of side
//! w ≥ 2 R_max + s, so every pair within reach lies in the same or in adjacent cells: each
//! disk looks at the disks of its 3 × 3 block of cells. With the solid fraction and the
//! size ratio R_max / R_min bounded, a cell holds a bounded number of disks and the cost is
//! O(N) (the number of cells is kept at most a few per disk: a large, sparsely filled domain
//! gets larger cells). The result is deterministic (the same whatever the threads or the
//! binning) and exactly what the brute-force double loop over all pairs finds with the
//! same test, since each pair's distance is computed the same way (`(x_i − x_j).norm()`,
//! with a period added or subtracted only for a pair that wraps).
//!
//! Periodic sides: along a periodic axis of period L the separation is the minimum image,
//! dx − L where dx > L/2, dx + L where dx < −L/2 (one image: the domain must be wider than
//! twice the reach for no pair to touch through two images). Centres outside a periodic
//! domain are binned by wrapping; outside a non-periodic one, in the edge cells.

use crate::boundary::Boundaries;
use crate::case::Domain;
use crate::grid::Grid;
use crate::math::{vector, Real, Vector, DIM};
use rayon::prelude::*;

/// The box the disks live in, and which of its axes are periodic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchDomain {
    /// Lower-left corner.
    pub origin: Vector,
    /// Extent along x and y (positive).
    pub size: Vector,
    /// Periodic along each axis (period `size[a]`).
    pub periodic: [bool; DIM],
}

impl SearchDomain {
    /// The box of a case's domain, periodic along the axes whose sides are `Periodic`.
    pub fn of(domain: &Domain, boundaries: &Boundaries) -> Self {
        SearchDomain { origin: vector(domain.origin), size: vector(domain.size), periodic: boundaries.periodic_axes() }
    }

    /// The box of a grid (its origin and `size()`), periodic as `boundaries` say: what the
    /// contact models search in.
    pub fn of_grid(grid: &Grid, boundaries: &Boundaries) -> Self {
        SearchDomain { origin: grid.origin, size: grid.size(), periodic: boundaries.periodic_axes() }
    }
}

/// One pair of disks within reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// The lower index.
    pub i: usize,
    /// The higher index.
    pub j: usize,
    /// x_i − x_j, the minimum image across periodic sides.
    pub separation: Vector,
    /// |x_i − x_j| (`separation.norm()`).
    pub distance: Real,
}

/// The minimum image of a difference `d` along an axis of period `l` (unchanged, bit for
/// bit, when |d| ≤ l/2 or the axis is not periodic).
#[inline]
pub fn minimum_image(d: Real, l: Real, periodic: bool) -> Real {
    if !periodic {
        d
    } else if d > 0.5 * l {
        d - l
    } else if d < -0.5 * l {
        d + l
    } else {
        d
    }
}

/// The separation x_i − x_j of two centres in `domain` (minimum image).
#[inline]
pub fn separation(a: Vector, b: Vector, domain: &SearchDomain) -> Vector {
    let d = a - b;
    Vector::from_fn(|k, _| minimum_image(d[k], domain.size[k], domain.periodic[k]))
}

/// Every pair (i < j) of disks with |x_i − x_j| ≤ R_i + R_j + `search` (minimum image),
/// sorted by (i, j); `centres` and `radii` have one entry per disk. O(N) for bounded size
/// ratios and solid fractions (module docs).
pub fn pairs_within(centres: &[Vector], radii: &[Real], search: Real, domain: &SearchDomain) -> Vec<Pair> {
    assert_eq!(centres.len(), radii.len(), "one radius per centre");
    let n = centres.len();
    if n < 2 {
        return Vec::new();
    }
    let r_max = radii.iter().fold(0.0 as Real, |m, &r| if r > m { r } else { m });
    // the reach of the widest pair, with a margin for the rounding of the cell indices
    let reach = 2.0 * r_max + search.max(0.0);
    let mut w = (reach * (1.0 + 1e-9)).max(Real::MIN_POSITIVE);
    if !w.is_finite() {
        return brute(centres, radii, search, domain);
    }
    // few cells per disk at most: larger cells in a large, sparse domain
    let cap = 4 * n + 64;
    let cells_along = |l: Real, w: Real, periodic: bool| -> usize {
        let c = if periodic { (l / w).floor() } else { (l / w).ceil() };
        if c.is_finite() && c >= 1.0 {
            (c as usize).min(1 << 20)
        } else {
            1
        }
    };
    let (mut nx, mut ny);
    loop {
        nx = cells_along(domain.size.x, w, domain.periodic[0]);
        ny = cells_along(domain.size.y, w, domain.periodic[1]);
        if nx.saturating_mul(ny) <= cap {
            break;
        }
        w *= 2.0;
    }
    // cell widths: a periodic axis is divided evenly (each cell at least w wide)
    let wx = if domain.periodic[0] { domain.size.x / nx as Real } else { w };
    let wy = if domain.periodic[1] { domain.size.y / ny as Real } else { w };
    let index = |x: Real, o: Real, wc: Real, nc: usize, periodic: bool| -> usize {
        let c = ((x - o) / wc).floor();
        if periodic {
            let c = if c.is_finite() { c.rem_euclid(nc as Real) } else { 0.0 };
            (c as usize).min(nc - 1)
        } else if c >= 0.0 {
            (c as usize).min(nc - 1)
        } else {
            0
        }
    };
    let cell_of: Vec<(usize, usize)> = centres
        .iter()
        .map(|p| {
            (
                index(p.x, domain.origin.x, wx, nx, domain.periodic[0]),
                index(p.y, domain.origin.y, wy, ny, domain.periodic[1]),
            )
        })
        .collect();
    // counting sort of the disks by cell: the disks of cell c are order[start[c]..start[c + 1]]
    let mut start = vec![0usize; nx * ny + 1];
    for &(cx, cy) in &cell_of {
        start[cy * nx + cx + 1] += 1;
    }
    for c in 0..nx * ny {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut order = vec![0usize; n];
    for (k, &(cx, cy)) in cell_of.iter().enumerate() {
        let c = cy * nx + cx;
        order[fill[c]] = k;
        fill[c] += 1;
    }
    // the distinct neighbour cells along an axis (fewer than 3 where the axis has fewer cells)
    let neighbours = |c: usize, nc: usize, periodic: bool| -> ([usize; 3], usize) {
        let mut out = [0usize; 3];
        let mut m = 0;
        for d in [-1isize, 0, 1] {
            let k = c as isize + d;
            let k = if periodic {
                k.rem_euclid(nc as isize) as usize
            } else if k < 0 || k >= nc as isize {
                continue;
            } else {
                k as usize
            };
            if !out[..m].contains(&k) {
                out[m] = k;
                m += 1;
            }
        }
        (out, m)
    };
    let mut pairs = Vec::new();
    let mut mine: Vec<Pair> = Vec::new();
    for (i, &(cx, cy)) in cell_of.iter().enumerate() {
        let (xs, mx) = neighbours(cx, nx, domain.periodic[0]);
        let (ys, my) = neighbours(cy, ny, domain.periodic[1]);
        mine.clear();
        for &y in &ys[..my] {
            for &x in &xs[..mx] {
                let c = y * nx + x;
                for &j in &order[start[c]..start[c + 1]] {
                    if j <= i {
                        continue;
                    }
                    if let Some(p) = test(i, j, centres, radii, search, domain) {
                        mine.push(p);
                    }
                }
            }
        }
        mine.sort_unstable_by_key(|p| p.j);
        pairs.extend_from_slice(&mine);
    }
    pairs
}

/// The pair (i, j) if within reach.
#[inline]
fn test(i: usize, j: usize, centres: &[Vector], radii: &[Real], search: Real, domain: &SearchDomain) -> Option<Pair> {
    let separation = separation(centres[i], centres[j], domain);
    let distance = separation.norm();
    (distance <= radii[i] + radii[j] + search).then_some(Pair { i, j, separation, distance })
}

/// The O(N²) double loop over all pairs with the same test as [`pairs_within`] (for
/// testing it, and for inputs a cell list cannot bin).
pub fn brute(centres: &[Vector], radii: &[Real], search: Real, domain: &SearchDomain) -> Vec<Pair> {
    let mut pairs = Vec::new();
    for i in 0..centres.len() {
        for j in (i + 1)..centres.len() {
            if let Some(p) = test(i, j, centres, radii, search, domain) {
                pairs.push(p);
            }
        }
    }
    pairs
}

/// A Verlet list over [`pairs_within`] for a search repeated while the disks move little
/// (the contact sub-steps of one fluid step): it keeps the pairs within reach plus a skin
/// of the centres it was built at, and while no centre has moved more than 0.45 × skin
/// since (minimum image), every pair within reach now is among them (by the triangle
/// inequality, with a margin for rounding), so a call only tests those candidates. A call
/// returns exactly what [`pairs_within`] returns (the same pairs, the same order, the same
/// separations: each candidate goes through the same test), so the list is an accelerator
/// with no state of its own to checkpoint: a fresh one gives bit-identical results. It is
/// rebuilt when a centre moved too far, or the number of disks, a radius, the search
/// distance or the domain changed.
#[derive(Clone, Debug, Default)]
pub struct VerletPairs {
    /// The skin as a fraction of the largest radius (0 rebuilds every call).
    skin_fraction: Real,
    skin: Real,
    reference: Vec<Vector>,
    radii: Vec<Real>,
    search: Real,
    domain: Option<SearchDomain>,
    candidates: Vec<(usize, usize)>,
    /// Per chunk of the candidates, the pairs it found (reused from call to call).
    found: Vec<Vec<Pair>>,
    builds: u64,
    calls: u64,
}

/// Candidates (and centres) per parallel chunk of [`VerletPairs`]: large enough that a
/// chunk's work outweighs a task's.
const CHUNK: usize = 2048;

impl VerletPairs {
    /// A list whose skin is `skin_fraction` × the largest radius (e.g. 0.5).
    pub fn new(skin_fraction: Real) -> Self {
        VerletPairs { skin_fraction: skin_fraction.max(0.0), ..Default::default() }
    }

    /// The skin of the list as last built (0 before): while the list holds (a call did not
    /// rebuild it), no centre is farther than 0.45 × skin from where it was at the build.
    pub fn skin(&self) -> Real {
        self.skin
    }

    /// How many calls rebuilt the list, and how many calls there were.
    pub fn counts(&self) -> (u64, u64) {
        (self.builds, self.calls)
    }

    fn valid(&self, centres: &[Vector], radii: &[Real], search: Real, domain: &SearchDomain) -> bool {
        if self.domain.as_ref() != Some(domain)
            || self.search.to_bits() != search.to_bits()
            || self.radii.len() != radii.len()
            || self.radii.iter().zip(radii).any(|(a, b)| a.to_bits() != b.to_bits())
        {
            return false;
        }
        let limit = 0.45 * self.skin;
        centres
            .par_chunks(CHUNK)
            .zip(self.reference.par_chunks(CHUNK))
            .all(|(now, then)| now.iter().zip(then).all(|(&a, &b)| separation(a, b, domain).norm() <= limit))
    }

    /// [`pairs_within`]`(centres, radii, search, domain)`, from the list while it holds.
    pub fn pairs_within(
        &mut self,
        centres: &[Vector],
        radii: &[Real],
        search: Real,
        domain: &SearchDomain,
    ) -> Vec<Pair> {
        let mut out = Vec::new();
        self.pairs_within_into(centres, radii, search, domain, &mut out);
        out
    }

    /// [`VerletPairs::pairs_within`] into `out` (cleared first), the candidates tested in
    /// parallel chunks whose finds are appended in order (the same pairs in the same order
    /// whatever the threads). While the list holds nothing is allocated once `out` and the
    /// chunks' buffers have grown: what a contact model calls in every sub-step.
    pub fn pairs_within_into(
        &mut self,
        centres: &[Vector],
        radii: &[Real],
        search: Real,
        domain: &SearchDomain,
        out: &mut Vec<Pair>,
    ) {
        assert_eq!(centres.len(), radii.len(), "one radius per centre");
        self.calls += 1;
        if !self.valid(centres, radii, search, domain) {
            let r_max = radii.iter().fold(0.0 as Real, |m, &r| if r > m { r } else { m });
            self.skin = self.skin_fraction * r_max;
            self.candidates =
                pairs_within(centres, radii, search.max(0.0) + self.skin, domain).iter().map(|p| (p.i, p.j)).collect();
            self.reference.clear();
            self.reference.extend_from_slice(centres);
            self.radii.clear();
            self.radii.extend_from_slice(radii);
            self.search = search;
            self.domain = Some(*domain);
            self.builds += 1;
        }
        let chunks = self.candidates.len().div_ceil(CHUNK);
        if self.found.len() < chunks {
            self.found.resize_with(chunks, Vec::new);
        }
        self.found[..chunks].par_iter_mut().zip(self.candidates.par_chunks(CHUNK)).for_each(|(found, chunk)| {
            found.clear();
            found.extend(chunk.iter().filter_map(|&(i, j)| test(i, j, centres, radii, search, domain)));
        });
        out.clear();
        for found in &mut self.found[..chunks] {
            out.append(found);
        }
    }
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;

    /// `n` random disks of radii in [r, 2r] in a unit-aspect box of side `l`.
    fn packing(seed: u64, n: usize, l: Real, r: Real) -> (Vec<Vector>, Vec<Real>) {
        let mut rng = fastrand::Rng::with_seed(seed);
        let centres = (0..n).map(|_| Vector::new(l * rng.f64(), l * rng.f64())).collect();
        let radii = (0..n).map(|_| r * (1.0 + rng.f64())).collect();
        (centres, radii)
    }

    fn check(seed: u64, n: usize, periodic: (bool, bool)) -> usize {
        // solid fraction about 0.3 with radii in [r, 2r]: π r² (7/3) n = 0.3 l²
        let l = 1.0;
        let r = (0.3 * l * l / (std::f64::consts::PI * 7.0 / 3.0 * n as Real)).sqrt();
        let (c, radii) = packing(seed, n, l, r);
        let domain =
            SearchDomain { origin: Vector::zeros(), size: Vector::new(l, l), periodic: [periodic.0, periodic.1] };
        let search = 0.5 * r;
        let fast = pairs_within(&c, &radii, search, &domain);
        let slow = brute(&c, &radii, search, &domain);
        assert_eq!(fast, slow, "seed {seed}, {n} disks, periodic {periodic:?}");
        fast.len()
    }

    /// The Verlet list returns what the plain search returns, call after call, while the
    /// disks drift (periodic and walled boxes), and rebuilds only when one has moved far.
    #[test]
    fn the_verlet_list_returns_the_pairs_of_the_plain_search() {
        for periodic in [(false, false), (true, true)] {
            let n = 400;
            let r = (0.3 / (std::f64::consts::PI * 7.0 / 3.0 * n as Real)).sqrt();
            let (mut c, radii) = packing(7, n, 1.0, r);
            let domain = SearchDomain {
                origin: Vector::zeros(),
                size: Vector::new(1.0, 1.0),
                periodic: [periodic.0, periodic.1],
            };
            let mut rng = fastrand::Rng::with_seed(3);
            let velocities: Vec<Vector> = (0..n).map(|_| Vector::new(rng.f64() - 0.5, rng.f64() - 0.5)).collect();
            let mut list = VerletPairs::new(0.5);
            let step = 0.01 * r;
            for _ in 0..200 {
                let listed = list.pairs_within(&c, &radii, 0.1 * r, &domain);
                assert_eq!(listed, pairs_within(&c, &radii, 0.1 * r, &domain), "periodic {periodic:?}");
                for (x, v) in c.iter_mut().zip(&velocities) {
                    *x += step * v;
                }
            }
            // the fastest disk moves at most 0.71 × 0.01 r a call: a skin of 0.5 × 2r holds
            // for ≥ 63 calls, so 200 calls take at most 4 builds
            let (builds, calls) = list.counts();
            assert_eq!(calls, 200);
            assert!((2..=4).contains(&builds), "{builds} builds");
        }
    }

    #[test]
    fn the_cell_list_finds_the_pairs_of_brute_force() {
        let mut wrapped = 0;
        let mut found = 0;
        for seed in 0..20 {
            for &n in &[2usize, 7, 100, 800] {
                for periodic in [(false, false), (true, false), (false, true), (true, true)] {
                    found += check(seed, n, periodic);
                }
            }
        }
        // pairs across periodic sides are found too (the minimum image differs from x_i − x_j)
        for seed in 0..5 {
            let n = 400;
            let r = (0.3 / (std::f64::consts::PI * 7.0 / 3.0 * n as Real)).sqrt();
            let (c, radii) = packing(seed, n, 1.0, r);
            let domain = SearchDomain { origin: Vector::zeros(), size: Vector::new(1.0, 1.0), periodic: [true, true] };
            wrapped +=
                pairs_within(&c, &radii, 0.5 * r, &domain).iter().filter(|p| p.separation != c[p.i] - c[p.j]).count();
        }
        eprintln!("{found} pairs as brute force finds them, {wrapped} across periodic sides");
        assert!(found > 10_000, "{found} pairs only: the packings are too sparse to test");
        assert!(wrapped > 20, "{wrapped} wrapped pairs only");
    }

    #[test]
    fn a_pair_across_a_periodic_side_comes_with_its_minimum_image() {
        let domain =
            SearchDomain { origin: Vector::new(-1.0, 0.0), size: Vector::new(2.0, 1.0), periodic: [true, false] };
        let c = [Vector::new(0.95, 0.5), Vector::new(-0.97, 0.52), Vector::new(0.0, 0.5)];
        let r = [0.03, 0.03, 0.03];
        let p = pairs_within(&c, &r, 0.03, &domain);
        assert_eq!(p.len(), 1);
        assert_eq!((p[0].i, p[0].j), (0, 1));
        assert!((p[0].separation - Vector::new(-0.08, -0.02)).norm() < 1e-12, "{:?}", p[0]);
        // not periodic: none
        let closed = SearchDomain { periodic: [false, domain.periodic[1]], ..domain };
        assert!(pairs_within(&c, &r, 0.03, &closed).is_empty());
        // few cells along a periodic axis (a domain narrower than three reaches): no pair twice
        let narrow = SearchDomain { size: Vector::new(0.1, 1.0), origin: Vector::zeros(), ..domain };
        let c = [Vector::new(0.01, 0.5), Vector::new(0.09, 0.5), Vector::new(0.05, 0.52)];
        assert_eq!(pairs_within(&c, &r, 0.03, &narrow), brute(&c, &r, 0.03, &narrow));
        assert_eq!(pairs_within(&c, &r, 0.03, &narrow).len(), 3);
    }
}
