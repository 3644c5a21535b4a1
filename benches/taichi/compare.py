#!/usr/bin/env python3
"""examples/mpm88.ron against Taichi's mpm88 on this machine: speed and physics.

Needs a release build and Taichi 1.7 (this script installs nothing):

    cargo build --release
    pip install "taichi==1.7.*"
    python3 benches/taichi/compare.py                      # 1 and 2 threads, one run each
    python3 benches/taichi/compare.py --repeat 3 --threads 1 2
    python3 benches/taichi/compare.py --set 'fields.fluid.frame.params.grid="staggered"' --set coupling.max_volume_fraction_error=2  # the coupled grid (its points crowd to Σθ 2.79: docs/performance.md)
    MULTIFIELD_BIN=/other/target/release/multifield python3 benches/taichi/compare.py  # another build
    python3 benches/taichi/compare.py --baseline-bin /tmp/multifield_before --repeat 3  # before/after

Speed: particle-steps per second (8,192 points × steps / seconds) of
- ours: `multifield run examples/mpm88.ron --threads N --quiet --set output.interval=0`,
  2,000 steps; seconds = `wall_seconds` of summary.json (the time loop: every step with its
  diagnostics, and the CSV rows; not the set-up). `output.interval=0` writes a row every
  step (the mean height below needs them); that costs well under 1 % of the run.
- Taichi: `benches/taichi/mpm88.py --threads N` (mpm88 itself, 128² nodes, f32 as shipped),
  the 1,990 steps after a 10-step warm-up that includes the JIT compilation.
- bare C: benches/taichi/mpm88_bare.c, mpm88's algorithm in plain C (f32, the same lattice,
  2,000 steps, all timed), compiled here with `gcc -O3 -march=native` (one thread) and with
  `-fopenmp` added (more threads; per-thread grids summed node by node; run with
  GOMP_SPINCOUNT=10000 unless it or OMP_WAIT_POLICY is set): what this machine allows
  for the algorithm with no framework around it. `--no-bare` skips it.
With `--baseline-bin PATH` a second build of ours (e.g. the commit before a change) runs
right after ours in every repetition, with the same case and overrides; its rates and its
ratio to Taichi get their own table, and its ratio against ours. With `--repeat R` each
is run R times, interleaved; the tables give the median rate of the
R runs (the machine is shared) and, in parentheses, the best; the ratios are of medians.
The load average before each run is printed. The bare kernel's checksum (kinetic
energy and mean height every 500 steps) is compared with Taichi's one-thread history.

Physics: ours (1 thread) against `mpm88.py --walls-at-unit-square --threads 1`, the same
kernel on 132² nodes with the points moved by 2 dx, so that mpm88's effective walls (its
points stop 2 dx inside the clamped node layers) enclose the same box as our unit square.
Compared every 50 steps: the kinetic energy, and the mean height of the points ȳ. Ours is
not in the output; it is ȳ₀ + Σ Δt p_y/M over the steps (the points move by Δt v with
the velocity whose momentum is reported; only points stopped at a wall make it drift, by
less than 1e-5 in this run).
"""

import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
POINTS = 8192
DT = 2e-4
DX = 1.0 / 128


def load():
    a, b, c = os.getloadavg()
    return f"{a:.2f} {b:.2f} {c:.2f}"


def run_ours(binary, case, out, threads, sets=()):
    cmd = [str(binary), "run", str(case), "--out", str(out), "--threads", str(threads), "--quiet"]
    cmd += ["--set", "output.interval=0"]
    for s in sets:
        cmd += ["--set", s]
    before = load()
    p = subprocess.run(cmd, capture_output=True, text=True)
    summary = {}
    if (out / "summary.json").exists():
        summary = json.loads((out / "summary.json").read_text())
    if p.returncode != 0 or summary.get("status") != "completed":
        print(f"  ours, {threads} thread(s): {summary.get('status', 'failed')}: {summary.get('reason', p.stderr.strip())}")
    steps, wall = summary.get("steps", 0), summary.get("wall_seconds", float("nan"))
    rate = POINTS * steps / wall if steps else float("nan")
    return dict(rate=rate, steps=steps, seconds=wall, load=before, status=summary.get("status"), cmd=" ".join(cmd))


