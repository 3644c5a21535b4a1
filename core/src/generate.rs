//! Body generators (issue 15): disks made from a seed instead of listed by hand.
//!
//! A Lagrangian field's `generate: [...]` entries each fill a rectangle with disks: a
//! number of them (`count`) or as many as reach a solid fraction (`solid_fraction`), their
//! diameters drawn from a distribution, placed at random (random sequential addition) or
//! on a lattice. [`Case::expand_generators`] turns them into ordinary bodies of the field's
//! `region: Bodies([...])` once, before the run is built: everything downstream (bodies.csv,
//! monitors, contact, mass points, checkpoints) sees listed bodies.
//!
//! The random numbers are ChaCha8 (`rand_chacha`) seeded by the entry's `seed`, turned into
//! reals with integer arithmetic and the pure-Rust `libm`, so the same seed gives the same
//! bodies, bit for bit, on every platform and thread count.

use crate::case::{BodyShape, BodySpec, Case, Domain, Motion, Region};
use crate::error::{Error, Result};
use crate::limits::MAX_BODIES;
use crate::math::Real;
use rand_chacha::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The rectangle a generator fills.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rect {
    /// Lower-left corner.
    pub min: [Real; 2],
    /// Upper-right corner.
    pub max: [Real; 2],
}

/// How the diameters are drawn.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Diameter {
    /// Every disk has this diameter.
    Fixed(Real),
    /// Uniform between `min` and `max`.
    Uniform {
        /// Smallest diameter.
        min: Real,
        /// Largest diameter.
        max: Real,
    },
    /// Normal, truncated to `[min, max]` (a draw outside is drawn again).
    Normal {
        /// Mean of the untruncated normal.
        mean: Real,
        /// Standard deviation of the untruncated normal.
        std: Real,
        /// Smallest diameter; default mean − 3 std (which must then be positive).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        min: Option<Real>,
        /// Largest diameter; default mean + 3 std.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max: Option<Real>,
    },
    /// Log-normal: ln d is normal with mean ln `median` and standard deviation `sigma`,
    /// truncated to `[min, max]` (a draw outside is drawn again).
    LogNormal {
        /// Median diameter.
        median: Real,
        /// Standard deviation of ln d.
        sigma: Real,
        /// Smallest diameter; default median · e^(−3 sigma).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        min: Option<Real>,
        /// Largest diameter; default median · e^(3 sigma).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max: Option<Real>,
    },
    /// These diameters, one disk each, in this order.
    List(Vec<Real>),
}

/// The lattice of [`Arrangement::Lattice`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Lattice {
    /// Rows and columns `spacing` apart.
    Square,
    /// Rows `spacing` · √3/2 apart, every other row shifted by `spacing`/2.
    Hexagonal,
}

/// Where the disks go.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Arrangement {
    /// Random sequential addition: each disk (largest first) at a uniformly drawn free
    /// place, at most `attempts` draws each.
    #[default]
    Random,
    /// The sites of a lattice from the region's lower-left corner, row by row.
    Lattice(Lattice),
}

/// One generator of disks (an entry of a field's `generate: [...]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeneratorSpec {
    /// Prefix of the bodies' names: `<name><k>`, k = 0, 1, … (e.g. `p0`, `p1`, …).
    pub name: String,
    /// The rectangle the disks fill (each wholly inside, at least `min_gap` from its sides).
    pub region: Rect,
    /// How many disks, e.g. `Some(250)`; give this or `solid_fraction`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<usize>,
    /// The fraction of the region's area the disks cover, e.g. `Some(0.2)`: disks are
    /// drawn until the next one would overshoot it by more than half its area.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solid_fraction: Option<Real>,
    /// The diameters.
    pub diameter: Diameter,
    /// `Random` (default) or `Lattice(Square)` / `Lattice(Hexagonal)`.
    #[serde(default)]
    pub arrangement: Arrangement,
    /// Lattice only: distance between neighbouring sites; default the largest diameter
    /// plus `min_gap`, and 10⁻⁹ of that, so that rounding never makes neighbours overlap (a
    /// row of width w then holds ⌊(w − 2 min_gap − d_max) / spacing⌋ + 1 disks).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spacing: Option<Real>,
    /// Smallest gap between two disks' surfaces, and between a disk and the region's sides
    /// or a listed body (length); default 0 (touching allowed).
    #[serde(default)]
    pub min_gap: Real,
    /// The seed of the random numbers (default 0): the same seed, the same bodies.
    #[serde(default)]
    pub seed: u64,
    /// Random only: draws of a place per disk before the generator gives up (default 10000).
    #[serde(default = "default_attempts")]
    pub attempts: u32,
    /// Every disk's motion (default `Free`).
    #[serde(default)]
    pub motion: Motion,
    /// Every disk's initial velocity.
    #[serde(default)]
    pub velocity: [Real; 2],
    /// Every disk's initial angular velocity.
    #[serde(default)]
    pub angular_velocity: Real,
    /// Every disk's material density; default the field's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<Real>,
}

