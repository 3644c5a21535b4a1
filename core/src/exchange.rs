//! The implicit momentum exchange at one location (docs/method.md §3 step 4).
//!
//! Solves `(D + Δt L) ū = D u*` with `D = diag(ρ_k)` (bulk densities) and `L` the graph
//! Laplacian with weights `θ_k θ_n K_kn`, and `(D + Δt L) w = θ` for the effective specific
//! volumes. No-slip pairs (K = ∞) are merged first into one mass-weighted velocity, exactly.
//! The velocities are weighted with the masses the frames put on the grid (momentum is
//! conserved exactly); `w` uses the bulk densities θρ⁰ of the same θ the pressure equation
//! sees, so that a uniform mixture is exactly hydrostatic whatever the kernel masses.
//! The solve conserves momentum Σ ρ_k u_k to round-off and is stable for any Δt.

use crate::case::MAX_FIELDS;
use crate::math::Real;

/// Largest Δt·θK/ρ kept in the dense solve: beyond it digits are lost (docs/method.md §3 step 4).
pub const STIFFNESS_CLAMP: Real = 1e8;

/// One location's data for N fields.
#[derive(Clone, Copy, Debug)]
pub struct Local {
    /// Number of fields.
    pub n: usize,
    /// Grid mass per volume of each field (0 where absent): weights of the velocities.
    pub rho: [Real; MAX_FIELDS],
    /// Bulk density θρ⁰ of each field: the diagonal of the solve for w.
    pub rho_w: [Real; MAX_FIELDS],
    /// Volume fraction of each field.
    pub theta: [Real; MAX_FIELDS],
    /// Material density of each field (for w where a field is absent).
    pub material_density: [Real; MAX_FIELDS],
    /// Velocity component of each field; replaced by ū.
    pub u: [Real; MAX_FIELDS],
    /// Velocity component of each field at the start of the step (for added mass).
    pub u_old: [Real; MAX_FIELDS],
    /// Effective specific volume of each field (output).
    pub w: [Real; MAX_FIELDS],
}

impl Local {
    /// `n` fields, all absent (mass 0, material density 1) and at rest.
    pub fn empty(n: usize) -> Self {
        Local {
            n,
            rho: [0.0; MAX_FIELDS],
            rho_w: [0.0; MAX_FIELDS],
            theta: [0.0; MAX_FIELDS],
            material_density: [1.0; MAX_FIELDS],
            u: [0.0; MAX_FIELDS],
            u_old: [0.0; MAX_FIELDS],
            w: [0.0; MAX_FIELDS],
        }
    }
}

/// Couplings at one location: `k[a][b]` is K (∞ for no-slip, 0 for none).
pub type Coefficients = [[Real; MAX_FIELDS]; MAX_FIELDS];

/// Solves the exchange at one location in place.
pub fn solve(loc: &mut Local, k: &Coefficients, dt: Real) {
    solve_with_added_mass(loc, k, &[[0.0; MAX_FIELDS]; MAX_FIELDS], dt);
}

