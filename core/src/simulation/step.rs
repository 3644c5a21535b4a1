//! One step: the time step's choice and the phases in the order [`Simulation::step_with`]
//! runs them (the module doc of `simulation` lists them); the heavy phases are in
//! `momentum_exchange.rs` (4) and `projection.rs` (5–6).

use super::*;
#[cfg(feature = "dim2")]
use crate::grid::FaceVelocity;

/// The limit of a step shortened to land on an exact output time ([`Simulation::choose_dt`]).
pub const OUTPUT_TIME: &str = "output time";

/// A step `best` (Δt, limit) shortened to the `remaining` time when it would reach or pass
/// it ("end").
fn cut_to_end(best: (Real, String), remaining: Real) -> (Real, String) {
    if remaining < best.0 * (1.0 + 1e-9) {
        (remaining, "end".into())
    } else {
        best
    }
}

impl Simulation {
    /// The next time step and what limits it: the stable Δt (or `time.fixed_dt`), cut to
    /// land on `time.end` ("end") and on the next exact output time
    /// ([`crate::case::OutputSpec::next_moment`], [`OUTPUT_TIME`]); the steps after go on
    /// with the normal Δt.
    pub fn choose_dt(&self) -> (Real, String) {
        self.choose_dt_at(self.time, &self.stable_dt())
    }

    /// The Δt of [`Simulation::choose_dt`] at simulated time `time` when the stable Δt is
    /// `stable` ([`Simulation::stable_dt`]).
    fn choose_dt_at(&self, time: Real, stable: &(Real, String)) -> (Real, String) {
        let (dt, label) = self.choose_dt_to_end(time, stable);
        // shortened to land on the next exact output time (`output.snapshots.times`, …)
        match self.case.output.next_moment(time) {
            Some(m) => {
                let r = m - time;
                let lands_at_end = label == "end" && r >= dt * (1.0 - 1e-12);
                if r > 0.0 && r < dt * (1.0 + 1e-9) && !lands_at_end {
                    (r, OUTPUT_TIME.to_string())
                } else {
                    (dt, label)
                }
            }
            None => (dt, label),
        }
    }

    /// The stable Δt of the current state and what limits it, before any cut to land on a
    /// time: the adaptive one (CFL, `max_dt`, every model's limit); with `time.fixed_dt`,
    /// the adaptive limit without `max_dt`, which the fixed step is compared with.
    pub fn stable_dt(&self) -> (Real, String) {
        let t = &self.case.time;
        if t.fixed_dt.is_some() {
            let mut adaptive = t.clone();
            adaptive.fixed_dt = None;
            adaptive.max_dt = Real::INFINITY;
            return self.adaptive_dt(&adaptive, Real::INFINITY);
        }
        self.adaptive_dt(t, Real::INFINITY)
    }

    /// The Δt of [`Simulation::choose_dt`] at `time` before it lands on an output time.
    fn choose_dt_to_end(&self, time: Real, stable: &(Real, String)) -> (Real, String) {
        let t = &self.case.time;
        let remaining = t.end - time;
        let (limit, by) = stable;
        if let Some(dt) = t.fixed_dt {
            // the adaptive choice says whether the fixed step exceeds a stable limit
            let dt = dt.min(remaining.max(0.0)).max(0.0);
            let label = if dt > limit * (1.0 + 1e-9) {
                format!("fixed (exceeds the {by} limit {limit:.3e})")
            } else {
                "fixed".to_string()
            };
            return (dt, label);
        }
        cut_to_end((*limit, by.clone()), remaining)
    }

