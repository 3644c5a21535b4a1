//! HDF5 snapshots of the whole state with an XDMF sidecar for ParaView and VisIt
//! (`output.snapshots: Some((interval: T))` in the case).
//!
//! A run with snapshots writes into `snapshots/` of its output directory:
//!
//! - `snapshot_000000.h5`, `snapshot_000001.h5`, …: one file per output time, numbered by
//!   output index: t = 0, then every `interval` of simulated time (the first step at or past
//!   each multiple), and always the last step of the run, whatever ended it; with `times:
//!   [...]`, also at each of those times (the step lands on it, so the snapshot's `time` is
//!   the requested one to round-off); with `at_end: true`, the last step (`interval` may be
//!   left out: `Some((at_end: true))` writes one snapshot, at the end, and `Some((times:
//!   [0.5, 1.0]))` two, with none at t = 0);
//! - `<case name>.xdmf`: a temporal collection of every snapshot written so far, rewritten
//!   after each one, which ParaView ("Xdmf Reader") and VisIt open as a time series.
//!
//! Every file is written in memory, then to a temporary name and renamed
//! ([`crate::output::write_atomically`]); the XDMF is rewritten only once its new snapshot
//! is complete, so a killed run leaves complete snapshots and an XDMF that lists only those
//! (at most a hidden `.snapshot_…h5.tmp` leftover). Files of an earlier run in the same
//! `snapshots/` are removed when the run starts, except that a run continued from a
//! checkpoint keeps (and lists) those of the steps before the checkpoint's.
//!
//! Open the time series with `paraview out/<case>/snapshots/<case>.xdmf` (pick "XDMF
//! Reader") or in VisIt. Each time is a spatial collection of `grid`, the mesh one cell
//! thick in z with the mixture's cell arrays (`pressure`, `velocity`, `vorticity` by
//! default) and each field's as `<f>_<quantity>` (`theta`, `velocity`, `vorticity`,
//! `density` by default), and of `<f> points` for each field with points: its points as
//! vertices with their arrays (`velocity`, `volume`, `stress` as σxx, σyy, σxy by default)
//! and `body`.
//!
//! # Which quantities
//!
//! The arrays are quantities of the registry ([`crate::core::quantity`]; `multifield
//! quantities` lists them with their units and formulas, and plugins add more), chosen in
//! the case:
//!
//! ```text
//! snapshots: Some((interval: 0.1,
//!     mixture: ["pressure", "velocity", "vorticity", "divergence"],   // /<name>
//!     fields: ["theta", "velocity", "vorticity", "density"],          // /fields/<f>/<name>
//!     points: ["position", "velocity", "volume", "stress"])),          // /fields/<f>/points/<name>
//! ```
//!
//! Each list defaults to what is shown, the set earlier versions wrote. The points' `body`
//! is always written, and so is the per-point state of the field's stress models
//! (`StressModel::point_state`), one array per component named `<model>_<component>`
//! (none of the shipped models keeps any); leave `position` out and ParaView cannot draw
//! the points.
//!
//! # Layout of a snapshot
//!
//! Grid arrays are row-major `(NY, NX)`, y slow and x fast (cell `(i, j)` at `j·NX + i`,
//! the order of `Simulation::pressure`); vectors are `(NY, NX, 3)` with z = 0 (ParaView reads
//! 2-component vectors wrongly). Every value is a cell-centre value, f64. With the default
//! quantities:
//!
//! | path | shape | units | what |
//! | --- | --- | --- | --- |
//! | `/pressure` | (NY, NX) | force/area | the shared pressure |
//! | `/velocity` | (NY, NX, 3) | length/time | mixture velocity Σθₖuₖ / Σθₖ (0 where Σθ = 0) |
//! | `/vorticity` | (NY, NX) | 1/time | ∂v/∂x − ∂u/∂y of `/velocity` |
//! | `/fields/<f>/theta` | (NY, NX) | - | volume fraction θ |
//! | `/fields/<f>/velocity` | (NY, NX, 3) | length/time | the field's velocity, mean of the two faces |
//! | `/fields/<f>/vorticity` | (NY, NX) | 1/time | vorticity of the field's velocity |
//! | `/fields/<f>/density` | (NY, NX) | mass/volume | bulk density θ ρ⁰ |
//! | `/fields/<f>/faces/u`, `faces/v` | (NY, NX + 1), (NY + 1, NX) | length/time | an Eulerian field's face velocities, the grid state itself; only with `faces: true` (for `velocity: FromSnapshot(...)`, [`read_velocity`]) |
//! | `/fields/<f>/points/position` | (N, 3) | length | points (material points, or one per body of a mass-point field), z = 0 |
//! | `/fields/<f>/points/velocity` | (N, 3) | length/time | z = 0 |
//! | `/fields/<f>/points/volume` | (N) | volume | current volume det F · V⁰ (area × unit depth) |
//! | `/fields/<f>/points/stress` | (N, 3) | force/area | Cauchy stress σxx, σyy, σxy |
//! | `/fields/<f>/points/body` | (N) | - | index of the point's body in `bodies`, −1 for none (i64) |
//! | `/averages/<name>` | (NY, NX) or (NY, NX, 3) | the quantity's | running time average of a `TimeAverage` monitor (docs/monitors.md), with the attributes `quantity`, `field`, `from`, `to`, `samples`; only once it has a sample |
//! | `/suspension/<name>/statistics` | (9) | per column | a `Suspension` monitor's figures at this step (docs/monitors.md), in the order of the attribute `columns`: bodies, solid_fraction, u_x, u_y, settling_velocity, temperature, bed_height, contacts, wall_contacts; equal to its row of `monitors/<name>.csv` at the same step |
//! | `/suspension/<name>/profiles` | (bins, 4) | length, -, length/time, length/time | its profile at this step, per slab: centre, solid_fraction, u_x, u_y (attribute `columns`; NaN where a slab holds no solid); the group has the attributes `field`, `axis` (`"X"` or `"Y"`), `bins`, `bed_fraction`, `contact_gap` |
//!
//! The files are in the HDF5 1.8 format (version 2 superblock, contiguous uncompressed
//! datasets), which every HDF5 library since 1.8 reads. Every dataset has the attributes
//! `units` and `description`. The root has `time`, `step`, `case` (its name), `program`
//! (`"multifield <version>"`), `units`, the grid (`cells` = [NX, NY], `origin` = [x, y],
//! `spacing` = h) and `fields` (the group names of `/fields`, in the case's order). A field
//! group has `name` (as in the case), `frame` (`"eulerian"` or `"lagrangian"`) and
//! `material_density` (ρ⁰); a points group has `count` and, for a field of bodies, `bodies`
//! (their names). The case has no unit system: "length", "time", "mass" are those of the
//! case file (CGS by convention).
//!
//! # What the values are
//!
//! Those of [`crate::core::quantity::Sample`]: after a step, θ and the face velocities are
//! the field's grid state as the step left it (the corrected velocity; θ of a Lagrangian
//! field and of the field of region `Rest` from the step's particles-to-grid, θ of an
//! advected Eulerian field after its advection). Before the first step no step has built
//! that state, so the t = 0 snapshot reconstructs it as the run starts from it: θ from the
//! regions (the field of region `Rest` takes what the others leave), an Eulerian field's
//! velocity from its initial velocity on the faces, a field of material points' by a
//! mass-weighted linear (cloud-in-cell) average of its points onto the faces; the
//! pressure is 0 until the first projection. The formulas of the quantities are in the
//! registry (vorticity: central differences of the cell-centred velocity, one-sided at a
//! domain edge, wrapped across a periodic side).

use crate::core::case::{RankLayout, SnapshotSpec};
use crate::core::driver::{Step, Writer};
use crate::core::error::Error;
use crate::core::grid::{Grid, Lattice};
use crate::core::mapping::SampledVelocity;
#[cfg(feature = "dim2")]
use crate::core::mapping::Samples;
use crate::core::math::{Index, Real, DIM};
use crate::core::monitor::suspension::{self, COLUMNS};
use crate::core::monitor::Monitored;
use crate::core::plugin::BodyState;
use crate::core::quantity::{self, Compute, Place, Quantity, Sample};
use crate::core::simulation::Simulation;
use crate::output::{write_atomically, Due, Moments};
use hdf5_pure::{AttrValue, FileBuilder, GroupBuilder, LibVer};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Name of the folder of snapshots in a run's output directory.
pub const FOLDER: &str = "snapshots";

/// `"multifield <version>"`, the `program` attribute.
pub fn program() -> String {
    format!("multifield {}", env!("CARGO_PKG_VERSION"))
}

/// File name of the snapshot of output index `index`: `snapshot_000042.h5`.
pub fn file_name(index: usize) -> String {
    format!("snapshot_{index:06}.h5")
}

/// File name of the XDMF sidecar of a case: `<case name>.xdmf` (made a safe file name).
pub fn xdmf_name(case_name: &str) -> String {
    format!("{}.xdmf", crate::run::directory_name(case_name))
}

/// Arrays by quantity name: over the cells, (NY, NX) or (NY, NX, 3); over points, (N) or
/// (N, 3). Vectors have z = 0.
pub type Arrays = BTreeMap<String, Vec<Real>>;

/// The points of a field in a snapshot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointData {
    /// The point quantities written (`output.snapshots.points`).
    pub values: Arrays,
    /// Index of the point's body in [`PointData::bodies`], −1 for none, (N).
    pub body: Vec<i64>,
    /// Names of the field's bodies (empty when it has none).
    pub bodies: Vec<String>,
}

