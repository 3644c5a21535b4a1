//! Eulerian frame: the field's state (θ at cells, u on x-faces, v on y-faces) lives on the
//! MAC grid and is advected there.
//!
//! **Momentum.** Flux form on the staggered control volumes,
//!
//! ```text
//!   ∂u/∂t + ∂(uu)/∂x + ∂(vu)/∂y = …,     ∂v/∂t + ∂(uv)/∂x + ∂(vv)/∂y = …
//! ```
//!
//! The x-face control volume of `u(i, j)` reaches from the centre of cell `(i−1, j)` to the
//! centre of cell `(i, j)`: its x fluxes sit at cell centres (advecting velocity the mean of
//! the two faces), its y fluxes at cell corners (advecting velocity the mean of the two
//! neighbouring y-faces). The transported component is reconstructed at the flux point by
//! a limited (MUSCL) upwind slope, `q_f = q_i + ½ φ(q_i − q_{i−1}, q_{i+1} − q_i)`, with the
//! limiter chosen in the case (`mc`, `minmod`, `van_leer`, `none` for Fromm's central
//! slope, or `third_order` for van Leer's unlimited κ = 1/3 slope). Ghost values come
//! from the boundary conditions (tangential mirror `2u_wall − u`, odd reflection of the
//! normal component about the wall value, periodic wrap).
//!
//! **Time** (second order, after Bell, Colella & Glaz, J. Comput. Phys. 85, 1989): a
//! midpoint predictor with the pressure acceleration `a_p = −w∇p` of the last corrector,
//! P = a_p + g, and the viscosity ν∇²u of a Newtonian stress by Crank–Nicolson
//! (`diffusion: "crank_nicolson"`, the default; L the Laplacian of `eulerian/viscous.rs`):
//!
//! ```text
//!   (I − Δt/2 νL) u½ = uⁿ + Δt/2 (−A(uⁿ) + P)                        (backward Euler)
//!   (I − Δt/2 νL) x  = uⁿ + Δt (−A(u½) + P) + Δt/2 νL uⁿ,   u* = x − Δt P
//! ```
//!
//! after which the core adds Δt g, exchanges and projects (uⁿ⁺¹ = u* + Δt a_pⁿ⁺¹). The
//! lagged P sits inside the solves, so a steady state (uⁿ⁺¹ = uⁿ, a_pⁿ⁺¹ = a_pⁿ) has
//! u½ = x = uⁿ and satisfies the steady discrete equations −A(u) + νLu + P = 0 whatever
//! Δt: a result does not depend on the steps that reached it. With P outside the solve,
//! νL would act on the pressure increment and leave Δt/2 νL P in the steady state. There is
//! no viscous stability limit; `max_diffusion_number` bounds νΔt/h² for the accuracy of the
//! transient (Crank–Nicolson damps the grid-scale viscous modes less as it grows).
//!
//! With `diffusion: "explicit"` (or a stress that is not Newtonian) the stresses V act
//! explicitly, split: on uⁿ in the midpoint, u½ = uⁿ + Δt/2 (V(uⁿ) − A(uⁿ) + P), then
//! u* = uⁿ − Δt A(u½) and V once more on u*. Cheaper by the solves, but bound by
//! Δt ≤ h²/(4ν), and its steady state holds a Δt ν∇²A(u) (on the 16² cavity its steady
//! profiles at CFL 0.1 and 0.4 differ by 1e-2, `tests/verification/eulerian.rs`). Explicit and
//! unsplit (V at u½) would not do either: the midpoint's real stability interval
//! [−2, 0] must then hold the upwind advection's and the viscosity's eigenvalues together,
//! 4C + 8νΔt/h² ≤ 2 in 2D at Courant number C per axis.
//!
//! Without `a_p` the midpoint state misses the pressure and the step is only first order
//! in time (for Taylor–Green the advection term is a pure gradient balanced by the
//! pressure: measured order 0.96 without it, 2.01 with it). The explicit stresses in u½
//! act on uⁿ, before P is added: a wall stencil acting on the Δt g increment would stir a
//! fluid at rest. The first step has no lagged pressure, so it leaves out P altogether
//! (gravity is mostly balanced by the pressure); that costs O(Δt²) once.
//!
//! **Volume fraction** (phase 9): `∂θ/∂t + ∇·(θu) = 0` with the corrected face velocities,
//! the same limited upwind reconstruction of θ at faces, and Heun's (SSP-RK2) method in time.
//! A field of region `Rest` is not advected: the core sets its θ = 1 − Σ others.
//!
//! Every loop writes disjoint rows, so the parallel results are the same bits for any
//! number of threads; the reductions (energy, momentum, mass) are serial.

#[cfg(feature = "dim3")]
mod dim3;
pub mod viscous;

use multifield_core::boundary::{Boundaries, Side, MIDDLE};
use multifield_core::case::Region;
#[cfg(feature = "dim2")]
use multifield_core::exact::Sums;
use multifield_core::grid::{FaceVelocity, Grid, Lattice};
use multifield_core::math::{Real, Vector, AXES};
use multifield_core::plugin::{apply_grid_stresses, Frame, FrameContext, InitContext, StressModel};
use multifield_core::registry::{params_value, ParamDoc};
use multifield_core::simulation::region_fraction;
use multifield_core::state;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::any::Any;
use std::borrow::Cow;
use viscous::FaceDiffusion;

/// Slope limiter of the MUSCL reconstruction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Limiter {
    /// Monotonised central (van Leer 1977): min(2|a|, 2|b|, |a + b|/2).
    #[default]
    Mc,
    /// Minmod: the smaller of the two one-sided slopes (most diffusive).
    Minmod,
    /// Van Leer's harmonic limiter 2ab/(a + b).
    VanLeer,
    /// No limiting: Fromm's central slope (a + b)/2 (not monotone).
    None,
    /// No limiting, van Leer's κ = 1/3 scheme: the slope (a + 2b)/3 weighted towards the flux
    /// point, third order in space for smooth data: no second-order dispersion, and two thirds of
    /// Fromm's fourth-order dissipation (not monotone).
    ThirdOrder,
}

impl Limiter {
    /// Limited slope from the difference `a` on the upwind side of the cell and `b` on the
    /// side of the flux point (for a positive velocity, the backward and forward differences).
    /// Only `third_order` treats the two differently.
    #[inline]
    pub fn slope(self, a: Real, b: Real) -> Real {
        match self {
            Limiter::None => 0.5 * (a + b),
            Limiter::ThirdOrder => (a + 2.0 * b) / 3.0,
            _ if a * b <= 0.0 => 0.0,
            Limiter::Minmod => {
                if a.abs() < b.abs() {
                    a
                } else {
                    b
                }
            }
            Limiter::Mc => {
                let m = (2.0 * a.abs()).min(2.0 * b.abs()).min(0.5 * (a + b).abs());
                m.copysign(a)
            }
            Limiter::VanLeer => 2.0 * a * b / (a + b),
        }
    }

    /// Upwind value at the flux point between `q0` and `q1` (neighbours `qm` and `q2`) for
    /// a transport velocity `vel`.
    #[inline]
    fn face_value(self, qm: Real, q0: Real, q1: Real, q2: Real, vel: Real) -> Real {
        if vel >= 0.0 {
            q0 + 0.5 * self.slope(q0 - qm, q1 - q0)
        } else {
            // the difference on the flux point's side comes second
            q1 - 0.5 * self.slope(q2 - q1, q1 - q0)
        }
    }
}

