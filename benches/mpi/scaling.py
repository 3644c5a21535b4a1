#!/usr/bin/env python3
"""Strong scaling of a decomposed run on this machine (issue 19): the same case and steps as
one process on 1 thread, one process on T threads, and P ranks of 1 thread each under
mpirun; wall time per step of the time loop (summary.json's wall_seconds over the steps),
medians of the repeats, run in interleaved order; with the ranks' communication per step
(summary.json's `communication`).

    cargo build --release --features mpi
    python3 benches/mpi/scaling.py                       # TGV 1024², multigrid PCG, 10 steps
    python3 benches/mpi/scaling.py --case taylor_green_jacobi   # the same with the Jacobi PCG
    python3 benches/mpi/scaling.py --cells 512 --steps 20 --repeat 3 --ranks 2
    python3 benches/mpi/scaling.py --case dkt --cells 240 --steps 20   # DKT, 24 cells a diameter
    python3 benches/mpi/scaling.py --case flip --cells 512 --steps 10  # the vortex on material points

The case is examples/taylor_green.ron at --cells² with its own solver (the
multigrid-preconditioned PCG, the V-cycle's levels on the blocks while their cuts are even,
the rest gathered), with `--case taylor_green_jacobi` the same with `preconditioner:
"jacobi"`, or with `--case dkt`
examples/dkt_seed.ron (two resolved disks of diameter 0.2 in a 2 × 8 channel) at --cells
× 4 --cells with its own solver (the multigrid-preconditioned PCG), or with `--case flip` examples/taylor_green_flip.ron
(APIC on material points, 4 a cell) at --cells² with the Jacobi PCG; no output but diagnostics.csv, bodies.csv and
summary.json. MULTIFIELD_BIN names the binary (default target/release/multifield, which
must be built with --features mpi for the ranks); MULTIFIELD_MPIRUN the launcher.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


CASES = {
    "taylor_green": ("taylor_green.ron", lambda c: [f"domain.cells=({c}, {c})"]),
    "taylor_green_jacobi": ("taylor_green.ron",
                            lambda c: [f"domain.cells=({c}, {c})", 'pressure.params.preconditioner="jacobi"']),
    "dkt": ("dkt_seed.ron", lambda c: [f"domain.cells=({c}, {4 * c})", "output.snapshots=None"]),
    "flip": ("taylor_green_flip.ron",
             lambda c: [f"domain.cells=({c}, {c})", 'pressure.params.preconditioner="jacobi"', "output.snapshots=None"]),
}


def run(binary, mpirun, case, ranks, threads, cells, steps, out):
    file, sets = CASES[case]
    args = [binary, "run", os.path.join(ROOT, "examples", file), "--out", out, "--quiet",
            "--threads", str(threads)]
    for s in sets(cells) + [f"time.max_steps={steps}", "output.interval=0", "output.charts=false"]:
        args += ["--set", s]
    if ranks:
        args = [mpirun, "-np", str(ranks), "--oversubscribe"] + args
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_btl_vader_single_copy_mechanism="none")
    p = subprocess.run(args, capture_output=True, text=True, env=env)
    if p.returncode != 0:
        sys.exit(f"error: {' '.join(args)}\n{p.stdout}\n{p.stderr}")
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    with open(os.path.join(out, "diagnostics.csv"), "rb") as f:
        diagnostics = f.read()
    if os.path.exists(os.path.join(out, "bodies.csv")):
        with open(os.path.join(out, "bodies.csv"), "rb") as f:
            diagnostics += f.read()
    return s["wall_seconds"] / s["steps"], s.get("communication"), diagnostics, s["pressure_iterations_total"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=sorted(CASES), default="taylor_green")
    ap.add_argument("--cells", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ranks", type=int, nargs="+", default=[2])
    ap.add_argument("--threads", type=int, default=2, help="threads of the one-process comparison")
    args = ap.parse_args()
    binary = os.environ.get("MULTIFIELD_BIN", os.path.join(ROOT, "target", "release", "multifield"))
    mpirun = os.environ.get("MULTIFIELD_MPIRUN", "mpirun")
    configs = [("1 process, 1 thread", 0, 1), (f"1 process, {args.threads} threads", 0, args.threads)]
    configs += [(f"mpirun -np {p}, 1 thread each", p, 1) for p in [1] + args.ranks]
    times = {c[0]: [] for c in configs}
    comm, diags, iters = {}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeat):
            for name, ranks, threads in configs:
                out = os.path.join(tmp, f"{ranks}_{threads}_{k}")
                t, c, d, it = run(binary, mpirun, args.case, ranks, threads, args.cells, args.steps, out)
                times[name].append(t)
                comm[name], diags[name], iters[name] = c, d, it
    base = statistics.median(times[configs[0][0]])
    what = {"taylor_green": f"Taylor–Green {args.cells}², multigrid PCG",
            "taylor_green_jacobi": f"Taylor–Green {args.cells}², Jacobi PCG",
            "flip": f"Taylor–Green on material points {args.cells}², Jacobi PCG",
            "dkt": f"DKT {args.cells} × {4 * args.cells}, multigrid PCG"}[args.case]
    print(f"{what}, {args.steps} steps, medians of {args.repeat} "
          f"({iters[configs[0][0]]} pressure iterations in all); load {os.getloadavg()[0]:.2f} at the end")
    print("| run | ms per step | speed-up over 1 thread | diagnostics (and bodies) as 1 thread | "
          "bytes sent per rank per step | exchanges | reductions | gathers | bytes gathered |")
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|")
    for name, ranks, threads in configs:
        m = statistics.median(times[name])
        same = "yes" if diags[name] == diags[configs[0][0]] else "NO"
        c = comm[name]
        if c:
            per = c["per_step"]
            traffic = (f"{max(r['bytes'] for r in per):,.0f} | {per[0]['exchanges']:.1f} | "
                       f"{per[0]['reductions']:.1f} | {per[0]['gathers']:.1f} | "
                       f"{max(r['gathered_bytes'] for r in per):,.0f}")
        else:
            traffic = "– | – | – | – | –"
        print(f"| {name} | {1e3 * m:.1f} | {base / m:.2f} | {same} | {traffic} |")
    name = configs[-1][0]
    if comm[name]:
        print(f"\nrank 0's traffic per step by phase ({name}):\n")
        print("| phase | bytes | messages | exchanges | reductions | gathers | bytes gathered |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for p in comm[name]["rank0_phases"]:
            print(f"| {p['phase']} | {p['bytes']:,.0f} | {p['messages']:.1f} | {p['exchanges']:.1f} | "
                  f"{p['reductions']:.1f} | {p['gathers']:.1f} | {p['gathered_bytes']:,.0f} |")


if __name__ == "__main__":
    main()