impl PointData {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.body.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.body.is_empty()
    }
    /// The array of quantity `name`, if written.
    pub fn get(&self, name: &str) -> Option<&[Real]> {
        self.values.get(name).map(Vec::as_slice)
    }
}

/// One field in a snapshot.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldData {
    /// The field's name in the case.
    pub name: String,
    /// Name of its group under `/fields` (the name made a safe HDF5 link name).
    pub group: String,
    /// `"eulerian"` or `"lagrangian"`.
    pub frame: String,
    /// Material density ρ⁰.
    pub material_density: Real,
    /// The field's cell quantities written (`output.snapshots.fields`).
    pub cells: Arrays,
    /// Its points, for a field that has points.
    pub points: Option<PointData>,
    /// Its face velocities `u` ((NY, NX + 1), x fast) and `v` ((NY + 1, NX)), the grid
    /// state itself, when the case asks for them (`output.snapshots.faces`; Eulerian
    /// fields only).
    pub faces: Option<[Vec<Real>; DIM]>,
}

impl FieldData {
    /// The cell array of quantity `name`, if written.
    pub fn get(&self, name: &str) -> Option<&[Real]> {
        self.cells.get(name).map(Vec::as_slice)
    }
}

/// A running time average in a snapshot (a `TimeAverage` monitor's, `/averages/<name>`).
#[derive(Clone, Debug, PartialEq)]
pub struct AverageData {
    /// The monitor's name.
    pub name: String,
    /// The quantity averaged.
    pub quantity: String,
    /// Its field (empty: the mixture's).
    pub field: String,
    /// The first and the last time averaged over.
    pub from: Real,
    /// The last time averaged over.
    pub to: Real,
    /// Samples averaged.
    pub samples: u64,
    /// The average, (NY, NX) or (NY, NX, 3).
    pub values: Vec<Real>,
}

/// A `Suspension` monitor's statistics in a snapshot (`/suspension/<name>`): the
/// figures of its row and its profile at the snapshot's step, computed from the bodies
/// as the monitor computes them (the same function on the same state: equal to its CSV
/// row at that step, bit for bit).
#[derive(Clone, Debug, PartialEq)]
pub struct SuspensionData {
    /// The monitor's name.
    pub name: String,
    /// The field of bodies.
    pub field: String,
    /// `"X"` or `"Y"`: the axis of the profiles and of the bed height.
    pub axis: String,
    /// The fraction of solid area below the bed height.
    pub bed_fraction: Real,
    /// The largest gap of a contact.
    pub contact_gap: Real,
    /// The row, in the order of [`crate::core::monitor::suspension::COLUMNS`].
    pub statistics: Vec<Real>,
    /// Per slab (`bins` of them): centre, solid fraction, u_x, u_y (NaN where the slab
    /// holds no solid).
    pub profiles: Vec<[Real; 4]>,
}

/// The columns of `/suspension/<name>/profiles`.
pub const SUSPENSION_PROFILE_COLUMNS: [&str; 4] = ["centre", "solid_fraction", "u_x", "u_y"];

/// Everything one snapshot file holds, as [`Snapshot::of`] computes it and
/// [`Snapshot::read`] reads it back.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Name of the case.
    pub case: String,
    /// `"multifield <version>"`.
    pub program: String,
    /// Simulated time.
    pub time: Real,
    /// Steps taken.
    pub step: u64,
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Cells along z.
    #[cfg(feature = "dim3")]
    pub nz: usize,
    /// Lower-left corner of the domain.
    pub origin: [Real; DIM],
    /// Cell side.
    pub spacing: Real,
    /// The mixture's cell quantities written (`output.snapshots.mixture`).
    pub cells: Arrays,
    /// The fields, in the case's order.
    pub fields: Vec<FieldData>,
    /// The running time averages that have a sample, in the case's order of monitors.
    pub averages: Vec<AverageData>,
    /// The statistics of the case's `Suspension` monitors, by name.
    pub suspensions: Vec<SuspensionData>,
}

const UNITS: &str = "case units: length, time and mass as in the case file (CGS by convention: cm, s, g)";

fn model_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Model(format!("{}: {e}", path.display()))
}

/// Group names for the fields: the names made safe link names, unique.
fn group_names(names: &[&str]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for n in names {
        let base = crate::run::directory_name(n);
        let mut g = base.clone();
        let mut k = 2;
        while out.contains(&g) {
            g = format!("{base}_{k}");
            k += 1;
        }
        out.push(g);
    }
    out
}

/// The registered quantity `name` at `place` (validated with the case).
fn quantity(name: &str, place: Place) -> Result<&'static Quantity, Error> {
    quantity::find(name, place).map_err(|m| Error::invalid("output.snapshots", m))
}

/// Units and description of a written array (from the registry; empty for a name it
/// does not know, which only a hand-made [`Snapshot`] has).
fn describe(name: &str, place: Place) -> (&'static str, &'static str) {
    quantity::find(name, place).map_or(("", ""), |q| (q.units, q.description))
}

impl Snapshot {
    /// The snapshot of the simulation's current state with the quantities of the case's
    /// `output.snapshots` (the defaults when it has none).
    pub fn of(sim: &Simulation) -> Result<Snapshot, Error> {
        let spec = sim.case.output.snapshots.clone().unwrap_or_else(|| SnapshotSpec::every(1.0));
        Snapshot::with(sim, &spec)
    }

    /// The snapshot of the simulation's current state with the quantities of `spec`; an
    /// unknown name is an error.
    pub fn with(sim: &Simulation, spec: &SnapshotSpec) -> Result<Snapshot, Error> {
        Snapshot::build(sim, spec, false)
    }

    /// [`Snapshot::with`] with the points of a decomposed run's rank (`local`: those it
    /// holds, [`Frame::local_points`](crate::core::plugin::Frame::local_points)) or every
    /// rank's; the cell arrays on the rank's storage.
    fn build(sim: &Simulation, spec: &SnapshotSpec, local: bool) -> Result<Snapshot, Error> {
        let g = &sim.grid;
        let sample = Sample::of(sim);
        let names: Vec<&str> = sim.fields.iter().map(|f| f.name.as_str()).collect();
        let groups = group_names(&names);
        let mut fields = Vec::new();
        for (k, (f, group)) in sim.fields.iter().zip(groups).enumerate() {
            let mut cells = Arrays::new();
            for q in &spec.fields {
                let values = sample.cells(quantity(q.as_str(), Place::Field)?, Some(k)).unwrap_or_default();
                cells.insert(q.to_string(), values);
            }
            let points = if local { f.frame.local_points(g.part.rank()) } else { f.frame.points() };
            let points = match points {
                Some(p) => {
                    let mut values = Arrays::new();
                    for q in &spec.points {
                        if let Compute::Points(eval) = quantity(q.as_str(), Place::Points)?.compute {
                            values.insert(q.to_string(), eval(&p));
                        }
                    }
                    // the stress models' per-point state, always
                    values.extend(p.named_state(&f.stress));
                    Some(PointData { values, body: p.body, bodies: p.bodies })
                }
                None => None,
            };
            let faces = (spec.faces && !f.frame.is_lagrangian())
                .then(|| std::array::from_fn(|a| sample.fields[k].faces[a].clone()));
            fields.push(FieldData {
                name: f.name.clone(),
                group,
                frame: if f.frame.is_lagrangian() { "lagrangian" } else { "eulerian" }.into(),
                material_density: f.density,
                cells,
                points,
                faces,
            });
        }
        let mut cells = Arrays::new();
        for q in &spec.mixture {
            cells.insert(q.to_string(), sample.cells(quantity(q.as_str(), Place::Mixture)?, None).unwrap_or_default());
        }
        // by name, as the file lists them
        let mut averages: Vec<AverageData> = sim
            .averages
            .iter()
            .filter(|a| a.samples > 0)
            .map(|a| AverageData {
                name: a.name.clone(),
                quantity: a.quantity.clone(),
                field: a.field.clone().unwrap_or_default(),
                from: a.first,
                to: a.last_time,
                samples: a.samples,
                values: a.mean(),
            })
            .collect();
        averages.sort_by(|a, b| a.name.cmp(&b.name));
        let suspensions = suspensions_of(sim);
        Ok(Snapshot {
            case: sim.case.name.clone(),
            program: program(),
            time: sim.time,
            step: sim.steps,
            nx: g.nx,
            ny: g.ny,
            #[cfg(feature = "dim3")]
            nz: g.nz,
            origin: g.origin.into(),
            spacing: g.h,
            cells,
            fields,
            averages,
            suspensions,
        })
    }

    /// The whole domain's snapshot from the blocks of a decomposed run (`grid`: this rank's
    /// block): every cell and face array gathered from the ranks' owned nodes, on every
    /// rank; the snapshot itself on one rank. Every rank calls it, with the same arrays.
    pub fn gathered(mut self, grid: &Grid) -> Snapshot {
        let part = &grid.part;
        if part.is_whole() {
            return self;
        }
        let shape = grid.shape(Lattice::Cell);
        let cells = grid.n_cells();
        // (an array a quantity does not give is empty on every rank)
        for a in self.cell_arrays_mut().filter(|a| !a.is_empty()) {
            *a = part.gather_per(Lattice::Cell, shape, a, a.len() / cells);
        }
        for faces in self.fields.iter_mut().filter_map(|f| f.faces.as_mut()) {
            for (a, values) in faces.iter_mut().enumerate() {
                let lattice = Lattice::face(a);
                *values = part.gather(lattice, grid.shape(lattice), values);
            }
        }
        self.set_cells_along(grid.domain);
        self
    }

    /// Every cell array: the mixture's and each field's.
    fn cell_arrays_mut(&mut self) -> impl Iterator<Item = &mut Vec<Real>> {
        self.cells.values_mut().chain(self.fields.iter_mut().flat_map(|f| f.cells.values_mut()))
    }

