//! Implicit viscosity on the MAC faces: the 5-point (7-point in 3D) Laplacian of a velocity
//! component on its face lattice, with
//! the boundary ghosts of the explicit `newtonian` stencil, and the solve of
//!
//! ```text
//!   (I − c L) x = r,    c = (Δt/2) ν / h²,  L u = Σ_neighbours u − 2·DIM u
//! ```
//!
//! for the Crank–Nicolson (and midpoint backward-Euler) steps of the Eulerian frame.
//!
//! Neighbours of a face are other faces of its lattice (wrapped on periodic sides; face n of
//! a periodic lattice is face 0), a fixed face (wall or inflow; its value is known), or a
//! ghost half a cell beyond a wall, `α u + β`: −u on a no-slip wall, u on a free-slip wall,
//! outflow or along the normal at an outflow, 2 u_w − u on a moving wall. The fixed faces
//! and the periodic copies are not unknowns. The operator on the unknowns is symmetric and
//! strictly diagonally dominant (diagonal 1 + c (2·DIM − Σα) ≥ 1 + c · #faces), so a
//! Jacobi-preconditioned conjugate gradient converges in a few iterations for the usual
//! c ≲ 1. Every loop writes disjoint faces and every dot product follows the reduction rule
//! of docs/design/mpi.md §3 (row groups of 32 faces along x, the high face n alone, added
//! exactly): the same bits on any number of threads.

use multifield_core::boundary::{Along, Boundaries, FaceNeighbour, Side};
use multifield_core::exact::{lanes_dot, Sums};
use multifield_core::grid::{Grid, Lattice};
use multifield_core::math::{Index, Real, DIM, SIDES};
use multifield_core::part::RowGroups;
use rayon::prelude::*;

/// One of the neighbours of a face in the Laplacian (four in 2D, six in 3D).
#[derive(Clone, Copy, Debug)]
enum Neighbour {
    /// An unknown face of the lattice.
    Face(u32),
    /// A fixed face: its value is read from the array and is a constant of the solve.
    Known(u32),
    /// A ghost α u_self + β beyond a wall.
    Ghost(Real, Real),
}

/// The Laplacian of one face lattice and the work space of its solves.
#[derive(Clone, Debug, Default)]
struct LatticeOperator {
    /// Whether each face is an unknown.
    active: Vec<bool>,
    /// Whether each face is an unknown whose neighbours are all unknown faces of the lattice
    /// one step away along each axis (no wrap, no wall): its stencil reads `u[k ∓ stride]`
    /// without the neighbour list (the same sum in the same order).
    plain: Vec<bool>,
    /// The step in storage of one face along each axis.
    strides: [usize; DIM],
    /// Faces in a row along x (the lattice's first extent).
    row: usize,
    /// The owned faces' row groups of the reductions (docs/design/mpi.md §3).
    groups: Option<RowGroups>,
    /// The grid (its part of a decomposed domain: the halo exchange and the reductions).
    grid: Option<Grid>,
    lattice: Option<Lattice>,
    /// The neighbours of each face, in the order of [`Side::ALL`] (unused for inactive faces).
    neighbours: Vec<[Neighbour; SIDES]>,
    /// Periodic copies: (copy, master) pairs, set after each solve.
    copies: Vec<(usize, usize)>,
    r: Vec<Real>,
    z: Vec<Real>,
    p: Vec<Real>,
    q: Vec<Real>,
    b: Vec<Real>,
    inverse_diagonal: Vec<Real>,
}

/// Chunk length of the ordered reductions.
const CHUNK: usize = 4096;

/// The centre weight of the Laplacian: 4 (5-point) in 2D, 6 (7-point) in 3D.
const CENTRE: Real = (2 * DIM) as Real;

