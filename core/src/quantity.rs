//! Output quantities: one registry of named quantities that snapshots and pictures take
//! their arrays from, computed through frame-independent views of the state.
//!
//! A quantity lives on the cells, for the mixture of all fields and/or for one field
//! ([`Compute::Cells`]), or on a field's points ([`Compute::Points`]: material points, or
//! the one point per body of a mass-point field). Cell quantities are computed from a
//! [`Sample`]: every field's volume fraction θ and face velocities, the same whatever the
//! frame. Point quantities are computed from a frame's [`PointSet`]
//! ([`crate::plugin::Frame::points`]). No writer looks at a concrete frame type.
//!
//! `multifield quantities` lists the registry. A plugin crate adds a quantity with
//! `inventory::submit!` of a [`Quantity`] (see `docs/plugins.md`), and it is then a name
//! that snapshots and pictures accept like a shipped one.
//!
//! Arrays are row-major over the cells `(NY, NX)` (cell `(i, j)` at `j·NX + i`) or over
//! the points; a vector is three components per cell or point with z = 0.

#[cfg(feature = "dim2")]
use crate::case::Representation;
use crate::grid::{FaceVelocity, Grid, Lattice};
use crate::math::{Index, Matrix, Real, Vector, AXES, DIM};
use crate::simulation::{region_fraction, Simulation};

/// How a picture colours a quantity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colours {
    /// A signed quantity on a diverging map symmetric about 0, the range ± the 99.5th
    /// percentile of |x| (so that thin layers do not wash out the rest).
    Diverging,
    /// A sequential map from 0 to the largest value (a magnitude).
    FromZero,
    /// A sequential map from 0 to 1 (a fraction).
    Fraction,
    /// A sequential map from the smallest to the largest value.
    Range,
}

/// How a quantity is computed.
#[derive(Clone, Copy)]
pub enum Compute {
    /// On the cells: for the mixture and/or for one field (by its index).
    Cells {
        /// The mixture's array, if the quantity has one.
        mixture: Option<fn(&Sample) -> Vec<Real>>,
        /// One field's array, if the quantity has one.
        field: Option<fn(&Sample, usize) -> Vec<Real>>,
    },
    /// On a field's points.
    Points(fn(&PointSet) -> Vec<Real>),
}

/// One registered output quantity.
pub struct Quantity {
    /// Its name in case files (`output.snapshots`, `output.pictures`) and in snapshots.
    pub name: &'static str,
    /// 1 (a scalar) or 3 (a vector, z = 0).
    pub components: usize,
    /// Units, in the case's units ("length/time", "-", …).
    pub units: &'static str,
    /// What it is, with its formula.
    pub description: &'static str,
    /// How a picture colours it.
    pub colours: Colours,
    /// How it is computed.
    pub compute: Compute,
}

inventory::collect!(Quantity);

impl Quantity {
    /// Whether it has a mixture form on the cells.
    pub fn has_mixture(&self) -> bool {
        matches!(self.compute, Compute::Cells { mixture: Some(_), .. })
    }
    /// Whether it has a per-field form on the cells.
    pub fn has_field(&self) -> bool {
        matches!(self.compute, Compute::Cells { field: Some(_), .. })
    }
    /// Whether it lives on points.
    pub fn on_points(&self) -> bool {
        matches!(self.compute, Compute::Points(_))
    }
    /// Where it is defined, for listings: "mixture, field", "field", "points", ….
    pub fn places(&self) -> String {
        let mut v = Vec::new();
        if self.has_mixture() {
            v.push("mixture");
        }
        if self.has_field() {
            v.push("field");
        }
        if self.on_points() {
            v.push("points");
        }
        v.join(", ")
    }
}

/// Where a quantity is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// The mixture's cells.
    Mixture,
    /// One field's cells.
    Field,
    /// A field's points.
    Points,
}

