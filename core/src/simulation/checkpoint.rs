//! What a [`Simulation`] carries from one step to the next, for checkpoints: saved and
//! loaded bit for bit.

use super::*;
use crate::math::axis_name;

/// What a [`Simulation`] carries from one step to the next ([`Simulation::save_state`]):
/// borrowed when saved, owned when loaded.
#[derive(Serialize, Deserialize)]
struct SimulationState<'a> {
    time: Real,
    steps: u64,
    initial_energy: Real,
    pressure: Cow<'a, [Real]>,
    last: Cow<'a, StepDiagnostics>,
    /// The contact force and torque of each body ([`BodyContact`] without the position
    /// correction of sub-stepped contact, which phase 8a recomputes in every step before a
    /// frame reads it).
    body_forces: Cow<'a, [Vec<(Vector, Real)>]>,
    fields: Vec<FieldCheckpoint<'a>>,
    /// Per direct forcing, the lagged marker forces ([`ForcedPair::lag`]).
    marker_forces: Vec<Cow<'a, [Vec<Vector>]>>,
    /// The running time averages of the monitors ([`Simulation::averages`]).
    averages: Cow<'a, [crate::monitor::TimeAverage]>,
    /// The contact model's history ([`ContactModel::history`]; empty without one).
    contact_history: Cow<'a, [u8]>,
}

/// A rank's own state ([`Simulation::save_rank_state`]): the rank grid it was written on
/// and the rank's [`SimulationState`] of its block.
#[derive(Serialize, Deserialize)]
struct RankState<'a> {
    rank: usize,
    ranks: usize,
    p: Vec<usize>,
    cuts: Vec<Vec<usize>>,
    state: Cow<'a, [u8]>,
}

/// One field in a [`SimulationState`]: its name and frame (checked on loading), its grid
/// state and its frame's own state ([`Frame::save_state`], opaque to the core).
#[derive(Serialize, Deserialize)]
struct FieldCheckpoint<'a> {
    name: Cow<'a, str>,
    model: Cow<'a, str>,
    grid: Cow<'a, FieldState>,
    frame: Cow<'a, [u8]>,
}

impl Simulation {
    /// Everything the next steps depend on, for a checkpoint: time, steps, the pressure
    /// (the initial guess of the next solve), the last step's figures, the initial energy,
    /// the contact forces and the contact model's history, every field's grid state and its frame's own state
    /// ([`Frame::save_state`]). [`Simulation::load_state`] on a simulation built from the
    /// same case continues bit for bit. The exchange coefficients are not in it (every step
    /// recomputes them), nor the pressure solvers' caches (multigrid hierarchy, symbolic
    /// and numeric factorizations), which every solve rebuilds from its problem: a solve
    /// depends only on the problem and the initial guess.
    ///
    /// A rank of a decomposed run saves the whole domain's state (its arrays gathered from
    /// every rank's owned nodes, the frames' too): the serial run's bytes, which a restart
    /// on any number of ranks loads. Every rank calls it.
    pub fn save_state(&self) -> Result<Vec<u8>> {
        self.save(false)
    }

    /// This rank's own state for a checkpoint written per rank (`output.checkpoints.layout:
    /// PerRank`): [`Simulation::save_state`] of its block's storage and its frames' own
    /// state ([`Frame::save_rank_state`]), nothing gathered, with the rank grid it is
    /// written on. [`Simulation::load_rank_state`] on the same rank of the same rank grid
    /// continues bit for bit.
    pub fn save_rank_state(&self) -> Result<Vec<u8>> {
        let part = &self.grid.part;
        let (p, cuts) = self.rank_grid();
        let own = RankState { rank: part.rank(), ranks: part.ranks(), p, cuts, state: Cow::Owned(self.save(true)?) };
        state::encode(&own).map_err(Error::Model)
    }

    /// The ranks along each axis and the cuts of this run's rank grid (one block of the
    /// whole domain on one process).
    fn rank_grid(&self) -> (Vec<usize>, Vec<Vec<usize>>) {
        match self.grid.part.block() {
            Some((rg, _)) => (rg.p.to_vec(), rg.cuts.to_vec()),
            None => (vec![1; DIM], self.grid.n().iter().map(|&n| vec![0, n]).collect()),
        }
    }

    /// Restores what [`Simulation::save_rank_state`] wrote on this rank of this rank grid;
    /// another rank count or grid is refused, saying which wrote it. Every rank calls it and
    /// learns whether every rank could (a rank's failure fails them all).
    pub fn load_rank_state(&mut self, bytes: &[u8]) -> Result<()> {
        let loaded = self.load_rank_state_here(bytes);
        if self.grid.part.any(loaded.is_err()) && loaded.is_ok() {
            return Err(Error::Model("another rank's state does not load (its message is in its output)".into()));
        }
        loaded
    }