/// The Eulerian frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Eulerian {
    /// Slope limiter of the advection: `"mc"`, `"minmod"`, `"van_leer"` or `"none"`.
    #[serde(default)]
    pub limiter: Limiter,
    /// Time integration of a Newtonian viscosity: `"crank_nicolson"` (implicit, no
    /// viscous Δt limit, steady states independent of Δt) or `"explicit"` (the earlier
    /// split step, Δt ≤ h²ρ/(4μ)).
    #[serde(default)]
    pub diffusion: Diffusion,
    /// With `"crank_nicolson"`, the largest diffusion number νΔt/h² a step takes (a bound
    /// of accuracy, not of stability: Crank–Nicolson damps the grid-scale viscous modes by
    /// |1 − 4d|/(1 + 4d) per step, which tends to 1 as d grows).
    #[serde(default = "default_diffusion_number")]
    pub max_diffusion_number: Real,
    #[serde(skip)]
    work: Work,
}

fn default_diffusion_number() -> Real {
    2.0
}

impl Default for Eulerian {
    fn default() -> Self {
        Self {
            limiter: Limiter::default(),
            diffusion: Diffusion::default(),
            max_diffusion_number: default_diffusion_number(),
            work: Work::default(),
        }
    }
}

/// Time integration of the field's viscosity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Diffusion {
    /// Crank–Nicolson in the full step, backward Euler in the midpoint, with the lagged
    /// pressure inside the solve; only for Newtonian stresses (others stay explicit).
    #[default]
    CrankNicolson,
    /// Explicit: the stresses act on uⁿ in the midpoint and on the advected state
    /// uⁿ − Δt A(u½) in the full step (split); the steady state then depends on Δt.
    Explicit,
}

multifield_core::register!(
    Frame,
    "eulerian",
    Eulerian,
    "state on the MAC grid: conservative limited (MUSCL) advection, second order in space and time \
     (midpoint predictor with the lagged pressure, after Bell–Colella–Glaz 1989)",
    &[
        ParamDoc {
            name: "limiter",
            unit: "-",
            default: "\"mc\"",
            doc: "slope limiter: \"mc\" (monotonised central), \"minmod\", \"van_leer\", \"none\" (Fromm, not monotone), \"third_order\" (κ = 1/3, not monotone)"
        },
        ParamDoc {
            name: "diffusion",
            unit: "-",
            default: "\"crank_nicolson\"",
            doc: "viscosity in time: \"crank_nicolson\" (implicit, steady states independent of Δt) or \"explicit\" (split, Δt ≤ 0.9 h²ρ/(4μ))"
        },
        ParamDoc {
            name: "max_diffusion_number",
            unit: "-",
            default: "2",
            doc: "with crank_nicolson, the largest νΔt/h² a step takes (accuracy of the transient)"
        },
    ]
);

/// Ghost layers on each side of a padded array.
#[cfg(feature = "dim2")]
const G: usize = 2;

/// A lattice array with two ghost layers on every side.
#[cfg(feature = "dim2")]
#[derive(Clone, Debug, Default)]
struct Padded {
    data: Vec<Real>,
    cols: usize,
    rows: usize,
}

#[cfg(feature = "dim2")]
impl Padded {
    fn new(cols: usize, rows: usize) -> Self {
        Self { data: vec![0.0; (cols + 2 * G) * (rows + 2 * G)], cols, rows }
    }
    fn stride(&self) -> usize {
        self.cols + 2 * G
    }
    /// Row `j` (−2 ≤ j < rows + 2) with its ghosts: lattice column `i` is at `i + 2`.
    #[inline]
    fn row(&self, j: isize) -> &[Real] {
        let s = self.stride();
        let start = (j + G as isize) as usize * s;
        &self.data[start..start + s]
    }
    #[inline]
    fn get(&self, i: isize, j: isize) -> Real {
        self.data[(i + G as isize) as usize + (j + G as isize) as usize * self.stride()]
    }
    #[inline]
    fn set(&mut self, i: isize, j: isize, v: Real) {
        let s = self.stride();
        self.data[(i + G as isize) as usize + (j + G as isize) as usize * s] = v;
    }
}

/// How the ghosts beyond one end of a line of lattice values are made.
#[derive(Clone, Copy, Debug)]
enum Rule {
    /// Periodic with this period (in lattice steps).
    Wrap(usize),
    /// Normal component on a wall or inflow node: odd reflection about the boundary value.
    Odd,
    /// Normal component on an outflow: zero gradient.
    Flat,
    /// Tangential component half a cell inside: the boundary's ghost rule.
    Tangential(Side),
    /// Cell quantity: even reflection about the side.
    Mirror,
}

/// Ghost values at −1, −2 (`lo`) and n, n + 1 (`hi`) of a line of `n` values `q`.
#[cfg(feature = "dim2")]
#[inline]
fn ghosts(q: impl Fn(usize) -> Real, n: usize, lo: Rule, hi: Rule, bc: &Boundaries, s: Real) -> ([Real; 2], [Real; 2]) {
    let mut l = [0.0; 2];
    let mut h = [0.0; 2];
    for k in 1..=2 {
        l[k - 1] = match lo {
            Rule::Wrap(p) => q(p - k),
            Rule::Odd => 2.0 * q(0) - q(k),
            Rule::Flat => q(0),
            Rule::Tangential(side) => bc.tangential_ghost(side, q(k - 1), s),
            Rule::Mirror => q(k - 1),
        };
        h[k - 1] = match hi {
            Rule::Wrap(p) => q(n - 1 + k - p),
            Rule::Odd => 2.0 * q(n - 1) - q(n - 1 - k),
            Rule::Flat => q(n - 1),
            Rule::Tangential(side) => bc.tangential_ghost(side, q(n - k), s),
            Rule::Mirror => q(n - k),
        };
    }
    (l, h)
}

#[cfg(feature = "dim2")]
/// Copies `src` (a `cols × rows` lattice array) into `p` and fills its ghosts: first along
/// x for the inside rows, then along y for every column (corners included). `sx(i)` and
/// `sy(j)` give the fraction along the bottom/top and left/right sides for moving walls.
fn fill(
    p: &mut Padded,
    src: &[Real],
    rules_x: (Rule, Rule),
    rules_y: (Rule, Rule),
    bc: &Boundaries,
    sx: impl Fn(isize) -> Real,
    sy: impl Fn(isize) -> Real + Sync,
) {
    let (cols, rows) = (p.cols, p.rows);
    let stride = p.stride();
    p.data[G * stride..(G + rows) * stride].par_chunks_mut(stride).zip(src.par_chunks(cols)).enumerate().for_each(
        |(j, (line, q))| {
            line[G..G + cols].copy_from_slice(q);
            let (l, h) = ghosts(|i| q[i], cols, rules_x.0, rules_x.1, bc, sy(j as isize));
            line[G - 1] = l[0];
            line[G - 2] = l[1];
            line[G + cols] = h[0];
            line[G + cols + 1] = h[1];
        },
    );
    for i in -(G as isize)..(cols + G) as isize {
        let (l, h) = ghosts(|j| p.get(i, j as isize), rows, rules_y.0, rules_y.1, bc, sx(i));
        p.set(i, -1, l[0]);
        p.set(i, -2, l[1]);
        p.set(i, rows as isize, h[0]);
        p.set(i, rows as isize + 1, h[1]);
    }
}