impl Place {
    /// The name of the place in messages.
    pub fn name(self) -> &'static str {
        match self {
            Place::Mixture => "the mixture's cells",
            Place::Field => "a field's cells",
            Place::Points => "points",
        }
    }
    fn has(self, q: &Quantity) -> bool {
        match self {
            Place::Mixture => q.has_mixture(),
            Place::Field => q.has_field(),
            Place::Points => q.on_points(),
        }
    }
}

/// Every registered quantity, sorted by name (cells before points).
pub fn quantities() -> Vec<&'static Quantity> {
    let mut v: Vec<_> = inventory::iter::<Quantity>.into_iter().collect();
    v.sort_by_key(|q| (q.name, q.on_points()));
    v
}

/// The quantity `name` defined at `place`; an unknown name lists the valid ones.
pub fn find(name: &str, place: Place) -> Result<&'static Quantity, String> {
    let all: Vec<_> = quantities().into_iter().filter(|q| place.has(q)).collect();
    all.iter().find(|q| q.name == name).copied().ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|q| q.name).collect();
        let hint = crate::error::did_you_mean(name, names.iter().copied());
        format!(
            "no quantity `{name}` on {}; the choices are: {}{hint} (`multifield quantities` lists them with their units)",
            place.name(),
            names.join(", ")
        )
    })
}

/// The points of one field, whatever its frame: material points, or one point per body
/// of a mass-point field.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointSet {
    /// Positions.
    pub position: Vec<Vector>,
    /// Velocities.
    pub velocity: Vec<Vector>,
    /// Current volumes (area × unit depth).
    pub volume: Vec<Real>,
    /// Masses.
    pub mass: Vec<Real>,
    /// Cauchy stresses (zero where the frame keeps none).
    pub stress: Vec<Matrix>,
    /// Index of each point's body in [`PointSet::bodies`], −1 for none.
    pub body: Vec<i64>,
    /// Names of the field's bodies (empty when it has none).
    pub bodies: Vec<String>,
    /// The per-point state of each of the field's stress models, in the order of its
    /// `stress` list (`StressModel::point_state` names k components: k values per point,
    /// point p's at `[k p, k (p + 1))`); empty when no model keeps any.
    pub model_state: Vec<Vec<Real>>,
}

impl PointSet {
    /// The per-point state of the field's stress `models`, one array per component, named
    /// `<model>_<component>`.
    pub fn named_state(&self, models: &[Box<dyn crate::plugin::StressModel>]) -> Vec<(String, Vec<Real>)> {
        let mut out = Vec::new();
        for (m, state) in models.iter().zip(&self.model_state) {
            let names = m.point_state();
            let k = names.len();
            if k == 0 || state.len() != k * self.len() {
                continue;
            }
            for (c, name) in names.iter().enumerate() {
                out.push((format!("{}_{name}", m.model()), state.iter().skip(c).step_by(k).copied().collect()));
            }
        }
        out
    }
    /// Number of points.
    pub fn len(&self) -> usize {
        self.position.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }
}

/// One field's cell state in a [`Sample`].
#[derive(Clone, Debug)]
pub struct FieldCells {
    /// Volume fraction θ per cell.
    pub theta: Vec<Real>,
    /// Face velocities.
    pub faces: FaceVelocity,
    /// Cell-centred velocity (the mean of each component's two faces), by component.
    pub velocity: [Vec<Real>; DIM],
}

/// The state every cell quantity is computed from: each field's θ and velocity, and
/// their mixture.
///
/// After a step these are the fields' grid states as the step left them (`FieldState`:
/// the corrected velocity; θ from the step). Before the first step no step has built that
/// state, so [`Sample::of`] reconstructs it as the run starts from it: θ from the regions
/// (the field of region `Rest` takes what the others leave), an Eulerian field's velocity
/// from its initial velocity on the faces, a field's points' velocity by a mass-weighted
/// linear (cloud-in-cell) average onto the faces.
pub struct Sample<'a> {
    /// The simulation.
    pub sim: &'a Simulation,
    /// Each field's cells, in the case's order.
    pub fields: Vec<FieldCells>,
    /// Σθ over the fields per cell.
    pub theta: Vec<Real>,
    /// The mixture velocity Σθu / Σθ at cell centres (0 where Σθ = 0), by component.
    pub velocity: [Vec<Real>; DIM],
}

