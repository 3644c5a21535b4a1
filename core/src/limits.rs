//! Resource limits: what a case will allocate, estimated from the schema alone, and the
//! caps that refuse a case before anything is allocated (issue 20).
//!
//! [`Case::memory_estimate`] counts the arrays the run keeps, per field, per frame and for
//! the pressure solver, from the numbers in the case (cells, points per cell, the bodies'
//! areas) without building anything; [`Case::check_resources`] refuses a case whose counts
//! exceed the caps below or whose estimate exceeds the memory it may use. Every product of
//! user numbers here saturates: an absurd case gives an absurd (but finite) estimate, never
//! an overflow. docs/limits.md compares the estimate with measured peak memory.
//!
//! [`time_estimate`] estimates how long a case runs on this machine: its steps, and the
//! time of a step measured on a coarsened copy of the case (`limits/time.rs`).

mod time;
pub use time::*;

use crate::case::{BodyShape, Case, Region, Representation};
use crate::error::{Error, Result};
use crate::math::{Real, DIM};

/// Most cells a case may have (nx × ny): 2³⁰, about 10⁹ (some 200 GB for one field).
pub const MAX_CELLS: u64 = 1 << 30;
/// Most material points all the fields together may seed: 2³⁰, about 10⁹.
pub const MAX_POINTS: u64 = 1 << 30;
/// Most bodies of one field (the checks of their overlaps and the contact are pairwise).
pub const MAX_BODIES: usize = 20_000;
/// Most stress models of one field, and most exchange entries of a case.
pub const MAX_LIST: usize = 64;

/// Bytes of one real.
const R: u64 = std::mem::size_of::<Real>() as u64;
/// Bytes a material point of the Lagrangian frame keeps: position, velocity, mass, volume,
/// F, ∇v, stress, two affine rows, body index, the last position and the sort order.
pub const BYTES_PER_POINT: u64 = 2 * 16 + 2 * 8 + 3 * 32 + 2 * 16 + 4 + 16 + 4;

/// What a case will allocate, by part.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The total (bytes).
    pub bytes: u64,
    /// The parts, largest first: (what, bytes).
    pub breakdown: Vec<(String, u64)>,
    /// Material points the fields seed (estimated from the regions' areas).
    pub points: u64,
}

impl std::fmt::Display for MemoryEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", bytes_text(self.bytes))?;
        let parts: Vec<String> =
            self.breakdown.iter().take(4).map(|(what, b)| format!("{what} {}", bytes_text(*b))).collect();
        if !parts.is_empty() {
            write!(f, " ({})", parts.join(", "))?;
        }
        Ok(())
    }
}

/// A size in bytes for people: "1.5 GB" (powers of 1000, as `free -h --si` and the
/// command line's `--max-memory 8GB`; "GiB" there means powers of 1024).
pub fn bytes_text(b: u64) -> String {
    bytesize::ByteSize::b(b).display().si().to_string()
}

/// Reads a size: `8GiB`, `8 GB`, `500M`, `123456` (bytes).
pub fn parse_bytes(s: &str) -> std::result::Result<u64, String> {
    s.trim()
        .parse::<bytesize::ByteSize>()
        .map(|b| b.as_u64())
        .map_err(|e| format!("`{s}` is not a size ({e}); give a number of bytes with a unit, e.g. 8GB, 8GiB or 500MB"))
}

/// The memory this machine has available now (`MemAvailable` of /proc/meminfo), or `None`
/// where it cannot be read (not Linux).
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// The environment variable that caps the memory a case may use, as `--max-memory`.
pub const MAX_MEMORY_VAR: &str = "MULTIFIELD_MAX_MEMORY";

/// How much memory a case may use: `--max-memory` if given, else `MULTIFIELD_MAX_MEMORY`,
/// else the machine's available memory (unlimited where it cannot be read).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit {
    /// The limit (bytes); `u64::MAX` for none.
    pub bytes: u64,
    /// Where it comes from.
    pub source: LimitSource,
}

/// Where a [`MemoryLimit`] comes from (for the message).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitSource {
    /// `--max-memory`.
    Option,
    /// The environment variable [`MAX_MEMORY_VAR`].
    Environment,
    /// The machine's available memory.
    Machine,
    /// None could be found.
    None,
}

