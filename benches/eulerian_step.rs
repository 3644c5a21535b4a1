//! One full Eulerian step in 3D (issue 17) beside the 2D step per cell, and the machine's
//! memory bandwidth, measured in the same run.
//!
//! Scene: the Taylor–Green vortex (amplitude 1) in the periodic cube [0, 2π]³ (3D) or square
//! [0, 2π]² (2D), one Eulerian field of density 1, `newtonian` viscosity 1/1600 (Re 1600),
//! Crank–Nicolson (`cn`, the default) or explicit (`explicit`) viscosity, the MC limiter,
//! pressure by the default `pcg` (multigrid preconditioner, tolerance 1e-9, warm-started),
//! a fixed Δt = 0.4 h (CFL 0.4 at the peak speed 1), so the work per step is about constant.
//! The timed call is `Simulation::step_with(Δt, "fixed")`: the whole step (predictor with
//! advection and viscosity, projection, θ advection, the step's diagnostics), not the
//! choice of Δt. Each configuration is built in a rayon pool of its thread count and warmed
//! up with two steps (multigrid hierarchy, viscous operators, pressure warm start).
//!
//! `cargo bench --bench eulerian_step`. One line per configuration on stdout:
//! `step<d>d n <n> threads <t> diffusion <cn|explicit> steps <k> wall_ms <w> min_ms <m> cpu_ms <c>
//! mcups <u> ns_per_cell <p> iterations <i>`: the medians over k steps of the wall time and of the
//! process CPU time (all threads), the fastest step, million cell updates per second
//! (cells × steps / wall seconds, from the median), the median wall time per cell and the
//! pressure iterations of the last step. Then `bandwidth <kernel> threads <t> gb_s <g>`:
//! STREAM-like copy (a = b) and triad (a = b + s c) on 128 MiB arrays of f64
//! (≫ the 32 MiB L3), the best of 10 passes, counting the bytes read and written, with the
//! write-allocate read of the stored array counted too (`gb_s_wa`). And per 3D grid
//! `viscous3d n <n> threads <t> c <c> iterations <k> wall_ms <w> ns_per_face <p>`: one of the
//! step's implicit viscous solves alone (the x-faces, right-hand side and initial guess the
//! Taylor–Green u, c = (Δt/2) ν/h²), the median of 5.
//!
//! Environment: `EULERIAN3D_SIZES=64,128`, `EULERIAN2D_SIZES=1024`, `EULERIAN_THREADS=1,2`,
//! `EULERIAN_DIFFUSION=cn,explicit`, `EULERIAN_STEPS=` (steps timed per configuration;
//! default 10 below 100³ cells, else 5), `EULERIAN_BANDWIDTH=0` skips the bandwidth.

use multifield::core::timing::{median, process_cpu_ns};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

fn list<T: std::str::FromStr>(var: &str, default: &str) -> Vec<T> {
    let s = std::env::var(var).unwrap_or_else(|_| default.to_string());
    s.split(',')
        .filter(|v| !v.trim().is_empty())
        .map(|v| v.trim().parse().unwrap_or_else(|_| panic!("{var}={s}: a comma-separated list, e.g. {default}")))
        .collect()
}

/// The Taylor–Green case on `n` cells along each of `dim` axes, fixed Δt = 0.4 h.
fn case_text(dim: usize, n: usize, diffusion: &str) -> String {
    let diffusion = if diffusion == "cn" { "crank_nicolson" } else { diffusion };
    let l = std::f64::consts::TAU;
    let dt = 0.4 * l / n as f64;
    let (size, cells, boundaries) = if dim == 3 {
        (
            format!("({l:?}, {l:?}, {l:?})"),
            format!("({n}, {n}, {n})"),
            "left: Periodic, right: Periodic, bottom: Periodic, top: Periodic, back: Periodic, front: Periodic",
        )
    } else {
        (
            format!("({l:?}, {l:?})"),
            format!("({n}, {n})"),
            "left: Periodic, right: Periodic, bottom: Periodic, top: Periodic",
        )
    };
    format!(
        r#"(
        name: "eulerian_step", domain: (size: {size}, cells: {cells}),
        boundaries: ({boundaries}),
        time: (end: 1e9, cfl: 0.4, max_dt: 1.0, fixed_dt: Some({dt:?})),
        fields: [(
            name: "fluid", density: 1.0,
            frame: (model: "eulerian", params: (diffusion: "{diffusion}")),
            region: All, velocity: TaylorGreen(amplitude: 1.0),
            stress: [(model: "newtonian", params: (viscosity: 0.000625))],
        )],
        pressure: Some((model: "pcg")),
    )"#
    )
}