/// Solves the exchange with added mass at one location in place.
///
/// `added[a][b]` = a_ab (mass/volume, e.g. C_A ρ_f θ_s) adds the force
/// a_ab (Δu_b − Δu_a)/Δt on field a (and its opposite on b), Δu the change of a velocity
/// over the step (from `u_old`): the fluid that a particle accelerates. It enters the
/// matrix, `(D + A + Δt L) ū = D u* + A u_old`, and the pressure response,
/// `(D + A + Δt L) w = θ`, so it is implicit: a particle barely heavier than the fluid
/// released from rest accelerates at (ρ_s − ρ_f) g / (ρ_s + C_A ρ_f), at any Δt.
/// Momentum is still conserved (A's rows sum to zero).
pub fn solve_with_added_mass(loc: &mut Local, k: &Coefficients, added: &Coefficients, dt: Real) {
    let n = loc.n;
    // absent fields take no part: keep u*, w = 1/ρ⁰
    let present: [bool; MAX_FIELDS] = std::array::from_fn(|i| i < n && loc.rho[i] > 1e-10 * loc.material_density[i]);
    // no field or one alone (most of a domain with bodies): nothing to exchange
    if present.iter().filter(|&&p| p).count() <= 1 {
        let l = &mut *loc;
        for (i, w) in l.w.iter_mut().enumerate().take(n) {
            *w = if present[i] && l.rho_w[i] > 0.0 {
                l.theta[i] / l.rho_w[i]
            } else if present[i] {
                l.theta[i] / l.rho[i]
            } else {
                1.0 / l.material_density[i]
            };
        }
        return;
    }
    // clusters of no-slip pairs (union–find on at most 8 entries)
    let mut parent: [usize; MAX_FIELDS] = std::array::from_fn(|i| i);
    fn root(p: &mut [usize; MAX_FIELDS], mut i: usize) -> usize {
        while p[i] != i {
            i = p[i];
        }
        i
    }
    for a in 0..n {
        for b in (a + 1)..n {
            if present[a] && present[b] && k[a][b].is_infinite() {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                if ra != rb {
                    parent[rb] = ra;
                }
            }
        }
    }
    // cluster index of each present field
    let mut cluster = [usize::MAX; MAX_FIELDS];
    let mut m = 0;
    let mut rep = [0usize; MAX_FIELDS];
    for i in 0..n {
        if !present[i] {
            continue;
        }
        let r = root(&mut parent, i);
        if cluster[r] == usize::MAX {
            cluster[r] = m;
            rep[m] = r;
            m += 1;
        }
        cluster[i] = cluster[r];
    }
    let mut big_r = [0.0; MAX_FIELDS];
    let mut big_t = [0.0; MAX_FIELDS];
    let mut big_p = [0.0; MAX_FIELDS];
    let mut big_rw = [0.0; MAX_FIELDS];
    for i in 0..n {
        if present[i] {
            let c = cluster[i];
            big_rw[c] += loc.rho_w[i];
            big_r[c] += loc.rho[i];
            big_t[c] += loc.theta[i];
            big_p[c] += loc.rho[i] * loc.u[i];
        }
    }
    // matrix (D + Δt L) on clusters
    let mut a = [[0.0; MAX_FIELDS]; MAX_FIELDS];
    for c in 0..m {
        a[c][c] = big_r[c];
    }
    for i in 0..n {
        for j in (i + 1)..n {
            if !(present[i] && present[j]) || k[i][j] == 0.0 || k[i][j].is_infinite() {
                continue;
            }
            let (ci, cj) = (cluster[i], cluster[j]);
            if ci == cj {
                continue;
            }
            let limit = STIFFNESS_CLAMP * big_r[ci].min(big_r[cj]);
            let wgt = (dt * loc.theta[i] * loc.theta[j] * k[i][j]).min(limit);
            a[ci][ci] += wgt;
            a[cj][cj] += wgt;
            a[ci][cj] -= wgt;
            a[cj][ci] -= wgt;
        }
    }
    for i in 0..n {
        for j in (i + 1)..n {
            let am = added[i][j];
            if !(present[i] && present[j]) || am == 0.0 {
                continue;
            }
            let (ci, cj) = (cluster[i], cluster[j]);
            if ci == cj {
                continue;
            }
            a[ci][ci] += am;
            a[cj][cj] += am;
            a[ci][cj] -= am;
            a[cj][ci] -= am;
            let rel = am * (loc.u_old[i] - loc.u_old[j]);
            big_p[ci] += rel;
            big_p[cj] -= rel;
        }
    }
    let (ubar, wbar) = if m == 1 {
        let rw = if big_rw[0] > 0.0 { big_rw[0] } else { big_r[0] };
        ([big_p[0] / big_r[0]; MAX_FIELDS], [big_t[0] / rw; MAX_FIELDS])
    } else {
        let ubar = solve_dense(&a, &big_p, m);
        for c in 0..m {
            let rw = if big_rw[c] > 0.0 { big_rw[c] } else { big_r[c] };
            a[c][c] += rw - big_r[c];
        }
        (ubar, solve_dense(&a, &big_t, m))
    };
    let _ = rep;
    for i in 0..n {
        if present[i] {
            loc.u[i] = ubar[cluster[i]];
            loc.w[i] = wbar[cluster[i]];
        } else {
            loc.w[i] = 1.0 / loc.material_density[i];
        }
    }
}

/// One face's data for exactly two fields (the case of a fluid and one dispersed field):
/// what [`Local`] holds, without its room for [`MAX_FIELDS`].
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    /// Grid mass per volume of each field.
    pub rho: [Real; 2],
    /// Bulk density θρ⁰ of each field.
    pub rho_w: [Real; 2],
    /// Volume fraction of each field.
    pub theta: [Real; 2],
    /// Material density of each field.
    pub material_density: [Real; 2],
    /// Velocity component of each field (u*).
    pub u: [Real; 2],
    /// Velocity component of each field at the start of the step.
    pub u_old: [Real; 2],
}

