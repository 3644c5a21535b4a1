# The steady drag of the mapped 16- and 32-cell runs of docs/validation.md ("32 cells per
# diameter, started from a coarser run"), estimated from their bodies.csv:
#   python3 validation/cylinder_stream/steady_drag.py re20_16 re20_32
# (run directories). (a) the 16-cell run's geometric (Aitken) fit over values 2 time units
# apart, plus the 32-cell run's difference to the 16-cell run at its last time (linear
# between the 16-cell rows); (b) the 32-cell run's own fit over values 1 time unit apart.
import sys
import numpy as np

def load(run):
    d = np.loadtxt(f"{run}/bodies.csv", delimiter=",", skiprows=1, usecols=(1, 8))
    d = d[d[:, 0] > 0]
    return d[:, 0], 2 * d[:, 1]

def aitken(t, f, span):
    a, b, c = np.interp(t[-1] - 2 * span, t, f), np.interp(t[-1] - span, t, f), f[-1]
    r = (c - b) / (b - a)
    return c + (c - b) * r / (1 - r), r

t16, f16 = load(sys.argv[1])
t32, f32 = load(sys.argv[2])
a16, r16 = aitken(t16, f16, 2.0)
a32, r32 = aitken(t32, f32, 1.0)
d = f32[-1] - np.interp(t32[-1], t16, f16)
print(f"16: last C_D {f16[-1]:.5f} at t = {t16[-1]:.2f}, steady {a16:.5f} (ratio {r16:.2f} per 2 time units)")
print(f"32: last C_D {f32[-1]:.5f} at t = {t32[-1]:.2f}; (a) {a16 + d:.5f} (difference {d:+.5f}); "
      f"(b) {a32:.5f} (ratio {r32:.2f} per time unit)")
