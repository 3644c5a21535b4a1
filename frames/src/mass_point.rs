//! Mass-point frame: each disk of a field is ONE material point {m, X, U, ω, V = πd²/4, d}
//! (docs/method.md §4), the `representation: MassPoint` of a body list.
//!
//! **Particles to grid.** The point's volume is spread over the cells its disk covers with
//! the exact disk ∩ cell areas ([`multifield_core::geometry`]), so θ ≤ 1 in every cell and
//! Σ θ h² = V to round-off, whether the disk is smaller or larger than a cell, on a face,
//! next to a wall or across a periodic side. The face fractions follow from the cell ones
//! as for every field (mean of the two neighbours); the point puts mass ρ_s θ_face h² on
//! each face it touches, moving with U. The fluid therefore sees the displaced volume in
//! the pressure equation (buoyancy is −θ_s ∇p by itself) and the drag in the exchange.
//!
//! **Grid to particles.** The point takes the mass-weighted mean of its faces' velocity
//! increments (FLIP): ΔU = Σ w_f (u_f − u_f^old) / Σ w_f over the faces it covers (walls'
//! fixed faces left out). With the exchange's momentum conservation on every face, the
//! point and the fluid exchange momentum exactly. The hydrodynamic force recorded in
//! `bodies.csv` is m ΔU/Δt − m g; contact forces act after it, as on resolved bodies.
//!
//! **Rotation.** With a drag law's `rotation: true` the point feels the torque per unit
//! length T = 4πμa² (½ ∇×u_f − ω) of a cylinder in a fluid rotating at ½∇×u_f (the
//! fluid's vorticity averaged over the footprint with the weights θ), integrated
//! implicitly: ω ← (I ω + Δt (c Ω_f + T_contact)) / (I + Δt c), c = 4πμa², I = m a²/2.
//!
//! **Validity.** The point model assumes d ≲ h and a Reynolds number in its drag law's
//! range; [`Frame::warnings`] names every point that left either, with the ratio.
//!
//! **On ranks** (docs/design/mpi.md §6) every rank holds every point (a body's state is a
//! few dozen numbers) and computes every footprint on the domain's grid. A rank sums onto
//! the nodes it owns and takes its halo from its neighbours; at grid-to-particles each
//! footprint node's values (the velocity increment, the fluid's velocity, the vorticity)
//! come from the rank that owns the node, gathered once a step, and every rank then moves
//! every point with the serial arithmetic: the points stay the same on every rank, and the
//! one-process bits. A point changes rank by moving; nothing migrates.

use multifield_core::boundary::Boundaries;
use multifield_core::case::{BodyShape, Motion, Region};
use multifield_core::decomposition::Block;
use multifield_core::field::FieldState;
use multifield_core::geometry::disk_cell_fractions;
use multifield_core::grid::{Grid, Lattice};
use multifield_core::math::{Matrix, Real, Vector};
use multifield_core::plugin::{BodyState, Frame, FrameContext, InitContext};
use multifield_core::quantity::{vorticity_at, PointSet};
use multifield_core::registry::params_value;
use multifield_core::state;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::any::Any;
use std::borrow::Cow;
use std::f64::consts::PI;

/// The mass-point frame (no parameters).
#[derive(Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassPoint {
    /// The points, one per body.
    #[serde(skip)]
    pub points: Vec<PointBody>,
    /// The drag law's name and Re range, once a step has seen it.
    #[serde(skip)]
    law: Option<(&'static str, (Real, Real))>,
    /// Whether the case's contact model keeps the bodies off the sides (then the contact
    /// meets the walls, and the frame only keeps the centres in the domain).
    #[serde(skip)]
    contact_walls: bool,
    /// The domain's grid, on which the footprints are numbered (a rank's block is the
    /// phases' `ctx.grid`; on one rank the two are the same).
    #[serde(skip)]
    domain: Grid,
    /// Whether the domain is periodic along each axis (a rank's own boundaries have `Halo`
    /// sides where it is cut).
    #[serde(skip)]
    periodic: [bool; 2],
}