/// Ghost rules of the normal component at `side`.
fn normal_rule(bc: &Boundaries, side: Side, period: usize, periodic: bool) -> Rule {
    if periodic {
        Rule::Wrap(period)
    } else if bc.normal_velocity(side, MIDDLE).is_some() {
        Rule::Odd
    } else {
        Rule::Flat
    }
}

/// Ghost rules of a tangential component at `side`.
fn tangential_rule(side: Side, period: usize, periodic: bool) -> Rule {
    if periodic {
        Rule::Wrap(period)
    } else {
        Rule::Tangential(side)
    }
}

/// Scratch and state that depend on the grid (built by `initialize`).
#[derive(Clone, Debug, Default)]
struct Work {
    /// The grid (a rank's block of a decomposed domain: its halo exchange and reductions).
    grid: Grid,
    #[cfg(feature = "dim2")]
    nx: usize,
    #[cfg(feature = "dim2")]
    ny: usize,
    /// Cells along each axis (3D).
    #[cfg(feature = "dim3")]
    n: multifield_core::math::Index,
    h: Real,
    density: Real,
    #[cfg(feature = "dim2")]
    periodic: (bool, bool),
    #[cfg(feature = "dim3")]
    periodic: [bool; 3],
    /// Whether the field fills what the others leave (region `Rest`).
    fills_rest: bool,
    /// Steps completed (the first has no lagged pressure acceleration).
    steps: u64,
    theta: Vec<Real>,
    velocity: FaceVelocity,
    /// u½, then the advection rate −A.
    half: FaceVelocity,
    /// Right-hand sides of the implicit viscous solves.
    viscous: FaceVelocity,
    /// The implicit viscous operators (built on first use).
    diffusion: Option<FaceDiffusion>,
    rate: FaceVelocity,
    #[cfg(feature = "dim2")]
    pu: Padded,
    #[cfg(feature = "dim2")]
    pv: Padded,
    #[cfg(feature = "dim2")]
    pt: Padded,
    /// Fluxes of the u equation: at cell centres ((nx+2) × ny) and corners ((nx+1) × (ny+1)).
    #[cfg(feature = "dim2")]
    fxu: Vec<Real>,
    #[cfg(feature = "dim2")]
    fyu: Vec<Real>,
    /// Fluxes of the v equation: at corners ((nx+1) × (ny+1)) and cell centres (nx × (ny+2)).
    #[cfg(feature = "dim2")]
    gxv: Vec<Real>,
    #[cfg(feature = "dim2")]
    gyv: Vec<Real>,
    /// θ fluxes on faces, θ¹ of Heun's method and its rate.
    #[cfg(feature = "dim2")]
    ftx: Vec<Real>,
    #[cfg(feature = "dim2")]
    fty: Vec<Real>,
    theta1: Vec<Real>,
    theta_rate: Vec<Real>,
    /// 3D: the fluxes of one component (or of θ) through the faces of its control
    /// volumes, one array per direction (`eulerian/dim3.rs`).
    #[cfg(feature = "dim3")]
    fluxes: [Vec<Real>; 3],
    /// 3D: the velocity components and θ with their ghost layers (`eulerian/dim3.rs`).
    #[cfg(feature = "dim3")]
    padded: [dim3::Padded; 3],
    #[cfg(feature = "dim3")]
    padded_theta: dim3::Padded,
}

#[cfg(feature = "dim2")]
impl Work {
    fn new(grid: &Grid, bc: &Boundaries, density: Real, fills_rest: bool) -> Self {
        let (nx, ny) = (grid.nx, grid.ny);
        Work {
            grid: grid.clone(),
            nx,
            ny,
            h: grid.h,
            density,
            periodic: (bc.periodic(0), bc.periodic(1)),
            fills_rest,
            steps: 0,
            theta: vec![0.0; grid.n_cells()],
            velocity: FaceVelocity::zeros(grid),
            half: FaceVelocity::zeros(grid),
            viscous: FaceVelocity::zeros(grid),
            diffusion: None,
            rate: FaceVelocity::zeros(grid),
            pu: Padded::new(nx + 1, ny),
            pv: Padded::new(nx, ny + 1),
            pt: Padded::new(nx, ny),
            fxu: vec![0.0; (nx + 2) * ny],
            fyu: vec![0.0; (nx + 1) * (ny + 1)],
            gxv: vec![0.0; (nx + 1) * (ny + 1)],
            gyv: vec![0.0; nx * (ny + 2)],
            ftx: vec![0.0; grid.n_xfaces()],
            fty: vec![0.0; grid.n_yfaces()],
            theta1: vec![0.0; grid.n_cells()],
            theta_rate: vec![0.0; grid.n_cells()],
        }
    }

    /// −A(u) of the velocity `vel` into `self.rate`.
    fn advect_rate(&mut self, vel: &FaceVelocity, bc: &Boundaries, lim: Limiter) {
        self.fill_velocity(vel, bc);
        self.advection_rate(lim);
    }

    /// Fills the padded velocity components from `vel` with boundary ghosts.
    fn fill_velocity(&mut self, vel: &FaceVelocity, bc: &Boundaries) {
        let (nx, ny) = (self.nx, self.ny);
        let (px, py) = self.periodic;
        let clamp = |t: Real| t.clamp(0.0, 1.0);
        // fractions along the domain's sides (a rank's block: by global index)
        let g = &self.grid;
        let (sx, sy) = (g.start[0], g.start[1]);
        let (dx, dy) = (g.domain[0] as Real, g.domain[1] as Real);
        fill(
            &mut self.pu,
            &vel.u,
            (normal_rule(bc, Side::Left, nx, px), normal_rule(bc, Side::Right, nx, px)),
            (tangential_rule(Side::Bottom, ny, py), tangential_rule(Side::Top, ny, py)),
            bc,
            |i| clamp((i + sx) as Real / dx),
            |_| 0.5,
        );
        fill(
            &mut self.pv,
            &vel.v,
            (tangential_rule(Side::Left, nx, px), tangential_rule(Side::Right, nx, px)),
            (normal_rule(bc, Side::Bottom, ny, py), normal_rule(bc, Side::Top, ny, py)),
            bc,
            |_| 0.5,
            |j| clamp((j + sy) as Real / dy),
        );
    }

