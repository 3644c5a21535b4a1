#!/usr/bin/env python3
"""Fully developed laminar (Poiseuille) flow in a rectangular duct: the analytic series.

The streamwise velocity u(y, z) of a duct of sides a_y x a_z (walls at y = 0, a_y and
z = 0, a_z, no slip), driven along x by a uniform pressure gradient or body force
G = -dp/dx (or rho g_x), with dynamic viscosity mu, solves

    mu (u_yy + u_zz) = -G,    u = 0 on the walls.

With the half-widths h = a_y/2, k = a_z/2 and centred coordinates eta = y - h,
zeta = z - k, F. M. White, Viscous Fluid Flow (2nd ed. 1991, eq. 3-48; 3rd ed. 2006,
eq. 3-48) gives, with lambda_i = i pi / (2h), i = 1, 3, 5, ...:

    u = 16 h^2 G / (mu pi^3) sum_i (-1)^((i-1)/2) [1 - cosh(lambda_i zeta) / cosh(lambda_i k)]
                                                   cos(lambda_i eta) / i^3

    Q = 4 k h^3 G / (3 mu) [1 - 192 h / (pi^5 k) sum_i tanh(lambda_i k) / i^5]

The first part of the sum is the Fourier series of the plane-channel parabola
(h^2 - eta^2)/2, so the same velocity is evaluated here as

    u = G / (2 mu) (h^2 - eta^2)
        - 16 h^2 G / (mu pi^3) sum_i (-1)^((i-1)/2) cos(lambda_i eta) / i^3
                                     cosh(lambda_i zeta) / cosh(lambda_i k),

whose terms fall like exp(-lambda_i (k - |zeta|)) / i^3, and for each point the roles of
y and z are swapped (the formula holds either way) so that the hyperbolic decay acts
across the wider gap to the walls. The tail after the last term is bounded by
16 h^2 G/(mu pi^3) * sum_{i > N} 2 exp(-lambda_i d) / i^3 (d = k - |zeta|, since
cosh(l zeta)/cosh(l k) <= 2 exp(-l d)) and by 16 h^2 G/(mu pi^3) / (4 N^2) (the plain
1/i^3 tail, the bracket lying in [0, 1]); terms are added until the smaller bound is
below `tol` (absolute, in the units of u). The flow-rate tail is bounded by
4 k h^3 G/(3 mu) * 192 h/(pi^5 k) * sum_{i > N} 1/i^5 <= ... / (4 N^4).

Run `python3 series.py` (numpy only): prints the centre velocity and the flow rate for
a = 1, G/mu = 1 and checks them against the known square-duct coefficients, against the
direct form of eq. 3-48, and against an independent second-order finite-difference
solution extrapolated in the grid spacing.
"""

import math
import sys

import numpy as np

SQUARE_UMAX = 0.07367   # u_max mu / (G a^2), square duct (White; Shah & London 1978)
SQUARE_Q = 0.035144     # Q mu / (G a^4): f Re = 14.227 (Fanning, D_h = a) <=> Q = a^4 G / (8 mu 14.227)
SQUARE_UMAX_OVER_UMEAN = 2.0962


def _terms_needed(h, d, tol, scale):
    """Smallest odd N whose tail bound is below tol (scale = 16 h^2 G / (mu pi^3))."""
    n = 1
    while True:
        plain = scale / (4.0 * n * n)
        if d > 0.0:
            lam = math.pi / (2.0 * h)
            # sum_{i > n, odd} 2 e^{-lam i d} / i^3 <= 2 e^{-lam (n+2) d} / ((n+2)^3 (1 - e^{-2 lam d}))
            q = math.exp(-2.0 * lam * d)
            decay = scale * 2.0 * math.exp(-lam * (n + 2) * d) / ((n + 2) ** 3 * (1.0 - q))
        else:
            decay = math.inf
        if min(plain, decay) <= tol:
            return n
        n = n + 2 if n < 64 else int(n * 1.25) | 1