impl MemoryLimit {
    /// The limit from `--max-memory` (already parsed), the environment, or the machine.
    pub fn resolve(option: Option<u64>) -> std::result::Result<MemoryLimit, String> {
        if let Some(bytes) = option {
            return Ok(MemoryLimit { bytes, source: LimitSource::Option });
        }
        if let Ok(v) = std::env::var(MAX_MEMORY_VAR) {
            let bytes = parse_bytes(&v).map_err(|m| format!("{MAX_MEMORY_VAR}={v}: {m}"))?;
            return Ok(MemoryLimit { bytes, source: LimitSource::Environment });
        }
        Ok(match available_memory() {
            Some(bytes) => MemoryLimit { bytes, source: LimitSource::Machine },
            None => MemoryLimit { bytes: u64::MAX, source: LimitSource::None },
        })
    }
    /// "this machine has 23 GB available" or "--max-memory is 8 GB".
    pub fn describe(&self) -> String {
        match self.source {
            LimitSource::Option => format!("--max-memory is {}", bytes_text(self.bytes)),
            LimitSource::Environment => format!("{MAX_MEMORY_VAR} is {}", bytes_text(self.bytes)),
            LimitSource::Machine => format!("this machine has {} available", bytes_text(self.bytes)),
            LimitSource::None => "no limit".into(),
        }
    }
}

/// Cells and faces (of every lattice) of a grid of `n` cells, saturating.
fn cells_and_faces(n: [u64; DIM]) -> (u64, u64) {
    let product = |m: [u64; DIM]| m.iter().fold(1u64, |a, &b| a.saturating_mul(b));
    let faces = (0..DIM).map(|a| {
        let mut f = n;
        f[a] = f[a].saturating_add(1);
        product(f)
    });
    (product(n), faces.fold(0, u64::saturating_add))
}

/// Cells, x-faces and y-faces of an `nx × ny` grid, saturating.
#[cfg(feature = "dim2")]
fn lattice(nx: u64, ny: u64) -> (u64, u64, u64) {
    (nx.saturating_mul(ny), nx.saturating_add(1).saturating_mul(ny), nx.saturating_mul(ny.saturating_add(1)))
}

/// Bytes per face of the implicit viscous operators of a field on each face lattice
/// (activity, a neighbour of 24 bytes per side, and six CG vectors); 0 for a field without
/// them (no Newtonian stress, or explicit diffusion).
fn implicit_viscous_per_face(f: &crate::case::FieldSpec) -> u64 {
    let viscous = f.stress.iter().any(|s| s.model == "newtonian");
    let implicit = f.frame.params.get("diffusion").and_then(|v| v.as_str()) != Some("explicit");
    if viscous && implicit {
        1 + crate::math::SIDES as u64 * 24 + 6 * R
    } else {
        0
    }
}

/// `a × b` saturating.
fn mul(a: u64, b: u64) -> u64 {
    a.saturating_mul(b)
}

/// Area of a body inside the domain's box (an annulus reaching past the domain counts the
/// domain's area at most).
fn body_area(shape: &BodyShape) -> Real {
    match *shape {
        BodyShape::Disk { radius, .. } => std::f64::consts::PI * radius * radius,
        BodyShape::Rectangle { min, max } => (max[0] - min[0]) * (max[1] - min[1]),
        BodyShape::Annulus { inner_radius, outer_radius, .. } => {
            std::f64::consts::PI * (outer_radius * outer_radius - inner_radius * inner_radius)
        }
    }
}

/// A count from a non-negative real, saturating (NaN gives 0).
fn count(x: Real) -> u64 {
    if x >= u64::MAX as Real {
        u64::MAX
    } else if x > 0.0 {
        x.ceil() as u64
    } else {
        0
    }
}

impl Case {
    /// The number of cells, nx × ny, or an error naming `domain.cells` when it exceeds
    /// [`MAX_CELLS`] (checked, so that no product of counts can overflow).
    pub fn cell_count(&self) -> Result<u64> {
        let n = self.cells();
        let cells = n.iter().try_fold(1u64, |c, &k| c.checked_mul(k as u64)).filter(|&c| c <= MAX_CELLS);
        cells.ok_or_else(|| {
            Error::invalid(
                "domain.cells",
                format!("{} cells: at most {MAX_CELLS} cells ({}) in all; reduce domain.cells", times(&n), {
                    #[cfg(feature = "dim2")]
                    let largest = "32768 × 32768";
                    #[cfg(feature = "dim3")]
                    let largest = "1024 × 1024 × 1024";
                    largest
                }),
            )
        })
    }

