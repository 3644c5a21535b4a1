#!/usr/bin/env python3
"""Taichi's mpm88 (MLS-MPM in 88 lines, Hu et al., ACM TOG 37(4) 2018) on the CPU, with no
GUI, for comparison with `examples/mpm88.ron` (benches/taichi/compare.py runs both).

The kernel `substep` is the one of `taichi/examples/simulation/mpm88.py` (Taichi 1.7),
unchanged: 128² nodes, dx = 1/128, dt = 2e-4, p_vol = (dx/2)², rho = 1, E = 400,
gravity 9.8, quadratic B-spline APIC, floats f32 (`--fp f64` for doubles). Its walls zero
the grid velocity components pointing into them on nodes i < 3 and i > 125 (j alike): the
points stop at x = 2.0 dx and x = 126.05 dx, so the fluid's box is about [2dx, 126dx]².
Only the initial state differs from mpm88: instead of 8,192 random points in [0.2, 0.6]²
(`--random`), the points sit on the lattice that multifield seeds for
`region: Rectangle(min: (0.2, 0.2), max: (0.7, 0.45))` with `points_per_cell: 2` (2 × 2
points per cell at ((i + (a + 0.5)/2) dx, (j + (b + 0.5)/2) dx)), 128 × 64 = 8,192 points,
all with velocity (0, −1) and J = 1 as in mpm88. `--walls-at-unit-square` puts the same
kernel on 132² nodes and moves the points by 2 dx: its box is then [2dx, 130dx]², the unit
square of examples/mpm88.ron moved by 2 dx (heights are reported from y = 2 dx).

Prints one line `taichi mpm88 ... particle_steps_per_s <rate>`: the steps after the warm-up
(which includes the JIT compilation) are timed with `ti.sync()` at both ends; sampling the
history is outside the timed windows. `--history FILE` writes a CSV row every `--every`
steps: step, time, kinetic energy Σ ½ m v², mean and 95th percentile of the points' y, and
the lowest y.

    pip install "taichi==1.7.*"
    python3 benches/taichi/mpm88.py --threads 1 --history /tmp/mpm88_taichi.csv
"""

import argparse
import csv
import sys
import time

import numpy as np
import taichi as ti

DX = 1.0 / 128
DT = 2e-4
P_RHO = 1.0
P_VOL = (DX * 0.5) ** 2
P_MASS = P_VOL * P_RHO
GRAVITY = 9.8
E = 400.0
REGION = ((0.2, 0.2), (0.7, 0.45))  # the case's Rectangle(min, max)
POINTS_PER_CELL = 2