def velocity(y, z, a_y=1.0, a_z=None, g_over_mu=1.0, tol=1e-13):
    """u(y, z) of the duct [0, a_y] x [0, a_z] (a_z defaults to a_y), G/mu = g_over_mu.

    y, z: scalars or arrays of the same shape. Absolute truncation error <= tol (units of u).
    """
    a_z = a_y if a_z is None else a_z
    y, z = np.broadcast_arrays(np.asarray(y, float), np.asarray(z, float))
    out = np.empty(y.shape)
    for idx in np.ndindex(y.shape):
        eta, zeta = y[idx] - a_y / 2.0, z[idx] - a_z / 2.0
        h, k = a_y / 2.0, a_z / 2.0
        if abs(eta) > h or abs(zeta) > k:
            raise ValueError(f"point ({y[idx]}, {z[idx]}) outside the duct")
        # hyperbolic decay across the wider remaining gap: swap the roles of y and z if needed
        if (h - abs(eta)) > (k - abs(zeta)):
            eta, zeta, h, k = zeta, eta, k, h
        d = k - abs(zeta)
        scale = 16.0 * h * h * g_over_mu / math.pi ** 3
        n = _terms_needed(h, d, tol, scale)
        i = np.arange(1, n + 1, 2, dtype=float)
        lam = i * math.pi / (2.0 * h)
        sign = np.where(((i - 1) / 2) % 2 == 0, 1.0, -1.0)
        # cosh(lam zeta)/cosh(lam k) without overflow
        ratio = np.exp(lam * (abs(zeta) - k)) * (1.0 + np.exp(-2.0 * lam * abs(zeta))) / (1.0 + np.exp(-2.0 * lam * k))
        series = np.sum(sign * np.cos(lam * eta) / i ** 3 * ratio)
        out[idx] = 0.5 * g_over_mu * (h * h - eta * eta) - scale * series
    return out if out.shape else float(out)


def velocity_direct(y, z, a=1.0, g_over_mu=1.0, terms=4001):
    """White's eq. 3-48 summed as printed (square duct of side a), for the cross-check."""
    h = k = a / 2.0
    eta, zeta = y - h, z - k
    i = np.arange(1, terms + 1, 2, dtype=float)
    lam = i * math.pi / (2.0 * h)
    sign = np.where(((i - 1) / 2) % 2 == 0, 1.0, -1.0)
    ratio = np.exp(lam * (abs(zeta) - k)) * (1.0 + np.exp(-2.0 * lam * abs(zeta))) / (1.0 + np.exp(-2.0 * lam * k))
    return 16.0 * h * h * g_over_mu / math.pi ** 3 * np.sum(sign * (1.0 - ratio) * np.cos(lam * eta) / i ** 3)


def flow_rate(a_y=1.0, a_z=None, g_over_mu=1.0, tol=1e-15):
    """Q = integral of u over the section, White eq. 3-48; absolute truncation error <= tol."""
    a_z = a_y if a_z is None else a_z
    h, k = a_y / 2.0, a_z / 2.0
    pre = 4.0 * k * h ** 3 * g_over_mu / 3.0
    c = 192.0 * h / (math.pi ** 5 * k)
    n = 1
    while pre * c / (4.0 * n ** 4) > tol:
        n += 2
    i = np.arange(1, n + 1, 2, dtype=float)
    return pre * (1.0 - c * np.sum(np.tanh(i * math.pi * k / (2.0 * h)) / i ** 5))


