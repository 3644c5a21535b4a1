//! HDF5 snapshots of the whole state with an XDMF sidecar for ParaView and VisIt
//! (`output.snapshots: Some((interval: T))` in the case).
//!
//! A run with snapshots writes into `snapshots/` of its output directory:
//!
//! - `snapshot_000000.h5`, `snapshot_000001.h5`, …: one file per output time, numbered by
//!   output index: t = 0, then every `interval` of simulated time (the first step at or past
//!   each multiple), and always the last step of the run, whatever ended it;
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
//! thick in z with the cell arrays `pressure`, `velocity`, `vorticity` and, per field,
//! `<f>_theta`, `<f>_velocity`, `<f>_vorticity`, `<f>_density`, and of `<f> points` for each
//! Lagrangian field: its points as vertices with `velocity`, `volume`, `stress` (σxx, σyy,
//! σxy as a 3-vector) and `body`.
//!
//! # Layout of a snapshot
//!
//! Grid arrays are row-major `(NY, NX)`, y slow and x fast (cell `(i, j)` at `j·NX + i`,
//! the order of `Simulation::pressure`); vectors are `(NY, NX, 3)` with z = 0 (ParaView reads
//! 2-component vectors wrongly). Every value is a cell-centre value, f64.
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
//! | `/fields/<f>/points/position` | (N, 3) | length | material points (Lagrangian fields), z = 0 |
//! | `/fields/<f>/points/velocity` | (N, 3) | length/time | z = 0 |
//! | `/fields/<f>/points/volume` | (N) | volume | current volume det F · V⁰ (area × unit depth) |
//! | `/fields/<f>/points/stress` | (N, 3) | force/area | Cauchy stress σxx, σyy, σxy |
//! | `/fields/<f>/points/body` | (N) | - | index of the point's body in `bodies`, −1 for none (i64) |
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
//! After a step, θ and the face velocities are the field's grid state as the step left it
//! ([`FieldState`](crate::core::field::FieldState): the corrected velocity; θ of a
//! Lagrangian field and of the field of region `Rest` from the step's particles-to-grid,
//! θ of an advected Eulerian field after its advection). Before the first step no step has
//! built that state, so the t = 0 snapshot reconstructs it as the run starts from it: θ
//! from the regions (the field of region `Rest` takes what the others leave), an Eulerian
//! field's velocity from its initial velocity on the faces, a Lagrangian field's by a
//! mass-weighted linear (cloud-in-cell) average of its points onto the faces; the
//! pressure is 0 until the first projection.
//!
//! Vorticity is computed at cell centres from the cell-centred velocity by central
//! differences, `(v[i+1] − v[i−1]) / 2h − (u[j+1] − u[j−1]) / 2h`; at a domain edge the
//! difference is one-sided (first order, into the domain), across a periodic side it wraps.

use crate::core::case::{Region, Schedule};
use crate::core::driver::{Step, Writer};
use crate::core::error::Error;
use crate::core::grid::{FaceVelocity, Grid, Lattice};
use crate::core::math::Real;
use crate::core::simulation::{region_fraction, Simulation};
use crate::frames::lagrangian::{Lagrangian, Points};
use crate::frames::mass_point::MassPoint;
use crate::output::{write_atomically, Due};
use hdf5_pure::{AttrValue, FileBuilder, GroupBuilder, LibVer};
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

/// The material points of a Lagrangian field in a snapshot (flattened row-major arrays).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointData {
    /// Positions, (N, 3) with z = 0.
    pub position: Vec<Real>,
    /// Velocities, (N, 3) with z = 0.
    pub velocity: Vec<Real>,
    /// Current volumes, (N).
    pub volume: Vec<Real>,
    /// Cauchy stress σxx, σyy, σxy, (N, 3).
    pub stress: Vec<Real>,
    /// Index of the point's body in [`PointData::bodies`], −1 for none, (N).
    pub body: Vec<i64>,
    /// Names of the field's bodies (empty when it has none).
    pub bodies: Vec<String>,
}