/// [`solve_with_added_mass`] for two fields, with the implicit coupling `k` (K, ∞ for
/// no-slip, 0 for none) and the added mass `added` (a₀₁) between them: returns the new
/// velocities and the specific volumes. The same operations in the same order, so the
/// result is bit-identical to the general solve; without its per-location 8 × 8 arrays it
/// is several times cheaper (the exchange of a fluid and mass points on every face).
pub fn solve_pair(p: &Pair, k: Real, added: Real, dt: Real) -> ([Real; 2], [Real; 2]) {
    let present = [p.rho[0] > 1e-10 * p.material_density[0], p.rho[1] > 1e-10 * p.material_density[1]];
    if !(present[0] && present[1]) {
        let w = std::array::from_fn(|i| {
            if present[i] && p.rho_w[i] > 0.0 {
                p.theta[i] / p.rho_w[i]
            } else if present[i] {
                p.theta[i] / p.rho[i]
            } else {
                1.0 / p.material_density[i]
            }
        });
        return (p.u, w);
    }
    // the sums start from 0.0 as the general solve's do (0.0 + (−0.0) is +0.0)
    let r = [0.0 + p.rho[0], 0.0 + p.rho[1]];
    let mut mom = [0.0 + p.rho[0] * p.u[0], 0.0 + p.rho[1] * p.u[1]];
    let rw = [0.0 + p.rho_w[0], 0.0 + p.rho_w[1]];
    let t = [0.0 + p.theta[0], 0.0 + p.theta[1]];
    if k.is_infinite() {
        // no-slip: one cluster, the mass-weighted velocity
        let (big_r, big_t, big_p, big_rw) =
            (r[0] + p.rho[1], t[0] + p.theta[1], mom[0] + p.rho[1] * p.u[1], rw[0] + p.rho_w[1]);
        let rw = if big_rw > 0.0 { big_rw } else { big_r };
        let (u, w) = (big_p / big_r, big_t / rw);
        return ([u; 2], [w; 2]);
    }
    let mut a = [[r[0], 0.0], [0.0, r[1]]];
    if k != 0.0 {
        let limit = STIFFNESS_CLAMP * r[0].min(r[1]);
        let wgt = (dt * p.theta[0] * p.theta[1] * k).min(limit);
        a[0][0] += wgt;
        a[1][1] += wgt;
        a[0][1] -= wgt;
        a[1][0] -= wgt;
    }
    if added != 0.0 {
        a[0][0] += added;
        a[1][1] += added;
        a[0][1] -= added;
        a[1][0] -= added;
        let rel = added * (p.u_old[0] - p.u_old[1]);
        mom[0] += rel;
        mom[1] -= rel;
    }
    let u = solve_dense2(a, mom);
    for c in 0..2 {
        let rwc = if rw[c] > 0.0 { rw[c] } else { r[c] };
        a[c][c] += rwc - r[c];
    }
    (u, solve_dense2(a, t))
}

/// [`solve_dense`] for m = 2, operation for operation (the same pivot, ties to the last row).
fn solve_dense2(mut a: [[Real; 2]; 2], mut x: [Real; 2]) -> [Real; 2] {
    if a[1][0].abs().total_cmp(&a[0][0].abs()) != std::cmp::Ordering::Less {
        a.swap(0, 1);
        x.swap(0, 1);
    }
    let f = a[1][0] / a[0][0];
    if f != 0.0 {
        a[1][1] -= f * a[0][1];
        x[1] -= f * x[0];
    }
    x[1] /= a[1][1];
    x[0] -= a[0][1] * x[1];
    x[0] /= a[0][0];
    x
}

/// Solves A x = b (m ≤ 8) by Gaussian elimination with partial pivoting.
fn solve_dense(a: &[[Real; MAX_FIELDS]; MAX_FIELDS], b: &[Real; MAX_FIELDS], m: usize) -> [Real; MAX_FIELDS] {
    let mut a = *a;
    let mut x = *b;
    for col in 0..m {
        let piv = (col..m).max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs())).unwrap_or(col);
        a.swap(col, piv);
        x.swap(col, piv);
        let d = a[col][col];
        for row in (col + 1)..m {
            let f = a[row][col] / d;
            if f != 0.0 {
                let pivot_row = a[col];
                for (v, p) in a[row][col..m].iter_mut().zip(&pivot_row[col..m]) {
                    *v -= f * p;
                }
                x[row] -= f * x[col];
            }
        }
    }
    for row in (0..m).rev() {
        for c in (row + 1)..m {
            x[row] -= a[row][c] * x[c];
        }
        x[row] /= a[row][row];
    }
    x
}

