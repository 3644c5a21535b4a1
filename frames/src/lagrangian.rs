//! Lagrangian frame: the field lives on material points {m, x, v, V⁰, F, stress}; the grid
//! is scratch space rebuilt every step. FLIP for a fluid, MPM for a solid.
//!
//! Particles to grid (docs/method.md §1, §3 step 1): `m_i = Σ m_p S_ip`, `(mu)_i = Σ m_p S_ip (v_p + C_p (x_i − x_p))`,
//! `θ_c = Σ V_p S_pc / h²`, internal force `f_i = −Σ V_p σ_p ∇S_ip`; provisional `u* = u + Δt f/m`.
//! Grid to particles (§3 step 7): `x_p += Δt Σ u_i S`, and per transfer scheme
//! PIC `v_p = Σ u_i S`; FLIP `v_p = α (v_p + Σ (u_i − u_i^old) S) + (1 − α) Σ u_i S`
//! (Brackbill & Ruppel 1986); APIC `v_p = Σ u_i S`, `C_p` from the grid (Jiang et al. 2015);
//! `F ← (I + Δt ∇v) F`, `V = det F · V⁰`.
//!
//! The transfer scheme and the shape function are values chosen in the case (`transfer`,
//! `shape`), not solver types.

pub mod collocated;
pub mod lanes;
pub mod ranks;
pub mod scatter;
pub mod shape;

use collocated::{Collocated, Simd};
use multifield_core::boundary::{Boundaries, Boundary, Side};
use multifield_core::case::{BodyShape, Motion, Region};
use multifield_core::exact::Sums as ExactSums;
use multifield_core::grid::{FaceVelocity, Grid, Lattice};
use multifield_core::math::{cross, Matrix, Real, Vector};
use multifield_core::part::Part;
use multifield_core::plugin::{
    BodyContact, BodyState, BodyStep, Frame, FrameContext, FrameFigures, InitContext, PointStressContext, StressModel,
};
use multifield_core::quantity::PointSet;
use multifield_core::registry::{params_value, ParamDoc};
use multifield_core::state;
use rayon::prelude::*;
use scatter::{point_weights, PointsIn, Scatter};
use serde::{Deserialize, Serialize};
use shape::{Shape, Weights1};
use std::any::Any;
use std::borrow::Cow;

/// Grid-to-particle transfer scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transfer {
    /// Particle-in-cell: the point takes the grid velocity (dissipative).
    Pic,
    /// FLIP increment blended with PIC by `flip_blend`.
    Flip,
    /// Affine particle-in-cell (conserves angular momentum, little dissipation).
    Apic,
}

/// Where the frame's scratch grid keeps the velocity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GridLayout {
    /// On the faces of the cells (MAC), where the core couples fields through one pressure.
    Staggered,
    /// Both components on the nodes (standard MPM), for a field that is alone in its case:
    /// one scatter and one gather a step, with no multifield phases (`collocated` module).
    Collocated,
}

/// Material points of one field (structure of arrays).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Points {
    /// Positions.
    pub x: Vec<Vector>,
    /// Velocities.
    pub v: Vec<Vector>,
    /// Masses.
    pub m: Vec<Real>,
    /// Initial volumes.
    pub vol0: Vec<Real>,
    /// Deformation gradients.
    pub f: Vec<Matrix>,
    /// Velocity gradients of the last step. On the collocated grid they are written only
    /// when a point-stress model of the field reads them
    /// (`StressKind::Points { velocity_gradient }`); otherwise they keep their last value (zero
    /// from the start).
    pub grad_v: Vec<Matrix>,
    /// Cauchy stress of the last evaluation.
    pub stress: Vec<Matrix>,
    /// APIC affine velocity of the x component.
    pub c_u: Vec<Vector>,
    /// APIC affine velocity of the y component.
    pub c_v: Vec<Vector>,
    /// Body each point belongs to (0 when the field has no bodies).
    pub body: Vec<u32>,
    /// The per-point state of each of the field's stress models, by its index in the
    /// field's `stress` list (`StressModel::point_state`): k values per point, point p's at
    /// `[k p .. k (p + 1)]`; empty for a model without state. Sized (zeros) at the first
    /// stress evaluation.
    pub model_state: Vec<Vec<Real>>,
    /// Each point's id: its index at seeding, the serial order (points are never created or
    /// removed afterwards, and serially never reordered, so id = index). A rank of a
    /// decomposed run keeps its points sorted by id. Not saved: a checkpoint holds every
    /// point in id order.
    #[serde(skip)]
    pub id: Vec<u64>,
    /// The values per point of each stress model's state (`model_state[m]`), once sized.
    #[serde(skip)]
    pub widths: Vec<usize>,
}

impl Points {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    /// Current volume of point `p`.
    pub fn volume(&self, p: usize) -> Real {
        self.vol0[p] * self.f[p].determinant()
    }
    /// Sizes [`Points::model_state`] for `models` (zeros where it is new); an error when a
    /// restored state does not fit them.
    pub fn size_model_state(&mut self, models: &[Box<dyn StressModel>]) -> Result<(), String> {
        let n = self.len();
        if self.model_state.is_empty() && models.iter().any(|m| !m.point_state().is_empty()) {
            self.model_state = vec![Vec::new(); models.len()];
        }
        if self.model_state.is_empty() {
            return Ok(());
        }
        self.widths = models.iter().map(|m| m.point_state().len()).collect();
        if self.model_state.len() != models.len() {
            return Err(format!(
                "the points hold the state of {} stress models, the field has {}",
                self.model_state.len(),
                models.len()
            ));
        }
        for (s, m) in self.model_state.iter_mut().zip(models) {
            let want = n * m.point_state().len();
            if s.is_empty() {
                s.resize(want, 0.0);
            } else if s.len() != want {
                return Err(format!(
                    "stress `{}`: {} values of point state for {n} points of {} values each",
                    m.model(),
                    s.len(),
                    m.point_state().len()
                ));
            }
        }
        Ok(())
    }
    fn push(&mut self, id: u64, x: Vector, v: Vector, m: Real, vol: Real) {
        self.id.push(id);
        self.x.push(x);
        self.v.push(v);
        self.m.push(m);
        self.vol0.push(vol);
        self.f.push(Matrix::identity());
        self.grad_v.push(Matrix::zeros());
        self.stress.push(Matrix::zeros());
        self.c_u.push(Vector::zeros());
        self.c_v.push(Vector::zeros());
        self.body.push(0);
    }
}

/// The Lagrangian frame.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lagrangian {
    /// Points per cell along each axis at seeding (n × n per cell).
    #[serde(default = "default_ppc")]
    pub points_per_cell: usize,
    /// `"linear"` (the seed's) or `"quadratic"` (B-spline).
    #[serde(default = "default_shape")]
    pub shape: Shape,
    /// `"pic"`, `"flip"` or `"apic"`.
    #[serde(default = "default_transfer")]
    pub transfer: Transfer,
    /// α of the FLIP/PIC blend (only for `"flip"`), 0.95–0.99 usual.
    #[serde(default = "default_blend")]
    pub flip_blend: Real,
    /// `"staggered"` (the default, coupled through the core) or `"collocated"` (a field
    /// alone in its case: no other field, pressure solve, exchange or contact).
    #[serde(default = "default_grid")]
    pub grid: GridLayout,
    /// The points.
    #[serde(skip)]
    pub points: Points,
    #[serde(skip)]
    scatter: Option<Scatter>,
    #[serde(skip)]
    vol: Vec<Real>,
    #[serde(skip)]
    has_point_stress: bool,
    /// Every point-stress model depends on F only through J: F is kept as diag(J, 1).
    #[serde(skip)]
    volumetric_only: bool,
    /// The field's bodies (empty when its region has none).
    #[serde(skip)]
    pub bodies: Vec<Body>,
    #[serde(skip)]
    x_old: Vec<Vector>,
    #[serde(skip)]
    collocated: Option<Collocated>,
    /// The most lanes the collocated grid's transfers may use (tests: all give the same bits).
    #[serde(skip, default = "Simd::available")]
    simd: Simd,
    /// The grid of the field's storage: on a rank of a decomposed run, its block's, whose
    /// `part` holds the ranks (the whole domain on one rank).
    #[serde(skip)]
    local: Grid,
    /// On a rank's block: its points and the neighbours' within reach, for the scatter.
    #[serde(skip)]
    cloud: ranks::Cloud,
    /// The face mass below which `to_grid` leaves a face's velocity zero (1e-12 of the
    /// largest point mass of every rank), for the MUSL update of the same step.
    #[serde(skip)]
    tiny: Real,
}

/// A body of a Lagrangian field: its definition and its state.
#[derive(Clone, Debug)]
pub struct Body {
    /// Free, fixed or prescribed.
    pub motion: Motion,
    /// Its reported state.
    pub state: BodyState,
}

