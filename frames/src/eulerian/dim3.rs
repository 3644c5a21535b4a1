//! The kernels of the Eulerian frame in 3D (issue 17, P1): the same scheme as the 2D
//! kernels of `eulerian.rs` (conservative limited advection of every velocity component on
//! its staggered control volume and of θ, the same ghost rules), written over the axes.
//!
//! The values outside a lattice come from the ghost rules of its lines ([`Lines::get`]),
//! made once per call into a copy with two ghost layers on every side ([`Padded`]), so the
//! flux loops read plain memory rows: every flux of the scheme reads nodes that are outside
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

/// Ghost layers on each side of a [`Padded`] array (the scheme reads two nodes beyond a side).
const G: usize = 2;

/// A lattice array with two ghost layers on every side, the ghosts made once per call from
/// the rules of [`Lines::get`], so that the flux loops read plain memory: each node holds
/// the value `Lines::get` gives it, the same bits. Nodes outside along two or more axes are
/// never read by the scheme and hold NaN (a read would show in every result).
#[derive(Clone, Debug, Default)]
pub(super) struct Padded {
    data: Vec<Real>,
    /// Shape with the ghosts (the lattice's shape + 2 G along each axis).
    outer: Index,
}

impl Padded {
    /// Position in `data` of node `at` of the lattice (−G ≤ at[d] < shape[d] + G).
    #[inline]
    fn index(&self, at: At) -> usize {
        let p = |d: usize| (at[d] + G as isize) as usize;
        p(0) + self.outer[0] * (p(1) + self.outer[1] * p(2))
    }

    /// The step in `data` of one node along `d`.
    #[inline]
    fn stride(&self, d: usize) -> usize {
        match d {
            0 => 1,
            1 => self.outer[0],
            _ => self.outer[0] * self.outer[1],
        }
    }

    /// Copies the lattice of `lines` and makes its ghosts (rows along x in parallel).
    fn fill(&mut self, lines: &Lines) {
        let s = lines.shape;
        let o = s.map(|v| v + 2 * G);
        self.outer = o;
        self.data.resize(o[0] * o[1] * o[2], 0.0);
        let inside = |v: isize, d: usize| v >= 0 && v < s[d] as isize;
        self.data.par_chunks_mut(o[0]).enumerate().for_each(|(row, out)| {
            let (j, k) = ((row % o[1]) as isize - G as isize, (row / o[1]) as isize - G as isize);
            let (jin, kin) = (inside(j, 1), inside(k, 2));
            let ends = (0..G).chain(G + s[0]..o[0]);
            if jin && kin {
                let start = s[0] * (j as usize + s[1] * k as usize);
                out[G..G + s[0]].copy_from_slice(&lines.q[start..start + s[0]]);
                for i in ends {
                    out[i] = lines.get([i as isize - G as isize, j, k]);
                }
            } else if jin || kin {
                for (i, v) in out.iter_mut().enumerate().skip(G).take(s[0]) {
                    *v = lines.get([i as isize - G as isize, j, k]);
                }
                for i in ends {
                    out[i] = Real::NAN;
                }
            } else {
                out.fill(Real::NAN);
            }
        });
    }
}

/// The momentum fluxes of component `c` in direction `d` from the base nodes `b0 + i e₀`
/// (i = 0 … out.len() − 1) to `+ e_d` of its lattice, as [`Lines`] would give them: through a
/// cell centre for `d == c` (advecting velocity the mean of the two faces), through an edge
/// otherwise (advecting velocity the mean of the two `d`-faces on either side along `c`),
/// times the limited upwind reconstruction.
#[inline]
fn momentum_fluxes(pads: &[Padded; 3], lim: Limiter, c: usize, d: usize, b0: At, out: &mut [Real]) {
    let q = &pads[c];
    let len = out.len();
    let st = q.stride(d);
    // the transported component at b − e_d, b, b + e_d, b + 2 e_d
    let i0 = q.index(b0);
    let (qm, q0, q1, q2) = (
        &q.data[i0 - st..i0 - st + len],
        &q.data[i0..i0 + len],
        &q.data[i0 + st..i0 + st + len],
        &q.data[i0 + 2 * st..i0 + 2 * st + len],
    );
    if d == c {
        for (i, f) in out.iter_mut().enumerate() {
            let vel = 0.5 * (q0[i] + q1[i]);
            *f = vel * lim.face_value(qm[i], q0[i], q1[i], q2[i], vel);
        }
    } else {
        // the d-faces at m − e_c and m, m = b + e_d
        let p = &pads[d];
        let m = p.index(moved(b0, d, 1));
        let (vb, va) = (&p.data[m - p.stride(c)..m - p.stride(c) + len], &p.data[m..m + len]);
        for (i, f) in out.iter_mut().enumerate() {
            let vel = 0.5 * (vb[i] + va[i]);
            *f = vel * lim.face_value(qm[i], q0[i], q1[i], q2[i], vel);
        }
    }
}

