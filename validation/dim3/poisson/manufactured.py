#!/usr/bin/env python3
"""Manufactured solutions of the 3D variable-coefficient Poisson problem

    -div(beta grad p) = f   on the unit cube [0, 1]^3,

for the tests of the pressure solvers (7-point cell-centred operator, MG-PCG, Jacobi-PCG,
Cholesky). See README.md beside this file for the formulas and how a test uses them.

    python3 manufactured.py              # sympy: derive and check every right-hand side
    python3 manufactured.py --discrete   # also solve each case with a numpy 7-point
                                         # operator at 16^3, 32^3, 64^3 and print the orders
                                         # (about 1.5 min on one core)

Cases (name: boundary, beta, p):
  periodic_const  periodic        1                        sin(2 pi x) cos(4 pi y) sin(2 pi z)
  periodic_var    periodic        1 + sin(2pi x) sin(2pi y) sin(2pi z)/2   (same p)
  walls_const     zero flux       1                        cos(pi x) cos(2 pi y) cos(3 pi z)
  walls_var       zero flux       1 + x y^2 z^3            (same p)
  sphere_jump     either          1000 in r < 0.3, 1 out   radial, continuous p and beta dp/dr,
                                                           p = 0 for r >= 0.45 (so both the
                                                           periodic and the wall conditions hold)
"""

import sys

import numpy as np
import sympy as sp

x, y, z, r = sp.symbols("x y z r", real=True)
pi = sp.pi

# --------------------------------------------------------------------------------------
# Smooth cases: p, beta, and f = -div(beta grad p) derived by sympy; the closed forms
# written in README.md are checked against the derivation here.
# --------------------------------------------------------------------------------------
P_PERIODIC = sp.sin(2 * pi * x) * sp.cos(4 * pi * y) * sp.sin(2 * pi * z)
P_WALLS = sp.cos(pi * x) * sp.cos(2 * pi * y) * sp.cos(3 * pi * z)
SMOOTH = {
    # name: (p, beta, boundary, closed form of f as written in the README)
    "periodic_const": (P_PERIODIC, sp.Integer(1), "periodic", 24 * pi**2 * P_PERIODIC),
    "periodic_var": (
        P_PERIODIC,
        1 + sp.sin(2 * pi * x) * sp.sin(2 * pi * y) * sp.sin(2 * pi * z) / 2,
        "periodic",
        None,
    ),
    "walls_const": (P_WALLS, sp.Integer(1), "walls", 14 * pi**2 * P_WALLS),
    "walls_var": (P_WALLS, 1 + x * y**2 * z**3, "walls", None),
}


def minus_div_beta_grad(p, beta):
    return sp.simplify(-sum(sp.diff(beta * sp.diff(p, v), v) for v in (x, y, z)))


def variable_closed_form(p, beta, f_const):
    """f = beta * f_const - grad(beta) . grad(p): the form written in the README."""
    return beta * f_const - sum(sp.diff(beta, v) * sp.diff(p, v) for v in (x, y, z))


# --------------------------------------------------------------------------------------
# The jumping coefficient: a sphere of radius R about the centre, beta_in inside, beta_out
# outside. With s = r^2 / R2^2 (R < R2 <= 1/2):
#   flux  q(r) = beta p'(r) = 8 (r / R2^2) (1 - s)^3         (r < R2; 0 beyond)
#   p(r)  = -(1 - s)^4 / beta_out                              (R <= r < R2)
#         = -(1 - s)^4 / beta_in + (1 - R^2/R2^2)^4 (1/beta_in - 1/beta_out)   (r < R)
#         = 0                                                  (r >= R2)
#   f(r)  = -(1/r^2) d/dr (r^2 q) = -(24 / R2^2) (1 - s)^2 (1 - 3 s)   (r < R2; 0 beyond)
# f does not depend on beta and is continuous; p is continuous, beta dp/dr is continuous
# at r = R, and p joins 0 at R2 with three continuous derivatives.
# --------------------------------------------------------------------------------------
JUMP = dict(centre=(0.5, 0.5, 0.5), radius=0.3, support=0.45, beta_in=1000.0, beta_out=1.0)


