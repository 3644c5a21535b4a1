# usage: python3 validation/cylinder_stream/recirculation_length.py <run>/snapshots/snapshot_NNNNNN.h5 ...
# L/D from a snapshot: the centre-line velocity behind the cylinder (mean of the two rows of
# cells beside y = 20), where it turns positive, less the radius; linear between cells.
import sys, h5py, numpy as np
for path in sys.argv[1:]:
    f = h5py.File(path, "r")
    nx, ny = f.attrs["cells"]; h = f.attrs["spacing"]; ox, oy = f.attrs["origin"]
    u = f["fields/water/velocity"][:, :, 0]
    j = int(round((20.0 - oy) / h))  # rows j-1 and j beside y = 20
    line = 0.5 * (u[j - 1, :] + u[j, :])
    x = ox + (np.arange(nx) + 0.5) * h
    i = np.searchsorted(x, 15.5)
    while line[i] >= 0: i += 1  # into the recirculation
    while line[i] < 0: i += 1
    xr = x[i - 1] + (0 - line[i - 1]) * h / (line[i] - line[i - 1])
    print(f"{path}: t = {f.attrs['time']:.3f}, L/D = {xr - 15.5:.4f}")
