//! What the drag laws share (`stokes`, `schiller_naumann`, `cylinder`): a dispersed field
//! of particles of diameter d in a continuous fluid, and how a drag law becomes K.
//!
//! **Which field is which.** The FIRST field of `between` is the continuous fluid (its
//! material density ρ_f is `density[0]`, its volume fraction θ_f), the second the dispersed
//! particles (θ_s). Nothing else is checked.
//!
//! **From a drag law to K.**
//! The fields' velocities are interstitial (phase) velocities and the slip is
//! Δu = u_f − u_s. A particle of volume V_p feels the drag F(Δu); with n = θ_s / V_p
//! particles per volume of mixture the force per volume on the dispersed field is n F, and
//! the exchange term of the core is θ_s θ_f K Δu, so
//!
//! ```text
//!     n F = θ_s θ_f K Δu   ⇒   K = F / (V_p θ_f |Δu|)      (F along Δu)
//! ```
//!
//! The single-particle laws use the interstitial slip: Re = ρ_f |Δu| d / μ. With
//! F = ½ ρ_f C_D(Re) A |Δu|² and C_D Re = G(Re):
//!
//! ```text
//!     sphere   (A = πd²/4, V_p = πd³/6):  K = (3/4) G(Re) μ / (d² θ_f)
//!     cylinder (A = d,     V_p = πd²/4):  K = (2/π) G(Re) μ / (d² θ_f)     (per unit length)
//! ```
//!
//! The optional dense-suspension correction of Di Felice (1994) follows the paper: the
//! unhindered drag is taken at the superficial slip U = θ_f |Δu| (Re_s = θ_f Re) and
//! multiplied by θ_f^(−χ), χ = 3.7 − 0.65 exp(−(1.5 − log₁₀ Re_s)²/2):
//! F = ½ ρ_f C_D(Re_s) A U² θ_f^(−χ), hence K = c G(Re_s) θ_f^(−χ) μ / d² (c = 3/4 or 2/π).
//! At θ_f = 1 it is the uncorrected law exactly.
//!
//!
//! **On a MAC face** K uses the face's θ_f (`theta_u`/`theta_v` of the fluid, floored at
//! [`THETA_FLOOR`]) and, in the slip-dependent laws, |Δu| from the face's normal slip and the
//! tangential slip averaged from the four nearest faces of the other lattice (one-sided
//! at the domain edges). Re is floored at [`RE_FLOOR`] (the Re → 0 limit; Lamb's law
//! needs it, since there K → 0 logarithmically).

use multifield_core::grid::Grid;
use multifield_core::math::Real;
use multifield_core::plugin::{DragLaw, ExchangeContext};
use multifield_core::registry::ParamDoc;

/// Smallest Reynolds number the laws are evaluated at.
pub const RE_FLOOR: Real = 1e-12;
/// Smallest fluid volume fraction the laws are evaluated at (K ∝ 1/θ_f or θ_f^(−χ)).
pub const THETA_FLOOR: Real = 1e-6;

/// Checks that a diameter and a viscosity are positive and finite.
pub fn validate_particle(diameter: Real, viscosity: Real) -> Result<(), String> {
    if !(diameter > 0.0 && diameter.is_finite()) {
        return Err(format!("diameter {diameter}: must be finite and > 0 (the particle diameter, a length)"));
    }
    if !(viscosity > 0.0 && viscosity.is_finite()) {
        return Err(format!(
            "viscosity {viscosity}: must be finite and > 0 (the dynamic viscosity μ of the fluid, \
             the first field of `between`; for an inviscid fluid use model \"constant\" with coefficient 0)"
        ));
    }
    Ok(())
}

/// The particle diameter and the fluid's viscosity, which every drag law takes.
pub const PARTICLE_PARAMS: [ParamDoc; 2] = [
    ParamDoc {
        name: "diameter",
        unit: "length",
        default: "required (mass points: the bodies')",
        doc: "particle diameter d",
    },
    ParamDoc {
        name: "viscosity",
        unit: "mass/(length·time)",
        default: "required (mass points: the fluid's newtonian)",
        doc: "dynamic viscosity μ of the fluid (first field of `between`)",
    },
];

/// Di Felice's dense-suspension option of the slip-dependent laws.
pub const DI_FELICE_PARAM: ParamDoc = ParamDoc {
    name: "di_felice",
    unit: "-",
    default: "false",
    doc: "Di Felice (1994) dense-suspension factor θf^(−χ) at the superficial slip",
};

/// The options every drag law offers point particles (`representation: MassPoint`).
pub const POINT_PARAMS: [ParamDoc; 2] = [
    ParamDoc {
        name: "added_mass",
        unit: "-",
        default: "0",
        doc: "added-mass coefficient C_A, solved implicitly (1 for a 2D disk, 0.5 for a sphere)",
    },
    ParamDoc {
        name: "rotation",
        unit: "-",
        default: "false",
        doc: "mass points feel the torque 4πμa²(½∇×u_f − ω) per unit length",
    },
];

/// Checks the added-mass coefficient.
pub fn validate_added_mass(c: Real) -> Result<(), String> {
    if !(c >= 0.0 && c.is_finite()) {
        return Err(format!(
            "added_mass {c}: must be finite and ≥ 0 (the added-mass coefficient C_A: 1 for a 2D disk, 0.5 for a sphere)"
        ));
    }
    Ok(())
}