impl<'a> Sample<'a> {
    /// The sample of the simulation's current state.
    pub fn of(sim: &'a Simulation) -> Sample<'a> {
        let g = &sim.grid;
        let n = g.n_cells();
        let fields: Vec<FieldCells> = grid_states(sim)
            .into_iter()
            .map(|(theta, faces)| {
                let velocity = cell_velocity(g, &faces);
                FieldCells { theta, faces, velocity }
            })
            .collect();
        let mut theta = vec![0.0; n];
        let mut flux: [Vec<Real>; DIM] = std::array::from_fn(|_| vec![0.0; n]);
        for f in &fields {
            for c in 0..n {
                theta[c] += f.theta[c];
                for a in AXES {
                    flux[a][c] += f.theta[c] * f.velocity[a][c];
                }
            }
        }
        let mut velocity: [Vec<Real>; DIM] = std::array::from_fn(|_| vec![0.0; n]);
        for c in 0..n {
            if theta[c] > 0.0 {
                for a in AXES {
                    velocity[a][c] = flux[a][c] / theta[c];
                }
            }
        }
        Sample { sim, fields, theta, velocity }
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.sim.grid
    }

    /// Whether the domain is periodic along each axis.
    pub fn periodic(&self) -> [bool; DIM] {
        self.sim.boundaries.periodic_axes()
    }

    /// The cell array of `q` for the mixture (`field` None) or for field `field`; None
    /// when the quantity has no such form.
    pub fn cells(&self, q: &Quantity, field: Option<usize>) -> Option<Vec<Real>> {
        match (q.compute, field) {
            (Compute::Cells { mixture: Some(m), .. }, None) => Some(m(self)),
            (Compute::Cells { field: Some(f), .. }, Some(k)) => Some(f(self, k)),
            _ => None,
        }
    }
}

/// The points of field `field` and the array of `q` on them; None when the field has no
/// points or `q` is not a point quantity.
pub fn points(sim: &Simulation, field: usize, q: &Quantity) -> Option<Vec<Real>> {
    let Compute::Points(f) = q.compute else { return None };
    sim.fields.get(field)?.frame.points().map(|p| f(&p))
}

/// Linear (cloud-in-cell) mass-weighted average of point velocities onto the faces (of
/// the storage of `grid`: on a rank's block, the points of every rank reaching it).
#[cfg(feature = "dim2")]
fn deposit_velocity(grid: &Grid, points: &PointSet) -> FaceVelocity {
    let mut vel = FaceVelocity::zeros(grid);
    for (lattice, comp) in [(Lattice::XFace, 0), (Lattice::YFace, 1)] {
        let (cols, rows) = grid.lattice_shape(lattice);
        let (ox, oy) = grid.lattice_offset(lattice);
        let mut num = vec![0.0; cols * rows];
        let mut den = vec![0.0; cols * rows];
        for p in 0..points.len() {
            let fx = (points.position[p].x - grid.origin.x) / grid.h - ox;
            let fy = (points.position[p].y - grid.origin.y) / grid.h - oy;
            let (i0, j0) = (fx.floor(), fy.floor());
            let (a, b) = (fx - i0, fy - j0);
            for (di, wx) in [(0, 1.0 - a), (1, a)] {
                for (dj, wy) in [(0, 1.0 - b), (1, b)] {
                    // the storage's node (on a rank's block, the domain's less its start)
                    let (i, j) = (i0 as i64 + di - grid.start[0] as i64, j0 as i64 + dj - grid.start[1] as i64);
                    if i < 0 || j < 0 || i >= cols as i64 || j >= rows as i64 {
                        continue;
                    }
                    let k = i as usize + j as usize * cols;
                    let w = wx * wy * points.mass[p];
                    num[k] += w * points.velocity[p][comp];
                    den[k] += w;
                }
            }
        }
        let out = if comp == 0 { &mut vel.u } else { &mut vel.v };
        for (o, (n, d)) in out.iter_mut().zip(num.iter().zip(&den)) {
            *o = if *d > 0.0 { n / d } else { 0.0 };
        }
    }
    vel
}

/// The fields' θ and face velocities: the grid state after a step, reconstructed from the
/// initial condition before the first one ([`Sample`]).
pub(crate) fn grid_states(sim: &Simulation) -> Vec<(Vec<Real>, FaceVelocity)> {
    if sim.steps > 0 {
        return sim.fields.iter().map(|f| (f.state.theta.clone(), f.state.velocity.clone())).collect();
    }
    let g = &sim.grid;
    let origin: [Real; DIM] = g.origin.into();
    let mut occupied = vec![0.0; g.n_cells()];
    let mut out: Vec<(Vec<Real>, FaceVelocity)> = Vec::new();
    for (f, spec) in sim.fields.iter().zip(&sim.case.fields) {
        let mut theta: Vec<Real> = if f.fills_rest {
            Vec::new()
        } else {
            region_fraction(&spec.region, g).into_iter().map(|t| t * spec.volume_fraction).collect()
        };
        // a rank's halo as its neighbours' (the initial state at the unwrapped positions
        // of a periodic side's halo is not the owners' to the bit); every rank calls this
        if !f.fills_rest {
            g.exchange(&mut [(Lattice::Cell, &mut theta)]);
        }
        for (o, t) in occupied.iter_mut().zip(&theta) {
            *o += t;
        }
        let mut vel = match f.frame.points() {
            // material points sample the field; a mass point stands for a whole body
            #[cfg(feature = "dim2")]
            Some(p) if f.frame.representation() == Representation::Resolved => deposit_velocity(g, &p),
            _ => {
                // validated: an unresolvable `FromInflow` does not reach a simulation
                let velocity = spec.velocity.resolved(&sim.case.boundaries, &sim.case.domain).unwrap_or_default();
                let mut vel = FaceVelocity::zeros(g);
                for a in AXES {
                    let lattice = Lattice::face(a);
                    for (k, at) in g.nodes(lattice) {
                        vel[a][k] = velocity.at(g.position(lattice, at).into(), origin)[a];
                    }
                }
                vel
            }
        };
        sim.boundaries.enforce(g, &mut vel);
        g.exchange_faces(&mut vel);
        out.push((theta, vel));
    }
    for ((theta, _), f) in out.iter_mut().zip(&sim.fields) {
        if f.fills_rest {
            *theta = occupied.iter().map(|o| (1.0 - o).max(0.0)).collect();
        }
    }
    out
}

/// Cell-centred velocity: the mean of the two faces of each component.
fn cell_velocity(grid: &Grid, vel: &FaceVelocity) -> [Vec<Real>; DIM] {
    let n = grid.n_cells();
    let mut out: [Vec<Real>; DIM] = std::array::from_fn(|_| vec![0.0; n]);
    if AXES.iter().any(|&a| vel[a].len() != grid.n_faces(a)) {
        return out;
    }
    for (c, at) in grid.nodes(Lattice::Cell) {
        for a in AXES {
            let lattice = Lattice::face(a);
            let mut hi = at;
            hi[a] += 1;
            out[a][c] = 0.5 * (vel[a][grid.index(lattice, at)] + vel[a][grid.index(lattice, hi)]);
        }
    }
    out
}

/// Neighbours `(lo, hi)` of index `k` in `0..n` and the spacing between them in cells:
/// central inside, one-sided at an edge, wrapped when periodic.
fn stencil(k: usize, n: usize, periodic: bool) -> (usize, usize, Real) {
    if n < 2 {
        (k, k, 1.0)
    } else if periodic {
        ((k + n - 1) % n, (k + 1) % n, 2.0)
    } else if k == 0 {
        (0, 1, 1.0)
    } else if k == n - 1 {
        (n - 2, n - 1, 1.0)
    } else {
        (k - 1, k + 1, 2.0)
    }
}

#[cfg(feature = "dim2")]
/// The velocity gradient `[[∂u/∂x, ∂u/∂y], [∂v/∂x, ∂v/∂y]]` at the centre of cell
/// `(i, j)` of a cell-centred velocity given by `at(i, j)`: central differences,
/// one-sided (first order) at a domain edge, wrapped across a periodic side; 0 along an
/// axis of one cell.
pub fn velocity_gradient_at(
    grid: &Grid,
    periodic: [bool; 2],
    at: impl Fn(usize, usize) -> [Real; 2],
    i: usize,
    j: usize,
) -> [[Real; 2]; 2] {
    let h = grid.h;
    let (il, ih, di) = stencil(i, grid.nx, periodic[0]);
    let (jl, jh, dj) = stencil(j, grid.ny, periodic[1]);
    let mut g = [[0.0; 2]; 2];
    for (c, row) in g.iter_mut().enumerate() {
        if il != ih {
            row[0] = (at(ih, j)[c] - at(il, j)[c]) / (di * h);
        }
        if jl != jh {
            row[1] = (at(i, jh)[c] - at(i, jl)[c]) / (dj * h);
        }
    }
    g
}

#[cfg(feature = "dim2")]
/// Vorticity ∂v/∂x − ∂u/∂y at the centre of cell `(i, j)` of a cell-centred velocity given
/// by `at(i, j)` ([`velocity_gradient_at`]). Every vorticity of the code (snapshots,
/// pictures, the mass-point lift) is this one.
pub fn vorticity_at(
    grid: &Grid,
    periodic: [bool; 2],
    at: impl Fn(usize, usize) -> [Real; 2],
    i: usize,
    j: usize,
) -> Real {
    let g = velocity_gradient_at(grid, periodic, at, i, j);
    g[1][0] - g[0][1]
}

#[cfg(feature = "dim2")]
/// Vorticity of a cell-centred velocity `[u, v]` at every cell ([`vorticity_at`]).
pub fn vorticity(grid: &Grid, periodic: [bool; 2], velocity: &[Vec<Real>; 2]) -> Vec<Real> {
    let mut out = vec![0.0; grid.n_cells()];
    let at = |i, j| {
        let c = grid.cell(i, j);
        [velocity[0][c], velocity[1][c]]
    };
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            out[grid.cell(i, j)] = vorticity_at(grid, periodic, at, i, j);
        }
    }
    out
}

