//! Building a [`Simulation`] from a case: fields, frames, plugins, the checks of their
//! combination (`checks.rs`) and the initial state.

use super::*;

impl Simulation {
    /// Builds every model from the registries and seeds the initial state.
    pub fn new(case: &Case) -> Result<Simulation> {
        Self::with_comm(case, std::sync::Arc::new(crate::parallel::Serial))
    }

    /// [`Simulation::new`] on rank `comm.rank()` of `comm.size()` (docs/design/mpi.md): on
    /// more than one rank the domain is cut by the rank grid of least halo surface and this
    /// rank builds and steps its block; every rank must call it with the same case. A case
    /// with a plugin that is not decomposed ([`Frame::decomposed`] and the like) is refused,
    /// naming it, on every rank alike.
    pub fn with_comm(case: &Case, comm: std::sync::Arc<dyn crate::parallel::Comm>) -> Result<Simulation> {
        // snapshots of `FromSnapshot` velocities are read once, here
        let case = &case.with_snapshots_read()?;
        case.validate()?;
        // generated bodies become listed ones once, here, and are checked as those are
        #[cfg(feature = "dim2")]
        let mut case = if case.has_generators() {
            let (expanded, _) = case.expand_generators()?;
            expanded.validate()?;
            expanded
        } else {
            case.clone()
        };
        #[cfg(feature = "dim3")]
        let mut case = case.clone();
        // the caps on cells, points, bodies and lists before the grid is allocated
        case.check_counts()?;
        let d = &case.domain;
        let cells = case.cells();
        let h = d.size[0] / cells[0] as Real;
        let ranks = comm.size();
        let part = if ranks > 1 {
            let periodic = case.boundaries.periodic_axes();
            // (the key that chose the grid names the refusal)
            let key = if d.ranks.is_some() { "domain.ranks" } else { "domain.cells" };
            let rank_grid = crate::decomposition::RankGrid::new(cells, periodic, ranks, d.ranks)
                .map_err(|m| Error::invalid(key, format!("a run on {ranks} ranks: {m}")))?;
            crate::part::Part::of(comm, rank_grid)
        } else {
            crate::part::Part::whole()
        };
        let grid = Grid::from_cells(cells, h, vector(d.origin)).of_part(part);
        let boundaries = case.boundaries.local(&grid.part);
        let mut fields = Vec::new();
        for (k, spec) in case.fields.iter_mut().enumerate() {
            let path = format!("fields.{}", spec.name);
            let mut frame = registry::build_frame(&spec.frame.model, &spec.frame.params, &format!("{path}.frame"))?;
            spec.frame.params = frame.params();
            if frame.representation() == Representation::MassPoint && spec.representation != Representation::MassPoint {
                return Err(Error::invalid(
                    format!("{path}.frame.model"),
                    format!(
                        "`{}` is the frame of `representation: MassPoint`: set that entry instead \
                         (and keep the resolved frame, e.g. `(model: \"lagrangian\")`, for switching back)",
                        spec.frame.model
                    ),
                ));
            }
            if spec.representation == Representation::MassPoint {
                // the resolved frame's options stay in the case, so that switching back is
                // one entry; the points are the `mass_point` frame's
                frame = registry::build_frame(
                    MASS_POINT_FRAME,
                    &serde_json::Value::Object(Default::default()),
                    &format!("{path}.representation"),
                )?;
                if frame.representation() != Representation::MassPoint {
                    return Err(Error::invalid(
                        format!("{path}.representation"),
                        format!(
                            "the frame registered as `{MASS_POINT_FRAME}` is not a mass-point frame (its \
                             Frame::representation is {:?}): another crate registered that name",
                            frame.representation()
                        ),
                    ));
                }
            }
            let mut stress = Vec::new();
            for (s, st) in spec.stress.iter_mut().enumerate() {
                let m = registry::build_stress(&st.model, &st.params, &format!("{path}.stress.{s}"))?;
                st.params = m.params();
                stress.push(m);
            }
            let fills_rest = spec.region == Region::Rest;
            if fills_rest && frame.is_lagrangian() {
                return Err(Error::invalid(
                    format!("{path}.region"),
                    "region `Rest` is only for an Eulerian field (its volume fraction is what the \
                     others leave); give a Lagrangian field an explicit region",
                ));
            }
            let _ = k;
            fields.push(Field {
                name: spec.name.clone(),
                density: spec.density,
                own_densities: matches!(&spec.region, Region::Bodies(b) if b.iter().any(|b| b.density.is_some())),
                fills_rest,
                frame,
                stress,
                state: FieldState::new(&grid),
            });
        }
        let mut exchanges = Vec::new();
        let mut forcings: Vec<ForcedPair> = Vec::new();
        let mut forced_entries = Vec::new();
        let mut partners: Vec<Option<(usize, DragLaw)>> = vec![None; fields.len()];
        for (k, e) in case.exchange.iter_mut().enumerate() {
            let idx = |n: &String| case_index(&fields, n);
            let (fa, fb) = (idx(&e.between[0]), idx(&e.between[1]));
            let spec_b = &case.fields[fb];
            let model = if spec_b.representation == Representation::MassPoint {
                let path = format!("exchange.{k}.mass_point");
                let alt = e.mass_point.clone().unwrap_or_else(|| PluginSpec::with(&e.model, e.params.clone()));
                let params = point_drag_params(&alt, &case.fields[fa], spec_b, &path)?;
                let model = registry::build_exchange(&alt.model, &params, &path)?;
                if e.mass_point.is_none() && !model.couples_mass_points() {
                    return Err(Error::invalid(
                        path,
                        format!(
                            "field `{}` is represented by mass points, which need a drag law, but this \
                             exchange is `{}` and names no `mass_point` model; add e.g. \
                             `mass_point: Some((model: \"cylinder\", params: (added_mass: 1.0)))` to \
                             the exchange (or set `representation: Resolved`)",
                            spec_b.name, e.model
                        ),
                    ));
                }
                let law = model.drag_law();
                if let Some(law) = &law {
                    check_point_diameters(law, spec_b, &path)?;
                }
                e.mass_point = Some(PluginSpec::with(&alt.model, model.params()));
                model
            } else {
                let model = registry::build_exchange(&e.model, &e.params, &format!("exchange.{k}"))?;
                e.params = model.params();
                model
            };
            if let Some(law) = model.drag_law() {
                partners[fb] = Some((fa, law));
            }
            if let Some(forcing) = model.immersed_boundary() {
                forced_entries.push(k);
                forcings.push(ForcedPair { fluid: fa, bodies: fb, forcing, lag: Vec::new() });
                continue;
            }
            exchanges.push(Exchange {
                fields: [idx(&e.between[0]), idx(&e.between[1])],
                model,
                integration: e.integration,
                k: FaceArrays::zeros(&grid),
            });
        }
        for (k, p) in forced_entries.iter().zip(&forcings) {
            check_forcing(&case, &fields, *k, p.fluid, p.bodies)?;
        }
        let pressure_solver = match &mut case.pressure {
            Some(p) => {
                let s = registry::build_pressure(&p.model, &p.params, "pressure")?;
                p.params = s.params();
                Some(s)
            }
            None => None,
        };
        let contact = match &mut case.contact {
            Some(c) => {
                let m = registry::build_contact(&c.model, &c.params, "contact")?;
                c.params = m.params();
                if m.needs_fluid_viscosity() && ambient_viscosity(&fields).is_none() {
                    let why = match fields.iter().find(|f| f.fills_rest) {
                        None => "the case has no ambient fluid (no field with region `Rest`)".to_string(),
                        Some(f) => {
                            format!("the ambient fluid `{}` has no Newtonian stress (e.g. \"newtonian\")", f.name)
                        }
                    };
                    return Err(Error::invalid(
                        "contact.params.lubrication",
                        format!(
                            "`{}` lubrication takes the fluid's viscosity from the case, but {why}: give the \
                             fluid a Newtonian stress, or set lubrication: false",
                            c.model
                        ),
                    ));
                }
                Some(m)
            }
            None => None,
        };
        if ranks > 1 {
            refuse_undecomposed(&case, &fields, &exchanges, &forcings, &pressure_solver, &contact, ranks)?;
        }
        let contact_sides = contact.as_ref().map(|c| (c.model(), c.keeps_bodies_off_sides()));
        // seed: fields with their own region first, then the one that fills the rest
        let mut occupied = vec![0.0; grid.n_cells()];
        let seeded: Vec<(String, bool)> = fields.iter().map(|f| (f.name.clone(), f.fills_rest)).collect();
        for (k, f) in fields.iter_mut().enumerate() {
            if f.fills_rest {
                continue;
            }
            let forced = forcings.iter().any(|p| p.bodies == k);
            let spec = &case.fields[k];
            let theta: Vec<Real> = match spec.representation {
                // (mass points are refused in 3D by the case's validation)
                #[cfg(feature = "dim2")]
                Representation::MassPoint => {
                    // on the domain's grid, then the rank's storage (halo included)
                    let domain = Grid::from_cells(grid.domain, grid.h, grid.origin);
                    let theta = mass_point_fraction(&spec.region, &domain, case.boundaries.periodic_axes());
                    let mut local = vec![0.0; grid.n_cells()];
                    grid.part.scatter(Lattice::Cell, grid.n(), &theta, &mut local);
                    local
                }
                _ => region_fraction(&spec.region, &grid).into_iter().map(|t| t * spec.volume_fraction).collect(),
            };
            // bodies under a direct forcing take no volume on the grid: the fluid fills them
            if !forced {
                // the first overfilled cell a rank owns; every rank learns whether one has
                let owned = grid.groups(Lattice::Cell);
                let first = owned.rows().flatten().find(|&c| occupied[c] + theta[c] > 1.0 + OVERLAP_TOLERANCE);
                if grid.part.any(first.is_some()) {
                    return Err(match first {
                        Some(c) => overlap(&grid, c, occupied[c] + theta[c], &case, &seeded[..k], &forcings, &f.name),
                        None => Error::invalid(
                            format!("fields.{}.region", f.name),
                            "overlaps the fields before it in another rank's block (that rank names the cell)",
                        ),
                    });
                }
                for (o, t) in occupied.iter_mut().zip(&theta) {
                    *o += t;
                }
            }
            if spec.volume_fraction != 1.0 && f.frame.is_lagrangian() {
                return Err(Error::invalid(
                    format!("fields.{}.volume_fraction", f.name),
                    "a Lagrangian field fills its region (its points carry the volume); \
                     use an Eulerian field for a partial volume fraction",
                ));
            }
            let velocity = spec
                .velocity
                .resolved(&case.boundaries, &case.domain)
                .map_err(|m| Error::invalid(format!("fields.{}.velocity", f.name), m))?;
            f.frame
                .initialize(&InitContext {
                    grid: &grid,
                    boundaries: &boundaries,
                    name: &f.name,
                    density: f.density,
                    region: &spec.region,
                    velocity: &velocity,
                    theta: (!f.frame.is_lagrangian()).then_some(&theta[..]),
                    contact: contact_sides,
                })
                .map_err(|m| Error::invalid(format!("fields.{}", f.name), m))?;
        }
        let rest: Vec<Real> = occupied.iter().map(|o| (1.0 - o).max(0.0)).collect();
        for (k, f) in fields.iter_mut().enumerate() {
            if !f.fills_rest {
                continue;
            }
            let spec = &case.fields[k];
            let velocity = spec
                .velocity
                .resolved(&case.boundaries, &case.domain)
                .map_err(|m| Error::invalid(format!("fields.{}.velocity", f.name), m))?;
            f.frame
                .initialize(&InitContext {
                    grid: &grid,
                    boundaries: &boundaries,
                    name: &f.name,
                    density: f.density,
                    region: &spec.region,
                    velocity: &velocity,
                    theta: Some(&rest),
                    contact: contact_sides,
                })
                .map_err(|m| Error::invalid(format!("fields.{}", f.name), m))?;
        }
        let initial_energy = fields.iter().map(|f| f.frame.kinetic_energy()).sum();
        let n_fields = fields.len();
        let alone = fields.iter().any(|f| f.frame.steps_alone());
        if alone {
            check_alone(&case, &fields, pressure_solver.is_some())?;
        }
        let sim = Simulation {
            gravity: vector(case.gravity),
            pressure: vec![0.0; grid.n_cells()],
            case,
            grid,
            boundaries,
            fields,
            exchanges,
            pressure_solver,
            contact,
            body_forces: vec![Vec::new(); n_fields],
            partners,
            forcings,
            body_steps: vec![Vec::new(); n_fields],
            time: 0.0,
            steps: 0,
            last: StepDiagnostics::default(),
            initial_energy,
            averages: Vec::new(),
            alone,
            grid_state_stale: false,
        };
        sim.check_time_resolution()?;
        Ok(sim)
    }