    /// The material points a field seeds, estimated from its region's area: points per cell
    /// squared per cell covered (0 for an Eulerian field, one per body for mass points).
    fn points_of(&self, k: usize) -> u64 {
        let f = &self.fields[k];
        let d = &self.domain;
        if f.representation == Representation::MassPoint {
            return match &f.region {
                Region::Bodies(b) => b.len() as u64,
                _ => 0,
            };
        }
        if f.frame.model != "lagrangian" {
            return 0;
        }
        let n = f.frame.params.get("points_per_cell").and_then(|v| v.as_u64()).unwrap_or(2);
        let h = d.size[0] / self.cells()[0] as Real;
        let domain_area = d.size[0] * d.size[1];
        let area = match &f.region {
            Region::All | Region::Rest => domain_area,
            Region::Rectangle { min, max } => (max[0] - min[0]) * (max[1] - min[1]),
            Region::Disk { radius, .. } => std::f64::consts::PI * radius * radius,
            // no Lagrangian field in 3D yet (issue 17)
            #[cfg(feature = "dim3")]
            Region::Box { .. } | Region::Sphere { .. } => domain_area,
            Region::Bodies(bodies) => bodies.iter().map(|b| body_area(&b.shape)).sum(),
        }
        .min(domain_area);
        mul(count(area / (h * h)), mul(n, n))
    }

    /// The bytes a run of this case will allocate at its peak, by part, from the case alone
    /// (nothing is built). Counts the grid arrays of every field (the core's per-field state
    /// and each frame's own arrays), the material points, the exchanges' coefficients, the
    /// pressure solver with its multigrid levels, and the output's buffers. A frame of
    /// another crate is counted as an Eulerian one. Saturates instead of overflowing.
    #[cfg(feature = "dim2")]
    pub fn memory_estimate(&self) -> MemoryEstimate {
        let [nx, ny] = self.cells().map(|n| n as u64);
        let (c, x, y) = lattice(nx, ny);
        let faces = x.saturating_add(y);
        let mut parts: Vec<(String, u64)> = Vec::new();
        let mut points_total = 0u64;
        // the simulation's own: pressure, and the occupied and free volume while seeding
        parts.push(("pressure and seeding".into(), mul(3 * R, c)));
        for (k, f) in self.fields.iter().enumerate() {
            // FieldState: θ at cells; θ and mass on faces, five face velocities
            let mut b = mul(R, c).saturating_add(mul(7 * R, faces));
            // the seeding's θ of the field
            b = b.saturating_add(mul(R, c));
            let lagrangian = f.frame.model == "lagrangian" || f.representation == Representation::MassPoint;
            let collocated = lagrangian && f.frame.params.get("grid").and_then(|v| v.as_str()) == Some("collocated");
            if collocated {
                // a field on the collocated grid never writes the core's grid state: its
                // zeroed pages are never touched, so they take no memory
                b = 0;
            }
            let points = self.points_of(k);
            points_total = points_total.saturating_add(points);
            if f.representation == Representation::MassPoint {
                // per point its state and the cells and faces its disk covers
                b = b.saturating_add(mul(points, 1024));
            } else if lagrangian {
                let (pc, _, _) = lattice(nx.saturating_add(5), ny.saturating_add(5));
                b = b.saturating_add(mul(points, BYTES_PER_POINT));
                b = b.saturating_add(if collocated {
                    // two partial lattices of 4 reals per node, the node velocity, the touched map
                    mul(pc, 2 * 4 * R + 2 * R + 1)
                } else {
                    // the scatter's 7 channels, padded and per stripe of 4 rows (8 with its
                    // ghosts), and the points' volumes per cell
                    mul(pc, 7 * R + 14 * R).saturating_add(mul(R, c))
                });
            } else {
                // Eulerian: θ, θ¹, its rate; four face velocities; three padded lattices (two
                // ghost layers); the fluxes of u, v and θ
                let (p1, _, _) = lattice(nx.saturating_add(5), ny.saturating_add(4));
                let (p2, _, _) = lattice(nx.saturating_add(4), ny.saturating_add(5));
                let (p3, _, _) = lattice(nx.saturating_add(4), ny.saturating_add(4));
                let fluxes = mul(nx.saturating_add(2), ny)
                    .saturating_add(mul(2, mul(nx.saturating_add(1), ny.saturating_add(1))))
                    .saturating_add(mul(nx, ny.saturating_add(2)))
                    .saturating_add(faces);
                let n = mul(3, c)
                    .saturating_add(mul(4, faces))
                    .saturating_add(p1)
                    .saturating_add(p2)
                    .saturating_add(p3)
                    .saturating_add(fluxes);
                b = b.saturating_add(mul(R, n));
                b = b.saturating_add(mul(faces, implicit_viscous_per_face(f)));
            }
            parts.push((format!("field {}", f.name), b));
        }
        parts.extend(self.exchange_bytes(faces));
        parts.extend(self.pressure_bytes());
        self.with_output(parts, c, points_total)
    }