/// Per-body sums over the points.
#[derive(Clone, Copy, Default)]
struct Sums {
    m: Real,
    p: Vector,
    vol: Real,
}

fn default_ppc() -> usize {
    2
}
fn default_shape() -> Shape {
    Shape::Linear
}
fn default_transfer() -> Transfer {
    Transfer::Flip
}
fn default_blend() -> Real {
    0.97
}
fn default_grid() -> GridLayout {
    GridLayout::Staggered
}

impl Lagrangian {
    /// Checks the parameters.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(1..=8).contains(&self.points_per_cell) {
            return Err(format!("points_per_cell {}: must lie in 1..=8 (2 or 3 usual)", self.points_per_cell));
        }
        if !(0.0..=1.0).contains(&self.flip_blend) {
            return Err(format!("flip_blend {}: must lie in [0, 1] (0.95–0.99 usual)", self.flip_blend));
        }
        if self.grid == GridLayout::Collocated {
            if self.shape != Shape::Quadratic {
                return Err("grid \"collocated\" needs shape \"quadratic\" (the linear shape's ∇v is unbounded \
                            where a point barely reaches a node); set shape: \"quadratic\" or grid: \"staggered\""
                    .into());
            }
            if self.transfer == Transfer::Flip {
                return Err("grid \"collocated\" transfers by \"apic\" or \"pic\"; set transfer: \"apic\", or \
                            grid: \"staggered\" for FLIP"
                    .into());
            }
        }
        Ok(())
    }

    /// A frame with the given options and no points (for building in code).
    pub fn new(points_per_cell: usize, shape: Shape, transfer: Transfer, flip_blend: Real) -> Self {
        Self {
            points_per_cell,
            shape,
            transfer,
            flip_blend,
            points: Points::default(),
            scatter: None,
            vol: Vec::new(),
            has_point_stress: false,
            volumetric_only: false,
            bodies: Vec::new(),
            x_old: Vec::new(),
            grid: GridLayout::Staggered,
            collocated: None,
            simd: Simd::available(),
            local: Grid::default(),
            cloud: ranks::Cloud::default(),
            tiny: 0.0,
        }
    }

    /// The most lanes the collocated grid's transfers may use: `Simd::Portable` forces the
    /// portable loops, `Simd::Avx` (the default is what the CPU has) four points per
    /// register; both give the same bits. Returns the most lanes that will be used: after a
    /// step that was not finite the portable loops run until one is.
    pub fn set_simd(&mut self, simd: Simd) -> Simd {
        self.simd = simd.min(Simd::available());
        if let Some(c) = self.collocated.as_mut() {
            c.use_simd(self.simd);
        }
        self.simd
    }

    /// The output's view of the points `p` (positions, velocities, volumes, masses,
    /// stresses, bodies and the models' per-point state).
    fn point_set(&self, p: &Points) -> PointSet {
        PointSet {
            position: p.x.clone(),
            velocity: p.v.clone(),
            volume: (0..p.len()).map(|k| p.volume(k)).collect(),
            mass: p.m.clone(),
            stress: p.stress.clone(),
            body: p.body.iter().map(|&b| b as i64 - 1).collect(),
            bodies: self.bodies.iter().map(|b| b.state.name.clone()).collect(),
            model_state: p.model_state.clone(),
        }
    }

    /// The field's points: on a rank's block of a decomposed domain, every rank's in id
    /// order (a collective: every rank calls it).
    fn all_points(&self) -> Cow<'_, Points> {
        if self.local.part.is_whole() {
            Cow::Borrowed(&self.points)
        } else {
            Cow::Owned(ranks::gathered(&self.points, &self.local.part))
        }
    }

    /// On a rank's block of a decomposed domain, keeps the points whose cell the block
    /// owns (once: nothing when already done, or on one rank).
    fn keep_own(&mut self, g: &Grid) {
        let Some((rg, _)) = self.local.part.block() else { return };
        let me = self.local.part.rank();
        let x = &self.points.x;
        let mine = |p: usize| rg.owner(Lattice::Cell, ranks::cell_of(g, x[p])) == Some(me);
        if (0..x.len()).all(mine) {
            return;
        }
        self.points = self.points.select(mine);
    }

    /// Whether the field has point-stress models, and whether all are `volumetric_only`;
    /// sizes the models' point state.
    fn classify_stress(&mut self, ctx: &FrameContext) -> Result<(), String> {
        self.has_point_stress = ctx.stress.iter().any(|s| s.kind().acts_on_points());
        self.volumetric_only = self.has_point_stress
            && ctx.stress.iter().filter(|s| s.kind().acts_on_points()).all(|s| s.kind().volumetric_only());
        self.points.size_model_state(ctx.stress)
    }

    /// The stress of every point from the field's point-stress models (zero without one);
    /// records whether there is one and whether all are `volumetric_only`.
    fn evaluate_stress(&mut self, ctx: &FrameContext) -> Result<(), String> {
        self.classify_stress(ctx)?;
        let pts = &mut self.points;
        if self.has_point_stress {
            pts.stress.par_iter_mut().for_each(|s| *s = Matrix::zeros());
            for (k, model) in ctx.stress.iter().enumerate().filter(|(_, s)| s.kind().acts_on_points()) {
                let state = match pts.model_state.get_mut(k) {
                    Some(s) => &mut s[..],
                    None => &mut [],
                };
                model.point_stress(&mut PointStressContext {
                    dt: ctx.dt,
                    density: ctx.density,
                    deformation_gradient: &pts.f,
                    velocity_gradient: &pts.grad_v,
                    stress: &mut pts.stress,
                    state,
                });
            }
        }
        Ok(())
    }

    /// `K` sums over the points of each body of `term(point)` (index 0: the points of no
    /// body), each added in the points' order. On a rank's block of a decomposed domain a
    /// body whose points are all on one rank takes that rank's sums (its points in id
    /// order, as serially); for a body whose points several ranks hold, every rank's terms
    /// of it are gathered and added in id order: the serial sums' bits, whichever ranks
    /// hold a body's points (every rank calls it).
    fn per_body<const K: usize>(&self, term: impl Fn(usize) -> [Real; K]) -> Vec<[Real; K]> {
        let n = self.bodies.len() + 1;
        let mut sums = vec![[0.0; K]; n];
        let add = |sums: &mut [[Real; K]], b: usize, t: &[Real]| sums[b].iter_mut().zip(t).for_each(|(s, v)| *s += v);
        let p = &self.points;
        for (k, &b) in p.body.iter().enumerate() {
            add(&mut sums, b as usize, &term(k));
        }
        if self.local.part.is_whole() {
            return sums;
        }
        // every rank's count of points and sums, by body
        let mut count = vec![0usize; n];
        p.body.iter().for_each(|&b| count[b as usize] += 1);
        let mut mine = Vec::with_capacity(n * (K + 1));
        for (c, s) in count.iter().zip(&sums) {
            mine.push(*c as Real);
            mine.extend(s);
        }
        let comm = self.local.part.comm();
        let all = comm.gather_all_f64(&mine);
        let held = |b: usize| all.iter().filter(|m| m[b * (K + 1)] > 0.0).count();
        let spanning: Vec<bool> = (0..n).map(|b| held(b) > 1).collect();
        for (b, s) in sums.iter_mut().enumerate() {
            // the one rank's sums (zeros when no rank holds the body's points)
            if let Some(m) = all.iter().find(|m| m[b * (K + 1)] > 0.0).filter(|_| !spanning[b]) {
                s.copy_from_slice(&m[b * (K + 1) + 1..(b + 1) * (K + 1)]);
            }
        }
        if !spanning.contains(&true) {
            return sums;
        }
        // the bodies several ranks hold: (id, body, the K terms) of each of their points
        let mut mine = Vec::new();
        for (k, &b) in p.body.iter().enumerate().filter(|(_, &b)| spanning[b as usize]) {
            mine.extend([Real::from_bits(p.id[k]), Real::from_bits(b as u64)]);
            mine.extend(term(k));
        }
        let all = comm.gather_all_f64(&mine);
        let mut records: Vec<&[Real]> = all.iter().flat_map(|m| m.chunks_exact(K + 2)).collect();
        records.sort_unstable_by_key(|r| r[0].to_bits());
        spanning.iter().enumerate().filter(|(_, &s)| s).for_each(|(b, _)| sums[b] = [0.0; K]);
        for r in records {
            add(&mut sums, r[1].to_bits() as usize, &r[2..]);
        }
        sums
    }

    /// Mass, momentum and volume of each body (index 0 = points of no body).
    fn body_sums(&self) -> Vec<Sums> {
        let p = &self.points;
        let sums = self.per_body(|k| {
            let (m, v) = (p.m[k], p.v[k]);
            [m, m * v.x, m * v.y, p.vol0[k] * p.f[k].determinant()]
        });
        sums.iter().map(|s| Sums { m: s[0], p: Vector::new(s[1], s[2]), vol: s[3] }).collect()
    }

    /// Angular momentum about `centres` and moment of inertia, per body, of points at `x`.
    fn body_angular(&self, x: &[Vector], centres: &[Vector]) -> (Vec<Real>, Vec<Real>) {
        let p = &self.points;
        let sums = self.per_body(|k| {
            let r = x[k] - centres[p.body[k] as usize];
            // a point stands for a square of side a: its own inertia m a²/6
            [p.m[k] * cross(r, p.v[k]), p.m[k] * (r.norm_squared() + p.vol0[k] / 6.0)]
        });
        sums.iter().map(|s| (s[0], s[1])).unzip()
    }

    /// Mass-weighted centroid of each body for points at `x`.
    fn centres(&self, x: &[Vector]) -> Vec<Vector> {
        let m = &self.points.m;
        let sums = self.per_body(|k| [m[k], m[k] * x[k].x, m[k] * x[k].y]);
        sums.iter().map(|s| if s[0] > 0.0 { Vector::new(s[1], s[2]) / s[0] } else { Vector::zeros() }).collect()
    }

    /// Refreshes the bodies' mass, centroid, velocity and angular velocity from the points.
    fn measure_bodies(&mut self) {
        if self.bodies.is_empty() {
            return;
        }
        let sums = self.body_sums();
        let centres = self.centres(&self.points.x);
        let (l, inertia) = self.body_angular(&self.points.x, &centres);
        for (k, body) in self.bodies.iter_mut().enumerate() {
            let s = &sums[k + 1];
            let st = &mut body.state;
            st.mass = s.m;
            st.volume = s.vol;
            st.position = centres[k + 1];
            st.velocity = if s.m > 0.0 { s.p / s.m } else { Vector::zeros() };
            st.inertia = inertia[k + 1];
            st.angular_velocity = if inertia[k + 1] > 0.0 { l[k + 1] / inertia[k + 1] } else { 0.0 };
        }
    }

    /// Rigid projection (docs/method.md §4): each body's points take the rigid motion with the
    /// same linear and angular momentum as the grid gave them (plus the contact impulse),
    /// V = P/M, ω = L/I, and move rigidly. Records the hydrodynamic force and torque
    /// (momentum change from the grid less the weight). A deformable body only receives
    /// the contact impulse on all its points.
    #[allow(clippy::needless_range_loop)] // indexes several point arrays at once
    fn rigid_projection(
        &mut self,
        dt: Real,
        gravity: Vector,
        forces: &[BodyContact],
        rigid: bool,
        apic: bool,
        forced: Option<&[BodyStep]>,
    ) {
        let before: Vec<(Vector, Real)> =
            self.bodies.iter().map(|b| (b.state.velocity, b.state.angular_velocity)).collect();
        let sums = self.body_sums();
        // the velocities are the new grid ones, the positions to use are those at the start
        let x_old = std::mem::take(&mut self.x_old);
        let centres = self.centres(&x_old);
        let (l, inertia) = self.body_angular(&x_old, &centres);
        let mut motion = vec![(Vector::zeros(), 0.0); self.bodies.len() + 1];
        // the position correction of sub-stepped contact, by body (zero without)
        let mut corrections = vec![(Vector::zeros(), 0.0); self.bodies.len() + 1];
        for (k, body) in self.bodies.iter_mut().enumerate() {
            let b = k + 1;
            let s = &sums[b];
            if s.m <= 0.0 {
                continue;
            }
            let contact = forces.get(k).copied().unwrap_or_default();
            if body.motion == Motion::Free {
                corrections[b] = (contact.shift, contact.turn);
            }
            if let Some(step) = forced.and_then(|f| f.get(k)) {
                // a direct forcing decided the motion and measured the force
                body.state.force = step.force;
                body.state.torque = step.torque;
                motion[b] = (step.velocity, step.angular_velocity);
                continue;
            }
            let (fc, tc) = (contact.force, contact.torque);
            let (v0, w0) = before[k];
            body.state.force = (s.p - s.m * v0) / dt - s.m * gravity;
            body.state.torque = (l[b] - inertia[b] * w0) / dt;
            motion[b] = if !rigid {
                (dt * fc / s.m, dt * tc / inertia[b])
            } else {
                match body.motion {
                    Motion::Free => ((s.p + dt * fc) / s.m, (l[b] + dt * tc) / inertia[b]),
                    Motion::Fixed => (Vector::zeros(), 0.0),
                    Motion::Prescribed { velocity, angular_velocity } => {
                        (Vector::new(velocity[0], velocity[1]), angular_velocity)
                    }
                }
            };
        }
        let rigid = rigid || forced.is_some();
        let pts = &mut self.points;
        for k in 0..pts.len() {
            let b = pts.body[k] as usize;
            if b == 0 {
                continue;
            }
            let (v, w) = motion[b];
            let c = centres[b];
            if rigid {
                let r = x_old[k] - c;
                // with sub-stepped contact, moved and turned to where the sub-steps put it
                let (shift, turn) = corrections[b];
                let corrected = shift != Vector::zeros() || turn != 0.0;
                let (sn, cs) = if turn != 0.0 { (w * dt + turn).sin_cos() } else { (w * dt).sin_cos() };
                let r_new = Vector::new(cs * r.x - sn * r.y, sn * r.x + cs * r.y);
                // a body at rest keeps its points' positions to the bit (c + (x − c) need
                // not be x, and c depends on the masses)
                pts.x[k] = if v == Vector::zeros() && w == 0.0 && !corrected {
                    x_old[k]
                } else if corrected {
                    c + dt * v + shift + r_new
                } else {
                    c + dt * v + r_new
                };
                pts.v[k] = v + w * Vector::new(-r_new.y, r_new.x);
                if apic {
                    pts.c_u[k] = Vector::new(0.0, -w);
                    pts.c_v[k] = Vector::new(w, 0.0);
                }
            } else {
                let r = pts.x[k] - c;
                pts.v[k] += v + w * Vector::new(-r.y, r.x);
            }
        }
        self.x_old = x_old;
        self.measure_bodies();
    }

    /// A rigid body's points move with the body and are not wrapped across a periodic side
    /// (its centroid and arms would break): the step that takes one across is an error on
    /// every rank, not a body that silently leaves the domain.
    fn bodies_inside_periodic_sides(&self, g: &Grid, bc: &Boundaries) -> Result<(), String> {
        let (lo, hi) = (g.origin, g.origin + g.size());
        let pts = &self.points;
        // (a rank's boundaries have `Halo` sides at its cuts: the domain's axes)
        let periodic = |a: usize| g.part.block().map_or(bc.periodic(a), |(rg, _)| rg.periodic[a]);
        let mut found = None;
        for axis in (0..2).filter(|&a| periodic(a)) {
            let out =
                (0..pts.len()).find(|&k| pts.body[k] > 0 && !(lo[axis] <= pts.x[k][axis] && pts.x[k][axis] < hi[axis]));
            if let Some(k) = out {
                let name = &self.bodies[pts.body[k] as usize - 1].state.name;
                let (side, at) = if pts.x[k][axis] < lo[axis] { ("low", lo[axis]) } else { ("high", hi[axis]) };
                let a = ["x", "y"][axis];
                found = Some(format!(
                    "rigid body `{name}` reached the periodic {side} {a} side ({a} = {at}): rigid bodies do not \
                     cross periodic sides yet; lengthen the domain along {a}, start the body farther from the \
                     side, or end the run earlier"
                ));
                break;
            }
        }
        if g.part.any(found.is_some()) {
            return Err(found.unwrap_or_else(|| {
                "a rigid body reached a periodic side of the domain (another rank names it): rigid bodies do not \
                 cross periodic sides yet"
                    .into()
            }));
        }
        Ok(())
    }

    /// Σ over the points of `term(p)` (`K` sums in one pass) by the reduction rule of
    /// docs/design/mpi.md §3 with a group of one point: every point's terms added exactly,
    /// so the sums depend on the set of points only (not on their order, the thread count
    /// or the rank that holds them).
    pub(crate) fn point_sums<const K: usize>(
        part: &Part,
        n: usize,
        term: impl Fn(usize) -> [Real; K] + Sync + Send,
    ) -> [Real; K] {
        let sums = (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .fold(ExactSums::boxed, |mut sums, p| {
                sums.add(term(p));
                sums
            })
            .reduce(ExactSums::boxed, ExactSums::merge_boxed);
        part.reduce(*sums)
    }

    /// Stored elastic energy Σ_p V⁰_p ψ(F_p) of the models that define a strain-energy
    /// density ψ (`StressModel::strain_energy_density`); 0 for models that store none.
    pub fn strain_energy(&self, models: &[Box<dyn StressModel>]) -> Real {
        let pts = &self.points;
        models
            .iter()
            .filter(|model| model.strain_energy_density(&Matrix::identity()).is_some())
            .map(|model| {
                Self::point_sums(&self.local.part, pts.f.len(), |p| {
                    [pts.vol0[p] * model.strain_energy_density(&pts.f[p]).unwrap_or(0.0)]
                })[0]
            })
            .sum()
    }

    /// Velocity gradient and deformation gradient of MPM solids by the modified update-stress-last
    /// scheme (MUSL; Sulsky, Zhou & Schreyer, Comput. Phys. Commun. 87, 1995): the points' new
    /// velocities are projected back to the grid, `u_i = Σ m_p S_ip v_p / Σ m_p S_ip`, and
    /// `∇v_p = Σ u_i ∇S_ip`, `F ← (I + Δt ∇v) F` at the positions of the step's start. The plain
    /// grid velocity `(mu + Δt f)/m` is unbounded on a face that a point barely reaches
    /// (m ∝ S, f ∝ ∇S), which blows F up when a point crosses into an empty cell. Not used for a
    /// fluid of `volumetric_only` models on the quadratic B-spline (J from the transfer's ∇v,
    /// see `from_grid`).
    fn update_deformation_musl(&mut self, g: &Grid, bc: &Boundaries, dt: Real, x_start: &[Vector]) {
        let shape = self.shape;
        let volumetric_only = self.volumetric_only;
        // (the points' masses and set are those of this step's `to_grid`)
        let tiny = self.tiny;
        let pts = &mut self.points;
        let scatter = self.scatter.get_or_insert_with(|| Scatter::new(g));
        let view = PointsIn {
            x: x_start,
            v: &pts.v,
            m: &pts.m,
            vol: &self.vol,
            affine: (self.transfer == Transfer::Apic).then_some((&pts.c_u[..], &pts.c_v[..])),
            stress: None,
        };
        scatter_on(scatter, &mut self.cloud, g, bc, shape, &view, &pts.id);
        let mut vel = FaceVelocity::zeros(g);
        // storage node (i, j) is the domain's (i + i0, j + j0)
        let (i0, j0) = (g.start[0], g.start[1]);
        for j in 0..g.ny {
            for i in 0..=g.nx {
                let (ii, jj) = (i as isize + i0, j as isize + j0);
                let m = scatter.at(scatter::MASS_U, ii, jj);
                vel.u[g.xface(i, j)] = if m > tiny { scatter.at(scatter::MOM_U, ii, jj) / m } else { 0.0 };
            }
        }
        for j in 0..=g.ny {
            for i in 0..g.nx {
                let (ii, jj) = (i as isize + i0, j as isize + j0);
                let m = scatter.at(scatter::MASS_V, ii, jj);
                vel.v[g.yface(i, j)] = if m > tiny { scatter.at(scatter::MOM_V, ii, jj) / m } else { 0.0 };
            }
        }
        bc.enforce(g, &mut vel);
        g.exchange_faces(&mut vel);
        pts.f.par_iter_mut().zip(pts.grad_v.par_iter_mut()).zip(x_start.par_iter()).for_each(|((f, gv), x)| {
            let w = point_weights(shape, g, *x);
            let want = Want { delta: false, affine: false };
            let (su, sv) = match shape {
                Shape::Linear => gather_point::<2>(g, bc, &w, &vel, &vel, want),
                Shape::Quadratic => gather_point::<3>(g, bc, &w, &vel, &vel, want),
            };
            let (gu, gvv) = (su.grad, sv.grad);
            let l = Matrix::new(gu.x, gu.y, gvv.x, gvv.y);
            *gv = l;
            *f = (Matrix::identity() + dt * l) * *f;
            if volumetric_only {
                // a fluid: only J = det F matters, and F itself would grow without bound;
                // diag(J, 1) rather than √J I keeps a point whose J went negative finite
                *f = Matrix::new(f.determinant(), 0.0, 0.0, 1.0);
            }
        });
    }
}

