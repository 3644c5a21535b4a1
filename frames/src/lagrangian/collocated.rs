//! The collocated grid of a lone Lagrangian field (`grid: "collocated"`): one whole step of
//! the material points in one scatter and one gather, with the grid velocity at the nodes
//! (i h, j h), the layout of standard MPM (Sulsky, Chen & Schreyer 1994; Jiang et al.'s
//! APIC 2015; Taichi's mpm88).
//!
//! A field that is alone (no other field, no pressure solve, no exchange, no contact) needs
//! none of the multifield phases: its step is particles to grid, the grid update
//! `u = (mu + Δt f)/m + Δt g` with the walls, and grid to particles. The staggered
//! (MAC) layout exists to couple fields through one pressure; a lone field can keep its two
//! velocity components on the same nodes, which halves the stencils a point touches (9
//! nodes of 3 sums, against 9 x-faces and 9 y-faces of 2 sums and 9 cells of volume).
//!
//! The discretisation is the staggered path's in every other respect: the quadratic
//! B-spline, the force `−V σ ∇S` (not MLS-MPM's `S D⁻¹ (x_i − x_p)`), APIC's
//! `C = D⁻¹ Σ S u (x_i − x_p)ᵀ` or PIC, `∇v = Σ u ∇Sᵀ`, J ← J det(I + Δt ∇v) for a
//! `volumetric_only` stress and F ← (I + Δt ∇v) F otherwise, and at a wall the ghost nodes
//! mirror the nodes inside (the normal component odd, the tangential one by the wall's
//! rule) in both transfers.
//!
//! Parallel and deterministic: the points are split by index into `PARTS` fixed parts,
//! each scattered into its own grid on its own thread (with more threads than parts, each
//! part's grid is cut into strips of rows, one task each, every strip adding the points
//! whose stencils reach it in point order: each node sums the same numbers in the same
//! order for any number of strips); the grid update adds the parts node by node in part
//! order, and the gather's per-block sums of the diagnostics are added in
//! block order (each block's in four lanes, point k in lane k mod 4). The same bits on any
//! number of threads. The kernel (scatter of four points, grid update of four nodes,
//! gather and end of the gather of four points) is written once, generic over four f64
//! lanes (`lanes::Lanes`), with the B-spline of `shape::quadratic_lanes`; it is compiled
//! for portable `[f64; 4]` lanes and, with AVX and FMA (x86-64, detected at run time),
//! for AVX registers inside `#[target_feature]` functions. Each lane operation is the same
//! IEEE operation in both (`mul_add` fused in both): the same bits with or without AVX.
//!
//! Each part clears the grid it filled at its next scatter, on its own thread, and folds
//! its ghost nodes in there too; the grid update only reads the parts. Only the chunks of
//! 8 nodes that the points' stencils reached are updated and cleared (a map per row): a
//! splash that spans the box touches a few chunks per row away from the bulk.
#[cfg(target_arch = "x86_64")]
use super::lanes::AvxFma;
use super::lanes::{Lane, Lanes, Portable};
use super::scatter::map_axis;
use super::shape::{quadratic, quadratic_lanes, Shape};
use super::{Points, Transfer};
use multifield_core::boundary::{Boundaries, Side};
use multifield_core::grid::Grid;
use multifield_core::math::{Matrix, Real, Vector};
use multifield_core::plugin::{FrameFigures, PointStressContext, StressModel};
use rayon::prelude::*;

/// Partial grids of the scatter: the points are split into this many parts by index, each
/// scattered into its own grid (in parallel), and the grids are added in part order. A
/// fixed number, so that the sums are the same bits for any number of threads.
const PARTS: usize = 2;
const _: () = assert!(PARTS == 2, "Collocated::scatter and Collocated::update split into two parts");
/// Ghost nodes on each side of the lattice.
const PAD: usize = 2;
/// Nodes per chunk of a row in the maps of touched nodes (`Collocated::touched`).
const CHUNK: usize = 8;
/// Points per block of the parallel gather (its diagnostic sums are added in block order).
const BLOCK: usize = 512;

/// A node's scattered sums [m, Σ (mu)_x, Σ (mu)_y, 0]: 32 bytes aligned to 32, one AVX
/// register that never straddles a cache line.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
struct Node([Real; 4]);

impl Node {
    const ZERO: Node = Node([0.0; 4]);
}

impl std::ops::Index<usize> for Node {
    type Output = Real;
    #[inline(always)]
    fn index(&self, c: usize) -> &Real {
        &self.0[c]
    }
}

impl std::ops::IndexMut<usize> for Node {
    #[inline(always)]
    fn index_mut(&mut self, c: usize) -> &mut Real {
        &mut self.0[c]
    }
}

/// The collocated grid's scratch, kept between steps.
pub struct Collocated {
    nx: usize,
    ny: usize,
    /// Padded lattice width (nodes per row).
    width: usize,
    /// Padded lattice height (rows).
    height: usize,
    /// `PARTS` partial grids, one after the other: part k holds the scattered sums
    /// [m, Σ (mu)_x, Σ (mu)_y, 0] of points [k n/PARTS, (k + 1) n/PARTS), kept until the
    /// part's next scatter clears it.
    acc: Vec<Node>,
    /// Grid velocity after the update, ghosts filled.
    vel: Vec<[Real; 2]>,
    /// Padded rows [lo, hi) that the last scatter touched (all parts).
    rows: (usize, usize),
    /// Per part and padded row, a bitmap (`words` u64) of the chunks of `CHUNK` nodes in
    /// which the stencils starting on that row begin or end: the grid update and the next
    /// clearing visit only those (a splash that spans the box touches a few chunks per row
    /// away from the bulk).
    touched: Vec<u64>,
    /// Words per row of `touched`.
    words: usize,
    /// Masses below this are empty nodes: 1e-12 of the largest point mass.
    tiny: Option<Real>,
    /// The lanes the transfers use (at most what the CPU has; the same bits with any).
    simd: Simd,
    /// Whether the last step's kinetic energy and largest speed were finite: then every
    /// point is finite and in the domain (the gather keeps it there), which the AVX lanes'
    /// conversion of the first node needs (a NaN would become −2³¹, and the stencil's
    /// checked indexing would panic). After a blown-up step the portable lanes run, which
    /// keep a NaN or infinite point on the padded lattice (`lattice`).
    finite: bool,
}

/// What the scatter reads of a point besides the `Points` arrays.
struct ScatterIn<'a> {
    pts: &'a Points,
    apic: bool,
    dt: Real,
    grid: &'a Grid,
    /// The field's stress models and density: each part evaluates its points' stress
    /// before scattering them.
    models: &'a [Box<dyn StressModel>],
    density: Real,
}

impl Collocated {
    /// Scratch for `grid`.
    pub fn new(grid: &Grid) -> Self {
        let (width, height) = (grid.nx + 1 + 2 * PAD, grid.ny + 1 + 2 * PAD);
        Self {
            nx: grid.nx,
            ny: grid.ny,
            width,
            height,
            acc: vec![Node::ZERO; PARTS * width * height],
            vel: vec![[0.0; 2]; width * height],
            rows: (0, 0),
            touched: vec![0; PARTS * height * width.div_ceil(CHUNK).div_ceil(64)],
            words: width.div_ceil(CHUNK).div_ceil(64),
            tiny: None,
            simd: Simd::available(),
            finite: true,
        }
    }