def finite_difference_centre(n, a=1.0, g_over_mu=1.0):
    """Centre velocity and flow rate of the 5-point discretisation on n x n cells (n even),
    solved exactly by diagonalising the 1D operator (independent of the series)."""
    m = n - 1                                   # interior nodes per direction
    hgrid = a / n
    j = np.arange(1, m + 1)
    s = np.sqrt(2.0 / n) * np.sin(np.pi * np.outer(j, j) / n)           # orthonormal DST-I
    ev = (2.0 - 2.0 * np.cos(np.pi * j / n)) / hgrid ** 2               # eigenvalues of -d2/dx2
    f = np.full((m, m), g_over_mu)
    uhat = (s @ f @ s) / (ev[:, None] + ev[None, :])
    u = s @ uhat @ s
    q = u.sum() * hgrid ** 2                                            # trapezoid, walls are 0
    return u[m // 2, m // 2], q


def main():
    a, g_over_mu = 1.0, 1.0
    u_c = velocity(0.5, 0.5, a, g_over_mu=g_over_mu)
    q = flow_rate(a, g_over_mu=g_over_mu)
    print(f"square duct, side a = {a}, G/mu = {g_over_mu}")
    print(f"  centre velocity u_max = {u_c:.12f}   (u_max mu/(G a^2))")
    print(f"  flow rate       Q     = {q:.12f}   (Q mu/(G a^4))")
    mean = q / a**2
    print(f"  mean velocity   U     = {mean:.12f};  u_max/U = {u_c / mean:.8f}")
    for n in (16, 32, 64):
        c = (n // 2 - 0.5) / n * a
        print(f"  {n} x {n} cells: u at the 4 cell centres next to the axis, u({c:.6f}, {c:.6f}) = {velocity(c, c, a, g_over_mu=g_over_mu):.12f}")
    print(f"  f Re (D_h = a): Fanning {g_over_mu * a**2 / (2.0 * mean):.6f}, Darcy {2.0 * g_over_mu * a**2 / mean:.5f}")

    ok = True

    def check(name, value, ref, rel):
        nonlocal ok
        good = abs(value / ref - 1.0) <= rel
        ok &= good
        print(f"  [{'ok' if good else 'FAIL'}] {name}: {value:.10g} vs {ref:.10g} (rel. diff {value / ref - 1.0:+.2e}, allowed {rel:.0e})")

    print("checks:")
    check("u_max against 0.07367", u_c, SQUARE_UMAX, 1e-4)
    check("Q against 0.035144", q, SQUARE_Q, 1e-5)
    check("u_max/U against 2.0962", u_c / (q / a**2), SQUARE_UMAX_OVER_UMEAN, 1e-4)
    check("centre: rearranged series against eq. 3-48 as printed (4001 terms)", u_c, velocity_direct(0.5, 0.5), 1e-9)
    pts = [(0.1, 0.3), (0.02, 0.5), (0.25, 0.75), (0.9, 0.97)]
    for yy, zz in pts:
        check(f"u({yy}, {zz}): rearranged against eq. 3-48 as printed", velocity(yy, zz), velocity_direct(yy, zz), 1e-7)
    # flow rate from the velocity series by Gauss-Legendre quadrature (piecewise, 8 panels)
    xg, wg = np.polynomial.legendre.leggauss(12)
    edges = np.linspace(0.0, a, 9)
    nodes = np.concatenate([(e0 + e1) / 2 + (e1 - e0) / 2 * xg for e0, e1 in zip(edges[:-1], edges[1:])])
    weights = np.concatenate([(e1 - e0) / 2 * wg for e0, e1 in zip(edges[:-1], edges[1:])])
    yy, zz = np.meshgrid(nodes, nodes, indexing="ij")
    q_quad = float(np.sum(weights[:, None] * weights[None, :] * velocity(yy, zz, a, tol=1e-12)))
    check("Q: quadrature of u(y, z) against the Q series", q_quad, q, 1e-8)
    # wall values
    wall = max(abs(velocity(0.0, 0.37)), abs(velocity(0.61, 1.0)), abs(velocity(1.0, 1.0)))
    good = wall < 1e-14
    ok &= good
    print(f"  [{'ok' if good else 'FAIL'}] u on the walls: max |u| = {wall:.1e}")
    # independent: second-order finite differences, Richardson-extrapolated
    (u1, q1), (u2, q2) = finite_difference_centre(128), finite_difference_centre(256)
    check("u_max: finite differences 128^2/256^2, Richardson", (4 * u2 - u1) / 3, u_c, 1e-6)
    check("Q: finite differences 128^2/256^2, Richardson", (4 * q2 - q1) / 3, q, 1e-5)
    print("all checks passed" if ok else "SOME CHECKS FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
