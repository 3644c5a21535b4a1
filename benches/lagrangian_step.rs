//! One full step of a Lagrangian fluid field: particles to grid, grid stress, pressure
//! projection, grid to particles (and the step's diagnostics), timed with criterion.
//!
//! Scene: a Taylor–Green vortex (amplitude 1) on the periodic square [0, 2π]², one
//! Lagrangian field of density 1 filling it (`points_per_cell: 2`, i.e. 2 × 2 = 4 points
//! per cell, quadratic B-spline shape, APIC transfer), Newtonian viscosity 1e-3, pressure
//! by `pcg` with the multigrid preconditioner (default tolerance 1e-9, warm-started), a
//! fixed Δt = 0.4 h (CFL 0.4 at the peak speed 1), so the work per step is constant. Grids
//! 128² and 512² (65,536 and 1,048,576 points), 1 and 2 threads (a rayon pool of that
//! size around every step). Criterion's throughput is in points per second, i.e. particle
//! updates per second. The timed call is `Simulation::step_with(Δt, "fixed")`: the step
//! itself, without the choice of Δt.
//!
//! `cargo bench --bench lagrangian_step`. `LAGRANGIAN_SIZES=128` limits the grids. Before
//! criterion measures a configuration, a line goes to stderr:
//! `step n <n> points <N> threads <t> iterations <k> ms_per_step <wall> min_ms <min> cpu_ms <cpu> mpts_per_s <M>
//! p2g_ms <a> g2p_ms <b> rest_ms <c> other_jobs_cores <o>`: medians over a few steps (9 at
//! 512², 25 at 128²) of the wall time and of the process CPU time (all threads), the
//! fastest step, the pressure iterations, a split of the step: particles to grid alone
//! (`to_grid`), grid to particles alone (`from_grid`, the points restored after each
//! call) and the rest (grid stress, exchange loop, pressure, diagnostics) by difference;
//! and how many cores other processes of the machine kept busy meanwhile (from
//! /proc/stat): on a shared machine, read the figures with that number.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput};
use multifield::core::case::Case;
use multifield::core::plugin::FrameContext;
use multifield::core::simulation::{Simulation, StepDiagnostics};
use multifield::core::timing::{median, process_cpu_ns};
use multifield::frames::lagrangian::Lagrangian;
use std::path::Path;
use std::time::{Duration, Instant};

const POINTS_PER_CELL: usize = 2;

/// The Taylor–Green case on n × n cells, fixed Δt = 0.4 h.
fn case(n: usize) -> Case {
    let size = std::f64::consts::TAU;
    let dt = 0.4 * size / n as f64;
    let text = format!(
        r#"(
        name: "lagrangian_step", domain: (size: ({size:?}, {size:?}), cells: ({n}, {n})),
        boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic),
        time: (end: 1e9, cfl: 0.4, max_dt: 1.0, fixed_dt: Some({dt:?})),
        fields: [(
            name: "fluid", density: 1.0,
            frame: (model: "lagrangian", params: (points_per_cell: {POINTS_PER_CELL}, shape: "quadratic", transfer: "apic")),
            region: All, velocity: TaylorGreen(amplitude: 1.0),
            stress: [(model: "newtonian", params: (viscosity: 1e-3))],
        )],
        pressure: Some((model: "pcg", params: (preconditioner: "multigrid"))),
    )"#
    );
    Case::from_ron(&text, Path::new("lagrangian_step.ron")).expect("bench case")
}

/// One step of the case's fixed Δt.
fn step(sim: &mut Simulation) -> multifield::core::Result<StepDiagnostics> {
    let dt = sim.case.time.fixed_dt.expect("fixed dt");
    sim.step_with(dt, "fixed".to_string())
}

/// CPU time all processes of the machine have used so far (s), from /proc/stat (0 where
/// unavailable): with [`process_cpu_ns`], how many cores the other jobs took meanwhile.
fn machine_busy_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/stat") else { return 0.0 };
    let Some(cpu) = stat.lines().next() else { return 0.0 };
    // user nice system idle iowait irq softirq steal (guest time is inside user)
    let ticks: Vec<f64> = cpu.split_whitespace().skip(1).filter_map(|v| v.parse().ok()).collect();
    let busy: f64 = ticks.iter().take(8).enumerate().filter(|(k, _)| *k != 3 && *k != 4).map(|(_, t)| t).sum();
    busy / 100.0 // USER_HZ
}

