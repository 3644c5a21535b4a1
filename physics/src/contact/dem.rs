//! Soft-sphere (DEM) contact: a linear spring–dashpot in the normal direction and a
//! tangential spring capped by Coulomb friction, between disks and between disks and walls
//! (Cundall & Strack, Géotechnique 29, 1979; the parameters from a restitution coefficient
//! and a collision time as in Luding, Granular Matter 10, 2008).
//!
//! For two disks i, j of radii R, centres x (separation x_i − x_j the minimum image across
//! periodic sides), distance d and overlap δ = R_i + R_j − d > 0, with n = (x_i − x_j)/d,
//! t = ẑ × n and the relative velocity of the contact point
//! v = v_i − v_j − (R_i ω_i + R_j ω_j) t, split into v_n = v·n and v_t = v·t:
//!
//!   F_n = k_n δ − γ_n v_n,
//!   k_n = m_eff (π² + ln² e) / t_c²,  γ_n = −2 m_eff ln e / t_c,  m_eff = m_i m_j/(m_i + m_j),
//!
//! e = `restitution`, t_c = `collision_time`. A head-on collision of this damped oscillator
//! lasts exactly t_c (the overlap returns to zero after half a damped period) and leaves
//! with e times its approach speed; the price is a slightly attractive force at the very
//! end of a contact (the dashpot), which the formulas assume and which is kept. A body that
//! is not free (fixed) and a wall have infinite mass: m_eff is the free body's mass.
//!
//! Tangential: a spring k_t = `tangential_stiffness` · k_n on the history ξ (the tangential
//! displacement of the contact point since the pair touched, one scalar along t per
//! touching pair), with an optional dashpot γ_t = `tangential_damping` · γ_n:
//! F_t = −k_t ξ − γ_t v_t, capped at |F_t| ≤ μ max(F_n, 0) (μ = `friction`); where the cap
//! acts (sliding) ξ is rescaled to the capped force, ξ = −(F_t + γ_t v_t)/k_t. ξ first
//! advances by v_t Δt over the (sub-)step Δt, then gives the force: with the frames moving
//! the bodies by their new velocity (symplectic Euler) the tangential spring is then
//! integrated symplectically too (advancing ξ after the force instead would be forward
//! Euler, gaining (π/N)²/2 of the tangential energy per contact of N steps). ξ is forgotten
//! when the pair separates. The force on i is F_n n + F_t t (its opposite on j), the torques
//! −R_i F_t on i and −R_j F_t on j. The default k_t/k_n = 1/3 makes the tangential period
//! of a sticking contact of two solid disks (tangential mass m_eff/3, since I = m R²/2)
//! equal to the normal one, so a sticking contact reverses its tangential velocity (the
//! 3D spheres' value is 2/7).
//!
//! Walls (every side that is not periodic, as `repulsion`'s: an inflow or an outflow of the
//! fluid is a wall for the bodies, which keeps them in the domain of a fluidized bed): a
//! body touching a wall is a pair with a fixed body of infinite mass whose surface is the wall.
//!
//! Step: Δt ≤ t_c / `steps_per_collision` at every step of a case with a free body (a
//! collision can begin at any step; docs/method.md §5). The pairs come from the cell-list
//! search of `multifield_core::neighbours` (O(N)).