/// The [`DragLaw`] a model reports.
pub fn law(
    model: &'static str,
    diameter: Real,
    viscosity: Real,
    valid_re: (Real, Real),
    added_mass: Real,
    rotation: bool,
) -> DragLaw {
    DragLaw { model, diameter, viscosity, valid_re, added_mass, rotation }
}

/// Di Felice's (1994) exponent χ(Re) = 3.7 − 0.65 exp(−(1.5 − log₁₀ Re)²/2).
pub fn di_felice_exponent(re: Real) -> Real {
    let l = 1.5 - re.max(RE_FLOOR).log10();
    3.7 - 0.65 * (-0.5 * l * l).exp()
}

/// Di Felice's factor θ_f^(−χ(Re)), Re the superficial Reynolds number.
pub fn di_felice_factor(theta_f: Real, re: Real) -> Real {
    theta_f.max(THETA_FLOOR).powf(-di_felice_exponent(re))
}

/// K of a slip-dependent law at one location: `c` is 3/4 (sphere) or 2/π (cylinder),
/// `g` is C_D·Re as a function of Re, `slip` = |Δu|, `rho_f` the fluid's material density.
#[allow(clippy::too_many_arguments)]
pub fn drag_coefficient(
    c: Real,
    g: impl Fn(Real) -> Real,
    diameter: Real,
    viscosity: Real,
    rho_f: Real,
    theta_f: Real,
    slip: Real,
    di_felice: bool,
) -> Real {
    let theta_f = theta_f.max(THETA_FLOOR);
    let re = rho_f * slip * diameter / viscosity;
    let scale = c * viscosity / (diameter * diameter);
    if di_felice {
        let re_s = (theta_f * re).max(RE_FLOOR);
        scale * g(re_s) * di_felice_factor(theta_f, re_s)
    } else {
        scale * g(re.max(RE_FLOOR)) / theta_f
    }
}

/// Slip speed |u_a − u_b| on every x-face and y-face: the face's normal component and the
/// tangential one averaged from the (up to) four nearest faces of the other lattice.
pub fn face_slip_speeds(ctx: &ExchangeContext, sx: &mut Vec<Real>, sy: &mut Vec<Real>) {
    let g: &Grid = ctx.grid;
    let (a, b) = (&ctx.a.velocity, &ctx.b.velocity);
    let du = |f: usize| a.u[f] - b.u[f];
    let dv = |f: usize| a.v[f] - b.v[f];
    sx.clear();
    sx.resize(g.n_xfaces(), 0.0);
    sy.clear();
    sy.resize(g.n_yfaces(), 0.0);
    if g.nx == 0 || g.ny == 0 {
        return;
    }
    for j in 0..g.ny {
        for i in 0..=g.nx {
            // y-faces (i−1, j), (i, j), (i−1, j+1), (i, j+1), columns clamped to the domain
            let (c0, c1) = (i.saturating_sub(1), i.min(g.nx - 1));
            let t = 0.25 * (dv(g.yface(c0, j)) + dv(g.yface(c1, j)) + dv(g.yface(c0, j + 1)) + dv(g.yface(c1, j + 1)));
            let f = g.xface(i, j);
            sx[f] = du(f).hypot(t);
        }
    }
    for j in 0..=g.ny {
        for i in 0..g.nx {
            // x-faces (i, j−1), (i+1, j−1), (i, j), (i+1, j), rows clamped to the domain
            let (r0, r1) = (j.saturating_sub(1), j.min(g.ny - 1));
            let t = 0.25 * (du(g.xface(i, r0)) + du(g.xface(i + 1, r0)) + du(g.xface(i, r1)) + du(g.xface(i + 1, r1)));
            let f = g.yface(i, j);
            sy[f] = dv(f).hypot(t);
        }
    }
}

/// Fills K on every face for a slip-dependent law (see [`drag_coefficient`]).
#[allow(clippy::too_many_arguments)]
pub fn fill_drag(
    ctx: &ExchangeContext,
    kx: &mut [Real],
    ky: &mut [Real],
    c: Real,
    g: impl Fn(Real) -> Real + Copy,
    diameter: Real,
    viscosity: Real,
    di_felice: bool,
) {
    let (mut sx, mut sy) = (Vec::new(), Vec::new());
    face_slip_speeds(ctx, &mut sx, &mut sy);
    let rho_f = ctx.density[0];
    for ((k, s), t) in kx.iter_mut().zip(&sx).zip(&ctx.a.theta_u) {
        *k = drag_coefficient(c, g, diameter, viscosity, rho_f, *t, *s, di_felice);
    }
    for ((k, s), t) in ky.iter_mut().zip(&sy).zip(&ctx.a.theta_v) {
        *k = drag_coefficient(c, g, diameter, viscosity, rho_f, *t, *s, di_felice);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn di_felice_factor_is_one_without_particles_and_hand_values() {
        for re in [1e-12, 0.1, 1.0, 31.6, 1e3, 1e5] {
            assert_eq!(di_felice_factor(1.0, re), 1.0);
        }
        // χ(10^1.5) = 3.7 − 0.65 = 3.05; χ(Re → 0) = 3.7; χ(1) = 3.7 − 0.65 e^(−1.125)
        assert!((di_felice_exponent(10f64.powf(1.5)) - 3.05).abs() < 1e-12);
        assert!((di_felice_exponent(0.0) - 3.7).abs() < 1e-12);
        assert!((di_felice_exponent(1.0) - (3.7 - 0.65 * (-1.125f64).exp())).abs() < 1e-12);
        assert!((di_felice_factor(0.5, 10f64.powf(1.5)) - 2f64.powf(3.05)).abs() < 1e-12);
    }
}