    /// The advection rate −A(u) = −∇·(u ⊗ u) on every face, from the padded components,
    /// into `self.rate`.
    fn advection_rate(&mut self, lim: Limiter) {
        let (nx, h) = (self.nx, self.h);
        let (pu, pv) = (&self.pu, &self.pv);
        // u equation, x fluxes at cell centres c = cp − 1, cp = 0..=nx+1
        self.fxu.par_chunks_mut(nx + 2).enumerate().for_each(|(j, out)| {
            let r = pu.row(j as isize);
            for (cp, f) in out.iter_mut().enumerate() {
                let vel = 0.5 * (r[cp + 1] + r[cp + 2]);
                *f = vel * lim.face_value(r[cp], r[cp + 1], r[cp + 2], r[cp + 3], vel);
            }
        });
        // u equation, y fluxes at corners (i, k) between rows k−1 and k
        self.fyu.par_chunks_mut(nx + 1).enumerate().for_each(|(k, out)| {
            let k = k as isize;
            let (a, b, c, d) = (pu.row(k - 2), pu.row(k - 1), pu.row(k), pu.row(k + 1));
            let rv = pv.row(k);
            for (i, f) in out.iter_mut().enumerate() {
                let vel = 0.5 * (rv[i + 1] + rv[i + 2]);
                *f = vel * lim.face_value(a[i + G], b[i + G], c[i + G], d[i + G], vel);
            }
        });
        // v equation, x fluxes at corners (k, j) between columns k−1 and k
        self.gxv.par_chunks_mut(nx + 1).enumerate().for_each(|(j, out)| {
            let j = j as isize;
            let rv = pv.row(j);
            let (ub, ut) = (pu.row(j - 1), pu.row(j));
            for (k, f) in out.iter_mut().enumerate() {
                let vel = 0.5 * (ub[k + G] + ut[k + G]);
                *f = vel * lim.face_value(rv[k], rv[k + 1], rv[k + 2], rv[k + 3], vel);
            }
        });
        // v equation, y fluxes at cell centres c = cp − 1, cp = 0..=ny+1
        self.gyv.par_chunks_mut(nx).enumerate().for_each(|(cp, out)| {
            let c = cp as isize - 1;
            let (a, b, cc, d) = (pv.row(c - 1), pv.row(c), pv.row(c + 1), pv.row(c + 2));
            for (i, f) in out.iter_mut().enumerate() {
                let vel = 0.5 * (b[i + G] + cc[i + G]);
                *f = vel * lim.face_value(a[i + G], b[i + G], cc[i + G], d[i + G], vel);
            }
        });
        let (fxu, fyu, gxv, gyv) = (&self.fxu, &self.fyu, &self.gxv, &self.gyv);
        self.rate.u.par_chunks_mut(nx + 1).enumerate().for_each(|(j, out)| {
            let fx = &fxu[j * (nx + 2)..(j + 1) * (nx + 2)];
            let (fs, fn_) = (&fyu[j * (nx + 1)..(j + 1) * (nx + 1)], &fyu[(j + 1) * (nx + 1)..(j + 2) * (nx + 1)]);
            for (i, r) in out.iter_mut().enumerate() {
                *r = -(fx[i + 1] - fx[i] + fn_[i] - fs[i]) / h;
            }
        });
        self.rate.v.par_chunks_mut(nx).enumerate().for_each(|(j, out)| {
            let gx = &gxv[j * (nx + 1)..(j + 1) * (nx + 1)];
            let (gs, gn) = (&gyv[j * nx..(j + 1) * nx], &gyv[(j + 1) * nx..(j + 2) * nx]);
            for (i, r) in out.iter_mut().enumerate() {
                *r = -(gx[i + 1] - gx[i] + gn[i] - gs[i]) / h;
            }
        });
    }

    /// −∇·(θu) per cell from `theta` and the face velocity in `self.velocity`, into
    /// `self.theta_rate`.
    fn theta_rate(&mut self, theta: &[Real], bc: &Boundaries, lim: Limiter) {
        let (nx, ny, h) = (self.nx, self.ny, self.h);
        let (px, py) = self.periodic;
        let rx = if px { (Rule::Wrap(nx), Rule::Wrap(nx)) } else { (Rule::Mirror, Rule::Mirror) };
        let ry = if py { (Rule::Wrap(ny), Rule::Wrap(ny)) } else { (Rule::Mirror, Rule::Mirror) };
        fill(&mut self.pt, theta, rx, ry, bc, |_| 0.5, |_| 0.5);
        let pt = &self.pt;
        let vel = &self.velocity;
        self.ftx.par_chunks_mut(nx + 1).zip(vel.u.par_chunks(nx + 1)).enumerate().for_each(|(j, (out, u))| {
            let r = pt.row(j as isize);
            for (i, f) in out.iter_mut().enumerate() {
                *f = u[i] * lim.face_value(r[i], r[i + 1], r[i + 2], r[i + 3], u[i]);
            }
        });
        self.fty.par_chunks_mut(nx).zip(vel.v.par_chunks(nx)).enumerate().for_each(|(j, (out, v))| {
            let j = j as isize;
            let (a, b, c, d) = (pt.row(j - 2), pt.row(j - 1), pt.row(j), pt.row(j + 1));
            for (i, f) in out.iter_mut().enumerate() {
                *f = v[i] * lim.face_value(a[i + G], b[i + G], c[i + G], d[i + G], v[i]);
            }
        });
        let (ftx, fty) = (&self.ftx, &self.fty);
        self.theta_rate.par_chunks_mut(nx).enumerate().for_each(|(j, out)| {
            let fx = &ftx[j * (nx + 1)..(j + 1) * (nx + 1)];
            let (fs, fn_) = (&fty[j * nx..(j + 1) * nx], &fty[(j + 1) * nx..(j + 2) * nx]);
            for (i, r) in out.iter_mut().enumerate() {
                *r = -(fx[i + 1] - fx[i] + fn_[i] - fs[i]) / h;
            }
        });
    }

    /// Volume fraction on x-face `(i, j)` (mean of the neighbours, wrapped if periodic) and
    /// the share of its control volume inside the domain (½ on a non-periodic side).
    fn xface_weight(&self, i: usize, j: usize) -> (Real, Real) {
        let (nx, px) = (self.nx, self.periodic.0);
        let t = |c: usize| self.theta[c + j * nx];
        if i > 0 && i < nx {
            (0.5 * (t(i - 1) + t(i)), 1.0)
        } else if px {
            // face nx repeats face 0: count it once
            (0.5 * (t(nx - 1) + t(0)), if i == 0 { 1.0 } else { 0.0 })
        } else {
            (t(if i == 0 { 0 } else { nx - 1 }), 0.5)
        }
    }

    /// As [`Work::xface_weight`] for y-face `(i, j)`.
    fn yface_weight(&self, i: usize, j: usize) -> (Real, Real) {
        let (nx, ny, py) = (self.nx, self.ny, self.periodic.1);
        let t = |r: usize| self.theta[i + r * nx];
        if j > 0 && j < ny {
            (0.5 * (t(j - 1) + t(j)), 1.0)
        } else if py {
            (0.5 * (t(ny - 1) + t(0)), if j == 0 { 1.0 } else { 0.0 })
        } else {
            (t(if j == 0 { 0 } else { ny - 1 }), 0.5)
        }
    }

    /// Σ over faces of f(face mass, velocity component) for x and y.
    fn face_sums(&self, f: impl Fn(Real, Real) -> Real + Sync + Send) -> (Real, Real) {
        let nx = self.nx;
        let m0 = self.density * self.h * self.h;
        // the reduction rule (docs/design/mpi.md §3): row groups of 32 faces along x (the
        // high face nx alone), each summed in order, the groups' values added exactly
        // (the owned faces of a rank's block, every rank's sums added)
        let (lx, ly) = (nx + 1, nx);
        let g = &self.grid;
        let Sums([sx]) = g.groups(Lattice::XFace).sums(|g| {
            let j = g.start / lx;
            [g.map(|k| {
                let (t, w) = self.xface_weight(k - j * lx, j);
                f(w * t * m0, self.velocity.u[k])
            })
            .sum()]
        });
        let Sums([sy]) = g.groups(Lattice::YFace).sums(|g| {
            let j = g.start / ly;
            [g.map(|k| {
                let (t, w) = self.yface_weight(k - j * ly, j);
                f(w * t * m0, self.velocity.v[k])
            })
            .sum()]
        });
        let [sx, sy] = g.part.reduce(Sums([sx, sy]));
        (sx, sy)
    }
}

