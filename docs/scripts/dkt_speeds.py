#!/usr/bin/env python3
"""Settling speeds of finished Uhlmann-scene runs against Uhlmann (2005) fig. 6b.

For each run directory (its bodies.csv, bodies named "leading" and "trailing"), prints the
relative difference of each disk's settling speed from Uhlmann's at t = 0.05, 0.10 and
0.15 s (both curves linearly interpolated), the trailing/leading speed ratio at 0.15 s
(Uhlmann: 1.447) and the gap along gravity at 0.16 and 0.17 s in diameters (Uhlmann:
1.24 d and 1.01 d). The table of docs/validation.md comes from

    python3 docs/scripts/dkt_speeds.py runs/uhlmann_d8 runs/uhlmann_d12 ...

The reference curves are the repository's validation/reference/dkt-uhlmann2005 (found from
this script's own location, whatever the working directory); set DKT_REFERENCE to a folder
laid out the same way to use others.
"""

import bisect
import csv
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REF = Path(os.environ.get("DKT_REFERENCE", ROOT / "validation/reference/dkt-uhlmann2005"))
D = 0.25


def interp(ts, vs, t):
    i = bisect.bisect_left(ts, t)
    if i == 0:
        return vs[0]
    if i >= len(ts):
        return vs[-1]
    a = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
    return vs[i - 1] + a * (vs[i] - vs[i - 1])


def reference(which):
    rows = sorted(tuple(map(float, line.split())) for line in open(REF / f"Uhlmann2005-fig6b-{which}-particle.csv") if line.strip())
    return [r[0] for r in rows], [abs(r[1]) for r in rows]


def main(dirs):
    if not dirs:
        sys.exit(__doc__)
    for d in dirs:
        tracks = {}
        for r in csv.DictReader(open(Path(d) / "bodies.csv")):
            tracks.setdefault(r["body"], []).append((float(r["time"]), float(r["y"]), -float(r["vy"])))
        for name in ("leading", "trailing"):
            if name not in tracks:
                sys.exit(f"{d}/bodies.csv: no body named {name!r} (found {sorted(tracks)})")
        col = lambda b, k: [row[k] for row in tracks[b]]
        ts = col("leading", 0)
        cells = []
        for t in (0.05, 0.10, 0.15):
            diffs = []
            for b in ("leading", "trailing"):
                rt, rv = reference(b)
                u, ur = interp(ts, col(b, 2), t), interp(rt, rv, t)
                diffs.append(f"{100 * (u - ur) / ur:+.1f} %")
            cells.append(f"t = {t:.2f} s: " + ", ".join(diffs))
        gap = lambda t: (interp(ts, col("trailing", 1), t) - interp(ts, col("leading", 1), t)) / D
        ratio = interp(ts, col("trailing", 2), 0.15) / interp(ts, col("leading", 2), 0.15)
        print(f"{d}: " + " | ".join(cells) + f" | ratio at 0.15 s {ratio:.3f} | gap {gap(0.16):.2f} d, {gap(0.17):.2f} d")


if __name__ == "__main__":
    main(sys.argv[1:])