/// The largest `value` of the ranks' (`value` on one rank).
fn part_max(part: &Part, value: Real) -> Real {
    let mut v = [value];
    part.max(&mut v);
    v[0]
}

/// The scatter of the points `pts` (ids `id`) on `g`: on a rank's block of a decomposed
/// domain, of its points and the neighbours' within reach, gathered in `cloud` (every rank
/// calls it); the points alone on the whole domain.
fn scatter_on(
    scatter: &mut Scatter,
    cloud: &mut ranks::Cloud,
    g: &Grid,
    bc: &Boundaries,
    shape: Shape,
    pts: &PointsIn,
    id: &[u64],
) {
    if g.part.is_whole() {
        scatter.run(g, bc, shape, pts);
    } else {
        cloud.fill(g, pts, id);
        scatter.run(g, bc, shape, &cloud.view());
    }
}

multifield_core::register!(
    Frame,
    "lagrangian",
    Lagrangian,
    "material points (FLIP fluid / MPM solid); grid rebuilt every step",
    &[
        ParamDoc { name: "points_per_cell", unit: "-", default: "2", doc: "n for n × n points per cell at seeding" },
        ParamDoc { name: "shape", unit: "-", default: "\"linear\"", doc: "\"linear\" or \"quadratic\" (B-spline)" },
        ParamDoc { name: "transfer", unit: "-", default: "\"flip\"", doc: "\"pic\", \"flip\" (blend) or \"apic\"" },
        ParamDoc { name: "flip_blend", unit: "-", default: "0.97", doc: "α of the FLIP/PIC blend" },
        ParamDoc {
            name: "grid",
            unit: "-",
            default: "\"staggered\"",
            doc: "\"staggered\" (faces, coupled) or \"collocated\" (nodes; a field alone in its case)"
        },
    ]
);