/// Calls `f(k, &mut out[k])` on every face `k` normal to `axis` that is neither fixed (wall
/// or inflow) nor the periodic copy of face 0, rows along x in parallel.
fn for_unknown_faces(
    grid: &Grid,
    bc: &Boundaries,
    axis: usize,
    out: &mut [Real],
    f: impl Fn(usize, &mut Real) + Sync + Send,
) {
    let shape = grid.shape(Lattice::face(axis));
    let n = grid.n()[axis];
    let periodic = bc.periodic(axis);
    let skip = |i: usize| bc.face_fixed(grid, axis, i) || (periodic && i == n);
    out.par_chunks_mut(shape[0]).enumerate().for_each(|(row, out)| {
        let o = row * shape[0];
        if axis == 0 {
            for (i, d) in out.iter_mut().enumerate() {
                if !skip(i) {
                    f(o + i, d);
                }
            }
            return;
        }
        // the row's coordinate along `axis`
        let mut r = row;
        for s in &shape[1..axis] {
            r /= s;
        }
        if skip(r % shape[axis]) {
            return;
        }
        for (i, d) in out.iter_mut().enumerate() {
            f(o + i, d);
        }
    });
}

impl Eulerian {
    /// Checks the parameters (the limiter is checked when it is read).
    pub fn validate(&mut self) -> Result<(), String> {
        let d = self.max_diffusion_number;
        if !(d > 0.0 && d.is_finite()) {
            return Err(format!(
                "max_diffusion_number {d}: must be positive (2 is the default; 0.225 is the explicit limit)"
            ));
        }
        Ok(())
    }

    /// The frame's volume fraction per cell.
    pub fn theta(&self) -> &[Real] {
        &self.work.theta
    }

    /// The frame's face velocities.
    pub fn velocity(&self) -> &FaceVelocity {
        &self.work.velocity
    }

    /// u½ += c (−A + a_p + f + g) (without a_p + f + g unless `lagged`; f the lagged
    /// immersed-boundary force) on the faces that are neither fixed nor periodic copies.
    fn half_step(
        &mut self,
        bc: &Boundaries,
        grid: &Grid,
        c: Real,
        (ap, f): (&FaceVelocity, &FaceVelocity),
        g: Vector,
        lagged: bool,
    ) {
        let w = &mut self.work;
        let s = if lagged { 1.0 } else { 0.0 };
        for a in AXES {
            let (r, ap, f, g) = (&w.rate[a], &ap[a], &f[a], g[a]);
            for_unknown_faces(grid, bc, a, &mut w.half[a], |k, d| {
                *d += c * (r[k] + s * (ap[k] + f[k] + g));
            });
        }
    }

    /// The field's grid stresses applied for `dt` to u½ (in `self.work.half`), through
    /// the state's velocity, which is kept.
    fn stresses_on_half(&mut self, ctx: &mut FrameContext, dt: Real) -> Result<(), String> {
        if ctx.stress.is_empty() {
            return Ok(());
        }
        std::mem::swap(&mut ctx.state.velocity, &mut self.work.half);
        let r = apply_grid_stresses(ctx, dt).map_err(|e| format!("{e} (on the midpoint state)"));
        std::mem::swap(&mut ctx.state.velocity, &mut self.work.half);
        r
    }

    /// u* = uⁿ − Δt A(u½) into `out`, on the faces that are neither fixed nor periodic copies.
    fn full_step(&self, bc: &Boundaries, grid: &Grid, dt: Real, out: &mut FaceVelocity) {
        let w = &self.work;
        for a in AXES {
            let (u, r) = (&w.velocity[a], &w.rate[a]);
            for_unknown_faces(grid, bc, a, &mut out[a], |k, d| {
                *d = u[k] + dt * r[k];
            });
        }
    }

    /// The field's Newtonian viscosity μ when the frame integrates it implicitly: with
    /// `diffusion: "crank_nicolson"` and every grid stress of the field Newtonian
    /// ([`StressKind::newtonian_viscosity`](multifield_core::plugin::StressKind::newtonian_viscosity); their viscosities add). `None`: explicit.
    pub fn implicit_viscosity(&self, stress: &[Box<dyn StressModel>]) -> Option<Real> {
        if self.diffusion != Diffusion::CrankNicolson || stress.is_empty() {
            return None;
        }
        stress.iter().filter(|m| m.kind().acts_on_grid()).map(|m| m.kind().newtonian_viscosity()).sum()
    }

    /// Backward Euler for the viscosity of the midpoint: (I − c L) u½ = u½ (as built so
    /// far), c = (Δt/2) ν / h².
    fn implicit_half(&mut self, grid: &Grid, bc: &Boundaries, c: Real) -> Result<(), String> {
        let w = &mut self.work;
        let diffusion = w.diffusion.get_or_insert_with(|| FaceDiffusion::new(grid, bc));
        bc.enforce(grid, &mut w.half);
        for a in AXES {
            let (x, rhs) = (&mut w.half[a], &mut w.viscous[a]);
            rhs.copy_from_slice(x);
            diffusion.solve(a, c, rhs, x)?;
        }
        Ok(())
    }

    /// Crank–Nicolson for the viscosity of the full step, with the lagged pressure and
    /// gravity inside the solve so that a steady state is one of the discrete equations:
    /// (I − c L) x = uⁿ + Δt (−A(u½) + P) + c L uⁿ, u* = x − Δt P on the unknown faces,
    /// c = (Δt/2) ν / h², P = a_p + g (0 on the first step), into `out`.
    fn crank_nicolson(
        &mut self,
        grid: &Grid,
        bc: &Boundaries,
        dt: Real,
        nu: Real,
        (lagged, (ap, f), g): (bool, (&FaceVelocity, &FaceVelocity), Vector),
        out: &mut FaceVelocity,
    ) -> Result<(), String> {
        let c = 0.5 * dt * nu / (grid.h * grid.h);
        let w = &mut self.work;
        let diffusion = w.diffusion.get_or_insert_with(|| FaceDiffusion::new(grid, bc));
        let s = if lagged { 1.0 } else { 0.0 };
        for axis in AXES {
            let gravity = g[axis];
            let (un, rate, a, f, rhs, x) =
                (&w.velocity[axis], &w.rate[axis], &ap[axis], &f[axis], &mut w.viscous[axis], &mut out[axis]);
            diffusion.laplacian(axis, un, rhs);
            rhs.par_iter_mut().enumerate().with_min_len(4096).for_each(|(k, r)| {
                *r = un[k] + dt * (rate[k] + s * (a[k] + f[k] + gravity)) + c * *r;
            });
            // initial guess uⁿ; the fixed faces hold the wall values
            x.copy_from_slice(un);
            diffusion.solve(axis, c, rhs, x)?;
            let d = &*diffusion;
            x.par_iter_mut().enumerate().with_min_len(4096).for_each(|(k, x)| {
                if d.is_unknown(axis, k) {
                    *x -= dt * s * (a[k] + f[k] + gravity);
                }
            });
        }
        Ok(())
    }
}

impl Frame for Eulerian {
    fn model(&self) -> &'static str {
        "eulerian"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn is_lagrangian(&self) -> bool {
        false
    }
    fn decomposed(&self) -> bool {
        // (3D: not yet; its padded arrays and sums are the next phase)
        cfg!(feature = "dim2")
    }
    fn implicit_diffusion_number(&self, stress: &[Box<dyn StressModel>]) -> Option<Real> {
        self.implicit_viscosity(stress).map(|_| self.max_diffusion_number)
    }