def jump_radial(radius, support, beta_in, beta_out):
    """Symbolic p_in(r), p_out(r), f(r) of the sphere case."""
    R, R2 = sp.nsimplify(radius), sp.nsimplify(support)
    b_in, b_out = sp.nsimplify(beta_in), sp.nsimplify(beta_out)
    s = r**2 / R2**2
    p_out = -(1 - s) ** 4 / b_out
    p_in = -(1 - s) ** 4 / b_in + (1 - R**2 / R2**2) ** 4 * (1 / b_in - 1 / b_out)
    f = -24 / R2**2 * (1 - s) ** 2 * (1 - 3 * s)
    return p_in, p_out, f, R, R2, b_in, b_out


def check_jump(radius, support, beta_in, beta_out):
    p_in, p_out, f, R, R2, b_in, b_out = jump_radial(radius, support, beta_in, beta_out)
    radial_op = lambda p, b: sp.simplify(-sp.diff(r**2 * b * sp.diff(p, r), r) / r**2)
    checks = {
        "inside: -div(beta grad p) = f": sp.simplify(radial_op(p_in, b_in) - f) == 0,
        "outside: -div(beta grad p) = f": sp.simplify(radial_op(p_out, b_out) - f) == 0,
        "p continuous at r = R": sp.simplify(p_in.subs(r, R) - p_out.subs(r, R)) == 0,
        "beta dp/dr continuous at r = R": sp.simplify((b_in * sp.diff(p_in, r) - b_out * sp.diff(p_out, r)).subs(r, R)) == 0,
        "p, p', p'', p''' = 0 at r = R2": all(sp.simplify(sp.diff(p_out, r, k).subs(r, R2)) == 0 for k in range(4)),
        "f = 0 at r = R2 (f continuous)": sp.simplify(f.subs(r, R2)) == 0,
        "integral of f over the ball R2 = 0 (compatible)": sp.simplify(sp.integrate(f * 4 * pi * r**2, (r, 0, R2))) == 0,
        "p smooth at r = 0 (even in r)": sp.simplify(p_in.subs(r, -r) - p_in) == 0,
    }
    return checks


def symbolic_checks():
    ok = True
    print("smooth cases (f = -div(beta grad p), derived by sympy):")
    for name, (p, beta, bc, closed) in SMOOTH.items():
        f = minus_div_beta_grad(p, beta)
        if closed is None:
            base = SMOOTH[name.replace("_var", "_const")][3]
            closed = variable_closed_form(p, beta, base)
        same = sp.simplify(sp.expand_trig(f - closed)) == 0
        # boundary conditions
        if bc == "periodic":
            bc_ok = all(sp.simplify(p.subs(v, 1) - p.subs(v, 0)) == 0 for v in (x, y, z)) and all(
                sp.simplify(beta.subs(v, 1) - beta.subs(v, 0)) == 0 for v in (x, y, z))
        else:
            bc_ok = all(sp.simplify(sp.diff(p, v).subs(v, e)) == 0 for v in (x, y, z) for e in (0, 1))
        mean0 = sp.simplify(sp.integrate(f, (x, 0, 1), (y, 0, 1), (z, 0, 1))) == 0
        pmean0 = sp.simplify(sp.integrate(p, (x, 0, 1), (y, 0, 1), (z, 0, 1))) == 0
        good = same and bc_ok and mean0 and pmean0
        ok &= good
        print(f"  [{'ok' if good else 'FAIL'}] {name:15s} f = {sp.simplify(f)}")
        print(f"        closed form matches: {same}; boundary condition: {bc_ok}; "
              f"mean f = 0: {mean0}; mean p = 0: {pmean0}")
    print("sphere with a jumping coefficient (radial checks):")
    for b_in in (JUMP["beta_in"], 1.0 / JUMP["beta_in"]):
        checks = check_jump(JUMP["radius"], JUMP["support"], b_in, JUMP["beta_out"])
        for what, good in checks.items():
            ok &= bool(good)
            print(f"  [{'ok' if good else 'FAIL'}] beta_in = {b_in:g}: {what}")
    return ok