    /// Refuses a `time.end` more than [`MAX_STEPS`] first steps away (unless
    /// `time.max_steps` bounds the run): beyond that the clock t, a float, resolves Δt to
    /// worse than 2⁻⁵² × 10¹² ≈ 2e-4 of itself, and the run would not end in any wall time.
    fn check_time_resolution(&self) -> Result<()> {
        let time = &self.case.time;
        if time.max_steps.is_some() {
            return Ok(());
        }
        let (dt, limit) = self.choose_dt();
        let steps = time.end / dt;
        if steps > MAX_STEPS {
            return Err(Error::invalid(
                "time.end",
                format!(
                    "{:e}: {steps:.3e} steps of the first Δt {dt:.3e} (limited by {limit}), more than {MAX_STEPS:e}: \
                     beyond that the clock no longer resolves Δt (t + Δt rounds by more than 2e-4 Δt) and the run \
                     would not end in any wall time; shorten time.end, or bound the run with time.max_steps",
                    time.end
                ),
            ));
        }
        Ok(())
    }
}

/// The most steps of the first Δt a run may need to reach `time.end`
/// ([`Simulation::check_time_resolution`]).
pub const MAX_STEPS: Real = 1e12;

/// How far Σθ may exceed 1 in a cell before the first step: the fields' regions are
/// sampled on 8 × 8 points a cell, so two regions that only touch can share one sample.
const OVERLAP_TOLERANCE: Real = 0.02;