    fn initialize(&mut self, ctx: &InitContext) -> Result<(), String> {
        if let Region::Bodies(bodies) = ctx.region {
            let names: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
            return Err(format!(
                "region `Bodies([...])` ({}) needs a Lagrangian frame: an Eulerian field has no bodies to track or \
                 hold (its fluid would flow through them); give this field `frame: (model: \"lagrangian\")` and \
                 `stress: [(model: \"rigid\")]`, and couple it to the fluid with an exchange (`direct_forcing` or \
                 `no_slip`), or give it a plain region (`Disk(...)`, `Rectangle(...)`)",
                names.join(", ")
            ));
        }
        let g = ctx.grid;
        let mut w = Work::new(g, ctx.boundaries, ctx.density, *ctx.region == Region::Rest);
        match ctx.theta {
            Some(t) => {
                if t.len() != g.n_cells() {
                    return Err(format!("{} initial volume fractions for {} cells", t.len(), g.n_cells()));
                }
                w.theta.copy_from_slice(t);
            }
            None => w.theta = region_fraction(ctx.region, g),
        }
        let origin = g.origin.into();
        for a in AXES {
            for (k, at) in g.nodes(Lattice::face(a)) {
                let p = g.position(Lattice::face(a), at);
                w.velocity[a][k] = ctx.velocity.at(p.into(), origin)[a];
            }
        }
        ctx.boundaries.enforce(g, &mut w.velocity);
        // a rank's halo as its neighbours' (not the values at the unwrapped positions)
        g.exchange(&mut [(Lattice::Cell, &mut w.theta)]);
        g.exchange_faces(&mut w.velocity);
        if g.part.any(!w.velocity.max_abs().is_finite()) {
            return Err("the initial velocity is not finite".into());
        }
        self.work = w;
        Ok(())
    }

    fn to_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        let w = &self.work;
        let s = &mut *ctx.state;
        s.theta.copy_from_slice(&w.theta);
        for a in AXES {
            s.velocity[a].copy_from_slice(&w.velocity[a]);
            s.velocity_old[a].copy_from_slice(&w.velocity[a]);
        }
        Ok(())
    }

    fn predict(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        let (bc, grid, dt) = (ctx.boundaries, ctx.grid, ctx.dt);
        let lim = self.limiter;
        let nu = self.implicit_viscosity(ctx.stress).map(|mu| mu / ctx.density);
        // −A(uⁿ)
        let un = std::mem::take(&mut self.work.velocity);
        self.work.advect_rate(&un, bc, lim);
        self.work.velocity = un;
        // u½ = uⁿ + Δt/2 (V + −A(uⁿ) + a_p + g), V explicit at uⁿ or backward Euler at u½
        let w = &mut self.work;
        for a in AXES {
            w.half[a].copy_from_slice(&w.velocity[a]);
        }
        if nu.is_none() {
            self.stresses_on_half(ctx, 0.5 * dt)?;
        }
        // no lagged pressure on the first step: leave out gravity too (see the module doc)
        let lagged = self.work.steps > 0;
        let s = &*ctx.state;
        self.half_step(bc, grid, 0.5 * dt, (&s.pressure_acceleration, &s.body_force), ctx.gravity, lagged);
        // (a decomposed run: the halo of u½ as the neighbours', read by the solve and −A(u½))
        grid.exchange_faces(&mut self.work.half);
        if let Some(nu) = nu {
            self.implicit_half(grid, bc, 0.5 * dt * nu / (grid.h * grid.h))?;
        }
        bc.enforce(grid, &mut self.work.half);
        if nu.is_some() {
            grid.exchange_faces(&mut self.work.half);
        }
        // −A(u½)
        let half = std::mem::take(&mut self.work.half);
        self.work.advect_rate(&half, bc, lim);
        self.work.half = half;
        let s = &mut ctx.state.velocity;
        match nu {
            // u* = uⁿ − Δt A(u½), then the stresses of the full step on it
            None => {
                self.full_step(bc, grid, dt, s);
                bc.enforce(grid, s);
                grid.exchange_faces(s);
                apply_grid_stresses(ctx, dt)?;
            }
            Some(nu) => {
                let mut s = std::mem::take(&mut ctx.state.velocity);
                let st = &*ctx.state;
                let p = (lagged, (&st.pressure_acceleration, &st.body_force), ctx.gravity);
                let r = self.crank_nicolson(grid, bc, dt, nu, p, &mut s);
                ctx.state.velocity = s;
                r?;
            }
        }
        bc.enforce(grid, &mut ctx.state.velocity);
        Ok(())
    }

    fn from_grid(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        let w = &mut self.work;
        let s = &*ctx.state;
        for a in AXES {
            w.velocity[a].copy_from_slice(&s.velocity[a]);
        }
        // the core's θ of this step (for a field of region `Rest`, what the others left)
        w.theta.copy_from_slice(&s.theta);
        w.steps += 1;
        Ok(())
    }

    fn advect(&mut self, ctx: &mut FrameContext) -> Result<(), String> {
        if self.work.fills_rest {
            return Ok(());
        }
        let (bc, dt, lim) = (ctx.boundaries, ctx.dt, self.limiter);
        let w = &mut self.work;
        // Heun: θ¹ = θ + Δt L(θ), θⁿ⁺¹ = ½ θ + ½ (θ¹ + Δt L(θ¹))
        let theta = std::mem::take(&mut w.theta);
        w.theta_rate(&theta, bc, lim);
        w.theta1.par_iter_mut().zip(theta.par_iter().zip(w.theta_rate.par_iter())).for_each(|(t1, (t, r))| {
            *t1 = t + dt * r;
        });
        let mut theta1 = std::mem::take(&mut w.theta1);
        ctx.grid.exchange(&mut [(Lattice::Cell, &mut theta1)]);
        w.theta_rate(&theta1, bc, lim);
        w.theta = theta;
        w.theta1 = theta1;
        let (t1, r) = (&w.theta1, &w.theta_rate);
        w.theta.par_iter_mut().zip(t1.par_iter().zip(r.par_iter())).for_each(|(t, (t1, r))| {
            *t = 0.5 * *t + 0.5 * (t1 + dt * r);
        });
        ctx.grid.exchange(&mut [(Lattice::Cell, &mut w.theta)]);
        ctx.state.theta.copy_from_slice(&w.theta);
        Ok(())
    }

    fn max_speed(&self) -> Real {
        let w = &self.work;
        if w.grid.part.is_whole() {
            return w.velocity.max_abs();
        }
        // the owned faces of every rank, the components in one gather
        let g = &w.grid;
        let mut m = AXES.map(|a| g.part.local_max_abs(Lattice::face(a), g.shape(Lattice::face(a)), &w.velocity[a]));
        g.part.max(&mut m);
        m.into_iter().fold(0.0, Real::max)
    }

    #[cfg(feature = "dim2")]
    fn kinetic_energy(&self) -> Real {
        let (ex, ey) = self.work.face_sums(|m, u| 0.5 * m * u * u);
        ex + ey
    }

    #[cfg(feature = "dim2")]
    fn momentum(&self) -> Vector {
        let (px, py) = self.work.face_sums(|m, u| m * u);
        Vector::new(px, py)
    }

    #[cfg(feature = "dim2")]
    fn mass(&self) -> Real {
        let w = &self.work;
        w.grid.sum(Lattice::Cell, &w.theta) * w.density * w.h * w.h
    }

    #[cfg(feature = "dim3")]
    fn kinetic_energy(&self) -> Real {
        let [ex, ey, ez] = self.work.face_sums(|m, u| 0.5 * m * u * u);
        ex + ey + ez
    }

    #[cfg(feature = "dim3")]
    fn momentum(&self) -> Vector {
        Vector::from(self.work.face_sums(|m, u| m * u))
    }

    #[cfg(feature = "dim3")]
    fn mass(&self) -> Real {
        let w = &self.work;
        multifield_core::exact::sum(&w.theta, w.n[0], w.n[0]) * w.density * w.h * w.h * w.h
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }

    /// Steps taken (the first step has no lagged pressure), θ and the face velocities; the
    /// rest of the work space is scratch, rebuilt every step.
    /// (A rank of a decomposed run saves the whole domain's θ and velocities, gathered.)
    fn save_state(&self) -> Result<Vec<u8>, String> {
        let w = &self.work;
        let g = &w.grid;
        if g.part.is_whole() {
            return self.save_rank_state();
        }
        let mut velocity = FaceVelocity::default();
        for a in AXES {
            let lattice = Lattice::face(a);
            velocity[a] = g.part.gather(lattice, g.shape(lattice), &w.velocity[a]);
        }
        state::encode(&EulerianState {
            steps: w.steps,
            theta: Cow::Owned(g.part.gather(Lattice::Cell, g.shape(Lattice::Cell), &w.theta)),
            velocity: Cow::Owned(velocity),
        })
    }

    /// The block's own θ and face velocities (its storage, halo included).
    fn save_rank_state(&self) -> Result<Vec<u8>, String> {
        let w = &self.work;
        state::encode(&EulerianState {
            steps: w.steps,
            theta: Cow::Borrowed(&w.theta),
            velocity: Cow::Borrowed(&w.velocity),
        })
    }

    fn load_rank_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.load(bytes, true)
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.load(bytes, false)
    }
}