impl PointData {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.volume.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.volume.is_empty()
    }
}

/// One field in a snapshot: grid arrays are (NY, NX) row-major, vectors (NY, NX, 3).
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
    /// Volume fraction θ.
    pub theta: Vec<Real>,
    /// Cell-centred velocity, (NY, NX, 3).
    pub velocity: Vec<Real>,
    /// Vorticity of [`FieldData::velocity`].
    pub vorticity: Vec<Real>,
    /// Bulk density θ ρ⁰.
    pub density: Vec<Real>,
    /// Material points (Lagrangian fields).
    pub points: Option<PointData>,
}

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
    /// Lower-left corner of the domain.
    pub origin: [Real; 2],
    /// Cell side.
    pub spacing: Real,
    /// Pressure.
    pub pressure: Vec<Real>,
    /// Mixture velocity Σθₖuₖ / Σθₖ, (NY, NX, 3).
    pub velocity: Vec<Real>,
    /// Vorticity of the mixture velocity.
    pub vorticity: Vec<Real>,
    /// The fields, in the case's order.
    pub fields: Vec<FieldData>,
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

/// Linear (cloud-in-cell) mass-weighted average of the points' velocity onto the faces.
fn deposit_velocity(grid: &Grid, points: &Points) -> FaceVelocity {
    let mut vel = FaceVelocity::zeros(grid);
    for (lattice, comp) in [(Lattice::XFace, 0), (Lattice::YFace, 1)] {
        let (cols, rows) = grid.lattice_shape(lattice);
        let (ox, oy) = grid.lattice_offset(lattice);
        let mut num = vec![0.0; cols * rows];
        let mut den = vec![0.0; cols * rows];
        for p in 0..points.len() {
            let fx = (points.x[p].x - grid.origin.x) / grid.h - ox;
            let fy = (points.x[p].y - grid.origin.y) / grid.h - oy;
            let (i0, j0) = (fx.floor(), fy.floor());
            let (a, b) = (fx - i0, fy - j0);
            for (di, wx) in [(0, 1.0 - a), (1, a)] {
                for (dj, wy) in [(0, 1.0 - b), (1, b)] {
                    let (i, j) = (i0 as i64 + di, j0 as i64 + dj);
                    if i < 0 || j < 0 || i >= cols as i64 || j >= rows as i64 {
                        continue;
                    }
                    let k = i as usize + j as usize * cols;
                    let w = wx * wy * points.m[p];
                    num[k] += w * points.v[p][comp];
                    den[k] += w;
                }
            }
        }
        let out = if comp == 0 { &mut vel.u } else { &mut vel.v };
        for (o, (n, d)) in out.iter_mut().zip(num.iter().zip(&den)) {
            *o = if *d > 0.0 { n / d } else { 0.0 };
        }
    }
    vel
}

/// The fields' θ and face velocities: the grid state after a step, reconstructed from the
/// initial condition before the first one (module doc).
fn grid_states(sim: &Simulation) -> Vec<(Vec<Real>, FaceVelocity)> {
    if sim.steps > 0 {
        return sim.fields.iter().map(|f| (f.state.theta.clone(), f.state.velocity.clone())).collect();
    }
    let g = &sim.grid;
    let origin = [g.origin.x, g.origin.y];
    let mut occupied = vec![0.0; g.n_cells()];
    let mut out: Vec<(Vec<Real>, FaceVelocity)> = Vec::new();
    for (f, spec) in sim.fields.iter().zip(&sim.case.fields) {
        let theta: Vec<Real> = if f.fills_rest {
            Vec::new()
        } else {
            region_fraction(&spec.region, g).into_iter().map(|t| t * spec.volume_fraction).collect()
        };
        for (o, t) in occupied.iter_mut().zip(&theta) {
            *o += t;
        }
        let mut vel = match f.frame.as_any().downcast_ref::<Lagrangian>() {
            Some(l) => deposit_velocity(g, &l.points),
            None => {
                let mut vel = FaceVelocity::zeros(g);
                for j in 0..g.ny {
                    for i in 0..=g.nx {
                        let p = g.node_position(Lattice::XFace, i, j);
                        vel.u[g.xface(i, j)] = spec.velocity.at(p.x, p.y, origin)[0];
                    }
                }
                for j in 0..=g.ny {
                    for i in 0..g.nx {
                        let p = g.node_position(Lattice::YFace, i, j);
                        vel.v[g.yface(i, j)] = spec.velocity.at(p.x, p.y, origin)[1];
                    }
                }
                vel
            }
        };
        sim.boundaries.enforce(g, &mut vel);
        out.push((theta, vel));
    }
    for ((theta, _), f) in out.iter_mut().zip(&sim.fields) {
        if f.fills_rest {
            *theta = occupied.iter().map(|o| (1.0 - o).max(0.0)).collect();
        }
    }
    out
}

