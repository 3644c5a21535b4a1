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
//! number of threads. With AVX and FMA (x86-64, detected at run time) the scatter adds a
//! node's four sums in one register and the gather takes four points at a time, by the
//! same operations in the same order as the portable loops, which use `mul_add` where the
//! lanes fuse a multiply-add: the same bits with or without AVX.
//!
//! Each part clears the grid it filled at its next scatter, on its own thread, and folds
//! its ghost nodes in there too; the grid update only reads the parts. Only the chunks of
//! 8 nodes that the points' stencils reached are updated and cleared (a map per row): a
//! splash that spans the box touches a few chunks per row away from the bulk.
use super::scatter::map_axis;
use super::shape::{quadratic, Shape};
use super::{Points, Transfer};
use multifield_core::boundary::{Boundaries, Side};
use multifield_core::grid::Grid;
use multifield_core::math::{Matrix, Real, Vector};
use multifield_core::plugin::{FrameFigures, PointStressContext, StressModel};
use rayon::prelude::*;

/// `shape::quadratic` in the four lanes of an AVX register of lattice coordinates: (base as f64,
/// fraction, weights, derivatives), by the same operations. A macro, so that it is inlined
/// into the AVX functions that use it (the two transfers).
#[cfg(target_arch = "x86_64")]
macro_rules! bspline4 {
    ($xi:expr) => {{
        let v = $xi;
        let base = _mm256_sub_pd(
            _mm256_cvtepi32_pd(_mm256_cvttpd_epi32(_mm256_add_pd(v, _mm256_set1_pd(0.5)))),
            _mm256_set1_pd(1.0),
        );
        let f = _mm256_sub_pd(v, base);
        let a = _mm256_sub_pd(_mm256_set1_pd(1.5), f);
        let b = _mm256_sub_pd(f, _mm256_set1_pd(1.0));
        let c = _mm256_sub_pd(f, _mm256_set1_pd(0.5));
        let half = _mm256_set1_pd(0.5);
        let w = [
            _mm256_mul_pd(_mm256_mul_pd(half, a), a),
            _mm256_sub_pd(_mm256_set1_pd(0.75), _mm256_mul_pd(b, b)),
            _mm256_mul_pd(_mm256_mul_pd(half, c), c),
        ];
        let dw = [_mm256_xor_pd(a, _mm256_set1_pd(-0.0)), _mm256_mul_pd(_mm256_set1_pd(-2.0), b), c];
        (base, f, w, dw)
    }};
}

/// Four f64 (an array) into the lanes of an AVX register. The lanes' helpers are macros,
/// not closures: a closure called from a `target_feature` function is not always inlined,
/// and then every intrinsic in it is a call.
#[cfg(target_arch = "x86_64")]
macro_rules! load4 {
    ($v:expr) => {{
        let v: [Real; 4] = $v;
        // SAFETY: four f64
        unsafe { _mm256_loadu_pd(v.as_ptr()) }
    }};
}

/// The 4 × 4 transpose of four AVX registers: lane l of row k to lane k of row l.
#[cfg(target_arch = "x86_64")]
macro_rules! transpose4 {
    ($r0:expr, $r1:expr, $r2:expr, $r3:expr) => {{
        let (t0, t1) = (_mm256_unpacklo_pd($r0, $r1), _mm256_unpackhi_pd($r0, $r1));
        let (t2, t3) = (_mm256_unpacklo_pd($r2, $r3), _mm256_unpackhi_pd($r2, $r3));
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
            _mm256_permute2f128_pd::<0x31>(t1, t3),
        ]
    }};
}

/// The four lanes of an AVX register as an array.
#[cfg(target_arch = "x86_64")]
macro_rules! store4 {
    ($v:expr) => {{
        let mut out = [0.0; 4];
        // SAFETY: four f64
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), $v) };
        out
    }};
}

/// Four vectors (x, y), contiguous, as the lanes [x0 x1 x2 x3], [y0 y1 y2 y3]: two loads
/// and four shuffles (`$v` a slice of at least four `Vector`s).
#[cfg(target_arch = "x86_64")]
macro_rules! soa2 {
    ($v:expr) => {{
        let v: &[Vector] = $v;
        assert!(v.len() >= 4);
        let p = v.as_ptr() as *const Real;
        // SAFETY: four vectors of two f64, contiguous (nalgebra's storage)
        let (a, b) = unsafe { (_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(4))) };
        let (t0, t1) = (_mm256_permute2f128_pd::<0x20>(a, b), _mm256_permute2f128_pd::<0x31>(a, b));
        (_mm256_unpacklo_pd(t0, t1), _mm256_unpackhi_pd(t0, t1))
    }};
}

/// Four 2 × 2 matrices, contiguous (column-major: m11, m21, m12, m22), as the lanes of
/// their entries [m11, m21, m12, m22]: four loads and eight shuffles.
#[cfg(target_arch = "x86_64")]
macro_rules! soa4 {
    ($m:expr) => {{
        let m: &[Matrix] = $m;
        assert!(m.len() >= 4);
        let p = m.as_ptr() as *const Real;
        // SAFETY: four matrices of four f64, contiguous
        let r = unsafe {
            [_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(4)), _mm256_loadu_pd(p.add(8)), _mm256_loadu_pd(p.add(12))]
        };
        transpose4!(r[0], r[1], r[2], r[3])
    }};
}