# --------------------------------------------------------------------------------------
# Numerical evaluation (numpy), and an optional reference discretisation.
# --------------------------------------------------------------------------------------
def smooth_functions(name):
    p, beta, bc, _ = SMOOTH[name]
    f = minus_div_beta_grad(p, beta)
    lam = lambda e: sp.lambdify((x, y, z), e, "numpy")
    return lam(p), lam(beta), lam(f), bc


def jump_functions(radius=JUMP["radius"], support=JUMP["support"], beta_in=JUMP["beta_in"],
                   beta_out=JUMP["beta_out"], centre=JUMP["centre"]):
    p_in, p_out, f, *_ = jump_radial(radius, support, beta_in, beta_out)
    pin, pout, fr = (sp.lambdify(r, e, "numpy") for e in (p_in, p_out, f))

    def rad(X, Y, Z):
        return np.sqrt((X - centre[0]) ** 2 + (Y - centre[1]) ** 2 + (Z - centre[2]) ** 2)

    def p(X, Y, Z):
        rr = rad(X, Y, Z)
        return np.where(rr < radius, pin(rr), np.where(rr < support, pout(rr), 0.0))

    def beta(X, Y, Z):
        return np.where(rad(X, Y, Z) < radius, beta_in, beta_out)

    beta.beta_in, beta.beta_out, beta.centre, beta.radius = beta_in, beta_out, centre, radius

    def f(X, Y, Z):
        rr = rad(X, Y, Z)
        return np.where(rr < support, fr(rr), 0.0)

    return p, beta, f


def discrete_solve(n, p_fn, beta_fn, f_fn, bc, face_beta, tol=1e-11, maxit=20000):
    """Cell-centred 7-point solve of -div(beta grad p) = f on n^3 cells, Jacobi-PCG.

    face_beta: 'exact' (beta at the face centre), 'harmonic' (harmonic mean of the two
    cell-centre values) or 'segment' (harmonic mean of beta along the segment joining the
    two cell centres; the sphere case only). Walls: zero flux; periodic: wrap. Returns (errors, iterations)."""
    h = 1.0 / n
    c = (np.arange(n) + 0.5) * h
    X, Y, Z = np.meshgrid(c, c, c, indexing="ij")
    f = f_fn(X, Y, Z) * np.ones_like(X)
    exact = p_fn(X, Y, Z) * np.ones_like(X)
    bc_cell = beta_fn(X, Y, Z) * np.ones_like(X)
    faces = []  # per axis: coefficient of the face between cell i-1 and i, index i = 0..n-1 (face 0 = wrap/wall)
    for axis in range(3):
        if face_beta == "exact":
            fc = [X, Y, Z]
            fc[axis] = fc[axis] - h / 2
            b = beta_fn(*fc) * np.ones_like(X)
        elif face_beta == "segment":
            # harmonic mean of beta along the segment joining the two cell centres:
            # 1/b = theta/beta_in + (1 - theta)/beta_out, theta = the fraction of the
            # segment inside the sphere (the sphere case only; JUMP's centre and radius)
            b_in, b_out = beta_fn.beta_in, beta_fn.beta_out
            cen, rad_ = beta_fn.centre, beta_fn.radius
            lo = [X, Y, Z]
            lo = [v.copy() for v in lo]
            lo[axis] = lo[axis] - h                          # the lower cell's centre (unwrapped)
            other = [lo[a] - cen[a] for a in range(3) if a != axis]
            rho2 = other[0] ** 2 + other[1] ** 2
            half = np.sqrt(np.maximum(rad_**2 - rho2, 0.0))
            a0 = lo[axis] - cen[axis]
            inside = np.clip(np.minimum(a0 + h, half) - np.maximum(a0, -half), 0.0, h)
            theta = np.where(rho2 < rad_**2, inside / h, 0.0)
            b = 1.0 / (theta / b_in + (1.0 - theta) / b_out)
        else:
            nb = np.roll(bc_cell, 1, axis=axis)
            b = 2.0 * bc_cell * nb / (bc_cell + nb)
        if bc == "walls":
            sl = [slice(None)] * 3
            sl[axis] = 0
            b[tuple(sl)] = 0.0
        faces.append(b / h**2)

    def apply(u):
        out = np.zeros_like(u)
        for axis in range(3):
            b = faces[axis]
            flux = b * (u - np.roll(u, 1, axis=axis))           # flux through the lower face of each cell
            out += flux - np.roll(flux, -1, axis=axis)          # lower minus upper (wall faces are 0)
        return out

    diag = sum(faces[a] + np.roll(faces[a], -1, axis=a) for a in range(3))
    rhs = f - f.mean()                                          # singular: compatible right-hand side
    u = np.zeros_like(rhs)
    res = rhs - apply(u)
    zv = res / diag
    d = zv.copy()
    rz = np.vdot(res, zv)
    norm0 = np.linalg.norm(rhs)
    it = 0
    while np.linalg.norm(res) > tol * norm0 and it < maxit:
        ad = apply(d)
        alpha = rz / np.vdot(d, ad)
        u += alpha * d
        res -= alpha * ad
        res -= res.mean()
        zv = res / diag
        rz_new = np.vdot(res, zv)
        d = zv + (rz_new / rz) * d
        rz = rz_new
        it += 1
    err = (u - u.mean()) - (exact - exact.mean())
    scale = np.max(np.abs(exact - exact.mean()))
    return np.max(np.abs(err)) / scale, np.sqrt(np.mean(err**2)) / scale, it