    /// [`Case::memory_estimate`] in 3D, where every field is Eulerian (the 2D count with
    /// three face lattices, the padded lattices of two ghost layers on every axis, nine
    /// momentum fluxes, and multigrid levels an eighth of the one above each).
    #[cfg(feature = "dim3")]
    pub fn memory_estimate(&self) -> MemoryEstimate {
        let n = self.cells().map(|n| n as u64);
        let (c, faces) = cells_and_faces(n);
        let mut parts: Vec<(String, u64)> = vec![("pressure and seeding".into(), mul(3 * R, c))];
        for f in &self.fields {
            // FieldState: θ at cells; θ and mass on faces, five face velocities; the seeding's θ
            let mut b = mul(2 * R, c).saturating_add(mul(7 * R, faces));
            // θ, θ¹, its rate; four face velocities; four padded lattices (two ghost layers);
            // the nine momentum fluxes and the θ fluxes (about a lattice each)
            let (padded, _) = cells_and_faces(n.map(|k| k.saturating_add(5)));
            let work =
                mul(3, c).saturating_add(mul(4, faces)).saturating_add(mul(4, padded)).saturating_add(mul(12, c));
            b = b.saturating_add(mul(R, work));
            b = b.saturating_add(mul(faces, implicit_viscous_per_face(f)));
            parts.push((format!("field {}", f.name), b));
        }
        parts.extend(self.exchange_bytes(faces));
        parts.extend(self.pressure_bytes());
        self.with_output(parts, c, 0)
    }

    /// The pressure solver's bytes, if the case has one: the problem (face coefficients,
    /// right-hand side) and the CG vectors in f64 and f32, then every level of the multigrid
    /// (each 2^DIM times smaller than the one above) or, for the direct solver, the factor.
    fn pressure_bytes(&self) -> Option<(String, u64)> {
        let p = self.pressure.as_ref()?;
        let n = self.cells().map(|n| n as u64);
        let (c, faces) = cells_and_faces(n);
        let mut b = mul(R, faces).saturating_add(mul(R, c)).saturating_add(mul(3 * R + 2 * 4, c));
        if p.model == "cholesky" {
            b = b.saturating_add(cholesky_bytes(c));
        } else {
            let mut m = n;
            loop {
                let (lc, lf) = cells_and_faces(m);
                // the level's operator (f64): face couplings, ghost terms, diagonal and its
                // inverse
                b = b.saturating_add(mul(R, lf).saturating_add(mul(3 * R, lc)));
                if !m.iter().all(|&k| k.is_multiple_of(2) && k >= 4) {
                    b = b.saturating_add(cholesky_bytes(lc));
                    break;
                }
                // smoothed levels: the f32 operator (4 per cell), the interpolation weights
                // (DIM per cell), the coarse right-hand side and solution
                b = b.saturating_add(mul(4, mul(lc, 4 + DIM as u64)).saturating_add(mul(4, lc >> (DIM - 1))));
                m = m.map(|k| k / 2);
            }
        }
        Some((format!("pressure solver {}", p.model), b))
    }

    /// The exchanges' coefficients on `faces` faces (a direct forcing keeps none), if any.
    fn exchange_bytes(&self, faces: u64) -> Option<(String, u64)> {
        let exchanges = self.exchange.iter().filter(|e| e.model != "direct_forcing").count() as u64;
        (exchanges > 0).then(|| ("exchange coefficients".into(), mul(mul(exchanges, R), faces)))
    }

    /// The estimate from the parts of the run, with the output's buffers added.
    fn with_output(&self, mut parts: Vec<(String, u64)>, c: u64, points_total: u64) -> MemoryEstimate {
        let o = &self.output;
        let fields = self.fields.len() as u64;
        let mut out = 0u64;
        if let Some(s) = &o.snapshots {
            // one quantity at a time, up to 3 components per cell, and a field's points
            let n = (s.mixture.len() + s.fields.len()) as u64;
            out = out.saturating_add(mul(mul(3 * R, c), n.min(1 + fields)));
        }
        if let Some(p) = &o.pictures {
            let w = p.width as u64;
            let h = count(w as Real * self.domain.size[1] / self.domain.size[0]);
            out = out.saturating_add(mul(mul(w, h), 8)).saturating_add(mul(2 * R, c));
        }
        if o.checkpoints.is_some() {
            // the serialised state: about the fields' and points' state once more
            let state: u64 = parts.iter().map(|p| p.1).fold(0, u64::saturating_add);
            out = out.saturating_add(state / 2);
        }
        if out > 0 {
            parts.push(("output buffers".into(), out));
        }
        parts.sort_by_key(|p| std::cmp::Reverse(p.1));
        let bytes = parts.iter().map(|p| p.1).fold(0, u64::saturating_add);
        MemoryEstimate { bytes, breakdown: parts, points: points_total }
    }

