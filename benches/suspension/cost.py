#!/usr/bin/env python3
"""Issue 15's two cost targets for suspensions, as ratios measured in the same run.

`disks`: the 100-disk scene of benches/contact_substeps/disks.py (resolved, 8 cells per
diameter, 160 x 640, contact sub-steps) against the same grid with two of its disks; the
wall time per step (target: at most 1.5x).

`points`: 10,000 mass points (d = 2 h, the 2D cylinder drag law, `dem` contact with
sub-steps) settling on a 256 x 1024 grid against the fluid alone on the same grid and
settings; the wall time per step (target: at most 2x).

`points --moving` adds a third run: the fluid alone started from the velocity the points
had stirred by `--end` (the points run's last snapshot, `FromSnapshot`), so that the points'
cost is seen against the fluid in the same flow as well as against the fluid at rest.

Each pair runs interleaved `--repeat R` times on `--threads T`; the script prints the
load before each run, the median (and best) time per step of each, and the ratio of the
medians. The time is `wall_seconds` of summary.json (the time loop) over its `steps`.

    cargo build --release
    python3 benches/suspension/cost.py disks points --repeat 3 --threads 1
    python3 benches/suspension/cost.py points --moving --repeat 3 --threads 1 --end 0.03
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def points_case(with_points, end):
    width, height, cells = 2.56, 10.24, (256, 1024)
    h = width / cells[0]
    d = 2.0 * h
    disks = ""
    if with_points:
        disks = f"""
        (
            name: "points",
            density: 1.1,
            frame: (model: "lagrangian", params: (points_per_cell: 2)),
            representation: MassPoint,
            region: Bodies([]),
            generate: [(
                name: "p",
                region: (min: (0.05, 2.0), max: ({width - 0.05}, {height - 0.5})),
                count: Some(10000),
                diameter: Fixed({d}),
                min_gap: {0.25 * d},
                seed: 15,
            )],
            stress: [(model: "rigid")],
        ),"""
    exchange = ""
    contact = "None"
    if with_points:
        exchange = """exchange: [(
        between: ("water", "points"),
        model: "no_slip",
        mass_point: Some((model: "cylinder", params: (added_mass: 1.0))),
    )],"""
        contact = 'Some((model: "dem", params: (restitution: 0.9, collision_time: 1e-3, friction: 0.3)))'
    return f"""(
    name: "{'points' if with_points else 'fluid'}",
    domain: (size: ({width}, {height}), cells: ({cells[0]}, {cells[1]})),
    boundaries: (left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip),
    gravity: (0.0, -981.0),
    time: (end: {end}, cfl: 0.4, max_dt: 2e-3, contact_substeps: true),
    fields: [
        (name: "water", density: 1.0, frame: (model: "eulerian", params: (diffusion: "explicit")), region: Rest,
         stress: [(model: "newtonian", params: (viscosity: 0.01))]),{disks}
    ],
    {exchange}
    contact: {contact},
    pressure: Some((model: "pcg", params: (tolerance: 1e-8))),
    output: (interval: {end}, charts: false),
)
"""


def disks_case(tmp, n, cols, end):
    out = tmp / f"disks_{n}.ron"
    cmd = [sys.executable, str(ROOT / "benches/contact_substeps/disks.py"), str(out), "--n", str(n)]
    cmd += ["--cols", str(cols), "--end", str(end), "--substeps"]
    subprocess.run(cmd, check=True)
    return out


def run(binary, case, out, threads, extra=()):
    load = os.getloadavg()[0]
    cmd = [binary, "run", str(case), "--out", str(out), "--quiet", "--threads", str(threads)]
    cmd += ["--set", "output.charts=false", *extra]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    s = json.loads((out / "summary.json").read_text())
    if s["status"] != "completed":
        sys.exit(f"error: {out}: {s['status']}: {s.get('reason')}")
    per_step = s["wall_seconds"] / s["steps"]
    print(f"  {case.stem:>10}: {s['steps']:5d} steps, {s['wall_seconds']:8.2f} s, "
          f"{1e3 * per_step:8.2f} ms/step (load {load:.2f})", flush=True)
    return per_step


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("which", nargs="+", choices=["disks", "points"])
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--end", type=float, default=None, help="simulated time (disks 0.1, points 0.05)")
    p.add_argument("--moving", action="store_true", help="points: also the fluid alone in the points' flow")
    args = p.parse_args()
    binary = os.environ.get("MULTIFIELD_BIN", str(ROOT / "target/release/multifield"))
    if not Path(binary).exists():
        sys.exit(f"error: {binary} not found: run `cargo build --release` first (or set MULTIFIELD_BIN)")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for which in args.which:
            if which == "disks":
                end = args.end or 0.1
                pair = [("100 disks", disks_case(tmp, 100, 10, end), ()), ("2 disks", disks_case(tmp, 2, 2, end), ())]
                target = 1.5
            else:
                end = args.end or 0.05
                cases = []
                for name, with_points in [("points", True), ("fluid", False)]:
                    path = tmp / f"{name}.ron"
                    path.write_text(points_case(with_points, end))
                    cases.append((name, path))
                pair = [("10,000 mass points", cases[0][1], ()), ("fluid alone", cases[1][1], ())]
                target = 2.0
                if args.moving:
                    # the points' flow at `end`: one run with a snapshot of its last step
                    snap = tmp / "stirred"
                    run(binary, cases[0][1], snap, args.threads, ["--set", "output.snapshots=Some((at_end: true))"])
                    last = sorted((snap / "snapshots").glob("*.h5"))[-1]
                    start = f'fields.water.velocity=FromSnapshot(file: "{last}", field: "water")'
                    pair.append(("fluid alone in the points' flow", cases[1][1], ("--set", start)))
            times = {label: [] for label, _, _ in pair}
            print(f"{which}: {args.repeat} x {len(pair)} runs, {args.threads} thread(s), to t = {end}")
            for r in range(args.repeat):
                for k, (label, case, extra) in enumerate(pair):
                    times[label].append(run(binary, case, tmp / f"{case.stem}_{k}_{r}", args.threads, extra))
            med = {label: statistics.median(t) for label, t in times.items()}
            for label, t in times.items():
                print(f"  {label}: median {1e3 * med[label]:.2f} ms/step (best {1e3 * min(t):.2f})")
            for label, _, _ in pair[1:]:
                ratio = med[pair[0][0]] / med[label]
                print(f"  ratio of medians to the {label}: {ratio:.2f} (target at most {target})")


if __name__ == "__main__":
    main()