/// Vorticity ∇ × u of a cell-centred velocity at every cell, as three components per
/// cell, each derivative by central differences as in 2D ([`velocity_gradient`]).
#[cfg(feature = "dim3")]
pub fn vorticity(grid: &Grid, periodic: [bool; DIM], velocity: &[Vec<Real>; DIM]) -> Vec<Real> {
    let mut out = Vec::with_capacity(3 * grid.n_cells());
    for (_, at) in grid.nodes(Lattice::Cell) {
        let g = velocity_gradient(grid, periodic, velocity, at);
        out.extend([g[(2, 1)] - g[(1, 2)], g[(0, 2)] - g[(2, 0)], g[(1, 0)] - g[(0, 1)]]);
    }
    out
}

/// The velocity gradient `g[(c, a)] = ∂u_c/∂x_a` at the centre of cell `at` of a
/// cell-centred velocity: central differences, one-sided (first order) at a domain edge,
/// wrapped across a periodic side; 0 along an axis of one cell.
#[cfg(feature = "dim3")]
pub fn velocity_gradient(grid: &Grid, periodic: [bool; DIM], velocity: &[Vec<Real>; DIM], at: Index) -> Matrix {
    let n = grid.n();
    let mut g = Matrix::zeros();
    for a in AXES {
        let (lo, hi, d) = stencil(at[a], n[a], periodic[a]);
        if lo == hi {
            continue;
        }
        let (mut l, mut r) = (at, at);
        (l[a], r[a]) = (lo, hi);
        let (l, r) = (grid.index(Lattice::Cell, l), grid.index(Lattice::Cell, r));
        for c in AXES {
            g[(c, a)] = (velocity[c][r] - velocity[c][l]) / (d * grid.h);
        }
    }
    g
}