    /// The lanes the transfers use: `simd` where the CPU has it, else the most it has (all
    /// give the same bits). Returns what is in use.
    pub fn use_simd(&mut self, simd: Simd) -> Simd {
        self.simd = simd.min(Simd::available());
        self.simd
    }

    /// Index of lattice node (i, j) (ghosts from −`PAD`).
    #[inline(always)]
    fn index(&self, i: isize, j: isize) -> usize {
        node_index(self.width, i, j)
    }

    /// One step of the points: stress (the `models` that act on points, into `pts.stress`),
    /// scatter, grid update, gather.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        grid: &Grid,
        bc: &Boundaries,
        pts: &mut Points,
        models: &[Box<dyn StressModel>],
        density: Real,
        transfer: Transfer,
        volumetric_only: bool,
        dt: Real,
        gravity: Vector,
    ) -> FrameFigures {
        let mut stress = std::mem::take(&mut pts.stress);
        let mut state = std::mem::take(&mut pts.model_state);
        let input = ScatterIn { pts, apic: transfer == Transfer::Apic, dt, grid, models, density };
        self.scatter(&input, &mut stress, &mut state, [bc.periodic(0), bc.periodic(1)]);
        pts.stress = stress;
        pts.model_state = state;
        // the points' masses never change
        let tiny = *self.tiny.get_or_insert_with(|| 1e-12 * pts.m.iter().cloned().fold(0.0, Real::max));
        self.update(bc, dt, gravity, tiny);
        // ∇v at the points only for a point stress that reads it
        let velocity_gradient = models.iter().any(|m| m.kind().uses_velocity_gradient());
        let figures = self.gather(grid, bc, pts, transfer, volumetric_only, velocity_gradient, dt);
        self.finite = figures.kinetic_energy.is_finite() && figures.max_speed.is_finite();
        figures
    }

    /// Particles to grid: mass, momentum (APIC) and Δt × internal force into `acc`, the
    /// points of each part into its own grid, the parts in parallel; each part first clears
    /// what it held (the grid update only reads the parts) and then folds its ghost nodes
    /// in. With more threads than parts each part's grid is cut into strips of rows, one
    /// task each (`scatter_strips`): every node still adds its part's points in point
    /// order, so the sums are the same bits for any number of threads or strips.
    fn scatter(&mut self, input: &ScatterIn, stress: &mut [Matrix], state: &mut [Vec<Real>], periodic: [bool; 2]) {
        let n = input.pts.len();
        // each model's point state, split as the points are (k values per point)
        let (mut state0, mut state1) = (Vec::new(), Vec::new());
        for (s, m) in state.iter_mut().zip(input.models) {
            let (a, b) = s.split_at_mut(n / PARTS * m.point_state().len());
            state0.push(a);
            state1.push(b);
        }
        let states = vec![state0, state1];
        let (nx, ny) = (self.nx, self.ny);
        let width = self.width;
        // the lanes only while every point is finite (see `finite`)
        let simd = if self.finite { self.simd } else { Simd::Portable };
        let row0 = -(PAD as isize); // lattice row of padded row 0
        let height = self.height;
        let (s0, s1) = stress.split_at_mut(n / PARTS);
        let parts: Vec<&mut [Matrix]> = vec![s0, s1];
        let words = self.words;
        let (nxi, nyi) = (nx as isize, ny as isize);
        let strips = rayon::current_num_threads().div_ceil(PARTS);
        let rows: Vec<(usize, usize)> = self
            .acc
            .par_chunks_mut(width * height)
            .zip(self.touched.par_chunks_mut(height * words))
            .zip(parts.into_par_iter().zip(states))
            .enumerate()
            .map(|(k, ((grid, touched), (sigma, mut state)))| {
                clear_part(grid, touched, width, words, periodic);
                debug_assert!(grid.iter().all(|a| *a == Node::ZERO), "a node of part {k} left uncleared");
                touched.fill(0);
                let pts = k * n / PARTS..(k + 1) * n / PARTS;
                sigma.iter_mut().for_each(|s| *s = Matrix::zeros());
                for (m, model) in input.models.iter().enumerate().filter(|(_, m)| m.kind().acts_on_points()) {
                    model.point_stress(&mut PointStressContext {
                        dt: input.dt,
                        density: input.density,
                        deformation_gradient: &input.pts.f[pts.clone()],
                        velocity_gradient: &input.pts.grad_v[pts.clone()],
                        stress: sigma,
                        state: state.get_mut(m).map_or(&mut [], |s| &mut s[..]),
                    });
                }
                let sigma = &*sigma;
                let mut note = |(bx, by): (isize, isize)| {
                    mark(touched, words, bx, by);
                    // a point clamped to the lattice's far edge (not finite) starts its stencil
                    // on node n, whose ghosts n + 1, n + 2 mirror to n − 1, n − 2
                    if bx >= nxi || by >= nyi {
                        mark(touched, words, bx.min(nxi - 2).max(-1), by.min(nyi - 2).max(-1));
                    }
                };
                if strips > 1 {
                    scatter_strips(grid, &mut note, width, input, pts, sigma, strips, simd);
                } else {
                    scatter_lanes(simd, grid, width, row0, input, pts, sigma, None, &mut note);
                }
                let rows = touched_rows(touched, words);
                fold_part(grid, width, [nx, ny], periodic, rows);
                rows
            })
            .collect();
        let rows = rows.iter().filter(|r| r.0 < r.1);
        self.rows = match (rows.clone().map(|r| r.0).min(), rows.map(|r| r.1).max()) {
            (Some(lo), Some(hi)) => (lo, hi),
            _ => (0, 0),
        };
    }

    /// The chunks of padded row `r` that the last scatter touched, in any part (the
    /// stencils starting on rows r − 2 ..= r), into `mask`.
    fn row_mask(&self, r: usize, mask: &mut [u64]) {
        mask.fill(0);
        for part in self.touched.chunks(self.height * self.words) {
            or_rows(mask, part, self.words, r);
        }
    }

    /// The grid update of the touched nodes (the ghosts are already folded in by each
    /// part's scatter): u = (mu + Δt f)/m + Δt g from the two parts, the walls; then the
    /// ghost nodes of `vel` filled. It only reads `acc`.
    fn update(&mut self, bc: &Boundaries, dt: Real, gravity: Vector, tiny: Real) {
        let (px, py) = (bc.periodic(0), bc.periodic(1));
        let (nx, ny) = (self.nx as isize, self.ny as isize);
        let pad = PAD as isize;
        // periodic along y: ghosts wrap to rows far away; update every row
        let (r0, r1) = if py { (0, self.height) } else { self.rows };
        let plane = self.width * self.height;
        // the update, row by row in parallel (rows of the lattice only): the parts added in
        // order (each part is cleared by its next scatter, on the thread that fills it)
        let lo = r0.max(PAD);
        let hi = r1.min(PAD + self.ny + 1).max(lo); // no points: no rows
        let width = self.width;
        let (gx, gy) = (dt * gravity.x, dt * gravity.y);
        let (nxu, nyu) = (self.nx, self.ny);
        // the touched chunks of each row; every column along a periodic side, where a
        // ghost's contribution wraps to the far side of the lattice
        let words = self.words;
        let mut masks = vec![u64::MAX; (hi - lo) * words];
        if !(px || py) {
            for (r, mask) in (lo..hi).zip(masks.chunks_mut(words)) {
                self.row_mask(r, mask);
            }
        }
        // the walls of lattice row j (its nodes from padded column PAD)
        let update_walls = |vel: &mut [[Real; 2]], j: usize| {
            let row = &mut vel[PAD..PAD + nxu + 1];
            let s = j as Real / nyu as Real;
            if px {
                row[nxu] = row[0];
            } else {
                wall(bc, Side::Left, s, &mut row[0], 0);
                wall(bc, Side::Right, s, &mut row[nxu], 0);
            }
            if !py && (j == 0 || j == nyu) {
                let side = if j == 0 { Side::Bottom } else { Side::Top };
                for (i, v) in row.iter_mut().enumerate() {
                    wall(bc, side, i as Real / nxu as Real, v, 1);
                }
            }
        };
        #[cfg(target_arch = "x86_64")]
        let avx = self.simd.avx();
        let (first, second) = self.acc.split_at(plane);
        first[lo * width..hi * width]
            .par_chunks(width)
            .zip(second[lo * width..hi * width].par_chunks(width))
            .zip(self.vel[lo * width..hi * width].par_chunks_mut(width))
            .zip(masks.par_chunks(words))
            .enumerate()
            // rows of a few chunks each: eight to a task (2 threads, mpm88: 13.7 against 14.8 us a step)
            .with_min_len(8)
            .for_each(|(k, (((a0, a1), vel), mask))| {
                let j = lo + k - PAD;
                // the lattice's columns of the touched chunks
                runs(mask, PAD, PAD + nxu + 1, |cols| {
                    let (a, b, v) = (&a0[cols.clone()], &a1[cols.clone()], &mut vel[cols]);
                    #[cfg(target_arch = "x86_64")]
                    if let Some(avx) = avx {
                        // SAFETY: `avx` exists, so the CPU has AVX and FMA
                        return unsafe { update_nodes_avx(avx, a, b, v, tiny, [gx, gy]) };
                    }
                    update_nodes(Portable, a, b, v, tiny, [gx, gy]);
                });
                update_walls(vel, j);
            });
        if py {
            for i in 0..=nx {
                let v = self.vel[self.index(i, 0)];
                let k = self.index(i, ny);
                self.vel[k] = v;
            }
        }
        // ghost velocities: the node they mirror (or wrap to), by the walls' rules
        for r in r0..r1 {
            let jg = r as isize - pad;
            let ghost_row = jg < 0 || jg > ny;
            for ig in ghost_columns(ghost_row, nx) {
                let (i, mx) = map_axis(ig, self.nx, true, px);
                let (j, my) = map_axis(jg, self.ny, true, py);
                let mut v = self.vel[self.index(i, j)];
                if mx {
                    let side = if ig < 0 { Side::Left } else { Side::Right };
                    v[0] = -v[0];
                    v[1] = bc.tangential_ghost(side, v[1], (jg as Real / ny as Real).clamp(0.0, 1.0));
                }
                if my {
                    let side = if jg < 0 { Side::Bottom } else { Side::Top };
                    v[1] = -v[1];
                    v[0] = bc.tangential_ghost(side, v[0], (ig as Real / nx as Real).clamp(0.0, 1.0));
                }
                let k = self.index(ig, jg);
                self.vel[k] = v;
            }
        }
    }

    /// Grid to particles: velocity (PIC or APIC), ∇v (where a point stress reads it), F (or
    /// J), position; the step's sums.
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        grid: &Grid,
        bc: &Boundaries,
        pts: &mut Points,
        transfer: Transfer,
        volumetric_only: bool,
        velocity_gradient: bool,
        dt: Real,
    ) -> FrameFigures {
        let (px, py) = (bc.periodic(0), bc.periodic(1));
        let fin = Finish {
            dt,
            ih: 1.0 / grid.h,
            velocity_gradient,
            dinv: Shape::Quadratic.apic_d_inverse(grid.h).unwrap_or(0.0),
            apic: transfer == Transfer::Apic,
            volumetric_only,
            lo: grid.origin,
            hi: grid.origin + grid.size(),
            eps: 1e-9 * grid.h,
            periodic: [px, py],
        };
        // the lanes only while every point is finite (see `finite`)
        let simd = if self.finite { self.simd } else { Simd::Portable };
        let m = &pts.m;
        let sums: Vec<FrameFigures> = pts
            .x
            .par_chunks_mut(BLOCK)
            .zip(pts.v.par_chunks_mut(BLOCK))
            .zip(pts.f.par_chunks_mut(BLOCK).zip(pts.grad_v.par_chunks_mut(BLOCK)))
            .zip(pts.c_u.par_chunks_mut(BLOCK).zip(pts.c_v.par_chunks_mut(BLOCK)))
            .zip(m.par_chunks(BLOCK))
            .map(|((((x, v), (f, gv)), (cu, cv)), m)| {
                let mut block = Outs { x, v, f, gv, cu, cv };
                let mut sums = LaneSums::default();
                #[cfg(target_arch = "x86_64")]
                if let Some(avx) = simd.avx() {
                    // SAFETY: `avx` exists, so the CPU has AVX and FMA
                    unsafe { self.gather_block_avx(avx, grid, &fin, &mut block, m, &mut sums) };
                    return sums.total();
                }
                self.gather_block(Portable, grid, &fin, &mut block, m, &mut sums);
                sums.total()
            })
            .collect();
        // kinetic energy, mass and momentum: the lanes' sums of blocks of points added in
        // order (the same bits for any number of threads), not yet the reduction rule of
        // docs/design/mpi.md §3 (issue 19, P2b): a group of one point, added exactly
        // (`Lagrangian::point_sums`), cost mpm88 30 % of its CPU time (docs/performance.md)
        let mut total = FrameFigures::default();
        for s in sums {
            total.kinetic_energy += s.kinetic_energy;
            total.mass += s.mass;
            total.momentum += s.momentum;
            total.max_speed = total.max_speed.max(s.max_speed);
        }
        total.max_speed = total.max_speed.sqrt();
        total
    }

    /// The gather of a block of points (`out`, masses `m`), four at a time in the lanes of
    /// `s`; the last one to three through four-point copies, the last point repeated in the
    /// lanes left over. Point k of the block is in lane k mod 4 of its sums.
    #[inline(always)]
    fn gather_block<S: Lanes>(&self, s: S, grid: &Grid, fin: &Finish, out: &mut Outs, m: &[Real], sums: &mut LaneSums) {
        let n = m.len();
        let mut k0 = 0;
        while k0 + 4 <= n {
            let r = self.gather4(s, grid, [&out.x[k0], &out.x[k0 + 1], &out.x[k0 + 2], &out.x[k0 + 3]]);
            let m = [&m[k0], &m[k0 + 1], &m[k0 + 2], &m[k0 + 3]];
            finish4(s, fin, &r, &mut out.four(k0..k0 + 4), m, 4, sums);
            k0 += 4;
        }
        if k0 < n {
            let rest = n - k0;
            let (mut x, mut v, mut f) = (pad4(&out.x[k0..]), pad4(&out.v[k0..]), pad4(&out.f[k0..]));
            let (mut gv, mut cu, mut cv) = (pad4(&out.gv[k0..]), pad4(&out.cu[k0..]), pad4(&out.cv[k0..]));
            let ms = pad4(&m[k0..]);
            let r = self.gather4(s, grid, [&x[0], &x[1], &x[2], &x[3]]);
            let mut four = Outs { x: &mut x, v: &mut v, f: &mut f, gv: &mut gv, cu: &mut cu, cv: &mut cv };
            finish4(s, fin, &r, &mut four, [&ms[0], &ms[1], &ms[2], &ms[3]], rest, sums);
            out.x[k0..].copy_from_slice(&x[..rest]);
            out.v[k0..].copy_from_slice(&v[..rest]);
            out.f[k0..].copy_from_slice(&f[..rest]);
            out.gv[k0..].copy_from_slice(&gv[..rest]);
            out.cu[k0..].copy_from_slice(&cu[..rest]);
            out.cv[k0..].copy_from_slice(&cv[..rest]);
        }
    }

    /// `gather_block` in AVX registers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,fma")]
    fn gather_block_avx(&self, s: AvxFma, grid: &Grid, fin: &Finish, out: &mut Outs, m: &[Real], sums: &mut LaneSums) {
        self.gather_block(s, grid, fin, out, m, sums)
    }

    /// The raw sums of the gathers of four points at `x`, one per lane, 10 of them:
    /// Σ S u (2), Σ u ∂S/∂ξ (2), Σ u ∂S/∂η (2), Σ S u (x_i − x_p) (2), Σ S u (y_i − y_p)
    /// (2), each for the components (x, y).
    #[inline(always)]
    fn gather4<S: Lanes>(&self, s: S, grid: &Grid, x: [&Vector; 4]) -> [S::V; 10] {
        let (h, ih) = (s.splat(grid.h), s.splat(1.0 / grid.h));
        let (px, py) = s.pairs([pair(x[0]), pair(x[1]), pair(x[2]), pair(x[3])]);
        let (bx, fx, wx, dwx) = quadratic_lanes(lattice_lanes(s, grid, px, ih, 0));
        let (by, fy, wy, dwy) = quadratic_lanes(lattice_lanes(s, grid, py, ih, 1));
        let k0 = self.first_nodes(bx.to_array(), by.to_array());
        let z = s.splat(0.0);
        let mut wxd = [z; 3];
        for a in 0..3 {
            wxd[a] = (s.splat(a as Real) - fx) * h * wx[a];
        }
        let (mut u, mut gx, mut gy, mut ax, mut ay) = ([z; 2], [z; 2], [z; 2], [z; 2], [z; 2]);
        for b in 0..3 {
            let row = |l: usize| -> &[[Real; 2]; 3] {
                let at = k0[l] + b * self.width;
                self.vel[at..at + 3].try_into().expect("a stencil row")
            };
            let rows = [row(0), row(1), row(2), row(3)];
            let (mut sw, mut t, mut r) = ([z; 2], [z; 2], [z; 2]);
            for a in 0..3 {
                let (u, v) = s.pairs([&rows[0][a], &rows[1][a], &rows[2][a], &rows[3][a]]);
                let uv = [u, v];
                for c in 0..2 {
                    sw[c] = wx[a].mul_add(uv[c], sw[c]);
                    t[c] = dwx[a].mul_add(uv[c], t[c]);
                    r[c] = wxd[a].mul_add(uv[c], r[c]);
                }
            }
            let wdy = wy[b] * (s.splat(b as Real) - fy) * h;
            for c in 0..2 {
                u[c] = wy[b].mul_add(sw[c], u[c]);
                gx[c] = wy[b].mul_add(t[c], gx[c]);
                gy[c] = dwy[b].mul_add(sw[c], gy[c]);
                ax[c] = wy[b].mul_add(r[c], ax[c]);
                ay[c] = wdy.mul_add(sw[c], ay[c]);
            }
        }
        [u[0], u[1], gx[0], gx[1], gy[0], gy[1], ax[0], ax[1], ay[0], ay[1]]
    }

    /// First stencil node of each of the points at lattice bases `bx`, `by`. Every stencil
    /// lies in the padded lattice: the lattice coordinates are clamped to [−½, n + ½]
    /// (`lattice_lanes`), which puts the first node in [−1, n] and the last in [1, n + 2].
    #[inline(always)]
    fn first_nodes(&self, bx: [Real; 4], by: [Real; 4]) -> [usize; 4] {
        let node = |l: usize| {
            assert!(bx[l] >= -1.0 && by[l] >= -1.0 && bx[l] <= self.nx as Real && by[l] <= self.ny as Real);
            self.index(bx[l] as isize, by[l] as isize)
        };
        [node(0), node(1), node(2), node(3)]
    }
}