def run_taichi(script, threads, history=None, extra=()):
    cmd = [sys.executable, str(script), "--threads", str(threads), *extra]
    if history:
        cmd += ["--history", str(history)]
    before = load()
    p = subprocess.run(cmd, capture_output=True, text=True)
    m = re.search(r"timed_steps (\d+) .* seconds ([0-9.]+) particle_steps_per_s ([0-9.e+]+)", p.stdout)
    if p.returncode != 0 or not m:
        sys.exit(f"taichi run failed ({' '.join(cmd)}):\n{p.stdout}\n{p.stderr}")
    return dict(rate=float(m.group(3)), steps=int(m.group(1)), seconds=float(m.group(2)), load=before, cmd=" ".join(cmd))


def build_bare(cc, out):
    """Compiles mpm88_bare.c without and with OpenMP: {1: serial, 2: openmp} binaries."""
    src = ROOT / "benches/taichi/mpm88_bare.c"
    bins = {}
    for name, extra in (("serial", []), ("openmp", ["-fopenmp"])):
        exe = out / f"mpm88_bare_{name}"
        cmd = [cc, "-O3", "-march=native", *extra, "-o", str(exe), str(src), "-lm"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr}")
        bins[name] = exe
    return bins


def run_bare(bins, threads):
    exe = bins["serial"] if threads == 1 else bins["openmp"]
    cmd = [str(exe), "--threads", str(threads), "--repeat", "1"]
    env = dict(os.environ)
    if "OMP_WAIT_POLICY" not in env:
        env.setdefault("GOMP_SPINCOUNT", "10000")  # see mpm88_bare.c: barriers on a shared machine
    before = load()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    m = re.search(r"bare mpm88 .* steps (\d+) threads \d+ seconds ([0-9.]+) particle_steps_per_s ([0-9.e+]+)", p.stdout)
    if p.returncode != 0 or not m:
        sys.exit(f"bare kernel failed ({' '.join(cmd)}):\n{p.stdout}\n{p.stderr}")
    checks = {
        int(c.group(1)): (float(c.group(2)), float(c.group(3)))
        for c in re.finditer(r"checksum step (\d+) kinetic_energy ([0-9.e+-]+) mean_y ([0-9.e+-]+)", p.stdout)
    }
    return dict(
        rate=float(m.group(3)), steps=int(m.group(1)), seconds=float(m.group(2)), load=before, cmd=" ".join(cmd), checks=checks
    )


