#!/usr/bin/env python3
"""Hindered settling of resolved disks: the table of docs/validation.md ("Hindered settling").

For each solid fraction φ (default 0.1, 0.2, 0.3, 0.4) runs a square lattice of 4 × 8
resolved disks (d = 0.1 cm, ρs = 2, no-slip coupling, about 8 cells per diameter) in a
box periodic in x with walls at the bottom and top, in a fluid of μ = 1 g/(cm s) (Re =
U d ρf/μ below 0.06), to t = 0.06 s; the mean settling velocity U is the `Suspension`
monitor's `settling_velocity` averaged (trapezoid rule) over 0.03 ≤ t ≤ 0.06. Prints U,
the square-array prediction of Sangani & Acrivos (1982, their dilute expansion with
Hasimoto's 1959 leading terms) U_SA = (ρs − ρf) g d² K(φ) / (16 μ),
K = −½ ln φ − 0.738 + φ − 0.887 φ² + 2.039 φ³, and the least-squares fit of
ln U = ln U₀ + n ln(1 − φ) (U₀ free: a 2D disk has no Stokes settling velocity of its own).

    python3 docs/scripts/hindered_settling_resolved.py [MULTIFIELD] [φ,φ,...]

MULTIFIELD defaults to ./target/release/multifield; runs go to out/hindered_resolved/.
"""

import csv
import math
import os
import subprocess
import sys
import time

D, MU, RHO_S, G = 0.1, 1.0, 2.0, 981.0

CASE = """(
    name: "hindered_resolved",
    domain: (size: ({lx!r}, {ly!r}), cells: ({nx}, {ny})),
    boundaries: (left: Periodic, right: Periodic, bottom: NoSlip, top: NoSlip),
    gravity: (0.0, -{G}),
    time: (end: 0.06, cfl: 0.4, max_dt: 1e-3),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian"), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: {MU}))]),
        (name: "disks", density: {RHO_S}, frame: (model: "lagrangian", params: (points_per_cell: 2)),
         representation: Resolved, region: Bodies([]),
         generate: [(name: "p", region: (min: (0.0, 0.0), max: ({lx!r}, {ly!r})), count: Some(32),
                     arrangement: Lattice(Square), spacing: Some({s!r}), diameter: Fixed({D}), min_gap: {g!r})],
         stress: [(model: "rigid")]),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip")],
    pressure: Some((model: "pcg", params: (tolerance: 1e-8))),
    monitors: [(name: "s", of: Suspension(field: "disks", bins: 8))],
    output: (interval: 0.005, charts: false),
)
"""


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else "./target/release/multifield"
    fractions = [float(x) for x in sys.argv[2].split(",")] if len(sys.argv) > 2 else [0.1, 0.2, 0.3, 0.4]
    out = os.path.join("out", "hindered_resolved")
    os.makedirs(out, exist_ok=True)
    rows = []
    print(f"{'phi':>6} {'cells':>8} {'steps':>6} {'wall s':>7} {'U cm/s':>9} {'U_SA':>9} {'U/U_SA':>7}")
    for phi in fractions:
        s = D * math.sqrt(math.pi / (4 * phi))  # πd²/4 = φ s²
        nx = round(4 * s / 0.0125)  # h ≈ d/8
        lx, ly, g = 4 * s, 8 * s, (s - D) / 2 * (1 - 1e-6)  # the lattice centred in the box
        path = os.path.join(out, f"phi_{phi}.ron")
        with open(path, "w") as f:
            f.write(CASE.format(lx=lx, ly=ly, nx=nx, ny=2 * nx, s=s, g=g, D=D, MU=MU, RHO_S=RHO_S, G=G))
        t0 = time.time()
        run = os.path.join(out, f"phi_{phi}")
        subprocess.run([binary, "run", path, "-o", run, "-q", "--threads", "1"], check=True, stdout=subprocess.DEVNULL)
        wall = time.time() - t0
        with open(os.path.join(run, "monitors", "s.csv"), newline="") as f:
            table = list(csv.DictReader(f))
        t = [float(r["time"]) for r in table]
        u = [float(r["settling_velocity"]) for r in table]
        inside = [k for k in range(len(t)) if 0.03 <= t[k] <= 0.06 + 1e-12]
        area = sum(0.5 * (u[a] + u[b]) * (t[b] - t[a]) for a, b in zip(inside, inside[1:]))
        mean = area / (t[inside[-1]] - t[inside[0]])
        got = float(table[0]["solid_fraction"])
        k = -0.5 * math.log(got) - 0.738 + got - 0.887 * got**2 + 2.039 * got**3
        u_sa = (RHO_S - 1.0) * G * D * D * k / (16 * MU)
        rows.append((got, mean))
        print(f"{got:>6.4f} {nx:>3}x{2 * nx:<4} {len(table) - 1:>6} {wall:>7.1f} {mean:>9.5f} {u_sa:>9.5f} "
              f"{mean / u_sa:>7.3f}")
    xs = [math.log(1 - p) for p, _ in rows]
    ys = [math.log(u) for _, u in rows]
    m = len(xs)
    mx, my = sum(xs) / m, sum(ys) / m
    n = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    c = my - n * mx
    rms = math.sqrt(sum((y - c - n * x) ** 2 for x, y in zip(xs, ys)) / m)
    print(f"fit ln U = ln U0 + n ln(1 - phi): n = {n:.3f}, U0 = {math.exp(c):.4f} cm/s, RMS residual {rms:.3e}")


if __name__ == "__main__":
    main()
