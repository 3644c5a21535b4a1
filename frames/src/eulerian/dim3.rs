//! The kernels of the Eulerian frame in 3D (issue 17, P1): the same scheme as the 2D
//! kernels of `eulerian.rs` (conservative limited advection of every velocity component on
//! its staggered control volume and of θ, the same ghost rules), written over the axes.
//!
//! Instead of padded copies, a value outside its lattice is made on demand from the ghost
//! rules of its line ([`Lines::get`]): every flux of the scheme reads nodes that are outside
//! along one axis at most. Each flux is computed where it is needed by both control volumes
//! that share it, by the same function of the same values: the same bits, so the scheme
//! stays exactly conservative. The rate of a component sums its directions in axis order,
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

/// The node `at` of a lattice as a signed index.
#[inline]
fn signed(at: Index) -> At {
    at.map(|i| i as isize)
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
        }
    }

    /// The advection rate −A(u) = −∇·(u ⊗ u) of the velocity `vel` on every face, into
    /// `self.rate`.
    pub(super) fn advect_rate(&mut self, vel: &FaceVelocity, bc: &Boundaries, lim: Limiter) {
        let (grid, h, periodic) = (&self.grid(), self.h, self.periodic);
        let lines: [Lines; 3] = std::array::from_fn(|c| Lines::component(grid, bc, periodic, &vel[c], c));
        for c in AXES {
            let lattice = Lattice::face(c);
            let row = grid.shape(lattice)[0];
            let lines = &lines;
            self.rate[c].par_chunks_mut(row).enumerate().for_each(|(r, out)| {
                for (i, rate) in out.iter_mut().enumerate() {
                    let at = signed(grid.node(lattice, r * row + i));
                    let dir = |d: usize| {
                        (momentum_flux(lines, lim, c, d, at), momentum_flux(lines, lim, c, d, moved(at, d, -1)))
                    };
                    let ((x1, x0), (y1, y0), (z1, z0)) = (dir(0), dir(1), dir(2));
                    *rate = -(x1 - x0 + y1 - y0 + z1 - z0) / h;
                }
            });
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
        self.theta_rate.par_chunks_mut(n[0]).enumerate().for_each(|(r, out)| {
            for (i, rate) in out.iter_mut().enumerate() {
                let at = signed(grid.node(Lattice::Cell, r * n[0] + i));
                let dir = |d: usize| (flux(d, at), flux(d, moved(at, d, -1)));
                let ((x1, x0), (y1, y0), (z1, z0)) = (dir(0), dir(1), dir(2));
                *rate = -(x1 - x0 + y1 - y0 + z1 - z0) / h;
            }
        });
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