impl Eulerian {
    /// [`Frame::load_state`] (`own`: [`Frame::load_rank_state`], the block's own storage).
    fn load(&mut self, bytes: &[u8], own: bool) -> Result<(), String> {
        let saved: EulerianState = state::decode(bytes, "eulerian state")?;
        let w = &mut self.work;
        let g = w.grid.clone();
        if g.part.is_whole() || own {
            state::copy_into(&mut w.theta, &saved.theta, "eulerian volume fraction")?;
            for a in AXES {
                let what = format!("eulerian velocity on {}-faces", multifield_core::math::axis_name(a));
                state::copy_into(&mut w.velocity[a], &saved.velocity[a], &what)?;
            }
        } else {
            // a rank of a decomposed run: its block (halo included) of the whole domain's
            let domain = Grid::from_cells(g.domain, g.h, g.origin);
            if saved.theta.len() != domain.n_cells()
                || AXES.iter().any(|&a| saved.velocity[a].len() != domain.n_faces(a))
            {
                return Err("eulerian state: not of this domain's size".into());
            }
            g.part.scatter(Lattice::Cell, g.shape(Lattice::Cell), &saved.theta, &mut w.theta);
            for a in AXES {
                let lattice = Lattice::face(a);
                g.part.scatter(lattice, g.shape(lattice), &saved.velocity[a], &mut w.velocity[a]);
            }
        }
        w.steps = saved.steps;
        Ok(())
    }
}

