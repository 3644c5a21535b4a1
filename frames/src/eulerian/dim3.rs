//! The kernels of the Eulerian frame in 3D (issue 17, P1): the same scheme as the 2D
//! kernels of `eulerian.rs` (conservative limited advection of every velocity component on
//! its staggered control volume and of θ, the same ghost rules), written over the axes.
//!
//! Instead of padded copies, a value outside its lattice is made on demand from the ghost
//! rules of its line ([`Lines::get`]): every flux of the scheme reads nodes that are outside
//! along one axis at most. Each flux is computed once, into an array per direction, and the
//! two control volumes that share it take the same value: the scheme is exactly
//! conservative. The rate of a component sums its directions in axis order,
//! `−((F₀⁺ − F₀⁻) + F₁⁺ − F₁⁻ + F₂⁺ − F₂⁻)/h`, the 2D expression with the z terms appended.
//! Every loop writes disjoint nodes: the same bits on any number of threads.

use super::{normal_rule, tangential_rule, Limiter, Rule, Work};
use multifield_core::boundary::{along, tangential_axes, Boundaries, Side};
use multifield_core::grid::{FaceVelocity, Grid, Lattice};
use multifield_core::math::{Index, Real, Vector, AXES};
use rayon::prelude::*;

/// A node of a lattice that may lie outside it (by up to two nodes along an axis).
type At = [isize; 3];

/// One lattice array with the ghost rules of its lines along each axis.
struct Lines<'a> {
    q: &'a [Real],
    shape: Index,
    /// Cells along each axis (for the fractions along a moving wall).
    n: Index,
    /// The velocity component the array holds (`None` for a cell quantity).
    component: Option<usize>,
    /// Ghost rules (low, high) along each axis.
    rules: [(Rule, Rule); 3],
    bc: &'a Boundaries,
}

impl Lines<'_> {
    /// The velocity component `c` on its face lattice.
    fn component<'a>(grid: &Grid, bc: &'a Boundaries, periodic: [bool; 3], q: &'a [Real], c: usize) -> Lines<'a> {
        let n = grid.n();
        let rules = std::array::from_fn(|d| {
            let rule = |high: bool| {
                let side = Side::of(d, high);
                if d == c {
                    normal_rule(bc, side, n[d], periodic[d])
                } else {
                    tangential_rule(side, n[d], periodic[d])
                }
            };
            (rule(false), rule(true))
        });
        Lines { q, shape: grid.shape(Lattice::face(c)), n, component: Some(c), rules, bc }
    }

    /// A cell quantity (θ): periodic wrap or even reflection.
    fn cells<'a>(grid: &Grid, bc: &'a Boundaries, periodic: [bool; 3], q: &'a [Real]) -> Lines<'a> {
        let n = grid.n();
        let rules = std::array::from_fn(|d| {
            let r = if periodic[d] { Rule::Wrap(n[d]) } else { Rule::Mirror };
            (r, r)
        });
        Lines { q, shape: n, n, component: None, rules, bc }
    }

    /// The value at `at`, made from the ghost rules along the first axis on which `at` lies
    /// outside the lattice (as the 2D `ghosts`).
    fn get(&self, at: At) -> Real {
        let s = self.shape;
        let Some(d) = (0..3).find(|&d| at[d] < 0 || at[d] >= s[d] as isize) else {
            return self.q[at[0] as usize + s[0] * (at[1] as usize + s[1] * at[2] as usize)];
        };
        let len = s[d] as isize;
        let with = |i: isize| {
            let mut m = at;
            m[d] = i;
            self.get(m)
        };
        if at[d] < 0 {
            let k = -at[d];
            match self.rules[d].0 {
                Rule::Wrap(p) => with(at[d] + p as isize),
                Rule::Odd => 2.0 * with(0) - with(k),
                Rule::Flat => with(0),
                Rule::Tangential(side) => self.ghost(side, at, with(k - 1)),
                Rule::Mirror => with(k - 1),
            }
        } else {
            let k = at[d] - (len - 1);
            match self.rules[d].1 {
                Rule::Wrap(p) => with(at[d] - p as isize),
                Rule::Odd => 2.0 * with(len - 1) - with(len - 1 - k),
                Rule::Flat => with(len - 1),
                Rule::Tangential(side) => self.ghost(side, at, with(len - k)),
                Rule::Mirror => with(len - k),
            }
        }
    }

    /// The boundary's ghost of the tangential component beyond `side`, from the value
    /// inside, at the fraction along the side of the node (the component's own axis at
    /// the face, the others at the cell centre, clamped as in 2D).
    fn ghost(&self, side: Side, at: At, inside: Real) -> Real {
        let c = self.component.expect("a tangential ghost rule on a velocity component");
        let s = tangential_axes(side.axis()).map(|t| {
            let x = if t == c { at[t] as Real } else { at[t] as Real + 0.5 };
            (x / self.n[t] as Real).clamp(0.0, 1.0)
        });
        self.bc.ghost(side, c, inside, along(s))
    }
}