def lattice(offset):
    """The points multifield's Lagrangian frame seeds in REGION on the unit square (same
    arithmetic, f64), moved by `offset` cells along x and y."""
    n = POINTS_PER_CELL
    coords = np.array([(i + (a + 0.5) / n) * DX for i in range(128) for a in range(n)])
    (x0, y0), (x1, y1) = REGION
    xs = coords[(coords >= x0) & (coords <= x1)]
    ys = coords[(coords >= y0) & (coords <= y1)]
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx.ravel(), gy.ravel()], axis=1) + offset * DX


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=2000, help="steps in all (default 2000: t = 0.4)")
    ap.add_argument("--threads", type=int, default=0, help="CPU threads (cpu_max_num_threads); 0: all cores")
    ap.add_argument("--warmup", type=int, default=10, help="untimed first steps (JIT compile), default 10")
    ap.add_argument("--history", help="CSV file for the history")
    ap.add_argument("--every", type=int, default=50, help="history row every this many steps (default 50)")
    ap.add_argument("--fp", choices=["f32", "f64"], default="f32", help="float type (mpm88: f32, the default)")
    ap.add_argument("--random", action="store_true", help="mpm88's own 8,192 random points in [0.2, 0.6]²")
    ap.add_argument(
        "--walls-at-unit-square",
        action="store_true",
        help="132² nodes and the points moved by 2 dx, so that the walls (where the points stop) enclose "
        "[2dx, 130dx]², the unit square of examples/mpm88.ron moved by 2 dx; heights are taken from y = 2 dx",
    )
    args = ap.parse_args()
    if args.random and args.walls_at_unit_square:
        ap.error("--random seeds mpm88's own square on its own grid: drop --walls-at-unit-square")

    config = dict(arch=ti.cpu, default_fp=ti.f32 if args.fp == "f32" else ti.f64, random_seed=0, log_level=ti.WARN)
    if args.threads > 0:
        config["cpu_max_num_threads"] = args.threads
    ti.init(**config)

    n_grid, offset = (132, 2) if args.walls_at_unit_square else (128, 0)
    x0 = lattice(offset) if not args.random else None
    n_particles = 8192 if args.random else len(x0)
    bound = 3

    x = ti.Vector.field(2, float, n_particles)
    v = ti.Vector.field(2, float, n_particles)
    C = ti.Matrix.field(2, 2, float, n_particles)
    J = ti.field(float, n_particles)
    grid_v = ti.Vector.field(2, float, (n_grid, n_grid))
    grid_m = ti.field(float, (n_grid, n_grid))
    dx, dt, p_vol, p_mass, gravity = DX, DT, P_VOL, P_MASS, GRAVITY

    # ---- the mpm88 kernel, verbatim ----
    @ti.kernel
    def substep():
        for i, j in grid_m:
            grid_v[i, j] = [0, 0]
            grid_m[i, j] = 0
        for p in x:
            Xp = x[p] / dx
            base = int(Xp - 0.5)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            stress = -dt * 4 * E * p_vol * (J[p] - 1) / dx**2
            affine = ti.Matrix([[stress, 0], [0, stress]]) + p_mass * C[p]
            for i, j in ti.static(ti.ndrange(3, 3)):
                offset = ti.Vector([i, j])
                dpos = (offset - fx) * dx
                weight = w[i].x * w[j].y
                grid_v[base + offset] += weight * (p_mass * v[p] + affine @ dpos)
                grid_m[base + offset] += weight * p_mass
        for i, j in grid_m:
            if grid_m[i, j] > 0:
                grid_v[i, j] /= grid_m[i, j]
            grid_v[i, j].y -= dt * gravity
            if i < bound and grid_v[i, j].x < 0:
                grid_v[i, j].x = 0
            if i > n_grid - bound and grid_v[i, j].x > 0:
                grid_v[i, j].x = 0
            if j < bound and grid_v[i, j].y < 0:
                grid_v[i, j].y = 0
            if j > n_grid - bound and grid_v[i, j].y > 0:
                grid_v[i, j].y = 0
        for p in x:
            Xp = x[p] / dx
            base = int(Xp - 0.5)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(float, 2)
            new_C = ti.Matrix.zero(float, 2, 2)
            for i, j in ti.static(ti.ndrange(3, 3)):
                offset = ti.Vector([i, j])
                dpos = (offset - fx) * dx
                weight = w[i].x * w[j].y
                g_v = grid_v[base + offset]
                new_v += weight * g_v
                new_C += 4 * weight * g_v.outer_product(dpos) / dx**2
            v[p] = new_v
            x[p] += dt * v[p]
            J[p] *= 1 + dt * new_C.trace()
            C[p] = new_C

    @ti.kernel
    def init_random():
        for i in range(n_particles):
            x[i] = [ti.random() * 0.4 + 0.2, ti.random() * 0.4 + 0.2]
            v[i] = [0, -1]
            J[i] = 1

    # ---- end of mpm88 ----

    if args.random:
        init_random()
    else:
        dtype = np.float32 if args.fp == "f32" else np.float64
        x.from_numpy(x0.astype(dtype))
        v.from_numpy(np.tile(np.array([0.0, -1.0], dtype=dtype), (n_particles, 1)))
        J.fill(1)
        C.fill(0)

    rows = []

    def sample(step):
        xs = x.to_numpy().astype(np.float64)
        vs = v.to_numpy().astype(np.float64)
        ke = 0.5 * P_MASS * float((vs**2).sum())
        y = xs[:, 1] - offset * DX
        rows.append((step, step * DT, ke, float(y.mean()), float(np.percentile(y, 95)), float(y.min())))

    sample(0)
    step = 0
    timed_steps, timed_seconds = 0, 0.0
    while step < args.steps:
        if step < args.warmup:
            n = min(args.warmup - step, args.steps - step)
            timed = False
        else:
            n = min(args.every - step % args.every, args.steps - step)
            timed = True
        ti.sync()
        t0 = time.perf_counter()
        for _ in range(n):
            substep()
        ti.sync()
        t1 = time.perf_counter()
        step += n
        if timed:
            timed_steps += n
            timed_seconds += t1 - t0
        if step % args.every == 0 or step == args.steps:
            sample(step)

    if args.history:
        with open(args.history, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["step", "time", "kinetic_energy", "mean_y", "p95_y", "min_y"])
            for r in rows:
                w.writerow([r[0], f"{r[1]:.6g}", f"{r[2]:.9e}", f"{r[3]:.9e}", f"{r[4]:.9e}", f"{r[5]:.9e}"])
    rate = timed_steps * n_particles / timed_seconds if timed_seconds > 0 else float("nan")
    print(
        f"taichi mpm88 points {n_particles} grid {n_grid} steps {step} timed_steps {timed_steps} threads {args.threads or 'all'} "
        f"fp {args.fp} seconds {timed_seconds:.4f} particle_steps_per_s {rate:.6e}"
    )
    sys.stdout.flush()


if __name__ == "__main__":
    main()