    /// The steps a run from the current state takes to `time.end` (at most
    /// `time.max_steps`) if the stable Δt stays that of the current state, each step
    /// chosen as the run chooses it ([`Simulation::choose_dt`]: landing on the exact output
    /// times and on the end) and the clock advanced as the run advances it; the first Δt
    /// and what limits it. Steps beyond `walk` are counted as whole steps of the stable
    /// Δt, not walked.
    pub fn planned_steps(&self, walk: u64) -> (u64, Real, String) {
        let stable = self.stable_dt();
        let first = self.choose_dt_at(self.time, &stable);
        let end = self.case.time.end;
        let max = self.case.time.max_steps.unwrap_or(u64::MAX);
        let (mut time, mut steps) = (self.time, self.steps);
        while !crate::driver::reached_end(time, end) && steps < max {
            if steps - self.steps >= walk {
                let rest = ((end - time) / self.choose_dt_at(time, &stable).0).ceil();
                let rest = if rest.is_finite() { rest as u64 } else { u64::MAX };
                steps = steps.saturating_add(rest).min(max);
                break;
            }
            let (dt, _) = self.choose_dt_at(time, &stable);
            if time + dt == time {
                break;
            }
            time += dt;
            steps += 1;
        }
        (steps - self.steps, first.0, first.1)
    }

    /// The adaptive Δt under `t` (CFL, `max_dt`, every model's limit) and what limits it,
    /// cut to `remaining` ([`cut_to_end`]).
    pub(super) fn adaptive_dt(&self, t: &crate::case::TimeControl, remaining: Real) -> (Real, String) {
        let h = self.grid.h;
        let umax = self.max_speed();
        let g = self.gravity.norm();
        // Δt (|u| + |g| Δt) ≤ C h: the step keeps the CFL bound even as gravity accelerates the flow
        let mut best = (t.max_dt, "max_dt".to_string());
        let cfl = if g > 0.0 {
            (-umax + (umax * umax + 4.0 * g * t.cfl * h).sqrt()) / (2.0 * g)
        } else if umax > 0.0 {
            t.cfl * h / umax
        } else {
            Real::INFINITY
        };
        if cfl < best.0 {
            best = (cfl, "cfl".into());
        }
        for f in &self.fields {
            let ctx = TimeStepContext {
                grid: &self.grid,
                density: f.density,
                max_speed: f.frame.max_speed(),
                implicit_viscosity: f.frame.implicit_diffusion_number(&f.stress),
            };
            for s in &f.stress {
                if let Some(dt) = s.stable_dt(&ctx) {
                    if dt < best.0 {
                        best = (dt, format!("{}({})", s.model(), f.name));
                    }
                }
            }
        }
        // with sub-steps the contact limits only its own integration (phase 8a)
        if let Some(c) = self.contact.as_ref().filter(|_| !self.case.time.contact_substeps) {
            let (bodies, resolved, _) = self.contact_bodies();
            let ctx = ContactContext {
                grid: &self.grid,
                // the domain's: contact is replicated on every rank (docs/design/mpi.md §5)
                boundaries: &self.case.boundaries,
                gravity: self.gravity,
                fluid_density: self.fluid_density(),
                fluid_viscosity: self.fluid_viscosity(),
                bodies: &bodies,
                resolved: &resolved,
            };
            if let Some(dt) = c.stable_dt(&ctx) {
                if dt < best.0 {
                    best = (dt, format!("contact({})", c.model()));
                }
            }
        }
        cut_to_end(best, remaining)
    }

    /// Advances one step.
    pub fn step(&mut self) -> Result<StepDiagnostics> {
        let (dt, limit) = self.choose_dt();
        self.step_with(dt, limit)
    }

