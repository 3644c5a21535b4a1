//! An output quantity defined outside multifield's crates: the shear rate
//! γ̇ = √(2 D:D) of a field, the quantity a power-law viscosity is a function of. Once
//! the crate is linked, snapshots and pictures take `"shear_rate"` like a shipped name
//! (`output.snapshots: Some((interval: 1.0, fields: ["velocity", "shear_rate"]))`), and
//! `multifield quantities` lists it.

use multifield_core::math::Real;
use multifield_core::quantity::{velocity_gradient_at, Colours, Compute, Quantity, Sample};

/// γ̇ = √(2 D:D) = √(2 u_x² + 2 v_y² + (u_y + v_x)²) at the cell centres of field `k`,
/// from the gradient of its cell-centred velocity
/// ([`multifield_core::quantity::velocity_gradient_at`]).
pub fn shear_rate(s: &Sample, k: usize) -> Vec<Real> {
    let g = s.grid();
    let v = &s.fields[k].velocity;
    let at = |i: usize, j: usize| [v[0][g.cell(i, j)], v[1][g.cell(i, j)]];
    let mut out = vec![0.0; g.n_cells()];
    for j in 0..g.ny {
        for i in 0..g.nx {
            let d = velocity_gradient_at(g, s.periodic(), at, i, j);
            let shear = d[0][1] + d[1][0];
            out[g.cell(i, j)] = (2.0 * d[0][0] * d[0][0] + 2.0 * d[1][1] * d[1][1] + shear * shear).sqrt();
        }
    }
    out
}

inventory::submit! { Quantity {
    name: "shear_rate",
    components: 1,
    units: "1/time",
    description: "shear rate √(2 D:D) of the field's cell-centred velocity (plugin multifield-power-law)",
    colours: Colours::FromZero,
    compute: Compute::Cells { mixture: None, field: Some(shear_rate) },
}}