/// Four copies of the first one to four entries of `v`, the last repeated.
#[inline(always)]
fn pad4<T: Copy>(v: &[T]) -> [T; 4] {
    let last = v.len() - 1;
    [v[0], v[1.min(last)], v[2.min(last)], v[3.min(last)]]
}

/// A vector's two entries.
#[inline(always)]
fn pair(v: &Vector) -> &[Real; 2] {
    &v.data.0[0]
}

/// Four 2 × 2 matrices as the lanes of their entries [m11, m21, m12, m22].
#[inline(always)]
fn matrices<S: Lanes>(s: S, m: [&Matrix; 4]) -> [S::V; 4] {
    let (m11, m21) = s.pairs([&m[0].data.0[0], &m[1].data.0[0], &m[2].data.0[0], &m[3].data.0[0]]);
    let (m12, m22) = s.pairs([&m[0].data.0[1], &m[1].data.0[1], &m[2].data.0[1], &m[3].data.0[1]]);
    [m11, m21, m12, m22]
}

/// The inverse of `matrices`: four matrices from the lanes of their entries.
#[inline(always)]
fn unmatrices<V: Lane>(m11: V, m21: V, m12: V, m22: V, to: &mut [Matrix]) {
    let [a, b, c, d] = to else { panic!("four matrices") };
    let ([a0, a1], [b0, b1], [c0, c1], [d0, d1]) = (&mut a.data.0, &mut b.data.0, &mut c.data.0, &mut d.data.0);
    V::unpairs(m11, m21, [a0, b0, c0, d0]);
    V::unpairs(m12, m22, [a1, b1, c1, d1]);
}

