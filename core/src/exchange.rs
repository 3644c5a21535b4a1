//! The implicit momentum exchange at one location (METHOD.md §3, step 4).
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

/// Largest Δt·θK/ρ kept in the dense solve: beyond it digits are lost (METHOD.md §3).
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
    /// Effective specific volume of each field (output).
    pub w: [Real; MAX_FIELDS],
}

/// Couplings at one location: `k[a][b]` is K (∞ for no-slip, 0 for none).
pub type Coefficients = [[Real; MAX_FIELDS]; MAX_FIELDS];

/// Solves the exchange at one location in place.
pub fn solve(loc: &mut Local, k: &Coefficients, dt: Real) {
    let n = loc.n;
    // absent fields take no part: keep u*, w = 1/ρ⁰
    let present: [bool; MAX_FIELDS] = std::array::from_fn(|i| i < n && loc.rho[i] > 1e-10 * loc.material_density[i]);
    // one field alone (most of a domain with bodies): nothing to exchange
    if present.iter().filter(|&&p| p).count() == 1 {
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
        let mut l = Local {
            n: rho.len(),
            rho: [0.0; MAX_FIELDS],
            rho_w: [0.0; MAX_FIELDS],
            theta: [0.0; MAX_FIELDS],
            material_density: [1.0; MAX_FIELDS],
            u: [0.0; MAX_FIELDS],
            w: [0.0; MAX_FIELDS],
        };
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