impl LatticeOperator {
    /// The operator of the faces normal to `axis` (the component `axis`).
    fn new(grid: &Grid, bc: &Boundaries, axis: usize) -> Self {
        let a = axis;
        let lattice = Lattice::face(a);
        let n = grid.n();
        let periodic = bc.periodic(a);
        let count = grid.n_faces(a);
        let mut active = vec![true; count];
        let mut copies = Vec::new();
        for (k, at) in grid.nodes(lattice) {
            let fixed = bc.face_fixed(grid, a, at[a]);
            let copy = periodic && at[a] == n[a];
            if copy {
                let mut master = at;
                master[a] = 0;
                copies.push((k, grid.index(lattice, master)));
            }
            active[k] = !(fixed || copy);
        }
        // face `m` of the lattice (face n of a periodic lattice is face 0)
        let face = |mut m: Index| {
            if periodic && m[a] == n[a] {
                m[a] = 0;
            }
            let k = grid.index(lattice, m) as u32;
            if active[k as usize] {
                Neighbour::Face(k)
            } else {
                Neighbour::Known(k)
            }
        };
        let ghost = |side: Side, s: Along| {
            let beta = bc.ghost(side, a, 0.0, s);
            Neighbour::Ghost(bc.ghost(side, a, 1.0, s) - beta, beta)
        };
        let mut neighbours = vec![[Neighbour::Ghost(0.0, 0.0); SIDES]; count];
        for (k, at) in grid.nodes(lattice) {
            if !active[k] {
                continue;
            }
            neighbours[k] = Side::ALL.map(|side| match bc.face_neighbour(grid, a, at, side) {
                FaceNeighbour::Face(m) => face(m),
                FaceNeighbour::Itself => Neighbour::Ghost(1.0, 0.0),
                FaceNeighbour::Ghost(s) => ghost(side, s),
            });
        }
        let shape = grid.shape(lattice);
        let strides: [usize; DIM] = std::array::from_fn(|d| shape[..d].iter().product());
        let plain = (0..count)
            .map(|k| {
                active[k]
                    && Side::ALL.iter().zip(&neighbours[k]).all(|(side, nb)| {
                        let st = strides[side.axis()];
                        let m = if side.high() { k.checked_add(st) } else { k.checked_sub(st) };
                        matches!((nb, m), (Neighbour::Face(i), Some(m)) if *i as usize == m)
                    })
            })
            .collect();
        LatticeOperator {
            active,
            plain,
            strides,
            row: shape[0],
            groups: Some(grid.groups(lattice)),
            grid: Some(grid.clone()),
            lattice: Some(lattice),
            neighbours,
            copies,
            ..Default::default()
        }
    }