/// Times `steps` steps of the case after two warm-up steps, in a pool of `threads`.
fn measure(dim: usize, n: usize, threads: usize, diffusion: &str, steps: usize) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    let text = case_text(dim, n, diffusion);
    // one step of the simulation: (wall ms, cpu ms, pressure iterations)
    let mut run: Box<dyn FnMut() -> (f64, f64, usize)> = if dim == 3 {
        use multifield3d::core::{case::Case, simulation::Simulation};
        let case = Case::from_ron(&text, Path::new("eulerian_step.ron")).expect("3D bench case");
        let dt = case.time.fixed_dt.expect("fixed dt");
        let mut sim = pool.install(|| Simulation::new(&case)).expect("3D simulation");
        let pool = &pool;
        Box::new(move || {
            let (c0, t0) = (process_cpu_ns(), Instant::now());
            let d = pool.install(|| sim.step_with(dt, "fixed".into())).expect("3D step");
            (t0.elapsed().as_secs_f64() * 1e3, (process_cpu_ns() - c0) as f64 * 1e-6, d.pressure_iterations)
        })
    } else {
        use multifield::core::{case::Case, simulation::Simulation};
        let case = Case::from_ron(&text, Path::new("eulerian_step.ron")).expect("2D bench case");
        let dt = case.time.fixed_dt.expect("fixed dt");
        let mut sim = pool.install(|| Simulation::new(&case)).expect("2D simulation");
        let pool = &pool;
        Box::new(move || {
            let (c0, t0) = (process_cpu_ns(), Instant::now());
            let d = pool.install(|| sim.step_with(dt, "fixed".into())).expect("2D step");
            (t0.elapsed().as_secs_f64() * 1e3, (process_cpu_ns() - c0) as f64 * 1e-6, d.pressure_iterations)
        })
    };
    for _ in 0..2 {
        run();
    }
    let (mut wall, mut cpu, mut iterations) = (vec![], vec![], 0);
    for _ in 0..steps {
        let (w, c, i) = run();
        wall.push(w);
        cpu.push(c);
        iterations = i;
    }
    let min = wall.iter().cloned().fold(f64::INFINITY, f64::min);
    let (wall, cpu) = (median(wall), median(cpu));
    let cells = n.pow(dim as u32) as f64;
    println!(
        "step{dim}d n {n} threads {threads} diffusion {diffusion} steps {steps} wall_ms {wall:.2} min_ms {min:.2} \
         cpu_ms {cpu:.2} mcups {:.3} ns_per_cell {:.1} iterations {iterations}",
        cells / (wall * 1e-3) / 1e6,
        wall * 1e6 / cells
    );
}