/// The inverse of `soa2!`: the lanes [x0 x1 x2 x3], [y0 y1 y2 y3] stored as four vectors
/// into `$to` (a slice of at least four `Vector`s).
#[cfg(target_arch = "x86_64")]
macro_rules! aos2 {
    ($a:expr, $b:expr, $to:expr) => {{
        let to: &mut [Vector] = $to;
        assert!(to.len() >= 4);
        let (lo, hi) = (_mm256_unpacklo_pd($a, $b), _mm256_unpackhi_pd($a, $b));
        let p = to.as_mut_ptr() as *mut Real;
        // SAFETY: four vectors of two f64, contiguous
        unsafe {
            _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(lo, hi));
            _mm256_storeu_pd(p.add(4), _mm256_permute2f128_pd::<0x31>(lo, hi));
        }
    }};
}

/// The inverse of `soa4!`: four matrices from the lanes of their entries (m11, m21, m12,
/// m22) into `$to` (a slice of at least four `Matrix`es).
#[cfg(target_arch = "x86_64")]
macro_rules! aos4 {
    ($m11:expr, $m21:expr, $m12:expr, $m22:expr, $to:expr) => {{
        let to: &mut [Matrix] = $to;
        assert!(to.len() >= 4);
        let m = transpose4!($m11, $m21, $m12, $m22);
        let p = to.as_mut_ptr() as *mut Real;
        // SAFETY: four matrices of four f64, contiguous
        unsafe {
            for (k, m) in m.into_iter().enumerate() {
                _mm256_storeu_pd(p.add(4 * k), m);
            }
        }
    }};
}

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
    /// point is finite and in the domain (the gather keeps it there), which the AVX loops'
    /// unchecked indexing needs. After a blown-up step the portable loops run, which keep
    /// a NaN or infinite point on the padded lattice (`lattice`).
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
        self.scatter(&input, &mut stress, &mut state, [bc.periodic_x(), bc.periodic_y()]);
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
        let (width, avx) = (self.width, self.simd >= Simd::Avx && self.finite);
        let row0 = -(PAD as isize); // lattice row of padded row 0
        let height = self.height;
        let (s0, s1) = stress.split_at_mut(n / PARTS);
        let parts: Vec<&mut [Matrix]> = vec![s0, s1];
        let words = self.words;
        let (nxi, nyi) = (nx as isize, ny as isize);
        let strips = rayon::current_num_threads().div_ceil(PARTS);
        let simd = self.simd;
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
                if strips > 1 {
                    scatter_strips(grid, touched, width, [nx, ny], input, pts, sigma, strips, simd);
                    let rows = touched_rows(touched, words);
                    fold_part(grid, width, [nx, ny], periodic, rows);
                    return rows;
                }
                let first = pts.start;
                let mut note = |(bx, by): (isize, isize)| {
                    mark(touched, words, bx, by);
                    // a point clamped to the lattice's far edge (not finite) starts its stencil
                    // on node n, whose ghosts n + 1, n + 2 mirror to n − 1, n − 2
                    if bx >= nxi || by >= nyi {
                        mark(touched, words, bx.min(nxi - 2).max(-1), by.min(nyi - 2).max(-1));
                    }
                };
                let mut p = pts.start;
                #[cfg(target_arch = "x86_64")]
                if avx {
                    while p + 4 <= pts.end {
                        let s = &sigma[p - first..p - first + 4];
                        // SAFETY: `avx` only where the CPU has AVX and FMA (`Collocated::use_simd`)
                        unsafe { scatter4_avx(grid, width, row0, input, p, s) }.into_iter().for_each(&mut note);
                        p += 4;
                    }
                }
                // the portable loop, or the last one to three points of the part
                for p in p..pts.end {
                    note(scatter_point(grid, width, row0, input, p, &sigma[p - first]));
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
        let (px, py) = (bc.periodic_x(), bc.periodic_y());
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
        let avx = self.simd >= Simd::Avx;
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
                    if avx {
                        // SAFETY: `simd` is at most what the CPU has (`Collocated::use_simd`)
                        return unsafe { update_nodes_avx(a, b, v, tiny, [gx, gy]) };
                    }
                    update_nodes(a, b, v, tiny, [gx, gy]);
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
        let (px, py) = (bc.periodic_x(), bc.periodic_y());
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
        // the end of the gather in the lanes too: a `volumetric_only` field with walls on
        // every side (`finish4`)
        let lanes_finish = volumetric_only && !px && !py;
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
                let mut k0 = 0;
                while k0 < m.len() {
                    // four points at a time with AVX, then one at a time
                    let n = if simd == Simd::Avx && m.len() - k0 >= 4 { 4 } else { 1 };
                    let r = k0..k0 + n;
                    k0 += n;
                    #[cfg(target_arch = "x86_64")]
                    if n > 1 {
                        let x = &block.x;
                        let xs = [x[r.start], x[r.start + 1], x[r.start + 2], x[r.start + 3]];
                        let mut raw = [[0.0; 10]; 4];
                        let mut sink = if lanes_finish {
                            Sink::Finish { fin: &fin, out: block.four(r.clone()), m: &m[r.clone()], sums: &mut sums }
                        } else {
                            Sink::Raw(&mut raw)
                        };
                        // SAFETY: `simd` is at most what the CPU has (`Collocated::use_simd`)
                        unsafe { self.gather4_avx(grid, &xs, &mut sink) };
                        if !lanes_finish {
                            for (k, r) in r.zip(&raw) {
                                // SAFETY: `simd` is at most what the CPU has (`Collocated::use_simd`)
                                unsafe { finish_point_fma(&fin, r, m[k], block.point(k), k % 4, &mut sums) };
                            }
                        }
                        continue;
                    }
                    let k = r.start;
                    let raw = self.gather_point(grid, block.x[k]);
                    finish_point(&fin, &raw, m[k], block.point(k), k % 4, &mut sums);
                }
                sums.total()
            })
            .collect();
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

    /// The raw sums of one point's gather, 10 of them: Σ S u (2), Σ u ∂S/∂ξ (2),
    /// Σ u ∂S/∂η (2), Σ S u (x_i − x_p) (2), Σ S u (y_i − y_p) (2), each for the
    /// components (x, y). `gather4_avx` computes them for four points in the lanes of a
    /// register, by the same operations in the same order: the
    /// same bits.
    #[inline(always)]
    fn gather_point(&self, grid: &Grid, x: Vector) -> [Real; 10] {
        let h = grid.h;
        let xi = lattice(grid, x);
        let (bx, fx, wx, dwx) = quadratic(xi.x);
        let (by, fy, wy, dwy) = quadratic(xi.y);
        let wxd: [Real; 3] = std::array::from_fn(|a| (a as Real - fx) * h * wx[a]);
        let (mut u, mut gx, mut gy, mut ax, mut ay) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2]);
        let k0 = self.index(bx, by);
        let rows = &self.vel[k0..k0 + 2 * self.width + 3];
        for b in 0..3 {
            let row = &rows[b * self.width..b * self.width + 3];
            let (mut s, mut t, mut r) = ([0.0; 2], [0.0; 2], [0.0; 2]);
            for a in 0..3 {
                for c in 0..2 {
                    s[c] = wx[a].mul_add(row[a][c], s[c]);
                    t[c] = dwx[a].mul_add(row[a][c], t[c]);
                    r[c] = wxd[a].mul_add(row[a][c], r[c]);
                }
            }
            let wdy = wy[b] * (b as Real - fy) * h;
            for c in 0..2 {
                u[c] = wy[b].mul_add(s[c], u[c]);
                gx[c] = wy[b].mul_add(t[c], gx[c]);
                gy[c] = dwy[b].mul_add(s[c], gy[c]);
                ax[c] = wy[b].mul_add(r[c], ax[c]);
                ay[c] = wdy.mul_add(s[c], ay[c]);
            }
        }
        [u[0], u[1], gx[0], gx[1], gy[0], gy[1], ax[0], ax[1], ay[0], ay[1]]
    }

    /// First stencil node of each of the points at lattice bases `bx`, `by`. Every stencil
    /// lies in the padded lattice: the lanes run only while every point is finite
    /// (`Collocated::finite`), and a finite point is in the domain, 0 ≤ ξ ≤ n, which puts
    /// its first node in [−1, n − 1] and its last in [1, n + 1].
    #[cfg(target_arch = "x86_64")]
    fn first_nodes(&self, bx: [Real; 4], by: [Real; 4]) -> [usize; 4] {
        std::array::from_fn(|l| {
            assert!(bx[l] >= -1.0 && by[l] >= -1.0 && bx[l] <= self.nx as Real && by[l] <= self.ny as Real);
            self.index(bx[l] as isize, by[l] as isize)
        })
    }

    /// `gather_point` for the four points at `x`, one per lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,fma")]
    fn gather4_avx(&self, grid: &Grid, x: &[Vector], sink: &mut Sink) {
        use std::arch::x86_64::*;
        let h = grid.h;
        let ih = 1.0 / h;
        let xi: [Vector; 4] = std::array::from_fn(|l| (x[l] - grid.origin) * ih);
        let (bxv, fx, wx, dwx) = bspline4!(load4!(arr4(|l| xi[l].x)));
        let (byv, fy, wy, dwy) = bspline4!(load4!(arr4(|l| xi[l].y)));
        let (mut bx, mut by) = ([0.0; 4], [0.0; 4]);
        // SAFETY: four f64 each
        unsafe {
            _mm256_storeu_pd(bx.as_mut_ptr(), bxv);
            _mm256_storeu_pd(by.as_mut_ptr(), byv);
        }
        let k0 = self.first_nodes(bx, by);
        let hv = _mm256_set1_pd(h);
        let mut wxd: [__m256d; 3] = [_mm256_setzero_pd(); 3];
        for a in 0..3 {
            wxd[a] = _mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_set1_pd(a as Real), fx), hv), wx[a]);
        }
        let z = _mm256_setzero_pd();
        let (mut u, mut gx, mut gy, mut ax, mut ay) = ([z; 2], [z; 2], [z; 2], [z; 2], [z; 2]);
        let base = self.vel.as_ptr() as *const Real;
        for b in 0..3 {
            let (mut s, mut t, mut r) = ([z; 2], [z; 2], [z; 2]);
            for a in 0..3 {
                let o = b * self.width + a;
                // SAFETY: k0[l] + o < vel.len() (`first_nodes`); a node is two f64
                let uv = unsafe {
                    let p: [__m128d; 4] = [
                        _mm_loadu_pd(base.add(2 * (k0[0] + o))),
                        _mm_loadu_pd(base.add(2 * (k0[1] + o))),
                        _mm_loadu_pd(base.add(2 * (k0[2] + o))),
                        _mm_loadu_pd(base.add(2 * (k0[3] + o))),
                    ];
                    let v02 = _mm256_set_m128d(p[2], p[0]);
                    let v13 = _mm256_set_m128d(p[3], p[1]);
                    [_mm256_unpacklo_pd(v02, v13), _mm256_unpackhi_pd(v02, v13)]
                };
                for c in 0..2 {
                    s[c] = _mm256_fmadd_pd(wx[a], uv[c], s[c]);
                    t[c] = _mm256_fmadd_pd(dwx[a], uv[c], t[c]);
                    r[c] = _mm256_fmadd_pd(wxd[a], uv[c], r[c]);
                }
            }
            let wdy = _mm256_mul_pd(_mm256_mul_pd(wy[b], _mm256_sub_pd(_mm256_set1_pd(b as Real), fy)), hv);
            for c in 0..2 {
                u[c] = _mm256_fmadd_pd(wy[b], s[c], u[c]);
                gx[c] = _mm256_fmadd_pd(wy[b], t[c], gx[c]);
                gy[c] = _mm256_fmadd_pd(dwy[b], s[c], gy[c]);
                ax[c] = _mm256_fmadd_pd(wy[b], r[c], ax[c]);
                ay[c] = _mm256_fmadd_pd(wdy, s[c], ay[c]);
            }
        }
        sink.put(&[u[0], u[1], gx[0], gx[1], gy[0], gy[1], ax[0], ax[1], ay[0], ay[1]], x);
    }
}