    /// The stencil's view of the operator.
    fn stencils(&self) -> Stencils<'_> {
        Stencils { plain: &self.plain, strides: self.strides, neighbours: &self.neighbours }
    }

    /// `out = L u` on the unknown faces (0 elsewhere), with the fixed faces' values from `u`.
    fn laplacian(&self, u: &[Real], out: &mut [Real]) {
        let (act, st) = (&self.active, self.stencils());
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, out)| {
            for (o, y) in out.iter_mut().enumerate() {
                let k = c * CHUNK + o;
                *y = if act[k] { st.sum(k, u, true) - CENTRE * u[k] } else { 0.0 };
            }
        });
    }

    /// `out = (I − c L₀) x` on the unknown faces: the linear part of the operator (fixed
    /// faces and ghost offsets β left out), 0 elsewhere.
    fn apply(&self, c: Real, x: &[Real], out: &mut [Real]) {
        let (act, st) = (&self.active, self.stencils());
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(ch, out)| {
            for (o, y) in out.iter_mut().enumerate() {
                let k = ch * CHUNK + o;
                *y = if act[k] { x[k] - c * (st.sum(k, x, false) - CENTRE * x[k]) } else { 0.0 };
            }
        });
    }

    /// The diagonal of `(I − c L₀)` at face `k`.
    fn diagonal(&self, c: Real, k: usize) -> Real {
        let alpha: Real =
            self.neighbours[k].iter().map(|n| if let Neighbour::Ghost(a, _) = n { *a } else { 0.0 }).sum();
        1.0 + c * (CENTRE - alpha)
    }

    /// Solves `(I − c L) x = rhs` for the unknown faces of `x` (the fixed faces of `x` hold
    /// their values and are kept; the periodic copies are set from their masters), by
    /// Jacobi-preconditioned conjugate gradients from the initial guess in `x`, to a
    /// residual of `tolerance` relative to the right-hand side. Returns the iterations.
    fn solve(&mut self, c: Real, rhs: &[Real], x: &mut [Real], tolerance: Real) -> Result<usize, String> {
        let n = x.len();
        for v in [&mut self.r, &mut self.z, &mut self.p, &mut self.q, &mut self.b, &mut self.inverse_diagonal] {
            v.resize(n, 0.0);
        }
        // b = rhs + c (known neighbours + ghost offsets), the constant part moved right
        let (act, nb, plain) = (&self.active, &self.neighbours, &self.plain);
        let st = Stencils { plain, strides: self.strides, neighbours: nb };
        let known: &[Real] = x;
        let mut b = std::mem::take(&mut self.b);
        b.par_chunks_mut(CHUNK).enumerate().for_each(|(ch, out)| {
            for (o, y) in out.iter_mut().enumerate() {
                let k = ch * CHUNK + o;
                // a plain face has no constant part: Σ of its six (four) zeros is +0
                let constant = if plain[k] { 0.0 } else { constants(&nb[k], known) };
                *y = if act[k] { rhs[k] + c * constant } else { 0.0 };
            }
        });
        let mut diag = std::mem::take(&mut self.inverse_diagonal);
        diag.par_chunks_mut(CHUNK).enumerate().for_each(|(ch, out)| {
            for (o, d) in out.iter_mut().enumerate() {
                let k = ch * CHUNK + o;
                // a plain face has no ghost: Σα = +0
                *d = if !act[k] {
                    0.0
                } else if plain[k] {
                    1.0 / (1.0 + c * (CENTRE - 0.0))
                } else {
                    1.0 / self.diagonal(c, k)
                };
            }
        });
        let row = self.row;
        let (grid, lattice) = (self.grid.as_ref().expect("built"), self.lattice.expect("built"));
        let (part, groups) = (&grid.part, self.groups.as_ref().expect("built"));
        let norm_b = grid.dot(lattice, &b, &b).sqrt();
        let mut q = std::mem::take(&mut self.q);
        self.apply(c, x, &mut q);
        let (r, z, p) = (&mut self.r, &mut self.z, &mut self.p);
        r.par_chunks_mut(CHUNK).zip(z.par_chunks_mut(CHUNK)).zip(p.par_chunks_mut(CHUNK)).enumerate().for_each(
            |(ch, ((r, z), p))| {
                let o = ch * CHUNK;
                for i in 0..r.len() {
                    r[i] = b[o + i] - q[o + i];
                    z[i] = diag[o + i] * r[i];
                    p[i] = z[i];
                }
            },
        );
        let [mut rz, mut rr] = {
            let (r, z): (&[Real], &[Real]) = (r, z);
            part.reduce(groups.sums(|g| [lanes_dot(&r[g.clone()], &z[g.clone()]), lanes_dot(&r[g.clone()], &r[g])]))
        };
        let mut iterations = 0;
        let target = tolerance * norm_b;
        while rr.sqrt() > target {
            if iterations >= 1000 {
                let residual = rr.sqrt();
                (self.q, self.b, self.inverse_diagonal) = (q, b, diag);
                return Err(format!(
                    "the implicit viscous solve did not converge in 1000 iterations (residual {residual:.2e} \
                     of {norm_b:.2e})"
                ));
            }
            // a rank's faces next to its cuts read the neighbours' p
            grid.exchange(&mut [(lattice, &mut p[..])]);
            let p_ref: &[Real] = p;
            // q = A p, with p·q by the reduction rule (rows along x, as `dot`)
            let pq = q
                .par_chunks_mut(row)
                .enumerate()
                .with_min_len((CHUNK / row).max(1))
                .fold(Sums::boxed, |mut sums, (j, out)| {
                    let o = j * row;
                    for (i, y) in out.iter_mut().enumerate() {
                        let k = o + i;
                        *y = if act[k] { p_ref[k] - c * (st.sum(k, p_ref, false) - CENTRE * p_ref[k]) } else { 0.0 };
                    }
                    let p = &p_ref[o..o + row];
                    for g in groups.of_row(j) {
                        sums.add([lanes_dot(&p[g.clone()], &out[g])]);
                    }
                    sums
                })
                .reduce(Sums::boxed, Sums::merge_boxed);
            let alpha = rz / part.reduce(*pq)[0];
            if !alpha.is_finite() {
                break;
            }
            // x += α p (unknowns), r −= α q, z = D⁻¹ r, with r·z and r·r by the reduction
            // rule (as `dot`)
            let q_ref: &[Real] = &q;
            let sums = x
                .par_chunks_mut(row)
                .zip(r.par_chunks_mut(row).zip(z.par_chunks_mut(row)))
                .enumerate()
                .with_min_len((CHUNK / row).max(1))
                .fold(Sums::boxed, |mut sums, (j, (x, (r, z)))| {
                    let o = j * row;
                    for i in 0..x.len() {
                        if act[o + i] {
                            x[i] += alpha * p_ref[o + i];
                        }
                        r[i] -= alpha * q_ref[o + i];
                        z[i] = diag[o + i] * r[i];
                    }
                    for g in groups.of_row(j) {
                        sums.add([lanes_dot(&r[g.clone()], &z[g.clone()]), lanes_dot(&r[g.clone()], &r[g])]);
                    }
                    sums
                })
                .reduce(Sums::boxed, Sums::merge_boxed);
            let [rz_new, rr_new] = part.reduce(*sums);
            rr = rr_new;
            let beta = rz_new / rz;
            rz = rz_new;
            p.par_iter_mut().zip(z.par_iter()).with_min_len(CHUNK).for_each(|(p, z)| *p = z + beta * *p);
            iterations += 1;
        }
        (self.q, self.b, self.inverse_diagonal) = (q, b, diag);
        for &(copy, master) in &self.copies {
            x[copy] = x[master];
        }
        Ok(iterations)
    }
}

