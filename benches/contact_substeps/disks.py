#!/usr/bin/env python3
"""Writes the case of issue 15's scene: N rigid disks (d = 0.1 cm, rho_s = 1.1) settling in
a closed channel of water (mu = 0.01 g/(cm s)), resolved at 8 cells per diameter, packed at
a gap of 0.4 d (within the repulsion's look-ahead of 2 rho = 0.5 d: contact-limited from the
first step), with small deterministic offsets. docs/performance.md, "Contact sub-steps".

usage: disks.py OUT.ron [--n 100] [--cols 10] [--width 2.0] [--height 8.0] [--end 0.3]
                        [--substeps] [--representation Resolved|MassPoint]
"""
import argparse
import random

p = argparse.ArgumentParser()
p.add_argument("out")
p.add_argument("--n", type=int, default=100)
p.add_argument("--cols", type=int, default=10)
p.add_argument("--width", type=float, default=2.0)
p.add_argument("--height", type=float, default=8.0)
p.add_argument("--end", type=float, default=0.3)
p.add_argument("--substeps", action="store_true")
p.add_argument("--seed", type=int, default=15)
a = p.parse_args()

d, h = 0.1, 0.1 / 8
pitch = 1.4 * d
rng = random.Random(a.seed)
x0 = 0.5 * a.width - 0.5 * (a.cols - 1) * pitch
y_top = a.height - 2.0 * d
bodies = []
for k in range(a.n):
    i, j = k % a.cols, k // a.cols
    x = x0 + i * pitch + rng.uniform(-0.02, 0.02) * d
    y = y_top - j * pitch + rng.uniform(-0.02, 0.02) * d
    bodies.append(f'(name: "d{k}", shape: Disk(center: ({x:.6f}, {y:.6f}), radius: {0.5 * d}))')
nx, ny = round(a.width / h), round(a.height / h)
body_list = ",\n                ".join(bodies)
substeps = "true" if a.substeps else "false"
text = f"""// {a.n} rigid disks (d = 0.1 cm, rho_s = 1.1) settling in a closed {a.width} x {a.height} cm channel of
// water, 8 cells per diameter (issue 15). Written by benches/contact_substeps/disks.py.
(
    name: "disks_{a.n}",
    domain: (size: ({a.width}, {a.height}), cells: ({nx}, {ny})),
    boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
    gravity: (0.0, -981.0),
    time: (end: {a.end}, cfl: 0.4, max_dt: 1e-2, contact_substeps: {substeps}),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian", params: (diffusion: "explicit")), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),
        (
            name: "disks",
            density: 1.1,
            frame: (model: "lagrangian", params: (points_per_cell: 2, shape: "linear", transfer: "flip", flip_blend: 1.0)),
            region: Bodies([
                {body_list},
            ]),
            stress: [(model: "rigid")],
        ),
    ],
    exchange: [(between: ("water", "disks"), model: "no_slip")],
    contact: Some((model: "repulsion")),
    pressure: Some((model: "pcg", params: (tolerance: 1e-8))),
    output: (interval: 0.01),
)
"""
open(a.out, "w").write(text)