    /// Advances one step of the given Δt.
    pub fn step_with(&mut self, dt: Real, dt_limit: String) -> Result<StepDiagnostics> {
        if self.alone {
            return self.step_alone(dt, dt_limit);
        }
        // (the phases name the traffic of a decomposed run's counters)
        let part = self.grid.part.clone();
        part.phase("1 particles to grid");
        self.particles_to_grid(dt)?;
        part.phase("2 volume fractions");
        let (volume_fraction_error, max_volume_fraction) = self.volume_fractions();
        #[cfg(feature = "dim2")]
        self.carry_immersed_forces();
        part.phase("3 predictor");
        self.predictor(dt)?;
        part.phase("4 exchange and contact");
        self.exchange(dt);
        self.contact_forces(dt)?;
        #[cfg(feature = "dim2")]
        self.immersed_boundaries(dt)?;
        part.phase("5 pressure");
        let (iterations, residual) = self.pressure_projection(dt)?;
        part.phase("6 max divergence");
        let max_divergence = self.max_divergence(dt);
        part.phase("7 grid to particles");
        self.grid_to_particles(dt)?;
        part.phase("8 advection");
        self.advection(dt)?;
        part.phase("9 diagnostics, time step and output");
        self.time += dt;
        self.steps += 1;
        let momentum = self.fields.iter().map(|f| f.frame.momentum()).fold(Vector::zeros(), |a, b| a + b);
        self.last = StepDiagnostics {
            step: self.steps,
            time: self.time,
            dt,
            dt_limit,
            kinetic_energy: self.kinetic_energy(),
            strain_energy: self.strain_energy(),
            momentum,
            mass: self.fields.iter().map(|f| f.frame.mass()).sum(),
            max_speed: self.max_speed(),
            max_divergence,
            volume_fraction_error,
            max_volume_fraction,
            pressure_iterations: iterations,
            pressure_residual: residual,
        };
        Ok(self.last.clone())
    }

    /// A step of the only field, which steps alone: none of the multifield phases (volume
    /// fractions, exchange, pressure, contact) has anything to do. Σθ and the strain energy
    /// are not computed: `volume_fraction_error`, `max_volume_fraction` and `strain_energy`
    /// are NaN.
    pub(super) fn step_alone(&mut self, dt: Real, dt_limit: String) -> Result<StepDiagnostics> {
        let mut figures = FrameFigures::default();
        self.frame_phase(dt, "step", |fr, ctx| {
            figures = fr.step_alone(ctx)?;
            Ok(())
        })?;
        self.grid_state_stale = true;
        self.time += dt;
        self.steps += 1;
        self.last = StepDiagnostics {
            step: self.steps,
            time: self.time,
            dt,
            dt_limit,
            kinetic_energy: figures.kinetic_energy,
            // a pass over every point's F (a logarithm each) would cost the fast path
            // 10–15 % of its step (mpm88)
            strain_energy: Real::NAN,
            momentum: figures.momentum,
            mass: figures.mass,
            max_speed: figures.max_speed,
            max_divergence: 0.0,
            volume_fraction_error: Real::NAN,
            max_volume_fraction: Real::NAN,
            pressure_iterations: 0,
            pressure_residual: 0.0,
        };
        Ok(self.last.clone())
    }

    /// Whether the fields' grid state is older than their frames' state (after a step of a
    /// field that steps alone, or a restart of one). Whatever reads the grid state (output
    /// writers, [`Simulation::save_state`]) should [`Simulation::refresh_grid_state`] first;
    /// the runner does.
    pub fn grid_state_stale(&self) -> bool {
        self.grid_state_stale
    }

    /// Brings the fields' grid state (θ, face masses and velocities) up to their frames'
    /// state when it is stale ([`Frame::refresh_grid_state`]); output writers read it.
    /// Changes nothing the next steps depend on.
    pub fn refresh_grid_state(&mut self) -> Result<()> {
        if self.grid_state_stale {
            self.frame_phase(0.0, "grid state for output", |fr, ctx| fr.refresh_grid_state(ctx))?;
            self.grid_state_stale = false;
        }
        Ok(())
    }

    pub(super) fn frame_phase(
        &mut self,
        dt: Real,
        phase: &str,
        f: impl FnMut(&mut dyn Frame, &mut FrameContext) -> Result<(), String>,
    ) -> Result<()> {
        self.frame_phase_of(dt, phase, |_| true, f)
    }