/// Σ over the neighbours of the values they stand for, at a face of value `own`: unknown
/// faces and (with `constants`) fixed faces from `u`, ghosts α own (+ β with `constants`).
#[inline]
fn stencil(nb: &[Neighbour; SIDES], u: &[Real], own: Real, constants: bool) -> Real {
    let mut s = 0.0;
    for n in nb {
        s += match *n {
            Neighbour::Face(i) => u[i as usize],
            Neighbour::Known(i) if constants => u[i as usize],
            Neighbour::Known(_) => 0.0,
            Neighbour::Ghost(a, b) => a * own + if constants { b } else { 0.0 },
        };
    }
    s
}

/// What the stencil of a face reads: the plain faces, the storage strides and the neighbour
/// lists of the others.
#[derive(Clone, Copy)]
struct Stencils<'a> {
    plain: &'a [bool],
    strides: [usize; DIM],
    neighbours: &'a [[Neighbour; SIDES]],
}

impl Stencils<'_> {
    /// Σ over the neighbours of face `k` of their values in `u` (`constants`: fixed faces'
    /// values and ghost offsets included), by the plain stencil where it holds.
    #[inline(always)]
    fn sum(&self, k: usize, u: &[Real], constants: bool) -> Real {
        if self.plain[k] {
            plain_sum(u, k, &self.strides)
        } else {
            stencil(&self.neighbours[k], u, u[k], constants)
        }
    }
}

/// The neighbour sum of a plain face `k` (every neighbour the face one stride away), in the
/// order of [`Side::ALL`]: the sum [`stencil`] makes from its list, the same bits.
#[inline(always)]
fn plain_sum(u: &[Real], k: usize, strides: &[usize; DIM]) -> Real {
    let mut s = 0.0;
    for &st in strides {
        s += u[k - st];
        s += u[k + st];
    }
    s
}

/// Σ over the neighbours of their constant parts: fixed faces' values and ghost offsets β.
#[inline]
fn constants(nb: &[Neighbour; SIDES], u: &[Real]) -> Real {
    nb.iter()
        .map(|n| match *n {
            Neighbour::Known(i) => u[i as usize],
            Neighbour::Ghost(_, b) => b,
            Neighbour::Face(_) => 0.0,
        })
        .sum()
}

/// The Laplacians and solves of every face lattice of a grid.
#[derive(Clone, Debug, Default)]
pub struct FaceDiffusion {
    /// One operator per face lattice, in axis order.
    lattices: Vec<LatticeOperator>,
}

impl FaceDiffusion {
    /// The operators of `grid` under `bc`.
    pub fn new(grid: &Grid, bc: &Boundaries) -> Self {
        Self { lattices: (0..DIM).map(|a| LatticeOperator::new(grid, bc, a)).collect() }
    }

    /// `out = L u` (Σ neighbours − 2·DIM u, without the 1/h²) on the unknown faces of the
    /// lattice normal to `axis`, 0 on the others.
    pub fn laplacian(&self, axis: usize, u: &[Real], out: &mut [Real]) {
        self.lattices[axis].laplacian(u, out);
    }