/// One implicit viscous solve of the 3D step, (I − c L) x = u, c = (Δt/2) ν/h², on the faces
/// normal to x of the case's grid, the right-hand side the Taylor–Green u and the initial
/// guess u (as the step's Crank–Nicolson solve starts from uⁿ): the median wall time of 5
/// solves after one untimed, and the CG iterations.
fn viscous3d(n: usize, threads: usize) {
    use multifield3d::core::{case::Case, simulation::Simulation};
    use multifield3d::frames::eulerian::{viscous::FaceDiffusion, Eulerian};
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    let case = Case::from_ron(&case_text(3, n, "cn"), Path::new("eulerian_step.ron")).expect("3D bench case");
    let sim = pool.install(|| Simulation::new(&case)).expect("3D simulation");
    let (g, dt) = (&sim.grid, case.time.fixed_dt.expect("fixed dt"));
    let c = 0.5 * dt * 0.000625 / (g.h * g.h);
    // the frame's uⁿ (the state's velocity is filled by the step)
    let frame = sim.fields[0].frame.as_any().downcast_ref::<Eulerian>().expect("an Eulerian field");
    let u = frame.velocity()[0].clone();
    let mut d = FaceDiffusion::new(g, &sim.boundaries);
    let mut x = u.clone();
    let (mut times, mut iterations) = (vec![], 0);
    for k in 0..6 {
        x.copy_from_slice(&u);
        let t = Instant::now();
        iterations = pool.install(|| d.solve(0, c, &u, &mut x)).expect("viscous solve");
        if k > 0 {
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    println!(
        "viscous3d n {n} threads {threads} c {c:.3e} iterations {iterations} wall_ms {:.2} ns_per_face {:.1}",
        median(times.clone()),
        median(times) * 1e6 / u.len() as f64
    );
}

/// Streaming bandwidth of copy and triad on 128 MiB arrays in a pool of `threads`
/// (best of 10 passes; blocks of 1 MiB spread over the threads).
fn bandwidth(threads: usize) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    let n = (128usize << 20) / 8;
    const BLOCK: usize = 1 << 17;
    pool.install(|| {
        let mut a = vec![0.0f64; n];
        let b = vec![2.0f64; n];
        let c = vec![0.5f64; n];
        // first touch of a
        a.par_chunks_mut(BLOCK).for_each(|a| a.fill(1.0));
        let bytes = (n * 8) as f64;
        let best = |f: &mut dyn FnMut()| {
            (0..10)
                .map(|_| {
                    let t = Instant::now();
                    f();
                    t.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min)
        };
        let copy = best(&mut || {
            a.par_chunks_mut(BLOCK).zip(b.par_chunks(BLOCK)).for_each(|(a, b)| a.copy_from_slice(b));
        });
        let triad = best(&mut || {
            a.par_chunks_mut(BLOCK).zip(b.par_chunks(BLOCK).zip(c.par_chunks(BLOCK))).for_each(|(a, (b, c))| {
                a.iter_mut().zip(b.iter().zip(c)).for_each(|(a, (b, c))| *a = b + 0.5 * c);
            });
        });
        let gb = |streams: f64, t: f64| streams * bytes / t / 1e9;
        println!("bandwidth copy threads {threads} gb_s {:.1} gb_s_wa {:.1}", gb(2.0, copy), gb(3.0, copy));
        println!("bandwidth triad threads {threads} gb_s {:.1} gb_s_wa {:.1}", gb(3.0, triad), gb(4.0, triad));
    });
}

fn main() {
    // `cargo bench` passes `--bench`; nothing else is read from the command line
    multifield::link_all();
    multifield3d::link_all();
    let threads: Vec<usize> = list("EULERIAN_THREADS", "1,2");
    let diffusion: Vec<String> = list("EULERIAN_DIFFUSION", "cn,explicit");
    let steps: Vec<usize> = list("EULERIAN_STEPS", "");
    let steps = |cells: usize| steps.first().copied().unwrap_or(if cells < 1_000_000 { 10 } else { 5 });
    if std::env::var("EULERIAN_BANDWIDTH").as_deref() != Ok("0") {
        for &t in &threads {
            bandwidth(t);
        }
    }
    for n in list::<usize>("EULERIAN3D_SIZES", "64,128") {
        for &t in &threads {
            viscous3d(n, t);
        }
        for d in &diffusion {
            // 1 and 2 threads one after the other, so that their ratio is measured under
            // the same machine load
            for &t in &threads {
                measure(3, n, t, d, steps(n * n * n));
            }
        }
    }
    for n in list::<usize>("EULERIAN2D_SIZES", "1024") {
        for d in &diffusion {
            for &t in &threads {
                measure(2, n, t, d, steps(n * n));
            }
        }
    }
}