/// `at` moved by `k` nodes along `d`.
#[inline]
fn moved(mut at: At, d: usize, k: isize) -> At {
    at[d] += k;
    at
}

/// The momentum flux of component `c` in direction `d` between the nodes `base` and
/// `base + e_d` of its lattice: through a cell centre for `d == c` (advecting velocity the
/// mean of the two faces), through an edge otherwise (advecting velocity the mean of the
/// two `d`-faces on either side along `c`), times the limited upwind reconstruction.
#[inline]
fn momentum_flux(lines: &[Lines; 3], lim: Limiter, c: usize, d: usize, base: At) -> Real {
    let q = &lines[c];
    let step = |k: isize| q.get(moved(base, d, k));
    let vel = if d == c {
        0.5 * (step(0) + step(1))
    } else {
        let m = moved(base, d, 1);
        0.5 * (lines[d].get(moved(m, c, -1)) + lines[d].get(m))
    };
    vel * lim.face_value(step(-1), step(0), step(1), step(2), vel)
}

/// The shape of the fluxes in direction `d` of a lattice of shape `shape`: one more node
/// along `d` (the flux between nodes `b` and `b + e_d` for `b[d]` = −1 … shape[d] − 1, stored
/// at `b + e_d`).
fn flux_shape(shape: Index, d: usize) -> Index {
    let mut s = shape;
    s[d] += 1;
    s
}

/// Fills `fluxes[d]` with `flux(d, b)` for every base node `b` of a lattice of shape `shape`
/// and direction `d` (rows along x in parallel): each flux computed once.
fn fill_fluxes(fluxes: &mut [Vec<Real>; 3], shape: Index, flux: impl Fn(usize, At) -> Real + Sync) {
    for (d, out) in fluxes.iter_mut().enumerate() {
        let s = flux_shape(shape, d);
        out.resize(s[0] * s[1] * s[2], 0.0);
        let flux = &flux;
        out.par_chunks_mut(s[0]).enumerate().for_each(|(row, out)| {
            let (j, k) = ((row % s[1]) as isize, (row / s[1]) as isize);
            for (i, f) in out.iter_mut().enumerate() {
                // stored at b + e_d
                let b = moved([i as isize, j, k], d, -1);
                *f = flux(d, b);
            }
        });
    }
}

/// `out[at] = −((F₀(at) − F₀(at − e₀)) + F₁(at) − F₁(at − e₁) + F₂(at) − F₂(at − e₂))/h` on a
/// lattice of shape `shape`, F_d(b) the flux between `b` and `b + e_d` (the 2D expression
/// with the z terms appended).
fn divergence(fluxes: &[Vec<Real>; 3], shape: Index, h: Real, out: &mut [Real]) {
    let s: [Index; 3] = std::array::from_fn(|d| flux_shape(shape, d));
    // F_d(at) (stored at at + e_d) and F_d(at − e_d) (stored at at)
    let index = |s: Index, at: [usize; 3]| at[0] + s[0] * (at[1] + s[1] * at[2]);
    out.par_chunks_mut(shape[0]).enumerate().for_each(|(row, out)| {
        let (j, k) = (row % shape[1], row / shape[1]);
        for (i, rate) in out.iter_mut().enumerate() {
            let at = [i, j, k];
            let pair = |d: usize| {
                let mut up = at;
                up[d] += 1;
                (fluxes[d][index(s[d], up)], fluxes[d][index(s[d], at)])
            };
            let ((x1, x0), (y1, y0), (z1, z0)) = (pair(0), pair(1), pair(2));
            *rate = -(x1 - x0 + y1 - y0 + z1 - z0) / h;
        }
    });
}

