#!/usr/bin/env python3
"""E_k(t) and epsilon(t) of multifield's Re 1600 Taylor-Green runs against the spectral reference.

For each run directory (of examples/dim3/taylor_green_re1600.ron), reads diagnostics.csv
(a row every step: `kinetic_energy` is the integral 1/2 rho |u|^2 over the cube, rho = 1;
the row of t = 0 is summary.json's `initial_kinetic_energy`),
forms the volume average E_k = kinetic_energy / (2 pi)^3 and epsilon = -dE_k/dt by centred
differences on the steps' (non-uniform) times (numpy.gradient, second order), writes
`energy.csv` (t, kinetic_energy, dissipation_rate) into the run directory, and prints the
epsilon peak (the largest sample, and the vertex of the parabola through it and its two
neighbours), E_k(9) and E_k(10) (linear interpolation) beside the published values of the
512^3 spectral reference (README.md): peak 0.012858 at t = 8.97, E_k(9) = 0.08640,
E_k(10) = 0.07448. When spectral_re1600_512.csv is present in this folder (it is not
shipped), also the relative L2 misfits of E_k and epsilon over the run.

    python3 validation/dim3/taylor_green_re1600/dissipation.py RUN_DIR [RUN_DIR ...]
"""

import json
import math
import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
VOLUME = (2.0 * math.pi) ** 3
PEAK, PEAK_T, EK9, EK10 = 0.012858, 8.97, 0.08640, 0.07448


def history(run):
    """t, E_k (volume average) from a run's diagnostics.csv."""
    path = pathlib.Path(run) / "diagnostics.csv"
    with open(path) as f:
        names = f.readline().strip().split(",")
    data = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=(names.index("time"), names.index("kinetic_energy")))
    t, ek = data[:, 0], data[:, 1] / VOLUME
    # diagnostics.csv starts after the first step: the initial energy is in summary.json
    summary = pathlib.Path(run) / "summary.json"
    if summary.exists() and t[0] > 0.0:
        t, ek = np.r_[0.0, t], np.r_[json.loads(summary.read_text())["initial_kinetic_energy"] / VOLUME, ek]
    # a restarted run may repeat rows: keep the times in increasing order, each once
    t, first = np.unique(t, return_index=True)
    return t, ek[first]


def peak(t, eps):
    """The largest sample of eps and the vertex of the parabola through it and its neighbours."""
    i = int(np.argmax(eps))
    if 0 < i < len(t) - 1:
        c = np.polyfit(t[i - 1 : i + 2], eps[i - 1 : i + 2], 2)
        tv = -c[1] / (2.0 * c[0])
        return i, tv, np.polyval(c, tv)
    return i, t[i], eps[i]


def main():
    runs = sys.argv[1:]
    if not runs:
        sys.exit(__doc__)
    ref_path = HERE / "spectral_re1600_512.csv"
    ref = np.loadtxt(ref_path, delimiter=",", skiprows=1) if ref_path.exists() else None
    print(f"reference (512^3 spectral): eps peak {PEAK:.6f} at t = {PEAK_T:.2f}, E_k(9) = {EK9:.5f}, E_k(10) = {EK10:.5f}")
    for run in runs:
        t, ek = history(run)
        eps = -np.gradient(ek, t)
        np.savetxt(pathlib.Path(run) / "energy.csv", np.column_stack([t, ek, eps]), delimiter=",",
                   header="t,kinetic_energy,dissipation_rate", comments="", fmt="%.10g")
        i, tv, ev = peak(t, eps)
        print(f"{run}: {len(t)} samples, t = {t[0]:g} .. {t[-1]:g}, E_k(0) = {ek[0]:.9f}")
        print(f"  eps peak {eps[i]:.6f} at t = {t[i]:.3f} (parabola {ev:.6f} at {tv:.3f}): "
              f"{ev / PEAK - 1:+.2%}, time {tv - PEAK_T:+.3f}")
        for when, value in ((9.0, EK9), (10.0, EK10)):
            if t[-1] >= when - 1e-9:
                mine = np.interp(when, t, ek)
                print(f"  E_k({when:g}) = {mine:.5f} ({mine / value - 1:+.2%} against {value:.5f})")
        if ref is not None:
            window = (t >= ref[0, 0]) & (t <= min(t[-1], ref[-1, 0]))
            for name, k, mine in (("E_k", 1, ek), ("eps", 2, eps)):
                r = np.interp(t[window], ref[:, 0], ref[:, k])
                misfit = np.sqrt(np.sum((mine[window] - r) ** 2) / np.sum(r**2))
                print(f"  relative L2 misfit of {name} over [{t[window][0]:g}, {t[window][-1]:g}]: {misfit:.3%}")


if __name__ == "__main__":
    main()