use multifield_core::boundary::{Boundary, Side};
use multifield_core::math::{Real, Vector};
use multifield_core::neighbours::{pairs_within, SearchDomain};
use multifield_core::plugin::{BodyState, ContactContext, ContactModel};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Soft-sphere contact (module docs).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dem {
    /// Normal restitution coefficient e ∈ (0, 1].
    pub restitution: Real,
    /// Duration t_c of a normal contact (time).
    pub collision_time: Real,
    /// Coulomb friction coefficient μ ≥ 0.
    #[serde(default)]
    pub friction: Real,
    /// k_t / k_n.
    #[serde(default = "default_tangential_stiffness")]
    pub tangential_stiffness: Real,
    /// γ_t / γ_n.
    #[serde(default)]
    pub tangential_damping: Real,
    /// Whether walls are contacts.
    #[serde(default = "default_walls")]
    pub walls: bool,
    /// Steps per collision time: Δt ≤ t_c / steps_per_collision.
    #[serde(default = "default_steps")]
    pub steps_per_collision: Real,
    /// ξ per touching pair: (i, j) for bodies, (i, WALL + side) for walls.
    #[serde(skip)]
    history: BTreeMap<(u64, u64), Real>,
}

/// The partner index of a wall in the history's keys: WALL + the side's index.
const WALL: u64 = u64::MAX - 8;

fn default_tangential_stiffness() -> Real {
    1.0 / 3.0
}
fn default_walls() -> bool {
    true
}
fn default_steps() -> Real {
    20.0
}

/// One contact's figures, for the force law.
struct Touch {
    /// Key of its history: (i, j) for bodies, (i, WALL + side) for a wall.
    key: (u64, u64),
    /// The first body.
    i: usize,
    /// The second body, `None` for a wall.
    j: Option<usize>,
    /// Overlap δ > 0.
    overlap: Real,
    /// Unit normal, towards the first body.
    n: Vector,
    /// Relative velocity of the contact point (first minus second).
    v: Vector,
    /// Effective mass.
    mass: Real,
}