/// The number of components of the vorticity: its z component in 2D, the vector in 3D.
pub const VORTICITY_COMPONENTS: usize = if DIM == 2 { 1 } else { 3 };

/// Divergence Σ ∂u_a/∂x_a at the cell centres of the face fluxes `flux(a, face index)`
/// (the MAC divergence).
fn face_divergence(grid: &Grid, flux: impl Fn(usize, Index) -> Real) -> Vec<Real> {
    let mut out = vec![0.0; grid.n_cells()];
    for (c, at) in grid.nodes(Lattice::Cell) {
        let faces = |a: usize| {
            let mut hi = at;
            hi[a] += 1;
            (flux(a, at), flux(a, hi))
        };
        // ((x_hi − x_lo) + y_hi) − y_lo (+ z_hi − z_lo)
        let (lo, hi) = faces(0);
        let mut d = hi - lo;
        for a in 1..DIM {
            let (lo, hi) = faces(a);
            d = d + hi - lo;
        }
        out[c] = d / grid.h;
    }
    out
}

/// Three components per cell of a cell-centred vector (z = 0 in 2D).
fn vector(v: &[Vec<Real>; DIM]) -> Vec<Real> {
    (0..v[0].len()).flat_map(|c| std::array::from_fn::<Real, 3, _>(|a| if a < DIM { v[a][c] } else { 0.0 })).collect()
}