/// Refuses open sides where the field's material can reach them. The frame neither creates
/// points where material enters nor removes them where it leaves: at an inflow the points
/// next to the side would be carried away and leave the grid there empty, at an outflow the
/// points that reach the side would be stopped and pile up against it. That holds for a
/// continuum (a FLIP fluid, an MPM solid filling a region), which is refused. A field of
/// bodies is accepted when its bodies cannot reach the side: all `Fixed` (a cylinder in a
/// channel flow of an Eulerian fluid), or kept off every side by the case's contact model
/// (`contact` of [`InitContext`]: its name, and whether it treats every non-periodic side,
/// open ones included, as a wall for bodies; `dem` and `repulsion` with `walls: true`). A
/// moving wall (a `Velocity` side with a tangential component only) is a wall.
fn check_open_sides(bc: &Boundaries, region: &Region, contact: Option<(&str, bool)>) -> Result<(), String> {
    let bodies = match region {
        Region::Bodies(bodies) => Some(bodies),
        _ => None,
    };
    if bodies.is_some_and(|b| b.iter().all(|b| b.motion == Motion::Fixed)) {
        return Ok(());
    }
    if bodies.is_some() && contact.is_some_and(|(_, walls)| walls) {
        return Ok(());
    }
    for side in Side::ALL {
        let what = match bc.side(side) {
            Boundary::Outflow { .. } => "an outflow (Outflow)",
            Boundary::Velocity { velocity, .. } => {
                // the normal component, positive into the domain
                let inward = match side {
                    Side::Left => velocity[0],
                    Side::Right => -velocity[0],
                    Side::Bottom => velocity[1],
                    Side::Top => -velocity[1],
                };
                if inward > 0.0 {
                    "an inflow (Velocity with a normal component)"
                } else if inward < 0.0 {
                    "an outlet (Velocity with an outward normal component)"
                } else {
                    continue;
                }
            }
            Boundary::NoSlip | Boundary::FreeSlip | Boundary::Periodic | Boundary::Halo => continue,
        };
        if bodies.is_none() {
            return Err(format!(
                "side `{}` is {what}: a Lagrangian field cannot create points at an inflow or remove them at an \
                 outflow yet; give this field an Eulerian frame (`frame: (model: \"eulerian\")`), or make the side \
                 a wall (NoSlip, FreeSlip, or Velocity with a tangential component only)",
                side.name()
            ));
        }
        let keep_off = match contact {
            Some((model, _)) => format!(
                "set `walls: true` in the contact model `{model}`'s params (it then treats every side that is not \
                 periodic, open ones included, as a wall for the bodies)"
            ),
            None => "add a contact model that treats every side that is not periodic, open ones included, as a \
                     wall for the bodies (`contact: Some((model: \"repulsion\"))`, or `dem`)"
                .to_string(),
        };
        return Err(format!(
            "side `{}` is {what}, and the bodies of this field that move could reach it: a body cannot leave at an \
             outflow or enter at an inflow; {keep_off}, make the side a wall (NoSlip, FreeSlip, or Velocity with a \
             tangential component only), or make every body of this field `motion: Fixed`",
            side.name()
        ));
    }
    Ok(())
}