def summary(runs):
    """The median run by rate (its rate, steps, checks...), with the best rate as `best`."""
    ordered = sorted(runs, key=lambda r: r["rate"])
    median = dict(ordered[(len(ordered) - 1) // 2])
    if len(ordered) % 2 == 0:
        median["rate"] = 0.5 * (ordered[len(ordered) // 2 - 1]["rate"] + ordered[len(ordered) // 2]["rate"])
    median["best"] = ordered[-1]["rate"]
    median["checks"] = runs[0].get("checks", {})
    return median


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def physics(ours_csv, taichi_csv, every=50):
    rows = read_csv(ours_csv)
    ref = {int(r["step"]): r for r in read_csv(taichi_csv)}
    mass = float(rows[0]["mass"])
    y = float(ref[0]["mean_y"])
    ours = {0: (float(ref[0]["kinetic_energy"]), y)}
    for r in rows:
        y += DT * float(r["momentum_y"]) / mass
        s = int(r["step"])
        if s % every == 0:
            ours[s] = (float(r["kinetic_energy"]), y)
    steps = sorted(s for s in ours if s in ref and s > 0)
    table = []
    for s in steps:
        ke_t, y_t = float(ref[s]["kinetic_energy"]), float(ref[s]["mean_y"])
        ke_o, y_o = ours[s]
        table.append((s, ke_o, ke_t, (ke_o - ke_t) / ke_t, y_o, y_t, (y_o - y_t) / y_t))
    return table


def main():
    ap = argparse.ArgumentParser(description="mpm88: multifield against Taichi (speed and physics)")
    ap.add_argument("--bin", default=os.environ.get("MULTIFIELD_BIN", ROOT / "target/release/multifield"))
    ap.add_argument("--baseline-bin", default=None, help="a second build of ours, run interleaved with --bin")
    ap.add_argument("--case", default=ROOT / "examples/mpm88.ron")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=1, help="runs per configuration; medians and bests are reported")
    ap.add_argument("--out", default=None, help="directory for the runs (default: a temporary one)")
    ap.add_argument("--impact", type=float, default=0.12, help="time that splits 'before impact' from 'after'")
    ap.add_argument("--no-bare", action="store_true", help="skip the bare C kernel (benches/taichi/mpm88_bare.c)")
    ap.add_argument("--cc", default="gcc", help="C compiler for the bare kernel (default gcc)")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help='a case override for ours, as `multifield run --set` (e.g. \'fields.fluid.frame.params.grid="staggered"\')',
    )
    args = ap.parse_args()

    binary = Path(args.bin)
    if not binary.exists():
        sys.exit(f"{binary} not found: run `cargo build --release` first")
    baseline = Path(args.baseline_bin) if args.baseline_bin else None
    if baseline and not baseline.exists():
        sys.exit(f"{baseline} not found")
    try:
        import taichi  # noqa: F401
    except ImportError:
        sys.exit('taichi is not installed: pip install "taichi==1.7.*"')
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="mpm88_compare_"))
    out.mkdir(parents=True, exist_ok=True)
    script = ROOT / "benches/taichi/mpm88.py"
    print(f"runs in {out}; {os.cpu_count()} cores; load average (1, 5, 15 min) now {load()}")

    bins = None if args.no_bare else build_bare(args.cc, out)
    results = {}
    base_results = {}
    for threads in args.threads:
        runs_o, runs_t, runs_b, runs_base = [], [], [], []
        for k in range(args.repeat):
            o = run_ours(binary, args.case, out / f"ours_t{threads}_{k}", threads, args.set)
            if baseline:
                r = run_ours(baseline, args.case, out / f"baseline_t{threads}_{k}", threads, args.set)
                print(
                    f"  threads {threads} run {k + 1}: baseline {r['rate']:.3e} p-steps/s ({r['steps']} steps, "
                    f"{r['seconds']:.2f} s, load {r['load']})"
                )
                runs_base.append(r)
            t = run_taichi(script, threads, history=out / f"taichi_t{threads}_{k}.csv")
            line = (
                f"  threads {threads} run {k + 1}: ours {o['rate']:.3e} p-steps/s ({o['steps']} steps, "
                f"{o['seconds']:.2f} s, load {o['load']}); taichi {t['rate']:.3e} ({t['steps']} steps, "
                f"{t['seconds']:.2f} s, load {t['load']})"
            )
            if bins:
                b = run_bare(bins, threads)
                line += f"; bare C {b['rate']:.3e} ({b['steps']} steps, {b['seconds']:.2f} s, load {b['load']})"
                runs_b.append(b)
            print(line)
            runs_o.append(o)
            runs_t.append(t)
        results[threads] = (summary(runs_o), summary(runs_t), summary(runs_b) if runs_b else None)
        if runs_base:
            base_results[threads] = summary(runs_base)

    print()
    if bins:
        print(
            "| threads | ours (particle-steps/s) | Taichi 1.7 CPU, f32 | bare C, f32 | ours / Taichi | bare C / Taichi "
            "| bare C / ours | 5 × Taichi |"
        )
        print("|---:|---:|---:|---:|---:|---:|---:|---:|")
        for threads, (o, t, b) in results.items():
            print(
                f"| {threads} | {o['rate']:.3e} ({o['best']:.3e}) | {t['rate']:.3e} ({t['best']:.3e}) "
                f"| {b['rate']:.3e} ({b['best']:.3e}) | {o['rate'] / t['rate']:.2f} "
                f"| {b['rate'] / t['rate']:.2f} | {b['rate'] / o['rate']:.2f} | {5 * t['rate']:.3e} |"
            )
        print("(medians of the runs, the best in parentheses; ratios of medians)")
        print()
        for threads, (o, t, b) in results.items():
            verdict = "reaches" if o["rate"] >= 5 * t["rate"] else "does not reach"
            print(
                f"{threads} thread(s): ours {verdict} 5 × Taichi ({o['rate']:.3e} against {5 * t['rate']:.3e} "
                f"particle-steps/s; it is {o['rate'] / t['rate']:.2f} × Taichi)"
            )
        for threads, (o, t, b) in results.items():
            verdict = "reaches" if b["rate"] >= 5 * t["rate"] else "does not reach"
            print(
                f"{threads} thread(s): the bare C kernel {verdict} 5 × Taichi ({b['rate']:.3e} against "
                f"{5 * t['rate']:.3e} particle-steps/s; it is {b['rate'] / t['rate']:.2f} × Taichi)"
            )
        # the bare kernel computes what mpm88 computes: its checksums against Taichi's history
        ref = {int(r["step"]): r for r in read_csv(out / f"taichi_t{min(results)}_0.csv")}
        b = results[min(results)][2]
        print("\nbare C against Taichi (same kernel, same lattice, both f32):")
        print("| step | KE bare C | KE Taichi | ΔKE/KE | ȳ bare C | ȳ Taichi | Δȳ/ȳ |")
        print("|---:|---:|---:|---:|---:|---:|---:|")
        for s_, (ke, y) in sorted(b["checks"].items()):
            if s_ in ref:
                ke_t, y_t = float(ref[s_]["kinetic_energy"]), float(ref[s_]["mean_y"])
                dke, dy = 100 * (ke / ke_t - 1), 100 * (y / y_t - 1)
                print(f"| {s_} | {ke:.5f} | {ke_t:.5f} | {dke:+.2f} % | {y:.5f} | {y_t:.5f} | {dy:+.2f} % |")
    else:
        print("| threads | ours (particle-steps/s) | Taichi 1.7 CPU, f32 (particle-steps/s) | ours / Taichi |")
        print("|---:|---:|---:|---:|")
        for threads, (o, t, _) in results.items():
            print(f"| {threads} | {o['rate']:.3e} ({o['best']:.3e}) | {t['rate']:.3e} ({t['best']:.3e}) | {o['rate'] / t['rate']:.2f} |")
    print()
    if base_results:
        print(f"ours ({binary}) against the baseline ({baseline}), same runs:")
        print("| threads | baseline (particle-steps/s) | ours | baseline / Taichi | ours / Taichi | ours / baseline |")
        print("|---:|---:|---:|---:|---:|---:|")
        for threads, r in base_results.items():
            o, t = results[threads][0], results[threads][1]
            print(
                f"| {threads} | {r['rate']:.3e} ({r['best']:.3e}) | {o['rate']:.3e} ({o['best']:.3e}) "
                f"| {r['rate'] / t['rate']:.2f} | {o['rate'] / t['rate']:.2f} | {o['rate'] / r['rate']:.3f} |"
            )
        for threads in base_results:
            a = read_csv(out / f"ours_t{threads}_0" / "diagnostics.csv")
            b = read_csv(out / f"baseline_t{threads}_0" / "diagnostics.csv")
            print(f"{threads} thread(s): diagnostics.csv of ours and the baseline {'identical' if a == b else 'DIFFER'}")
        print()

    # physics: ours at 1 thread (any thread count gives the same bits) against the walls-matched mpm88
    threads = min(results)
    ours_csv = out / f"ours_t{threads}_0" / "diagnostics.csv"
    ref_csv = out / "taichi_walls_matched.csv"
    run_taichi(script, 1, history=ref_csv, extra=["--walls-at-unit-square"])
    table = physics(ours_csv, ref_csv)
    if len(results) > 1:
        a = [r["kinetic_energy"] for r in read_csv(ours_csv)]
        for t in results:
            b = [r["kinetic_energy"] for r in read_csv(out / f"ours_t{t}_0" / "diagnostics.csv")]
            if a != b:
                print(f"note: ours at {t} threads differs from {threads} thread(s)")
    print("| step | t | KE ours | KE Taichi | ΔKE/KE | ȳ ours | ȳ Taichi | Δȳ/ȳ |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for s, ke_o, ke_t, dke, y_o, y_t, dy in table:
        if s % 100 == 0:
            print(f"| {s} | {s * DT:.2f} | {ke_o:.4f} | {ke_t:.4f} | {100 * dke:+.1f} % | {y_o:.4f} | {y_t:.4f} | {100 * dy:+.1f} % |")
    before = [r for r in table if r[0] * DT <= args.impact + 1e-9]
    after = [r for r in table if r[0] * DT > args.impact + 1e-9]

    def stats(rows, k):
        v = [abs(r[k]) for r in rows]
        return max(v), sum(v) / len(v)

    print()
    for name, rows in (("before impact", before), ("after impact", after), ("whole run", table)):
        if not rows:
            continue
        (mk, ak), (my, ay) = stats(rows, 3), stats(rows, 6)
        print(
            f"{name} (t {rows[0][0] * DT:.2f}–{rows[-1][0] * DT:.2f}, {len(rows)} samples): kinetic energy max "
            f"|Δ|/KE {100 * mk:.2f} %, mean {100 * ak:.2f} %; mean height max |Δ|/ȳ {100 * my:.2f} %, mean {100 * ay:.2f} %"
        )
    ke_o = sum(r[1] for r in after) / max(len(after), 1)
    ke_t = sum(r[2] for r in after) / max(len(after), 1)
    print(f"kinetic energy averaged after impact: ours {ke_o:.4f}, Taichi {ke_t:.4f} ({100 * (ke_o / ke_t - 1):+.1f} %)")
    print(f"final: KE ours {table[-1][1]:.4f} Taichi {table[-1][2]:.4f}; ȳ ours {table[-1][4]:.4f} Taichi {table[-1][5]:.4f}")


if __name__ == "__main__":
    main()