/// Where the lanes of a gather put their sums: the raw sums (see `gather_point`), or the
/// end of the points' gathers (`finish_point` in the lanes; a `volumetric_only` field with
/// walls on every side).
#[cfg(target_arch = "x86_64")]
enum Sink<'a> {
    Raw(&'a mut [[Real; 10]]),
    Finish { fin: &'a Finish, out: Outs<'a>, m: &'a [Real], sums: &'a mut LaneSums },
}

#[cfg(target_arch = "x86_64")]
impl Sink<'_> {
    /// The sums `all` of the four points (start positions `x`), one per lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,fma")]
    fn put(&mut self, all: &[std::arch::x86_64::__m256d; 10], x: &[Vector]) {
        match self {
            Sink::Raw(out) => {
                for (k, v) in all.iter().enumerate() {
                    let mut lane = [0.0; 4];
                    // SAFETY: four f64
                    unsafe { std::arch::x86_64::_mm256_storeu_pd(lane.as_mut_ptr(), *v) };
                    for l in 0..4 {
                        out[l][k] = lane[l];
                    }
                }
            }
            Sink::Finish { fin, out, m, sums } => finish4(fin, all, x, out, m, sums),
        }
    }
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
    /// Point `k`'s share.
    fn point(&mut self, k: usize) -> Out<'_> {
        Out {
            x: &mut self.x[k],
            v: &mut self.v[k],
            f: &mut self.f[k],
            gv: &mut self.gv[k],
            cu: &mut self.cu[k],
            cv: &mut self.cv[k],
        }
    }

    /// The points `r`'s shares.
    #[cfg(target_arch = "x86_64")]
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
/// `finish_point` for four points of a `volumetric_only` field with walls on every side,
/// one point per lane, from their sums `r` (the registers of `gather_point`'s ten sums) and
/// start positions `x`: the same operations, the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn finish4(
    fin: &Finish,
    r: &[std::arch::x86_64::__m256d; 10],
    x: &[Vector],
    out: &mut Outs,
    m: &[Real],
    sums: &mut LaneSums,
) {
    use std::arch::x86_64::*;
    assert!(
        x.len() == 4 && out.x.len() == 4 && out.v.len() == 4 && out.f.len() == 4 && out.gv.len() == 4 && m.len() == 4
    );
    assert!(out.cu.len() == 4 && out.cv.len() == 4);
    let (dt, one, zero) = (_mm256_set1_pd(fin.dt), _mm256_set1_pd(1.0), _mm256_setzero_pd());
    let ih = _mm256_set1_pd(fin.ih);
    let (l11, l12) = (_mm256_mul_pd(r[2], ih), _mm256_mul_pd(r[4], ih));
    let (l21, l22) = (_mm256_mul_pd(r[3], ih), _mm256_mul_pd(r[5], ih));
    if fin.apic {
        let d = _mm256_set1_pd(fin.dinv);
        aos2!(_mm256_mul_pd(r[6], d), _mm256_mul_pd(r[8], d), out.cu);
        aos2!(_mm256_mul_pd(r[7], d), _mm256_mul_pd(r[9], d), out.cv);
    }
    let (s11, s12) = (_mm256_fmadd_pd(dt, l11, one), _mm256_fmadd_pd(dt, l12, zero));
    let (s21, s22) = (_mm256_fmadd_pd(dt, l21, zero), _mm256_fmadd_pd(dt, l22, one));
    let det_step = _mm256_sub_pd(_mm256_mul_pd(s11, s22), _mm256_mul_pd(s21, s12));
    let [f11, f21, f12, f22] = soa4!(&*out.f);
    let det_f = _mm256_sub_pd(_mm256_mul_pd(f11, f22), _mm256_mul_pd(f21, f12));
    let j = _mm256_mul_pd(det_f, det_step);
    if fin.velocity_gradient {
        aos4!(l11, l21, l12, l22, out.gv);
    }
    aos4!(j, zero, zero, one, out.f);
    let mut vel = [r[0], r[1]];
    let (x0, y0) = soa2!(x);
    let mut pos = [_mm256_fmadd_pd(dt, vel[0], x0), _mm256_fmadd_pd(dt, vel[1], y0)];
    for axis in 0..2 {
        let lo = _mm256_set1_pd(fin.lo[axis] + fin.eps);
        let hi = _mm256_set1_pd(fin.hi[axis] - fin.eps);
        let below = _mm256_cmp_pd::<_CMP_LT_OQ>(pos[axis], lo);
        let above = _mm256_andnot_pd(below, _mm256_cmp_pd::<_CMP_GT_OQ>(pos[axis], hi));
        pos[axis] = _mm256_blendv_pd(_mm256_blendv_pd(pos[axis], lo, below), hi, above);
        let into_low = _mm256_and_pd(below, _mm256_cmp_pd::<_CMP_LT_OQ>(vel[axis], zero));
        let into_high = _mm256_and_pd(above, _mm256_cmp_pd::<_CMP_GT_OQ>(vel[axis], zero));
        // the comparisons' lanes are all ones or all zeros: and-not is the blend with 0
        vel[axis] = _mm256_andnot_pd(_mm256_or_pd(into_low, into_high), vel[axis]);
    }
    aos2!(pos[0], pos[1], out.x);
    aos2!(vel[0], vel[1], out.v);
    let mv = load4!(m.try_into().expect("four masses"));
    let s2 = _mm256_add_pd(_mm256_mul_pd(vel[0], vel[0]), _mm256_mul_pd(vel[1], vel[1]));
    let ke = _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(0.5), mv), s2);
    let (px, py) = (_mm256_mul_pd(mv, vel[0]), _mm256_mul_pd(mv, vel[1]));
    // the block's sums, lane by lane (`LaneSums::add`); max(s2, acc) is acc unless s2 > acc
    for (acc, v) in [(&mut sums.ke, ke), (&mut sums.mass, mv), (&mut sums.px, px), (&mut sums.py, py)] {
        // SAFETY: four f64
        unsafe { _mm256_storeu_pd(acc.as_mut_ptr(), _mm256_add_pd(_mm256_loadu_pd(acc.as_ptr()), v)) };
    }
    // SAFETY: four f64
    unsafe { _mm256_storeu_pd(sums.s2.as_mut_ptr(), _mm256_max_pd(s2, _mm256_loadu_pd(sums.s2.as_ptr()))) };
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

