#!/usr/bin/env python3
"""The communication model of docs/design/mpi.md §9: bytes, exchanges and reductions per
rank per step of a decomposed 2D Eulerian step (implicit viscosity, MG-PCG), and the
parallel efficiency they predict on a stated network, for square rank grids.

    python3 benches/mpi/model.py                      # the table of §9 (16384², P = 64 and 1,024)
    python3 benches/mpi/model.py --cells 8192 --ranks 16 64 256 --tc 0.5e-6 1.93e-6

The inputs marked *estimate* in §9 (I_h = I_c = 5 CG iterations, ν = 2 smoothing sweeps,
t_c = 0.5 µs on a quiet machine) and the network (α = 2 µs per message stage, β = 10 GB/s
per rank, recursive-doubling all_reduce) are options; P5 replaces the byte counts by the
`Comm` counters' measurements and checks the halo part against `halo_bytes` exactly.
"""

import argparse
import math

H = 2  # halo layers


def halo_values(a, b):
    """Values in one halo layer of one array a rank sends: its four sides."""
    return 2 * (a + b)


def per_step(a, b, p, i_p, i_h, i_c, nu):
    """(bytes B, exchanges X, reductions R, distributed levels L_d, coarse cells N_c)."""
    e = halo_values(a, b)
    # the multigrid is distributed while its cuts are even: a power-of-two block of a cells
    # keeps log2(a) - 1 levels on the blocks (the last of them 4 cells wide)
    l_d = int(math.log2(min(a, b))) - 1
    # f64 layers: advection of u^n (u, v, θ: 3 × 2), the half step's CG 2(I_h + 1), advection
    # of u^½ (4), Crank–Nicolson's CG 2(I_c + 1), the predicted velocity (2), the PCG
    # (I_p + 1), the pressure (1), the corrected velocity (2), θ's two Heun stages (4):
    # 24 + 2(I_h + I_c) + I_p in all. The V-cycle (I_p + 1 a step) exchanges whole two-layer
    # f32 halos: on block level l (E/2^l values a layer) 4ν − 1 times (below the finest one
    # of them the right-hand side's); the set-up (once a step) each block level's couplings,
    # diagonal and its inverse (4 arrays of two f64 layers)
    levels = [(4 * nu - 1) / 2**l for l in range(l_d)]
    v_cycle = 4 * H * e * sum(levels)
    setup = 8 * H * e * 4 * sum(1 / 2**l for l in range(l_d))
    big_b = 8 * e * (24 + 2 * (i_h + i_c) + i_p) + v_cycle * (i_p + 1) + setup
    x = 9 + i_h + i_c + (i_p + 1) * (4 * nu - 1) * l_d + l_d
    # and a pure-Neumann problem's mean on each block level below the finest, per V-cycle
    r = 4 + 2 * i_p + 4 * (3 + 2 * i_h) + 6 + (i_p + 1) * (l_d - 1)
    side = int(round(math.sqrt(p)))
    n_c = (2 * side) ** 2  # the level gathered: 2 × 2 cells a block
    return big_b, x, r, l_d, n_c


def time_per_step(a, b, p, t_c, big_b, x, r, n_c, i_p, alpha, beta, t_coarse):
    """(compute, halo latency 2Xα, halo bandwidth B/β, reductions, coarse) in seconds."""
    logp = math.ceil(math.log2(p)) if p > 1 else 0
    compute = (1 + 2 * H / a) * (1 + 2 * H / b) * a * b * t_c
    reductions = r * 2 * alpha * logp
    coarse = (i_p + 1) * (alpha * logp + 4 * n_c / beta + n_c * t_coarse)
    return compute, 2 * x * alpha, big_b / beta, reductions, coarse


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=16384, help="cells along each axis of the square grid")
    ap.add_argument("--ranks", type=int, nargs="+", default=[64, 1024], help="P (perfect squares)")
    ap.add_argument("--tc", type=float, nargs="+", default=[0.5e-6, 1.93e-6], help="seconds per cell per step")
    ap.add_argument("--pcg", type=int, default=3, help="I_p, PCG iterations a step (measured: 3)")
    ap.add_argument("--cg", type=int, default=5, help="I_h = I_c, viscous CG iterations (estimate)")
    ap.add_argument("--sweeps", type=int, default=2, help="ν, smoothing sweeps (estimate)")
    ap.add_argument("--alpha", type=float, default=2e-6, help="latency per message stage, s")
    ap.add_argument("--beta", type=float, default=10e9, help="bandwidth per rank, bytes/s")
    ap.add_argument("--coarse-time", type=float, default=50e-9 * 4 / 3,
                    help="redundant coarse cycle, s per coarse cell (4/3 × 50 ns)")
    args = ap.parse_args()
    n = args.cells
    print(f"{n}² cells; α = {args.alpha * 1e6:g} µs, β = {args.beta / 1e9:g} GB/s; "
          f"I_p = {args.pcg}, I_h = I_c = {args.cg}, ν = {args.sweeps}")
    head = "| P | block | E | B per rank per step | L_d | X | R | 2Xα | B/β | reductions | coarse (N_c) |"
    head += "".join(f" efficiency, t_c = {tc * 1e6:g} µs |" for tc in args.tc)
    print(head)
    print("|" + "---|" * (11 + len(args.tc)))
    for p in args.ranks:
        side = int(round(math.sqrt(p)))
        if side * side != p or n % side:
            raise SystemExit(f"error: P = {p} is not a square rank grid dividing {n} cells")
        a = b = n // side
        big_b, x, r, l_d, n_c = per_step(a, b, p, args.pcg, args.cg, args.cg, args.sweeps)
        row = f"| {p} ({side} × {side}) | {a} | {halo_values(a, b):,} | {big_b / 1e6:.2f} MB | {l_d} | {x} | {r} |"
        effs = []
        for tc in args.tc:
            parts = time_per_step(a, b, p, tc, big_b, x, r, n_c, args.pcg, args.alpha, args.beta, args.coarse_time)
            effs.append(a * b * tc / sum(parts))
        _, lat, bw, red, coarse = parts
        row += f" {lat * 1e3:.2f} ms | {bw * 1e3:.2f} ms | {red * 1e3:.2f} ms | {coarse * 1e3:.2f} ms ({n_c}) |"
        row += "".join(f" {100 * e:.1f} % |" for e in effs)
        print(row)


if __name__ == "__main__":
    main()
