//! Starting a run from another run's result on a different grid (OpenFOAM's `mapFields`):
//! the initial velocity `FromSnapshot(file: "...", field: "...")` of a field
//! ([`crate::case::InitialVelocity::FromSnapshot`]).
//!
//! The core does not read files of snapshots: the program that writes them registers a
//! reader ([`set_snapshot_reader`]; `multifield::link_all` does) which turns a file and a
//! field's name into [`SampledVelocity`]: the snapshot's velocity samples, on its faces when
//! it has them, else at its cell centres. A new grid's face takes the component it holds,
//! interpolated bilinearly (second order) from the four samples of that component around
//! it; at the edge of the samples (within half a cell of the snapshot's boundary) the
//! nearest two rows or columns are extrapolated linearly, which keeps second order there.
//! The mapped velocity is not divergence-free on the new grid: the first projection makes
//! it so, as it does any initial velocity.

use crate::case::Domain;
use crate::math::{axis_name, Real, DIM};
use std::path::Path;
use std::sync::OnceLock;

/// One velocity component sampled on a regular lattice (spacing `h`, first sample at
/// `x0, y0`, `nx × ny` samples, x fast).
#[derive(Clone, Debug, PartialEq)]
pub struct Samples {
    /// Position of the first sample.
    pub x0: Real,
    /// Position of the first sample.
    pub y0: Real,
    /// Distance between samples.
    pub h: Real,
    /// Samples along x (at least 2).
    pub nx: usize,
    /// Samples along y (at least 2).
    pub ny: usize,
    /// The values, `j·nx + i`.
    pub values: Vec<Real>,
}

/// The cell (`i0`, from 0 to n − 2) and the weight of its right neighbour for a sample
/// coordinate `s` (in samples from the first): bilinear inside, linear extrapolation
/// outside.
fn bracket(s: Real, n: usize) -> (usize, Real) {
    // a position on a sample (to round-off) takes that sample exactly
    let s = if (s - s.round()).abs() < 1e-9 { s.round() } else { s };
    let i0 = (s.floor().max(0.0) as usize).min(n - 2);
    (i0, s - i0 as Real)
}

/// `p + t (q − p)`, exactly `p` at t = 0 and `q` at t = 1.
fn lerp(p: Real, q: Real, t: Real) -> Real {
    if t == 1.0 {
        q
    } else {
        p + t * (q - p)
    }
}

impl Samples {
    /// The component at `(x, y)`: bilinear between the four samples around it, linear
    /// extrapolation from the nearest ones outside the samples' span.
    pub fn at(&self, x: Real, y: Real) -> Real {
        let (i, a) = bracket((x - self.x0) / self.h, self.nx);
        let (j, b) = bracket((y - self.y0) / self.h, self.ny);
        let v = |i: usize, j: usize| self.values[j * self.nx + i];
        lerp(lerp(v(i, j), v(i + 1, j), a), lerp(v(i, j + 1), v(i + 1, j + 1), a), b)
    }
}

/// A field's velocity read from a snapshot: the two components' samples and the domain
/// the snapshot covers.
#[derive(Clone, Debug, PartialEq)]
pub struct SampledVelocity {
    /// x component.
    pub u: Samples,
    /// y component.
    pub v: Samples,
    /// Lower-left corner of the snapshot's domain.
    pub origin: [Real; DIM],
    /// Its size.
    pub size: [Real; DIM],
    /// Cells of the snapshot's grid.
    pub cells: [usize; DIM],
    /// Whether the samples are the snapshot's face velocities (else cell centres).
    pub faces: bool,
}

impl SampledVelocity {
    /// The velocity at the point `p`.
    #[cfg(feature = "dim2")]
    pub fn at(&self, p: [Real; DIM]) -> [Real; DIM] {
        [self.u.at(p[0], p[1]), self.v.at(p[0], p[1])]
    }
    /// The velocity at the point `p`: never called in 3D, where [`read`] refuses (mapping
    /// a snapshot comes with 3D output).
    #[cfg(feature = "dim3")]
    pub fn at(&self, _p: [Real; DIM]) -> [Real; DIM] {
        [0.0; DIM]
    }

    /// An error (with the fix) unless the snapshot's domain covers `domain`.
    pub fn check_covers(&self, domain: &Domain) -> Result<(), String> {
        let tol = 1e-9 * domain.size.iter().chain(&self.size).fold(0.0, |m: Real, &s| m.max(s));
        let covers = (0..DIM).all(|k| {
            self.origin[k] <= domain.origin[k] + tol
                && self.origin[k] + self.size[k] >= domain.origin[k] + domain.size[k] - tol
        });
        if covers {
            return Ok(());
        }
        let span = |o: [Real; DIM], s: [Real; DIM]| {
            (0..DIM).map(|a| format!("{} {}..{}", axis_name(a), o[a], o[a] + s[a])).collect::<Vec<_>>().join(", ")
        };
        Err(format!(
            "the snapshot covers {} ({} cells), which does not cover the case's domain ({}); map from \
             a run whose domain contains this one (the same or a larger box), or change `domain`",
            span(self.origin, self.size),
            self.cells.map(|n| n.to_string()).join(" × "),
            span(domain.origin, domain.size),
        ))
    }
}

/// Reads the velocity of the field `field` from the snapshot file `file`; an error says
/// what is wrong and how to fix it (without the case entry's path).
pub type SnapshotReader = fn(file: &Path, field: &str) -> Result<SampledVelocity, String>;

static READER: OnceLock<SnapshotReader> = OnceLock::new();

/// Registers the reader of snapshot files (the first registration stays).
pub fn set_snapshot_reader(reader: SnapshotReader) {
    let _ = READER.set(reader);
}

/// The velocity of `field` in the snapshot `file`, checked to cover `domain`.
pub fn read(file: &Path, field: &str, domain: &Domain) -> Result<SampledVelocity, String> {
    #[cfg(feature = "dim3")]
    return Err(format!(
        "`FromSnapshot` ({}, field `{field}`, onto a domain from {:?}) is not available in 3D yet \
         (issue 17 brings 3D snapshots first); start from an initial velocity such as `Uniform(...)`",
        file.display(),
        domain.origin
    ));
    #[cfg(feature = "dim2")]
    {
        let reader = READER.get().ok_or_else(|| {
            "`FromSnapshot` needs a reader of snapshot files, and none is registered: call \
         `multifield::link_all()` before building the case"
                .to_string()
        })?;
        let sampled = reader(file, field)?;
        sampled.check_covers(domain)?;
        Ok(sampled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(f: impl Fn(Real, Real) -> Real, x0: Real, y0: Real, h: Real, n: usize) -> Samples {
        let mut values = Vec::new();
        for j in 0..n {
            for i in 0..n {
                values.push(f(x0 + i as Real * h, y0 + j as Real * h));
            }
        }
        Samples { x0, y0, h, nx: n, ny: n, values }
    }

    #[test]
    fn bilinear_is_exact_for_a_bilinear_function_inside_and_beyond_the_samples() {
        let f = |x: Real, y: Real| 0.3 + 2.0 * x - 1.5 * y + 0.7 * x * y;
        let s = lattice(f, 0.25, 0.25, 0.5, 6);
        for &(x, y) in &[(0.0, 0.0), (0.3, 1.1), (2.9, 3.0), (1.75, 0.25), (3.0, 2.2)] {
            assert!((s.at(x, y) - f(x, y)).abs() < 1e-13, "at ({x}, {y})");
        }
        // on a sample: that sample, bit for bit
        assert_eq!(s.at(0.75, 1.25), s.values[2 * 6 + 1]);
    }
}