/// One body as a mass point.
#[derive(Clone, Debug)]
pub struct PointBody {
    /// Free, fixed or prescribed.
    pub motion: Motion,
    /// Mass, volume, radius, position, velocity, rotation, forces (`bodies.csv`).
    pub state: BodyState,
    /// Material density of the body (its own, or the field's).
    pub density: Real,
    /// Largest particle Reynolds number ρ_f |U − u_f| d / μ seen (0 without a drag law).
    pub max_reynolds: Real,
    /// Cells of the footprint and their θ.
    cells: Vec<(usize, Real)>,
    /// x-faces of the footprint and their θ (with repeats).
    xfaces: Vec<(usize, Real)>,
    /// y-faces of the footprint and their θ (with repeats).
    yfaces: Vec<(usize, Real)>,
    /// Whether the footprint reaches a face on the domain's sides (one a wall may fix):
    /// only then does the gather look for fixed faces.
    edge: bool,
    /// What grid-to-particles reads at each x-face of the footprint: the velocity increment
    /// u − u_old and the partner fluid's u (0 without one), `None` where the velocity is
    /// fixed by a wall.
    xval: Vec<Option<[Real; 2]>>,
    /// The same at each y-face.
    yval: Vec<Option<[Real; 2]>>,
    /// The partner fluid's vorticity at each cell of the footprint (with a drag law's
    /// `rotation` only).
    vort: Vec<Real>,
}

impl PointBody {
    /// Reads [`PointBody::xval`], `yval`, `vort` from the whole domain's grid state `s`
    /// and the partner's (one rank).
    fn sample(&mut self, g: &Grid, bc: &Boundaries, s: &FieldState, partner: Option<&FieldState>, rotation: bool) {
        let nx = g.nx;
        let edge = self.edge;
        self.xval.clear();
        for &(f, _) in &self.xfaces {
            let fixed = edge && bc.xface_fixed(g, f % (nx + 1));
            self.xval.push(
                (!fixed).then(|| [s.velocity.u[f] - s.velocity_old.u[f], partner.map_or(0.0, |pt| pt.velocity.u[f])]),
            );
        }
        self.yval.clear();
        for &(f, _) in &self.yfaces {
            let fixed = edge && bc.yface_fixed(g, f / nx);
            self.yval.push(
                (!fixed).then(|| [s.velocity.v[f] - s.velocity_old.v[f], partner.map_or(0.0, |pt| pt.velocity.v[f])]),
            );
        }
        self.vort.clear();
        if let Some(pt) = partner.filter(|_| rotation) {
            for &(c, _) in &self.cells {
                self.vort.push(MassPoint::vorticity(g, bc, &pt.velocity.u, &pt.velocity.v, c));
            }
        }
    }

    /// The domain's nodes of the footprint in the order grid-to-particles reads them: the
    /// x-faces, the y-faces, and (`cells`) the cells.
    fn nodes<'a>(&'a self, b: &'a RankBlock, cells: bool) -> impl Iterator<Item = (Lattice, [usize; 2])> + 'a {
        let x = self.xfaces.iter().map(|&(f, _)| (Lattice::XFace, f));
        let y = self.yfaces.iter().map(|&(f, _)| (Lattice::YFace, f));
        let c = self.cells.iter().filter(move |_| cells).map(|&(c, _)| (Lattice::Cell, c));
        x.chain(y).chain(c).map(|(lattice, k)| (lattice, b.node(lattice, k)))
    }
}

/// A rank's block in the domain's numbering of the footprints.
struct RankBlock<'a> {
    /// The rank's storage (its `Grid`).
    grid: &'a Grid,
    /// Its block of the rank grid (owned nodes, the domain's cells and periodic axes).
    block: &'a Block,
    /// The low side's padding along each axis.
    pad: [usize; 2],
    /// Whether the rank holds all of an axis with no padding (its storage is the domain's
    /// along it, face n included).
    whole: [bool; 2],
}

impl<'a> RankBlock<'a> {
    fn of(grid: &'a Grid) -> Option<Self> {
        let (_, block) = grid.part.block()?;
        let pads = [grid.part.pads(0), grid.part.pads(1)];
        Some(Self {
            grid,
            block,
            pad: [pads[0][0], pads[1][0]],
            whole: std::array::from_fn(|a| pads[a] == [0, 0] && block.cells[a] == (0..block.n[a])),
        })
    }

