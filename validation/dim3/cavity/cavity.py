#!/usr/bin/env python3
"""The centre-line profiles of multifield's lid-driven cube against Albensoeder & Kuhlmann (2005).

For each run directory of examples/dim3/cavity.ron, reads the last rows of the monitors
`vertical` and `horizontal` (the velocity at the 17 stations of Tables 5 and 6: u on
x = y = 1/2, w on y = z = 1/2) and prints the largest and the RMS difference over the 15
interior stations of each table (the end rows are the walls' values, set by the boundary
condition), and the extrema u_min, w_max, w_min of the 201-point `vertical_line` and
`horizontal_line` by the least-squares parabola through the samples within 1.5 cells of the
extreme sample between the outermost rows of nodes (the line's samples interpolate the grid
linearly and extrapolate it in the half cell at a wall), beside the
7-digit values of the same spectral solution quoted by Ben Beya & Lili (2008) (README.md:
for orientation only). numpy only.

    python3 validation/dim3/cavity/cavity.py RUN_DIR [RUN_DIR ...]
"""

import pathlib
import re
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
TABLES = (
    ("Table 5, u(z) on x = y = 1/2", "albensoeder_kuhlmann2005_re1000_table5.csv", "vertical", "x"),
    ("Table 6, w(x) on y = z = 1/2", "albensoeder_kuhlmann2005_re1000_table6.csv", "horizontal", "z"),
)
# (name, line monitor, component, min or max, value, position) quoted by Ben Beya & Lili (2008)
EXTREMA = (
    ("u_min", "vertical_line", "x", np.argmin, -0.2803833, 0.12419),
    ("w_max", "horizontal_line", "z", np.argmax, 0.2466511, 0.10913),
    ("w_min", "horizontal_line", "z", np.argmin, -0.4350186, 0.90957),
)


def last_row(path):
    with open(path) as f:
        names = f.readline().strip().split(",")
    rows = np.atleast_2d(np.genfromtxt(path, delimiter=",", skip_header=1))
    return dict(zip(names, rows[-1]))


def table(name):
    data = np.genfromtxt(HERE / name, delimiter=",", names=True)
    return data[data.dtype.names[2]], data[data.dtype.names[3]]


def compare(run):
    """{table: (max, rms, station of the max)} and {extremum: (value, position)} of a run."""
    run = pathlib.Path(run)
    out = {}
    for label, name, monitor, comp in TABLES:
        s, ref = table(name)
        row = last_row(run / "monitors" / f"{monitor}.csv")
        mine = np.array([row[f"p{i}_{comp}"] for i in range(len(s))])
        d = (mine - ref)[1:-1]
        k = int(np.argmax(np.abs(d)))
        out[label] = (np.max(np.abs(d)), np.sqrt(np.mean(d**2)), s[1:-1][k], row["time"])
    cells = int(re.search(r"cells:\s*\(\s*(\d+)", (run / "case.ron").read_text()).group(1))
    ext = {}
    for name, monitor, comp, pick, _, _ in EXTREMA:
        row = last_row(run / "monitors" / f"{monitor}.csv")
        n = sum(1 for key in row if key.endswith("_x") and key.startswith("s"))
        s = np.linspace(0.0, 1.0, n)
        v = np.array([row[f"s{i}_{comp}"] for i in range(n)])
        # between the outermost rows of nodes (half a cell from the walls): nearer the wall
        # the line extrapolates the two last rows
        inside = (s >= 0.5 / cells - 1e-12) & (s <= 1.0 - 0.5 / cells + 1e-12)
        k = np.flatnonzero(inside)[int(pick(v[inside]))]
        near = inside & (np.abs(s - s[k]) <= 1.5 / cells)
        c = np.polyfit(s[near], v[near], 2)
        at = -c[1] / (2.0 * c[0])
        if s[near][0] <= at <= s[near][-1]:
            ext[name] = (np.polyval(c, at), at)
        else:  # no extremum inside the fitted samples: the extreme sample itself
            ext[name] = (v[k], s[k])
    return out, ext


def main():
    runs = sys.argv[1:]
    if not runs:
        sys.exit(__doc__)
    for run in runs:
        out, ext = compare(run)
        print(f"{run}:")
        for label, (dmax, rms, at, t) in out.items():
            print(f"  {label} (t = {t:g}): max |difference| {dmax:.4f} (at {at:g}), RMS {rms:.4f} over 15 stations")
        for name, _, _, _, value, pos in EXTREMA:
            mine, at = ext[name]
            print(f"  {name} = {mine:.4f} at {at:.4f} (quoted {value:.4f} at {pos:.4f}; difference {mine - value:+.4f})")


if __name__ == "__main__":
    main()