/// Cell-centred velocity (NY, NX, 3), z = 0: the mean of the two faces of each component.
fn cell_velocity(grid: &Grid, vel: &FaceVelocity) -> Vec<Real> {
    let mut out = vec![0.0; 3 * grid.n_cells()];
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let c = grid.cell(i, j);
            out[3 * c] = 0.5 * (vel.u[grid.xface(i, j)] + vel.u[grid.xface(i + 1, j)]);
            out[3 * c + 1] = 0.5 * (vel.v[grid.yface(i, j)] + vel.v[grid.yface(i, j + 1)]);
        }
    }
    out
}

/// Neighbours `(lo, hi)` of index `k` in `0..n` and the spacing between them in cells:
/// central inside, one-sided at an edge, wrapped when periodic.
fn stencil(k: usize, n: usize, periodic: bool) -> (usize, usize, Real) {
    if n < 2 {
        (k, k, 1.0)
    } else if periodic {
        ((k + n - 1) % n, (k + 1) % n, 2.0)
    } else if k == 0 {
        (0, 1, 1.0)
    } else if k == n - 1 {
        (n - 2, n - 1, 1.0)
    } else {
        (k - 1, k + 1, 2.0)
    }
}

/// Vorticity ∂v/∂x − ∂u/∂y at cell centres of a cell-centred velocity (NY, NX, 3) by central
/// differences, one-sided (first order) at a domain edge and wrapped across a periodic side.
pub fn vorticity(grid: &Grid, velocity: &[Real], periodic_x: bool, periodic_y: bool) -> Vec<Real> {
    let (nx, ny, h) = (grid.nx, grid.ny, grid.h);
    let mut out = vec![0.0; grid.n_cells()];
    for j in 0..ny {
        let (jl, jh, dj) = stencil(j, ny, periodic_y);
        for i in 0..nx {
            let (il, ih, di) = stencil(i, nx, periodic_x);
            let dvdx = (velocity[3 * grid.cell(ih, j) + 1] - velocity[3 * grid.cell(il, j) + 1]) / (di * h);
            let dudy = (velocity[3 * grid.cell(i, jh)] - velocity[3 * grid.cell(i, jl)]) / (dj * h);
            out[grid.cell(i, j)] = if il == ih { 0.0 } else { dvdx } - if jl == jh { 0.0 } else { dudy };
        }
    }
    out
}

fn point_data(sim: &Simulation, k: usize, l: &Lagrangian) -> PointData {
    let p = &l.points;
    let mut d = PointData {
        bodies: match &sim.case.fields[k].region {
            Region::Bodies(specs) => specs.iter().map(|b| b.name.clone()).collect(),
            _ => Vec::new(),
        },
        ..PointData::default()
    };
    for q in 0..p.len() {
        d.position.extend([p.x[q].x, p.x[q].y, 0.0]);
        d.velocity.extend([p.v[q].x, p.v[q].y, 0.0]);
        d.volume.push(p.volume(q));
        let s = &p.stress[q];
        d.stress.extend([s[(0, 0)], s[(1, 1)], s[(0, 1)]]);
        d.body.push(p.body[q] as i64 - 1);
    }
    d
}