/// Particles to grid (`to_grid` alone) or grid to particles (`from_grid` alone, with the
/// points put back afterwards, outside the timing) of the single field, in milliseconds.
fn time_phase(sim: &mut Simulation, g2p: bool, repeats: usize) -> f64 {
    let dt = sim.case.time.fixed_dt.expect("fixed dt");
    let field = &mut sim.fields[0];
    let saved = field.frame.as_any().downcast_ref::<Lagrangian>().expect("lagrangian frame").points.clone();
    let mut times = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let mut ctx = FrameContext {
            grid: &sim.grid,
            boundaries: &sim.boundaries,
            dt,
            time: sim.time,
            gravity: sim.gravity,
            density: field.density,
            state: &mut field.state,
            stress: &field.stress,
            body_forces: &sim.body_forces[0],
            forced_bodies: None,
            partner: None,
        };
        let t0 = Instant::now();
        if g2p {
            field.frame.from_grid(&mut ctx).expect("grid to particles");
        } else {
            field.frame.to_grid(&mut ctx).expect("particles to grid");
        }
        times.push(t0.elapsed().as_secs_f64() * 1e3);
        let lag = field.frame.as_any_mut().downcast_mut::<Lagrangian>().expect("lagrangian frame");
        lag.points.clone_from(&saved);
    }
    median(times)
}

fn bench(c: &mut Criterion) {
    multifield::link_all();
    let sizes: Vec<usize> = std::env::var("LAGRANGIAN_SIZES")
        .map(|s| s.split(',').map(|v| v.parse().expect("LAGRANGIAN_SIZES=128,512")).collect())
        .unwrap_or_else(|_| vec![128, 512]);
    for &n in &sizes {
        let points = (n * n * POINTS_PER_CELL * POINTS_PER_CELL) as u64;
        let mut group = c.benchmark_group(format!("lagrangian_step/{n}"));
        group
            .sample_size(10)
            .sampling_mode(SamplingMode::Flat)
            .warm_up_time(Duration::from_secs(1))
            .measurement_time(Duration::from_secs(if n > 256 { 8 } else { 3 }))
            .throughput(Throughput::Elements(points));
        // 1 and 2 threads one after the other at each size, so that their ratio is measured
        // under the same machine load
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
            let case = case(n);
            let mut sim = pool.install(|| Simulation::new(&case)).expect("simulation");
            assert_eq!(sim.fields[0].frame.as_any().downcast_ref::<Lagrangian>().unwrap().points.len() as u64, points);
            // warm-up: the scatter buffers, the multigrid hierarchy and the pressure warm start
            for _ in 0..2 {
                pool.install(|| step(&mut sim)).expect("warm-up step");
            }
            let repeats = if n > 256 { 9 } else { 25 };
            let (mut wall, mut cpu, mut iterations) = (vec![], vec![], vec![]);
            let (busy0, own0, start) = (machine_busy_s(), process_cpu_ns(), Instant::now());
            for _ in 0..repeats {
                let (c0, t0) = (process_cpu_ns(), Instant::now());
                let d = pool.install(|| step(&mut sim)).expect("step");
                wall.push(t0.elapsed().as_secs_f64() * 1e3);
                cpu.push((process_cpu_ns() - c0) as f64 * 1e-6);
                iterations.push(d.pressure_iterations as f64);
            }
            let others = (machine_busy_s() - busy0 - (process_cpu_ns() - own0) as f64 * 1e-9).max(0.0)
                / start.elapsed().as_secs_f64();
            let min = wall.iter().cloned().fold(f64::INFINITY, f64::min);
            let (wall, cpu, iterations) = (median(wall), median(cpu), median(iterations));
            let p2g = pool.install(|| time_phase(&mut sim, false, repeats));
            let g2p = pool.install(|| time_phase(&mut sim, true, repeats));
            eprintln!(
                "step n {n} points {points} threads {threads} iterations {iterations} ms_per_step {wall:.2} \
                 min_ms {min:.2} cpu_ms {cpu:.2} mpts_per_s {:.2} p2g_ms {p2g:.2} g2p_ms {g2p:.2} rest_ms {:.2} \
                 other_jobs_cores {others:.2}",
                points as f64 / wall * 1e-3,
                wall - p2g - g2p
            );
            group.bench_function(BenchmarkId::new("threads", threads), |b| {
                b.iter(|| pool.install(|| step(&mut sim)).expect("step"))
            });
        }
        group.finish();
    }
}

// No plots: criterion's plotters backend panics where no font is installed (this machine).
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