fn default_attempts() -> u32 {
    10_000
}

/// Most attempts per disk.
pub const MAX_ATTEMPTS: u32 = 1_000_000;

/// The largest solid fraction random sequential addition of equal disks reaches (its
/// jamming limit, 0.547; Hinrichsen, Feder & Jøssang 1986): a random target must lie below.
pub const RANDOM_LIMIT: Real = 0.547;

/// Draws of a truncated diameter before the truncation is called too narrow.
const TRUNCATION_DRAWS: usize = 1000;

/// What a generator made, for `check`.
#[derive(Clone, Debug, PartialEq)]
pub struct Generated {
    /// The entry, e.g. `fields.disks.generate.0`.
    pub path: String,
    /// The prefix of the names.
    pub name: String,
    /// Disks made.
    pub count: usize,
    /// Σ π d²/4 over the region's area.
    pub region_fraction: Real,
    /// Σ π d²/4 over the domain's area.
    pub domain_fraction: Real,
    /// Smallest gap between two of its disks' surfaces (`None` for one disk).
    pub smallest_gap: Option<Real>,
    /// Smallest distance from one of its disks to a side of the domain.
    pub wall_gap: Real,
    /// Smallest, mean and largest diameter.
    pub diameters: [Real; 3],
}

/// A uniform real in [0, 1): the top 53 bits of the next `u64`.
fn uniform(rng: &mut ChaCha8Rng) -> Real {
    (rng.next_u64() >> 11) as Real * (1.0 / (1u64 << 53) as Real)
}

/// A standard normal (Box–Muller, the cosine branch), with `libm` for the same bits everywhere.
fn normal(rng: &mut ChaCha8Rng) -> Real {
    let u1 = 1.0 - uniform(rng); // (0, 1]
    let u2 = uniform(rng);
    libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * std::f64::consts::PI * u2)
}

impl Diameter {
    /// The smallest and largest diameter it can give (`path` names it in messages).
    fn bounds(&self, path: &str) -> Result<(Real, Real)> {
        let bad = |m: String| Err(Error::invalid(path, m));
        let (lo, hi) = match *self {
            Diameter::Fixed(d) => (d, d),
            Diameter::Uniform { min, max } => (min, max),
            Diameter::Normal { mean, std, min, max } => {
                if !(mean > 0.0 && std >= 0.0) {
                    return bad(format!("Normal(mean: {mean}, std: {std}): need mean > 0 and std ≥ 0"));
                }
                let lo = min.unwrap_or(mean - 3.0 * std);
                if !(lo > 0.0) && min.is_none() {
                    return bad(format!(
                        "mean − 3 std = {lo} is not a diameter: give a positive smallest diameter, e.g. `min: Some({})`",
                        mean / 10.0
                    ));
                }
                (lo, max.unwrap_or(mean + 3.0 * std))
            }
            Diameter::LogNormal { median, sigma, min, max } => {
                if !(median > 0.0 && sigma >= 0.0) {
                    return bad(format!("LogNormal(median: {median}, sigma: {sigma}): need median > 0 and sigma ≥ 0"));
                }
                (min.unwrap_or(median * libm::exp(-3.0 * sigma)), max.unwrap_or(median * libm::exp(3.0 * sigma)))
            }
            Diameter::List(ref list) => {
                if list.is_empty() {
                    return bad("an empty list of diameters: give at least one".into());
                }
                if list.len() > MAX_BODIES {
                    return bad(format!("{} diameters; at most {MAX_BODIES} bodies in one field", list.len()));
                }
                if let Some((k, d)) = list.iter().enumerate().find(|(_, d)| !(**d > 0.0)) {
                    return bad(format!("diameter {k} is {d}: every diameter must be positive"));
                }
                (list.iter().copied().fold(Real::INFINITY, Real::min), list.iter().copied().fold(0.0, Real::max))
            }
        };
        if !(lo > 0.0) {
            return bad(format!("smallest diameter {lo}: diameters must be positive"));
        }
        if !(hi >= lo) {
            return bad(format!("largest diameter {hi} is below the smallest {lo}"));
        }
        Ok((lo, hi))
    }