/// The points of a mass-point field: one per body, no stress.
fn mass_point_data(m: &MassPoint) -> PointData {
    let mut d = PointData { bodies: m.points.iter().map(|p| p.state.name.clone()).collect(), ..PointData::default() };
    for (k, p) in m.points.iter().enumerate() {
        let s = &p.state;
        d.position.extend([s.position.x, s.position.y, 0.0]);
        d.velocity.extend([s.velocity.x, s.velocity.y, 0.0]);
        d.volume.push(s.volume);
        d.stress.extend([0.0; 3]);
        d.body.push(k as i64);
    }
    d
}

impl Snapshot {
    /// The snapshot of the simulation's current state (module doc).
    pub fn of(sim: &Simulation) -> Snapshot {
        let g = &sim.grid;
        let (px, py) = (sim.boundaries.periodic_x(), sim.boundaries.periodic_y());
        let states = grid_states(sim);
        let names: Vec<&str> = sim.fields.iter().map(|f| f.name.as_str()).collect();
        let groups = group_names(&names);
        let n = g.n_cells();
        let (mut sum_theta, mut sum_flux) = (vec![0.0; n], vec![0.0; 3 * n]);
        let mut fields = Vec::new();
        for (k, ((f, (theta, faces)), group)) in sim.fields.iter().zip(&states).zip(groups).enumerate() {
            let velocity = cell_velocity(g, faces);
            for c in 0..n {
                sum_theta[c] += theta[c];
                sum_flux[3 * c] += theta[c] * velocity[3 * c];
                sum_flux[3 * c + 1] += theta[c] * velocity[3 * c + 1];
            }
            let lagrangian = f.frame.as_any().downcast_ref::<Lagrangian>();
            fields.push(FieldData {
                name: f.name.clone(),
                group,
                frame: if f.frame.is_lagrangian() { "lagrangian" } else { "eulerian" }.into(),
                material_density: f.density,
                vorticity: vorticity(g, &velocity, px, py),
                density: theta.iter().map(|t| t * f.density).collect(),
                theta: theta.clone(),
                velocity,
                points: match lagrangian {
                    Some(l) => Some(point_data(sim, k, l)),
                    None => f.frame.as_any().downcast_ref::<MassPoint>().map(mass_point_data),
                },
            });
        }
        let mut velocity = vec![0.0; 3 * n];
        for c in 0..n {
            if sum_theta[c] > 0.0 {
                velocity[3 * c] = sum_flux[3 * c] / sum_theta[c];
                velocity[3 * c + 1] = sum_flux[3 * c + 1] / sum_theta[c];
            }
        }
        Snapshot {
            case: sim.case.name.clone(),
            program: program(),
            time: sim.time,
            step: sim.steps,
            nx: g.nx,
            ny: g.ny,
            origin: [g.origin.x, g.origin.y],
            spacing: g.h,
            pressure: sim.pressure.clone(),
            vorticity: vorticity(g, &velocity, px, py),
            velocity,
            fields,
        }
    }