    /// [`Simulation::load_rank_state`] on this rank alone.
    fn load_rank_state_here(&mut self, bytes: &[u8]) -> Result<()> {
        let own: RankState = state::decode(bytes, "a rank's state").map_err(Error::Model)?;
        let part = &self.grid.part;
        let here = self.rank_grid();
        if own.ranks != part.ranks() || (own.p.clone(), own.cuts.clone()) != here {
            let grid = |p: &[usize]| p.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(" × ");
            return Err(Error::Model(format!(
                "it was written per rank by {} ranks (rank grid {}), and this run has {} (rank grid {}): continue \
                 it with `mpirun -np {}` and `domain.ranks: Some(({}))`, or from a checkpoint written with \
                 `layout: Gathered` (the default), which restarts on any number of ranks",
                own.ranks,
                grid(&own.p),
                part.ranks(),
                grid(&here.0),
                own.ranks,
                own.p.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")
            )));
        }
        if own.rank != part.rank() {
            return Err(Error::Model(format!("rank {} read the file of rank {}", part.rank(), own.rank)));
        }
        self.load_state_inner(&own.state, true).map_err(Error::Model)?;
        self.grid_state_stale = self.alone;
        Ok(())
    }

    /// [`Simulation::save_state`] (`own`: [`Simulation::save_rank_state`]'s, the block's
    /// own storage).
    fn save(&self, own: bool) -> Result<Vec<u8>> {
        let g = &self.grid;
        let decomposed = !g.part.is_whole() && !own;
        let mut fields = Vec::with_capacity(self.fields.len());
        for f in &self.fields {
            let frame = if own { f.frame.save_rank_state() } else { f.frame.save_state() };
            let frame = frame.map_err(|m| Error::Model(format!("field `{}`: {m}", f.name)))?;
            fields.push(FieldCheckpoint {
                name: Cow::Borrowed(&f.name),
                model: Cow::Borrowed(f.frame.model()),
                grid: if decomposed { Cow::Owned(f.state.gathered(g)) } else { Cow::Borrowed(&f.state) },
                frame: Cow::Owned(frame),
            });
        }
        let pressure = if decomposed {
            Cow::Owned(g.part.gather(Lattice::Cell, g.shape(Lattice::Cell), &self.pressure))
        } else {
            Cow::Borrowed(&self.pressure[..])
        };
        let saved = SimulationState {
            time: self.time,
            steps: self.steps,
            initial_energy: self.initial_energy,
            pressure,
            last: Cow::Borrowed(&self.last),
            body_forces: Cow::Owned(
                self.body_forces.iter().map(|f| f.iter().map(|c| (c.force, c.torque)).collect()).collect(),
            ),
            fields,
            marker_forces: self.forcings.iter().map(|p| Cow::Borrowed(&p.lag[..])).collect(),
            averages: Cow::Borrowed(&self.averages),
            contact_history: Cow::Owned(self.contact.as_ref().map_or_else(Vec::new, |c| c.history())),
        };
        state::encode(&saved).map_err(Error::Model)
    }