    /// Sets the cells along each axis.
    fn set_cells_along(&mut self, n: Index) {
        (self.nx, self.ny) = (n[0], n[1]);
        #[cfg(feature = "dim3")]
        {
            self.nz = n[2];
        }
    }

    /// This rank's block of a decomposed run as a snapshot of its own (`layout: PerRank`):
    /// its owned cells (the block's cells and origin), its faces from the block's low
    /// sides to its high ones (the faces at a high cut are the neighbour's: the face
    /// velocities' halo is exchanged here), and the points it holds. Every rank calls it.
    pub fn of_block(sim: &Simulation, spec: &SnapshotSpec) -> Result<Snapshot, Error> {
        let mut snap = Snapshot::build(sim, spec, true)?;
        let grid = &sim.grid;
        let Some((_, block)) = grid.part.block() else {
            return Ok(snap);
        };
        let pads: [usize; DIM] = std::array::from_fn(|a| grid.part.pads(a)[0]);
        let cells: Index = std::array::from_fn(|a| block.cells[a].len());
        // the storage nodes of `lattice` from the block's first cell on, `along` more
        // along each axis
        let cut = |values: &[Real], lattice: Lattice, per: usize| -> Vec<Real> {
            let shape = grid.shape(lattice);
            let take: Index = std::array::from_fn(|a| cells[a] + (lattice.axis() == Some(a)) as usize);
            let mut out = Vec::with_capacity(take.iter().product::<usize>() * per);
            let ranges: [std::ops::Range<usize>; DIM] = std::array::from_fn(|a| pads[a]..pads[a] + take[a]);
            crate::core::halo::for_each(shape, &ranges, |k| out.extend_from_slice(&values[k * per..(k + 1) * per]));
            out
        };
        let n_storage = grid.n_cells();
        for a in snap.cell_arrays_mut().filter(|a| !a.is_empty()) {
            *a = cut(a, Lattice::Cell, a.len() / n_storage);
        }
        for f in &mut snap.fields {
            if let Some(faces) = &mut f.faces {
                let mut arrays: Vec<(Lattice, &mut [Real])> =
                    faces.iter_mut().enumerate().map(|(a, v)| (Lattice::face(a), v.as_mut_slice())).collect();
                grid.part.exchange(&mut arrays);
                for (a, values) in faces.iter_mut().enumerate() {
                    *values = cut(values, Lattice::face(a), 1);
                }
            }
        }
        snap.set_cells_along(cells);
        for a in 0..DIM {
            snap.origin[a] = grid.origin[a] + grid.h * block.cells[a].start as Real;
        }
        Ok(snap)
    }

