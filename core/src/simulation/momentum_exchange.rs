//! Phase 4: the implicit momentum exchange between the fields on every face.

use super::*;
use rayon::prelude::*;

/// Faces per parallel task of the exchange (about 0.1 ms of work: a task outweighs its cost;
/// small enough that the thread-count tests on 32 × 96 cells split it).
const EXCHANGE_CHUNK: usize = 1024;

/// One field's faces of one chunk: what the exchange reads and the two arrays it writes.
struct FaceChunk<'a> {
    u: &'a mut [Real],
    w: &'a mut [Real],
    mass: &'a [Real],
    theta: &'a [Real],
    u_old: &'a [Real],
    /// Bodies of their own densities (θρ⁰ is the mass the points put there).
    own: bool,
}

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
        let area = self.grid.cell_volume();
        for e in &mut self.exchanges {
            let [a, b] = e.fields;
            let ctx = ExchangeContext {
                grid: &self.grid,
                a: &self.fields[a].state,
                b: &self.fields[b].state,
                density: [self.fields[a].density, self.fields[b].density],
                periodic: self.boundaries.periodic_axes(),
            };
            if e.model.no_slip() {
                for a in AXES {
                    e.k[a].fill(Real::INFINITY);
                }
            } else {
                e.model.coefficients(&ctx, &mut e.k);
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
        // chunks of faces, each chunk writing its own faces of every field in place
        // (bit-identical whatever the threads)
        for lattice in AXES {
            let nf = self.grid.n_faces(lattice);
            let mut chunks: Vec<Vec<FaceChunk>> =
                (0..nf.div_ceil(EXCHANGE_CHUNK)).map(|_| Vec::with_capacity(n)).collect();
            for f in self.fields.iter_mut() {
                let own = f.own_densities;
                let s = &mut f.state;
                let (u, w, mass, theta, u_old) = (
                    &mut s.velocity[lattice],
                    &mut s.specific_volume[lattice],
                    &s.mass_face[lattice],
                    &s.theta_face[lattice],
                    &s.velocity_old[lattice],
                );
                let parts = u
                    .chunks_mut(EXCHANGE_CHUNK)
                    .zip(w.chunks_mut(EXCHANGE_CHUNK))
                    .zip(mass.chunks(EXCHANGE_CHUNK))
                    .zip(theta.chunks(EXCHANGE_CHUNK))
                    .zip(u_old.chunks(EXCHANGE_CHUNK));
                for (chunk, ((((u, w), mass), theta), u_old)) in chunks.iter_mut().zip(parts) {
                    chunk.push(FaceChunk { u, w, mass, theta, u_old, own });
                }
            }
            let exchanges = &self.exchanges;
            // two fields and one implicit exchange (a fluid and a dispersed field): the
            // same solve without the general one's 8 × 8 arrays ([`exchange::solve_pair`])
            let pair = (n == 2 && exchanges.len() == 1 && exchanges[0].integration == Integration::Implicit)
                .then(|| (&exchanges[0], added.first().map(|&([_, b], c)| (b, c))));
            chunks.into_par_iter().enumerate().for_each(|(c, mut chunk)| {
                let len = chunk.first().map_or(0, |f| f.u.len());
                if let Some((e, added)) = pair {
                    let k = &e.k[lattice];
                    let (f0, f1) = chunk.split_at_mut(1);
                    let (f0, f1) = (&mut f0[0], &mut f1[0]);
                    for i in 0..len {
                        let face = c * EXCHANGE_CHUNK + i;
                        let (m, t) = ([f0.mass[i], f1.mass[i]], [f0.theta[i], f1.theta[i]]);
                        let rho = [m[0] / area, m[1] / area];
                        let p = exchange::Pair {
                            rho,
                            rho_w: [
                                if f0.own { rho[0] } else { t[0] * densities[0] },
                                if f1.own { rho[1] } else { t[1] * densities[1] },
                            ],
                            theta: t,
                            material_density: [densities[0], densities[1]],
                            u: [f0.u[i], f1.u[i]],
                            u_old: [f0.u_old[i], f1.u_old[i]],
                        };
                        let am = added.map_or(0.0, |(b, c)| c * t[b]);
                        let (u, w) = exchange::solve_pair(&p, k[face], am, dt);
                        (f0.u[i], f1.u[i], f0.w[i], f1.w[i]) = (u[0], u[1], w[0], w[1]);
                    }
                    return;
                }
                for i in 0..len {
                    let face = c * EXCHANGE_CHUNK + i;
                    let mut loc = Local::empty(n);
                    for (k, f) in chunk.iter().enumerate() {
                        let (m, t) = (f.mass[i], f.theta[i]);
                        loc.rho[k] = m / area;
                        // bodies of their own densities: θρ⁰ is the mass the points put there
                        loc.rho_w[k] = if f.own { m / area } else { t * densities[k] };
                        loc.theta[k] = t;
                        loc.u[k] = f.u[i];
                        loc.u_old[k] = f.u_old[i];
                        loc.material_density[k] = densities[k];
                    }

                    let mut implicit: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                    let mut explicit: Coefficients = [[0.0; MAX_FIELDS]; MAX_FIELDS];
                    let mut any_explicit = false;
                    for e in exchanges {
                        let kk = e.k[lattice][face];
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
                    for (k, f) in chunk.iter_mut().enumerate() {
                        f.u[i] = loc.u[k];
                        f.w[i] = loc.w[k];
                    }
                }
            });
        }
    }

    /// The specific volumes of fields that exchange nothing: what [`exchange::solve`] gives
    /// without coupling, face by face, without building its local system.
    pub(super) fn uncoupled_specific_volumes(&mut self) {
        let area = self.grid.cell_volume();
        for f in &mut self.fields {
            let rho0 = f.density;
            let own = f.own_densities;
            let s = &mut f.state;
            for a in AXES {
                let (w, m, t) = (&mut s.specific_volume[a], &s.mass_face[a], &s.theta_face[a]);
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