    /// [`Simulation::frame_phase`] for the fields `k` with `include(k)`.
    pub(super) fn frame_phase_of(
        &mut self,
        dt: Real,
        phase: &str,
        include: impl Fn(usize) -> bool,
        mut f: impl FnMut(&mut dyn Frame, &mut FrameContext) -> Result<(), String>,
    ) -> Result<()> {
        for k in 0..self.fields.len() {
            if !include(k) {
                continue;
            }
            let forced = self.forcings.iter().any(|p| p.bodies == k);
            // the field mutably, its drag partner (another field) immutably
            let (field, partner) = match &self.partners[k] {
                Some((p, law)) => {
                    let (field, other) = if *p > k {
                        let (lo, hi) = self.fields.split_at_mut(*p);
                        (&mut lo[k], &hi[0])
                    } else {
                        let (lo, hi) = self.fields.split_at_mut(k);
                        (&mut hi[0], &lo[*p])
                    };
                    (field, Some(Partner { state: &other.state, density: other.density, law }))
                }
                None => (&mut self.fields[k], None),
            };
            let mut ctx = FrameContext {
                grid: &self.grid,
                boundaries: &self.boundaries,
                dt,
                time: self.time,
                gravity: self.gravity,
                density: field.density,
                state: &mut field.state,
                stress: &field.stress,
                body_forces: &self.body_forces[k],
                forced_bodies: forced.then_some(&self.body_steps[k][..]),
                partner,
            };
            f(field.frame.as_mut(), &mut ctx)
                .map_err(|m| Error::Model(format!("{phase} of field `{}`: {m}", field.name)))?;
        }
        Ok(())
    }

    /// Phase 1: every frame puts its state on the grid (but the bodies of a direct
    /// forcing, which take no room there).
    pub(super) fn particles_to_grid(&mut self, dt: Real) -> Result<()> {
        let forced: Vec<usize> = self.forcings.iter().map(|p| p.bodies).collect();
        self.frame_phase_of(dt, "particles to grid", |k| !forced.contains(&k), |fr, ctx| fr.to_grid(ctx))
    }

    #[cfg(feature = "dim2")]
    /// Phase 4b (after the exchange and the contact forces, before the pressure): every
    /// direct forcing moves its free bodies and forces its fluid towards the bodies' rigid
    /// motion on their surfaces ([`crate::immersed::couple`]).
    pub(super) fn immersed_boundaries(&mut self, dt: Real) -> Result<()> {
        let bodies: Vec<Vec<crate::immersed::ForcedBody>> =
            (0..self.forcings.len()).map(|k| self.forced_bodies(k)).collect();
        // every forcing's lagged forces where the bodies end the step, if one of the
        // fluid's bodies moves (else they stand where carry_immersed_forces spread them)
        for (fluid, ks) in self.forcings_by_fluid() {
            let ahead: Vec<Vec<crate::immersed::ForcedBody>> =
                ks.iter().map(|&k| bodies[k].iter().map(|b| b.ahead(dt)).collect()).collect();
            let moves =
                ks.iter().zip(&ahead).any(|(&k, a)| a.iter().zip(&bodies[k]).any(|(a, b)| a.center != b.center));
            if moves {
                let parts: Vec<_> = ks
                    .iter()
                    .zip(&ahead)
                    .map(|(&k, a)| (self.forcings[k].forcing.retraction, &a[..], &self.forcings[k].lag[..]))
                    .collect();
                let out = &mut self.fields[fluid].state.body_force;
                crate::immersed::spread_all_lagged(&self.grid, &self.boundaries, &parts, out);
            }
        }
        let mut applied = vec![false; self.fields.len()];
        for (k, bodies) in bodies.iter().enumerate() {
            let p = &mut self.forcings[k];
            let rho_f = self.fields[p.fluid].density;
            let name = self.fields[p.bodies].name.clone();
            let fluid = &mut self.fields[p.fluid].state;
            // a later forcing of the fluid: Δt f is in the velocity already
            let total = std::mem::replace(&mut applied[p.fluid], true)
                .then(|| std::mem::replace(&mut fluid.body_force, FaceVelocity::zeros(&self.grid)));
            let steps = crate::immersed::couple(
                &self.grid,
                &self.boundaries,
                p.forcing.sweeps,
                p.forcing.retraction,
                dt,
                self.gravity,
                rho_f,
                fluid,
                bodies,
                &mut p.lag,
                self.steps > 0,
            )
            .map_err(|m| Error::Model(format!("immersed boundaries of field `{name}`: {m}")))?;
            if let Some(mut total) = total {
                // f ← f + S δF of this forcing
                for (t, f) in
                    total.u.iter_mut().zip(&fluid.body_force.u).chain(total.v.iter_mut().zip(&fluid.body_force.v))
                {
                    *t += f;
                }
                fluid.body_force = total;
            }
            self.boundaries.enforce(&self.grid, &mut fluid.velocity);
            self.body_steps[p.bodies] = steps;
        }
        Ok(())
    }