impl Dem {
    /// Checks the parameters.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(self.restitution > 0.0 && self.restitution <= 1.0) {
            return Err(format!(
                "restitution {}: must lie in (0, 1] (1 elastic; a perfectly plastic 0 has no finite spring)",
                self.restitution
            ));
        }
        if !(self.collision_time > 0.0 && self.collision_time.is_finite()) {
            return Err(format!(
                "collision_time {}: must be positive (the duration of a contact, a few steps' worth at least)",
                self.collision_time
            ));
        }
        if !(self.friction >= 0.0 && self.friction.is_finite()) {
            return Err(format!("friction {}: must be zero or positive (0 frictionless)", self.friction));
        }
        if !(self.tangential_stiffness > 0.0 && self.tangential_stiffness.is_finite()) {
            return Err(format!(
                "tangential_stiffness {}: must be positive (k_t/k_n; 1/3 for disks, 2/7 for spheres)",
                self.tangential_stiffness
            ));
        }
        if !(self.tangential_damping >= 0.0 && self.tangential_damping.is_finite()) {
            return Err(format!("tangential_damping {}: must be zero or positive (γ_t/γ_n)", self.tangential_damping));
        }
        if !(self.steps_per_collision >= 1.0 && self.steps_per_collision.is_finite()) {
            return Err(format!(
                "steps_per_collision {}: must be at least 1 (20 or more for the restitution within a few %)",
                self.steps_per_collision
            ));
        }
        Ok(())
    }

    /// k_n and γ_n for the effective mass `m`.
    fn normal(&self, m: Real) -> (Real, Real) {
        let ln_e = self.restitution.ln();
        let tc = self.collision_time;
        let k = m * (std::f64::consts::PI.powi(2) + ln_e * ln_e) / (tc * tc);
        let gamma = -2.0 * m * ln_e / tc;
        (k, gamma)
    }

    /// The normal and tangential forces of a contact from the history ξ before the step,
    /// and ξ after it: (F_n, F_t, ξ').
    fn law(&self, c: &Touch, xi: Real, dt: Real) -> (Real, Real, Real) {
        let (k_n, gamma_n) = self.normal(c.mass);
        let t = Vector::new(-c.n.y, c.n.x);
        let (v_n, v_t) = (c.v.dot(&c.n), c.v.dot(&t));
        let f_n = k_n * c.overlap - gamma_n * v_n;
        let k_t = self.tangential_stiffness * k_n;
        let gamma_t = self.tangential_damping * gamma_n;
        let mut xi = xi + v_t * dt;
        let mut f_t = -k_t * xi - gamma_t * v_t;
        let cap = self.friction * f_n.max(0.0);
        if f_t.abs() > cap {
            f_t = cap.copysign(f_t);
            xi = -(f_t + gamma_t * v_t) / k_t;
        }
        (f_n, f_t, xi)
    }

    /// Every touching pair and wall contact, in a deterministic order (pairs by (i, j), then
    /// walls by body and side).
    fn touches(&self, ctx: &ContactContext) -> Vec<Touch> {
        let bodies = ctx.bodies;
        let domain = SearchDomain {
            origin: ctx.grid.origin,
            size: ctx.grid.size(),
            periodic_x: ctx.boundaries.periodic_x(),
            periodic_y: ctx.boundaries.periodic_y(),
        };
        let centres: Vec<Vector> = bodies.iter().map(|b| b.position).collect();
        let radii: Vec<Real> = bodies.iter().map(|b| b.radius).collect();
        let mut out = Vec::new();
        for p in pairs_within(&centres, &radii, 0.0, &domain) {
            let (a, b) = (&bodies[p.i], &bodies[p.j]);
            let Some(mass) = effective_mass(a, Some(b)) else { continue };
            let overlap = a.radius + b.radius - p.distance;
            if !(overlap > 0.0 && p.distance > 0.0) {
                continue;
            }
            let n = p.separation / p.distance;
            let t = Vector::new(-n.y, n.x);
            let v = a.velocity - b.velocity - (a.radius * a.angular_velocity + b.radius * b.angular_velocity) * t;
            out.push(Touch { key: (p.i as u64, p.j as u64), i: p.i, j: Some(p.j), overlap, n, v, mass });
        }
        if !self.walls {
            return out;
        }
        let lo = ctx.grid.origin;
        let hi = lo + ctx.grid.size();
        for (i, a) in bodies.iter().enumerate() {
            let Some(mass) = effective_mass(a, None) else { continue };
            for (k, side) in Side::ALL.into_iter().enumerate() {
                if ctx.boundaries.side(side) == Boundary::Periodic {
                    continue;
                }
                let x = a.position;
                let (gap, n) = match side {
                    Side::Left => (x.x - lo.x, Vector::new(1.0, 0.0)),
                    Side::Right => (hi.x - x.x, Vector::new(-1.0, 0.0)),
                    Side::Bottom => (x.y - lo.y, Vector::new(0.0, 1.0)),
                    Side::Top => (hi.y - x.y, Vector::new(0.0, -1.0)),
                };
                let overlap = a.radius - gap;
                if !(overlap > 0.0) {
                    continue;
                }
                let t = Vector::new(-n.y, n.x);
                let v = a.velocity - a.radius * a.angular_velocity * t;
                out.push(Touch { key: (i as u64, WALL + k as u64), i, j: None, overlap, n, v, mass });
            }
        }
        out
    }
}

/// m_eff of a pair (a wall or a fixed body: infinite mass), `None` when neither moves.
fn effective_mass(a: &BodyState, b: Option<&BodyState>) -> Option<Real> {
    match b {
        None => a.free.then_some(a.mass),
        Some(b) => match (a.free, b.free) {
            (true, true) => Some(a.mass * b.mass / (a.mass + b.mass)),
            (true, false) => Some(a.mass),
            (false, true) => Some(b.mass),
            (false, false) => None,
        },
    }
}