/// Where storage node `i` along `axis` lies along the domain's side, from 0 to 1.
#[inline]
fn along(grid: &Grid, axis: usize, i: isize) -> Real {
    ((i + grid.start[axis]) as Real / grid.domain[axis] as Real).clamp(0.0, 1.0)
}

/// Reads a lattice value of the storage of `grid` at storage node (i, j), ghost nodes
/// beyond a side of the domain from the boundary conditions.
#[inline]
fn sample(grid: &Grid, bc: &Boundaries, arr: &[Real], x_faces: bool, i: isize, j: isize) -> Real {
    let (nx, ny) = (grid.nx, grid.ny);
    let (ni, nj) = if x_faces { (nx + 1, ny) } else { (nx, ny + 1) };
    let width = ni;
    let inside = i >= 0 && (i as usize) < ni && j >= 0 && (j as usize) < nj;
    if inside {
        return arr[i as usize + j as usize * width];
    }
    let (ii, mi) = scatter::map_axis(i, nx, x_faces, bc.periodic(0));
    let (jj, mj) = scatter::map_axis(j, ny, !x_faces, bc.periodic(1));
    let val = arr[ii as usize + jj as usize * width];
    // normal component mirrored across its wall: odd; tangential: the wall's ghost rule
    let mut out = val;
    if x_faces {
        if mi {
            out = -out;
        }
        if mj {
            let side = if j < 0 { Side::Bottom } else { Side::Top };
            out = bc.tangential_ghost(side, out, along(grid, 0, i));
        }
    } else {
        if mj {
            out = -out;
        }
        if mi {
            let side = if i < 0 { Side::Left } else { Side::Right };
            out = bc.tangential_ghost(side, out, along(grid, 1, j));
        }
    }
    out
}

/// Sums over a point's stencil on one face lattice.
#[derive(Clone, Copy, Default)]
struct Gathered {
    /// Σ S u.
    pic: Real,
    /// Σ S (u − u_old) (only when `Want::delta`).
    delta: Real,
    /// Σ u ∇S.
    grad: Vector,
    /// Σ S u (x_i − x_p) (only when `Want::affine`).
    affine: Vector,
}

/// The optional sums of a gather.
#[derive(Clone, Copy)]
struct Want {
    /// The FLIP increment (reads the old velocities).
    delta: bool,
    /// The APIC moment.
    affine: bool,
}

/// Gathers the x-face and y-face lattices at a point of weights `w`, shape of `NS` nodes.
#[inline(always)]
fn gather_point<const NS: usize>(
    g: &Grid,
    bc: &Boundaries,
    w: &scatter::PointWeights,
    new: &FaceVelocity,
    old: &FaceVelocity,
    want: Want,
) -> (Gathered, Gathered) {
    (
        gather_lattice::<NS>(g, bc, true, &w.xf, &w.yc, w.xi, &new.u, &old.u, want),
        gather_lattice::<NS>(g, bc, false, &w.xc, &w.yf, w.xi, &new.v, &old.v, want),
    )
}

/// Gathers one face lattice (`x_faces`: nodes at (i, j + ½), else at (i + ½, j)) over the
/// `NS` × `NS` stencil of weights `wx`, `wy` at lattice position `xi`. A stencil inside the
/// lattice is read row by row directly; one that reaches a ghost node goes through `sample`.
#[allow(clippy::too_many_arguments)]
#[allow(clippy::needless_range_loop)] // indexes weights and values by the same node
#[inline(always)]
fn gather_lattice<const NS: usize>(
    g: &Grid,
    bc: &Boundaries,
    x_faces: bool,
    wx: &Weights1,
    wy: &Weights1,
    xi: Vector,
    new: &[Real],
    old: &[Real],
    want: Want,
) -> Gathered {
    let (ni, nj) = if x_faces { (g.nx + 1, g.ny) } else { (g.nx, g.ny + 1) };
    let (ox, oy) = if x_faces { (0.0, 0.5) } else { (0.5, 0.0) };
    // the stencil's first node in the storage (the weights are the domain's)
    let (i0, j0) = (wx.base - g.start[0], wy.base - g.start[1]);
    let inside = i0 >= 0 && j0 >= 0 && i0 as usize + NS <= ni && j0 as usize + NS <= nj;
    let values = |arr: &[Real]| stencil_values::<NS>(g, bc, x_faces, i0, j0, inside, arr);
    let un = values(new);
    let uo = if want.delta { values(old) } else { un };
    let dx: [Real; NS] = std::array::from_fn(|a| (wx.base + a as isize) as Real + ox - xi.x);
    // the tensor-product sums, along x first: S = wx wy, ∇S = (wx' wy, wx wy')
    let mut r = Gathered::default();
    for b in 0..NS {
        let (mut sw, mut sdw, mut sd, mut sdel) = (0.0, 0.0, 0.0, 0.0);
        for a in 0..NS {
            sw += wx.w[a] * un[b][a];
            sdw += wx.dw[a] * un[b][a];
            sd += wx.w[a] * dx[a] * un[b][a];
            sdel += wx.w[a] * (un[b][a] - uo[b][a]);
        }
        let (wyb, dwyb) = (wy.w[b], wy.dw[b]);
        r.pic += wyb * sw;
        r.delta += wyb * sdel;
        r.grad += Vector::new(wyb * sdw, dwyb * sw);
        if want.affine {
            let dy = (wy.base + b as isize) as Real + oy - xi.y;
            r.affine += wyb * Vector::new(sd, sw * dy);
        }
    }
    r.grad /= g.h;
    r.affine *= g.h;
    r
}

/// The `NS` × `NS` values of lattice `arr` from node (i0, j0), rows along y: read directly
/// when `inside` the lattice, else through `sample` (ghost nodes).
#[inline(always)]
fn stencil_values<const NS: usize>(
    g: &Grid,
    bc: &Boundaries,
    x_faces: bool,
    i0: isize,
    j0: isize,
    inside: bool,
    arr: &[Real],
) -> [[Real; NS]; NS] {
    if inside {
        let ni = if x_faces { g.nx + 1 } else { g.nx };
        let mut v = [[0.0; NS]; NS];
        for (b, row) in v.iter_mut().enumerate() {
            let start = i0 as usize + (j0 as usize + b) * ni;
            row.copy_from_slice(&arr[start..start + NS]);
        }
        v
    } else {
        std::array::from_fn(|b| std::array::from_fn(|a| sample(g, bc, arr, x_faces, i0 + a as isize, j0 + b as isize)))
    }
}

impl Frame for Lagrangian {
    fn model(&self) -> &'static str {
        "lagrangian"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn is_lagrangian(&self) -> bool {
        true
    }
    /// On the staggered grid (a field of bodies is refused on ranks at `initialize`).
    fn decomposed(&self) -> bool {
        self.grid == GridLayout::Staggered
    }