    /// The snapshot a folder of rank files holds (`layout: PerRank`), put together: each
    /// rank's cells and faces at its block's place in the domain (the union of the blocks,
    /// which must tile a box once), the ranks' points one after the other in rank order
    /// (not the one-process run's point order). The values are the ranks', to the bit.
    pub fn read_folder(path: &Path) -> Result<Snapshot, Error> {
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .map_err(io)?
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("rank_")))
            .collect();
        files.sort();
        let pieces = files.iter().map(|f| Snapshot::read(f)).collect::<Result<Vec<_>, _>>()?;
        let Some(first) = pieces.first() else {
            return Err(model_error(path, "no rank_<r>.h5 file in it (not a snapshot written per rank)"));
        };
        let h = first.spacing;
        let bad = |what: String| model_error(path, what);
        // the blocks' corners and extents in cells of the first one's spacing
        let corner = |p: &Snapshot, a: usize| ((p.origin[a] - first.origin[a]) / h).round() as isize;
        let lo: [isize; DIM] = std::array::from_fn(|a| pieces.iter().map(|p| corner(p, a)).min().unwrap_or(0));
        let hi: [isize; DIM] = std::array::from_fn(|a| {
            pieces.iter().map(|p| corner(p, a) + p.cells_along()[a] as isize).max().unwrap_or(0)
        });
        let n: Index = std::array::from_fn(|a| (hi[a] - lo[a]) as usize);
        let cells: usize = n.iter().product();
        let mut whole = first.clone();
        whole.set_cells_along(n);
        whole.origin = std::array::from_fn(|a| first.origin[a] + h * lo[a] as Real);
        let own: usize = first.cells_along().iter().product();
        for a in whole.cell_arrays_mut() {
            *a = vec![0.0; a.len() / own.max(1) * cells];
        }
        for f in &mut whole.fields {
            if let Some(faces) = &mut f.faces {
                for (a, v) in faces.iter_mut().enumerate() {
                    let mut m = n;
                    m[a] += 1;
                    *v = vec![0.0; m.iter().product()];
                }
            }
            if let Some(p) = &mut f.points {
                p.values.values_mut().for_each(Vec::clear);
                p.body.clear();
            }
        }
        let mut covered = vec![0u8; cells];
        for (piece, file) in pieces.iter().zip(&files) {
            let b = piece.cells_along();
            let start: [usize; DIM] = std::array::from_fn(|a| (corner(piece, a) - lo[a]) as usize);
            let box_of = |extra: Option<usize>| -> [std::ops::Range<usize>; DIM] {
                std::array::from_fn(|a| start[a]..start[a] + b[a] + (extra == Some(a)) as usize)
            };
            let mut at = Vec::with_capacity(b.iter().product());
            crate::core::halo::for_each(n, &box_of(None), |k| at.push(k));
            at.iter().for_each(|&k| covered[k] += 1);
            let put = |into: &mut Arrays, from: &Arrays| -> Result<(), Error> {
                for (name, w) in into.iter_mut() {
                    let v = from.get(name).ok_or_else(|| bad(format!("{}: no array {name}", file.display())))?;
                    let per = w.len() / cells;
                    if v.len() != per * at.len() {
                        return Err(bad(format!("{}: {name} has {} values", file.display(), v.len())));
                    }
                    for (q, &k) in at.iter().enumerate() {
                        w[k * per..(k + 1) * per].copy_from_slice(&v[q * per..(q + 1) * per]);
                    }
                }
                Ok(())
            };
            put(&mut whole.cells, &piece.cells)?;
            if piece.fields.len() != whole.fields.len() {
                return Err(bad(format!("{}: another list of fields", file.display())));
            }
            for (f, g) in whole.fields.iter_mut().zip(&piece.fields) {
                put(&mut f.cells, &g.cells)?;
                if let (Some(faces), Some(mine)) = (&mut f.faces, &g.faces) {
                    for (a, (w, v)) in faces.iter_mut().zip(mine).enumerate() {
                        let mut m = n;
                        m[a] += 1;
                        let mut q = 0;
                        crate::core::halo::for_each(m, &box_of(Some(a)), |k| {
                            if let Some(&x) = v.get(q) {
                                w[k] = x;
                            }
                            q += 1;
                        });
                        if q != v.len() {
                            return Err(bad(format!("{}: {} faces along axis {a}", file.display(), v.len())));
                        }
                    }
                }
                if let (Some(p), Some(mine)) = (&mut f.points, &g.points) {
                    for (name, w) in p.values.iter_mut() {
                        w.extend_from_slice(mine.values.get(name).map_or(&[][..], Vec::as_slice));
                    }
                    p.body.extend_from_slice(&mine.body);
                    if p.bodies.is_empty() {
                        p.bodies = mine.bodies.clone();
                    }
                }
            }
        }
        if covered.iter().any(|&c| c != 1) {
            return Err(bad("its rank files' blocks do not tile a box once".into()));
        }
        Ok(whole)
    }

    /// The statistics of the `Suspension` monitor `name`, if written.
    pub fn suspension(&self, name: &str) -> Option<&SuspensionData> {
        self.suspensions.iter().find(|s| s.name == name)
    }

    /// The running time average of the monitor `name`, if written.
    pub fn average(&self, name: &str) -> Option<&AverageData> {
        self.averages.iter().find(|a| a.name == name)
    }

    /// The mixture's cell array of quantity `name`, if written.
    pub fn get(&self, name: &str) -> Option<&[Real]> {
        self.cells.get(name).map(Vec::as_slice)
    }

    /// The field named `name` (as in the case).
    pub fn field(&self, name: &str) -> Option<&FieldData> {
        self.fields.iter().find(|f| f.name == name)
    }

    /// Cells along each axis, x first.
    pub fn cells_along(&self) -> [usize; DIM] {
        #[cfg(feature = "dim2")]
        return [self.nx, self.ny];
        #[cfg(feature = "dim3")]
        return [self.nx, self.ny, self.nz];
    }

    /// The shape of a cell array in the file: the cells along each axis, slowest (z, or y
    /// in 2D) first.
    fn cell_dims(&self) -> Vec<u64> {
        self.cells_along().iter().rev().map(|&n| n as u64).collect()
    }

    /// The HDF5 file's bytes.
    pub fn to_hdf5(&self) -> Result<Vec<u8>, Error> {
        let n_cells: usize = self.cells_along().iter().product();
        let dims = self.cell_dims();
        let cell_shape = |len: usize| {
            let mut shape = dims.clone();
            if len == 3 * n_cells {
                shape.push(3);
            }
            shape
        };
        let mut b = FileBuilder::new();
        // the HDF5 1.8 format (version 2 superblock, contiguous datasets, no filters):
        // readable by every HDF5 library since 1.8, VisIt's and MATLAB's included
        b.with_libver_bounds(LibVer::Earliest, LibVer::V18);
        b.set_attr("time", AttrValue::F64(self.time));
        b.set_attr("step", AttrValue::I64(self.step as i64));
        b.set_attr("case", AttrValue::String(self.case.clone()));
        b.set_attr("program", AttrValue::String(self.program.clone()));
        b.set_attr("units", AttrValue::String(UNITS.into()));
        b.set_attr("cells", AttrValue::I64Array(self.cells_along().iter().map(|&n| n as i64).collect()));
        b.set_attr("origin", AttrValue::F64Array(self.origin.to_vec()));
        b.set_attr("spacing", AttrValue::F64(self.spacing));
        b.set_attr("fields", AttrValue::StringArray(self.fields.iter().map(|f| f.group.clone()).collect()));
        let attrs = |(units, what): (&str, &str)| {
            [("units", AttrValue::String(units.into())), ("description", AttrValue::String(what.into()))]
        };
        for (name, data) in &self.cells {
            let d = b.create_dataset(name);
            d.with_f64_data(data).with_shape(&cell_shape(data.len()));
            for (k, v) in attrs(describe(name, Place::Mixture)) {
                d.set_attr(k, v);
            }
        }
        let put = |g: &mut GroupBuilder, name: &str, data: &[Real], shape: &[u64], place: Place| {
            let d = g.create_dataset(name);
            d.with_f64_data(data).with_shape(shape);
            for (k, v) in attrs(describe(name, place)) {
                d.set_attr(k, v);
            }
        };
        let mut fields = b.create_group("fields");
        for f in &self.fields {
            let mut g = fields.create_group(&f.group);
            g.set_attr("name", AttrValue::String(f.name.clone()));
            g.set_attr("frame", AttrValue::String(f.frame.clone()));
            g.set_attr("material_density", AttrValue::F64(f.material_density));
            for (name, data) in &f.cells {
                put(&mut g, name, data, &cell_shape(data.len()), Place::Field);
            }
            if let Some(p) = &f.points {
                let n = p.len() as u64;
                let mut pg = g.create_group("points");
                pg.set_attr("count", AttrValue::I64(n as i64));
                if !p.bodies.is_empty() {
                    pg.set_attr("bodies", AttrValue::StringArray(p.bodies.clone()));
                }
                for (name, data) in &p.values {
                    let shape = if point_vector(name, data.len(), p.len()) { vec![n, 3] } else { vec![n] };
                    put(&mut pg, name, data, &shape, Place::Points);
                }
                let d = pg.create_dataset("body");
                d.with_i64_data(&p.body).with_shape(&[n]);
                for (k, v) in attrs(("-", "index of the point's body in the attribute `bodies`, -1 for none")) {
                    d.set_attr(k, v);
                }
                g.add_group(pg.finish());
            }
            if let Some(faces) = &f.faces {
                let mut fg = g.create_group("faces");
                #[cfg(feature = "dim2")]
                let descriptions = [
                    "x velocity on the x faces (the grid state), face (i, j) at x0 + i h, y0 + (j + 1/2) h",
                    "y velocity on the y faces (the grid state), face (i, j) at x0 + (i + 1/2) h, y0 + j h",
                ];
                #[cfg(feature = "dim3")]
                let descriptions = [
                    "x velocity on the x faces (the grid state), face (i, j, k) at x0 + i h, y0 + (j + 1/2) h, \
                     z0 + (k + 1/2) h",
                    "y velocity on the y faces (the grid state), face (i, j, k) at x0 + (i + 1/2) h, y0 + j h, \
                     z0 + (k + 1/2) h",
                    "z velocity on the z faces (the grid state), face (i, j, k) at x0 + (i + 1/2) h, \
                     y0 + (j + 1/2) h, z0 + k h",
                ];
                for (a, (data, description)) in faces.iter().zip(descriptions).enumerate() {
                    // the cells, one more along the faces' axis (the shape lists z, y, x)
                    let mut shape = dims.clone();
                    shape[DIM - 1 - a] += 1;
                    let d = fg.create_dataset(["u", "v", "w"][a]);
                    d.with_f64_data(data).with_shape(&shape);
                    for (k, v) in attrs(("length/time", description)) {
                        d.set_attr(k, v);
                    }
                }
                g.add_group(fg.finish());
            }
            fields.add_group(g.finish());
        }
        b.add_group(fields.finish());
        if !self.averages.is_empty() {
            let mut g = b.create_group("averages");
            for a in &self.averages {
                let place = if a.field.is_empty() { Place::Mixture } else { Place::Field };
                let d = g.create_dataset(&a.name);
                d.with_f64_data(&a.values).with_shape(&cell_shape(a.values.len()));
                let of = if a.field.is_empty() { "the mixture".to_string() } else { format!("field `{}`", a.field) };
                let what = format!(
                    "time average of `{}` of {of} over t in [{}, {}], {} samples (trapezoid rule)",
                    a.quantity, a.from, a.to, a.samples
                );
                for (k, v) in attrs((describe(&a.quantity, place).0, &what)) {
                    d.set_attr(k, v);
                }
                d.set_attr("quantity", AttrValue::String(a.quantity.clone()));
                d.set_attr("field", AttrValue::String(a.field.clone()));
                d.set_attr("from", AttrValue::F64(a.from));
                d.set_attr("to", AttrValue::F64(a.to));
                d.set_attr("samples", AttrValue::I64(a.samples as i64));
            }
            b.add_group(g.finish());
        }
        if !self.suspensions.is_empty() {
            let mut top = b.create_group("suspension");
            for s in &self.suspensions {
                let mut g = top.create_group(&s.name);
                g.set_attr("field", AttrValue::String(s.field.clone()));
                g.set_attr("axis", AttrValue::String(s.axis.clone()));
                g.set_attr("bins", AttrValue::I64(s.profiles.len() as i64));
                g.set_attr("bed_fraction", AttrValue::F64(s.bed_fraction));
                g.set_attr("contact_gap", AttrValue::F64(s.contact_gap));
                let d = g.create_dataset("statistics");
                d.with_f64_data(&s.statistics).with_shape(&[s.statistics.len() as u64]);
                d.set_attr("units", AttrValue::String("per column (docs/monitors.md, Suspension)".into()));
                d.set_attr(
                    "description",
                    AttrValue::String(format!(
                        "the statistics of the bodies of field `{}` at this step, as the row of monitors/{}.csv",
                        s.field, s.name
                    )),
                );
                d.set_attr("columns", AttrValue::StringArray(COLUMNS.iter().map(|c| c.to_string()).collect()));
                let flat: Vec<Real> = s.profiles.iter().flatten().copied().collect();
                let d = g.create_dataset("profiles");
                d.with_f64_data(&flat).with_shape(&[s.profiles.len() as u64, 4]);
                d.set_attr("units", AttrValue::String("length, -, length/time, length/time".into()));
                d.set_attr(
                    "description",
                    AttrValue::String(format!(
                        "per slab across {}: centre, solid fraction, area-weighted u_x and u_y (NaN: no solid), \
                         as monitors/{}_profiles.csv at this step",
                        s.axis, s.name
                    )),
                );
                d.set_attr(
                    "columns",
                    AttrValue::StringArray(SUSPENSION_PROFILE_COLUMNS.iter().map(|c| c.to_string()).collect()),
                );
                top.add_group(g.finish());
            }
            b.add_group(top.finish());
        }
        b.finish().map_err(|e| Error::Model(format!("cannot build the HDF5 snapshot: {e}")))
    }

    /// Writes the snapshot to `path` through a temporary file and a rename.
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        write_atomically(path, &self.to_hdf5()?)
    }

    /// Reads a snapshot file back: every dataset of the root, of each field's group and
    /// of its points.
    /// A folder of a snapshot written per rank (`snapshot_<n>/`, `layout: PerRank`) is read
    /// whole: its rank files put together ([`Snapshot::read_folder`]).
    pub fn read(path: &Path) -> Result<Snapshot, Error> {
        if path.is_dir() {
            return Snapshot::read_folder(path);
        }
        let err = |e: hdf5_pure::Error| model_error(path, e);
        let file = hdf5_pure::File::open(path).map_err(err)?;
        let root = file.root().attrs().map_err(err)?;
        let missing = |what: &str| model_error(path, format!("no valid attribute `{what}`"));
        let string = |a: &std::collections::HashMap<String, AttrValue>, k: &str| {
            a.get(k).and_then(AttrValue::as_str).map(str::to_string).ok_or_else(|| missing(k))
        };
        let real = |a: &std::collections::HashMap<String, AttrValue>, k: &str| {
            a.get(k).and_then(AttrValue::as_f64).ok_or_else(|| missing(k))
        };
        let cells = root.get("cells").and_then(AttrValue::to_i64s).ok_or_else(|| missing("cells"))?;
        let origin = root.get("origin").and_then(AttrValue::to_f64s).ok_or_else(|| missing("origin"))?;
        if cells.len() != DIM || origin.len() != DIM {
            return Err(model_error(
                path,
                format!("attribute `cells` has {} numbers: this is not a {DIM}D snapshot", cells.len()),
            ));
        }
        let f64s = |name: &str| file.dataset(name).and_then(|d| d.read_f64()).map_err(err);
        let arrays = |base: &str, names: Vec<String>, skip: &[&str]| -> Result<Arrays, Error> {
            let mut out = Arrays::new();
            for n in names.into_iter().filter(|n| !skip.contains(&n.as_str())) {
                let values = f64s(&format!("{base}{n}"))?;
                out.insert(n, values);
            }
            Ok(out)
        };
        let groups = root.get("fields").and_then(AttrValue::as_strings).ok_or_else(|| missing("fields"))?;
        let mut fields = Vec::new();
        for group in groups {
            let base = format!("fields/{group}");
            let fg = file.group(&base).map_err(err)?;
            let a = fg.attrs().map_err(err)?;
            let points = match file.group(&format!("{base}/points")) {
                Ok(pg) => {
                    let pa = pg.attrs().map_err(err)?;
                    Some(PointData {
                        values: arrays(&format!("{base}/points/"), pg.datasets().map_err(err)?, &["body"])?,
                        body: file.dataset(&format!("{base}/points/body")).and_then(|d| d.read_i64()).map_err(err)?,
                        bodies: pa
                            .get("bodies")
                            .and_then(AttrValue::as_strings)
                            .map(<[String]>::to_vec)
                            .unwrap_or_default(),
                    })
                }
                Err(_) => None,
            };
            fields.push(FieldData {
                name: string(&a, "name")?,
                group: group.clone(),
                frame: string(&a, "frame")?,
                material_density: real(&a, "material_density")?,
                cells: arrays(&format!("{base}/"), fg.datasets().map_err(err)?, &[])?,
                points,
                faces: {
                    let faces: Vec<Vec<Real>> =
                        ["u", "v", "w"][..DIM].iter().filter_map(|c| f64s(&format!("{base}/faces/{c}")).ok()).collect();
                    faces.try_into().ok()
                },
            });
        }
        Ok(Snapshot {
            case: string(&root, "case")?,
            program: string(&root, "program")?,
            time: real(&root, "time")?,
            step: root.get("step").and_then(AttrValue::as_i64).ok_or_else(|| missing("step"))? as u64,
            nx: cells[0] as usize,
            ny: cells[1] as usize,
            #[cfg(feature = "dim3")]
            nz: cells[2] as usize,
            origin: std::array::from_fn(|a| origin[a]),
            spacing: real(&root, "spacing")?,
            cells: arrays("", file.root().datasets().map_err(err)?, &[])?,
            fields,
            averages: match file.group("averages") {
                Ok(g) => {
                    let mut out = Vec::new();
                    for name in g.datasets().map_err(err)? {
                        let d = file.dataset(&format!("averages/{name}")).map_err(err)?;
                        let a = d.attrs().map_err(err)?;
                        out.push(AverageData {
                            quantity: string(&a, "quantity")?,
                            field: string(&a, "field")?,
                            from: real(&a, "from")?,
                            to: real(&a, "to")?,
                            samples: a.get("samples").and_then(AttrValue::as_i64).ok_or_else(|| missing("samples"))?
                                as u64,
                            values: d.read_f64().map_err(err)?,
                            name,
                        });
                    }
                    out.sort_by(|a: &AverageData, b| a.name.cmp(&b.name));
                    out
                }
                Err(_) => Vec::new(),
            },
            suspensions: match file.group("suspension") {
                Ok(g) => {
                    let mut out = Vec::new();
                    for name in g.groups().map_err(err)? {
                        let base = format!("suspension/{name}");
                        let a = file.group(&base).and_then(|g| g.attrs()).map_err(err)?;
                        let flat = f64s(&format!("{base}/profiles"))?;
                        out.push(SuspensionData {
                            field: string(&a, "field")?,
                            axis: string(&a, "axis")?,
                            bed_fraction: real(&a, "bed_fraction")?,
                            contact_gap: real(&a, "contact_gap")?,
                            statistics: f64s(&format!("{base}/statistics"))?,
                            profiles: flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect(),
                            name,
                        });
                    }
                    out.sort_by(|a: &SuspensionData, b| a.name.cmp(&b.name));
                    out
                }
                Err(_) => Vec::new(),
            },
        })
    }
}