/// The shape of the fluxes in direction `d` of a lattice of shape `shape`: one more node
/// along `d` (the flux between nodes `b` and `b + e_d` for `b[d]` = −1 … shape[d] − 1, stored
/// at `b + e_d`).
fn flux_shape(shape: Index, d: usize) -> Index {
    let mut s = shape;
    s[d] += 1;
    s
}

/// Fills `fluxes[d]` for every direction `d` of a lattice of shape `shape`, a row along x
/// at a time (in parallel): `row(d, b0, out)` writes the fluxes from the base nodes
/// `b0 + i e₀` to `+ e_d`, stored at `b + e_d`. Each flux is computed once.
fn fill_fluxes(fluxes: &mut [Vec<Real>; 3], shape: Index, row: impl Fn(usize, At, &mut [Real]) + Sync) {
    for (d, out) in fluxes.iter_mut().enumerate() {
        let s = flux_shape(shape, d);
        out.resize(s[0] * s[1] * s[2], 0.0);
        let row = &row;
        out.par_chunks_mut(s[0]).enumerate().for_each(|(r, out)| {
            let (j, k) = ((r % s[1]) as isize, (r / s[1]) as isize);
            // stored at b + e_d
            row(d, moved([0, j, k], d, -1), out);
        });
    }
}