multifield_core::register!(
    Contact,
    "dem",
    Dem,
    "soft-sphere (DEM) contact: linear spring–dashpot from e and t_c, tangential spring with Coulomb friction",
    &[
        ParamDoc {
            name: "restitution",
            unit: "-",
            default: "required",
            doc: "normal restitution coefficient e in (0, 1]"
        },
        ParamDoc {
            name: "collision_time",
            unit: "time",
            default: "required",
            doc: "duration t_c of a contact; k_n = m_eff(π²+ln²e)/t_c², γ_n = −2 m_eff ln e/t_c",
        },
        ParamDoc { name: "friction", unit: "-", default: "0.0", doc: "Coulomb coefficient μ: |F_t| ≤ μ F_n" },
        ParamDoc {
            name: "tangential_stiffness",
            unit: "-",
            default: "0.3333333333333333",
            doc: "k_t/k_n (1/3: a sticking disk contact's tangential period equals the normal one)",
        },
        ParamDoc { name: "tangential_damping", unit: "-", default: "0.0", doc: "γ_t/γ_n (tangential dashpot)" },
        ParamDoc {
            name: "walls",
            unit: "-",
            default: "true",
            doc: "whether the sides (every non-periodic one, inflows and outflows included) are walls for the bodies"
        },
        ParamDoc {
            name: "steps_per_collision",
            unit: "-",
            default: "20.0",
            doc: "Δt ≤ t_c/steps_per_collision at every step of a case with a free body",
        },
    ]
);

