//! Direct-forcing immersed boundaries (Uhlmann, J. Comput. Phys. 209, 2005), a sharp
//! coupling of a fluid field with the rigid bodies of a Lagrangian field: beside
//! `no_slip`, whose no-slip condition is the mass-weighted average of the fields in the
//! cells a body partly covers (smeared over a cell at any resolution, weighted by the
//! body's density, lagged by a step), this one imposes the body's rigid motion on the fluid
//! at Lagrangian markers on the body's surface.
//!
//! Each step, after the exchange and before the pressure (the core's phase "immersed
//! boundaries", `multifield_core::immersed`): markers `X_l` every h on the surface,
//! `retraction` cells into the solid (Breugem, J. Comput. Phys. 231, 2012: 0.3); the fluid
//! velocity there with the lagged pressure acceleration, ṽ = u* + Δt a_pⁿ, interpolated
//! with the 3-point kernel of Roma, Peskin & Berger (1999); a force F_l = (U_b(X_l) −
//! ṽ(X_l))/Δt spread back to the faces, repeated `iterations` times on the forced velocity
//! (multi-direct forcing, Breugem §2.3), or (`forcing: "exact"`, the default) the forces
//! solved so that every marker takes the body's velocity exactly. The body's fluid is the whole domain: the body
//! field takes no volume on the grid (the fluid's θ = 1 inside it, the "fictitious" fluid).
//!
//! The fluid inside a disk is not held: it moves as the grid lets it (a body that starts
//! moving or turning spins its inside up over R²/ν). Its momentum `P = ∫_V u dV` and
//! angular momentum `L = ∫_V r × u dV`, summed over the faces with their exact fractions
//! of the disk, enter the body's balance instead of the rigid-interior approximation
//! (Kempe & Fröhlich, J. Comput. Phys. 231, 2012). A free body moves by Newton–Euler,
//! implicit in the new velocity (the forcing's target is the body's new rigid motion, so
//! the forcing shell's fluid mass and the fluid it leaves inside enter the body's inertia;
//! Tschisgale, Kempe & Fröhlich, J. Comput. Phys. 339, 2017, for the idea). Free bodies
//! whose surfaces are closer than a cell are solved together, their markers' forces on the
//! whole cluster's markers (issue 15: solved one by one, touching disks blew up;
//! docs/method.md §6):
//!
//! ```text
//!   M (U' − Uⁿ)/Δt = −ρ_f Σ_l F_l(U', ω') ΔV_l + ρ_f (P'(U', ω') − Pⁿ)/Δt + (M − ρ_f V) g + F_contact
//!   J (ω' − ωⁿ)/Δt = −ρ_f Σ_l (X_l − X_c) × F_l(U', ω') ΔV_l + ρ_f (L' − Lⁿ)/Δt + T_contact
//! ```
//!
//! with `Pⁿ` from the velocity uⁿ at the start of the step, inside the disk where it
//! starts the step, and `P'` from the forced velocity the step ends with, ṽ + δu, inside
//! the disk where it ends it.
//!
//! **Moving bodies.** The forcing holds a body where it ends the step, its centre moved
//! by Δt times its velocity at the start (the prescribed one for a prescribed body), so
//! that the slip its motion opens in a step is closed in the same step whatever the steps'
//! lengths. The lagged force is carried with the body as marker forces `F_l` (per marker,
//! stored between steps and in checkpoints) and spread from where the markers stand now:
//! a field of face forces lagged in place leaves behind a moving body a part its markers
//! no longer see, which grew unchecked and reversed a translating disk's drag. The first
//! step, which has no lagged pressure, estimates it as the hydrostatic one (a_p = −g).
//! Measured (docs/validation.md): a disk moving through fluid at rest against the same
//! disk held in a stream, +2.7 % and +0.6 % at 8 and 16 cells per diameter; free disks
//! stable from ρ_b/ρ_f = 0.02 (rising; erratic at 0.01) to 10; a settling disk's speed
//! converges with the grid.
//!
//! The hydrodynamic force reported in `bodies.csv` (buoyancy included, as for every body)
//! is the momentum balance of the fluid inside the body's surface,
//! `F = −ρ_f Σ_l F_l ΔV_l + ρ_f (P' − Pⁿ)/Δt − ρ_f V g`, and the torque
//! `T = −ρ_f Σ_l r_l × F_l ΔV_l + ρ_f (L' − Lⁿ)/Δt` (an annulus's inside is taken as
//! rigid: its V and J are zero). Counting the change of the inside's angular momentum took
//! the circular Couette torque from 0.54 % to 0.15 % off at 20 cells per R₁: the inside of
//! the turning disk still spins up at t = 4. Because the lagged pressure enters ṽ, a
//! steady state has F_l = −(the steady residual of the fluid's equations at the markers)
//! and P' = Pⁿ, independent of Δt and of the body's density.