    /// The domain's node (column, row) of a footprint's index on `lattice`.
    fn node(&self, lattice: Lattice, k: usize) -> [usize; 2] {
        let row = self.block.n[0] + (lattice == Lattice::XFace) as usize;
        [k % row, k / row]
    }

    /// The storage index of the domain's node `at` when this rank owns it
    /// ([`Block::owned_global`]), as the sums onto the grid need it: face n of a periodic
    /// axis is nobody's (its halo copy of face 0 arrives with the halo) unless the rank
    /// holds the whole axis.
    fn owned(&self, lattice: Lattice, at: [usize; 2]) -> Option<usize> {
        let mut l = [0; 2];
        for a in 0..2 {
            l[a] = if self.whole[a] {
                at[a]
            } else if self.block.owned_global(lattice, a).contains(&at[a]) {
                at[a] - self.block.cells[a].start + self.pad[a]
            } else {
                return None;
            };
        }
        Some(self.grid.index(lattice, l))
    }

    /// [`RankBlock::owned`] of the node a read of `at` takes its value from: face n of a
    /// periodic axis is face 0 (the same face, the same value after the boundary rules).
    fn read(&self, lattice: Lattice, at: [usize; 2]) -> Option<usize> {
        let b = self.block;
        let wrapped = std::array::from_fn(|a| if b.periodic[a] { at[a] % b.n[a] } else { at[a] });
        self.owned(lattice, wrapped)
    }
}

impl MassPoint {
    /// No parameters to check.
    pub fn validate(&mut self) -> Result<(), String> {
        Ok(())
    }

    /// Face θ of one point from its cells, the way `FieldState::update_face_fractions`
    /// derives face fractions (mean of the two neighbours; the inside cell on a wall; the
    /// wrapped neighbour on a periodic side, where faces 0 and n are the same face).
    fn footprint_faces(p: &mut PointBody, g: &Grid, periodic: [bool; 2]) {
        p.xfaces.clear();
        p.yfaces.clear();
        let (nx, ny) = (g.nx, g.ny);
        p.edge = false;
        for &(c, t) in &p.cells {
            let (i, j) = (c % nx, c / nx);
            p.edge |= i == 0 || i + 1 == nx || j == 0 || j + 1 == ny;
            let half = 0.5 * t;
            // x-faces i (left) and i + 1 (right)
            for (f, edge, other) in [(i, i == 0, nx), (i + 1, i + 1 == nx, 0)] {
                if !edge {
                    p.xfaces.push((g.xface(f, j), half));
                } else if periodic[0] {
                    p.xfaces.push((g.xface(f, j), half));
                    p.xfaces.push((g.xface(other, j), half));
                } else {
                    p.xfaces.push((g.xface(f, j), t));
                }
            }
            for (f, edge, other) in [(j, j == 0, ny), (j + 1, j + 1 == ny, 0)] {
                if !edge {
                    p.yfaces.push((g.yface(i, f), half));
                } else if periodic[1] {
                    p.yfaces.push((g.yface(i, f), half));
                    p.yfaces.push((g.yface(i, other), half));
                } else {
                    p.yfaces.push((g.yface(i, f), t));
                }
            }
        }
    }