    /// The HDF5 file's bytes.
    pub fn to_hdf5(&self) -> Result<Vec<u8>, Error> {
        let (nx, ny) = (self.nx as u64, self.ny as u64);
        let scalar = [ny, nx];
        let vector = [ny, nx, 3];
        let mut b = FileBuilder::new();
        // the HDF5 1.8 format (version 2 superblock, contiguous datasets, no filters):
        // readable by every HDF5 library since 1.8, VisIt's and MATLAB's included
        b.with_libver_bounds(LibVer::Earliest, LibVer::V18);
        b.set_attr("time", AttrValue::F64(self.time));
        b.set_attr("step", AttrValue::I64(self.step as i64));
        b.set_attr("case", AttrValue::String(self.case.clone()));
        b.set_attr("program", AttrValue::String(self.program.clone()));
        b.set_attr("units", AttrValue::String(UNITS.into()));
        b.set_attr("cells", AttrValue::I64Array(vec![self.nx as i64, self.ny as i64]));
        b.set_attr("origin", AttrValue::F64Array(self.origin.to_vec()));
        b.set_attr("spacing", AttrValue::F64(self.spacing));
        b.set_attr("fields", AttrValue::StringArray(self.fields.iter().map(|f| f.group.clone()).collect()));
        let attrs = |units: &str, what: &str| {
            [("units", AttrValue::String(units.into())), ("description", AttrValue::String(what.into()))]
        };
        let mut put = |name: &str, data: &[Real], shape: &[u64], units: &str, what: &str| {
            let d = b.create_dataset(name);
            d.with_f64_data(data).with_shape(shape);
            for (k, v) in attrs(units, what) {
                d.set_attr(k, v);
            }
        };
        put("pressure", &self.pressure, &scalar, "force/area", "pressure at cell centres");
        put("velocity", &self.velocity, &vector, "length/time", "mixture velocity sum(theta u)/sum(theta), z = 0");
        put("vorticity", &self.vorticity, &scalar, "1/time", "dv/dx - du/dy of the mixture velocity");
        let mut fields = b.create_group("fields");
        for f in &self.fields {
            let mut g = fields.create_group(&f.group);
            g.set_attr("name", AttrValue::String(f.name.clone()));
            g.set_attr("frame", AttrValue::String(f.frame.clone()));
            g.set_attr("material_density", AttrValue::F64(f.material_density));
            let put = |g: &mut GroupBuilder, name: &str, data: &[Real], shape: &[u64], units: &str, what: &str| {
                let d = g.create_dataset(name);
                d.with_f64_data(data).with_shape(shape);
                for (k, v) in attrs(units, what) {
                    d.set_attr(k, v);
                }
            };
            put(&mut g, "theta", &f.theta, &scalar, "-", "volume fraction");
            put(&mut g, "velocity", &f.velocity, &vector, "length/time", "velocity at cell centres, z = 0");
            put(&mut g, "vorticity", &f.vorticity, &scalar, "1/time", "dv/dx - du/dy of the field's velocity");
            put(&mut g, "density", &f.density, &scalar, "mass/volume", "bulk density theta rho0");
            if let Some(p) = &f.points {
                let n = p.len() as u64;
                let mut pg = g.create_group("points");
                pg.set_attr("count", AttrValue::I64(n as i64));
                if !p.bodies.is_empty() {
                    pg.set_attr("bodies", AttrValue::StringArray(p.bodies.clone()));
                }
                put(&mut pg, "position", &p.position, &[n, 3], "length", "material point positions, z = 0");
                put(&mut pg, "velocity", &p.velocity, &[n, 3], "length/time", "material point velocities, z = 0");
                put(&mut pg, "volume", &p.volume, &[n], "volume", "current volume (area x unit depth)");
                put(&mut pg, "stress", &p.stress, &[n, 3], "force/area", "Cauchy stress xx, yy, xy");
                let d = pg.create_dataset("body");
                d.with_i64_data(&p.body).with_shape(&[n]);
                for (k, v) in attrs("-", "index of the point's body in the attribute `bodies`, -1 for none") {
                    d.set_attr(k, v);
                }
                g.add_group(pg.finish());
            }
            fields.add_group(g.finish());
        }
        b.add_group(fields.finish());
        b.finish().map_err(|e| Error::Model(format!("cannot build the HDF5 snapshot: {e}")))
    }