fn speed(v: &[Vec<Real>; DIM]) -> Vec<Real> {
    #[cfg(feature = "dim2")]
    return v[0].iter().zip(&v[1]).map(|(u, v)| u.hypot(*v)).collect();
    #[cfg(feature = "dim3")]
    return (0..v[0].len()).map(|c| (v[0][c] * v[0][c] + v[1][c] * v[1][c] + v[2][c] * v[2][c]).sqrt()).collect();
}

/// θ of the face `at` normal to `axis`: the mean of the two cells beside it (the one cell
/// at a domain edge).
pub(crate) fn face_theta(grid: &Grid, theta: &[Real], axis: usize, at: Index) -> Real {
    let cell = |i: usize| {
        let mut c = at;
        c[axis] = i;
        theta[grid.index(Lattice::Cell, c)]
    };
    let i = at[axis];
    match (i.checked_sub(1), (i < grid.n()[axis]).then_some(i)) {
        (Some(a), Some(b)) => 0.5 * (cell(a) + cell(b)),
        (Some(c), None) | (None, Some(c)) => cell(c),
        (None, None) => 0.0,
    }
}

fn mixture_divergence(s: &Sample) -> Vec<Real> {
    let g = s.grid();
    face_divergence(g, |a, at| {
        let face = g.index(Lattice::face(a), at);
        s.fields.iter().map(|f| face_theta(g, &f.theta, a, at) * f.faces[a][face]).sum()
    })
}

fn field_divergence(s: &Sample, k: usize) -> Vec<Real> {
    let g = s.grid();
    let f = &s.fields[k];
    face_divergence(g, |a, at| f.faces[a][g.index(Lattice::face(a), at)])
}

/// Three components per point (z = 0 in 2D).
fn points_vector(v: &[Vector]) -> Vec<Real> {
    v.iter().flat_map(|x| std::array::from_fn::<Real, 3, _>(|a| if a < DIM { x[a] } else { 0.0 })).collect()
}

inventory::submit! { Quantity {
    name: "pressure",
    components: 1,
    units: "force/area",
    description: "the pressure all fields share (0 until the first projection)",
    colours: Colours::Range,
    compute: Compute::Cells { mixture: Some(|s| s.sim.pressure.clone()), field: None },
}}

inventory::submit! { Quantity {
    name: "velocity",
    components: 3,
    units: "length/time",
    description: "cell-centred velocity, the mean of each component's two faces; the mixture's is Σθu / Σθ (0 where Σθ = 0)",
    colours: Colours::FromZero,
    compute: Compute::Cells {
        mixture: Some(|s| vector(&s.velocity)),
        field: Some(|s, k| vector(&s.fields[k].velocity)),
    },
}}