/// Forward-Euler exchange from the provisional velocities (for stability studies):
/// `u_k += Δt Σ_n θ_k θ_n K_kn (u_n − u_k) / ρ_k`.
pub fn explicit(loc: &mut Local, k: &Coefficients, dt: Real) {
    let n = loc.n;
    let u0 = loc.u;
    for i in 0..n {
        if loc.rho[i] <= 1e-10 * loc.material_density[i] {
            continue;
        }
        let mut du = 0.0;
        for j in 0..n {
            if j != i && k[i][j] > 0.0 && k[i][j].is_finite() {
                du += loc.theta[i] * loc.theta[j] * k[i][j] * (u0[j] - u0[i]);
            }
        }
        loc.u[i] += dt * du / loc.rho[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn local(rho: &[Real], theta: &[Real], u: &[Real]) -> Local {
        let mut l = Local::empty(rho.len());
        for i in 0..rho.len() {
            l.rho[i] = rho[i];
            l.rho_w[i] = rho[i];
            l.theta[i] = theta[i];
            l.u[i] = u[i];
            l.material_density[i] = rho[i] / theta[i];
        }
        l
    }

    #[test]
    fn two_fields_match_closed_form_and_conserve_momentum() {
        // ρ1 ū1 + ρ2 ū2 conserved; relative velocity decays by 1/(1 + Δt θ1θ2K(1/ρ1 + 1/ρ2))
        let mut l = local(&[0.3, 0.7], &[0.3, 0.7], &[1.0, -2.0]);
        let mut k = [[0.0; MAX_FIELDS]; MAX_FIELDS];
        k[0][1] = 50.0;
        k[1][0] = 50.0;
        let dt = 0.1;
        let p0 = 0.3 * 1.0 + 0.7 * -2.0;
        solve(&mut l, &k, dt);
        let p1 = 0.3 * l.u[0] + 0.7 * l.u[1];
        assert!((p1 - p0).abs() < 1e-15);
        let factor = 1.0 / (1.0 + dt * 0.21 * 50.0 * (1.0 / 0.3 + 1.0 / 0.7));
        assert!(((l.u[0] - l.u[1]) - 3.0 * factor).abs() < 1e-14);
        // K = 0 limit of w is 1/ρ⁰ = 1 here; with coupling w lies between
        assert!(l.w[0] > 0.0 && l.w[1] > 0.0);
    }

    #[test]
    fn added_mass_gives_the_release_acceleration_and_conserves_momentum() {
        // fluid (θ 0.99, ρ⁰ 1) and particles (θ 0.01, ρ⁰ 1.01) at rest; a unit pressure
        // gradient pushes each by −Δt w ∇p. Buoyant weight against the fluid: the particle's
        // relative acceleration is (ρ_s − ρ_f) g/(ρ_s + C_A ρ_f θ_f/…) — here checked
        // against the 2×2 system solved by hand.
        let (tf, ts, rf, rs, ca) = (0.99, 0.01, 1.0, 1.01, 1.0);
        let mut l = local(&[tf * rf, ts * rs], &[tf, ts], &[0.0, 0.0]);
        let k = [[0.0; MAX_FIELDS]; MAX_FIELDS];
        let mut a = [[0.0; MAX_FIELDS]; MAX_FIELDS];
        let am = ca * rf * ts;
        a[0][1] = am;
        a[1][0] = am;
        // u* = u_old + Δt g for both (gravity), so the added mass sees no relative change
        let (dt, g) = (0.01, -981.0);
        l.u_old = [0.0; MAX_FIELDS];
        l.u[0] = dt * g;
        l.u[1] = dt * g;
        solve_with_added_mass(&mut l, &k, &a, dt);
        assert!((l.u[0] - dt * g).abs() < 1e-14 && (l.u[1] - dt * g).abs() < 1e-14);
        // w solves [[ρf θf + a, −a], [−a, ρs θs + a]] w = θ
        let (m11, m12, m22) = (rf * tf + am, -am, rs * ts + am);
        let det = m11 * m22 - m12 * m12;
        let w0 = (m22 * tf - m12 * ts) / det;
        let w1 = (m11 * ts - m12 * tf) / det;
        assert!((l.w[0] - w0).abs() < 1e-14 && (l.w[1] - w1).abs() < 1e-14);
        // hydrostatic ∇p = ρ_f g: the particle's acceleration g (1 − w_s ρ_f) tends to the
        // added-mass value (ρ_s − ρ_f) g/(ρ_s + C_A ρ_f) as θ_s → 0
        let acc = g * (1.0 - l.w[1] * rf);
        let exact = (rs - rf) * g / (rs + ca * rf);
        assert!((acc - exact).abs() < 0.02 * exact.abs(), "{acc} vs {exact}");
        // without added mass it is (ρ_s − ρ_f) g/ρ_s, twice as large at ρ_s ≈ ρ_f
        let mut l2 = local(&[tf * rf, ts * rs], &[tf, ts], &[0.0, 0.0]);
        solve(&mut l2, &k, dt);
        let acc2 = g * (1.0 - l2.w[1] * rf);
        assert!((acc2 - (rs - rf) * g / rs).abs() < 1e-12 * g.abs());
        // momentum: a relative velocity at the start is exchanged, Σρu conserved
        let mut l3 = local(&[tf * rf, ts * rs], &[tf, ts], &[0.0, 0.0]);
        l3.u_old[1] = 1.0;
        l3.u[1] = 1.0;
        let p0 = ts * rs;
        solve_with_added_mass(&mut l3, &k, &a, dt);
        assert!((tf * rf * l3.u[0] + ts * rs * l3.u[1] - p0).abs() < 1e-15);
    }

    #[test]
    fn the_pair_solve_is_bit_identical_to_the_general_one() {
        // random faces of two fields: absent ones, −0.0 velocities, K of 0, ∞ and past the
        // clamp, with and without added mass, bulk densities 0 (w from ρ)
        let mut seed: u64 = 15;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as Real / (1u64 << 53) as Real
        };
        let mut cases = 0;
        for _ in 0..20_000 {
            let mut p = Pair {
                rho: [0.0; 2],
                rho_w: [0.0; 2],
                theta: [0.0; 2],
                material_density: [1.0 + next(), 0.5 + 2.0 * next()],
                u: [0.0; 2],
                u_old: [0.0; 2],
            };
            for i in 0..2 {
                p.theta[i] = if next() < 0.15 { 0.0 } else { next() };
                p.rho[i] = if next() < 0.05 { 1e-12 } else { p.theta[i] * p.material_density[i] * (0.5 + next()) };
                p.rho_w[i] = if next() < 0.1 { 0.0 } else { p.theta[i] * p.material_density[i] };
                p.u[i] = if next() < 0.1 { -0.0 } else { 4.0 * next() - 2.0 };
                p.u_old[i] = if next() < 0.1 { -0.0 } else { 4.0 * next() - 2.0 };
            }
            let k = match (next() * 5.0) as usize {
                0 => 0.0,
                1 => Real::INFINITY,
                2 => 1e30 * next(),
                _ => 100.0 * next(),
            };
            let am = if next() < 0.3 { 0.0 } else { next() * p.theta[1] };
            let dt = 1e-3 * (0.1 + next());
            let mut loc = Local::empty(2);
            for i in 0..2 {
                loc.rho[i] = p.rho[i];
                loc.rho_w[i] = p.rho_w[i];
                loc.theta[i] = p.theta[i];
                loc.material_density[i] = p.material_density[i];
                loc.u[i] = p.u[i];
                loc.u_old[i] = p.u_old[i];
            }
            let mut kk = [[0.0; MAX_FIELDS]; MAX_FIELDS];
            (kk[0][1], kk[1][0]) = (k, k);
            let mut a = [[0.0; MAX_FIELDS]; MAX_FIELDS];
            (a[0][1], a[1][0]) = (am, am);
            solve_with_added_mass(&mut loc, &kk, &a, dt);
            let (u, w) = solve_pair(&p, k, am, dt);
            for i in 0..2 {
                assert_eq!(u[i].to_bits(), loc.u[i].to_bits(), "u[{i}] of {p:?}, k {k}, a {am}");
                assert_eq!(w[i].to_bits(), loc.w[i].to_bits(), "w[{i}] of {p:?}, k {k}, a {am}");
            }
            cases += usize::from(p.rho.iter().zip(&p.material_density).all(|(r, d)| *r > 1e-10 * d));
        }
        // most draws have both fields present (the solve proper, not its early return)
        assert!(cases > 10_000, "{cases}");
    }

    #[test]
    fn no_slip_is_exact_mass_average_and_w_is_mixture_specific_volume() {
        let mut l = local(&[0.5 * 1.5, 0.5 * 1.0], &[0.5, 0.5], &[2.0, 0.0]);
        let mut k = [[0.0; MAX_FIELDS]; MAX_FIELDS];
        k[0][1] = Real::INFINITY;
        k[1][0] = Real::INFINITY;
        solve(&mut l, &k, 1.0);
        let expected = 0.75 * 2.0 / 1.25;
        assert_eq!(l.u[0], l.u[1]);
        assert!((l.u[0] - expected).abs() < 1e-15);
        assert!((l.w[0] - 1.0 / 1.25).abs() < 1e-15);
    }
}