/// The refusal of a cell that the fields' regions fill beyond its volume: `name` is the
/// field that overfilled it, `before` the fields seeded before it (those with a share of
/// the cell are named).
fn overlap(
    grid: &Grid,
    c: usize,
    sum: Real,
    case: &Case,
    before: &[(String, bool)],
    forcings: &[ForcedPair],
    name: &str,
) -> Error {
    let x = grid.position(Lattice::Cell, grid.node(Lattice::Cell, c));
    let others: Vec<String> = before
        .iter()
        .enumerate()
        .filter(|(k, (_, rest))| !rest && !forcings.iter().any(|p| p.bodies == *k))
        .filter(|(k, _)| case.fields[*k].region.contains_point(x))
        .map(|(_, (name, _))| format!("`{name}`"))
        .collect();
    let with = if others.is_empty() { "the fields before it".to_string() } else { others.join(", ") };
    Error::invalid(
        format!("fields.{name}.region"),
        format!(
            "overlaps {with}: the cell at ({:.6}, {:.6}) would hold Σθ = {sum:.4} of its volume before the \
             first step. The regions of the fields (other than the one with region `Rest`) must not overlap, \
             and their volume fractions must sum to at most 1; move or shrink one of the regions, or lower \
             a volume_fraction",
            x.x, x.y
        ),
    )
}