/// Four vectors from the lanes of their entries.
#[inline(always)]
fn unvectors<V: Lane>(x: V, y: V, to: &mut [Vector]) {
    let [a, b, c, d] = to else { panic!("four vectors") };
    V::unpairs(x, y, [&mut a.data.0[0], &mut b.data.0[0], &mut c.data.0[0], &mut d.data.0[0]]);
}

/// What the end of the gathers of a run of points writes (a block, or four of its points).
struct Outs<'a> {
    x: &'a mut [Vector],
    v: &'a mut [Vector],
    f: &'a mut [Matrix],
    gv: &'a mut [Matrix],
    cu: &'a mut [Vector],
    cv: &'a mut [Vector],
}

impl Outs<'_> {
    /// The points `r`'s shares.
    #[inline(always)]
    fn four(&mut self, r: std::ops::Range<usize>) -> Outs<'_> {
        Outs {
            x: &mut self.x[r.clone()],
            v: &mut self.v[r.clone()],
            f: &mut self.f[r.clone()],
            gv: &mut self.gv[r.clone()],
            cu: &mut self.cu[r.clone()],
            cv: &mut self.cv[r],
        }
    }
}

/// The end of the gathers of four points, one per lane, from their sums `r` (see
/// `Collocated::gather4`): velocity, APIC C, ∇v, F (or J), position (wrapped at periodic
/// sides, stopped at walls), and the shares of the step's figures of the first `n` of
/// them, point l in lane l of `sums`. `out` holds the four points (start positions and F
/// read, all written).
#[inline(always)]
fn finish4<S: Lanes>(s: S, fin: &Finish, r: &[S::V; 10], out: &mut Outs, m: [&Real; 4], n: usize, sums: &mut LaneSums) {
    let (dt, one, zero) = (s.splat(fin.dt), s.splat(1.0), s.splat(0.0));
    let ih = s.splat(fin.ih);
    // ∇v = L = [[r2, r4], [r3, r5]] / h
    let (l11, l12, l21, l22) = (r[2] * ih, r[4] * ih, r[3] * ih, r[5] * ih);
    if fin.apic {
        let d = s.splat(fin.dinv);
        unvectors(r[6] * d, r[8] * d, out.cu);
        unvectors(r[7] * d, r[9] * d, out.cv);
    }
    if fin.velocity_gradient {
        unmatrices(l11, l21, l12, l22, out.gv);
    }
    // I + Δt L
    let (s11, s12) = (dt.mul_add(l11, one), dt.mul_add(l12, zero));
    let (s21, s22) = (dt.mul_add(l21, zero), dt.mul_add(l22, one));
    let [f11, f21, f12, f22] = matrices(s, [&out.f[0], &out.f[1], &out.f[2], &out.f[3]]);
    if fin.volumetric_only {
        // F = diag(J, 1): only J = det F matters to the stress (see `Lagrangian`)
        let det_step = s11 * s22 - s21 * s12;
        let det_f = f11 * f22 - f21 * f12;
        unmatrices(det_f * det_step, zero, zero, one, out.f);
    } else {
        // (I + Δt L) F, each entry as nalgebra's product takes it
        let (g11, g12) = (s11 * f11 + s12 * f21, s11 * f12 + s12 * f22);
        let (g21, g22) = (s21 * f11 + s22 * f21, s21 * f12 + s22 * f22);
        unmatrices(g11, g21, g12, g22, out.f);
    }
    let mut vel = [r[0], r[1]];
    let (x0, y0) = s.pairs([pair(&out.x[0]), pair(&out.x[1]), pair(&out.x[2]), pair(&out.x[3])]);
    let mut pos = [dt.mul_add(vel[0], x0), dt.mul_add(vel[1], y0)];
    for axis in 0..2 {
        if fin.periodic[axis] {
            // wrapped lane by lane (a remainder, not in the lanes)
            let (lo, hi) = (fin.lo[axis], fin.hi[axis]);
            let mut p = pos[axis].to_array();
            for x in &mut p {
                if *x < lo || *x >= hi {
                    *x = lo + (*x - lo).rem_euclid(hi - lo);
                }
            }
            pos[axis] = s.load(&p);
            continue;
        }
        let lo = s.splat(fin.lo[axis] + fin.eps);
        let hi = s.splat(fin.hi[axis] - fin.eps);
        let below = pos[axis].lt(lo);
        let above = S::V::and_not(pos[axis].gt(hi), below);
        pos[axis] = S::V::select(below, lo, S::V::select(above, hi, pos[axis]));
        // stopped at the wall: no velocity into it
        let into = (below & vel[axis].lt(zero)) | (above & vel[axis].gt(zero));
        vel[axis] = S::V::select(into, zero, vel[axis]);
    }
    unvectors(pos[0], pos[1], out.x);
    unvectors(vel[0], vel[1], out.v);
    let mv = s.gather(m);
    let s2 = vel[0] * vel[0] + vel[1] * vel[1];
    let ke = s.splat(0.5) * mv * s2;
    let (px, py) = (mv * vel[0], mv * vel[1]);
    sums.add(s, n, [ke, mv, px, py], s2);
}