/// The grid update of a run of nodes: the two parts `a` and `b` added, u = Σ m u / Σ m
/// (0 where Σ m ≤ `tiny`) plus Δt g into `vel`.
#[inline(always)]
fn update_nodes(a: &[Node], b: &[Node], vel: &mut [[Real; 2]], tiny: Real, g: [Real; 2]) {
    for ((a, b), v) in a.iter().zip(b).zip(vel.iter_mut()) {
        let (m, mx, my) = (a[0] + b[0], a[1] + b[1], a[2] + b[2]);
        let (ux, uy) = if m > tiny { (mx / m, my / m) } else { (0.0, 0.0) };
        *v = [ux + g[0], uy + g[1]];
    }
}

/// `update_nodes` four nodes at a time in the lanes of AVX registers (the divisions four
/// at once): the same operations, the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn update_nodes_avx(a: &[Node], b: &[Node], vel: &mut [[Real; 2]], tiny: Real, g: [Real; 2]) {
    use std::arch::x86_64::*;
    let n = a.len().min(b.len()).min(vel.len());
    let (least, gx, gy) = (_mm256_set1_pd(tiny), _mm256_set1_pd(g[0]), _mm256_set1_pd(g[1]));
    let mut k = 0;
    while k + 4 <= n {
        // SAFETY: nodes k .. k + 4 of `a`, `b` and `vel` exist (k + 4 ≤ n); a node is four
        // f64 (32-byte aligned), a velocity two
        unsafe {
            let (pa, pb) = (a.as_ptr().add(k) as *const Real, b.as_ptr().add(k) as *const Real);
            // rows [m, mx, my, 0] of the four nodes, the parts added
            let s: [__m256d; 4] =
                std::array::from_fn(|l| _mm256_add_pd(_mm256_load_pd(pa.add(4 * l)), _mm256_load_pd(pb.add(4 * l))));
            let (t0, t1) = (_mm256_unpacklo_pd(s[0], s[1]), _mm256_unpackhi_pd(s[0], s[1]));
            let (t2, t3) = (_mm256_unpacklo_pd(s[2], s[3]), _mm256_unpackhi_pd(s[2], s[3]));
            let m = _mm256_permute2f128_pd::<0x20>(t0, t2);
            let mx = _mm256_permute2f128_pd::<0x20>(t1, t3);
            let my = _mm256_permute2f128_pd::<0x31>(t0, t2);
            let keep = _mm256_cmp_pd::<_CMP_GT_OQ>(m, least);
            let ux = _mm256_add_pd(_mm256_and_pd(_mm256_div_pd(mx, m), keep), gx);
            let uy = _mm256_add_pd(_mm256_and_pd(_mm256_div_pd(my, m), keep), gy);
            let (lo, hi) = (_mm256_unpacklo_pd(ux, uy), _mm256_unpackhi_pd(ux, uy));
            let pv = vel.as_mut_ptr().add(k) as *mut Real;
            _mm256_storeu_pd(pv, _mm256_permute2f128_pd::<0x20>(lo, hi));
            _mm256_storeu_pd(pv.add(4), _mm256_permute2f128_pd::<0x31>(lo, hi));
        }
        k += 4;
    }
    update_nodes(&a[k..n], &b[k..n], &mut vel[k..n], tiny, g);
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