/// The velocity of the field named `field` in the snapshot `file`, for an initial velocity
/// `FromSnapshot` ([`crate::core::mapping`]; registered by [`crate::link_all`]): its face
/// velocities (`/fields/<f>/faces/u`, `/faces/v`) when the snapshot has them, else its
/// cell-centred `velocity`. An error says what is wrong and how to fix it.
pub fn read_velocity(file: &Path, field: &str) -> Result<SampledVelocity, String> {
    #[cfg(feature = "dim3")]
    return Err(format!(
        "`FromSnapshot` ({}, field `{field}`) is not available in 3D yet (issue 17 brings 3D snapshots first)",
        file.display()
    ));
    #[cfg(feature = "dim2")]
    read_velocity_2d(file, field)
}

/// [`read_velocity`] of a 2D snapshot.
#[cfg(feature = "dim2")]
fn read_velocity_2d(file: &Path, field: &str) -> Result<SampledVelocity, String> {
    let shown = file.display();
    let how = "give the path of a snapshot a run wrote (`<run dir>/snapshots/snapshot_NNNNNN.h5`, \
               relative to the directory multifield runs in)";
    if !file.is_file() {
        return Err(format!("snapshot `{shown}` does not exist; {how}"));
    }
    let h5 = hdf5_pure::File::open(file).map_err(|e| format!("`{shown}` is not an HDF5 file ({e}); {how}"))?;
    let root = h5.root().attrs().map_err(|e| format!("`{shown}`: cannot read its attributes ({e}); {how}"))?;
    let program = root.get("program").and_then(AttrValue::as_str).unwrap_or_default().to_string();
    if !program.starts_with("multifield ") {
        return Err(format!("`{shown}` was not written by multifield (its `program` attribute is `{program}`); {how}"));
    }
    let cells = root.get("cells").and_then(AttrValue::to_i64s).unwrap_or_default();
    let origin = root.get("origin").and_then(AttrValue::to_f64s).unwrap_or_default();
    let spacing = root.get("spacing").and_then(AttrValue::as_f64).unwrap_or(0.0);
    if cells.len() != 2 || origin.len() != 2 {
        return Err(format!(
            "`{shown}` is not a 2D snapshot ({} cell counts and {} origin coordinates, written by `{program}`): \
             this build maps only the 2D snapshots it writes; map from a snapshot of a 2D run",
            cells.len(),
            origin.len()
        ));
    }
    let (nx, ny) = (cells[0].max(0) as usize, cells[1].max(0) as usize);
    if nx < 2 || ny < 2 || !(spacing > 0.0 && spacing.is_finite()) {
        return Err(format!(
            "`{shown}` has {nx} × {ny} cells of side {spacing}: mapping needs at least 2 × 2 cells of positive side"
        ));
    }
    let groups = root.get("fields").and_then(AttrValue::as_strings).map(<[String]>::to_vec).unwrap_or_default();
    let mut names = Vec::new();
    let mut found = None;
    for g in &groups {
        let a = h5.group(&format!("fields/{g}")).and_then(|g| g.attrs()).map_err(|e| format!("`{shown}`: {e}"))?;
        let name = a.get("name").and_then(AttrValue::as_str).unwrap_or(g).to_string();
        if name == field {
            found = Some(g.clone());
        }
        names.push(name);
    }
    let Some(group) = found else {
        return Err(format!(
            "snapshot `{shown}` has no field `{field}`; its fields: {}; set `field` to one of them",
            if names.is_empty() { "none".to_string() } else { names.join(", ") }
        ));
    };
    let read = |name: &str| h5.dataset(&format!("fields/{group}/{name}")).and_then(|d| d.read_f64()).ok();
    let [ox, oy] = [origin[0], origin[1]];
    let h = spacing;
    let at = |x0: Real, y0: Real, nx: usize, ny: usize, values: Vec<Real>| Samples { x0, y0, h, nx, ny, values };
    let (u, v, faces) = match (read("faces/u"), read("faces/v")) {
        (Some(u), Some(v)) if u.len() == (nx + 1) * ny && v.len() == nx * (ny + 1) => {
            (at(ox, oy + 0.5 * h, nx + 1, ny, u), at(ox + 0.5 * h, oy, nx, ny + 1, v), true)
        }
        _ => {
            let Some(c) = read("velocity") else {
                return Err(format!(
                    "field `{field}` of snapshot `{shown}` has no velocity (neither `faces/u`, `faces/v` nor \
                     `velocity`); map from a snapshot written with `\"velocity\"` in `output.snapshots.fields`"
                ));
            };
            if c.len() != 3 * nx * ny {
                return Err(format!(
                    "field `{field}` of snapshot `{shown}` has {} velocity values for {nx} × {ny} cells (3 each \
                     expected): the file is damaged or not a snapshot of this program",
                    c.len()
                ));
            }
            let (x0, y0) = (ox + 0.5 * h, oy + 0.5 * h);
            let u = c.chunks_exact(3).map(|w| w[0]).collect();
            let v = c.chunks_exact(3).map(|w| w[1]).collect();
            (at(x0, y0, nx, ny, u), at(x0, y0, nx, ny, v), false)
        }
    };
    if u.values.iter().chain(&v.values).any(|x| !x.is_finite()) {
        return Err(format!("field `{field}` of snapshot `{shown}` has a velocity that is not finite"));
    }
    Ok(SampledVelocity { u, v, origin: [ox, oy], size: [nx as Real * h, ny as Real * h], cells: [nx, ny], faces })
}

/// The statistics of the case's `Suspension` monitors at the simulation's current state
/// (by monitor name).
fn suspensions_of(sim: &Simulation) -> Vec<SuspensionData> {
    let case = &sim.case;
    let specs: Vec<_> = case
        .monitors
        .iter()
        .filter_map(|m| match &m.of {
            Monitored::Suspension { field, axis, bins, bed_fraction, contact_gap } => {
                Some((m.name.clone(), field, *axis, *bins, *bed_fraction, *contact_gap))
            }
            _ => None,
        })
        .collect();
    if specs.is_empty() {
        return Vec::new();
    }
    let bodies = sim.bodies();
    let mut out: Vec<SuspensionData> = specs
        .into_iter()
        .map(|(name, field, axis, bins, bed_fraction, contact_gap)| {
            let geometry = suspension::Geometry::new(
                case.domain.origin,
                case.domain.size,
                &case.boundaries,
                case.gravity,
                axis,
                bins,
                bed_fraction,
                contact_gap,
            );
            let chosen: Vec<&BodyState> = bodies.iter().filter(|(f, _)| f == field).map(|(_, b)| b).collect();
            let (statistics, profiles) = suspension::sample(&geometry, &chosen);
            SuspensionData {
                name,
                field: field.clone(),
                axis: format!("{axis:?}"),
                bed_fraction,
                contact_gap,
                statistics,
                profiles,
            }
        })
        .collect();
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}