/// What an Eulerian frame carries from step to step ([`Frame::save_state`]): borrowed
/// when saved, owned when loaded.
#[derive(Serialize, Deserialize)]
struct EulerianState<'a> {
    steps: u64,
    theta: Cow<'a, [Real]>,
    velocity: Cow<'a, FaceVelocity>,
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;
    use multifield_core::boundary::Boundary;
    use multifield_core::case::InitialVelocity;
    use multifield_core::field::FieldState;

    fn periodic() -> Boundaries {
        Boundaries {
            left: Boundary::Periodic,
            right: Boundary::Periodic,
            bottom: Boundary::Periodic,
            top: Boundary::Periodic,
        }
    }

    fn frame(limiter: Limiter, grid: &Grid, bc: &Boundaries, region: &Region, vel: &InitialVelocity) -> Eulerian {
        let mut e = Eulerian { limiter, ..Default::default() };
        let ctx = InitContext {
            grid,
            boundaries: bc,
            name: "test",
            density: 2.0,
            region,
            velocity: vel,
            theta: None,
            contact: None,
        };
        e.initialize(&ctx).unwrap();
        e
    }

    /// Runs `steps` of predict (no pressure) and θ advection with a frozen velocity.
    fn run(e: &mut Eulerian, grid: &Grid, bc: &Boundaries, dt: Real, steps: usize) -> FieldState {
        let mut state = FieldState::new(grid);
        for _ in 0..steps {
            let mut ctx = FrameContext {
                grid,
                boundaries: bc,
                dt,
                time: 0.0,
                gravity: Vector::zeros(),
                density: 2.0,
                state: &mut state,
                stress: &[],
                body_forces: &[],
                forced_bodies: None,
                partner: None,
            };
            e.to_grid(&mut ctx).unwrap();
            e.predict(&mut ctx).unwrap();
            e.advect(&mut ctx).unwrap();
        }
        state
    }

    /// κ = 1/3 reconstructs the face value of a quadratic from its cell averages exactly, in
    /// either flow direction, and every reconstruction treats the two directions as mirror
    /// images of each other.
    #[test]
    fn third_order_is_exact_for_quadratics_and_every_limiter_is_mirror_symmetric() {
        // cell averages of q(x) = 3x² − x + 2 on unit cells centred at −1, 0, 1, 2
        let q = |x: Real| 3.0 * x * x - x + 2.0;
        let avg = |c: Real| q(c) + 3.0 / 12.0;
        let (qm, q0, q1, q2) = (avg(-1.0), avg(0.0), avg(1.0), avg(2.0));
        for vel in [1.0, -1.0] {
            let f = Limiter::ThirdOrder.face_value(qm, q0, q1, q2, vel);
            assert!((f - q(0.5)).abs() < 1e-13, "velocity {vel}: {f} against {}", q(0.5));
        }
        // Fromm's slope is not exact for a quadratic: that is the third order
        assert!((Limiter::None.face_value(qm, q0, q1, q2, 1.0) - q(0.5)).abs() > 0.1);
        let (a, b, c, d) = (0.3, 1.1, 1.7, 4.0);
        for l in [Limiter::Mc, Limiter::Minmod, Limiter::VanLeer, Limiter::None, Limiter::ThirdOrder] {
            assert_eq!(l.face_value(a, b, c, d, 1.0), l.face_value(d, c, b, a, -1.0), "{l:?}");
        }
    }

    /// Bodies on an Eulerian field are refused with the fix (they were accepted and ignored).
    #[test]
    fn bodies_need_a_lagrangian_frame() {
        use multifield_core::case::{BodyShape, BodySpec};
        let g = Grid::new(8, 8, 0.125, Vector::zeros());
        let region = Region::Bodies(vec![BodySpec {
            name: "disk".into(),
            shape: BodyShape::Disk { center: [0.5, 0.5], radius: 0.2 },
            motion: Default::default(),
            velocity: [0.0, 0.0],
            angular_velocity: 0.0,
            density: None,
        }]);
        let vel = InitialVelocity::default();
        let bc = periodic();
        let ctx = InitContext {
            grid: &g,
            boundaries: &bc,
            name: "f",
            density: 1.0,
            region: &region,
            velocity: &vel,
            theta: None,
            contact: None,
        };
        let e = Eulerian::default().initialize(&ctx).expect_err("refused");
        assert!(e.starts_with("region `Bodies([...])` (disk) needs a Lagrangian frame"), "{e}");
        assert!(e.contains("direct_forcing"), "{e}");
    }

    #[test]
    fn limiters_follow_their_formulas() {
        let (a, b) = (1.0, 3.0);
        assert_eq!(Limiter::Mc.slope(a, b), 2.0);
        assert_eq!(Limiter::Minmod.slope(a, b), 1.0);
        assert_eq!(Limiter::VanLeer.slope(a, b), 1.5);
        assert_eq!(Limiter::None.slope(a, b), 2.0);
        assert_eq!(Limiter::Mc.slope(-1.0, -3.0), -2.0);
        for l in [Limiter::Mc, Limiter::Minmod, Limiter::VanLeer] {
            assert_eq!(l.slope(1.0, -2.0), 0.0, "{l:?} at an extremum");
            assert_eq!(l.slope(0.0, 2.0), 0.0, "{l:?} next to a plateau");
        }
    }

    #[test]
    fn parameters_are_registered_and_checked() {
        use multifield_core::registry::build_frame;
        let f = build_frame("eulerian", &serde_json::json!({"limiter": "van_leer"}), "f").unwrap();
        let defaults = serde_json::json!({"diffusion": "crank_nicolson", "max_diffusion_number": 2.0});
        let with = |limiter: &str| {
            let mut p = defaults.clone();
            p["limiter"] = limiter.into();
            p
        };
        assert_eq!(f.params(), with("van_leer"));
        assert!(!f.is_lagrangian());
        let f = build_frame("eulerian", &serde_json::Value::Null, "f").unwrap();
        assert_eq!(f.params(), with("mc"));
        let e = build_frame("eulerian", &serde_json::json!({"max_diffusion_number": 0.0}), "f").err().unwrap();
        assert!(e.to_string().contains("max_diffusion_number 0: must be positive"), "{e}");
        let e = build_frame("eulerian", &serde_json::json!({"limitr": "mc"}), "f").err().unwrap().to_string();
        assert!(e.contains("limitr") && e.contains("limiter"), "{e}");
        let e = build_frame("eulerian", &serde_json::json!({"limiter": "superbee"}), "f").err().unwrap().to_string();
        assert!(e.contains("superbee") && e.contains("van_leer"), "{e}");
    }

    /// A uniform stream is an exact steady solution of the flux form.
    #[test]
    fn uniform_stream_is_kept_exactly() {
        let g = Grid::new(8, 6, 0.25, Vector::new(-1.0, 2.0));
        let bc = periodic();
        let mut e = frame(Limiter::Mc, &g, &bc, &Region::All, &InitialVelocity::Uniform([0.3, -0.2]));
        let s = run(&mut e, &g, &bc, 0.1, 3);
        assert!(s.velocity.u.iter().all(|&u| u == 0.3) && s.velocity.v.iter().all(|&v| v == -0.2));
        let m = e.momentum();
        let mass = 2.0 * 2.0 * 1.5;
        assert!((m.x - 0.3 * mass).abs() < 1e-12 && (m.y + 0.2 * mass).abs() < 1e-12, "{m:?}");
        assert!((e.kinetic_energy() - 0.5 * mass * 0.13).abs() < 1e-12);
        assert!((e.mass() - mass).abs() < 1e-12);
    }

    /// A block of θ carried diagonally through a periodic box: mass is conserved to
    /// round-off and the limited scheme creates no new extrema.
    #[test]
    fn theta_transport_is_conservative_and_bounded() {
        let g = Grid::new(32, 32, 1.0 / 32.0, Vector::zeros());
        let bc = periodic();
        let region = Region::Rectangle { min: [0.2, 0.3], max: [0.55, 0.6] };
        for lim in [Limiter::Mc, Limiter::Minmod, Limiter::VanLeer] {
            let mut e = frame(lim, &g, &bc, &region, &InitialVelocity::Uniform([1.0, 0.5]));
            let m0 = e.mass();
            run(&mut e, &g, &bc, 0.3 * g.h, 40);
            let (lo, hi) = e.theta().iter().fold((1.0 as Real, 0.0 as Real), |(a, b), &t| (a.min(t), b.max(t)));
            assert!(((e.mass() - m0) / m0).abs() < 1e-13, "{lim:?}: mass {} → {}", m0, e.mass());
            assert!(lo >= -1e-14 && hi <= 1.0 + 1e-14, "{lim:?}: θ in [{lo}, {hi}]");
        }
    }

    /// A smooth θ = ½ + ¼ sin 2πx carried once around a periodic box returns to itself
    /// with a second-order error (unlimited), close to it with the MC limiter.
    #[test]
    fn theta_transport_is_second_order() {
        let mut orders = vec![];
        for lim in [Limiter::None, Limiter::Mc] {
            let mut errs = vec![];
            for n in [32, 64] {
                let g = Grid::new(n, 2, 1.0 / n as Real, Vector::zeros());
                let bc = periodic();
                let mut e = frame(lim, &g, &bc, &Region::All, &InitialVelocity::Uniform([1.0, 0.0]));
                for j in 0..2 {
                    for i in 0..n {
                        let x = g.cell_center(i, j).x;
                        e.work.theta[g.cell(i, j)] = 0.5 + 0.25 * (2.0 * std::f64::consts::PI * x).sin();
                    }
                }
                let t0 = e.theta().to_vec();
                let steps = 2 * n;
                run(&mut e, &g, &bc, 1.0 / steps as Real, steps);
                let l1: Real = e.theta().iter().zip(&t0).map(|(a, b)| (a - b).abs()).sum::<Real>() / t0.len() as Real;
                errs.push(l1);
            }
            eprintln!("θ transport, {lim:?}: L1 errors {errs:?} on 32, 64 cells");
            orders.push((errs[0] / errs[1]).log2());
        }
        eprintln!("θ transport orders (none, mc): {orders:.2?}");
        assert!(orders[0] > 1.9, "unlimited order {orders:?}");
        assert!(orders[1] > 1.6, "MC order {orders:?}");
    }

    /// The parallel loops give the same bits for any number of threads.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let g = Grid::new(70, 40, 0.1, Vector::zeros());
        let bc = Boundaries {
            top: Boundary::Velocity { velocity: [1.0, 0.0], profile: multifield_core::boundary::Profile::Parabolic },
            ..Boundaries::default()
        };
        let region = Region::Disk { center: [3.0, 2.0], radius: 1.0 };
        let vel = InitialVelocity::RigidRotation { center: [3.5, 2.0], angular_velocity: 0.3 };
        let result = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut e = frame(Limiter::Mc, &g, &bc, &region, &vel);
                let s = run(&mut e, &g, &bc, 0.02, 5);
                (s.velocity, e.theta().to_vec())
            })
        };
        let (v1, t1) = result(1);
        let (v3, t3) = result(3);
        let bits = |x: &[Real]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&v1.u), bits(&v3.u));
        assert_eq!(bits(&v1.v), bits(&v3.v));
        assert_eq!(bits(&t1), bits(&t3));
    }
}
