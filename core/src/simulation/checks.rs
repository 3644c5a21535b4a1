//! The checks of a case's combination of fields, frames and couplings, made while
//! building (each error names the entry and the fix).

use super::*;

/// A field that steps alone ([`Frame::steps_alone`]) must be the case's only one, with no
/// pressure solve, exchange or contact, and no stress model that acts on the grid.
pub(super) fn check_alone(case: &Case, fields: &[Field], pressure: bool) -> Result<()> {
    let field = fields.iter().find(|f| f.frame.steps_alone()).expect("a field steps alone");
    let path = format!("fields.{}.frame", field.name);
    let fix = "or give the field its coupled grid (for the Lagrangian frame, grid: \"staggered\")";
    let why = |what: String| {
        Error::invalid(path.clone(), format!("this frame steps alone (grid \"collocated\"), {what}; {fix}"))
    };
    if fields.len() > 1 {
        let others: Vec<&str> = fields.iter().filter(|f| f.name != field.name).map(|f| f.name.as_str()).collect();
        return Err(why(format!(
            "but the case has other fields ({}): remove them",
            others.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
        )));
    }
    if pressure {
        return Err(why("but the case has a pressure solve: set `pressure: None`".into()));
    }
    if !case.exchange.is_empty() {
        return Err(why("but the case has exchanges: remove them".into()));
    }
    if case.contact.is_some() {
        return Err(why("but the case has a contact model: set `contact: None`".into()));
    }
    if let Some(m) = field.stress.iter().find(|m| m.kind().is_rigid()) {
        return Err(why(format!(
            "but its stress `{}` makes bodies rigid, and a field on this grid has none: remove it",
            m.model()
        )));
    }
    if let Some(m) = field.stress.iter().find(|m| m.kind().acts_on_grid()) {
        return Err(why(format!(
            "but its stress `{}` acts on the staggered grid: use a point stress (e.g. weakly_compressible)",
            m.model()
        )));
    }
    Ok(())
}

/// A direct forcing couples an Eulerian fluid (first) with a Lagrangian field of rigid disks
/// or annuli (second), which no other exchange or forcing names.
pub(super) fn check_forcing(case: &Case, fields: &[Field], k: usize, fa: usize, fb: usize) -> Result<()> {
    let path = format!("exchange.{k}");
    let (a, b) = (&fields[fa], &fields[fb]);
    let model = &case.exchange[k].model;
    if a.frame.is_lagrangian() {
        return Err(Error::invalid(
            format!("{path}.between"),
            format!(
                "`{model}` forces a fluid on a grid towards its bodies' motion: its first field must be Eulerian, \
                 and `{}` is Lagrangian; name the Eulerian fluid first and the bodies second",
                a.name
            ),
        ));
    }
    let Region::Bodies(specs) = &case.fields[fb].region else {
        return Err(Error::invalid(
            format!("{path}.between"),
            format!(
                "`{model}` acts on the surfaces of bodies: its second field (`{}`) must be a Lagrangian field of \
                 `region: Bodies([...])`",
                b.name
            ),
        ));
    };
    if !b.frame.is_lagrangian() || !b.stress.iter().any(|m| m.kind().is_rigid()) {
        return Err(Error::invalid(
            format!("fields.{}.stress", b.name),
            format!(
                "`{model}` moves bodies rigidly: give field `{}` a Lagrangian frame and `stress: [(model: \"rigid\")]`",
                b.name
            ),
        ));
    }
    for spec in specs {
        let bp = format!("fields.{}.region.{}", b.name, spec.name);
        match (&spec.shape, spec.motion) {
            (BodyShape::Rectangle { .. }, _) => {
                return Err(Error::invalid(
                    bp,
                    format!("`{model}` places its markers on circles: a rectangle is not supported; use a Disk or an Annulus, or `no_slip`"),
                ))
            }
            (BodyShape::Annulus { .. }, Motion::Free) => {
                return Err(Error::invalid(
                    format!("{bp}.motion"),
                    "an annulus holds a flow: make it `Fixed` or `Prescribed` with a rotation about its centre",
                ))
            }
            (BodyShape::Annulus { .. }, Motion::Prescribed { velocity, .. }) if velocity != [0.0, 0.0] => {
                return Err(Error::invalid(
                    format!("{bp}.motion"),
                    "an annulus may rotate about its centre but not translate: set `velocity: (0, 0)`",
                ))
            }
            _ => {}
        }
    }
    let others: Vec<usize> = case
        .exchange
        .iter()
        .enumerate()
        .filter(|(j, e)| *j != k && e.between.iter().any(|n| n == &b.name))
        .map(|(j, _)| j)
        .collect();
    if let Some(j) = others.first() {
        return Err(Error::invalid(
            format!("exchange.{j}"),
            format!(
                "field `{}` is moved by the direct forcing of exchange {k}, which owns its coupling: remove this entry",
                b.name
            ),
        ));
    }
    Ok(())
}