    /// Whether face `k` of the lattice normal to `axis` is an unknown (neither fixed nor a
    /// periodic copy).
    pub fn is_unknown(&self, axis: usize, k: usize) -> bool {
        self.lattices[axis].active[k]
    }

    /// Solves `(I − c L) x = rhs` on the lattice normal to `axis` (see the module doc); `x`
    /// holds the initial guess and the fixed faces' values. Returns the iterations.
    pub fn solve(&mut self, axis: usize, c: Real, rhs: &[Real], x: &mut [Real]) -> Result<usize, String> {
        self.lattices[axis].solve(c, rhs, x, 1e-13)
    }
}

#[cfg(all(test, feature = "dim2"))]
mod tests {
    use super::*;
    use multifield_core::boundary::{Boundary, Profile};
    use multifield_core::math::Vector;

    fn boundaries() -> Boundaries {
        Boundaries {
            left: Boundary::Periodic,
            right: Boundary::Periodic,
            bottom: Boundary::NoSlip,
            top: Boundary::Velocity { velocity: [2.0, 0.0], profile: Profile::Uniform },
        }
    }

    /// The solve inverts the operator: (I − c L) x = rhs to round-off, for a lattice with
    /// periodic, no-slip and moving-wall sides, and for an outflow.
    #[test]
    fn the_solve_inverts_the_operator() {
        let g = Grid::new(12, 9, 0.1, Vector::zeros());
        for bc in [
            boundaries(),
            Boundaries { right: Boundary::Outflow { pressure: 0.0 }, left: Boundary::NoSlip, ..boundaries() },
        ] {
            let mut d = FaceDiffusion::new(&g, &bc);
            for (axis, n) in [(0, g.n_xfaces()), (1, g.n_yfaces())] {
                let rhs: Vec<Real> = (0..n).map(|k| ((k * 7919) % 23) as Real * 0.1 - 1.0).collect();
                let mut x = vec![0.0; n];
                // fixed faces: a known value
                let lat = &d.lattices[axis];
                for (k, x) in x.iter_mut().enumerate() {
                    if !lat.active[k] && !lat.copies.iter().any(|c| c.0 == k) {
                        *x = 0.5;
                    }
                }
                let c = 3.0;
                let its = d.solve(axis, c, &rhs, &mut x).unwrap();
                let mut lap = vec![0.0; n];
                d.laplacian(axis, &x, &mut lap);
                let lat = &d.lattices[axis];
                let err =
                    (0..n).filter(|&k| lat.active[k]).map(|k| (x[k] - c * lap[k] - rhs[k]).abs()).fold(0.0, Real::max);
                eprintln!("faces normal to {axis}: {its} iterations, max residual {err:.2e}");
                assert!(err < 1e-11, "residual {err:e}");
                assert!(its < 60, "{its} iterations");
            }
        }
    }

    /// The Laplacian is that of the explicit stencil: a linear profile between a wall at rest
    /// and a wall moving at U (Couette) has L u = 0 on every unknown face.
    #[test]
    fn couette_profile_is_in_the_kernel_of_the_laplacian() {
        let g = Grid::new(4, 8, 0.125, Vector::zeros());
        let bc = boundaries();
        let d = FaceDiffusion::new(&g, &bc);
        let u: Vec<Real> = (0..g.n_xfaces()).map(|k| 2.0 * (((k / (g.nx + 1)) as Real + 0.5) / 8.0)).collect();
        let mut lap = vec![1.0; u.len()];
        d.laplacian(0, &u, &mut lap);
        let m = lap.iter().fold(0.0 as Real, |m, l| m.max(l.abs()));
        assert!(m < 1e-14, "max |L u| = {m:e}");
    }

    /// The same bits on one and three threads.
    #[test]
    fn the_solve_does_not_depend_on_the_thread_count() {
        let g = Grid::new(100, 70, 0.01, Vector::zeros());
        let bc = boundaries();
        let n = g.n_xfaces();
        let rhs: Vec<Real> = (0..n).map(|k| ((k * 104729) % 97) as Real * 0.01).collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut d = FaceDiffusion::new(&g, &bc);
                let mut x = vec![0.0; n];
                d.solve(0, 0.7, &rhs, &mut x).unwrap();
                x.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            })
        };
        assert_eq!(run(1), run(3));
    }
}