/// Marks in one part's map `touched` (`words` per padded row) the chunks of the stencil
/// that starts on lattice node (bx, by): its columns bx .. bx + 2 on its first row.
#[inline(always)]
fn mark(touched: &mut [u64], words: usize, bx: isize, by: isize) {
    let (r, c) = ((by + PAD as isize) as usize, (bx + PAD as isize) as usize);
    for chunk in [c / CHUNK, (c + 2) / CHUNK] {
        touched[r * words + chunk / 64] |= 1 << (chunk % 64);
    }
}

/// ORs into `mask` the chunks of the stencils of one part (`touched`, `words` per row)
/// that cover padded row `r`: those starting on rows r − 2 ..= r.
#[inline]
fn or_rows(mask: &mut [u64], touched: &[u64], words: usize, r: usize) {
    for row in touched[r.saturating_sub(2) * words..(r + 1) * words].chunks(words) {
        for (m, t) in mask.iter_mut().zip(row) {
            *m |= t;
        }
    }
}

/// Calls `f` on the runs of columns (merged across adjacent chunks) of the chunks set in
/// `mask`, cut to [lo, hi).
#[inline]
fn runs(mask: &[u64], lo: usize, hi: usize, mut f: impl FnMut(std::ops::Range<usize>)) {
    let mut run: Option<(usize, usize)> = None;
    let mut emit = |(a, z): (usize, usize)| {
        let (a, z) = (a.max(lo), z.min(hi));
        if a < z {
            f(a..z);
        }
    };
    for (w, &word) in mask.iter().enumerate() {
        let mut bits = word;
        while bits != 0 {
            let c = w * 64 + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let (a, z) = (c * CHUNK, (c + 1) * CHUNK);
            run = match run {
                Some((s, e)) if e == a => Some((s, z)),
                Some(done) => {
                    emit(done);
                    Some((a, z))
                }
                None => Some((a, z)),
            };
        }
    }
    if let Some(done) = run {
        emit(done);
    }
}

/// The padded rows [lo, hi) that the stencils of one part touch, from its map `touched`
/// (`words` per row; a stencil starting on padded row r covers rows r, r + 1, r + 2);
/// (0, 0) if none.
fn touched_rows(touched: &[u64], words: usize) -> (usize, usize) {
    let height = touched.len() / words;
    let any = |r: &usize| touched[r * words..(r + 1) * words].iter().any(|&w| w != 0);
    match ((0..height).find(any), (0..height).rev().find(any)) {
        (Some(lo), Some(hi)) => (lo, (hi + 3).min(height)),
        _ => (0, 0),
    }
}

/// Zeroes what the last step left in one part's grid `acc` (padded rows of `width` nodes,
/// its map `touched` with `words` per row): the chunks of its stencils, and along a
/// periodic side the whole rows (x) or the whole grid (y) its ghosts wrapped into. At a
/// wall the ghosts fold into their stencil's own nodes (the stencil of a point clamped to
/// the far edge is marked with the nodes its ghosts mirror to: see the scatter's `note`).
fn clear_part(acc: &mut [Node], touched: &[u64], width: usize, words: usize, periodic: [bool; 2]) {
    if periodic[1] {
        acc.fill(Node::ZERO);
        return;
    }
    let mut mask = vec![0; words];
    for (q, row) in acc.chunks_mut(width).enumerate() {
        mask.fill(0);
        or_rows(&mut mask, touched, words, q);
        if periodic[0] && mask.iter().any(|&w| w != 0) {
            row.fill(Node::ZERO);
            continue;
        }
        runs(&mask, 0, width, |cols| row[cols].fill(Node::ZERO));
    }
}