    #[cfg(feature = "dim2")]
    /// Phase 2b (before the predictors): every direct forcing's fluid takes the last
    /// step's marker forces spread from where its bodies' markers stand now
    /// ([`crate::immersed::spread_lagged`]), the lagged force its predictor sees.
    pub(super) fn carry_immersed_forces(&mut self) {
        for (fluid, ks) in self.forcings_by_fluid() {
            let bodies: Vec<_> = ks.iter().map(|&k| self.forced_bodies(k)).collect();
            let parts: Vec<_> = ks
                .iter()
                .zip(&bodies)
                .map(|(&k, b)| (self.forcings[k].forcing.retraction, &b[..], &self.forcings[k].lag[..]))
                .collect();
            let out = &mut self.fields[fluid].state.body_force;
            crate::immersed::spread_all_lagged(&self.grid, &self.boundaries, &parts, out);
        }
    }

    #[cfg(feature = "dim2")]
    /// The fluids of the direct forcings, in the order of their first forcing, each with
    /// its forcings' indices in order.
    fn forcings_by_fluid(&self) -> Vec<(usize, Vec<usize>)> {
        let mut out: Vec<(usize, Vec<usize>)> = Vec::new();
        for (k, p) in self.forcings.iter().enumerate() {
            match out.iter_mut().find(|(f, _)| *f == p.fluid) {
                Some((_, ks)) => ks.push(k),
                None => out.push((p.fluid, vec![k])),
            }
        }
        out
    }

    #[cfg(feature = "dim2")]
    /// The bodies of direct forcing `k` as they stand now.
    pub(super) fn forced_bodies(&self, k: usize) -> Vec<crate::immersed::ForcedBody> {
        let p = &self.forcings[k];
        let Region::Bodies(specs) = &self.case.fields[p.bodies].region else {
            return Vec::new();
        };
        let states = self.fields[p.bodies].frame.bodies();
        // the contact model's clearance from the walls (lubrication below it), if any
        let clearance = self.contact.as_ref().map_or(0.0, |c| c.wall_clearance(self.grid.h));
        specs
            .iter()
            .zip(&states)
            .enumerate()
            .map(|(j, (spec, state))| crate::immersed::ForcedBody {
                shape: spec.shape.clone(),
                // a fixed body's centre is its shape's (the points' centroid carries the
                // round-off of its masses); a moving disk's is its centroid
                center: match (&spec.shape, spec.motion) {
                    (BodyShape::Annulus { center, .. } | BodyShape::Disk { center, .. }, Motion::Fixed)
                    | (BodyShape::Annulus { center, .. }, _) => vector(*center),
                    _ => state.position,
                },
                motion: spec.motion,
                velocity: state.velocity,
                angular_velocity: state.angular_velocity,
                density: spec.density_or(self.fields[p.bodies].density),
                contact: self.body_forces[p.bodies].get(j).copied().unwrap_or_default(),
                hold: match spec.shape {
                    BodyShape::Disk { radius, .. } => {
                        crate::immersed::ForcedBody::hold_box(&self.grid, &self.boundaries, radius, clearance)
                    }
                    _ => None,
                },
            })
            .collect()
    }