inventory::submit! { Quantity {
    name: "speed",
    components: 1,
    units: "length/time",
    description: "|u| of the cell-centred velocity",
    colours: Colours::FromZero,
    compute: Compute::Cells {
        mixture: Some(|s| speed(&s.velocity)),
        field: Some(|s, k| speed(&s.fields[k].velocity)),
    },
}}

inventory::submit! { Quantity {
    name: "vorticity",
    components: VORTICITY_COMPONENTS,
    units: "1/time",
    #[cfg(feature = "dim2")]
    description: "∂v/∂x − ∂u/∂y of the cell-centred velocity by central differences (one-sided at a domain edge, wrapped across a periodic side)",
    #[cfg(feature = "dim3")]
    description: "∇ × u (x, y, z components) of the cell-centred velocity by central differences (one-sided at a domain edge, wrapped across a periodic side)",
    colours: Colours::Diverging,
    compute: Compute::Cells {
        mixture: Some(|s| vorticity(s.grid(), s.periodic(), &s.velocity)),
        field: Some(|s, k| vorticity(s.grid(), s.periodic(), &s.fields[k].velocity)),
    },
}}

inventory::submit! { Quantity {
    name: "divergence",
    components: 1,
    units: "1/time",
    description: "∇·u of the face velocities (MAC); the mixture's is ∇·Σθu with θ at a face the mean of its two cells",
    colours: Colours::Diverging,
    compute: Compute::Cells { mixture: Some(mixture_divergence), field: Some(field_divergence) },
}}

inventory::submit! { Quantity {
    name: "theta",
    components: 1,
    units: "-",
    description: "volume fraction θ of the field",
    colours: Colours::Fraction,
    compute: Compute::Cells { mixture: None, field: Some(|s, k| s.fields[k].theta.clone()) },
}}

inventory::submit! { Quantity {
    name: "density",
    components: 1,
    units: "mass/volume",
    description: "bulk density θρ⁰ of the field; the mixture's is Σθρ⁰",
    colours: Colours::FromZero,
    compute: Compute::Cells {
        mixture: Some(|s| {
            let mut out = vec![0.0; s.theta.len()];
            for (f, cells) in s.sim.fields.iter().zip(&s.fields) {
                for (o, t) in out.iter_mut().zip(&cells.theta) {
                    *o += t * f.density;
                }
            }
            out
        }),
        field: Some(|s, k| s.fields[k].theta.iter().map(|t| t * s.sim.fields[k].density).collect()),
    },
}}

inventory::submit! { Quantity {
    name: "position",
    components: 3,
    units: "length",
    description: "positions of the points",
    colours: Colours::Range,
    compute: Compute::Points(|p| points_vector(&p.position)),
}}

inventory::submit! { Quantity {
    name: "velocity",
    components: 3,
    units: "length/time",
    description: "velocities of the points",
    colours: Colours::FromZero,
    compute: Compute::Points(|p| points_vector(&p.velocity)),
}}

inventory::submit! { Quantity {
    name: "volume",
    components: 1,
    units: "volume",
    description: "current volume of each point, det F · V⁰ (area × unit depth)",
    colours: Colours::FromZero,
    compute: Compute::Points(|p| p.volume.clone()),
}}

inventory::submit! { Quantity {
    name: "mass",
    components: 1,
    units: "mass",
    description: "mass of each point",
    colours: Colours::FromZero,
    compute: Compute::Points(|p| p.mass.clone()),
}}

inventory::submit! { Quantity {
    name: "stress",
    components: 3,
    units: "force/area",
    description: "Cauchy stress σxx, σyy, σxy of each point (0 where the frame keeps none)",
    colours: Colours::Range,
    compute: Compute::Points(|p| p.stress.iter().flat_map(|s| [s[(0, 0)], s[(1, 1)], s[(0, 1)]]).collect()),
}}
