//! What a [`Simulation`] carries from one step to the next, for checkpoints: saved and
//! loaded bit for bit.

use super::*;

/// What a [`Simulation`] carries from one step to the next ([`Simulation::save_state`]):
/// borrowed when saved, owned when loaded.
#[derive(Serialize, Deserialize)]
struct SimulationState<'a> {
    time: Real,
    steps: u64,
    initial_energy: Real,
    pressure: Cow<'a, [Real]>,
    last: Cow<'a, StepDiagnostics>,
    body_forces: Cow<'a, [Vec<(Vector, Real)>]>,
    fields: Vec<FieldCheckpoint<'a>>,
    /// Per direct forcing, the lagged marker forces ([`ForcedPair::lag`]).
    marker_forces: Vec<Cow<'a, [Vec<Vector>]>>,
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
    /// the contact forces, every field's grid state and its frame's own state
    /// ([`Frame::save_state`]). [`Simulation::load_state`] on a simulation built from the
    /// same case continues bit for bit. The exchange coefficients are not in it (every step
    /// recomputes them), nor the pressure solvers' caches (multigrid hierarchy, symbolic
    /// and numeric factorizations), which every solve rebuilds from its problem: a solve
    /// depends only on the problem and the initial guess.
    pub fn save_state(&self) -> Result<Vec<u8>> {
        let mut fields = Vec::with_capacity(self.fields.len());
        for f in &self.fields {
            let frame = f.frame.save_state().map_err(|m| Error::Model(format!("field `{}`: {m}", f.name)))?;
            fields.push(FieldCheckpoint {
                name: Cow::Borrowed(&f.name),
                model: Cow::Borrowed(f.frame.model()),
                grid: Cow::Borrowed(&f.state),
                frame: Cow::Owned(frame),
            });
        }
        let saved = SimulationState {
            time: self.time,
            steps: self.steps,
            initial_energy: self.initial_energy,
            pressure: Cow::Borrowed(&self.pressure),
            last: Cow::Borrowed(&self.last),
            body_forces: Cow::Borrowed(&self.body_forces),
            fields,
            marker_forces: self.forcings.iter().map(|p| Cow::Borrowed(&p.lag[..])).collect(),
        };
        state::encode(&saved).map_err(Error::Model)
    }

    /// Restores what [`Simulation::save_state`] wrote, into a simulation built from the
    /// same case (same grid and fields; the time control and output may differ). The
    /// message of an error says which part does not fit.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        self.load_state_inner(bytes).map_err(Error::Model)?;
        self.grid_state_stale = self.alone;
        Ok(())
    }

    pub(super) fn load_state_inner(&mut self, bytes: &[u8]) -> std::result::Result<(), String> {
        let saved: SimulationState = state::decode(bytes, "simulation state")?;
        let mut pressure = vec![0.0; self.grid.n_cells()];
        state::copy_into(&mut pressure, &saved.pressure, "pressure")?;
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
        for (f, c) in self.fields.iter_mut().zip(&saved.fields) {
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
            for (a, b, q) in [
                (&mut s.theta, &g.theta, "volume fraction"),
                (&mut s.theta_u, &g.theta_u, "x-face volume fraction"),
                (&mut s.theta_v, &g.theta_v, "y-face volume fraction"),
                (&mut s.mass_u, &g.mass_u, "x-face mass"),
                (&mut s.mass_v, &g.mass_v, "y-face mass"),
            ] {
                state::copy_into(a, b, &what(q))?;
            }
            for (v, w, q) in [
                (&mut s.velocity, &g.velocity, "velocity"),
                (&mut s.velocity_old, &g.velocity_old, "old velocity"),
                (&mut s.pressure_acceleration, &g.pressure_acceleration, "pressure acceleration"),
                (&mut s.specific_volume, &g.specific_volume, "specific volume"),
                (&mut s.body_force, &g.body_force, "immersed-boundary force"),
            ] {
                state::copy_into(&mut v.u, &w.u, &what(&format!("{q} on x-faces")))?;
                state::copy_into(&mut v.v, &w.v, &what(&format!("{q} on y-faces")))?;
            }
            f.frame.load_state(&c.frame).map_err(|m| format!("field `{name}`: {m}"))?;
            if let Some(points) = f.frame.points() {
                check_points(&points, grid).map_err(|m| format!("field `{name}`: {m}"))?;
            }
        }
        for (p, lag) in self.forcings.iter_mut().zip(saved.marker_forces) {
            p.lag = lag.into_owned();
        }
        self.time = saved.time;
        self.steps = saved.steps;
        self.initial_energy = saved.initial_energy;
        self.pressure = pressure;
        self.last = saved.last.into_owned();
        self.body_forces = saved.body_forces.into_owned();
        Ok(())
    }
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
    let (lo, size) = (grid.origin, grid.size());
    let tol = 1e-6 * grid.h;
    for k in 0..n {
        let x = p.position[k];
        let q = x - lo;
        if !(q.x >= -tol && q.y >= -tol && q.x <= size.x + tol && q.y <= size.y + tol) {
            return Err(format!(
                "point {k} is at ({}, {}), outside the domain [{}, {}] × [{}, {}]",
                x.x,
                x.y,
                lo.x,
                lo.x + size.x,
                lo.y,
                lo.y + size.y
            ));
        }
        let v = p.velocity[k];
        if !(v.x.is_finite() && v.y.is_finite() && p.mass[k].is_finite() && p.volume[k].is_finite()) {
            return Err(format!(
                "point {k} has velocity ({}, {}), mass {} and volume {}: not all finite",
                v.x, v.y, p.mass[k], p.volume[k]
            ));
        }
        if !p.stress[k].iter().all(|s| s.is_finite()) {
            return Err(format!("point {k} has a stress that is not finite"));
        }
        if p.body[k] < -1 || p.body[k] >= p.bodies.len() as i64 {
            return Err(format!("point {k} belongs to body {}, of a field of {} bodies", p.body[k], p.bodies.len()));
        }
    }
    Ok(())
}