/// `out[at] = −((F₀(at) − F₀(at − e₀)) + F₁(at) − F₁(at − e₁) + F₂(at) − F₂(at − e₂))/h` on a
/// lattice of shape `shape`, F_d(b) the flux between `b` and `b + e_d` (the 2D expression
/// with the z terms appended).
fn divergence(fluxes: &[Vec<Real>; 3], shape: Index, h: Real, out: &mut [Real]) {
    let s: [Index; 3] = std::array::from_fn(|d| flux_shape(shape, d));
    let nx = shape[0];
    // the row (j, k) of the flux lattice of direction d
    let row = |d: usize, j: usize, k: usize| {
        let start = s[d][0] * (j + s[d][1] * k);
        &fluxes[d][start..start + s[d][0]]
    };
    out.par_chunks_mut(nx).enumerate().for_each(|(r, out)| {
        let (j, k) = (r % shape[1], r / shape[1]);
        // F_d(at) is stored at at + e_d, F_d(at − e_d) at at
        let fx = row(0, j, k);
        let (y0, y1) = (row(1, j, k), row(1, j + 1, k));
        let (z0, z1) = (row(2, j, k), row(2, j, k + 1));
        for (i, rate) in out.iter_mut().enumerate() {
            let (x1, x0) = (fx[i + 1], fx[i]);
            *rate = -(x1 - x0 + y1[i] - y0[i] + z1[i] - z0[i]) / h;
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
            grid: grid.clone(),
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
            padded: Default::default(),
            padded_theta: Padded::default(),
            fluxes: Default::default(),
        }
    }

    /// The advection rate −A(u) = −∇·(u ⊗ u) of the velocity `vel` on every face, into
    /// `self.rate`.
    pub(super) fn advect_rate(&mut self, vel: &FaceVelocity, bc: &Boundaries, lim: Limiter) {
        let (grid, h, periodic) = (&self.grid(), self.h, self.periodic);
        for (c, pad) in self.padded.iter_mut().enumerate() {
            pad.fill(&Lines::component(grid, bc, periodic, &vel[c], c));
        }
        for c in AXES {
            let shape = grid.shape(Lattice::face(c));
            let pads = &self.padded;
            fill_fluxes(&mut self.fluxes, shape, |d, b0, out| momentum_fluxes(pads, lim, c, d, b0, out));
            divergence(&self.fluxes, shape, h, &mut self.rate[c]);
        }
    }

    /// −∇·(θu) per cell from `theta` and the face velocity in `self.velocity`, into
    /// `self.theta_rate`.
    pub(super) fn theta_rate(&mut self, theta: &[Real], bc: &Boundaries, lim: Limiter) {
        let (grid, h) = (&self.grid(), self.h);
        self.padded_theta.fill(&Lines::cells(grid, bc, self.periodic, theta));
        let (t, vel) = (&self.padded_theta, &self.velocity);
        let n = grid.n();
        // the fluxes through the d-faces between the cells `b` and `b + e_d`, b = b0 + i e₀:
        // the flux lattice of direction d is the d-face lattice (the flux stored at the face)
        let row = |d: usize, b0: At, out: &mut [Real]| {
            let len = out.len();
            let face = moved(b0, d, 1);
            let s = grid.shape(Lattice::face(d));
            let start = face[0] as usize + s[0] * (face[1] as usize + s[1] * face[2] as usize);
            let u = &vel[d][start..start + len];
            let (i0, st) = (t.index(b0), t.stride(d));
            let (qm, q0, q1, q2) = (
                &t.data[i0 - st..i0 - st + len],
                &t.data[i0..i0 + len],
                &t.data[i0 + st..i0 + st + len],
                &t.data[i0 + 2 * st..i0 + 2 * st + len],
            );
            for (i, f) in out.iter_mut().enumerate() {
                *f = u[i] * lim.face_value(qm[i], q0[i], q1[i], q2[i], u[i]);
            }
        };
        fill_fluxes(&mut self.fluxes, n, row);
        divergence(&self.fluxes, n, h, &mut self.theta_rate);
    }

    /// Σ over the faces of each lattice of f(face mass, velocity component), in storage order.
    /// The face mass is w θ_f ρ h³: θ_f the mean of the two neighbouring cells (wrapped if
    /// periodic), w the share of its control volume inside the domain (½ on a non-periodic
    /// side; 0 on the periodic copy of face 0, counted once), as the 2D `xface_weight`.
    pub(super) fn face_sums(&self, f: impl Fn(Real, Real) -> Real) -> [Real; 3] {
        use multifield_core::exact::{reduce, row_groups, ExactSum, Sums, GROUP};
        let m0 = self.density * self.h * self.h * self.h;
        let n = self.n;
        let theta = &self.theta;
        let sums: [ExactSum; 3] = std::array::from_fn(|a| {
            let mut shape = n;
            shape[a] += 1;
            let (na, periodic, vel) = (n[a], self.periodic[a], &self.velocity[a]);
            let mut sum = ExactSum::new();
            // the terms of a row along x, then by the reduction rule (docs/design/mpi.md
            // §3): row groups of 32 faces (the high face n[0] alone) summed in order, the
            // groups' values added exactly
            let mut terms = vec![0.0; shape[0]];
            for z in 0..shape[2] {
                for y in 0..shape[1] {
                    let row = shape[0] * (y + shape[1] * z);
                    let vel = &vel[row..row + shape[0]];
                    if a == 0 {
                        let cells = &theta[n[0] * (y + n[1] * z)..][..n[0]];
                        for (x, term) in terms.iter_mut().enumerate() {
                            let (t, w) = if x > 0 && x < na {
                                (0.5 * (cells[x - 1] + cells[x]), 1.0)
                            } else if periodic {
                                // face n repeats face 0: count it once
                                (0.5 * (cells[na - 1] + cells[0]), if x == 0 { 1.0 } else { 0.0 })
                            } else {
                                (cells[if x == 0 { 0 } else { na - 1 }], 0.5)
                            };
                            *term = f(w * t * m0, vel[x]);
                        }
                    } else {
                        // the rows of cells at i − 1 and i along a (i = y or z)
                        let i = [y, z][a - 1];
                        let cells = |c: usize| {
                            let (y, z) = if a == 1 { (c, z) } else { (y, c) };
                            &theta[n[0] * (y + n[1] * z)..][..n[0]]
                        };
                        if i > 0 && i < na {
                            let (lo, hi) = (cells(i - 1), cells(i));
                            for (x, term) in terms.iter_mut().enumerate() {
                                *term = f(1.0 * (0.5 * (lo[x] + hi[x])) * m0, vel[x]);
                            }
                        } else if periodic {
                            let (lo, hi) = (cells(na - 1), cells(0));
                            let w = if i == 0 { 1.0 } else { 0.0 };
                            for (x, term) in terms.iter_mut().enumerate() {
                                *term = f(w * (0.5 * (lo[x] + hi[x])) * m0, vel[x]);
                            }
                        } else {
                            let t = cells(if i == 0 { 0 } else { na - 1 });
                            for (x, term) in terms.iter_mut().enumerate() {
                                *term = f(0.5 * t[x] * m0, vel[x]);
                            }
                        }
                    }
                    for g in row_groups(shape[0], n[0], GROUP) {
                        sum.add(terms[g].iter().sum());
                    }
                }
            }
            sum
        });
        reduce(&Sums(sums))
    }
}