    /// Refuses a case whose counts exceed the documented caps ([`MAX_CELLS`],
    /// [`MAX_POINTS`], [`MAX_BODIES`], [`MAX_LIST`]), naming the entry. Pure and cheap
    /// (no allocation beyond the message); [`crate::simulation::Simulation::new`] calls it
    /// before it allocates the grid, so that no product of these counts can overflow.
    pub fn check_counts(&self) -> Result<()> {
        self.cell_count()?;
        for f in &self.fields {
            if f.stress.len() > MAX_LIST {
                return Err(Error::invalid(
                    format!("fields.{}.stress", f.name),
                    format!("{} stress models; at most {MAX_LIST}", f.stress.len()),
                ));
            }
            if let Region::Bodies(bodies) = &f.region {
                if bodies.len() > MAX_BODIES {
                    return Err(Error::invalid(
                        format!("fields.{}.region", f.name),
                        format!(
                            "{} bodies; at most {MAX_BODIES} in one field (their overlaps and contacts are \
                             checked pair by pair); use fewer bodies",
                            bodies.len()
                        ),
                    ));
                }
            }
        }
        if self.exchange.len() > MAX_LIST {
            return Err(Error::invalid("exchange", format!("{} entries; at most {MAX_LIST}", self.exchange.len())));
        }
        let mut total = 0u64;
        for (k, f) in self.fields.iter().enumerate() {
            let n = self.points_of(k);
            total = total.saturating_add(n);
            if n > MAX_POINTS || total > MAX_POINTS {
                return Err(Error::invalid(
                    format!("fields.{}.frame.params.points_per_cell", f.name),
                    format!(
                        "about {total} material points; at most {MAX_POINTS} in all; lower points_per_cell or \
                         domain.cells"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Refuses a case whose memory estimate exceeds `limit` (with the estimate, the limit
    /// and the fix), then one beyond the caps of [`Case::check_counts`]. Allocates nothing:
    /// call it before building a [`crate::simulation::Simulation`]. Returns the estimate.
    pub fn check_resources(&self, limit: &MemoryLimit) -> Result<MemoryEstimate> {
        let estimate = self.memory_estimate();
        if estimate.bytes > limit.bytes {
            let n = self.cells();
            let fix = match limit.source {
                LimitSource::Option => "raise --max-memory",
                LimitSource::Environment => "raise MULTIFIELD_MAX_MEMORY (or give --max-memory)",
                _ => "free memory, or give a larger --max-memory (at your own risk)",
            };
            return Err(Error::invalid(
                "domain.cells",
                format!(
                    "{} needed for {} cells{}; {}; reduce domain.cells (or points_per_cell), or {fix}",
                    bytes_text(estimate.bytes),
                    n.map(|k| group(k as u64)).join(" × "),
                    if estimate.points > 0 {
                        format!(" and about {} points", group(estimate.points))
                    } else {
                        String::new()
                    },
                    limit.describe()
                ),
            ));
        }
        self.check_counts()?;
        Ok(estimate)
    }
}

/// Bytes of the sparse Cholesky factor of the 5-point operator on `n` cells with an
/// approximate-minimum-degree ordering: the factor holds about n (8 + 2 log₂ n) entries
/// of a value and a row index, and the symbolic factorization as much again in indices.
#[cfg(feature = "dim2")]
fn cholesky_bytes(n: u64) -> u64 {
    let log = 64 - n.max(2).leading_zeros() as u64;
    mul(n, mul(8 + 2 * log, 2 * R + 8))
}

/// Bytes of the sparse Cholesky factor of the 7-point operator on `n` cells: about
/// 2 n^{3/2} entries (faer's AMD ordering on a cube measured 1.50–1.83 n^{3/2} from 16³ to
/// 48³, as `multifield_physics::pressure::cholesky::factor_bytes` counts it) of a value and
/// a row index, and the symbolic factorization as much again in indices.
#[cfg(feature = "dim3")]
fn cholesky_bytes(n: u64) -> u64 {
    let entries = (2.0 * n as Real * (n as Real).sqrt()).min(u64::MAX as Real) as u64;
    mul(entries, 2 * R + 8)
}

/// Cells as "nx × ny" (or "nx × ny × nz").
fn times(n: &[usize]) -> String {
    n.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(" × ")
}

/// 2000000 as "2,000,000".
pub fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}