    /// A rough mean of d² (for the count a solid fraction asks for, before any draw).
    fn mean_square(&self, lo: Real, hi: Real) -> Real {
        match *self {
            Diameter::Fixed(d) => d * d,
            Diameter::Uniform { min, max } => (min * min + min * max + max * max) / 3.0,
            Diameter::Normal { mean, std, .. } => (mean * mean + std * std).clamp(lo * lo, hi * hi),
            Diameter::LogNormal { median, sigma, .. } => {
                (median * median * libm::exp(2.0 * sigma * sigma)).clamp(lo * lo, hi * hi)
            }
            Diameter::List(ref l) => l.iter().map(|d| d * d).sum::<Real>() / l.len() as Real,
        }
    }

    /// The next diameter.
    fn draw(&self, rng: &mut ChaCha8Rng, lo: Real, hi: Real, path: &str) -> Result<Real> {
        let truncated = |rng: &mut ChaCha8Rng, f: &dyn Fn(Real) -> Real| -> Result<Real> {
            for _ in 0..TRUNCATION_DRAWS {
                let d = f(normal(rng));
                if d >= lo && d <= hi {
                    return Ok(d);
                }
            }
            Err(Error::invalid(
                path,
                format!(
                    "[{lo}, {hi}] holds too little of the distribution ({TRUNCATION_DRAWS} draws in a row fell \
                     outside): widen min/max or move them towards the centre"
                ),
            ))
        };
        match *self {
            Diameter::Fixed(d) => Ok(d),
            Diameter::Uniform { min, max } => Ok(min + (max - min) * uniform(rng)),
            Diameter::Normal { mean, std, .. } => truncated(rng, &|z| mean + std * z),
            Diameter::LogNormal { median, sigma, .. } => truncated(rng, &|z| median * libm::exp(sigma * z)),
            Diameter::List(_) => unreachable!("a list is not drawn"),
        }
    }
}