    /// [`PointBody::sample`] on ranks: every rank puts the values of the footprint nodes it
    /// owns, point by point and node by node in the footprints' order, in one message to
    /// every rank; each rank then reads each node's values from its owner's message, in the
    /// same order.
    fn sample_on_ranks(
        &mut self,
        b: &RankBlock,
        bc: &Boundaries,
        s: &FieldState,
        partner: Option<&FieldState>,
        rotation: bool,
    ) {
        let g = b.grid;
        let rg = g.part.block().expect("a rank's block").0;
        // x-faces and y-faces: [fixed, u − u_old, the partner's u]; cells: the vorticity
        let face = |lattice: Lattice, l: usize, out: &mut Vec<Real>| {
            let (u, old, fixed) = match lattice {
                Lattice::XFace => (&s.velocity.u, &s.velocity_old.u, bc.xface_fixed(g, l % (g.nx + 1))),
                _ => (&s.velocity.v, &s.velocity_old.v, bc.yface_fixed(g, l / g.nx)),
            };
            let pu =
                partner.map_or(0.0, |pt| if lattice == Lattice::XFace { pt.velocity.u[l] } else { pt.velocity.v[l] });
            out.extend([fixed as u8 as Real, u[l] - old[l], pu]);
        };
        let cells = rotation && partner.is_some();
        let mut mine = Vec::new();
        for p in &self.points {
            for (lattice, at) in p.nodes(b, cells) {
                if let Some(l) = b.read(lattice, at) {
                    match (lattice, partner) {
                        (Lattice::Cell, Some(pt)) => {
                            mine.push(Self::vorticity(g, bc, &pt.velocity.u, &pt.velocity.v, l))
                        }
                        _ => face(lattice, l, &mut mine),
                    }
                }
            }
        }
        let all = g.part.comm().gather_all_f64(&mine);
        let mut next = vec![0; all.len()];
        let mut take = |lattice: Lattice, at: [usize; 2], n: usize| {
            let r = rg.owner(lattice, [at[0] as isize, at[1] as isize]).expect("a footprint's node is in the domain");
            let v = &all[r][next[r]..next[r] + n];
            next[r] += n;
            v
        };
        for p in &mut self.points {
            let mut xval = std::mem::take(&mut p.xval);
            let mut yval = std::mem::take(&mut p.yval);
            xval.clear();
            yval.clear();
            p.vort.clear();
            for (lattice, at) in p.nodes(b, cells).collect::<Vec<_>>() {
                match lattice {
                    Lattice::Cell => p.vort.push(take(lattice, at, 1)[0]),
                    _ => {
                        let v = take(lattice, at, 3);
                        let value = (v[0] == 0.0).then_some([v[1], v[2]]);
                        if lattice == Lattice::XFace { &mut xval } else { &mut yval }.push(value);
                    }
                }
            }
            (p.xval, p.yval) = (xval, yval);
        }
        debug_assert!(next.iter().zip(&all).all(|(n, a)| *n == a.len()), "every rank's values read once");
    }

    /// Vorticity ∂v/∂x − ∂u/∂y of face velocities `(u, v)` at the centre of cell `c`
    /// ([`vorticity_at`] of the cell-centred velocities).
    fn vorticity(g: &Grid, bc: &Boundaries, u: &[Real], v: &[Real], c: usize) -> Real {
        let at = |i: usize, j: usize| {
            [0.5 * (u[g.xface(i, j)] + u[g.xface(i + 1, j)]), 0.5 * (v[g.yface(i, j)] + v[g.yface(i, j + 1)])]
        };
        vorticity_at(g, [bc.periodic(0), bc.periodic(1)], at, c % g.nx, c / g.nx)
    }
}

/// Sums entries onto `a` (and `b`): `entries(add)` calls `add(index, to a, to b)` in the
/// order of the serial sums. The arrays are split into one block per thread, each block
/// running `entries` and keeping those that fall in it: every element receives the same
/// terms in the same order whatever the number of threads, so the same bits.
fn scatter<F>(a: &mut [Real], b: Option<&mut [Real]>, entries: F)
where
    F: Fn(&mut dyn FnMut(usize, Real, Real)) + Sync,
{
    let n = a.len();
    let block = n.div_ceil(rayon::current_num_threads().max(1)).max(1);
    let run = |lo: usize, a: &mut [Real], mut b: Option<&mut [Real]>| {
        let hi = lo + a.len();
        entries(&mut |k, x, y| {
            if (lo..hi).contains(&k) {
                a[k - lo] += x;
                if let Some(b) = b.as_deref_mut() {
                    b[k - lo] += y;
                }
            }
        });
    };
    match b {
        Some(b) => a
            .par_chunks_mut(block)
            .zip(b.par_chunks_mut(block))
            .enumerate()
            .for_each(|(k, (a, b))| run(k * block, a, Some(b))),
        None => a.par_chunks_mut(block).enumerate().for_each(|(k, a)| run(k * block, a, None)),
    }
}