    /// Restores what [`Simulation::save_state`] wrote, into a simulation built from the
    /// same case (same grid and fields; the time control and output may differ). The
    /// message of an error says which part does not fit.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        self.load_state_inner(bytes, false).map_err(Error::Model)?;
        self.grid_state_stale = self.alone;
        Ok(())
    }

    /// [`Simulation::load_state`] (`own`: the block's own storage, [`Simulation::load_rank_state`]).
    pub(super) fn load_state_inner(&mut self, bytes: &[u8], own: bool) -> std::result::Result<(), String> {
        let mut saved: SimulationState = state::decode(bytes, "simulation state")?;
        let mut pressure = vec![0.0; self.grid.n_cells()];
        let g = &self.grid;
        if g.part.is_whole() || own {
            state::copy_into(&mut pressure, &saved.pressure, "pressure")?;
        } else {
            // a rank of a decomposed run: its block of the whole domain's state
            let cells = g.domain_cells();
            if saved.pressure.len() != cells {
                return Err(format!("pressure: {} cells in the checkpoint, {cells} here", saved.pressure.len()));
            }
            g.part.scatter(Lattice::Cell, g.shape(Lattice::Cell), &saved.pressure, &mut pressure);
            for c in &mut saved.fields {
                let block = FieldState::block_of(g, &c.grid)
                    .ok_or_else(|| format!("field `{}`: its grid state is not of this domain's size", c.name))?;
                c.grid = Cow::Owned(block);
            }
        }
        let n = saved.body_forces.len();
        if n != self.fields.len() {
            return Err(format!("contact forces of {n} fields in the checkpoint, {} fields here", self.fields.len()));
        }
        let n = saved.fields.len();
        if n != self.fields.len() {
            return Err(format!("{n} fields in the checkpoint, {} here", self.fields.len()));
        }
        let n = saved.marker_forces.len();
        if n != self.forcings.len() {
            return Err(format!("{n} direct forcings in the checkpoint, {} here", self.forcings.len()));
        }
        let grid = &self.grid;
        let theta_max = 1.0 + self.case.coupling.max_volume_fraction_error;
        for ((f, c), contact) in self.fields.iter_mut().zip(&saved.fields).zip(saved.body_forces.iter()) {
            let (name, model) = (&c.name, &c.model);
            if *name != f.name || *model != f.frame.model() {
                return Err(format!(
                    "the checkpoint holds field `{name}` ({model} frame) where the case has `{}` ({} frame)",
                    f.name,
                    f.frame.model()
                ));
            }
            let what = |q: &str| format!("field `{name}`: {q}");
            let (s, g) = (&mut f.state, &c.grid);
            state::copy_into(&mut s.theta, &g.theta, &what("volume fraction"))?;
            for a in AXES {
                let q = format!("{}-face volume fraction", axis_name(a));
                state::copy_into(&mut s.theta_face[a], &g.theta_face[a], &what(&q))?;
            }
            for a in AXES {
                state::copy_into(&mut s.mass_face[a], &g.mass_face[a], &what(&format!("{}-face mass", axis_name(a))))?;
            }
            for (v, w, q) in [
                (&mut s.velocity, &g.velocity, "velocity"),
                (&mut s.velocity_old, &g.velocity_old, "old velocity"),
                (&mut s.pressure_acceleration, &g.pressure_acceleration, "pressure acceleration"),
                (&mut s.specific_volume, &g.specific_volume, "specific volume"),
                (&mut s.body_force, &g.body_force, "immersed-boundary force"),
            ] {
                for a in AXES {
                    state::copy_into(&mut v[a], &w[a], &what(&format!("{q} on {}-faces", axis_name(a))))?;
                }
            }
            // Volume fractions and masses are not negative (beyond round-off); a field on
            // the grid holds at most 1 + coupling.max_volume_fraction_error of a cell, the
            // bound on Σθ that every step of a run with a pressure solve checks. (A
            // Lagrangian field's θ is rebuilt from its points at every step and may exceed
            // it where they are compressed.)
            let hi = if f.frame.is_lagrangian() { Real::INFINITY } else { theta_max };
            let why = "a volume fraction lies in [0, 1], to round-off and coupling.max_volume_fraction_error";
            state::within(&s.theta, -THETA_ROUND_OFF, hi, &what("volume fraction"), why)?;
            for a in AXES {
                let q = format!("{}-face volume fraction", axis_name(a));
                state::within(&s.theta_face[a], -THETA_ROUND_OFF, hi, &what(&q), why)?;
            }
            let m0 = -THETA_ROUND_OFF * f.density * grid.cell_volume();
            for a in AXES {
                let q = format!("{}-face mass", axis_name(a));
                state::within(&s.mass_face[a], m0, Real::INFINITY, &what(&q), "a mass is not negative")?;
            }
            let loaded = if own { f.frame.load_rank_state(&c.frame) } else { f.frame.load_state(&c.frame) };
            loaded.map_err(|m| format!("field `{name}`: {m}"))?;
            let bodies = f.frame.bodies();
            if !contact.is_empty() && contact.len() != bodies.len() {
                let n = contact.len();
                return Err(what(&format!("contact forces of {n} bodies in the checkpoint, {} here", bodies.len())));
            }
            state::finite(&contact[..], &what("contact force and torque of body"))?;
            check_bodies(&bodies, grid).map_err(|m| what(&m))?;
            // (a rank's own points when loading its own state: no rank waits on another)
            let points = if own { f.frame.local_points(grid.part.rank()) } else { f.frame.points() };
            if let Some(points) = points {
                check_points(&points, grid).map_err(|m| what(&m))?;
                check_model_state(&points, &f.stress).map_err(|m| what(&m))?;
            }
        }
        for (k, lag) in saved.marker_forces.iter().enumerate() {
            state::finite(&lag[..], &format!("lagged marker forces of direct forcing {k}, body"))?;
        }
        match &mut self.contact {
            Some(c) => {
                c.restore_history(&saved.contact_history).map_err(|m| format!("contact `{}`: {m}", c.model()))?
            }
            None if !saved.contact_history.is_empty() => {
                return Err("the checkpoint holds a contact model's history, and the case has no contact model".into())
            }
            None => {}
        }
        for (p, lag) in self.forcings.iter_mut().zip(saved.marker_forces) {
            p.lag = lag.into_owned();
        }
        for a in saved.averages.iter() {
            a.check(self.grid.n_cells())?;
        }
        self.averages = saved.averages.into_owned();
        self.time = saved.time;
        self.steps = saved.steps;
        self.initial_energy = saved.initial_energy;
        self.pressure = pressure;
        self.last = saved.last.into_owned();
        self.body_forces =
            saved.body_forces.iter().map(|f| f.iter().map(|&(f, t)| BodyContact::force(f, t)).collect()).collect();
        Ok(())
    }
}