pub(super) fn case_index(fields: &[Field], name: &str) -> usize {
    fields.iter().position(|f| f.name == name).expect("validated: exchange names exist")
}

/// Name of the frame of fields with `representation: MassPoint`.
pub const MASS_POINT_FRAME: &str = "mass_point";

/// Volume fraction of a list of disks spread exactly (disk ∩ cell areas), as the
/// `mass_point` frame spreads it.
#[cfg(feature = "dim2")]
pub(super) fn mass_point_fraction(region: &Region, grid: &Grid, periodic: [bool; 2]) -> Vec<Real> {
    let mut theta = vec![0.0; grid.n_cells()];
    if let Region::Bodies(bodies) = region {
        let mut cells = Vec::new();
        for b in bodies {
            if let BodyShape::Disk { center, radius } = b.shape {
                cells.clear();
                crate::geometry::disk_cell_fractions(grid, center, radius, periodic, &mut cells);
                for (c, t) in &cells {
                    theta[*c] += t;
                }
            }
        }
    }
    theta
}

/// The parameters of the drag law of mass points: a registered `diameter` defaults to the
/// bodies' (when they all have one), a `viscosity` to the fluid's `newtonian` viscosity.
pub(super) fn point_drag_params(
    spec: &PluginSpec,
    fluid: &crate::case::FieldSpec,
    points: &crate::case::FieldSpec,
    path: &str,
) -> Result<serde_json::Value> {
    let entry = registry::find(registry::Role::Exchange, &spec.model, path)?;
    let mut params = match &spec.params {
        serde_json::Value::Object(m) => m.clone(),
        serde_json::Value::Null => Default::default(),
        other => {
            return Err(Error::invalid(format!("{path}.params"), format!("{other}: expected a map of parameters")))
        }
    };
    let has = |name: &str| entry.params.iter().any(|p| p.name == name);
    if has("diameter") && !params.contains_key("diameter") {
        let mut diameters = Vec::new();
        if let Region::Bodies(bodies) = &points.region {
            for b in bodies {
                if let BodyShape::Disk { radius, .. } = b.shape {
                    diameters.push(2.0 * radius);
                }
            }
        }
        if let Some(&d) = diameters.first() {
            if diameters.iter().all(|x| (x - d).abs() <= 1e-12 * d) {
                params.insert("diameter".into(), serde_json::json!(d));
            }
        }
    }
    if has("viscosity") && !params.contains_key("viscosity") {
        // the fluid's Newtonian viscosity, whichever model gives it (its kind says so)
        let mu = fluid.stress.iter().find_map(|s| {
            registry::build_stress(&s.model, &s.params, path).ok().and_then(|m| m.kind().newtonian_viscosity())
        });
        if let Some(mu) = mu {
            params.insert("viscosity".into(), serde_json::json!(mu));
        }
    }
    Ok(serde_json::Value::Object(params))
}

/// Every body of a mass-point field must have the drag law's diameter.
pub(super) fn check_point_diameters(law: &DragLaw, points: &crate::case::FieldSpec, path: &str) -> Result<()> {
    if let Region::Bodies(bodies) = &points.region {
        for b in bodies {
            if let BodyShape::Disk { radius, .. } = b.shape {
                let d = 2.0 * radius;
                if (d - law.diameter).abs() > 1e-9 * d {
                    return Err(Error::invalid(
                        format!("{path}.params.diameter"),
                        format!(
                            "{}: body `{}` of field `{}` has diameter {d}; a drag law has one diameter, so \
                             give `diameter: {d}` (or leave it out to take the bodies'), or put bodies of \
                             another size in a field of their own",
                            law.diameter, b.name, points.name
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}