/// Whether the point array `name` of `len` values on `n` points is a vector: 3 values a
/// point, or, with no points (a rank that holds none), a vector quantity.
fn point_vector(name: &str, len: usize, n: usize) -> bool {
    if n > 0 {
        len == 3 * n
    } else {
        quantity::find(name, Place::Points).is_ok_and(|q| q.components == 3)
    }
}

/// An array of a snapshot as the XDMF lists it: its name and whether it is a vector.
type Listed = Vec<(String, bool)>;

/// What the XDMF needs to know of one field of a written snapshot.
#[derive(Clone, Debug, PartialEq)]
struct FieldEntry {
    group: String,
    cells: Listed,
    /// The point count and the point arrays (`None` for a field without points).
    points: Option<(usize, Listed)>,
}

/// What the XDMF needs to know of one written snapshot.
#[derive(Clone, Debug)]
struct Entry {
    file: String,
    time: Real,
    step: u64,
    cells: Listed,
    fields: Vec<FieldEntry>,
    /// The running time averages (`/averages/<name>`).
    averages: Listed,
    /// The ranks' files of a snapshot written per rank (`file` is then their folder);
    /// empty for one file.
    pieces: Vec<Piece>,
}

/// One rank's file of a snapshot written per rank: its block and its points.
#[derive(Clone, Debug, PartialEq)]
struct Piece {
    /// The file, from the snapshots' folder.
    file: String,
    /// The block's cells along each axis.
    cells: Index,
    /// The block's lower corner.
    origin: [Real; DIM],
    /// The point count of each field that has points, in the order of the fields.
    points: Vec<usize>,
}

impl Piece {
    /// The words another rank needs of this one (cells, origin, point counts).
    fn encode(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.cells.iter().for_each(|&n| out.extend_from_slice(&(n as u64).to_le_bytes()));
        self.origin.iter().for_each(|&x| out.extend_from_slice(&x.to_le_bytes()));
        self.points.iter().for_each(|&n| out.extend_from_slice(&(n as u64).to_le_bytes()));
        out
    }

    /// [`Piece::encode`]'s inverse.
    fn decode(file: String, bytes: &[u8]) -> Piece {
        let mut words = bytes.chunks_exact(8).map(|w| <[u8; 8]>::try_from(w).expect("8 bytes"));
        let cells = std::array::from_fn(|_| u64::from_le_bytes(words.next().expect("a piece's cells")) as usize);
        let origin = std::array::from_fn(|_| f64::from_le_bytes(words.next().expect("a piece's origin")));
        let points = words.map(|w| u64::from_le_bytes(w) as usize).collect();
        Piece { file, cells, origin, points }
    }

    /// The piece of a rank's snapshot `snap` (its file named by the ranks that read it).
    fn of(snap: &Snapshot) -> Piece {
        Piece {
            file: String::new(),
            cells: snap.cells_along(),
            origin: snap.origin,
            points: snap.fields.iter().filter_map(|f| f.points.as_ref().map(PointData::len)).collect(),
        }
    }
}

impl Entry {
    /// The output index in the file (or folder) name.
    fn index(&self) -> Option<usize> {
        let n = self.file.strip_prefix("snapshot_")?;
        n.strip_suffix(".h5").unwrap_or(n).parse().ok()
    }

    /// What the XDMF needs of the folder `path` of a snapshot written per rank, read from
    /// its files (`rank_<r>.h5`, in rank order).
    fn read_folder(path: &Path) -> Result<Entry, Error> {
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)
            .map_err(io)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("rank_")) && p.is_file())
            .collect();
        files.sort();
        let folder = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let mut entry: Option<Entry> = None;
        let mut pieces = Vec::new();
        for f in &files {
            let e = Entry::read(f)?;
            let file = hdf5_pure::File::open(f).map_err(|e| model_error(f, e))?;
            let root = file.root().attrs().map_err(|e| model_error(f, e))?;
            let missing = |what: &str| model_error(f, format!("no valid attribute `{what}`"));
            let cells = root.get("cells").and_then(AttrValue::to_i64s).ok_or_else(|| missing("cells"))?;
            let origin = root.get("origin").and_then(AttrValue::to_f64s).ok_or_else(|| missing("origin"))?;
            if cells.len() != DIM || origin.len() != DIM {
                return Err(missing("cells"));
            }
            pieces.push(Piece {
                file: format!("{folder}/{}", f.file_name().map(|n| n.to_string_lossy()).unwrap_or_default()),
                cells: std::array::from_fn(|a| cells[a] as usize),
                origin: std::array::from_fn(|a| origin[a]),
                points: e.fields.iter().filter_map(|f| f.points.as_ref().map(|p| p.0)).collect(),
            });
            entry.get_or_insert(e);
        }
        let mut entry = entry.ok_or_else(|| model_error(path, "no rank_<r>.h5 file in it"))?;
        (entry.file, entry.pieces) = (folder, pieces);
        Ok(entry)
    }

    /// What the XDMF lists of `snap`, written as `file`.
    fn of(snap: &Snapshot, file: String) -> Entry {
        let n: usize = snap.cells_along().iter().product();
        let listed = |a: &Arrays, count: usize| -> Listed {
            a.iter().map(|(k, v)| (k.clone(), count > 0 && v.len() == 3 * count)).collect()
        };
        Entry {
            file,
            time: snap.time,
            step: snap.step,
            cells: listed(&snap.cells, n),
            fields: snap
                .fields
                .iter()
                .map(|f| FieldEntry {
                    group: f.group.clone(),
                    cells: listed(&f.cells, n),
                    points: f.points.as_ref().map(|p| {
                        (
                            p.len(),
                            p.values.iter().map(|(k, v)| (k.clone(), point_vector(k, v.len(), p.len()))).collect(),
                        )
                    }),
                })
                .collect(),
            averages: snap.averages.iter().map(|a| (a.name.clone(), a.values.len() == 3 * n && n > 0)).collect(),
            pieces: Vec::new(),
        }
    }

    /// What the XDMF needs of the snapshot file `path`, read from it.
    fn read(path: &Path) -> Result<Entry, Error> {
        let err = |e: hdf5_pure::Error| model_error(path, e);
        let file = hdf5_pure::File::open(path).map_err(err)?;
        let root = file.root().attrs().map_err(err)?;
        let missing = |what: &str| model_error(path, format!("no valid attribute `{what}`"));
        let time = root.get("time").and_then(AttrValue::as_f64).ok_or_else(|| missing("time"))?;
        let step = root.get("step").and_then(AttrValue::as_i64).ok_or_else(|| missing("step"))?;
        let groups = root.get("fields").and_then(AttrValue::as_strings).ok_or_else(|| missing("fields"))?;
        // a vector has one more dimension than a scalar of its place
        let listed = |base: &str, names: Vec<String>, scalar_rank: usize| -> Result<Listed, Error> {
            let mut out = Listed::new();
            for n in names {
                let rank = file.dataset(&format!("{base}{n}")).and_then(|d| d.shape()).map_err(err)?.len();
                out.push((n, rank > scalar_rank));
            }
            Ok(out)
        };
        let mut fields = Vec::new();
        for g in groups {
            let base = format!("fields/{g}");
            let names = file.group(&base).and_then(|fg| fg.datasets()).map_err(err)?;
            let points = match file.group(&format!("{base}/points")) {
                Ok(pg) => {
                    let count = pg
                        .attrs()
                        .map_err(err)?
                        .get("count")
                        .and_then(AttrValue::as_i64)
                        .ok_or_else(|| missing("count"))? as usize;
                    let names = pg.datasets().map_err(err)?.into_iter().filter(|n| n != "body").collect();
                    Some((count, listed(&format!("{base}/points/"), names, 1)?))
                }
                Err(_) => None,
            };
            fields.push(FieldEntry { group: g.clone(), cells: listed(&format!("{base}/"), names, 2)?, points });
        }
        let cells = listed("", file.root().datasets().map_err(err)?, 2)?;
        let averages = match file.group("averages") {
            Ok(g) => listed("averages/", g.datasets().map_err(err)?, 2)?,
            Err(_) => Listed::new(),
        };
        let file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        Ok(Entry { file, time, step: step as u64, cells, fields, averages, pieces: Vec::new() })
    }
}

/// Writer of `snapshots/` (module doc).
pub struct Snapshots {
    dir: PathBuf,
    xdmf: PathBuf,
    case: String,
    due: Moments,
    grid: Grid,
    written: Vec<Entry>,
    next_index: usize,
    spec: SnapshotSpec,
    /// Whether this process writes the files: one process, or rank 0 of a decomposed run
    /// (the other ranks gather their blocks into its snapshots and keep its schedule).
    writes: bool,
}

