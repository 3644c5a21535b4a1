//! Contact in sub-steps inside a fluid step (`time.contact_substeps`; docs/method.md §5):
//! the contact's stiffness limits only its own integration, not the fluid's Δt.

use super::*;
use rayon::prelude::*;

/// The most sub-steps a fluid step may take; more is an error (a contact this stiff
/// against the step wants a smaller `time.max_dt`, or a softer contact).
pub const MAX_CONTACT_SUBSTEPS: usize = 10_000;

/// Integrates every body over the step `dt` from its state at the step's start (`ctx.bodies`)
/// in n = ceil(Δt / δ) equal sub-steps δt = Δt/n, δ the model's
/// [`ContactModel::substep_dt`] (n = 1 when it has none), by symplectic Euler: contact
/// forces at the sub-step's positions, v ← v + δt (a + F_c/M), x ← x + δt v, and the same
/// for ω and the rotation. A free body's non-contact acceleration a is constant over the
/// step: gravity plus its hydrodynamic force of the last step over its mass (lagged;
/// [`BodyState::force`], zero at the first step); a fixed or prescribed body moves with
/// its velocity and takes no force. Returns for each body the mean contact force and
/// torque (impulse/Δt) and, for a free body, the shift s = X_n − (X₀ + Δt V_n) and the turn
/// φ = θ_n − Δt ω_n: the frame that moves the body with its end velocity over the whole
/// step and adds them ends it where the sub-steps put it (to Δt² times the difference
/// between the lagged and the actual hydrodynamic force over the mass). Sums run in body
/// order, the same on any number of threads.
pub(super) fn substepped(
    model: &mut dyn ContactModel,
    ctx: &ContactContext,
    dt: Real,
) -> std::result::Result<Vec<BodyContact>, String> {
    let start = ctx.bodies;
    let n = match model.substep_dt(ctx) {
        None => 1,
        Some(step) => {
            let n = (dt / step).ceil();
            if !(step > 0.0 && n <= MAX_CONTACT_SUBSTEPS as Real) {
                return Err(format!(
                    "the contact ({}) needs sub-steps of {step:e}: {n} in the step of {dt:e}, more than \
                     {MAX_CONTACT_SUBSTEPS}; lower time.max_dt or soften the contact",
                    model.model()
                ));
            }
            (n as usize).max(1)
        }
    };
    let h = dt / n as Real;
    let accel: Vec<(Vector, Real)> = start
        .iter()
        .map(|b| {
            let a = if b.mass > 0.0 { ctx.gravity + b.force / b.mass } else { Vector::zeros() };
            let alpha = if b.inertia > 0.0 { b.torque / b.inertia } else { 0.0 };
            (a, alpha)
        })
        .collect();
    let mut bodies = start.to_vec();
    let mut impulse = vec![(Vector::zeros(), 0.0); start.len()];
    let mut angle = vec![0.0; start.len()];
    let mut out = vec![(Vector::zeros(), 0.0); start.len()];
    for _ in 0..n {
        let sub = ContactContext { bodies: &bodies, ..*ctx };
        model.forces(&sub, h, &mut out);
        // each body on its own: in parallel, the same bits on any number of threads
        bodies
            .par_iter_mut()
            .zip(impulse.par_iter_mut())
            .zip(angle.par_iter_mut())
            .zip(out.par_iter().zip(&accel))
            .with_min_len(1024)
            .for_each(|(((b, impulse), angle), (&(f, t), accel))| {
                impulse.0 += h * f;
                impulse.1 += h * t;
                if b.free && b.mass > 0.0 {
                    b.velocity += h * (accel.0 + f / b.mass);
                    if b.inertia > 0.0 {
                        b.angular_velocity += h * (accel.1 + t / b.inertia);
                    }
                }
                b.position += h * b.velocity;
                *angle += h * b.angular_velocity;
            });
    }
    Ok(bodies
        .iter()
        .zip(start)
        .zip(impulse.iter().zip(&angle))
        .map(|((end, b), (&(j, l), &theta))| {
            let mut c = BodyContact::force(j / dt, l / dt);
            if b.free && b.mass > 0.0 {
                c.shift = end.position - (b.position + dt * end.velocity);
                c.turn = theta - dt * end.angular_velocity;
            }
            c
        })
        .collect())
}