/// The lanes of the transfers: the portable loops, or four points per AVX register. Both
/// give the same bits: the same operations in the same order per point, with a fused
/// multiply-add (`mul_add`) in the portable loops wherever the lanes fuse one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[non_exhaustive]
pub enum Simd {
    /// One point at a time, in plain Rust (any CPU).
    Portable,
    /// Four points in the lanes of an AVX register (with FMA).
    Avx,
}

impl Simd {
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

/// `[f(0), f(1), f(2), f(3)]`: the four lanes of a register, one per point.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn arr4(f: impl Fn(usize) -> Real) -> [Real; 4] {
    [f(0), f(1), f(2), f(3)]
}

/// det F of a 2 × 2 matrix, written out so that the scalar and the AVX scatter compute
/// it by the same operations.
#[inline(always)]
fn det2(f: &Matrix) -> Real {
    f.m11 * f.m22 - f.m21 * f.m12
}

/// Scatters point `p` into `chunk` (padded rows of `width` nodes, lattice row `row0` at
/// its row 0): for each of its 9 nodes, [S m, S m (v + C (x_i − x_p)) − Δt V σ ∇S, 0].
/// With S = wx_a wy_b and ∇S = (wx_a' wy_b, wx_a wy_b')/h this is wy_b P_a + wx_a Q_b:
/// P_a = [m wx_a, m wx_a (v + C·0 dx_a) − k σ·0 wx_a'], Q_b = [0, m wy_b C·1 dy_b − k σ·1 wy_b'],
/// k = Δt V/h.
#[inline(always)]
fn scatter_point(
    chunk: &mut [Node],
    width: usize,
    row0: isize,
    input: &ScatterIn,
    p: usize,
    sg: &Matrix,
) -> (isize, isize) {
    let (g, pts, dt) = (input.grid, input.pts, input.dt);
    let h = g.h;
    let xi = lattice(g, pts.x[p]);
    let (bx, fx, wx, dwx) = quadratic(xi.x);
    let (by, fy, wy, dwy) = quadratic(xi.y);
    let (m, v) = (pts.m[p], pts.v[p]);
    let (cu, cv) = if input.apic { (pts.c_u[p], pts.c_v[p]) } else { (Vector::zeros(), Vector::zeros()) };
    let k = dt * pts.vol0[p] * det2(&pts.f[p]) * (1.0 / h);
    let (s00, s01, s10, s11) = (k * sg.m11, k * sg.m12, k * sg.m21, k * sg.m22);
    let mut pa = [[0.0; 4]; 3];
    let mut qb = [[0.0; 4]; 3];
    for a in 0..3 {
        let dx = (a as Real - fx) * h;
        let mw = m * wx[a];
        pa[a] = [mw, mw * (v.x + dx * cu.x) - dwx[a] * s00, mw * (v.y + dx * cv.x) - dwx[a] * s10, 0.0];
        let dy = (a as Real - fy) * h;
        let mwd = m * wy[a] * dy;
        qb[a] = [0.0, mwd * cu.y - dwy[a] * s01, mwd * cv.y - dwy[a] * s11, 0.0];
    }
    let col = (bx + PAD as isize) as usize;
    // the stencil's rows in `chunk`, which holds the padded rows from lattice row `row0` on
    let first = by - row0;
    for b in 0..3 {
        let r = first + b as isize;
        if r < 0 || r as usize * width >= chunk.len() {
            continue;
        }
        let at = r as usize * width + col;
        let row = &mut chunk[at..at + 3];
        for a in 0..3 {
            for c in 0..4 {
                row[a][c] += wy[b].mul_add(pa[a][c], wx[a] * qb[b][c]);
            }
        }
    }
    (bx, by)
}