impl Snapshots {
    /// Prepares `dir/snapshots/`. The snapshots of an earlier run there are removed, except,
    /// when the simulation continues from a checkpoint (`sim.steps > 0`), those of the steps
    /// before it, which stay in the XDMF and keep their numbers.
    pub fn create(sim: &Simulation, dir: &Path, spec: SnapshotSpec) -> Result<Self, Error> {
        let interval = spec.interval;
        if !(interval.is_finite() && interval >= 0.0) || (interval == 0.0 && spec.times.is_empty() && !spec.at_end) {
            return Err(Error::invalid(
                "output.snapshots.interval",
                format!("{interval}: must be a positive time between snapshots (or give times or at_end)"),
            ));
        }
        let folder = dir.join(FOLDER);
        // (the other ranks of a decomposed run touch no file but their own per-rank ones)
        let writes = sim.grid.part.rank() == 0;
        let kept = if writes { Self::clean(&folder, sim.steps) } else { Ok(Vec::new()) };
        // every rank learns whether rank 0 could prepare the folder (and waits for it), and
        // the number of the next snapshot
        if sim.grid.part.any(kept.is_err()) {
            return kept.and(Err(Error::Model("rank 0 could not prepare the snapshots' folder".into())));
        }
        let kept = kept?;
        // numbered on: a gap in the numbers (a file removed by hand) is kept, never overwritten
        let mut next = [kept.iter().filter_map(|e| e.index()).max().map_or(0.0, |k| (k + 1) as Real)];
        sim.grid.part.max(&mut next);
        let next_index = next[0] as usize;
        // the schedule continues on the multiples of the interval, and the exact times after now
        let due = (interval > 0.0).then(|| {
            let first = (sim.time / interval - 1e-9).ceil().max(0.0) * interval;
            Due::new(first, interval)
        });
        Ok(Self {
            dir: folder.clone(),
            xdmf: folder.join(xdmf_name(&sim.case.name)),
            case: sim.case.name.clone(),
            due: Moments::new(due, &spec.times, spec.at_end, sim.time),
            // the domain's (a decomposed run's rank 0 writes the whole domain)
            grid: Grid::from_cells(sim.grid.domain, sim.grid.h, sim.grid.origin),
            writes,
            written: kept,
            next_index,
            spec,
        })
    }