    /// Phase 2: volume fractions; the field of region `Rest` takes what the others leave.
    /// Returns max |Σθ − 1| and max Σθ over the cells.
    pub(super) fn volume_fractions(&mut self) -> (Real, Real) {
        let n = self.grid.n_cells();
        let mut others = vec![0.0; n];
        for f in self.fields.iter().filter(|f| !f.fills_rest) {
            for (o, t) in others.iter_mut().zip(&f.state.theta) {
                *o += t;
            }
        }
        let periodic = self.boundaries.periodic_axes();
        let volume = self.grid.cell_volume();
        for f in &mut self.fields {
            if f.fills_rest {
                for (t, o) in f.state.theta.iter_mut().zip(&others) {
                    *t = (1.0 - o).max(0.0);
                }
            }
            f.state.update_face_fractions(&self.grid, periodic);
            // An Eulerian field's face mass follows from θ; a Lagrangian field keeps the
            // mass its points put there, so that momentum is conserved between frames.
            if !f.frame.is_lagrangian() {
                let s = &mut f.state;
                for a in AXES {
                    for (m, t) in s.mass_face[a].iter_mut().zip(&s.theta_face[a]) {
                        *m = t * f.density * volume;
                    }
                }
            }
        }
        // over the owned cells, every rank's
        let (mut err, mut max): (Real, Real) = (0.0, 0.0);
        for cells in self.grid.groups(Lattice::Cell).rows() {
            for c in cells {
                let s: Real = self.fields.iter().map(|f| f.state.theta[c]).sum();
                err = err.max((s - 1.0).abs());
                max = max.max(s);
            }
        }
        let mut m = [err, max];
        self.grid.part.max(&mut m);
        (m[0], m[1])
    }

    /// Phase 3: frame predictors (advection and grid stresses, in each frame's own time
    /// discretisation), then gravity.
    pub(super) fn predictor(&mut self, dt: Real) -> Result<()> {
        self.frame_phase(dt, "predictor", |fr, ctx| fr.predict(ctx))?;
        let g = self.gravity;
        for f in &mut self.fields {
            let s = &mut f.state;
            // gravity after the stresses: a viscous stencil must not act on the gravity
            // increment Δt g, which the pressure cancels at rest (hydrostatic box with walls)
            for a in AXES {
                s.velocity[a].iter_mut().for_each(|u| *u += dt * g[a]);
            }
            self.boundaries.enforce(&self.grid, &mut s.velocity);
        }
        Ok(())
    }

    /// Phase 8a (bodies, right after the exchange): contact forces from the positions at
    /// the start of the step; the frames apply them with the rigid projection in
    /// grid-to-particles (8b). With `time.contact_substeps`, the bodies' contact is
    /// integrated over the step in sub-steps ([`super::contact::substepped`]), and the
    /// frames take its mean force and the position correction.
    pub(super) fn contact_forces(&mut self, dt: Real) -> Result<()> {
        let fluid_density = self.fluid_density();
        let fluid_viscosity = self.fluid_viscosity();
        let substeps = self.case.time.contact_substeps;
        if self.contact.is_none() {
            return Ok(());
        }
        let (all, resolved, per_field) = self.contact_bodies();
        if all.is_empty() {
            return Ok(());
        }
        let Some(c) = &mut self.contact else {
            return Ok(());
        };
        let ctx = ContactContext {
            grid: &self.grid,
            // the domain's: contact is replicated on every rank (docs/design/mpi.md §5)
            boundaries: &self.case.boundaries,
            gravity: self.gravity,
            fluid_density,
            fluid_viscosity,
            bodies: &all,
            resolved: &resolved,
        };
        let out = if substeps && dt > 0.0 {
            super::contact::substepped(c.as_mut(), &ctx, dt)
                .map_err(|m| Error::Model(format!("time.contact_substeps: {m}")))?
        } else {
            let mut out = vec![(Vector::zeros(), 0.0); all.len()];
            c.forces(&ctx, dt, &mut out);
            out.into_iter().map(|(f, t)| BodyContact::force(f, t)).collect()
        };
        let mut k = 0;
        for (f, &n) in per_field.iter().enumerate() {
            self.body_forces[f] = out[k..k + n].to_vec();
            k += n;
        }
        Ok(())
    }

    /// Phase 7: every frame takes the corrected grid velocity back.
    pub(super) fn grid_to_particles(&mut self, dt: Real) -> Result<()> {
        self.frame_phase(dt, "grid to particles", |fr, ctx| fr.from_grid(ctx))
    }

    /// Phase 9: Eulerian transport of volume fractions.
    pub(super) fn advection(&mut self, dt: Real) -> Result<()> {
        self.frame_phase(dt, "advection", |fr, ctx| fr.advect(ctx))
    }
}
