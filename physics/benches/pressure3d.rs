//! Time per pressure solve in 3D: MG-PCG from 32³ to 128³ (256³ on request) and sparse
//! Cholesky (faer, factor and solve) at the grids it can do, on the 1000:1 sphere of
//! validation/dim3/poisson (β = 1000 in a sphere of radius 0.3 at the centre of the unit
//! cube, 1 outside, walls all round, segment-harmonic face coefficients), relative
//! tolerance 1e-8 from a zero initial guess. As in a run, the multigrid hierarchy and the
//! symbolic factorization are kept across solves; the numeric set-up (coarse operators,
//! numeric factorization) is part of every solve.
//!
//! `cargo bench -p multifield-physics --bench pressure3d`. One line per case on stdout:
//! `solve3d <solver> n <n> threads <t> iterations <k> wall_ms <w> cpu_ms <c> ns_per_cell <u>`,
//! the medians over a few solves (after one untimed solve) of the wall time and of the
//! process CPU time (all threads), and the median wall time per cell. Environment:
//! `PRESSURE3D_SIZES=32,64,128` (MG-PCG's grids; add 256 for 256³, about 3 GB),
//! `PRESSURE3D_CHOLESKY=16,32,48` (Cholesky's: 48³ factors in about 10 s; 64³ needs about
//! 4 GB and minutes), `PRESSURE3D_THREADS=1,2`.

use multifield_core3d::boundary::Boundaries;
use multifield_core3d::grid::{FaceArrays, Grid, Lattice};
use multifield_core3d::math::{vector, Real, Vector};
use multifield_core3d::plugin::PressureSolver;
use multifield_core3d::poisson::PoissonProblem;
use multifield_core3d::timing::{median, process_cpu_ns};
use multifield_physics3d::pressure::cholesky::Cholesky;
use multifield_physics3d::pressure::pcg::{Pcg, PreconditionerKind};

/// The 1000:1 sphere on n³ cells (validation/dim3/poisson/README.md).
fn sphere(n: usize) -> PoissonProblem {
    let (radius, support, b_in, b_out) = (0.3, 0.45, 1000.0, 1.0);
    let centre = vector([0.5; 3]);
    let h = 1.0 / n as Real;
    let g = Grid::from_cells([n, n, n], h, vector([0.0; 3]));
    let mut c = FaceArrays::zeros(&g);
    for a in 0..3 {
        for (k, at) in g.nodes(Lattice::face(a)) {
            if at[a] == 0 || at[a] == n {
                continue; // walls
            }
            let d: Vector = g.position(Lattice::face(a), at) - centre;
            let rho2: Real = (0..3).filter(|&b| b != a).map(|b| d[b] * d[b]).sum();
            let theta = if rho2 < radius * radius {
                let half = (radius * radius - rho2).sqrt();
                let lo = d[a] - h / 2.0;
                ((lo + h).min(half) - lo.max(-half)).clamp(0.0, h) / h
            } else {
                0.0
            };
            c[a][k] = 1.0 / (theta / b_in + (1.0 - theta) / b_out);
        }
    }
    let rhs = g
        .nodes(Lattice::Cell)
        .map(|(_, at)| {
            let r = (g.position(Lattice::Cell, at) - centre).norm();
            let s = r * r / (support * support);
            if r < support {
                -24.0 / (support * support) * (1.0 - s).powi(2) * (1.0 - 3.0 * s)
            } else {
                0.0
            }
        })
        .collect();
    PoissonProblem::new(&g, &Boundaries::default(), c, rhs)
}

fn list(var: &str, default: &[usize]) -> Vec<usize> {
    std::env::var(var)
        .map(|s| {
            s.split(',').filter(|v| !v.is_empty()).map(|v| v.parse().expect("a list of numbers, e.g. 32,64")).collect()
        })
        .unwrap_or_else(|_| default.to_vec())
}

fn main() {
    // `cargo bench` passes `--bench`; a filter is not supported (use the variables)
    let sizes = list("PRESSURE3D_SIZES", &[32, 64, 128]);
    let cholesky_sizes = list("PRESSURE3D_CHOLESKY", &[16, 32, 48]);
    let threads = list("PRESSURE3D_THREADS", &[1, 2]);
    type Make = fn() -> Box<dyn PressureSolver>;
    let mg: Make = || Box::new(Pcg::new(PreconditionerKind::Multigrid, 1e-8, 1000));
    let cholesky: Make = || Box::new(Cholesky::new(1e-8, 5));
    for &t in &threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build().expect("thread pool");
        let cases =
            sizes.iter().map(|&n| ("mg_pcg", mg, n)).chain(cholesky_sizes.iter().map(|&n| ("cholesky", cholesky, n)));
        for (name, make, n) in cases {
            let problem = sphere(n);
            let cells = n * n * n;
            let mut solver = make();
            let mut p = vec![0.0; cells];
            let stats = pool.install(|| solver.solve(&problem, &mut p)).expect("solve");
            let (mut cpu, mut wall) = (vec![], vec![]);
            for _ in 0..((1 << 23) / cells).clamp(3, 9) {
                p.fill(0.0);
                let (c0, t0) = (process_cpu_ns(), std::time::Instant::now());
                pool.install(|| solver.solve(&problem, &mut p)).expect("solve");
                wall.push(t0.elapsed().as_secs_f64() * 1e3);
                cpu.push((process_cpu_ns() - c0) as f64 * 1e-6);
            }
            let w = median(wall);
            println!(
                "solve3d {name} n {n} threads {t} iterations {} wall_ms {w:.1} cpu_ms {:.1} ns_per_cell {:.1}",
                stats.iterations,
                median(cpu),
                w * 1e6 / cells as f64
            );
        }
    }
}
