#!/usr/bin/env python3
"""The cost of monitors (issue 22): the Uhlmann DKT with and without monitors, wall time.

Runs examples/dkt_uhlmann2005.ron (16 cells per diameter, 128 × 384) for `--steps` steps
twice per repetition, interleaved: as shipped, and with ten velocity probes, a line of
100 velocity samples and the forces on both disks, all sampled every step. Prints the
median wall time of each (the time loop: `wall_seconds` of summary.json), the best in
parentheses, and the ratio of the medians, per thread count. It also checks that both
runs wrote the same diagnostics.csv and bodies.csv (monitors only read the state).
Needs a release build:

    cargo build --release
    python3 benches/monitors/compare.py                       # 2 threads, 3 pairs
    python3 benches/monitors/compare.py --repeat 7 --threads 1 2

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
PROBES = ", ".join(f"({0.2 + 0.16 * k:.2f}, {1.0 + 0.45 * k:.2f})" for k in range(10))
MONITORS = f"""
    monitors: [
        (name: "probes", of: Probes(quantity: "velocity", points: [{PROBES}])),
        (name: "line", of: Line(quantity: "velocity", from: (0.0, 3.0), to: (2.0, 3.0), points: 100)),
        (name: "forces", of: Forces(bodies: ["trailing", "leading"])),
    ],
)
"""


def with_monitors(text):
    end = text.rstrip()
    if not end.endswith(")"):
        sys.exit("error: the example does not end with `)`")
    return end[:-1] + MONITORS


def run(binary, case, out, threads, steps):
    cmd = [binary, "run", str(case), "--out", str(out), "--quiet", "--threads", str(threads)]
    cmd += ["--set", f"time.max_steps={steps}", "--set", "output.charts=false"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    summary = json.loads((out / "summary.json").read_text())
    if summary["steps"] != steps:
        sys.exit(f"error: {out}: {summary['steps']} steps, not {steps}: {summary.get('reason')}")
    return summary["wall_seconds"]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--threads", type=int, nargs="+", default=[2])
    p.add_argument("--steps", type=int, default=150)
    args = p.parse_args()
    binary = os.environ.get("MULTIFIELD_BIN", str(ROOT / "target/release/multifield"))
    if not Path(binary).exists():
        sys.exit(f"error: {binary} not found: run `cargo build --release` first (or set MULTIFIELD_BIN)")
    example = ROOT / "examples/dkt_uhlmann2005.ron"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        monitored = tmp / "dkt_monitors.ron"
        monitored.write_text(with_monitors(example.read_text()))
        for threads in args.threads:
            times = {"without": [], "with": []}
            for r in range(args.repeat):
                for kind, case in [("without", example), ("with", monitored)]:
                    out = tmp / f"{kind}_{threads}_{r}"
                    load = os.getloadavg()[0]
                    t = run(binary, case, out, threads, args.steps)
                    times[kind].append(t)
                    print(f"  {threads} threads, {kind:>7} monitors, run {r + 1}: {t:.3f} s (load {load:.2f})")
                for name in ["diagnostics.csv", "bodies.csv"]:
                    a = (tmp / f"without_{threads}_{r}" / name).read_text()
                    b = (tmp / f"with_{threads}_{r}" / name).read_text()
                    if a != b:
                        sys.exit(f"error: {name} differs with the monitors")
            m0, m1 = statistics.median(times["without"]), statistics.median(times["with"])
            print(
                f"{threads} threads, {args.steps} steps: without {m0:.3f} s (best {min(times['without']):.3f}), "
                f"with {m1:.3f} s (best {min(times['with']):.3f}); ratio of medians {m1 / m0:.4f} "
                f"({100 * (m1 / m0 - 1):+.2f} %)"
            )


if __name__ == "__main__":
    main()
