#!/usr/bin/env python3
"""Write 0/U and 0/p of the Re 1600 Taylor-Green case (numpy only).

    u =  sin x cos y cos z,   v = -cos x sin y cos z,   w = 0,
    p = (cos 2x + cos 2y)(cos 2z + 2) / 16          (kinematic: p/rho, V0 = L = 1)

at the cell centres of blockMesh's single 64^3 block on [0, 2 pi]^3 (cells numbered x
fastest, then y, then z), as nonuniform internalFields in the templates of 0.orig/.
Run from the case directory after blockMesh: python3 initial_fields.py [N]
"""

import math
import pathlib
import re
import sys

import numpy as np

CASE = pathlib.Path(__file__).resolve().parent


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    h = 2.0 * math.pi / n
    c = (np.arange(n) + 0.5) * h
    z, y, x = np.meshgrid(c, c, c, indexing="ij")   # x varies fastest in C order
    x, y, z = x.ravel(), y.ravel(), z.ravel()
    u = np.sin(x) * np.cos(y) * np.cos(z)
    v = -np.cos(x) * np.sin(y) * np.cos(z)
    p = (np.cos(2 * x) + np.cos(2 * y)) * (np.cos(2 * z) + 2.0) / 16.0

    out = CASE / "0"
    out.mkdir(exist_ok=True)
    vec = "\n".join(f"({a:.17g} {b:.17g} 0)" for a, b in zip(u, v))
    sca = "\n".join(f"{a:.17g}" for a in p)
    for name, kind, body in (("U", "vector", vec), ("p", "scalar", sca)):
        text = (CASE / "0.orig" / name).read_text()
        field = f"internalField   nonuniform List<{kind}>\n{n**3}\n(\n{body}\n)\n;"
        text, count = re.subn(r"internalField\s+uniform[^;]*;", lambda _: field, text)
        assert count == 1, f"0.orig/{name}: no uniform internalField to replace"
        (out / name).write_text(text)
    print(f"0/U, 0/p: {n}^3 cells; mean 0.5|u|^2 = {0.5 * np.mean(u * u + v * v):.15f} (exact 0.125)")


if __name__ == "__main__":
    main()