/// The scatter of one part's points `pts` (stresses `sigma`) into its grid `grid` by strips
/// of rows, `strips` tasks in parallel: a strip adds the points whose stencils reach its
/// rows, in point order, and leaves out the rows of the stencils that are not its own. The
/// part's map `touched` is filled first (`words` a row, the lattice `n` cells).
#[allow(clippy::too_many_arguments)]
fn scatter_strips(
    grid: &mut [Node],
    touched: &mut [u64],
    width: usize,
    n: [usize; 2],
    input: &ScatterIn,
    pts: std::ops::Range<usize>,
    sigma: &[Matrix],
    strips: usize,
    simd: Simd,
) {
    let height = grid.len() / width;
    let words = touched.len() / height;
    let (nx, ny) = (n[0] as isize, n[1] as isize);
    // each point's first stencil row (padded), and the map of the part's stencils
    let firsts: Vec<usize> = pts
        .clone()
        .map(|p| {
            let xi = lattice(input.grid, input.pts.x[p]);
            let (bx, by) = (quadratic(xi.x).0, quadratic(xi.y).0);
            mark(touched, words, bx, by);
            // a point clamped to the lattice's far edge (see the scatter's `note`)
            if bx >= nx || by >= ny {
                mark(touched, words, bx.min(nx - 2).max(-1), by.min(ny - 2).max(-1));
            }
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
        let run = |strip: &mut [Node]| {
            for (k, p) in pts.clone().enumerate() {
                if firsts[k] + 3 > lo && firsts[k] < hi {
                    scatter_point(strip, width, lo as isize - PAD as isize, input, p, &sigma[k]);
                }
            }
        };
        #[cfg(target_arch = "x86_64")]
        if simd >= Simd::Avx {
            // SAFETY: `simd` is at most what the CPU has (`Collocated::use_simd`)
            return unsafe { with_fma(strip, run) };
        }
        run(strip);
    });
}

