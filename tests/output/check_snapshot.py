#!/usr/bin/env python3
"""Checks the HDF5 snapshots of a multifield run with h5py, independently of the crate.

Usage: python3 tests/output/check_snapshot.py RUN_DIR   (RUN_DIR holds snapshots/, or is it)

Opens the newest snapshot (each rank's file of a snapshot written per rank) and checks its attributes (time, step, case, program, grid),
the shapes of every grid and point array, that no value is NaN, that θ lies in [0, 1]
and the bulk density is θ ρ⁰, the point count and body ids. Then parses the XDMF sidecar
(xml.etree) and checks that every time refers to a snapshot whose `time` attribute it
states, and that every `file.h5:/path` it references exists with the stated Dimensions
and number type. Every snapshot's `/suspension/<name>` groups (a `Suspension` monitor's
statistics and profile) must equal, bit for bit, the monitor's rows of the snapshot's step
in RUN_DIR/monitors/<name>.csv and <name>_profiles.csv (when the monitor sampled that
step). Prints a summary and exits 0, or prints every mismatch on stderr and exits 1 (2 for
bad usage).
"""

import csv
import glob
import os
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np

errors = []


def fail(message):
    errors.append(message)


def text(value):
    """An HDF5 string attribute (fixed-length ones arrive as bytes) as str."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray) and value.shape == ():
        return text(value[()])
    return str(value)


def check_snapshot(path):
    with h5py.File(path, "r") as f:
        a = f.attrs
        for key in ("time", "step", "case", "program", "units", "cells", "origin", "spacing", "fields"):
            if key not in a:
                fail(f"{path}: no root attribute `{key}`")
        if errors:
            return None
        time, step = float(a["time"]), int(a["step"])
        if not np.isfinite(time) or time < 0:
            fail(f"{path}: time = {time}")
        if not text(a["program"]).startswith("multifield "):
            fail(f"{path}: program = {text(a['program'])!r}")
        nx, ny = (int(c) for c in a["cells"])
        fields = [text(g) for g in a["fields"]]
        grid = {"pressure": (ny, nx), "velocity": (ny, nx, 3), "vorticity": (ny, nx)}
        for name, shape in grid.items():
            if name not in f:
                fail(f"{path}: no dataset /{name}")
                continue
            d = f[name]
            if d.shape != shape:
                fail(f"{path}: /{name} has shape {d.shape}, expected {shape}")
            if "units" not in d.attrs:
                fail(f"{path}: /{name} has no `units` attribute")
            if np.isnan(d[()]).any():
                fail(f"{path}: /{name} holds NaN")
        if "velocity" in f and np.any(f["velocity"][..., 2] != 0):
            fail(f"{path}: the z component of /velocity is not 0")
        points = {}
        for g in fields:
            base = f"fields/{g}"
            if base not in f:
                fail(f"{path}: no group /{base}")
                continue
            grp = f[base]
            for name, shape in (("theta", (ny, nx)), ("velocity", (ny, nx, 3)), ("vorticity", (ny, nx)),
                                ("density", (ny, nx))):
                if name not in grp or grp[name].shape != shape:
                    fail(f"{path}: /{base}/{name} missing or not of shape {shape}")
            theta = grp["theta"][()]
            if np.isnan(theta).any() or theta.min() < -1e-9 or theta.max() > 1 + 1e-9:
                fail(f"{path}: /{base}/theta outside [0, 1]: {theta.min()} .. {theta.max()}")
            rho0 = float(grp.attrs["material_density"])
            if not np.allclose(grp["density"][()], theta * rho0, rtol=1e-12, atol=0):
                fail(f"{path}: /{base}/density is not theta * material_density")
            if "points" in grp:
                p = grp["points"]
                n = int(p.attrs["count"])
                points[g] = n
                for name, shape in (("position", (n, 3)), ("velocity", (n, 3)), ("volume", (n,)),
                                    ("stress", (n, 3)), ("body", (n,))):
                    if name not in p or p[name].shape != shape:
                        fail(f"{path}: /{base}/points/{name} missing or not of shape {shape}")
                if n and (np.isnan(p["position"][()]).any() or (p["volume"][()] <= 0).any()):
                    fail(f"{path}: /{base}/points: NaN positions or non-positive volumes")
                bodies = [text(b) for b in p.attrs["bodies"]] if "bodies" in p.attrs else []
                body = p["body"][()]
                if p["body"].dtype.kind != "i" or (n and (body.min() < -1 or body.max() >= len(bodies))):
                    fail(f"{path}: /{base}/points/body not in -1 .. {len(bodies) - 1}")
        print(f"{os.path.basename(path)}: case {text(a['case'])!r}, t = {time}, step {step}, "
              f"{nx} x {ny} cells, fields {fields}, points {points}, "
              f"max |p| = {np.abs(f['pressure'][()]).max():.6g}")
        return time


def csv_rows(path):
    """The rows of a CSV file as dicts of str (None when the file is missing)."""
    if not os.path.isfile(path):
        return None
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def number(cell):
    """A CSV cell as written by multifield: a float, an empty cell for NaN."""
    return float("nan") if cell == "" else float(cell)


def same(a, b):
    """Equal floats, NaN equal to NaN (bit for bit otherwise)."""
    return (np.isnan(a) and np.isnan(b)) or a == b


def check_suspension(path, run_dir):
    """Every /suspension/<name> group of the snapshot: its shapes and attributes, and its
    values against the monitor's CSV rows of the snapshot's step (equal, bit for bit).
    Returns the number of groups checked."""
    checked = 0
    with h5py.File(path, "r") as f:
        if "suspension" not in f:
            return 0
        step = int(f.attrs["step"])
        for name, g in f["suspension"].items():
            for key in ("field", "axis", "bins", "bed_fraction", "contact_gap"):
                if key not in g.attrs:
                    fail(f"{path}: /suspension/{name} has no attribute `{key}`")
            stats, prof = g["statistics"], g["profiles"]
            columns = [text(c) for c in stats.attrs["columns"]]
            bins = int(g.attrs["bins"])
            if stats.shape != (len(columns),) or prof.shape != (bins, 4):
                fail(f"{path}: /suspension/{name}: shapes {stats.shape}, {prof.shape} for "
                     f"{len(columns)} columns and {bins} bins")
                continue
            if text(g.attrs["axis"]) not in ("X", "Y"):
                fail(f"{path}: /suspension/{name}: axis {text(g.attrs['axis'])!r}")
            rows = csv_rows(os.path.join(run_dir, "monitors", f"{name}.csv"))
            profiles = csv_rows(os.path.join(run_dir, "monitors", f"{name}_profiles.csv"))
            if rows is None or profiles is None:
                fail(f"{path}: /suspension/{name} but no monitors/{name}.csv and {name}_profiles.csv in {run_dir}")
                continue
            row = [r for r in rows if int(r["step"]) == step]
            slabs = [r for r in profiles if int(r["step"]) == step]
            if not row:
                print(f"{os.path.basename(path)}: suspension {name}: the monitor did not sample step {step} "
                      "(its schedule): not compared")
                continue
            if len(row) != 1 or len(slabs) != bins:
                fail(f"{path}: monitors/{name}.csv has {len(row)} rows and its profiles {len(slabs)} of step {step}")
                continue
            values = stats[()]
            for k, c in enumerate(columns):
                if not same(values[k], number(row[0][c])):
                    fail(f"{path}: /suspension/{name}/statistics `{c}` = {values[k]!r}, "
                         f"monitors/{name}.csv at step {step}: {row[0][c]}")
            p = prof[()]
            pcols = [text(c) for c in prof.attrs["columns"]]
            for s in slabs:
                b = int(s["bin"])
                for k, c in enumerate(pcols):
                    if not same(p[b, k], number(s[c])):
                        fail(f"{path}: /suspension/{name}/profiles[{b}] `{c}` = {p[b, k]!r}, "
                             f"monitors/{name}_profiles.csv at step {step}: {s[c]}")
            checked += 1
            print(f"{os.path.basename(path)}: suspension {name}: step {step}, {len(columns)} statistics and "
                  f"{bins} slabs equal to monitors/{name}.csv")
    return checked


NUMBER_KIND = {"Float": "f", "Int": "i", "UInt": "u"}


def check_xdmf(xdmf, folder):
    try:
        root = ET.parse(xdmf).getroot()
    except ET.ParseError as e:
        fail(f"{xdmf}: not XML: {e}")
        return 0
    temporal = [g for g in root.iter("Grid") if g.get("CollectionType") == "Temporal"]
    if len(temporal) != 1:
        fail(f"{xdmf}: {len(temporal)} temporal collections, expected 1")
        return 0
    steps = [g for g in temporal[0] if g.tag == "Grid"]
    times, files = [], {}
    for s in steps:
        t = s.find("Time")
        if t is None:
            fail(f"{xdmf}: grid {s.get('Name')!r} has no Time")
            continue
        times.append(float(t.get("Value")))
        for item in s.iter("DataItem"):
            if item.get("Format") != "HDF":
                continue
            ref = item.text.strip()
            name, _, dpath = ref.partition(":")
            full = os.path.join(folder, name)
            if not os.path.isfile(full):
                fail(f"{xdmf}: {ref}: no file {full}")
                continue
            if name not in files:
                files[name] = h5py.File(full, "r")
                if float(files[name].attrs["time"]) != times[-1]:
                    fail(f"{xdmf}: Time {times[-1]} but {name} has time {float(files[name].attrs['time'])}")
            f = files[name]
            if dpath not in f:
                fail(f"{xdmf}: {ref}: no dataset {dpath} in {name}")
                continue
            d = f[dpath]
            dims = tuple(int(x) for x in item.get("Dimensions").split())
            if dims != d.shape and dims != (1,) + d.shape:
                fail(f"{xdmf}: {ref}: Dimensions {dims}, the dataset's shape {d.shape}")
            kind = NUMBER_KIND.get(item.get("NumberType", "Float"))
            precision = int(item.get("Precision", "4"))
            if d.dtype.kind != kind or d.dtype.itemsize != precision:
                fail(f"{xdmf}: {ref}: NumberType {item.get('NumberType')} Precision {precision}, "
                     f"the dataset is {d.dtype}")
        for g in s.iter("Grid"):
            topo = g.find("Topology")
            if topo is None:
                continue
            kind = topo.get("TopologyType")
            if kind == "3DCoRectMesh":
                # the file of this grid's arrays (a rank's, for a snapshot written per rank)
                item = next((i for i in g.iter("DataItem") if i.get("Format") == "HDF"), None)
                f = files.get(item.text.strip().partition(":")[0]) if item is not None else None
                if f is not None:
                    nx, ny = (int(c) for c in f.attrs["cells"])
                    if topo.get("Dimensions") != f"2 {ny + 1} {nx + 1}":
                        fail(f"{xdmf}: mesh Dimensions {topo.get('Dimensions')}, cells {nx} x {ny}")
            elif kind == "Polyvertex":
                n = int(topo.get("NumberOfElements"))
                geometry = g.find("Geometry/DataItem")
                if geometry is not None and int(geometry.get("Dimensions").split()[0]) != n:
                    fail(f"{xdmf}: Polyvertex of {n} points, geometry {geometry.get('Dimensions')}")
            else:
                fail(f"{xdmf}: unexpected topology {kind}")
    if any(b <= a for a, b in zip(times, times[1:])):
        fail(f"{xdmf}: times not increasing: {times}")
    for f in files.values():
        f.close()
    print(f"{os.path.basename(xdmf)}: {len(steps)} times from {min(times, default=0)} to {max(times, default=0)}, "
          f"{len(files)} files")
    return len(steps)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = sys.argv[1]
    if os.path.isdir(os.path.join(folder, "snapshots")):
        folder = os.path.join(folder, "snapshots")
    # a snapshot is one file, or (written per rank by a decomposed run) a folder of the
    # ranks' files
    snapshots = sorted(glob.glob(os.path.join(folder, "snapshot_*.h5")) +
                       [d for d in glob.glob(os.path.join(folder, "snapshot_*")) if os.path.isdir(d)])
    xdmfs = glob.glob(os.path.join(folder, "*.xdmf"))
    if not snapshots:
        fail(f"{folder}: no snapshot_*.h5")
    if len(xdmfs) != 1:
        fail(f"{folder}: {len(xdmfs)} .xdmf files, expected 1")
    if not errors:
        newest = snapshots[-1]
        for f in sorted(glob.glob(os.path.join(newest, "rank_*.h5"))) if os.path.isdir(newest) else [newest]:
            check_snapshot(f)
        run_dir = os.path.dirname(os.path.abspath(folder))
        groups = sum(check_suspension(s, run_dir) for s in snapshots if not os.path.isdir(s))
        if groups:
            print(f"{groups} suspension groups equal to their monitors' CSV rows")
        listed = check_xdmf(xdmfs[0], folder)
        if listed != len(snapshots):
            fail(f"{xdmfs[0]} lists {listed} times, the folder holds {len(snapshots)} snapshots")
    for e in errors:
        print(f"error: {e}", file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