multifield_core::register!(
    Frame,
    "mass_point",
    MassPoint,
    "one material point per disk (representation MassPoint): exact disk ∩ cell volume spreading, FLIP gather",
    &[]
);

impl Frame for MassPoint {
    fn model(&self) -> &'static str {
        "mass_point"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn is_lagrangian(&self) -> bool {
        true
    }
    fn representation(&self) -> multifield_core::case::Representation {
        multifield_core::case::Representation::MassPoint
    }
    /// Every rank holds every point (see the module's documentation).
    fn decomposed(&self) -> bool {
        true
    }

    fn initialize(&mut self, ctx: &InitContext) -> Result<(), String> {
        let Region::Bodies(specs) = ctx.region else {
            return Err("a mass-point field needs `region: Bodies([...])` of disks".into());
        };
        self.points.clear();
        self.contact_walls = ctx.contact.is_some_and(|(_, walls)| walls);
        let g = ctx.grid;
        self.domain = Grid::from_cells(g.domain, g.h, g.origin);
        self.periodic =
            std::array::from_fn(|a| g.part.block().map_or(ctx.boundaries.periodic(a), |(rg, _)| rg.periodic[a]));
        for spec in specs {
            let BodyShape::Disk { center, radius } = spec.shape else {
                return Err(format!("body `{}` is not a disk; a mass point stands for a disk", spec.name));
            };
            let volume = PI * radius * radius;
            let density = spec.density_or(ctx.density);
            let mass = density * volume;
            let (velocity, omega) = match spec.motion {
                Motion::Free => (spec.velocity, spec.angular_velocity),
                Motion::Fixed => ([0.0, 0.0], 0.0),
                Motion::Prescribed { velocity, angular_velocity } => (velocity, angular_velocity),
            };
            self.points.push(PointBody {
                motion: spec.motion,
                state: BodyState {
                    name: spec.name.clone(),
                    mass,
                    inertia: 0.5 * mass * radius * radius,
                    volume,
                    radius,
                    position: Vector::new(center[0], center[1]),
                    velocity: Vector::new(velocity[0], velocity[1]),
                    angular_velocity: omega,
                    force: Vector::zeros(),
                    torque: 0.0,
                    free: spec.motion == Motion::Free,
                },
                density,
                max_reynolds: 0.0,
                cells: Vec::new(),
                xfaces: Vec::new(),
                yfaces: Vec::new(),
                edge: true,
                xval: Vec::new(),
                yval: Vec::new(),
                vort: Vec::new(),
            });
        }
        Ok(())
    }