/// Folds the ghost nodes of one part's grid `acc` into its lattice of `n` cells over the
/// padded `rows` (every row along a periodic y): mirrored at walls (the normal momentum
/// flips), wrapped along periodic sides, where node n is node 0.
fn fold_part(acc: &mut [Node], width: usize, n: [usize; 2], periodic: [bool; 2], rows: (usize, usize)) {
    let [px, py] = periodic;
    let (nx, ny, pad) = (n[0] as isize, n[1] as isize, PAD as isize);
    let (r0, r1) = if py { (0, acc.len() / width) } else { rows };
    let at = |i: isize, j: isize| node_index(width, i, j);
    for r in r0..r1 {
        let jg = r as isize - pad;
        let ghost_row = jg < 0 || jg > ny;
        for ig in ghost_columns(ghost_row, nx) {
            let k = at(ig, jg);
            let a = acc[k];
            if a.0 == [0.0; 4] {
                continue;
            }
            acc[k] = Node::ZERO;
            let (i, mx) = map_axis(ig, n[0], true, px);
            let (j, my) = map_axis(jg, n[1], true, py);
            let t = at(i, j);
            let sx = if mx { -1.0 } else { 1.0 };
            let sy = if my { -1.0 } else { 1.0 };
            acc[t][0] += a[0];
            acc[t][1] += sx * a[1];
            acc[t][2] += sy * a[2];
        }
    }
    let mut merge = |into: usize, from: usize| {
        let v = std::mem::replace(&mut acc[from], Node::ZERO);
        for c in 0..3 {
            acc[into][c] += v[c];
        }
    };
    if px {
        for jg in (r0 as isize - pad).max(0)..(r1 as isize - pad).min(ny + 1) {
            merge(at(0, jg), at(nx, jg));
        }
    }
    if py {
        for i in 0..=nx {
            merge(at(i, 0), at(i, ny));
        }
    }
}

/// The grid update of a run of nodes in the lanes of `s`, four nodes at a time: the two
/// parts `a` and `b` added, u = Σ m u / Σ m (0 where Σ m ≤ `tiny`) plus Δt g into `vel`.
#[inline(always)]
fn update_nodes<S: Lanes>(s: S, a: &[Node], b: &[Node], vel: &mut [[Real; 2]], tiny: Real, g: [Real; 2]) {
    let n = a.len().min(b.len()).min(vel.len());
    let mut k = 0;
    while k + 4 <= n {
        let [v0, v1, v2, v3] = &mut vel[k..k + 4] else { unreachable!() };
        update4(s, &a[k..k + 4], &b[k..k + 4], [v0, v1, v2, v3], tiny, g);
        k += 4;
    }
    if k < n {
        // the last one to three nodes, empty nodes after them
        let (mut pa, mut pb, mut v) = ([Node::ZERO; 4], [Node::ZERO; 4], [[0.0; 2]; 4]);
        pa[..n - k].copy_from_slice(&a[k..n]);
        pb[..n - k].copy_from_slice(&b[k..n]);
        let [v0, v1, v2, v3] = &mut v;
        update4(s, &pa, &pb, [v0, v1, v2, v3], tiny, g);
        vel[k..n].copy_from_slice(&v[..n - k]);
    }
}

/// `update_nodes` of four nodes, one per lane.
#[inline(always)]
fn update4<S: Lanes>(s: S, a: &[Node], b: &[Node], vel: [&mut [Real; 2]; 4], tiny: Real, g: [Real; 2]) {
    // rows [m, mx, my, 0] of the four nodes, the parts added, to lanes of m, mx, my
    let (a, b) = (&a[..4], &b[..4]);
    let r = [
        s.load(&a[0].0) + s.load(&b[0].0),
        s.load(&a[1].0) + s.load(&b[1].0),
        s.load(&a[2].0) + s.load(&b[2].0),
        s.load(&a[3].0) + s.load(&b[3].0),
    ];
    let [m, mx, my, _] = S::V::transpose4(r);
    let (keep, zero) = (m.gt(s.splat(tiny)), s.splat(0.0));
    let ux = S::V::select(keep, mx / m, zero) + s.splat(g[0]);
    let uy = S::V::select(keep, my / m, zero) + s.splat(g[1]);
    S::V::unpairs(ux, uy, vel);
}

/// `update_nodes` in AVX registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn update_nodes_avx(s: AvxFma, a: &[Node], b: &[Node], vel: &mut [[Real; 2]], tiny: Real, g: [Real; 2]) {
    update_nodes(s, a, b, vel, tiny, g)
}

/// Index of lattice node (i, j) (ghosts from −`PAD`) in a padded lattice of `width`
/// nodes per row.
#[inline(always)]
fn node_index(width: usize, i: isize, j: isize) -> usize {
    (i + PAD as isize) as usize + (j + PAD as isize) as usize * width
}

/// The ghost columns of a lattice row of `nx` cells: all of a ghost row, else the `PAD` on
/// each side.
fn ghost_columns(ghost_row: bool, nx: isize) -> impl Iterator<Item = isize> {
    let pad = PAD as isize;
    let (left, right) = if ghost_row { (nx + 1, nx + 1) } else { (0, nx + 1) };
    (-pad..left).chain(right..=nx + pad)
}

/// The lanes of the transfers: four points in portable `[f64; 4]` lanes, or in an AVX
/// register. Both run the same kernel and give the same bits: the same operations in the
/// same order per point, with a fused multiply-add (`mul_add`) in both wherever one fuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[non_exhaustive]
pub enum Simd {
    /// Four points in plain Rust lanes (any CPU).
    Portable,
    /// Four points in the lanes of an AVX register (with FMA).
    Avx,
}

impl Simd {
    /// The token of the AVX lanes, where `self` asks for them and the CPU has them.
    #[cfg(target_arch = "x86_64")]
    fn avx(self) -> Option<AvxFma> {
        if self >= Simd::Avx {
            AvxFma::detect()
        } else {
            None
        }
    }

    /// The most this CPU has (x86-64: detected at run time).
    pub fn available() -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            // the lanes use fused multiply-adds where the portable loops use `mul_add`
            if !std::arch::is_x86_feature_detected!("fma") {
                return Simd::Portable;
            }
            if std::arch::is_x86_feature_detected!("avx") {
                return Simd::Avx;
            }
        }
        Simd::Portable
    }
}

/// A wall node: the normal component takes the wall's, the tangential one the mean of the
/// inside value and its ghost (0 at a no-slip wall, the wall's at a moving one, unchanged
/// at a free-slip one). `normal`: the component normal to `side`.
#[inline]
fn wall(bc: &Boundaries, side: Side, s: Real, v: &mut [Real; 2], normal: usize) {
    if let Some(w) = bc.normal_velocity(side, s) {
        v[normal] = w;
    }
    let t = 1 - normal;
    v[t] = 0.5 * (v[t] + bc.tangential_ghost(side, v[t], s));
}

/// Lattice coordinates of `x`, (x − origin)/h, kept within [−½, n + ½]: a no-op for a point
/// in the domain, and a blown-up (infinite) one indexes the padded lattice and turns the
/// grid to NaN instead of running off it (the run then stops as unstable).
#[inline(always)]
fn lattice(g: &Grid, x: Vector) -> Vector {
    let xi = (x - g.origin) * (1.0 / g.h);
    Vector::new(xi.x.clamp(-0.5, g.nx as Real + 0.5), xi.y.clamp(-0.5, g.ny as Real + 0.5))
}

/// Lattice coordinates along `axis` of the positions `x` in the lanes (`ih` = 1/h), `lattice`'s.
#[inline(always)]
fn lattice_lanes<S: Lanes>(s: S, g: &Grid, x: S::V, ih: S::V, axis: usize) -> S::V {
    let xi = (x - s.splat(g.origin[axis])) * ih;
    let n = if axis == 0 { g.nx } else { g.ny };
    // max(lo, ξ), min(hi, ·): ξ where it is NaN, as `clamp`
    s.splat(n as Real + 0.5).min(s.splat(-0.5).max(xi))
}