    /// Prepares the snapshots' `folder`: the files and per-rank folders of an earlier run
    /// removed, but for a run continued from step `steps` (> 0) the readable snapshots of
    /// the steps before it, which are returned in order.
    fn clean(folder: &Path, steps: u64) -> Result<Vec<Entry>, Error> {
        let io = |source| Error::Io { path: folder.to_path_buf(), source };
        let mut kept = Vec::new();
        std::fs::create_dir_all(folder).map_err(io)?;
        for entry in std::fs::read_dir(folder).map_err(io)? {
            let path = entry.map_err(io)?.path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            if name.starts_with("snapshot_") && path.is_dir() {
                // a snapshot written per rank
                if steps > 0 {
                    if let Some(e) = Entry::read_folder(&path).ok().filter(|e| e.step < steps) {
                        kept.push(e);
                        continue;
                    }
                }
                std::fs::remove_dir_all(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
                continue;
            }
            let snapshot = name.starts_with("snapshot_") && name.ends_with(".h5");
            let ours = snapshot
                || (name.starts_with(".snapshot_") && name.ends_with(".h5.tmp"))
                || name.ends_with(".xdmf")
                || (name.starts_with('.') && name.ends_with(".xdmf.tmp"));
            if !ours || !path.is_file() {
                continue;
            }
            if snapshot && steps > 0 {
                // a run continued from a checkpoint keeps the readable snapshots before it
                if let Some(e) = Entry::read(&path).ok().filter(|e| e.step < steps) {
                    kept.push(e);
                    continue;
                }
            }
            std::fs::remove_file(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
        }
        kept.sort_by(|a, b| a.file.cmp(&b.file));
        Ok(kept)
    }

    /// Paths of the snapshots written so far, in order.
    pub fn files(&self) -> Vec<PathBuf> {
        self.written.iter().map(|e| self.dir.join(&e.file)).collect()
    }

    /// Path of the XDMF sidecar.
    pub fn xdmf_path(&self) -> &Path {
        &self.xdmf
    }

    /// Writes the snapshot of the current state and rewrites the XDMF.
    fn write(&mut self, sim: &Simulation) -> Result<(), Error> {
        if self.spec.layout == RankLayout::PerRank && !sim.grid.part.is_whole() {
            return self.write_per_rank(sim);
        }
        let snap = Snapshot::with(sim, &self.spec)?.gathered(&sim.grid);
        let file = file_name(self.next_index);
        self.written.push(Entry::of(&snap, file.clone()));
        let written = if self.writes {
            snap.write(&self.dir.join(&file))
                .and_then(|_| write_atomically(&self.xdmf, xdmf(&self.case, &self.grid, &self.written).as_bytes()))
        } else {
            Ok(())
        };
        // every rank of a decomposed run learns whether rank 0 could write
        if sim.grid.part.any(written.is_err()) {
            self.written.pop();
            return written.and(Err(Error::Model("rank 0 could not write a snapshot".into())));
        }
        self.next_index += 1;
        Ok(())
    }
}

impl Snapshots {
    /// [`Snapshots::write`] with `layout: PerRank` on a rank of a decomposed run: its block
    /// to `snapshot_<n>/rank_<r>.h5`, every rank's block and point counts gathered for the
    /// XDMF, which rank 0 rewrites once every rank's file is written.
    fn write_per_rank(&mut self, sim: &Simulation) -> Result<(), Error> {
        let part = &sim.grid.part;
        let snap = Snapshot::of_block(sim, &self.spec)?;
        let index = file_name(self.next_index);
        let folder = index.strip_suffix(".h5").unwrap_or(&index).to_string();
        let dir = self.dir.join(&folder);
        let rank_file = |r: usize| format!("rank_{r:04}.h5");
        let written = std::fs::create_dir_all(&dir)
            .map_err(|source| Error::Io { path: dir.clone(), source })
            .and_then(|_| snap.write(&dir.join(rank_file(part.rank()))));
        let mine = Piece::of(&snap).encode();
        let mut entry = Entry::of(&snap, folder.clone());
        entry.pieces = part
            .comm()
            .gather_all(&mine)
            .iter()
            .enumerate()
            .map(|(r, bytes)| Piece::decode(format!("{folder}/{}", rank_file(r)), bytes))
            .collect();
        self.written.push(entry);
        let failed = part.any(written.is_err());
        let xdmf = if !failed && self.writes {
            write_atomically(&self.xdmf, xdmf(&self.case, &self.grid, &self.written).as_bytes())
        } else {
            Ok(())
        };
        if failed || part.any(xdmf.is_err()) {
            self.written.pop();
            return written.and(xdmf).and(Err(Error::Model(format!(
                "another rank could not write its part of snapshot {folder} (its message is in its output)"
            ))));
        }
        self.next_index += 1;
        Ok(())
    }

    /// Whether [`Snapshots::after_step`] writes now.
    pub fn due(&self, sim: &Simulation, last: bool) -> bool {
        let done = self.written.last().is_some_and(|e| e.step == sim.steps);
        self.due.peek(sim.time, last) && !done
    }
    /// The snapshot at the start (t = 0, or the restart time) with an interval; without
    /// one, only a run continued from a step that landed on one of the `times` writes it
    /// again (its file from before the checkpoint's step was removed).
    pub fn start(&mut self, sim: &Simulation) -> Result<(), Error> {
        let interval = self.due.has_interval();
        self.due.check(sim.time, false);
        if interval || (sim.steps > 0 && self.due.is_exact_time(sim.time)) {
            self.write(sim)?;
        }
        Ok(())
    }
    /// After a step: a snapshot when one is due, and at the run's `last` step (once) with
    /// an interval or `at_end`.
    pub fn after_step(&mut self, sim: &Simulation, last: bool) -> Result<(), Error> {
        let due = self.due.check(sim.time, last);
        let done = self.written.last().is_some_and(|e| e.step == sim.steps);
        if due && !done {
            self.write(sim)?;
        }
        Ok(())
    }
}

impl Writer for Snapshots {
    fn name(&self) -> &str {
        "snapshots"
    }
    fn needs_grid_state_at_start(&self) -> bool {
        true
    }
    fn start(&mut self, sim: &Simulation) -> Result<(), Error> {
        Snapshots::start(self, sim)
    }
    fn needs_grid_state(&self, step: &Step) -> bool {
        self.due(step.sim, step.last)
    }
    fn after_step(&mut self, step: &Step) -> Result<(), Error> {
        Snapshots::after_step(self, step.sim, step.last)
    }
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&apos;")
}

/// The XDMF (version 2) of the snapshots `entries`: a temporal collection whose every time
/// is a spatial collection of the grid (a `3DCoRectMesh` one cell thick, cell data) and one
/// `Polyvertex` grid per field of material points (node data). Only forms VTK's XDMF reader
/// (ParaView's) reads correctly: a 3D mesh (`2DCoRectMesh` loads wrongly), 3-component
/// vectors, origin and spacing in z, y, x order.
fn xdmf(case: &str, grid: &Grid, entries: &[Entry]) -> String {
    use std::fmt::Write as _;
    let mut s =
        String::from("<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n");
    let _ = writeln!(
        s,
        "  <Domain>\n    <Grid Name=\"{}\" GridType=\"Collection\" CollectionType=\"Temporal\">",
        xml_escape(case)
    );
    for e in entries {
        let _ = writeln!(s, "      <Grid Name=\"step {}\" GridType=\"Collection\" CollectionType=\"Spatial\">", e.step);
        let _ = writeln!(s, "        <Time Value=\"{}\"/>", e.time);
        if e.pieces.is_empty() {
            let counts: Vec<usize> = e.fields.iter().filter_map(|f| f.points.as_ref().map(|p| p.0)).collect();
            let whole = Piece { file: e.file.clone(), cells: grid.n(), origin: grid.origin.into(), points: counts };
            xdmf_piece(&mut s, e, &whole, grid.h, "");
        } else {
            // a snapshot written per rank: each rank's block and points, one dataset
            for (r, piece) in e.pieces.iter().enumerate() {
                xdmf_piece(&mut s, e, piece, grid.h, &format!(" rank {r}"));
            }
        }
        s.push_str("      </Grid>\n");
    }
    s.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    s
}

/// The XDMF grids of one file of the snapshot `e` (the whole domain, or a rank's block):
/// the cells' mesh with the cell arrays, and a grid of each field's points.
fn xdmf_piece(s: &mut String, e: &Entry, piece: &Piece, h: Real, suffix: &str) {
    use std::fmt::Write as _;
    let item = |dims: &str, number: &str, format: &str, content: &str| {
        format!(
            "<DataItem Dimensions=\"{dims}\" NumberType=\"{number}\" Precision=\"8\" \
             Format=\"{format}\">{content}</DataItem>"
        )
    };
    let attribute = |name: &str, kind: &str, center: &str, item: String| {
        format!(
            "          <Attribute Name=\"{}\" AttributeType=\"{kind}\" Center=\"{center}\">\n            \
             {item}\n          </Attribute>\n",
            xml_escape(name)
        )
    };
    let (n, o) = (piece.cells, piece.origin);
    // a 2D grid is a mesh one cell thick; the dimensions list z, y, x
    #[cfg(feature = "dim2")]
    let (cells, nodes, origin) =
        (format!("1 {} {}", n[1], n[0]), format!("2 {} {}", n[1] + 1, n[0] + 1), format!("0 {} {}", o[1], o[0]));
    #[cfg(feature = "dim3")]
    let (cells, nodes, origin) = (
        format!("{} {} {}", n[2], n[1], n[0]),
        format!("{} {} {}", n[2] + 1, n[1] + 1, n[0] + 1),
        format!("{} {} {}", o[2], o[1], o[0]),
    );
    let (scalar, vector) = (cells.clone(), format!("{cells} 3"));
    let file = xml_escape(&piece.file);
    let hdf = |dims: &str, number: &str, path: &str| item(dims, number, "HDF", &format!("{file}:{path}"));
    let _ = writeln!(
        s,
        "        <Grid Name=\"grid{suffix}\" GridType=\"Uniform\">\n          \
         <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"{nodes}\"/>\n          \
         <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n            {}\n            {}\n          </Geometry>",
        item("3", "Float", "XML", &origin).replace("<DataItem", "<DataItem Name=\"Origin\""),
        item("3", "Float", "XML", &format!("{h} {h} {h}")).replace("<DataItem", "<DataItem Name=\"Spacing\""),
    );
    let mut arrays: Vec<(String, bool, String)> =
        e.cells.iter().map(|(q, v)| (q.clone(), *v, format!("/{q}"))).collect();
    for f in &e.fields {
        for (q, v) in &f.cells {
            arrays.push((format!("{}_{q}", f.group), *v, format!("/fields/{}/{q}", f.group)));
        }
    }
    for (a, v) in &e.averages {
        arrays.push((format!("average_{a}"), *v, format!("/averages/{a}")));
    }
    for (name, v, path) in arrays {
        let (kind, dims) = if v { ("Vector", &vector) } else { ("Scalar", &scalar) };
        s.push_str(&attribute(&name, kind, "Cell", hdf(dims, "Float", &path)));
    }
    s.push_str("        </Grid>\n");
    let with_points = e.fields.iter().filter_map(|f| f.points.as_ref().map(|(_, listed)| (&f.group, listed)));
    for ((g, listed), &n) in with_points.zip(&piece.points) {
        // the points' grid needs their positions
        if n == 0 || !listed.iter().any(|(q, _)| q == "position") {
            continue;
        }
        let base = format!("/fields/{g}/points");
        let _ = writeln!(
            s,
            "        <Grid Name=\"{} points{suffix}\" GridType=\"Uniform\">\n          \
             <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\"/>\n          \
             <Geometry GeometryType=\"XYZ\">\n            {}\n          </Geometry>",
            xml_escape(g),
            hdf(&format!("{n} 3"), "Float", &format!("{base}/position"))
        );
        let arrays = listed
            .iter()
            .filter(|(q, _)| q != "position")
            .map(|(q, v)| (q.as_str(), *v, "Float"))
            .chain([("body", false, "Int")]);
        for (q, v, number) in arrays {
            let (kind, dims) = if v { ("Vector", format!("{n} 3")) } else { ("Scalar", format!("{n}")) };
            s.push_str(&attribute(q, kind, "Node", hdf(&dims, number, &format!("{base}/{q}"))));
        }
        s.push_str("        </Grid>\n");
    }
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;
    use crate::core::math::Vector;

    #[test]
    fn vorticity_of_a_rigid_rotation_is_twice_the_angular_velocity() {
        let g = Grid::new(6, 5, 0.5, Vector::new(-1.0, 2.0));
        let w = 0.7;
        let mut vel = [vec![0.0; g.n_cells()], vec![0.0; g.n_cells()]];
        for j in 0..g.ny {
            for i in 0..g.nx {
                let p = g.cell_center(i, j);
                vel[0][g.cell(i, j)] = -w * p.y;
                vel[1][g.cell(i, j)] = w * p.x;
            }
        }
        for o in quantity::vorticity(&g, [false, false], &vel) {
            assert!((o - 2.0 * w).abs() < 1e-12, "{o}");
        }
    }

    fn arrays(v: &[(&str, Vec<Real>)]) -> Arrays {
        v.iter().map(|(k, x)| (k.to_string(), x.clone())).collect()
    }

    #[test]
    fn a_field_without_points_left_round_trips() {
        let field = FieldData {
            name: "sand grains".into(),
            group: "sand_grains".into(),
            frame: "lagrangian".into(),
            material_density: 2.5,
            cells: arrays(&[
                ("theta", vec![0.0, 0.5]),
                ("velocity", vec![0.0, 1.0, 0.0, 2.0, 3.0, 0.0]),
                ("vorticity", vec![0.1, -0.1]),
                ("density", vec![0.0, 1.25]),
            ]),
            points: Some(PointData::default()),
            faces: None,
        };
        let snap = Snapshot {
            case: "tiny".into(),
            program: program(),
            time: 0.25,
            step: 7,
            nx: 2,
            ny: 1,
            origin: [-1.0, 0.5],
            spacing: 0.1,
            cells: arrays(&[
                ("pressure", vec![1.0, f64::MIN_POSITIVE]),
                ("velocity", vec![0.5, 1.5, 0.0, 2.0, 3.0, 0.0]),
                ("vorticity", vec![0.0, 1e300]),
            ]),
            fields: vec![field],
            // by name, as they are written and read
            averages: vec![
                AverageData {
                    name: "p_mean".into(),
                    quantity: "pressure".into(),
                    field: String::new(),
                    from: 0.0,
                    to: 0.25,
                    samples: 8,
                    values: vec![0.5, -2.0],
                },
                AverageData {
                    name: "u_mean".into(),
                    quantity: "velocity".into(),
                    field: "sand grains".into(),
                    from: 0.125,
                    to: 0.25,
                    samples: 3,
                    values: vec![0.25, 1.0, 0.0, 2.5, -3.0, 0.0],
                },
            ],
            suspensions: vec![SuspensionData {
                name: "bed".into(),
                field: "sand grains".into(),
                axis: "Y".into(),
                bed_fraction: 0.99,
                contact_gap: 1e-3,
                statistics: (0..COLUMNS.len()).map(|k| 0.5 + k as Real).collect(),
                profiles: vec![[0.25, 0.3, -1.0, 2.0], [0.75, 0.0, 1e-300, -0.5]],
            }],
        };
        let path = std::env::temp_dir().join(format!("multifield-snapshot-{}.h5", std::process::id()));
        snap.write(&path).unwrap();
        assert_eq!(std::fs::read(&path).unwrap()[8], 2, "a version 2 superblock (HDF5 1.8)");
        assert_eq!(Snapshot::read(&path).unwrap(), snap);
        let entry = Entry::read(&path).unwrap();
        assert_eq!(entry.fields, Entry::of(&snap, file_name(0)).fields, "the vectors found from the datasets' shapes");
        assert_eq!((entry.step, entry.time, &entry.fields[0].points), (7, 0.25, &Some((0, Vec::new()))));
        assert!(entry.cells.contains(&("velocity".into(), true)) && entry.cells.contains(&("pressure".into(), false)));
        assert_eq!(entry.averages, [("p_mean".to_string(), false), ("u_mean".to_string(), true)]);
        std::fs::remove_file(&path).unwrap();
        // no grid of zero points in the XDMF
        let text = xdmf("tiny", &Grid::new(2, 1, 0.1, Vector::new(-1.0, 0.5)), &[entry]);
        assert!(!text.contains("Polyvertex") && text.contains("Dimensions=\"2 2 3\""), "{text}");
        assert!(text.contains(">0 0.5 -1</DataItem>"), "origin in z, y, x order: {text}");
        assert!(text.contains("Name=\"sand_grains_velocity\" AttributeType=\"Vector\""), "{text}");
        assert!(text.contains("Name=\"average_u_mean\" AttributeType=\"Vector\""), "{text}");
        assert!(text.contains(":/averages/p_mean</DataItem>"), "{text}");
    }

    #[test]
    fn group_names_are_safe_and_unique() {
        assert_eq!(group_names(&["water", "a/b", "a_b", "."]), ["water", "a_b", "a_b_2", "case"]);
    }
}