impl GeneratorSpec {
    /// Checks the entry's own values against the domain (cheap: nothing is generated);
    /// `path` is e.g. `fields.disks.generate.0`. Returns the bounds of the diameters.
    pub fn check(&self, path: &str, domain: &Domain) -> Result<(Real, Real)> {
        let at = |k: &str| format!("{path}.{k}");
        let bad = |k: &str, m: String| Err(Error::invalid(at(k), m));
        if self.name.is_empty() {
            return bad("name", "give a prefix for the bodies' names, e.g. `name: \"p\"` (bodies p0, p1, …)".into());
        }
        let Rect { min, max } = self.region;
        if !(min[0] < max[0] && min[1] < max[1]) {
            return bad("region", format!("min {min:?} must lie below and left of max {max:?}"));
        }
        let (x0, y0) = (domain.origin[0], domain.origin[1]);
        let (x1, y1) = (x0 + domain.size[0], y0 + domain.size[1]);
        if min[0] < x0 - 1e-12 || min[1] < y0 - 1e-12 || max[0] > x1 + 1e-12 || max[1] > y1 + 1e-12 {
            return bad(
                "region",
                format!("{min:?}–{max:?} reaches outside the domain [{x0}, {x1}] × [{y0}, {y1}]; move it inside"),
            );
        }
        if !(self.min_gap >= 0.0) {
            return bad("min_gap", format!("{}: must be zero or positive", self.min_gap));
        }
        if !(1..=MAX_ATTEMPTS).contains(&self.attempts) {
            return bad("attempts", format!("{}: must lie in 1..={MAX_ATTEMPTS}", self.attempts));
        }
        if let Some(rho) = self.density {
            if !(rho > 0.0) {
                return bad("density", format!("{rho}: must be positive (omit it for the field's)"));
            }
        }
        let (lo, hi) = self.diameter.bounds(&at("diameter"))?;
        let width = (max[0] - min[0]).min(max[1] - min[1]);
        if hi + 2.0 * self.min_gap > width {
            return bad(
                "diameter",
                format!(
                    "a diameter of {hi} (plus twice min_gap {}) does not fit in the region, {width} across at its \
                     narrowest: use smaller disks or a larger region",
                    self.min_gap
                ),
            );
        }
        let list = matches!(self.diameter, Diameter::List(_));
        let area = (max[0] - min[0]) * (max[1] - min[1]);
        match (self.count, self.solid_fraction) {
            (Some(_), Some(_)) => {
                return bad("count", "give `count` or `solid_fraction`, not both".into());
            }
            (None, None) if !list => {
                return bad("count", "give how many disks: `count: Some(N)` or `solid_fraction: Some(φ)`".into());
            }
            (Some(_), None) | (None, Some(_)) if list => {
                return bad(
                    if self.count.is_some() { "count" } else { "solid_fraction" },
                    "`diameter: List([...])` gives one disk per diameter: leave out count and solid_fraction".into(),
                );
            }
            (Some(n), None) => {
                if n == 0 {
                    return bad("count", "0: give at least one disk".into());
                }
                if n > MAX_BODIES {
                    return bad(
                        "count",
                        format!("{n} bodies; at most {MAX_BODIES} in one field (their overlaps and contacts are checked pair by pair)"),
                    );
                }
            }
            (None, Some(phi)) => {
                let limit = match self.arrangement {
                    Arrangement::Random => RANDOM_LIMIT,
                    Arrangement::Lattice(Lattice::Square) => std::f64::consts::PI / 4.0,
                    Arrangement::Lattice(Lattice::Hexagonal) => std::f64::consts::PI / (2.0 * 3.0f64.sqrt()),
                };
                if !(phi > 0.0 && phi < limit) {
                    let fix = match self.arrangement {
                        Arrangement::Random => {
                            " (random sequential addition jams at 0.547); for a denser packing use \
                             `arrangement: Lattice(Hexagonal)` (up to 0.9069)"
                        }
                        _ => " (the densest packing of this lattice)",
                    };
                    return bad("solid_fraction", format!("{phi}: must lie in (0, {limit:.4}){fix}"));
                }
                let about = phi * area / (std::f64::consts::PI / 4.0 * self.diameter.mean_square(lo, hi));
                if about > MAX_BODIES as Real {
                    return bad(
                        "solid_fraction",
                        format!(
                            "{phi} of the region takes about {about:.0} bodies; at most {MAX_BODIES} in one field: \
                             lower it, use larger disks or a smaller region"
                        ),
                    );
                }
            }
            (None, None) => {}
        }
        match (self.arrangement, self.spacing) {
            (Arrangement::Random, Some(_)) => {
                return bad(
                    "spacing",
                    "only a lattice has a spacing: leave it out, or use `arrangement: Lattice(..)`".into(),
                );
            }
            (Arrangement::Lattice(_), Some(a)) if !(a >= hi + self.min_gap) => {
                return bad(
                    "spacing",
                    format!(
                        "{a}: below the largest diameter {hi} plus min_gap {}: the disks would overlap",
                        self.min_gap
                    ),
                );
            }
            _ => {}
        }
        Ok((lo, hi))
    }