use multifield_core::grid::FaceArrays;
use multifield_core::math::{Real, AXES};
use multifield_core::plugin::{ExchangeContext, ExchangeModel, ImmersedBoundary};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Serialize};

/// Direct forcing on markers of the bodies' surfaces.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectForcing {
    /// `"exact"`: the markers' forces that give every marker its body's velocity, solved
    /// by conjugate gradients; `"sweeps"`: `iterations` sweeps of multi-direct forcing.
    #[serde(default)]
    pub forcing: ForcingSolve,
    /// Forcing sweeps per step with `forcing: "sweeps"` (1 is Uhlmann's original).
    #[serde(default = "default_iterations")]
    pub iterations: usize,
    /// Markers this many cells inside the solid from the surface (Breugem: 0.3).
    #[serde(default = "default_retraction")]
    pub retraction: Real,
}

/// How the markers' forces are found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForcingSolve {
    /// Solved so that every marker takes its body's velocity (to 1e-12).
    #[default]
    Exact,
    /// `iterations` sweeps of multi-direct forcing (Breugem 2012): the slip they leave makes
    /// the force depend on Δt (slip/Δt).
    Sweeps,
}

fn default_iterations() -> usize {
    3
}
fn default_retraction() -> Real {
    0.3
}

impl DirectForcing {
    /// The sweeps lie in 1..=20, the retraction in [0, 1] cell.
    pub fn validate(&mut self) -> Result<(), String> {
        if !(1..=20).contains(&self.iterations) {
            return Err(format!("iterations {}: must lie in 1..=20 (2–4 usual)", self.iterations));
        }
        if !(0.0..=1.0).contains(&self.retraction) {
            return Err(format!("retraction {}: must lie in [0, 1] cells (0.3 usual)", self.retraction));
        }
        Ok(())
    }
}

multifield_core::register!(
    Exchange,
    "direct_forcing",
    DirectForcing,
    "sharp no-slip: direct-forcing immersed boundaries on the bodies' surfaces (Uhlmann 2005, Breugem 2012)",
    &[
        ParamDoc {
            name: "forcing",
            unit: "-",
            default: "\"exact\"",
            doc: "\"exact\" (markers take the body's velocity, CG) or \"sweeps\" (multi-direct forcing)"
        },
        ParamDoc { name: "iterations", unit: "-", default: "3", doc: "sweeps per step with forcing: \"sweeps\"" },
        ParamDoc {
            name: "retraction",
            unit: "cells",
            default: "0.3",
            doc: "markers inside the solid from the surface"
        },
    ]
);

impl ExchangeModel for DirectForcing {
    fn model(&self) -> &'static str {
        "direct_forcing"
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    fn immersed_boundary(&self) -> Option<ImmersedBoundary> {
        let sweeps = (self.forcing == ForcingSolve::Sweeps).then_some(self.iterations);
        Some(ImmersedBoundary { sweeps, retraction: self.retraction })
    }
    fn coefficients(&self, _ctx: &ExchangeContext, k: &mut FaceArrays) {
        for a in AXES {
            k[a].fill(0.0);
        }
    }
}