    fn initialize(&mut self, ctx: &InitContext) -> Result<(), String> {
        check_open_sides(ctx.boundaries, ctx.region, ctx.contact)?;
        if self.grid == GridLayout::Collocated && matches!(ctx.region, Region::Bodies(_)) {
            return Err("a field of bodies needs grid \"staggered\" (its rigid projection and its coupling \
                        to a fluid live on the faces); remove grid: \"collocated\""
                .into());
        }
        let g = ctx.grid;
        self.local = g.clone();
        // seeded over the whole domain in the serial order (the ids); a rank keeps its own
        let domain = Grid::from_cells(g.domain, g.h, g.origin);
        let n = self.points_per_cell;
        let dv = g.cell_volume() / (n * n) as Real;
        let origin = [g.origin.x, g.origin.y];
        if let Region::Bodies(specs) = ctx.region {
            // each body on its own lattice, symmetric about the body's centre, so that the
            // points' centroid is the body's centre and small offsets between bodies survive
            let a = g.h / n as Real;
            for (k, spec) in specs.iter().enumerate() {
                // each body's points carry its own density (the field's by default)
                let rho = spec.density_or(ctx.density);
                let (lo, hi) = spec.shape.bounds();
                let c = Vector::new(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
                let kx = ((hi[0] - lo[0]) / (2.0 * a)).ceil() as i64 + 1;
                let ky = ((hi[1] - lo[1]) / (2.0 * a)).ceil() as i64 + 1;
                for j in -ky..ky {
                    for i in -kx..kx {
                        let x = c.x + (i as Real + 0.5) * a;
                        let y = c.y + (j as Real + 0.5) * a;
                        if spec.shape.contains(x, y) && g.contains(Vector::new(x, y)) {
                            let v = spec.velocity_at(x, y);
                            let id = self.points.len() as u64;
                            self.points.push(id, Vector::new(x, y), Vector::new(v[0], v[1]), rho * dv, dv);
                            *self.points.body.last_mut().expect("just pushed") = k as u32 + 1;
                        }
                    }
                }
            }
        } else {
            for j in 0..domain.ny {
                for i in 0..domain.nx {
                    for b in 0..n {
                        for a in 0..n {
                            let x = g.origin.x + (i as Real + (a as Real + 0.5) / n as Real) * g.h;
                            let y = g.origin.y + (j as Real + (b as Real + 0.5) / n as Real) * g.h;
                            if ctx.region.contains(x, y) {
                                let v = ctx.velocity.at([x, y], origin);
                                let (id, m) = (self.points.len() as u64, ctx.density * dv);
                                self.points.push(id, Vector::new(x, y), Vector::new(v[0], v[1]), m, dv);
                            }
                        }
                    }
                }
            }
        }
        if self.points.is_empty() {
            return Err("the region holds no material point: enlarge it or refine the grid".into());
        }
        if let Region::Bodies(specs) = ctx.region {
            let mut held = vec![false; specs.len() + 1];
            for &b in &self.points.body {
                held[b as usize] = true;
            }
            for (k, spec) in specs.iter().enumerate() {
                if !held[k + 1] {
                    return Err(format!(
                        "body `{}` holds no material point: it is smaller than a cell; refine the grid",
                        spec.name
                    ));
                }
            }
            // (each body's points counted before a rank keeps its own)
            self.keep_own(g);
            self.bodies = specs
                .iter()
                .map(|spec| Body {
                    motion: spec.motion,
                    state: BodyState {
                        name: spec.name.clone(),
                        radius: match spec.shape {
                            BodyShape::Disk { radius, .. } => radius,
                            BodyShape::Rectangle { min, max } => {
                                ((max[0] - min[0]) * (max[1] - min[1]) / std::f64::consts::PI).sqrt()
                            }
                            // the fluid's side
                            BodyShape::Annulus { inner_radius, .. } => inner_radius,
                        },
                        free: spec.motion == Motion::Free,
                        ..BodyState::default()
                    },
                })
                .collect();
            self.measure_bodies();
        }
        self.keep_own(g);
        if self.transfer == Transfer::Apic {
            // initial affine velocity from the initial field's gradient (central differences)
            let d = 1e-6 * g.h;
            for p in 0..self.points.len() {
                let x = self.points.x[p];
                let at = |dx: Real, dy: Real| ctx.velocity.at([x.x + dx, x.y + dy], origin);
                let (xp, xm, yp, ym) = (at(d, 0.0), at(-d, 0.0), at(0.0, d), at(0.0, -d));
                self.points.c_u[p] = Vector::new(xp[0] - xm[0], yp[0] - ym[0]) / (2.0 * d);
                self.points.c_v[p] = Vector::new(xp[1] - xm[1], yp[1] - ym[1]) / (2.0 * d);
            }
        }
        Ok(())
    }

    fn steps_alone(&self) -> bool {
        self.grid == GridLayout::Collocated
    }

    fn step_alone(&mut self, ctx: &mut FrameContext) -> Result<FrameFigures, String> {
        self.classify_stress(ctx)?;
        let simd = self.simd;
        let grid = self.collocated.get_or_insert_with(|| {
            let mut c = Collocated::new(ctx.grid);
            c.use_simd(simd);
            c
        });
        // a point stress that is not `volumetric_only` keeps the full F (F ← (I + Δt ∇v) F)
        Ok(grid.step(
            ctx.grid,
            ctx.boundaries,
            &mut self.points,
            ctx.stress,
            ctx.density,
            self.transfer,
            self.volumetric_only,
            ctx.dt,
            ctx.gravity,
        ))
    }

    /// The staggered scatter of the points as they are now: θ, face masses, and the face
    /// velocities mu/m (without the internal force). It also re-evaluates the points'
    /// stress (with Δt = 0) from their F; every step evaluates it again before using it.
    fn refresh_grid_state(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        self.to_grid(ctx)?;
        let s = &mut *ctx.state;
        s.velocity.clone_from(&s.velocity_old);
        Ok(())
    }

    fn to_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        let g = ctx.grid;
        self.evaluate_stress(ctx)?;
        let pts = &mut self.points;
        let n = pts.len();
        self.vol.resize(n, 0.0);
        self.vol.par_iter_mut().enumerate().for_each(|(p, v)| *v = pts.vol0[p] * pts.f[p].determinant());
        let scatter = self.scatter.get_or_insert_with(|| Scatter::new(g));
        let view = PointsIn {
            x: &pts.x,
            v: &pts.v,
            m: &pts.m,
            vol: &self.vol,
            affine: (self.transfer == Transfer::Apic).then_some((&pts.c_u[..], &pts.c_v[..])),
            stress: self.has_point_stress.then_some(&pts.stress[..]),
        };
        scatter_on(scatter, &mut self.cloud, g, ctx.boundaries, self.shape, &view, &pts.id);
        let s = &mut *ctx.state;
        let area = g.cell_volume();
        let tiny = 1e-12 * part_max(&self.local.part, pts.m.iter().cloned().fold(0.0, Real::max));
        self.tiny = tiny;
        // the storage's rows and columns in the domain's numbering
        let (i0, j0) = (g.start[0], g.start[1]);
        for j in 0..g.ny {
            let theta = &mut s.theta[g.cell(0, j)..g.cell(0, j) + g.nx];
            for (t, vol) in theta.iter_mut().zip(scatter.row(scatter::VOLUME, i0, j0 + j as isize, g.nx)) {
                *t = vol / area;
            }
        }
        let dt = ctx.dt;
        // per lattice row: mass, old velocity mu/m and provisional velocity (mu + Δt f)/m
        let faces = |mass: &mut [Real], old: &mut [Real], new: &mut [Real], m: &[Real], mu: &[Real], f: &[Real]| {
            for k in 0..mass.len() {
                mass[k] = m[k];
                let (u, a) = if m[k] > tiny { (mu[k] / m[k], f[k] / m[k]) } else { (0.0, 0.0) };
                old[k] = u;
                new[k] = u + dt * a;
            }
        };
        let nu = g.nx + 1;
        for j in 0..g.ny {
            let r = g.xface(0, j)..g.xface(0, j) + nu;
            faces(
                &mut s.mass_face.u[r.clone()],
                &mut s.velocity_old.u[r.clone()],
                &mut s.velocity.u[r],
                scatter.row(scatter::MASS_U, i0, j0 + j as isize, nu),
                scatter.row(scatter::MOM_U, i0, j0 + j as isize, nu),
                scatter.row(scatter::FORCE_U, i0, j0 + j as isize, nu),
            );
        }
        for j in 0..=g.ny {
            let r = g.yface(0, j)..g.yface(0, j) + g.nx;
            faces(
                &mut s.mass_face.v[r.clone()],
                &mut s.velocity_old.v[r.clone()],
                &mut s.velocity.v[r],
                scatter.row(scatter::MASS_V, i0, j0 + j as isize, g.nx),
                scatter.row(scatter::MOM_V, i0, j0 + j as isize, g.nx),
                scatter.row(scatter::FORCE_V, i0, j0 + j as isize, g.nx),
            );
        }
        ctx.boundaries.enforce(g, &mut s.velocity_old);
        ctx.boundaries.enforce(g, &mut s.velocity);
        // the halo as the owners' (the scatter leaves it incomplete)
        if !g.part.is_whole() {
            g.exchange(&mut [
                (Lattice::Cell, &mut s.theta),
                (Lattice::XFace, &mut s.mass_face.u),
                (Lattice::YFace, &mut s.mass_face.v),
                (Lattice::XFace, &mut s.velocity_old.u),
                (Lattice::YFace, &mut s.velocity_old.v),
                (Lattice::XFace, &mut s.velocity.u),
                (Lattice::YFace, &mut s.velocity.v),
            ]);
        }
        Ok(())
    }