    /// The disks of this entry, avoiding `others` (the field's listed bodies and those of
    /// earlier entries).
    pub fn generate(&self, path: &str, domain: &Domain, others: &[BodySpec]) -> Result<(Vec<BodySpec>, Generated)> {
        let (lo, hi) = self.check(path, domain)?;
        let Rect { min, max } = self.region;
        let area = (max[0] - min[0]) * (max[1] - min[1]);
        let quarter_pi = std::f64::consts::PI / 4.0;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let d_path = format!("{path}.diameter");
        let diameters: Vec<Real> = match (&self.diameter, self.count, self.solid_fraction) {
            (Diameter::List(l), _, _) => l.clone(),
            (_, Some(n), _) => (0..n).map(|_| self.diameter.draw(&mut rng, lo, hi, &d_path)).collect::<Result<_>>()?,
            (_, None, Some(phi)) => {
                let target = phi * area;
                let (mut sum, mut out) = (0.0, Vec::new());
                loop {
                    let d = self.diameter.draw(&mut rng, lo, hi, &d_path)?;
                    let a = quarter_pi * d * d;
                    if sum + a / 2.0 > target {
                        break;
                    }
                    if out.len() == MAX_BODIES {
                        return Err(Error::invalid(
                            format!("{path}.solid_fraction"),
                            format!("{phi} takes more than {MAX_BODIES} bodies, the most one field may have: lower it"),
                        ));
                    }
                    sum += a;
                    out.push(d);
                }
                if out.is_empty() {
                    return Err(Error::invalid(
                        format!("{path}.solid_fraction"),
                        format!("{phi} of the region is less than half a disk: raise it, or use `count`"),
                    ));
                }
                out
            }
            _ => unreachable!("checked: a count or a solid fraction"),
        };
        let g = self.min_gap;
        let mut obstacles = Obstacles::new(self.region, hi / 2.0, g, diameters.len());
        for b in others {
            obstacles.add_body(&b.shape);
        }
        let centers: Vec<[Real; 2]> = match self.arrangement {
            Arrangement::Random => {
                // the largest first (ties in order); each at a free place drawn uniformly
                let mut order: Vec<usize> = (0..diameters.len()).collect();
                order.sort_by(|&a, &b| diameters[b].total_cmp(&diameters[a]).then(a.cmp(&b)));
                let mut centers = vec![[0.0; 2]; diameters.len()];
                let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
                rng.set_stream(1);
                for (placed, &k) in order.iter().enumerate() {
                    let r = diameters[k] / 2.0;
                    let (ax, bx) = (min[0] + r + g, max[0] - r - g);
                    let (ay, by) = (min[1] + r + g, max[1] - r - g);
                    let mut found = None;
                    for _ in 0..self.attempts {
                        let c = [ax + (bx - ax) * uniform(&mut rng), ay + (by - ay) * uniform(&mut rng)];
                        if obstacles.free(c, r) {
                            found = Some(c);
                            break;
                        }
                    }
                    let Some(c) = found else {
                        let what = match (self.count, self.solid_fraction) {
                            (_, Some(phi)) => format!("solid fraction {phi}"),
                            _ => format!("{} disks", diameters.len()),
                        };
                        let reached: Real = order[..placed].iter().map(|&j| quarter_pi * diameters[j].powi(2)).sum();
                        return Err(Error::invalid(
                            path,
                            format!(
                                "random placement could not reach {what}: {placed} of {} disks placed (solid \
                                 fraction {:.4}), then {} attempts found no free place for a disk of diameter {}; \
                                 lower the count or solid fraction, enlarge the region, lower min_gap, or use \
                                 `arrangement: Lattice(Hexagonal)`",
                                diameters.len(),
                                reached / area,
                                self.attempts,
                                diameters[k]
                            ),
                        ));
                    };
                    obstacles.add_disk(c, r);
                    centers[k] = c;
                }
                centers
            }
            Arrangement::Lattice(lattice) => {
                let a = self.spacing.unwrap_or_else(|| default_spacing(hi, g));
                let (dy, shift) = match lattice {
                    Lattice::Square => (a, 0.0),
                    Lattice::Hexagonal => (a * 3.0f64.sqrt() / 2.0, a / 2.0),
                };
                let r = hi / 2.0;
                let (ax, ay) = (min[0] + r + g, min[1] + r + g);
                let (bx, by) = (max[0] - r - g, max[1] - r - g);
                let mut centers = Vec::with_capacity(diameters.len());
                let mut row = 0usize;
                'rows: loop {
                    let y = ay + row as Real * dy;
                    if y > by {
                        break;
                    }
                    let x_first = ax + if row % 2 == 1 { shift } else { 0.0 };
                    let mut col = 0usize;
                    loop {
                        let x = x_first + col as Real * a;
                        if x > bx {
                            break;
                        }
                        let k = centers.len();
                        if k == diameters.len() {
                            break 'rows;
                        }
                        // a site a listed body (or an earlier entry's disk) takes is skipped; the
                        // lattice's own disks are `a` apart
                        if obstacles.free([x, y], diameters[k] / 2.0) {
                            centers.push([x, y]);
                        }
                        col += 1;
                    }
                    row += 1;
                }
                if centers.len() < diameters.len() {
                    return Err(Error::invalid(
                        path,
                        format!(
                            "the lattice of spacing {a} has {} free sites in the region, {} disks asked for: lower \
                             the count or solid fraction, lower the spacing or min_gap, enlarge the region, or use \
                             a hexagonal lattice",
                            centers.len(),
                            diameters.len()
                        ),
                    ));
                }
                centers
            }
        };
        let bodies: Vec<BodySpec> = centers
            .iter()
            .zip(&diameters)
            .enumerate()
            .map(|(k, (c, d))| BodySpec {
                name: format!("{}{k}", self.name),
                shape: BodyShape::Disk { center: *c, radius: d / 2.0 },
                motion: self.motion,
                velocity: self.velocity,
                angular_velocity: self.angular_velocity,
                density: self.density,
            })
            .collect();
        let solid: Real = diameters.iter().map(|d| quarter_pi * d * d).sum();
        let (x0, y0) = (domain.origin[0], domain.origin[1]);
        let (x1, y1) = (x0 + domain.size[0], y0 + domain.size[1]);
        let wall_gap = centers
            .iter()
            .zip(&diameters)
            .map(|(c, d)| {
                let r = d / 2.0;
                (c[0] - r - x0).min(x1 - c[0] - r).min(c[1] - r - y0).min(y1 - c[1] - r)
            })
            .fold(Real::INFINITY, Real::min);
        let disks: Vec<([Real; 2], Real)> = centers.iter().zip(&diameters).map(|(c, d)| (*c, d / 2.0)).collect();
        let report = Generated {
            path: path.to_string(),
            name: self.name.clone(),
            count: bodies.len(),
            region_fraction: solid / area,
            domain_fraction: solid / (domain.size[0] * domain.size[1]),
            smallest_gap: smallest_gap(&disks),
            wall_gap,
            diameters: [lo_of(&diameters), diameters.iter().sum::<Real>() / diameters.len() as Real, hi_of(&diameters)],
        };
        Ok((bodies, report))
    }
}