impl Work {
    /// The grid's indexing (at the origin: the kernels need no positions).
    fn grid(&self) -> Grid {
        Grid::from_cells(self.n, self.h, Vector::zeros())
    }

    pub(super) fn new(grid: &Grid, bc: &Boundaries, density: Real, fills_rest: bool) -> Self {
        Work {
            n: grid.n(),
            h: grid.h,
            density,
            periodic: bc.periodic_axes(),
            fills_rest,
            steps: 0,
            theta: vec![0.0; grid.n_cells()],
            velocity: FaceVelocity::zeros(grid),
            half: FaceVelocity::zeros(grid),
            viscous: FaceVelocity::zeros(grid),
            diffusion: None,
            rate: FaceVelocity::zeros(grid),
            theta1: vec![0.0; grid.n_cells()],
            theta_rate: vec![0.0; grid.n_cells()],
            fluxes: Default::default(),
        }
    }

    /// The advection rate −A(u) = −∇·(u ⊗ u) of the velocity `vel` on every face, into
    /// `self.rate`.
    pub(super) fn advect_rate(&mut self, vel: &FaceVelocity, bc: &Boundaries, lim: Limiter) {
        let (grid, h, periodic) = (&self.grid(), self.h, self.periodic);
        let lines: [Lines; 3] = std::array::from_fn(|c| Lines::component(grid, bc, periodic, &vel[c], c));
        for c in AXES {
            let shape = grid.shape(Lattice::face(c));
            let lines = &lines;
            fill_fluxes(&mut self.fluxes, shape, |d, base| momentum_flux(lines, lim, c, d, base));
            divergence(&self.fluxes, shape, h, &mut self.rate[c]);
        }
    }

    /// −∇·(θu) per cell from `theta` and the face velocity in `self.velocity`, into
    /// `self.theta_rate`.
    pub(super) fn theta_rate(&mut self, theta: &[Real], bc: &Boundaries, lim: Limiter) {
        let (grid, h) = (&self.grid(), self.h);
        let t = Lines::cells(grid, bc, self.periodic, theta);
        let vel = &self.velocity;
        let n = grid.n();
        // the flux through the d-face between the cells `base` and `base + e_d`
        let flux = |d: usize, base: At| {
            let face = moved(base, d, 1);
            let s = grid.shape(Lattice::face(d));
            let u = vel[d][face[0] as usize + s[0] * (face[1] as usize + s[1] * face[2] as usize)];
            let q = |k: isize| t.get(moved(base, d, k));
            u * lim.face_value(q(-1), q(0), q(1), q(2), u)
        };
        fill_fluxes(&mut self.fluxes, n, flux);
        divergence(&self.fluxes, n, h, &mut self.theta_rate);
    }

    /// Volume fraction on the face `at` normal to `a` (mean of the neighbours, wrapped if
    /// periodic) and the share of its control volume inside the domain (½ on a
    /// non-periodic side), as the 2D `xface_weight`.
    fn face_weight(&self, a: usize, at: Index) -> (Real, Real) {
        let g = &self.grid();
        let n = g.n()[a];
        let t = |c: usize| {
            let mut cell = at;
            cell[a] = c;
            self.theta[g.index(Lattice::Cell, cell)]
        };
        let i = at[a];
        if i > 0 && i < n {
            (0.5 * (t(i - 1) + t(i)), 1.0)
        } else if self.periodic[a] {
            // face n repeats face 0: count it once
            (0.5 * (t(n - 1) + t(0)), if i == 0 { 1.0 } else { 0.0 })
        } else {
            (t(if i == 0 { 0 } else { n - 1 }), 0.5)
        }
    }

    /// Σ over the faces of each lattice of f(face mass, velocity component), in storage order.
    pub(super) fn face_sums(&self, f: impl Fn(Real, Real) -> Real) -> [Real; 3] {
        let m0 = self.density * self.h * self.h * self.h;
        std::array::from_fn(|a| {
            let mut sum = 0.0;
            for (k, at) in self.grid().nodes(Lattice::face(a)) {
                let (t, w) = self.face_weight(a, at);
                sum += f(w * t * m0, self.velocity[a][k]);
            }
            sum
        })
    }
}
