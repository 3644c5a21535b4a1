//! Stress (constitutive) models: `ls physics/src/stress/` lists them.

// In 3D only the Newtonian stress so far (issue 17, P1); the point stresses come with the
// Lagrangian frame.
#[cfg(feature = "dim2")]
pub mod linear_elastic;
#[cfg(feature = "dim2")]
pub mod neo_hookean;
pub mod newtonian;
#[cfg(feature = "dim2")]
pub mod rigid;
#[cfg(feature = "dim2")]
pub mod weakly_compressible;

#[cfg(feature = "dim2")]
use multifield_core::math::Real;

#[cfg(feature = "dim2")]
/// Lamé constants (λ, μ) from Young's modulus E and Poisson's ratio ν:
/// λ = E ν / ((1 + ν)(1 − 2ν)), μ = E / (2 (1 + ν)). Plane strain uses them unchanged.
pub fn lame(young_modulus: Real, poisson_ratio: Real) -> (Real, Real) {
    let (e, nu) = (young_modulus, poisson_ratio);
    (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)))
}

#[cfg(feature = "dim2")]
/// Checks the elastic parameters shared by the elastic models.
pub(crate) fn check_elastic(young_modulus: Real, poisson_ratio: Real, cfl: Real) -> Result<(), String> {
    if !(young_modulus > 0.0 && young_modulus.is_finite()) {
        return Err(format!("young_modulus {young_modulus}: must be a positive stress (force/area)"));
    }
    if !(poisson_ratio > -1.0 && poisson_ratio < 0.5) {
        return Err(format!(
            "poisson_ratio {poisson_ratio}: must lie in (−1, 0.5); 0.5 is incompressible (use a rigid or fluid model)"
        ));
    }
    if !(cfl > 0.0 && cfl <= 1.0) {
        return Err(format!("cfl {cfl}: must lie in (0, 1]; 0.3–0.5 is usual"));
    }
    Ok(())
}

#[cfg(feature = "dim2")]
/// Explicit elastic time step Δt = C h / (c + |v|) with the dilatational (P-wave) speed
/// c = sqrt((λ + 2μ)/ρ) = sqrt((K + 4G/3)/ρ) of plane strain (docs/method.md §4, §5).
pub(crate) fn elastic_dt(cfl: Real, h: Real, p_wave_modulus: Real, density: Real, max_speed: Real) -> Real {
    cfl * h / ((p_wave_modulus / density).sqrt() + max_speed)
}