    /// Writes the snapshot to `path` through a temporary file and a rename.
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        write_atomically(path, &self.to_hdf5()?)
    }

    /// Reads a snapshot file back.
    pub fn read(path: &Path) -> Result<Snapshot, Error> {
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
        if cells.len() != 2 || origin.len() != 2 {
            return Err(missing("cells"));
        }
        let f64s = |name: &str| file.dataset(name).and_then(|d| d.read_f64()).map_err(err);
        let groups = root.get("fields").and_then(AttrValue::as_strings).ok_or_else(|| missing("fields"))?;
        let mut fields = Vec::new();
        for group in groups {
            let base = format!("fields/{group}");
            let a = file.group(&base).and_then(|g| g.attrs()).map_err(err)?;
            let points = match file.group(&format!("{base}/points")) {
                Ok(pg) => {
                    let pa = pg.attrs().map_err(err)?;
                    Some(PointData {
                        position: f64s(&format!("{base}/points/position"))?,
                        velocity: f64s(&format!("{base}/points/velocity"))?,
                        volume: f64s(&format!("{base}/points/volume"))?,
                        stress: f64s(&format!("{base}/points/stress"))?,
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
                theta: f64s(&format!("{base}/theta"))?,
                velocity: f64s(&format!("{base}/velocity"))?,
                vorticity: f64s(&format!("{base}/vorticity"))?,
                density: f64s(&format!("{base}/density"))?,
                points,
            });
        }
        Ok(Snapshot {
            case: string(&root, "case")?,
            program: string(&root, "program")?,
            time: real(&root, "time")?,
            step: root.get("step").and_then(AttrValue::as_i64).ok_or_else(|| missing("step"))? as u64,
            nx: cells[0] as usize,
            ny: cells[1] as usize,
            origin: [origin[0], origin[1]],
            spacing: real(&root, "spacing")?,
            pressure: f64s("pressure")?,
            velocity: f64s("velocity")?,
            vorticity: f64s("vorticity")?,
            fields,
        })
    }
}

/// What the XDMF needs to know of one written snapshot.
#[derive(Clone, Debug)]
struct Entry {
    file: String,
    time: Real,
    step: u64,
    /// Field groups with their point counts (`None` for a field without points).
    fields: Vec<(String, Option<usize>)>,
}

impl Entry {
    /// The output index in the file name.
    fn index(&self) -> Option<usize> {
        self.file.strip_prefix("snapshot_")?.strip_suffix(".h5")?.parse().ok()
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
        let mut fields = Vec::new();
        for g in groups {
            let count = match file.group(&format!("fields/{g}/points")) {
                Ok(pg) => Some(
                    pg.attrs().map_err(err)?.get("count").and_then(AttrValue::as_i64).ok_or_else(|| missing("count"))?
                        as usize,
                ),
                Err(_) => None,
            };
            fields.push((g.clone(), count));
        }
        let file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        Ok(Entry { file, time, step: step as u64, fields })
    }
}

/// Writer of `snapshots/` (module doc).
pub struct Snapshots {
    dir: PathBuf,
    xdmf: PathBuf,
    case: String,
    due: Due,
    grid: Grid,
    written: Vec<Entry>,
    next_index: usize,
}

impl Snapshots {
    /// Prepares `dir/snapshots/`. The snapshots of an earlier run there are removed, except,
    /// when the simulation continues from a checkpoint (`sim.steps > 0`), those of the steps
    /// before it, which stay in the XDMF and keep their numbers.
    pub fn create(sim: &Simulation, dir: &Path, schedule: Schedule) -> Result<Self, Error> {
        let interval = schedule.interval;
        if !(interval.is_finite() && interval > 0.0) {
            return Err(Error::invalid(
                "output.snapshots.interval",
                format!("{interval}: must be a positive time between snapshots"),
            ));
        }
        let folder = dir.join(FOLDER);
        let io = |source| Error::Io { path: folder.clone(), source };
        std::fs::create_dir_all(&folder).map_err(io)?;
        let mut kept = Vec::new();
        for entry in std::fs::read_dir(&folder).map_err(io)? {
            let path = entry.map_err(io)?.path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let snapshot = name.starts_with("snapshot_") && name.ends_with(".h5");
            let ours = snapshot
                || (name.starts_with(".snapshot_") && name.ends_with(".h5.tmp"))
                || name.ends_with(".xdmf")
                || (name.starts_with('.') && name.ends_with(".xdmf.tmp"));
            if !ours || !path.is_file() {
                continue;
            }
            if snapshot && sim.steps > 0 {
                // a run continued from a checkpoint keeps the readable snapshots before it
                if let Some(e) = Entry::read(&path).ok().filter(|e| e.step < sim.steps) {
                    kept.push(e);
                    continue;
                }
            }
            std::fs::remove_file(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
        }
        kept.sort_by(|a, b| a.file.cmp(&b.file));
        // numbered on: a gap in the numbers (a file removed by hand) is kept, never overwritten
        let next_index = kept.iter().filter_map(|e| e.index()).max().map_or(0, |k| k + 1);
        // the schedule continues on the multiples of the interval
        let first = (sim.time / interval - 1e-9).ceil().max(0.0) * interval;
        Ok(Self {
            dir: folder.clone(),
            xdmf: folder.join(xdmf_name(&sim.case.name)),
            case: sim.case.name.clone(),
            due: Due::new(first, interval),
            grid: sim.grid.clone(),
            written: kept,
            next_index,
        })
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
        let snap = Snapshot::of(sim);
        let file = file_name(self.next_index);
        snap.write(&self.dir.join(&file))?;
        self.next_index += 1;
        self.written.push(Entry {
            file,
            time: snap.time,
            step: snap.step,
            fields: snap.fields.iter().map(|f| (f.group.clone(), f.points.as_ref().map(PointData::len))).collect(),
        });
        write_atomically(&self.xdmf, xdmf(&self.case, &self.grid, &self.written).as_bytes())
    }
}

impl Snapshots {
    /// Whether [`Snapshots::after_step`] writes now.
    pub fn due(&self, sim: &Simulation, last: bool) -> bool {
        let done = self.written.last().is_some_and(|e| e.step == sim.steps);
        (self.due.peek(sim.time) || last) && !done
    }
    /// The snapshot at the start (t = 0, or the restart time).
    pub fn start(&mut self, sim: &Simulation) -> Result<(), Error> {
        self.due.check(sim.time);
        self.write(sim)
    }
    /// After a step: a snapshot when one is due, and at the run's `last` step (once).
    pub fn after_step(&mut self, sim: &Simulation, last: bool) -> Result<(), Error> {
        let due = self.due.check(sim.time);
        let done = self.written.last().is_some_and(|e| e.step == sim.steps);
        if (due || last) && !done {
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
    let (nx, ny, h) = (grid.nx, grid.ny, grid.h);
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
    let mut s =
        String::from("<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n");
    let _ = writeln!(
        s,
        "  <Domain>\n    <Grid Name=\"{}\" GridType=\"Collection\" CollectionType=\"Temporal\">",
        xml_escape(case)
    );
    let (scalar, vector) = (format!("1 {ny} {nx}"), format!("1 {ny} {nx} 3"));
    for e in entries {
        let file = xml_escape(&e.file);
        let hdf = |dims: &str, number: &str, path: &str| item(dims, number, "HDF", &format!("{file}:{path}"));
        let _ = writeln!(s, "      <Grid Name=\"step {}\" GridType=\"Collection\" CollectionType=\"Spatial\">", e.step);
        let _ = writeln!(s, "        <Time Value=\"{}\"/>", e.time);
        let _ = writeln!(
            s,
            "        <Grid Name=\"grid\" GridType=\"Uniform\">\n          \
             <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"2 {} {}\"/>\n          \
             <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n            {}\n            {}\n          </Geometry>",
            ny + 1,
            nx + 1,
            item("3", "Float", "XML", &format!("0 {} {}", grid.origin.y, grid.origin.x))
                .replace("<DataItem", "<DataItem Name=\"Origin\""),
            item("3", "Float", "XML", &format!("{h} {h} {h}")).replace("<DataItem", "<DataItem Name=\"Spacing\""),
        );
        let mut cells = vec![("pressure".to_string(), false, "/pressure".to_string())];
        cells.push(("velocity".into(), true, "/velocity".into()));
        cells.push(("vorticity".into(), false, "/vorticity".into()));
        for (g, _) in &e.fields {
            for (q, v) in [("theta", false), ("velocity", true), ("vorticity", false), ("density", false)] {
                cells.push((format!("{g}_{q}"), v, format!("/fields/{g}/{q}")));
            }
        }
        for (name, v, path) in cells {
            let (kind, dims) = if v { ("Vector", &vector) } else { ("Scalar", &scalar) };
            s.push_str(&attribute(&name, kind, "Cell", hdf(dims, "Float", &path)));
        }
        s.push_str("        </Grid>\n");
        for (g, n) in &e.fields {
            let Some(n) = n.filter(|n| *n > 0) else { continue };
            let base = format!("/fields/{g}/points");
            let _ = writeln!(
                s,
                "        <Grid Name=\"{} points\" GridType=\"Uniform\">\n          \
                 <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\"/>\n          \
                 <Geometry GeometryType=\"XYZ\">\n            {}\n          </Geometry>",
                xml_escape(g),
                hdf(&format!("{n} 3"), "Float", &format!("{base}/position"))
            );
            for (q, kind, dims, number) in [
                ("velocity", "Vector", format!("{n} 3"), "Float"),
                ("volume", "Scalar", format!("{n}"), "Float"),
                ("stress", "Vector", format!("{n} 3"), "Float"),
                ("body", "Scalar", format!("{n}"), "Int"),
            ] {
                s.push_str(&attribute(q, kind, "Node", hdf(&dims, number, &format!("{base}/{q}"))));
            }
            s.push_str("        </Grid>\n");
        }
        s.push_str("      </Grid>\n");
    }
    s.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::math::Vector;

    #[test]
    fn vorticity_of_a_rigid_rotation_is_twice_the_angular_velocity() {
        let g = Grid::new(6, 5, 0.5, Vector::new(-1.0, 2.0));
        let w = 0.7;
        let mut vel = vec![0.0; 3 * g.n_cells()];
        for j in 0..g.ny {
            for i in 0..g.nx {
                let p = g.cell_center(i, j);
                vel[3 * g.cell(i, j)] = -w * p.y;
                vel[3 * g.cell(i, j) + 1] = w * p.x;
            }
        }
        for o in vorticity(&g, &vel, false, false) {
            assert!((o - 2.0 * w).abs() < 1e-12, "{o}");
        }
    }

    #[test]
    fn a_field_without_points_left_round_trips() {
        let field = FieldData {
            name: "sand grains".into(),
            group: "sand_grains".into(),
            frame: "lagrangian".into(),
            material_density: 2.5,
            theta: vec![0.0, 0.5],
            velocity: vec![0.0, 1.0, 0.0, 2.0, 3.0, 0.0],
            vorticity: vec![0.1, -0.1],
            density: vec![0.0, 1.25],
            points: Some(PointData::default()),
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
            pressure: vec![1.0, f64::MIN_POSITIVE],
            velocity: vec![0.5, 1.5, 0.0, 2.0, 3.0, 0.0],
            vorticity: vec![0.0, 1e300],
            fields: vec![field],
        };
        let path = std::env::temp_dir().join(format!("multifield-snapshot-{}.h5", std::process::id()));
        snap.write(&path).unwrap();
        assert_eq!(std::fs::read(&path).unwrap()[8], 2, "a version 2 superblock (HDF5 1.8)");
        assert_eq!(Snapshot::read(&path).unwrap(), snap);
        let entry = Entry::read(&path).unwrap();
        assert_eq!((entry.step, entry.time, entry.fields), (7, 0.25, vec![("sand_grains".to_string(), Some(0))]));
        std::fs::remove_file(&path).unwrap();
        // no grid of zero points in the XDMF
        let e = Entry { file: file_name(0), time: 0.0, step: 0, fields: vec![("sand_grains".into(), Some(0))] };
        let text = xdmf("tiny", &Grid::new(2, 1, 0.1, Vector::new(-1.0, 0.5)), &[e]);
        assert!(!text.contains("Polyvertex") && text.contains("Dimensions=\"2 2 3\""), "{text}");
        assert!(text.contains(">0 0.5 -1</DataItem>"), "origin in z, y, x order: {text}");
    }

    #[test]
    fn group_names_are_safe_and_unique() {
        assert_eq!(group_names(&["water", "a/b", "a_b", "."]), ["water", "a_b", "a_b_2", "case"]);
    }
}