/// `run(strip)` compiled with FMA, so that `scatter_point`'s `mul_add`s are instructions
/// (the x86-64 baseline calls libm's `fma`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
#[inline]
fn with_fma(strip: &mut [Node], run: impl Fn(&mut [Node])) {
    run(strip)
}

/// `scatter_point` for the four points `p .. p + 4` (stresses `sg`): their weights, stress
/// factors and node sums computed in the lanes of AVX registers (one point per lane), then
/// transposed to one register per node and added to it. The same
/// operations in the same order per point: the same bits. Returns each point's first
/// stencil column and row.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn scatter4_avx(
    chunk: &mut [Node],
    width: usize,
    row0: isize,
    input: &ScatterIn,
    p: usize,
    sg: &[Matrix],
) -> [(isize, isize); 4] {
    use std::arch::x86_64::*;
    let (g, pts, dt) = (input.grid, input.pts, input.dt);
    let h = g.h;
    let (hv, zero) = (_mm256_set1_pd(h), _mm256_setzero_pd());
    let ih = _mm256_set1_pd(1.0 / h);
    let r = p..p + 4;
    let (x, y) = soa2!(&pts.x[r.clone()]);
    let xi_x = _mm256_mul_pd(_mm256_sub_pd(x, _mm256_set1_pd(g.origin.x)), ih);
    let xi_y = _mm256_mul_pd(_mm256_sub_pd(y, _mm256_set1_pd(g.origin.y)), ih);
    let (bxv, fx, wx, dwx) = bspline4!(xi_x);
    let (byv, fy, wy, dwy) = bspline4!(xi_y);
    let m = load4!(pts.m[r.clone()].try_into().expect("four masses"));
    let (vx, vy) = soa2!(&pts.v[r.clone()]);
    let ((cux, cuy), (cvx, cvy)) = if input.apic {
        (soa2!(&pts.c_u[r.clone()]), soa2!(&pts.c_v[r.clone()]))
    } else {
        ((zero, zero), (zero, zero))
    };
    // k = Δt V⁰ det F (1/h), with det F = F11 F22 − F21 F12 (`det2`)
    let [f11, f21, f12, f22] = soa4!(&pts.f[r.clone()]);
    let det = _mm256_sub_pd(_mm256_mul_pd(f11, f22), _mm256_mul_pd(f21, f12));
    let vol0 = load4!(pts.vol0[r].try_into().expect("four volumes"));
    let k = _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(dt), vol0), det), ih);
    let [g11, g21, g12, g22] = soa4!(sg);
    let (s00, s01, s10, s11) =
        (_mm256_mul_pd(k, g11), _mm256_mul_pd(k, g12), _mm256_mul_pd(k, g21), _mm256_mul_pd(k, g22));
    // rows (channels, one point per lane) are transposed to one register per point
    // P_a = [m wx_a, m wx_a (vx + dx_a cux) − wx_a' s00, m wx_a (vy + dx_a cvx) − wx_a' s10, 0]
    let mut pa: [[__m256d; 4]; 3] = [[zero; 4]; 3];
    for a in 0..3 {
        pa[a] = {
            let dx = _mm256_mul_pd(_mm256_sub_pd(_mm256_set1_pd(a as Real), fx), hv);
            let mw = _mm256_mul_pd(m, wx[a]);
            let px =
                _mm256_sub_pd(_mm256_mul_pd(mw, _mm256_add_pd(vx, _mm256_mul_pd(dx, cux))), _mm256_mul_pd(dwx[a], s00));
            let py =
                _mm256_sub_pd(_mm256_mul_pd(mw, _mm256_add_pd(vy, _mm256_mul_pd(dx, cvx))), _mm256_mul_pd(dwx[a], s10));
            transpose4!(mw, px, py, zero)
        };
    }
    // Q_b = [0, m wy_b dy_b cuy − wy_b' s01, m wy_b dy_b cvy − wy_b' s11, 0]
    let mut qb: [[__m256d; 4]; 3] = [[zero; 4]; 3];
    for b in 0..3 {
        qb[b] = {
            let dy = _mm256_mul_pd(_mm256_sub_pd(_mm256_set1_pd(b as Real), fy), hv);
            let mwd = _mm256_mul_pd(_mm256_mul_pd(m, wy[b]), dy);
            let qx = _mm256_sub_pd(_mm256_mul_pd(mwd, cuy), _mm256_mul_pd(dwy[b], s01));
            let qy = _mm256_sub_pd(_mm256_mul_pd(mwd, cvy), _mm256_mul_pd(dwy[b], s11));
            transpose4!(zero, qx, qy, zero)
        };
    }
    let (bx, by) = (store4!(bxv), store4!(byv));
    let (wxs, wys) =
        ([store4!(wx[0]), store4!(wx[1]), store4!(wx[2])], [store4!(wy[0]), store4!(wy[1]), store4!(wy[2])]);
    let mut firsts = [(0, 0); 4];
    let mut first_nodes = [0; 4];
    // the lattice of this part's grid: nodes −PAD ..= n + PAD on each axis
    let (nx, ny) = ((width - 1 - 2 * PAD) as isize, (chunk.len() / width - 1 - 2 * PAD) as isize);
    for l in 0..4 {
        let (bx, by) = (bx[l] as isize, by[l] as isize);
        firsts[l] = (bx, by);
        // a finite point is in the domain (the gather keeps it there): its stencil starts on
        // a node in [−1, n − 1]; checked on the values, before any cast can wrap
        assert!((-1..=nx).contains(&bx) && (-1..=ny).contains(&by), "a stencil off the padded lattice");
        first_nodes[l] = (by - row0) as usize * width + (bx + PAD as isize) as usize;
    }
    let base = chunk.as_mut_ptr() as *mut Real;
    for l in 0..4 {
        for b in 0..3 {
            let wyb = _mm256_set1_pd(wys[b][l]);
            for a in 0..3 {
                let add = _mm256_fmadd_pd(wyb, pa[a][l], _mm256_mul_pd(_mm256_set1_pd(wxs[a][l]), qb[b][l]));
                // SAFETY: node b·width + a of the stencil lies in `chunk` (its first node was
                // asserted in the lattice, which the padding surrounds by 2); four f64
                unsafe {
                    let at = base.add(4 * (first_nodes[l] + b * width + a));
                    _mm256_storeu_pd(at, _mm256_add_pd(_mm256_loadu_pd(at), add));
                }
            }
        }
    }
    firsts
}