impl ContactModel for Dem {
    fn model(&self) -> &'static str {
        "dem"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn forces(&mut self, ctx: &ContactContext, dt: Real, out: &mut [(Vector, Real)]) {
        out.iter_mut().for_each(|o| *o = (Vector::zeros(), 0.0));
        let mut history = BTreeMap::new();
        for c in self.touches(ctx) {
            let (i, j) = (c.i, c.j);
            let xi = self.history.get(&c.key).copied().unwrap_or(0.0);
            let (f_n, f_t, xi) = self.law(&c, xi, dt);
            history.insert(c.key, xi);
            let t = Vector::new(-c.n.y, c.n.x);
            let f = f_n * c.n + f_t * t;
            out[i].0 += f;
            out[i].1 -= ctx.bodies[i].radius * f_t;
            if let Some(j) = j {
                out[j].0 -= f;
                out[j].1 -= ctx.bodies[j].radius * f_t;
            }
        }
        self.history = history;
    }
    fn stable_dt(&self, ctx: &ContactContext) -> Option<Real> {
        ctx.bodies.iter().any(|b| b.free).then(|| self.collision_time / self.steps_per_collision)
    }
    /// Every non-periodic side is a wall for the bodies, inflows and outflows included.
    fn keeps_bodies_off_sides(&self) -> bool {
        self.walls
    }
    fn history(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(8 + 24 * self.history.len());
        b.extend_from_slice(&(self.history.len() as u64).to_le_bytes());
        for (&(i, j), &xi) in &self.history {
            b.extend_from_slice(&i.to_le_bytes());
            b.extend_from_slice(&j.to_le_bytes());
            b.extend_from_slice(&xi.to_bits().to_le_bytes());
        }
        b
    }
    fn restore_history(&mut self, bytes: &[u8]) -> Result<(), String> {
        let word = |k: usize| u64::from_le_bytes(bytes[8 * k..8 * k + 8].try_into().expect("8 bytes"));
        if bytes.is_empty() {
            self.history.clear();
            return Ok(());
        }
        if bytes.len() < 8 || !(bytes.len() - 8).is_multiple_of(24) || word(0) != ((bytes.len() - 8) / 24) as u64 {
            return Err(format!(
                "dem contact history of {} bytes: not a count and (i, j, ξ) triples (a checkpoint of another contact model?)",
                bytes.len()
            ));
        }
        let mut history = BTreeMap::new();
        for k in 0..word(0) as usize {
            let (i, j, xi) = (word(1 + 3 * k), word(2 + 3 * k), Real::from_bits(word(3 + 3 * k)));
            if !xi.is_finite() || (j < WALL && j <= i) {
                return Err(format!("dem contact history entry {k}: pair ({i}, {j}) with ξ = {xi}"));
            }
            history.insert((i, j), xi);
        }
        self.history = history;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::boundary::Boundaries;
    use multifield_core::grid::Grid;
    use std::f64::consts::PI;

    fn dem(e: Real, tc: Real, mu: Real) -> Dem {
        let mut d: Dem = multifield_core::registry::parse_params(
            &serde_json::json!({ "restitution": e, "collision_time": tc, "friction": mu }),
        )
        .unwrap();
        d.validate().unwrap();
        d
    }

    fn disk(x: Real, y: Real, vx: Real, vy: Real) -> BodyState {
        let (m, r) = (2.0, 0.1);
        BodyState {
            mass: m,
            inertia: 0.5 * m * r * r,
            radius: r,
            position: Vector::new(x, y),
            velocity: Vector::new(vx, vy),
            free: true,
            ..Default::default()
        }
    }

    fn energy(b: &[BodyState]) -> Real {
        b.iter().map(|b| 0.5 * b.mass * b.velocity.norm_squared() + 0.5 * b.inertia * b.angular_velocity.powi(2)).sum()
    }

    /// Symplectic Euler with the contact forces alone until no pair touches after a
    /// contact: the bodies after, the contact's duration (steps × Δt) and the largest ratio
    /// of the kinetic energy (translation and rotation) to its initial value.
    fn collide(m: &mut Dem, bodies: &mut [BodyState], bc: &Boundaries, dt: Real) -> (Real, Real) {
        let grid = Grid::new(10, 10, 0.1, Vector::zeros());
        let e0 = energy(bodies);
        let mut out = vec![(Vector::zeros(), 0.0); bodies.len()];
        let (mut steps, mut touched, mut rose) = (0, false, 1.0 as Real);
        for _ in 0..1_000_000 {
            let ctx =
                ContactContext { grid: &grid, boundaries: bc, gravity: Vector::zeros(), fluid_density: 0.0, bodies };
            m.forces(&ctx, dt, &mut out);
            let touching = !m.history.is_empty();
            if touched && !touching {
                return (steps as Real * dt, rose);
            }
            touched |= touching;
            steps += touching as usize;
            for (b, (f, t)) in bodies.iter_mut().zip(&out) {
                b.velocity += dt / b.mass * f;
                b.angular_velocity += dt / b.inertia * t;
                b.position += dt * b.velocity;
            }
            rose = rose.max(energy(bodies) / e0);
        }
        panic!("no collision");
    }

    fn periodic() -> Boundaries {
        Boundaries {
            left: Boundary::Periodic,
            right: Boundary::Periodic,
            bottom: Boundary::Periodic,
            top: Boundary::Periodic,
        }
    }

    /// Head-on: the separation speed is e times the approach speed and the contact lasts
    /// t_c, to the step Δt = t_c/1000 (error O(Δt/t_c)); between two disks across a periodic
    /// side and against a wall.
    #[test]
    fn a_normal_collision_rebounds_with_the_restitution_and_lasts_the_collision_time() {
        let tc = 1e-3;
        let dt = tc / 1000.0;
        for e in [0.9, 0.5, 0.1] {
            // two disks approaching at 1 across the periodic side x = 0 ≡ 1
            let mut m = dem(e, tc, 0.0);
            let mut b = [disk(0.1005, 0.5, -0.5, 0.0), disk(0.8995, 0.5, 0.5, 0.0)];
            let (duration, rose) = collide(&mut m, &mut b, &periodic(), dt);
            let ratio = (b[0].velocity.x - b[1].velocity.x) / 1.0;
            eprintln!("e = {e}: rebound/approach {ratio:.5}, contact {duration:.4e} s (t_c {tc:e})");
            assert!((ratio / e - 1.0).abs() < 1e-2, "e = {e}: rebound/approach {ratio}");
            assert!((duration - tc).abs() <= 2.0 * dt, "e = {e}: contact {duration} s, t_c {tc}");
            assert!(rose <= 1.0 + 1e-12, "e = {e}: the energy rose by {}", rose - 1.0);
            assert!((b[0].velocity + b[1].velocity).norm() < 1e-12, "momentum");
            // a disk falling on the bottom wall at 1
            let mut m = dem(e, tc, 0.0);
            let mut b = [disk(0.5, 0.1005, 0.0, -1.0)];
            let (duration, rose) = collide(&mut m, &mut b, &Boundaries::default(), dt);
            assert!((b[0].velocity.y / e - 1.0).abs() < 1e-2, "wall, e = {e}: {}", b[0].velocity.y);
            assert!((duration - tc).abs() <= 2.0 * dt, "wall, e = {e}: contact {duration} s");
            assert!(rose <= 1.0 + 1e-12, "wall, e = {e}: the energy rose by {}", rose - 1.0);
        }
    }

    /// Oblique impacts on a wall with friction (Foerster et al., Phys. Fluids 6, 1994;
    /// Walton's model): with ψ = v_t/v_n at the contact point, a disk (I = m R²/2) slides
    /// throughout beyond ψ ≈ 3μ(1 + e)/(1 + β₀), and its centre's tangential speed drops by
    /// μ(1 + e)v_n, its spin by 2μ(1 + e)v_n/R; below, it sticks and the tangential
    /// restitution of the contact point is the spring's, β₀ = −cos(t_c sqrt(k_t/m_t)),
    /// m_t = m/3 (1 with the default k_t/k_n = 1/3 but for the damping's ln²e).
    #[test]
    fn an_oblique_collision_follows_the_sliding_and_sticking_regimes() {
        let (tc, mu) = (1e-3, 0.3);
        let dt = tc / 1000.0;
        for e in [0.9, 0.5] {
            // sliding: ψ = 4 · 3μ(1 + e)/2
            let vn = 1.0;
            let vt = 4.0 * 1.5 * mu * (1.0 + e) * vn;
            let mut m = dem(e, tc, mu);
            let mut b = [disk(0.5, 0.1005, vt, -vn)];
            let (_, rose) = collide(&mut m, &mut b, &Boundaries::default(), dt);
            let dv = b[0].velocity.x - vt;
            let expected = -mu * (1.0 + e) * vn;
            assert!((dv / expected - 1.0).abs() < 1e-2, "sliding, e = {e}: Δv_t {dv}, expected {expected}");
            let w = b[0].angular_velocity;
            eprintln!("sliding, e = {e}: Δv_t {dv:.5} (−μ(1+e)v_n = {expected:.5}), ω {w:.4}");
            let expected = 2.0 * expected / 0.1;
            assert!((w / expected - 1.0).abs() < 1e-2, "sliding, e = {e}: ω {w}, expected {expected}");
            assert!((b[0].velocity.y / e - vn).abs() < 1e-2 * vn);
            assert!(rose <= 1.0 + 1e-12, "the energy rose by {}", rose - 1.0);
        }
        // sticking: ψ = 0.01 · 3μ(1 + e)/2. β₀ is the undamped spring's value: the linear
        // dashpot's force turns attractive (F_n < 0) near the end of a damped contact, where
        // the cap μ max(F_n, 0) releases whatever the spring still holds. With the default
        // k_t/k_n = 1/3 the spring is nearly unloaded then (equal undamped periods): β within
        // 0.3 % of β₀ at e = 0.9, but 0.936 against 0.997 at e = 0.5; with 2/7 it is not, so
        // 2/7 is checked without damping (e = 1).
        for (e, ratio) in [(0.9, 1.0 / 3.0), (1.0, 1.0 / 3.0), (1.0, 2.0 / 7.0)] {
            let vn = 1.0;
            let vt = 0.01 * 1.5 * mu * (1.0 + e) * vn;
            let mut m = dem(e, tc, mu);
            m.tangential_stiffness = ratio;
            let mut b = [disk(0.5, 0.1005, vt, -vn)];
            let (_, rose) = collide(&mut m, &mut b, &Boundaries::default(), dt);
            let after = b[0].velocity.x + 0.1 * b[0].angular_velocity;
            let beta = -after / vt;
            let ln_e = e.ln();
            let beta0 = -(3.0 * ratio * (PI * PI + ln_e * ln_e)).sqrt().cos();
            eprintln!("sticking, e = {e}, k_t/k_n {ratio:.4}: β {beta:.5}, spring β₀ {beta0:.5}");
            assert!((beta - beta0).abs() < 5e-3, "sticking, e = {e}, k_t/k_n {ratio}: β {beta}, spring β₀ {beta0}");
            // no damping (e = 1): the energy comes back, to the step's O(Δt²) error
            let bound = if e < 1.0 { 1e-12 } else { 1e-3 };
            assert!(rose <= 1.0 + bound, "e = {e}: the energy rose by {}", rose - 1.0);
        }
    }

    /// A contact's history survives `history`/`restore_history`: the restored model gives
    /// the same forces, bit for bit; bytes of another shape are refused.
    #[test]
    fn the_history_round_trips_and_bad_bytes_are_refused() {
        let grid = Grid::new(10, 10, 0.1, Vector::zeros());
        let bc = Boundaries::default();
        let bodies = [disk(0.3, 0.095, 1.0, -1.0), disk(0.49, 0.099, -1.0, 0.0)];
        let ctx = ContactContext {
            grid: &grid,
            boundaries: &bc,
            gravity: Vector::zeros(),
            fluid_density: 0.0,
            bodies: &bodies,
        };
        let mut a = dem(0.5, 1e-3, 0.5);
        let mut out = vec![(Vector::zeros(), 0.0); 2];
        a.forces(&ctx, 1e-6, &mut out);
        assert_eq!(a.history.len(), 3, "a pair and a wall contact each, {:?}", a.history);
        assert!(a.history.values().all(|&x| x != 0.0));
        let mut b = dem(0.5, 1e-3, 0.5);
        b.restore_history(&a.history()).unwrap();
        let mut out_b = out.clone();
        a.forces(&ctx, 1e-6, &mut out);
        b.forces(&ctx, 1e-6, &mut out_b);
        assert_eq!(out, out_b);
        assert!(out[0].1 != 0.0, "torque from the tangential spring");
        let mut bytes = a.history();
        bytes.pop();
        assert!(b.restore_history(&bytes).unwrap_err().contains("not a count and (i, j, ξ) triples"));
    }

    #[test]
    fn bad_parameters_are_refused_with_the_valid_range() {
        let build = |p: serde_json::Value| -> Result<Dem, String> {
            let mut d: Dem = multifield_core::registry::parse_params(&p)?;
            d.validate().map(|_| d)
        };
        let err = build(serde_json::json!({ "restitution": 0.0, "collision_time": 1e-3 })).unwrap_err();
        assert!(err.contains("restitution 0: must lie in (0, 1]"), "{err}");
        let err = build(serde_json::json!({ "restitution": 0.5, "collision_time": -1.0 })).unwrap_err();
        assert!(err.contains("collision_time -1: must be positive"), "{err}");
        let err = build(serde_json::json!({ "restitution": 0.5 })).unwrap_err();
        assert!(err.contains("missing parameter `collision_time`"), "{err}");
        let err =
            build(serde_json::json!({ "restitution": 0.5, "collision_time": 1.0, "friction": -0.1 })).unwrap_err();
        assert!(err.contains("friction -0.1"), "{err}");
        let err = build(serde_json::json!({ "restitution": 0.5, "collision_time": 1.0, "steps_per_collision": 0.5 }))
            .unwrap_err();
        assert!(err.contains("at least 1"), "{err}");
    }
}