/// A lattice's default spacing: the largest diameter plus the gap, and a hair (10⁻⁹
/// relative) so that neighbours computed in floating point never overlap by rounding.
pub fn default_spacing(largest: Real, gap: Real) -> Real {
    (largest + gap) * (1.0 + 1e-9)
}

fn lo_of(v: &[Real]) -> Real {
    v.iter().copied().fold(Real::INFINITY, Real::min)
}

fn hi_of(v: &[Real]) -> Real {
    v.iter().copied().fold(0.0, Real::max)
}

/// The smallest gap between two disks' surfaces (centre distance − r₁ − r₂), by a sweep
/// along x; `None` for fewer than two disks.
pub fn smallest_gap(disks: &[([Real; 2], Real)]) -> Option<Real> {
    if disks.len() < 2 {
        return None;
    }
    let r_max = disks.iter().map(|d| d.1).fold(0.0, Real::max);
    let mut order: Vec<usize> = (0..disks.len()).collect();
    order.sort_by(|&a, &b| disks[a].0[0].total_cmp(&disks[b].0[0]));
    let mut best = Real::INFINITY;
    for (i, &k) in order.iter().enumerate() {
        let (c, r) = disks[k];
        for &j in order[..i].iter().rev() {
            let (c2, r2) = disks[j];
            if c[0] - c2[0] - r - r_max > best {
                break;
            }
            let gap = ((c[0] - c2[0]).powi(2) + (c[1] - c2[1]).powi(2)).sqrt() - r - r2;
            best = best.min(gap);
        }
    }
    Some(best)
}

/// The disks placed so far (and the listed bodies) in a grid of cells at least as wide as
/// the largest generated disk plus the gap: a candidate is tested against the 3 × 3 cells
/// around it, bodies larger than that cell one by one.
struct Obstacles {
    origin: [Real; 2],
    cell: Real,
    n: [usize; 2],
    cells: Vec<Vec<u32>>,
    disks: Vec<([Real; 2], Real)>,
    /// Bodies too large for the cells (and every other shape), tested one by one.
    large: Vec<BodyShape>,
    r_max: Real,
    gap: Real,
}

impl Obstacles {
    fn new(region: Rect, r_max: Real, gap: Real, count: usize) -> Obstacles {
        let size = [region.max[0] - region.min[0], region.max[1] - region.min[1]];
        // no more cells than about 4 per disk (a region far larger than its disks), nor
        // 65,536 along a side (a long thin region)
        let floor = (size[0] * size[1] / (4 * count.max(1)) as Real).sqrt().max(size[0].max(size[1]) / 65536.0);
        let cell = (2.0 * r_max + gap).max(floor);
        let n = [((size[0] / cell).ceil() as usize).max(1), ((size[1] / cell).ceil() as usize).max(1)];
        Obstacles {
            origin: region.min,
            cell,
            n,
            cells: vec![Vec::new(); n[0] * n[1]],
            disks: Vec::new(),
            large: Vec::new(),
            r_max,
            gap,
        }
    }