/// Volume fractions as low as −this (round-off of the transport) are accepted on loading.
const THETA_ROUND_OFF: Real = 1e-6;

/// Distance outside the domain (× h) within which a restored point or body centre is
/// accepted (the round-off of the frames' wall and periodic clamps).
const DOMAIN_ROUND_OFF: Real = 1e-6;

/// A position outside the domain of `grid` (beyond [`DOMAIN_ROUND_OFF`]), as "at (x, y),
/// outside the domain [x0, x1] × [y0, y1]"; NaN is outside.
fn outside(x: Vector, grid: &Grid) -> Option<String> {
    let (lo, size) = (grid.origin, grid.size());
    let tol = DOMAIN_ROUND_OFF * grid.h;
    let q = x - lo;
    let inside = q.x >= -tol && q.y >= -tol && q.x <= size.x + tol && q.y <= size.y + tol;
    (!inside).then(|| {
        format!(
            "at ({}, {}), outside the domain [{}, {}] × [{}, {}]",
            x.x,
            x.y,
            lo.x,
            lo.x + size.x,
            lo.y,
            lo.y + size.y
        )
    })
}

/// Refuses body states that no run writes: a real that is not finite (centre, velocity,
/// angular velocity, mass, forces, …), a centre outside the domain (a body's centre stays
/// inside: the case puts bodies inside, walls stop them, rigid bodies do not cross
/// periodic sides and mass points wrap across them).
fn check_bodies(bodies: &[crate::plugin::BodyState], grid: &Grid) -> std::result::Result<(), String> {
    for b in bodies {
        state::finite(b, &format!("body `{}`", b.name))?;
        if let Some(at) = outside(b.position, grid) {
            return Err(format!("body `{}` has its centre {at}", b.name));
        }
    }
    Ok(())
}

/// Refuses stress models' point state ([`crate::plugin::StressModel::point_state`]) that
/// does not fit the field's models and points: one array per model (or none at all), each
/// of k values per point (or empty: sized at the next step), all finite.
fn check_model_state(
    p: &crate::quantity::PointSet,
    models: &[Box<dyn crate::plugin::StressModel>],
) -> std::result::Result<(), String> {
    if p.model_state.is_empty() {
        return Ok(());
    }
    if p.model_state.len() != models.len() {
        return Err(format!(
            "the points hold the state of {} stress models, the field has {}",
            p.model_state.len(),
            models.len()
        ));
    }
    let n = p.len();
    for (s, m) in p.model_state.iter().zip(models) {
        let k = m.point_state().len();
        let what = format!("point state of stress `{}` ({k} values per point)", m.model());
        if !s.is_empty() {
            state::length(s.len(), k * n, &what)?;
        }
        state::finite(&s[..], &what)?;
    }
    Ok(())
}

/// Refuses point state that no run writes (a damaged or forged checkpoint whose checksum
/// was recomputed), which the frames' kernels take for granted: arrays of one length,
/// finite values, positions inside the domain, body indices of the field's bodies.
fn check_points(p: &crate::quantity::PointSet, grid: &Grid) -> std::result::Result<(), String> {
    let n = p.position.len();
    let lengths = [p.velocity.len(), p.volume.len(), p.mass.len(), p.stress.len(), p.body.len()];
    if lengths.iter().any(|&l| l != n) {
        return Err(format!("the point arrays have different lengths ({n} positions, others {lengths:?})"));
    }
    for k in 0..n {
        if let Some(at) = outside(p.position[k], grid) {
            return Err(format!("point {k} is {at}"));
        }
        let v = p.velocity[k];
        if !(v.x.is_finite() && v.y.is_finite() && p.mass[k].is_finite() && p.volume[k].is_finite()) {
            return Err(format!(
                "point {k} has velocity ({}, {}), mass {} and volume {}: not all finite",
                v.x, v.y, p.mass[k], p.volume[k]
            ));
        }
        if p.mass[k] < 0.0 {
            return Err(format!("point {k} has mass {}: negative", p.mass[k]));
        }
        state::finite(&p.stress[k], &format!("point {k}: stress"))?;
        if p.body[k] < -1 || p.body[k] >= p.bodies.len() as i64 {
            return Err(format!("point {k} belongs to body {}, of a field of {} bodies", p.body[k], p.bodies.len()));
        }
    }
    Ok(())
}