def discrete_study(sizes=(16, 32, 64)):
    cases = [(name, *smooth_functions(name), "exact") for name in SMOOTH]
    pj, bj, fj = jump_functions()
    cases.append(("sphere_jump 1000:1", pj, bj, fj, "walls", "harmonic"))
    cases.append(("sphere_jump 1000:1", pj, bj, fj, "walls", "segment"))
    cases.append(("sphere_jump 1000:1", pj, bj, fj, "periodic", "segment"))
    pj2, bj2, fj2 = jump_functions(beta_in=1.0 / JUMP["beta_in"])
    cases.append(("sphere_jump 1:1000", pj2, bj2, fj2, "walls", "harmonic"))
    cases.append(("sphere_jump 1:1000", pj2, bj2, fj2, "walls", "segment"))
    print("\nreference 7-point discretisation (cell centres; errors relative to max|p - mean p|):")
    for name, p_fn, b_fn, f_fn, bc, fb in cases:
        rows = [discrete_solve(n, p_fn, b_fn, f_fn, bc, fb) for n in sizes]
        line = ", ".join(f"{n}^3: max {e:.3e} rms {l:.3e} ({it} it)" for n, (e, l, it) in zip(sizes, rows))
        om = [np.log2(rows[k][0] / rows[k + 1][0]) for k in range(len(rows) - 1)]
        ol = [np.log2(rows[k][1] / rows[k + 1][1]) for k in range(len(rows) - 1)]
        print(f"  {name:18s} {bc:8s} face beta {fb:8s}: {line}")
        print(f"  {'':18s} observed order max {', '.join(f'{o:.2f}' for o in om)}; rms {', '.join(f'{o:.2f}' for o in ol)}")
        sys.stdout.flush()


if __name__ == "__main__":
    ok = symbolic_checks()
    print("all symbolic checks passed" if ok else "SOME SYMBOLIC CHECKS FAILED")
    if "--discrete" in sys.argv[1:]:
        discrete_study()
    sys.exit(0 if ok else 1)
