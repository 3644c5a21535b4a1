//! Phase 4: the implicit momentum exchange between the fields on every face.

use super::*;
use rayon::prelude::*;

/// Faces per parallel task of the exchange (about 0.1 ms of work: a task outweighs its cost;
/// small enough that the thread-count tests on 32 × 96 cells split it).
const EXCHANGE_CHUNK: usize = 1024;

impl Simulation {
    /// Phase 4: implicit (or explicit) momentum exchange on every face.
    pub(super) fn exchange(&mut self, dt: Real) {
        if self.exchanges.is_empty() {
            // no coupling: velocities stay; each field's w = θ/(θρ⁰) for the pressure
            if self.pressure_solver.is_some() {
                self.uncoupled_specific_volumes();
            }
            return;
        }
        let n = self.fields.len();
        let area = self.grid.cell_area();
        for e in &mut self.exchanges {
            let [a, b] = e.fields;
            let ctx = ExchangeContext {
                grid: &self.grid,
                a: &self.fields[a].state,
                b: &self.fields[b].state,
                density: [self.fields[a].density, self.fields[b].density],
            };
            if e.model.no_slip() {
                e.kx.fill(Real::INFINITY);
                e.ky.fill(Real::INFINITY);
            } else {
                e.model.coefficients(&ctx, &mut e.kx, &mut e.ky);
            }
        }
        let densities: Vec<Real> = self.fields.iter().map(|f| f.density).collect();
        // added mass C_A ρ_f θ_s per face, between the fluid a and the particles b
        let added: Vec<([usize; 2], Real)> = self
            .exchanges
            .iter()
            .filter_map(|e| {
                let law = e.model.drag_law()?;
                (law.added_mass > 0.0).then(|| (e.fields, law.added_mass * densities[e.fields[0]]))
            })
            .collect();
        // each face's exchange is independent of every other's: solved in parallel in
        // chunks, the results written back in face order (bit-identical whatever the threads)
        for lattice in 0..2 {
            let nf = if lattice == 0 { self.grid.n_xfaces() } else { self.grid.n_yfaces() };
            let (fields, exchanges) = (&self.fields, &self.exchanges);
            let solved: Vec<([Real; MAX_FIELDS], [Real; MAX_FIELDS])> = (0..nf)
                .into_par_iter()
                .with_min_len(EXCHANGE_CHUNK)
                .map(|face| {
                    let mut loc = Local {
                        n,
                        rho: [0.0; MAX_FIELDS],
                        rho_w: [0.0; MAX_FIELDS],
                        theta: [0.0; MAX_FIELDS],
                        material_density: [1.0; MAX_FIELDS],
                        u: [0.0; MAX_FIELDS],
                        u_old: [0.0; MAX_FIELDS],
                        w: [0.0; MAX_FIELDS],
                    };
                    for (k, f) in fields.iter().enumerate() {
                        let s = &f.state;
                        let (m, t, u, u0) = if lattice == 0 {
                            (s.mass_u[face], s.theta_u[face], s.velocity.u[face], s.velocity_old.u[face])
                        } else {
                            (s.mass_v[face], s.theta_v[face], s.velocity.v[face], s.velocity_old.v[face])
                        };
                        loc.rho[k] = m / area;
                        // bodies of their own densities: θρ⁰ is the mass the points put there
                        loc.rho_w[k] = if f.own_densities { m / area } else { t * densities[k] };
                        loc.theta[k] = t;
                        loc.u[k] = u;
                        loc.u_old[k] = u0;
                        loc.material_density[k] = densities[k];
                    }

                    let mut implicit: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                    let mut explicit: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                    let mut any_explicit = false;
                    for e in exchanges {
                        let kk = if lattice == 0 { e.kx[face] } else { e.ky[face] };
                        let [a, b] = e.fields;
                        let target = if e.integration == Integration::Explicit && !kk.is_infinite() {
                            any_explicit = true;
                            &mut explicit
                        } else {
                            &mut implicit
                        };
                        target[a][b] = kk;
                        target[b][a] = kk;
                    }
                    if any_explicit {
                        exchange::explicit(&mut loc, &explicit, dt);
                    }
                    if added.is_empty() {
                        exchange::solve(&mut loc, &implicit, dt);
                    } else {
                        let mut added_mass: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                        for ([a, b], c) in &added {
                            let am = c * loc.theta[*b];
                            added_mass[*a][*b] = am;
                            added_mass[*b][*a] = am;
                        }
                        exchange::solve_with_added_mass(&mut loc, &implicit, &added_mass, dt);
                    }
                    (loc.u, loc.w)
                })
                .collect();
            for (k, f) in self.fields.iter_mut().enumerate() {
                let s = &mut f.state;
                let (vel, w) = if lattice == 0 {
                    (&mut s.velocity.u, &mut s.specific_volume.u)
                } else {
                    (&mut s.velocity.v, &mut s.specific_volume.v)
                };
                for (face, (u_face, w_face)) in solved.iter().enumerate() {
                    vel[face] = u_face[k];
                    w[face] = w_face[k];
                }
            }
        }
    }

    /// The specific volumes of fields that exchange nothing: what [`exchange::solve`] gives
    /// without coupling, face by face, without building its local system.
    pub(super) fn uncoupled_specific_volumes(&mut self) {
        let area = self.grid.cell_area();
        for f in &mut self.fields {
            let rho0 = f.density;
            let own = f.own_densities;
            let s = &mut f.state;
            for (w, m, t) in
                [(&mut s.specific_volume.u, &s.mass_u, &s.theta_u), (&mut s.specific_volume.v, &s.mass_v, &s.theta_v)]
            {
                for ((w, m), t) in w.iter_mut().zip(m.iter()).zip(t.iter()) {
                    let rho = m / area;
                    let rho_w = if own { rho } else { t * rho0 };
                    *w = if rho > 1e-10 * rho0 {
                        if rho_w > 0.0 {
                            t / rho_w
                        } else {
                            t / rho
                        }
                    } else {
                        1.0 / rho0
                    };
                }
            }
        }
    }
}