/// Scatters the points `idx[..n]` (stresses `sg`) into `chunk` (padded rows of `width`
/// nodes, lattice row `row0` at its row 0, rows outside it left out): for each of a
/// point's 9 nodes, [S m, S m (v + C (x_i − x_p)) − Δt V σ ∇S, 0]. With S = wx_a wy_b and
/// ∇S = (wx_a' wy_b, wx_a wy_b')/h this is wy_b P_a + wx_a Q_b:
/// P_a = [m wx_a, m wx_a (v + C·0 dx_a) − k σ·0 wx_a'], Q_b = [0, m wy_b C·1 dy_b − k σ·1 wy_b'],
/// k = Δt V/h. The four points' weights, factors and rows are computed in the lanes of `s`
/// (one point per lane; the lanes past `n` repeat a point and are not added), then
/// transposed to one register per node row and added to the nodes, point by point.
/// Returns each point's first stencil column and row.
#[inline(always)]
fn scatter4<S: Lanes>(
    s: S,
    chunk: &mut [Node],
    width: usize,
    row0: isize,
    input: &ScatterIn,
    four: Four,
    n: usize,
) -> [(isize, isize); 4] {
    let (g, dt) = (input.grid, input.dt);
    let (h, ih, zero) = (s.splat(g.h), s.splat(1.0 / g.h), s.splat(0.0));
    let (x, y) = s.pairs(four.x.map(pair));
    let (bxv, fx, wx, dwx) = quadratic_lanes(lattice_lanes(s, g, x, ih, 0));
    let (byv, fy, wy, dwy) = quadratic_lanes(lattice_lanes(s, g, y, ih, 1));
    let m = s.gather(four.m);
    let (vx, vy) = s.pairs(four.v.map(pair));
    let ((cux, cuy), (cvx, cvy)) = if input.apic {
        (s.pairs(four.cu.map(pair)), s.pairs(four.cv.map(pair)))
    } else {
        ((zero, zero), (zero, zero))
    };
    // k = Δt V⁰ det F (1/h), with det F = F11 F22 − F21 F12
    let [f11, f21, f12, f22] = matrices(s, four.f);
    let det = f11 * f22 - f21 * f12;
    let vol0 = s.gather(four.vol0);
    let k = s.splat(dt) * vol0 * det * ih;
    let [g11, g21, g12, g22] = matrices(s, four.sg);
    let (s00, s01, s10, s11) = (k * g11, k * g12, k * g21, k * g22);
    // the rows (channels, one point per lane) transposed to one register per point
    let mut pa = [[zero; 4]; 3];
    let mut qb = [[zero; 4]; 3];
    for a in 0..3 {
        // P_a = [m wx_a, m wx_a (vx + dx_a cux) − wx_a' s00, m wx_a (vy + dx_a cvx) − wx_a' s10, 0]
        let dx = (s.splat(a as Real) - fx) * h;
        let mw = m * wx[a];
        let px = mw * (vx + dx * cux) - dwx[a] * s00;
        let py = mw * (vy + dx * cvx) - dwx[a] * s10;
        pa[a] = S::V::transpose4([mw, px, py, zero]);
        // Q_b = [0, m wy_b dy_b cuy − wy_b' s01, m wy_b dy_b cvy − wy_b' s11, 0]
        let dy = (s.splat(a as Real) - fy) * h;
        let mwd = m * wy[a] * dy;
        let qx = mwd * cuy - dwy[a] * s01;
        let qy = mwd * cvy - dwy[a] * s11;
        qb[a] = S::V::transpose4([zero, qx, qy, zero]);
    }
    let (bx, by) = (bxv.to_array(), byv.to_array());
    let (wx, wy) = (
        [wx[0].to_array(), wx[1].to_array(), wx[2].to_array()],
        [wy[0].to_array(), wy[1].to_array(), wy[2].to_array()],
    );
    let rows = (chunk.len() / width) as isize;
    let mut firsts = [(0, 0); 4];
    for l in 0..n {
        let (bx, by) = (bx[l] as isize, by[l] as isize);
        firsts[l] = (bx, by);
        let col = (bx + PAD as isize) as usize;
        for b in 0..3 {
            let r = by - row0 + b as isize;
            if r < 0 || r >= rows {
                continue;
            }
            let at = r as usize * width + col;
            let row: &mut [Node; 3] = (&mut chunk[at..at + 3]).try_into().expect("a stencil row");
            let wyb = s.splat(wy[b][l]);
            for a in 0..3 {
                let add = wyb.mul_add(pa[a][l], s.splat(wx[a][l]) * qb[b][l]);
                (s.load(&row[a].0) + add).store(&mut row[a].0);
            }
        }
    }
    firsts
}

/// The scatter of one part's points `pts` (stresses `sigma`, from `pts.start`) into its grid
/// `chunk` (as in `scatter4`), four at a time in the lanes of `s`; with `reach` = (each
/// point's first stencil row, padded, and the rows [lo, hi) of `chunk`) only the points
/// whose stencils reach those rows, still in point order. `note` gets each point's first
/// stencil node.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn scatter_points<S: Lanes>(
    s: S,
    chunk: &mut [Node],
    width: usize,
    row0: isize,
    input: &ScatterIn,
    pts: std::ops::Range<usize>,
    sigma: &[Matrix],
    reach: Option<(&[usize], usize, usize)>,
    note: &mut impl FnMut((isize, isize)),
) {
    let first = pts.start;
    let mut idx = [pts.start; 4];
    let mut n = 0;
    let mut p = pts.start;
    if reach.is_none() {
        // four in a row
        while p + 4 <= pts.end {
            let four = Four::run(input.pts, sigma, first, p);
            for f in scatter4(s, chunk, width, row0, input, four, 4) {
                note(f);
            }
            p += 4;
        }
    }
    while p < pts.end {
        let k = p - first;
        p += 1;
        if let Some((firsts, lo, hi)) = reach {
            if firsts[k] + 3 <= lo || firsts[k] >= hi {
                continue;
            }
        }
        idx[n] = k + first;
        n += 1;
        if n == 4 {
            for f in scatter4(s, chunk, width, row0, input, Four::of(input.pts, sigma, first, idx), 4) {
                note(f);
            }
            n = 0;
        }
    }
    if n > 0 {
        // the last one to three points, the last repeated in the other lanes
        let last = idx[n - 1];
        idx[n..].fill(last);
        let firsts = scatter4(s, chunk, width, row0, input, Four::of(input.pts, sigma, first, idx), n);
        for &f in &firsts[..n] {
            note(f);
        }
    }
}