    /// The cell of `c`, clamped into the grid (a body outside the region still meets the
    /// candidates near its side).
    fn cell_of(&self, c: [Real; 2]) -> [usize; 2] {
        let index = |k: usize| {
            let i = ((c[k] - self.origin[k]) / self.cell).floor();
            if i.is_nan() || i < 0.0 {
                0
            } else {
                (i as usize).min(self.n[k] - 1)
            }
        };
        [index(0), index(1)]
    }

    fn add_disk(&mut self, c: [Real; 2], r: Real) {
        if r > self.r_max {
            self.large.push(BodyShape::Disk { center: c, radius: r });
            return;
        }
        let [i, j] = self.cell_of(c);
        self.cells[j * self.n[0] + i].push(self.disks.len() as u32);
        self.disks.push((c, r));
    }

    fn add_body(&mut self, shape: &BodyShape) {
        match *shape {
            BodyShape::Disk { center, radius } => self.add_disk(center, radius),
            _ => self.large.push(shape.clone()),
        }
    }

    /// Whether a disk at `c` of radius `r` keeps the gap to every obstacle.
    fn free(&self, c: [Real; 2], r: Real) -> bool {
        let g = self.gap;
        let apart = |c2: [Real; 2], r2: Real| ((c[0] - c2[0]).powi(2) + (c[1] - c2[1]).powi(2)).sqrt() >= r + r2 + g;
        let [i, j] = self.cell_of(c);
        for jj in j.saturating_sub(1)..=(j + 1).min(self.n[1] - 1) {
            for ii in i.saturating_sub(1)..=(i + 1).min(self.n[0] - 1) {
                for &k in &self.cells[jj * self.n[0] + ii] {
                    let (c2, r2) = self.disks[k as usize];
                    if !apart(c2, r2) {
                        return false;
                    }
                }
            }
        }
        self.large.iter().all(|s| match *s {
            BodyShape::Disk { center, radius } => apart(center, radius),
            BodyShape::Rectangle { min, max } => {
                let dx = (min[0] - c[0]).max(c[0] - max[0]).max(0.0);
                let dy = (min[1] - c[1]).max(c[1] - max[1]).max(0.0);
                (dx * dx + dy * dy).sqrt() >= r + g
            }
            BodyShape::Annulus { center, inner_radius, outer_radius } => {
                let d = ((c[0] - center[0]).powi(2) + (c[1] - center[1]).powi(2)).sqrt();
                d + r + g <= inner_radius || d - r - g >= outer_radius
            }
        })
    }
}

impl Case {
    /// Whether a field has `generate` entries.
    pub fn has_generators(&self) -> bool {
        self.fields.iter().any(|f| !f.generate.is_empty())
    }

    /// The case with every `generate` entry turned into bodies appended to its field's
    /// `region: Bodies([...])` (after the listed ones, entry by entry), and what each entry
    /// made. Each entry's disks avoid the listed bodies and those of earlier entries.
    pub fn expand_generators(&self) -> Result<(Case, Vec<Generated>)> {
        let mut case = self.clone();
        let mut reports = Vec::new();
        for f in &mut case.fields {
            if f.generate.is_empty() {
                continue;
            }
            let Region::Bodies(bodies) = &mut f.region else {
                return Err(Error::invalid(
                    format!("fields.{}.region", f.name),
                    "generated bodies go into a list of bodies: write `region: Bodies([])` (or list bodies \
                     there to place beside the generated ones)",
                ));
            };
            for (k, spec) in f.generate.iter().enumerate() {
                let path = format!("fields.{}.generate.{k}", f.name);
                let (made, report) = spec.generate(&path, &case.domain, bodies)?;
                if bodies.len() + made.len() > MAX_BODIES {
                    return Err(Error::invalid(
                        path,
                        format!(
                            "{} bodies with those before; at most {MAX_BODIES} in one field: generate fewer",
                            bodies.len() + made.len()
                        ),
                    ));
                }
                bodies.extend(made);
                reports.push(report);
            }
            f.generate.clear();
        }
        Ok((case, reports))
    }
}
