#!/usr/bin/env python3
"""E_k(t) and epsilon(t) of the OpenFOAM Taylor-Green run, against the spectral reference.

Reads postProcessing/energy/0/volFieldValue.dat (volume averages of magSqr(U) and of the
enstrophy 0.5|curl U|^2, every time step; E_k(0) = 1/8 prepended), writes energy.csv (t, kinetic_energy,
dissipation_rate = -dE_k/dt by centred differences, enstrophy, 2 nu enstrophy) and prints
the epsilon peak and the misfits against spectral_re1600_512.csv (in the folder above
this one) when that file is
present. Run from anywhere: python3 energy.py [case directory]
"""

import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
NU = 1.0 / 1600.0


def read_volfieldvalue(path):
    names, rows = None, []
    for line in path.read_text().splitlines():
        if line.startswith("#"):
            words = line.lstrip("#").split()
            if words and words[0] == "Time":
                names = words
            continue
        if line.strip():
            rows.append([float(w) for w in line.split()])
    data = np.array(rows)
    # a restarted run appends: keep the last value of each time
    _, last = np.unique(data[::-1, 0], return_index=True)
    data = data[::-1][last]
    return names, data


def main():
    case = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else HERE
    files = sorted(case.glob("postProcessing/energy/*/volFieldValue.dat"))
    if not files:
        sys.exit(f"no postProcessing/energy/*/volFieldValue.dat under {case}")
    names, data = read_volfieldvalue(files[-1])
    col = {n: i for i, n in enumerate(names or [])}
    t = data[:, 0]
    ek = 0.5 * data[:, col.get("volAverage(magSqrU)", 1)]
    ens = data[:, col.get("volAverage(enstrophy)", 2)]
    if t[0] > 0.0:
        # the function objects run after each step, not at t = 0: the initial state's E_k is
        # the mean of 1/2 |u|^2 at the cell centres, 1/8 exactly (initial_fields.py prints it);
        # its enstrophy is left unknown
        t, ek, ens = np.r_[0.0, t], np.r_[0.125, ek], np.r_[np.nan, ens]
    eps = -np.gradient(ek, t)
    np.savetxt(case / "energy.csv", np.column_stack([t, ek, eps, ens, 2 * NU * ens]), delimiter=",",
               header="t,kinetic_energy,dissipation_rate,enstrophy,two_nu_enstrophy", comments="", fmt="%.10g")
    i = int(np.argmax(eps))
    print(f"{len(t)} samples, t = {t[0]:g} .. {t[-1]:g}; E_k(0) = {ek[0]:.6f}; "
          f"epsilon peak {eps[i]:.6f} at t = {t[i]:.3f} (2 nu zeta there {2 * NU * ens[i]:.6f})")
    # the published scalars of the reference (../README.md)
    print(f"reference: epsilon peak 0.012858 at t = 8.97: peak value {eps[i] / 0.012858 - 1:+.2%}, time {t[i] - 8.97:+.3f}")
    for when, value in ((9.0, 0.08640), (10.0, 0.07448)):
        if t[-1] >= when - 1e-9:
            mine = np.interp(when, t, ek)
            print(f"E_k({when:g}) = {mine:.5f} ({mine / value - 1:+.2%} against {value:.5f})")
    ref_path = HERE.parent / "spectral_re1600_512.csv"
    if not ref_path.exists():
        print(f"reference {ref_path.name} not present: no comparison")
        return
    ref = np.loadtxt(ref_path, delimiter=",", skiprows=1)
    j = int(np.argmax(ref[:, 2]))
    print(f"reference epsilon peak {ref[j, 2]:.6f} at t = {ref[j, 0]:.2f}: "
          f"peak value {eps[i] / ref[j, 2] - 1:+.2%}, time {t[i] - ref[j, 0]:+.3f}")
    window = (t >= ref[0, 0]) & (t <= min(t[-1], ref[-1, 0]))
    for name, k, mine in (("E_k", 1, ek), ("epsilon", 2, eps)):
        r = np.interp(t[window], ref[:, 0], ref[:, k])
        misfit = np.sqrt(np.sum((mine[window] - r) ** 2) / np.sum(r**2))
        print(f"relative L2 misfit of {name} over t in [{t[window][0]:g}, {t[window][-1]:g}]: {misfit:.3%}")


if __name__ == "__main__":
    main()
