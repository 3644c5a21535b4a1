#!/usr/bin/env python3
"""The resolved DKT under the two couplings: `direct_forcing` against `no_slip`, wall time.

Runs examples/dkt_uhlmann2005.ron (Uhlmann 2005's two disks, direct forcing, the
repulsion's range one cell) and the same with `no_slip` and range two cells (as
examples/dkt_uhlmann2005_no_slip.ron) at 24 cells per diameter (192 × 576) to t = 0.3 s,
interleaved, `--repeat R` times, on the same
number of threads, and prints the median wall time of each (the time loop: `wall_seconds`
of summary.json), the best in parentheses, the steps and the ratio of medians. Needs a
release build:

    cargo build --release
    python3 benches/couplings/compare.py                    # 2 threads, 1 run each
    python3 benches/couplings/compare.py --repeat 3 --threads 1 2
    python3 benches/couplings/compare.py --cells 128 384    # 16 cells per diameter

The load average before each run is printed: the machine is shared.
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
COUPLINGS = {
    "no_slip": ['exchange.0.model="no_slip"', "contact.params.range_cells=2.0"],
    "direct_forcing": [],
}


def run(binary, out, threads, cells, end, overrides):
    sets = [f"domain.cells=({cells[0]}, {cells[1]})", f"time.end={end}", "output.charts=false"] + overrides
    cmd = [binary, "run", str(ROOT / "examples/dkt_uhlmann2005.ron"), "--out", str(out), "--quiet"]
    cmd += ["--threads", str(threads)]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    summary = json.loads((out / "summary.json").read_text())
    if summary["status"] != "completed":
        sys.exit(f"error: {out}: {summary['status']}: {summary.get('reason')}")
    return summary["wall_seconds"], summary["steps"]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--threads", type=int, nargs="+", default=[2])
    p.add_argument("--cells", type=int, nargs=2, default=[192, 576])
    p.add_argument("--end", type=float, default=0.3)
    args = p.parse_args()
    binary = os.environ.get("MULTIFIELD_BIN", str(ROOT / "target/release/multifield"))
    if not Path(binary).exists():
        sys.exit(f"error: {binary} not found: run `cargo build --release` first (or set MULTIFIELD_BIN)")
    with tempfile.TemporaryDirectory() as tmp:
        for threads in args.threads:
            walls = {name: [] for name in COUPLINGS}
            steps = {}
            for r in range(args.repeat):
                for name, overrides in COUPLINGS.items():
                    load = os.getloadavg()[0]
                    wall, n = run(binary, Path(tmp) / f"{name}_{threads}_{r}", threads, args.cells, args.end, overrides)
                    walls[name].append(wall)
                    steps[name] = n
                    print(f"  {threads} thread(s), run {r + 1}, {name}: {wall:.2f} s, {n} steps (load {load:.2f})")
            med = {k: statistics.median(v) for k, v in walls.items()}
            print(f"{threads} thread(s), {args.cells[0]} x {args.cells[1]} cells, t = {args.end}:")
            for name in COUPLINGS:
                print(f"  {name:15s} median {med[name]:7.2f} s (best {min(walls[name]):.2f}), {steps[name]} steps")
            print(f"  direct_forcing / no_slip: {med['direct_forcing'] / med['no_slip']:.2f}")


if __name__ == "__main__":
    main()