    fn from_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        if let Some(steps) = ctx.forced_bodies {
            // bodies moved by a direct forcing: not on the grid, every point is a body's
            self.x_old.clone_from(&self.points.x);
            let apic = self.transfer == Transfer::Apic;
            self.rigid_projection(ctx.dt, ctx.gravity, ctx.body_forces, true, apic, Some(steps));
            return self.bodies_inside_periodic_sides(ctx.grid, ctx.boundaries);
        }
        let g = ctx.grid;
        let bc = ctx.boundaries;
        let s = &*ctx.state;
        let (shape, transfer, alpha, dt, h) = (self.shape, self.transfer, self.flip_blend, ctx.dt, g.h);
        let dinv = shape.apic_d_inverse(h);
        // Solids: ∇v and F from the re-projected velocities (MUSL, below). A fluid whose stress
        // depends on F only through J, on the quadratic B-spline: J from ∇v of this gather, the
        // gradient of the new grid velocity (one scatter and one gather per step, as mpm88).
        // MUSL guards against u = (mu + Δt f)/m on a face a point barely reaches, m ∝ S, f ∝ ∇S;
        // that face enters the point's own ∇v weighted by ∇S, so as |∇S|²/S = (w_x'²/w_x w_y +
        // w_x w_y'²/w_y)/h², which is at most 3/h² for the B-spline (w'²/w ≤ 2, w ≤ ¾) but
        // grows as 1/(h² w) for the tent: a linear-shape fluid keeps MUSL. (mpm88's C, the APIC matrix, in place of
        // this ∇v, which is the gradient the internal force −V σ ∇S pairs with, made
        // examples/mpm88.ron go unstable near step 1,400.)
        let grid_j = self.has_point_stress && self.volumetric_only && shape == Shape::Quadratic;
        let musl = self.has_point_stress && !grid_j;
        let rigid = ctx.stress.iter().any(|m| m.kind().is_rigid()) && !self.bodies.is_empty();
        if !self.bodies.is_empty() {
            self.x_old.clone_from(&self.points.x);
        }
        let x_start = musl.then(|| self.points.x.clone());
        let want = Want { delta: transfer == Transfer::Flip, affine: transfer == Transfer::Apic && dinv.is_some() };
        let pts = &mut self.points;
        let lo = g.origin;
        let hi = g.origin + g.size();
        let eps = 1e-9 * h;
        pts.x
            .par_iter_mut()
            .zip(pts.v.par_iter_mut())
            .zip(pts.f.par_iter_mut().zip(pts.grad_v.par_iter_mut()))
            .zip(pts.c_u.par_iter_mut().zip(pts.c_v.par_iter_mut()))
            .for_each(|(((x, v), (f, gv)), (cu, cv))| {
                let w = point_weights(shape, g, *x);
                let (su, sv) = match shape {
                    Shape::Linear => gather_point::<2>(g, bc, &w, &s.velocity, &s.velocity_old, want),
                    Shape::Quadratic => gather_point::<3>(g, bc, &w, &s.velocity, &s.velocity_old, want),
                };
                let upic = Vector::new(su.pic, sv.pic);
                let du = Vector::new(su.delta, sv.delta);
                let (gu, gvv, au, av) = (su.grad, sv.grad, su.affine, sv.affine);
                *v = match transfer {
                    Transfer::Pic | Transfer::Apic => upic,
                    Transfer::Flip => alpha * (*v + du) + (1.0 - alpha) * upic,
                };
                if transfer == Transfer::Apic {
                    match dinv {
                        Some(d) => {
                            *cu = au * d;
                            *cv = av * d;
                        }
                        None => {
                            *cu = gu;
                            *cv = gvv;
                        }
                    }
                }
                if !musl {
                    *gv = Matrix::new(gu.x, gu.y, gvv.x, gvv.y);
                }
                if grid_j {
                    // F = diag(J, 1): J ← det((I + Δt ∇v) F) = J det(I + Δt ∇v), the volume
                    // change of the step's own kinematic update (the same as tracking the full
                    // F and taking its determinant); mpm88's J (1 + Δt tr C) drops the Δt² det ∇v
                    let l = Matrix::identity() + dt * *gv;
                    *f = Matrix::new(f.determinant() * l.determinant(), 0.0, 0.0, 1.0);
                }
                *x += dt * upic;
                // keep points in the domain: wrap periodic sides, stop at walls
                for (axis, periodic) in [(0, bc.periodic(0)), (1, bc.periodic(1))] {
                    let len = hi[axis] - lo[axis];
                    if periodic {
                        if x[axis] < lo[axis] || x[axis] >= hi[axis] {
                            x[axis] = lo[axis] + (x[axis] - lo[axis]).rem_euclid(len);
                        }
                    } else if x[axis] < lo[axis] + eps {
                        x[axis] = lo[axis] + eps;
                        v[axis] = v[axis].max(0.0);
                    } else if x[axis] > hi[axis] - eps {
                        x[axis] = hi[axis] - eps;
                        v[axis] = v[axis].min(0.0);
                    }
                }
            });
        if let Some(x_start) = x_start {
            self.update_deformation_musl(g, bc, dt, &x_start);
        }
        if !self.bodies.is_empty() {
            let apic = self.transfer == Transfer::Apic;
            self.rigid_projection(dt, ctx.gravity, ctx.body_forces, rigid, apic, None);
            if rigid {
                self.bodies_inside_periodic_sides(g, bc)?;
            }
        }
        if !g.part.is_whole() {
            ranks::migrate(&mut self.points, g)?;
        }
        Ok(())
    }

    fn body_states(&self) -> Vec<&BodyState> {
        self.bodies.iter().map(|b| &b.state).collect()
    }

    /// On a rank's block of a decomposed domain, every rank's points in id order (a
    /// collective: every rank calls it).
    fn points(&self) -> Option<PointSet> {
        Some(self.point_set(&self.all_points()))
    }

    /// This rank's points (they migrate: each rank writes those whose cell it owns).
    fn local_points(&self, _rank: usize) -> Option<PointSet> {
        Some(self.point_set(&self.points))
    }

    fn max_speed(&self) -> Real {
        part_max(&self.local.part, self.points.v.par_iter().map(|v| v.norm()).reduce(|| 0.0, Real::max))
    }
    fn strain_energy(&self, stress: &[Box<dyn StressModel>]) -> Real {
        Lagrangian::strain_energy(self, stress)
    }
    fn kinetic_energy(&self) -> Real {
        let (m, v) = (&self.points.m, &self.points.v);
        Lagrangian::point_sums(&self.local.part, m.len(), |p| [0.5 * m[p] * v[p].norm_squared()])[0]
    }
    fn momentum(&self) -> Vector {
        let (m, v) = (&self.points.m, &self.points.v);
        Vector::from(Lagrangian::point_sums(&self.local.part, m.len(), |p| (m[p] * v[p]).into()))
    }
    fn mass(&self) -> Real {
        let m = &self.points.m;
        Lagrangian::point_sums(&self.local.part, m.len(), |p| [m[p]])[0]
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }

    /// Every point array (positions, velocities, masses, initial volumes, F, ∇v, stress,
    /// the APIC matrices, body indices, the stress models' point state) and each body's state (its velocities before the
    /// next rigid projection give the hydrodynamic force). The scatter buffers, current
    /// volumes and start positions are scratch, rebuilt every step.
    fn save_state(&self) -> Result<Vec<u8>, String> {
        // on a rank's block, every rank's points in id order: the serial bytes
        state::encode(&LagrangianState {
            points: self.all_points(),
            bodies: self.bodies.iter().map(|b| Cow::Borrowed(&b.state)).collect(),
        })
    }

    /// The points this rank holds, with their ids and the models' per-point widths.
    fn save_rank_state(&self) -> Result<Vec<u8>, String> {
        state::encode(&LagrangianRankState {
            state: LagrangianState {
                points: Cow::Borrowed(&self.points),
                bodies: self.bodies.iter().map(|b| Cow::Borrowed(&b.state)).collect(),
            },
            id: Cow::Borrowed(&self.points.id),
            widths: Cow::Borrowed(&self.points.widths),
        })
    }

    fn load_rank_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let saved: LagrangianRankState = state::decode(bytes, "lagrangian state of a rank")?;
        let n = saved.state.points.len();
        if saved.id.len() != n || saved.id.windows(2).any(|w| w[0] >= w[1]) {
            return Err(format!("{} point ids for {n} points, or not increasing", saved.id.len()));
        }
        if saved.widths.len() != saved.state.points.model_state.len() {
            return Err("the points' model-state widths do not match their arrays".into());
        }
        let (id, widths) = (saved.id.into_owned(), saved.widths.into_owned());
        self.load(saved.state, Some((id, widths)))
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let saved: LagrangianState = state::decode(bytes, "lagrangian state")?;
        self.load(saved, None)
    }
}