    fn to_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        let g = ctx.grid;
        let bc = ctx.boundaries;
        let (d, periodic) = (&self.domain, self.periodic);
        let block = RankBlock::of(g);
        let s = &mut *ctx.state;
        // the grid-wide passes elementwise in parallel (each value is the serial one)
        const BLOCK: usize = 4096;
        for a in [&mut s.theta, &mut s.mass_face.u, &mut s.mass_face.v, &mut s.velocity.u, &mut s.velocity.v] {
            a.par_chunks_mut(BLOCK).for_each(|a| a.fill(0.0));
        }
        let area = g.cell_volume();
        if let Some(p) =
            self.points.iter().find(|p| !(p.state.position.x.is_finite() && p.state.position.y.is_finite()))
        {
            return Err(format!("point `{}` is at {:?}: the run has blown up", p.state.name, p.state.position));
        }
        // each point's footprint (the exact areas: most of the work) in parallel; the sums
        // onto the grid after, point by point in order (bit-identical whatever the threads)
        // (on the domain's grid: on ranks every rank has every point's footprint)
        self.points.par_iter_mut().with_min_len(64).for_each(|p| {
            let (x, r) = (p.state.position, p.state.radius);
            p.cells.clear();
            disk_cell_fractions(d, [x.x, x.y], r, periodic, &mut p.cells);
            Self::footprint_faces(p, d, periodic);
        });
        // (each array split into as many blocks as threads, each block summing the points'
        // entries that fall in it, in point order: the bits of one serial pass; a rank sums
        // the entries on the nodes it owns, in the same order)
        let points = &self.points;
        let at = |lattice: Lattice, k: usize| match &block {
            None => Some(k),
            Some(b) => b.owned(lattice, b.node(lattice, k)),
        };
        scatter(&mut s.theta, None, |add| {
            for p in points {
                for &(c, t) in &p.cells {
                    if let Some(c) = at(Lattice::Cell, c) {
                        add(c, t, 0.0);
                    }
                }
            }
        });
        scatter(&mut s.mass_face.u, Some(&mut s.velocity.u), |add| {
            for p in points {
                let (scale, u) = (p.density * area, p.state.velocity.x);
                for &(f, w) in &p.xfaces {
                    if let Some(f) = at(Lattice::XFace, f) {
                        add(f, scale * w, scale * w * u);
                    }
                }
            }
        });
        scatter(&mut s.mass_face.v, Some(&mut s.velocity.v), |add| {
            for p in points {
                let (scale, u) = (p.density * area, p.state.velocity.y);
                for &(f, w) in &p.yfaces {
                    if let Some(f) = at(Lattice::YFace, f) {
                        add(f, scale * w, scale * w * u);
                    }
                }
            }
        });
        for (u, m) in [(&mut s.velocity.u, &s.mass_face.u), (&mut s.velocity.v, &s.mass_face.v)] {
            u.par_chunks_mut(BLOCK).zip(m.par_chunks(BLOCK)).for_each(|(u, m)| {
                for (u, m) in u.iter_mut().zip(m) {
                    *u = if *m > 0.0 { *u / m } else { 0.0 };
                }
            });
        }
        bc.enforce(g, &mut s.velocity);
        // the halo as the owners'
        if block.is_some() {
            g.exchange(&mut [
                (Lattice::Cell, &mut s.theta),
                (Lattice::XFace, &mut s.mass_face.u),
                (Lattice::YFace, &mut s.mass_face.v),
                (Lattice::XFace, &mut s.velocity.u),
                (Lattice::YFace, &mut s.velocity.v),
            ]);
        }
        for (old, u) in [(&mut s.velocity_old.u, &s.velocity.u), (&mut s.velocity_old.v, &s.velocity.v)] {
            old.par_chunks_mut(BLOCK).zip(u.par_chunks(BLOCK)).for_each(|(o, u)| o.copy_from_slice(u));
        }
        Ok(())
    }

    fn from_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        let g = ctx.grid;
        let bc = ctx.boundaries;
        let s = &*ctx.state;
        let dt = ctx.dt;
        if let Some(p) = &ctx.partner {
            self.law = Some((p.law.model, p.law.valid_re));
        }
        let rotation = ctx.partner.as_ref().is_some_and(|pt| pt.law.rotation);
        let partner = ctx.partner.as_ref().map(|pt| pt.state);
        // what each point reads at its footprint: from the grid on one rank, from the
        // nodes' owners on ranks
        match RankBlock::of(g) {
            None => self.points.par_iter_mut().with_min_len(64).for_each(|p| p.sample(g, bc, s, partner, rotation)),
            Some(b) => self.sample_on_ranks(&b, bc, s, partner, rotation),
        }
        let lo = g.origin;
        let hi = g.origin + g.size();
        let periodic = self.periodic;
        // each point writes only itself: in parallel
        let contact_walls = self.contact_walls;
        self.points.par_iter_mut().with_min_len(64).enumerate().for_each(|(k, p)| {
            let st = &mut p.state;
            let (m, r) = (st.mass, st.radius);
            // mass-weighted velocity increment and fluid velocity over the footprint
            let (mut du, mut wsum, mut uf) = (Vector::zeros(), Vector::zeros(), Vector::zeros());
            for (&(_, w), v) in p.xfaces.iter().zip(&p.xval) {
                let Some([dv, u]) = v else { continue };
                du.x += w * dv;
                wsum.x += w;
                if ctx.partner.is_some() {
                    uf.x += w * u;
                }
            }
            for (&(_, w), v) in p.yfaces.iter().zip(&p.yval) {
                let Some([dv, u]) = v else { continue };
                du.y += w * dv;
                wsum.y += w;
                if ctx.partner.is_some() {
                    uf.y += w * u;
                }
            }
            let mut gained = Vector::zeros();
            for a in 0..2 {
                if wsum[a] > 0.0 {
                    gained[a] = du[a] / wsum[a];
                    uf[a] /= wsum[a];
                } else {
                    gained[a] = dt * ctx.gravity[a];
                    uf[a] = st.velocity[a];
                }
            }
            let contact = ctx.body_forces.get(k).copied().unwrap_or_default();
            let (fc, tc) = (contact.force, contact.torque);
            st.force = m * gained / dt - m * ctx.gravity;
            let u_grid = st.velocity + gained;
            // rotation: implicit torque 4πμa²(Ω_f − ω) towards the fluid's local rotation
            let inertia = st.inertia;
            let (c, omega_f) = match &ctx.partner {
                Some(pt) if pt.law.rotation && !p.cells.is_empty() => {
                    let (mut wsum, mut vort) = (0.0, 0.0);
                    for (&(_, t), w) in p.cells.iter().zip(&p.vort) {
                        vort += t * w;
                        wsum += t;
                    }
                    (4.0 * PI * pt.law.viscosity * r * r, 0.5 * vort / wsum)
                }
                _ => (0.0, 0.0),
            };
            let (v_new, w_new) = match p.motion {
                Motion::Free => {
                    let w = (inertia * st.angular_velocity + dt * (c * omega_f + tc)) / (inertia + dt * c);
                    (u_grid + dt * fc / m, w)
                }
                Motion::Fixed => (Vector::zeros(), 0.0),
                Motion::Prescribed { velocity, angular_velocity } => {
                    (Vector::new(velocity[0], velocity[1]), angular_velocity)
                }
            };
            st.torque = c * (omega_f - w_new);
            st.velocity = v_new;
            st.angular_velocity = w_new;
            if let Some(pt) = &ctx.partner {
                let re = pt.density * (v_new - uf).norm() * 2.0 * r / pt.law.viscosity;
                if re.is_finite() {
                    p.max_reynolds = p.max_reynolds.max(re);
                }
            }
            // move; wrap periodic sides; at the other sides, stop the centre at a disk's radius
            // from the side, or, where the contact model meets the sides (as it does for
            // resolved bodies), only at the side itself, a backstop the contact never lets
            // it reach
            let stop = if contact_walls { 0.0 } else { r };
            let mut x = st.position + dt * v_new;
            if contact.shift != Vector::zeros() {
                // sub-stepped contact: where the sub-steps put the centre (docs/method.md §5)
                x += contact.shift;
            }
            for (axis, periodic) in [(0, periodic[0]), (1, periodic[1])] {
                let len = hi[axis] - lo[axis];
                if periodic {
                    if x[axis] < lo[axis] || x[axis] >= hi[axis] {
                        x[axis] = lo[axis] + (x[axis] - lo[axis]).rem_euclid(len);
                    }
                } else if x[axis] < lo[axis] + stop.min(0.5 * len) {
                    x[axis] = lo[axis] + stop.min(0.5 * len);
                    st.velocity[axis] = st.velocity[axis].max(0.0);
                } else if x[axis] > hi[axis] - stop.min(0.5 * len) {
                    x[axis] = hi[axis] - stop.min(0.5 * len);
                    st.velocity[axis] = st.velocity[axis].min(0.0);
                }
            }
            st.position = x;
        });
        Ok(())
    }

    fn body_states(&self) -> Vec<&BodyState> {
        self.points.iter().map(|p| &p.state).collect()
    }

    fn points(&self) -> Option<PointSet> {
        let states = self.points.iter().map(|p| &p.state);
        Some(PointSet {
            position: states.clone().map(|s| s.position).collect(),
            velocity: states.clone().map(|s| s.velocity).collect(),
            volume: states.clone().map(|s| s.volume).collect(),
            mass: states.clone().map(|s| s.mass).collect(),
            stress: vec![Matrix::zeros(); self.points.len()],
            body: (0..self.points.len() as i64).collect(),
            bodies: states.map(|s| s.name.clone()).collect(),
            model_state: Vec::new(),
        })
    }

    fn warnings(&self, grid: &Grid) -> Vec<String> {
        let mut out = Vec::new();
        for p in &self.points {
            let d = 2.0 * p.state.radius;
            if d > grid.h {
                let mut cells = Vec::new();
                disk_cell_fractions(
                    &self.domain,
                    [p.state.position.x, p.state.position.y],
                    p.state.radius,
                    [true, true],
                    &mut cells,
                );
                out.push(format!(
                    "point `{}`: diameter {d} is {:.2} × the cell size {}; the point model assumes d ≲ h \
                     (its volume is spread exactly over {} cells, so it runs, as a smeared body)",
                    p.state.name,
                    d / grid.h,
                    grid.h,
                    cells.len()
                ));
            }
            if let Some((law, (lo, hi))) = self.law {
                let re = p.max_reynolds;
                if re > hi {
                    out.push(format!(
                        "point `{}`: its Reynolds number reached {re:.4} (ρ_f |U − u_f| d / μ), {:.2} × the \
                         upper end Re = {hi} of drag law `{law}`",
                        p.state.name,
                        re / hi
                    ));
                } else if re < lo {
                    out.push(format!(
                        "point `{}`: its Reynolds number stayed below {re:.4}, under the lower end Re = {lo} of \
                         drag law `{law}` ({:.2} ×)",
                        p.state.name,
                        re / lo
                    ));
                }
            }
        }
        out
    }

    fn max_speed(&self) -> Real {
        self.points.iter().map(|p| p.state.velocity.norm()).fold(0.0, Real::max)
    }
    fn kinetic_energy(&self) -> Real {
        self.points
            .iter()
            .map(|p| {
                let s = &p.state;
                0.5 * s.mass * s.velocity.norm_squared() + 0.5 * s.inertia * s.angular_velocity.powi(2)
            })
            .sum()
    }
    fn momentum(&self) -> Vector {
        self.points.iter().fold(Vector::zeros(), |a, p| a + p.state.mass * p.state.velocity)
    }
    fn mass(&self) -> Real {
        self.points.iter().map(|p| p.state.mass).sum()
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }

    /// Each point's state (name, mass, position, velocity, angular velocity, last force and
    /// torque, …) and largest Reynolds number. The footprints are rebuilt every step.
    fn save_state(&self) -> Result<Vec<u8>, String> {
        let points: Vec<_> = self.points.iter().map(|p| (Cow::Borrowed(&p.state), p.max_reynolds)).collect();
        state::encode(&MassPointState { points })
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let saved: MassPointState = state::decode(bytes, "mass-point state")?;
        let n = saved.points.len();
        if n != self.points.len() {
            return Err(format!("{n} points in the checkpoint, {} bodies in the case", self.points.len()));
        }
        if let Some(((s, _), p)) = saved.points.iter().zip(&self.points).find(|((s, _), p)| s.name != p.state.name) {
            return Err(format!("point `{}` in the checkpoint where the case has `{}`", s.name, p.state.name));
        }
        // the core checks that every real is finite and the centre inside the domain
        for (s, re) in &saved.points {
            for (q, x) in
                [("mass", s.mass), ("volume", s.volume), ("radius", s.radius), ("moment of inertia", s.inertia)]
            {
                if !(x > 0.0 && x.is_finite()) {
                    return Err(format!("point `{}` has {q} {x}: not a positive number", s.name));
                }
            }
            if re.is_nan() || *re < 0.0 {
                return Err(format!("point `{}` has largest Reynolds number {re}: not a number ≥ 0", s.name));
            }
        }
        for (p, (s, re)) in self.points.iter_mut().zip(saved.points) {
            p.state = s.into_owned();
            p.max_reynolds = re;
        }
        Ok(())
    }
}

/// What a mass-point frame carries from step to step ([`Frame::save_state`]): each
/// point's state and largest Reynolds number; borrowed when saved, owned when loaded.
#[derive(Serialize, Deserialize)]
struct MassPointState<'a> {
    points: Vec<(Cow<'a, BodyState>, Real)>,
}