/// The refusal of a case that does not run on `ranks` ranks: the first plugin (frame,
/// stress, exchange, pressure solver, contact model) that is not decomposed, named with its
/// key in the case.
fn refuse_undecomposed(
    case: &Case,
    fields: &[Field],
    exchanges: &[Exchange],
    forcings: &[ForcedPair],
    pressure: &Option<Box<dyn PressureSolver>>,
    contact: &Option<Box<dyn ContactModel>>,
    ranks: usize,
) -> Result<()> {
    let refuse = |key: String, what: String| {
        Err(Error::invalid(
            key,
            format!(
                "{what} does not run on several ranks yet, and this run has {ranks}: run the case on one rank \
                 (without mpirun, or `mpirun -np 1`), or change the plugin. Decomposed so far (issue 19): in 2D, \
                 Eulerian fields, Lagrangian fields (material or resolved bodies) on the staggered grid and mass \
                 points, with `newtonian`, `linear_elastic`, `neo_hookean`, `weakly_compressible` or `rigid` \
                 stress, the `constant` and `no_slip` exchanges and the drag laws, the `repulsion` and `dem` \
                 contact models and the shipped pressure solvers (docs/design/mpi.md)"
            ),
        ))
    };
    for f in fields {
        if !f.frame.decomposed() {
            return refuse(format!("fields.{}.frame", f.name), format!("the `{}` frame", f.frame.model()));
        }
        for (k, s) in f.stress.iter().enumerate() {
            if !s.decomposed() {
                return refuse(format!("fields.{}.stress.{k}", f.name), format!("the `{}` stress", s.model()));
            }
        }
    }
    if let Some(e) = exchanges.iter().find(|e| !e.model.decomposed()) {
        let k = case.exchange.iter().position(|x| x.model == e.model.model()).unwrap_or(0);
        return refuse(format!("exchange.{k}"), format!("the `{}` exchange", e.model.model()));
    }
    if let Some(p) = forcings.first() {
        return refuse(
            format!("fields.{}", case.fields[p.bodies].name),
            "the direct forcing of bodies (`direct_forcing`)".into(),
        );
    }
    if let Some(p) = pressure.as_ref().filter(|p| !p.decomposed()) {
        return refuse("pressure".into(), format!("the `{}` pressure solver", p.model()));
    }
    if let Some(c) = contact.as_ref().filter(|c| !c.decomposed()) {
        return refuse("contact".into(), format!("the `{}` contact model", c.model()));
    }
    Ok(())
}