impl Lagrangian {
    /// [`Frame::load_state`] of `saved`, every point of the domain (`own` None: a rank
    /// keeps those in its block), or a rank's own points with their ids and widths.
    fn load(&mut self, saved: LagrangianState, own: Option<(Vec<u64>, Vec<usize>)>) -> Result<(), String> {
        let p = saved.points.into_owned();
        let n = p.len();
        let lengths = [p.v.len(), p.m.len(), p.vol0.len(), p.f.len(), p.grad_v.len()];
        let more = [p.stress.len(), p.c_u.len(), p.c_v.len(), p.body.len()];
        // the models' point state is checked against the models at the first step
        if lengths.iter().chain(&more).any(|&l| l != n) {
            return Err(format!("the point arrays have different lengths ({n} positions)"));
        }
        // positions, velocities, masses and stresses are checked by the core with the
        // grid (`Frame::points`), the models' point state with the models
        state::finite(&p.vol0[..], "initial volume of point")?;
        state::finite(&p.f[..], "deformation gradient of point")?;
        state::finite(&p.grad_v[..], "velocity gradient of point")?;
        state::finite(&p.c_u[..], "APIC matrix (x) of point")?;
        state::finite(&p.c_v[..], "APIC matrix (y) of point")?;
        if let Some(k) = p.vol0.iter().position(|&v| v <= 0.0) {
            return Err(format!("initial volume of point {k} is {}: not positive", p.vol0[k]));
        }
        let nb = saved.bodies.len();
        if nb != self.bodies.len() {
            return Err(format!("{nb} bodies in the checkpoint, {} in the case", self.bodies.len()));
        }
        if let Some(&b) = p.body.iter().find(|&&b| b as usize > nb) {
            return Err(format!("a point of body {b} in a field of {nb} bodies"));
        }
        if let Some((s, b)) = saved.bodies.iter().zip(&self.bodies).find(|(s, b)| s.name != b.state.name) {
            return Err(format!("body `{}` in the checkpoint where the case has `{}`", s.name, b.state.name));
        }
        for (b, s) in self.bodies.iter_mut().zip(saved.bodies) {
            b.state = s.into_owned();
        }
        let mut p = p;
        if let Some((id, widths)) = own {
            (p.id, p.widths) = (id, widths);
            self.points = p;
            self.vol.clear();
            self.x_old.clear();
            return Ok(());
        }
        p.id = (0..n as u64).collect();
        self.points = match self.local.part.block() {
            // a rank keeps the points in its block
            Some((rg, _)) => {
                if let Some(s) = p.model_state.iter().find(|s| s.len() % n.max(1) != 0) {
                    return Err(format!("{} values of a stress model's point state for {n} points", s.len()));
                }
                p.widths = p.model_state.iter().map(|s| s.len() / n.max(1)).collect();
                let (g, me) = (&self.local, self.local.part.rank());
                p.select(|k| rg.owner(Lattice::Cell, ranks::cell_of(g, p.x[k])) == Some(me))
            }
            None => p,
        };
        self.vol.clear();
        self.x_old.clear();
        Ok(())
    }
}

/// What a Lagrangian frame carries from step to step ([`Frame::save_state`]): every
/// point array and each body's state; borrowed when saved, owned when loaded.
#[derive(Serialize, Deserialize)]
struct LagrangianState<'a> {
    points: Cow<'a, Points>,
    bodies: Vec<Cow<'a, BodyState>>,
}

/// A rank's own Lagrangian state ([`Frame::save_rank_state`]): its points (with the ids and
/// the models' per-point widths, which the serial state leaves out) and the bodies.
#[derive(Serialize, Deserialize)]
struct LagrangianRankState<'a> {
    state: LagrangianState<'a>,
    id: Cow<'a, [u64]>,
    widths: Cow<'a, [usize]>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use multifield_core::boundary::Profile;
    use multifield_core::case::{BodySpec, InitialVelocity};

    /// Initializes a 4 × 4 Lagrangian field of `region` within `bc`.
    fn init(bc: Boundaries, region: Region) -> Result<Lagrangian, String> {
        init_with(bc, region, None)
    }

    /// [`init`] in a case whose contact model is `contact` (name, keeps bodies off the sides).
    fn init_with(bc: Boundaries, region: Region, contact: Option<(&str, bool)>) -> Result<Lagrangian, String> {
        let grid = Grid::new(4, 4, 0.25, Vector::zeros());
        let mut frame = Lagrangian::new(2, Shape::Linear, Transfer::Flip, 0.97);
        let velocity = InitialVelocity::default();
        let ctx = InitContext {
            grid: &grid,
            boundaries: &bc,
            name: "test",
            density: 1.0,
            region: &region,
            velocity: &velocity,
            theta: None,
            contact,
        };
        frame.initialize(&ctx).map(|_| frame)
    }

    fn velocity(u: Real, v: Real, profile: Profile) -> Boundary {
        Boundary::Velocity { velocity: [u, v], profile }
    }

    fn disk(motion: Motion) -> Region {
        Region::Bodies(vec![BodySpec {
            name: "disk".into(),
            shape: BodyShape::Disk { center: [0.5, 0.5], radius: 0.2 },
            motion,
            velocity: [0.0, 0.0],
            angular_velocity: 0.0,
            density: None,
        }])
    }

    #[test]
    fn open_sides_are_refused_with_the_fix() {
        let inflow = Boundaries { left: velocity(1.0, 0.0, Profile::Parabolic), ..Boundaries::default() };
        let e = init(inflow, Region::All).err().expect("an inflow is refused");
        assert_eq!(
            e,
            "side `left` is an inflow (Velocity with a normal component): a Lagrangian field cannot create \
             points at an inflow or remove them at an outflow yet; give this field an Eulerian frame \
             (`frame: (model: \"eulerian\")`), or make the side a wall (NoSlip, FreeSlip, or Velocity with a \
             tangential component only)"
        );
        // an inflow through the top points down
        let top = Boundaries { top: velocity(0.3, -1.0, Profile::Uniform), ..Boundaries::default() };
        let e = init(top, Region::All).err().expect("an inflow is refused");
        assert!(e.starts_with("side `top` is an inflow (Velocity with a normal component): "), "{e}");
        let suction = Boundaries { bottom: velocity(0.0, -1.0, Profile::Uniform), ..Boundaries::default() };
        let e = init(suction, Region::All).err().expect("an outlet is refused");
        assert!(e.starts_with("side `bottom` is an outlet (Velocity with an outward normal component): "), "{e}");
        let outflow = Boundaries { right: Boundary::Outflow { pressure: 1.0 }, ..Boundaries::default() };
        let e = init(outflow, Region::All).err().expect("an outflow is refused");
        assert!(e.starts_with("side `right` is an outflow (Outflow): a Lagrangian field cannot create points"), "{e}");
        assert!(e.contains("give this field an Eulerian frame"), "{e}");
        // bodies that can move would stop against an open side: the fix is a contact model
        // that keeps them off it, a wall or fixed bodies
        let e = init(outflow, disk(Motion::Free)).err().expect("a free body is refused");
        assert_eq!(
            e,
            "side `right` is an outflow (Outflow), and the bodies of this field that move could reach it: a body \
             cannot leave at an outflow or enter at an inflow; add a contact model that treats every side that \
             is not periodic, open ones included, as a wall for the bodies (`contact: Some((model: \"repulsion\"))`, \
             or `dem`), make the side a wall (NoSlip, FreeSlip, or Velocity with a tangential component only), or \
             make every body of this field `motion: Fixed`"
        );
        // a contact model whose walls are off
        let e = init_with(inflow, disk(Motion::Free), Some(("dem", false))).err().expect("no walls: refused");
        assert!(
            e.starts_with(
                "side `left` is an inflow (Velocity with a normal component), and the bodies of this field that \
                 move could reach it: a body cannot leave at an outflow or enter at an inflow; set `walls: true` in \
                 the contact model `dem`'s params"
            ),
            "{e}"
        );
        // a continuum stays refused whatever the contact model
        let e = init_with(outflow, Region::All, Some(("dem", true))).err().expect("a continuum is refused");
        assert!(e.contains("give this field an Eulerian frame"), "{e}");
    }

    #[test]
    fn bodies_kept_off_the_sides_by_contact_may_face_open_sides() {
        let bed = Boundaries {
            bottom: velocity(0.0, 1.0, Profile::Uniform),
            top: Boundary::Outflow { pressure: 0.0 },
            ..Boundaries::default()
        };
        for model in ["dem", "repulsion"] {
            let frame = init_with(bed, disk(Motion::Free), Some((model, true))).expect("bodies kept off");
            assert!(!frame.points.is_empty());
        }
    }

    #[test]
    fn walls_moving_walls_and_fixed_bodies_are_accepted() {
        let lid = Boundaries { top: velocity(1.0, 0.0, Profile::Uniform), ..Boundaries::default() };
        init(lid, Region::All).expect("a moving lid is a wall");
        let sides = Boundaries {
            left: velocity(0.0, 2.0, Profile::Parabolic),
            right: velocity(0.0, -1.0, Profile::Uniform),
            bottom: Boundary::FreeSlip,
            top: Boundary::NoSlip,
        };
        init(sides, Region::All).expect("walls moving along themselves are walls");
        let channel = Boundaries {
            left: velocity(1.0, 0.0, Profile::Parabolic),
            right: Boundary::Outflow { pressure: 0.0 },
            ..Boundaries::default()
        };
        let frame = init(channel, disk(Motion::Fixed)).expect("a fixed body in a channel flow");
        assert!(!frame.points.is_empty());
    }
}