/// What `scatter4` reads of its four points, one per lane.
struct Four<'a> {
    x: [&'a Vector; 4],
    v: [&'a Vector; 4],
    cu: [&'a Vector; 4],
    cv: [&'a Vector; 4],
    f: [&'a Matrix; 4],
    m: [&'a Real; 4],
    vol0: [&'a Real; 4],
    /// The stresses.
    sg: [&'a Matrix; 4],
}

impl<'a> Four<'a> {
    /// The points `idx` of `pts` (stresses `sigma` from point `first` on).
    #[inline(always)]
    fn of(pts: &'a Points, sigma: &'a [Matrix], first: usize, idx: [usize; 4]) -> Self {
        let [a, b, c, d] = idx;
        Four {
            x: [&pts.x[a], &pts.x[b], &pts.x[c], &pts.x[d]],
            v: [&pts.v[a], &pts.v[b], &pts.v[c], &pts.v[d]],
            cu: [&pts.c_u[a], &pts.c_u[b], &pts.c_u[c], &pts.c_u[d]],
            cv: [&pts.c_v[a], &pts.c_v[b], &pts.c_v[c], &pts.c_v[d]],
            f: [&pts.f[a], &pts.f[b], &pts.f[c], &pts.f[d]],
            m: [&pts.m[a], &pts.m[b], &pts.m[c], &pts.m[d]],
            vol0: [&pts.vol0[a], &pts.vol0[b], &pts.vol0[c], &pts.vol0[d]],
            sg: [&sigma[a - first], &sigma[b - first], &sigma[c - first], &sigma[d - first]],
        }
    }

    /// The points `p .. p + 4` (one bounds check per array).
    #[inline(always)]
    fn run(pts: &'a Points, sigma: &'a [Matrix], first: usize, p: usize) -> Self {
        fn four<T>(v: &[T], p: usize) -> [&T; 4] {
            let v: &[T; 4] = v[p..p + 4].try_into().expect("four points");
            v.each_ref()
        }
        Four {
            x: four(&pts.x, p),
            v: four(&pts.v, p),
            cu: four(&pts.c_u, p),
            cv: four(&pts.c_v, p),
            f: four(&pts.f, p),
            m: four(&pts.m, p),
            vol0: four(&pts.vol0, p),
            sg: four(sigma, p - first),
        }
    }
}

/// `scatter_points` in AVX registers.
#[allow(clippy::too_many_arguments)]
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn scatter_points_avx(
    s: AvxFma,
    chunk: &mut [Node],
    width: usize,
    row0: isize,
    input: &ScatterIn,
    pts: std::ops::Range<usize>,
    sigma: &[Matrix],
    reach: Option<(&[usize], usize, usize)>,
    note: &mut impl FnMut((isize, isize)),
) {
    scatter_points(s, chunk, width, row0, input, pts, sigma, reach, note)
}

/// `scatter_points` in the lanes `simd` asks for.
#[allow(clippy::too_many_arguments)]
fn scatter_lanes(
    simd: Simd,
    chunk: &mut [Node],
    width: usize,
    row0: isize,
    input: &ScatterIn,
    pts: std::ops::Range<usize>,
    sigma: &[Matrix],
    reach: Option<(&[usize], usize, usize)>,
    note: &mut impl FnMut((isize, isize)),
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = simd.avx() {
        // SAFETY: `avx` exists, so the CPU has AVX and FMA
        return unsafe { scatter_points_avx(avx, chunk, width, row0, input, pts, sigma, reach, note) };
    }
    let _ = simd;
    scatter_points(Portable, chunk, width, row0, input, pts, sigma, reach, note)
}

/// The scatter of one part's points `pts` (stresses `sigma`) into its grid `grid` by strips
/// of rows, `strips` tasks in parallel: a strip adds the points whose stencils reach its
/// rows, in point order, and leaves out the rows of the stencils that are not its own.
/// `note` gets each point's first stencil node first.
#[allow(clippy::too_many_arguments)]
fn scatter_strips(
    grid: &mut [Node],
    note: &mut impl FnMut((isize, isize)),
    width: usize,
    input: &ScatterIn,
    pts: std::ops::Range<usize>,
    sigma: &[Matrix],
    strips: usize,
    simd: Simd,
) {
    let height = grid.len() / width;
    // each point's first stencil row (padded)
    let firsts: Vec<usize> = pts
        .clone()
        .map(|p| {
            let xi = lattice(input.grid, input.pts.x[p]);
            let (bx, by) = (quadratic(xi.x).0, quadratic(xi.y).0);
            note((bx, by));
            (by + PAD as isize) as usize
        })
        .collect();
    // strips of about as many first rows each
    let mut count = vec![0usize; height];
    for &r in &firsts {
        count[r] += 1;
    }
    let mut cuts = vec![0];
    let mut seen = 0;
    for (r, c) in count.iter().enumerate() {
        seen += c;
        while cuts.len() < strips && seen * strips >= cuts.len() * firsts.len().max(1) {
            cuts.push(r + 1);
        }
    }
    cuts.resize(strips, height);
    cuts.push(height);
    let mut chunks = Vec::with_capacity(strips);
    let mut rest = grid;
    for w in cuts.windows(2) {
        let (strip, tail) = rest.split_at_mut((w[1] - w[0]) * width);
        chunks.push((strip, w[0]));
        rest = tail;
    }
    chunks.into_par_iter().for_each(|(strip, lo)| {
        let hi = lo + strip.len() / width;
        let row0 = lo as isize - PAD as isize;
        let reach = Some((&firsts[..], lo, hi));
        scatter_lanes(simd, strip, width, row0, input, pts.clone(), sigma, reach, &mut |_| {});
    });
}

/// A gather block's sums for the step's figures in four lanes: point k of the block adds
/// to lane k mod 4, in point order, so that every thread count adds the same numbers in
/// the same order; the lanes are then added in lane order (`total`).
#[derive(Default)]
struct LaneSums {
    ke: [Real; 4],
    mass: [Real; 4],
    px: [Real; 4],
    py: [Real; 4],
    /// The largest squared speed of each lane.
    s2: [Real; 4],
}

impl LaneSums {
    /// The kinetic energies, masses and momenta `v` and squared speeds `s2` of four points
    /// into their lanes, of the first `n` of them.
    #[inline(always)]
    fn add<S: Lanes>(&mut self, s: S, n: usize, v: [S::V; 4], s2: S::V) {
        if n == 4 {
            for (acc, v) in [&mut self.ke, &mut self.mass, &mut self.px, &mut self.py].into_iter().zip(v) {
                (s.load(acc) + v).store(acc);
            }
            // a NaN stays out: max(s2, acc) is acc unless s2 > acc
            s2.max(s.load(&self.s2)).store(&mut self.s2);
            return;
        }
        let (ke, m, px, py, s2) = (v[0].to_array(), v[1].to_array(), v[2].to_array(), v[3].to_array(), s2.to_array());
        for l in 0..n {
            self.ke[l] += ke[l];
            self.mass[l] += m[l];
            self.px[l] += px[l];
            self.py[l] += py[l];
            if s2[l] > self.s2[l] {
                self.s2[l] = s2[l];
            }
        }
    }

    /// The lanes added in order (the largest squared speed, not yet its root).
    fn total(&self) -> FrameFigures {
        let mut f = FrameFigures::default();
        for l in 0..4 {
            f.kinetic_energy += self.ke[l];
            f.mass += self.mass[l];
            f.momentum.x += self.px[l];
            f.momentum.y += self.py[l];
            if self.s2[l] > f.max_speed {
                f.max_speed = self.s2[l];
            }
        }
        f
    }
}

/// What the end of a point's gather needs besides its sums.
struct Finish {
    dt: Real,
    /// 1/h (a product, not a quotient, in every lane: no division in the loops)
    ih: Real,
    /// Whether to write ∇v at the points (a point-stress model reads it).
    velocity_gradient: bool,
    dinv: Real,
    apic: bool,
    volumetric_only: bool,
    lo: Vector,
    hi: Vector,
    eps: Real,
    periodic: [bool; 2],
}
