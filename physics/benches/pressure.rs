//! Time per pressure solve for each solver on a DKT-like system: water (ρ = 1) with two
//! dense disks (ρ = 1.5 or 1000), c = 1/ρ on faces, walls all round, relative tolerance
//! 1e-8, from a zero initial guess, at 1 and 2 threads. The multigrid hierarchy and the
//! symbolic Cholesky factorization are reused across solves, as in a run; the numeric
//! set-up (coarse operators, numeric factorization) is part of every solve.
//!
//! `cargo bench -p multifield-physics --bench pressure`. Before criterion measures a case,
//! a line `solve <solver> rho <ρ> n <n> threads <t> iterations <k> cpu_ms <c> wall_ms <w>`
//! goes to stderr: the median over a few solves of the process CPU time (all threads) and of
//! the wall time. On a shared machine the CPU time is the robust figure: it does not count
//! the time other processes hold the cores. `PRESSURE_SIZES=64,128` limits the sizes,
//! `PRESSURE_SOLVERS=mg_pcg,cholesky` the solvers, `PRESSURE_THREADS=1` the thread counts;
//! `PRESSURE_NO_CAP=1` lifts the per-solver size caps (Cholesky at 1024², ~1.3 s a solve).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use multifield_core::boundary::Boundaries;
use multifield_core::grid::{FaceArrays, Grid};
use multifield_core::math::{Real, Vector};
use multifield_core::plugin::PressureSolver;
use multifield_core::poisson::PoissonProblem;
use multifield_core::timing::{median, process_cpu_ns};
use multifield_physics::pressure::cholesky::Cholesky;
use multifield_physics::pressure::multigrid::Multigrid;
use multifield_physics::pressure::pcg::{Pcg, PreconditionerKind};
use std::f64::consts::PI;
use std::time::Duration;

/// The DKT-like system on n × n cells of the unit square.
pub fn dkt(n: usize, rho_disk: Real) -> PoissonProblem {
    let g = Grid::new(n, n, 1.0 / n as Real, Vector::zeros());
    let rho = |x: Real, y: Real| {
        let d1 = (x - 0.35).powi(2) + (y - 0.6).powi(2);
        let d2 = (x - 0.62).powi(2) + (y - 0.4).powi(2);
        if d1 < 0.1 * 0.1 || d2 < 0.12 * 0.12 {
            rho_disk
        } else {
            1.0
        }
    };
    let h = g.h;
    let mut cx = vec![0.0; g.n_xfaces()];
    for j in 0..n {
        for i in 0..=n {
            cx[g.xface(i, j)] = 1.0 / rho(i as Real * h, (j as Real + 0.5) * h);
        }
    }
    let mut cy = vec![0.0; g.n_yfaces()];
    for j in 0..=n {
        for i in 0..n {
            cy[g.yface(i, j)] = 1.0 / rho((i as Real + 0.5) * h, j as Real * h);
        }
    }
    let rhs = (0..g.n_cells())
        .map(|k| {
            let c = g.cell_center(k % n, k / n);
            (3.0 * PI * c.x).sin() * (2.0 * PI * c.y).cos() + 0.3 * (c.x - c.y)
        })
        .collect();
    PoissonProblem::new(&g, &Boundaries::default(), FaceArrays { u: cx, v: cy }, rhs)
}

type Make = fn() -> Box<dyn PressureSolver>;

fn solvers() -> Vec<(&'static str, Make, usize)> {
    vec![
        ("mg_pcg", || Box::new(Pcg::new(PreconditionerKind::Multigrid, 1e-8, 1000)), 1024),
        ("multigrid", || Box::new(Multigrid::new(1e-8, 500, 2)), 1024),
        ("cholesky", || Box::new(Cholesky::new(1e-8, 5)), 512),
        ("jacobi_pcg", || Box::new(Pcg::new(PreconditionerKind::Jacobi, 1e-8, 100_000)), 256),
    ]
}

fn bench(c: &mut Criterion) {
    let sizes: Vec<usize> = std::env::var("PRESSURE_SIZES")
        .map(|s| s.split(',').map(|v| v.parse().expect("PRESSURE_SIZES=64,128")).collect())
        .unwrap_or_else(|_| vec![64, 128, 256, 512, 1024]);
    let wanted: Option<Vec<String>> =
        std::env::var("PRESSURE_SOLVERS").ok().map(|s| s.split(',').map(str::to_string).collect());
    let no_cap = std::env::var("PRESSURE_NO_CAP").is_ok_and(|v| v == "1");
    let thread_counts: Vec<usize> = std::env::var("PRESSURE_THREADS")
        .map(|s| s.split(',').map(|v| v.parse().expect("PRESSURE_THREADS=1,2")).collect())
        .unwrap_or_else(|_| vec![1, 2]);
    for threads in thread_counts {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
        for rho in [1.5, 1000.0] {
            let mut group = c.benchmark_group(format!("pressure/rho{rho}/threads{threads}"));
            group.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
            for &n in &sizes {
                let problem = dkt(n, rho);
                group.throughput(Throughput::Elements((n * n) as u64));
                for (name, make, max_n) in solvers() {
                    if (n > max_n && !no_cap) || wanted.as_ref().is_some_and(|w| !w.iter().any(|s| s == name)) {
                        continue;
                    }
                    let mut solver = make();
                    let mut p = vec![0.0; n * n];
                    let stats = pool.install(|| solver.solve(&problem, &mut p)).expect("solve");
                    let (mut cpu, mut wall) = (vec![], vec![]);
                    for _ in 0..((1 << 22) / (n * n)).clamp(3, 15) {
                        p.fill(0.0);
                        let (c0, t0) = (process_cpu_ns(), std::time::Instant::now());
                        pool.install(|| solver.solve(&problem, &mut p)).expect("solve");
                        wall.push(t0.elapsed().as_secs_f64() * 1e3);
                        cpu.push((process_cpu_ns() - c0) as f64 * 1e-6);
                    }
                    eprintln!(
                        "solve {name} rho {rho} n {n} threads {threads} iterations {} cpu_ms {:.3} wall_ms {:.3}",
                        stats.iterations,
                        median(cpu),
                        median(wall)
                    );
                    group.bench_function(BenchmarkId::new(name, n), |b| {
                        b.iter(|| {
                            p.fill(0.0);
                            pool.install(|| solver.solve(&problem, &mut p)).expect("solve")
                        })
                    });
                }
            }
            group.finish();
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