/// A gather block's sums for the step's figures in four lanes: point k of the block adds
/// to lane k mod 4, in point order, whether it is finished alone or in the lanes of a
/// register, so that every path adds the same numbers in the same order; the lanes are
/// then added in lane order (`total`).
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
    /// One point's kinetic energy, mass, momentum and squared speed into `lane`.
    #[inline(always)]
    fn add(&mut self, lane: usize, ke: Real, m: Real, px: Real, py: Real, s2: Real) {
        self.ke[lane] += ke;
        self.mass[lane] += m;
        self.px[lane] += px;
        self.py[lane] += py;
        // a NaN stays out, as in `_mm256_max_pd(s2, acc)`
        if s2 > self.s2[lane] {
            self.s2[lane] = s2;
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

/// What the end of a point's gather writes.
struct Out<'a> {
    x: &'a mut Vector,
    v: &'a mut Vector,
    f: &'a mut Matrix,
    gv: &'a mut Matrix,
    cu: &'a mut Vector,
    cv: &'a mut Vector,
}

/// `finish_point` compiled with FMA, for the points the lanes gathered but do not finish
/// (a full F, a periodic side): its `mul_add`s are instructions here, where the baseline
/// x86-64 build would call libm's `fma` (mpm88 with a linear elastic stress, 1 thread: 26.3
/// against 21.9 M particle-steps/s).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,fma")]
fn finish_point_fma(fin: &Finish, r: &[Real; 10], m: Real, out: Out, lane: usize, sums: &mut LaneSums) {
    finish_point(fin, r, m, out, lane, sums)
}

/// The end of a point's gather from its sums `r` (see `gather_point`): velocity, APIC C, ∇v,
/// F (or J), position (wrapped at periodic sides, stopped at walls), and its share of the
/// step's figures.
#[inline(always)]
fn finish_point(fin: &Finish, r: &[Real; 10], m: Real, out: Out, lane: usize, sums: &mut LaneSums) {
    let dt = fin.dt;
    let ih = fin.ih;
    let l = Matrix::new(r[2] * ih, r[4] * ih, r[3] * ih, r[5] * ih);
    let mut vk = Vector::new(r[0], r[1]);
    if fin.apic {
        *out.cu = Vector::new(r[6] * fin.dinv, r[8] * fin.dinv);
        *out.cv = Vector::new(r[7] * fin.dinv, r[9] * fin.dinv);
    }
    if fin.velocity_gradient {
        *out.gv = l;
    }
    let step =
        Matrix::new(dt.mul_add(l.m11, 1.0), dt.mul_add(l.m12, 0.0), dt.mul_add(l.m21, 0.0), dt.mul_add(l.m22, 1.0));
    *out.f = if fin.volumetric_only {
        // F = diag(J, 1): only J = det F matters to the stress (see `Lagrangian`)
        Matrix::new(det2(out.f) * det2(&step), 0.0, 0.0, 1.0)
    } else {
        step * *out.f
    };
    let mut xk = Vector::new(dt.mul_add(vk.x, out.x.x), dt.mul_add(vk.y, out.x.y));
    for axis in 0..2 {
        let (lo, hi) = (fin.lo[axis], fin.hi[axis]);
        if fin.periodic[axis] {
            if xk[axis] < lo || xk[axis] >= hi {
                xk[axis] = lo + (xk[axis] - lo).rem_euclid(hi - lo);
            }
        } else if xk[axis] < lo + fin.eps {
            xk[axis] = lo + fin.eps;
            if vk[axis] < 0.0 {
                vk[axis] = 0.0;
            }
        } else if xk[axis] > hi - fin.eps {
            xk[axis] = hi - fin.eps;
            if vk[axis] > 0.0 {
                vk[axis] = 0.0;
            }
        }
    }
    *out.x = xk;
    *out.v = vk;
    let s2 = vk.x * vk.x + vk.y * vk.y;
    sums.add(lane, 0.5 * m * s2, m, m * vk.x, m * vk.y, s2);
}
