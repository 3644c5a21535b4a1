//! What the drag laws share (`stokes`, `schiller_naumann`, `cylinder`): a dispersed field
//! of particles of diameter d in a continuous fluid, and how a drag law becomes K.
//!
//! **A drag law is one correlation.** A law implements [`DragCorrelation`]: its drag
//! coefficient as C_D·Re = G(Re, θ_f), its particle [`Shape`], its range of Re and its
//! citation; [`Drag<C>`] turns any correlation into an exchange model (parameters,
//! validation, K on every face, the [`DragLaw`] of mass points). A new law is one file:
//!
//! ```ignore
//! #[derive(Clone, Copy, Debug, Default)]
//! pub struct MyLaw;
//! impl DragCorrelation for MyLaw {
//!     const NAME: &'static str = "my_law";
//!     const SUMMARY: &'static str = "my drag on spheres: CD = 24/Re (1 + 0.1 Re^0.75)";
//!     const CITATION: &'static str = "Author (year), Journal vol, page";
//!     const SHAPE: Shape = Shape::Sphere;
//!     const VALID_RE: (Real, Real) = (0.0, 800.0);
//!     fn cd_re(re: Real, _theta_f: Real) -> Real {
//!         24.0 * (1.0 + 0.1 * re.powf(0.75))
//!     }
//! }
//! multifield_core::register!(Exchange, "my_law", Drag<MyLaw>, MyLaw::SUMMARY, Drag::<MyLaw>::PARAMS);
//! ```
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
//! **On a MAC face** K uses the face's θ_f (`theta_face` of the fluid, floored at
//! [`THETA_FLOOR`]) and, in the slip-dependent laws, |Δu| from the face's normal slip and the
//! tangential slip averaged from the four nearest faces of the other lattice (one-sided
//! at the domain edges). Re is floored at [`RE_FLOOR`] (the Re → 0 limit; Lamb's law
//! needs it, since there K → 0 logarithmically).

use multifield_core::grid::{FaceArrays, Grid};
use multifield_core::math::{Real, AXES};
use multifield_core::plugin::{DragLaw, ExchangeContext, ExchangeModel};
use multifield_core::registry::{params_value, ParamDoc};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::marker::PhantomData;

/// The shape of the particles, which sets the ratio of projected area to volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Spheres: A = πd²/4, V_p = πd³/6.
    Sphere,
    /// Circular cylinders per unit length (2D disks): A = d, V_p = πd²/4.
    Cylinder,
}

impl Shape {
    /// c in K = c G(Re) μ / (d² θ_f): 3/4 for spheres, 2/π for cylinders.
    pub fn factor(self) -> Real {
        match self {
            Shape::Sphere => 0.75,
            Shape::Cylinder => 2.0 / std::f64::consts::PI,
        }
    }
}

/// A drag law as a correlation: the drag coefficient of one particle, as C_D·Re (finite as
/// Re → 0), and where it comes from. [`Drag<C>`] makes it an exchange model.
pub trait DragCorrelation: Send + Sync + 'static {
    /// Registered name (the name given to [`multifield_core::register!`]).
    const NAME: &'static str;
    /// One line for `multifield plugins`: the law and its formula.
    const SUMMARY: &'static str;
    /// Where the correlation is published.
    const CITATION: &'static str;
    /// The particles' shape.
    const SHAPE: Shape;
    /// The Reynolds numbers Re = ρ_f |Δu| d / μ where the law holds (mass points warn
    /// outside them).
    const VALID_RE: (Real, Real);
    /// Whether the law offers Di Felice's dense-suspension option (`di_felice`).
    const DI_FELICE: bool = true;
    /// `Some(G)` when C_D·Re is the constant G (Stokes: 24): K is then independent of the
    /// slip, K = (c G) μ / (d² θ_f), and the slip speeds are not computed.
    const CONSTANT_CD_RE: Option<Real> = None;
    /// C_D·Re at the Reynolds number `re` (≥ [`RE_FLOOR`]) and the fluid fraction
    /// `theta_f` (≥ [`THETA_FLOOR`]; for a law with a voidage function of its own).
    fn cd_re(re: Real, theta_f: Real) -> Real;
}

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
/// `g` is C_D·Re as a function of Re and θ_f, `slip` = |Δu|, `rho_f` the fluid's material
/// density.
#[allow(clippy::too_many_arguments)]
pub fn drag_coefficient(
    c: Real,
    g: impl Fn(Real, Real) -> Real,
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
        scale * g(re_s, theta_f) * di_felice_factor(theta_f, re_s)
    } else {
        scale * g(re.max(RE_FLOOR), theta_f) / theta_f
    }
}

/// The cells on either side of face `i` along an axis of `n` cells (`n` > 0): `i − 1` and
/// `i`, wrapped where the storage wraps (`periodic`: faces 0 and n, the same face, both
/// take cells n − 1 and 0), else clamped to the storage at its ends.
#[inline]
fn sides(i: usize, n: usize, periodic: bool) -> [usize; 2] {
    if periodic {
        [(i + n - 1) % n, i % n]
    } else {
        [i.saturating_sub(1), i.min(n - 1)]
    }
}

/// Slip speed |u_a − u_b| on x-face `(i, j)`: its normal component and the tangential one
/// averaged from the four nearest y-faces (i−1, j), (i, j), (i−1, j+1), (i, j+1), the
/// columns wrapped across a periodic side and clamped at the others ([`sides`]; `g.nx`,
/// `g.ny` > 0).
#[cfg(feature = "dim2")]
#[inline]
fn xface_slip(ctx: &ExchangeContext, g: &Grid, i: usize, j: usize) -> Real {
    let (a, b) = (&ctx.a.velocity, &ctx.b.velocity);
    let dv = |f: usize| a.v[f] - b.v[f];
    let [c0, c1] = sides(i, g.nx, ctx.periodic[0]);
    let t = 0.25 * (dv(g.yface(c0, j)) + dv(g.yface(c1, j)) + dv(g.yface(c0, j + 1)) + dv(g.yface(c1, j + 1)));
    let f = g.xface(i, j);
    (a.u[f] - b.u[f]).hypot(t)
}

/// Slip speed on y-face `(i, j)`, the tangential part from the x-faces (i, j−1), (i+1, j−1),
/// (i, j), (i+1, j), the rows wrapped or clamped as [`xface_slip`]'s columns.
#[cfg(feature = "dim2")]
#[inline]
fn yface_slip(ctx: &ExchangeContext, g: &Grid, i: usize, j: usize) -> Real {
    let (a, b) = (&ctx.a.velocity, &ctx.b.velocity);
    let du = |f: usize| a.u[f] - b.u[f];
    let [r0, r1] = sides(j, g.ny, ctx.periodic[1]);
    let t = 0.25 * (du(g.xface(i, r0)) + du(g.xface(i + 1, r0)) + du(g.xface(i, r1)) + du(g.xface(i + 1, r1)));
    let f = g.yface(i, j);
    (a.v[f] - b.v[f]).hypot(t)
}

/// Slip speed |u_a − u_b| on every x-face and y-face ([`xface_slip`], [`yface_slip`]).
#[cfg(feature = "dim2")]
pub fn face_slip_speeds(ctx: &ExchangeContext, sx: &mut Vec<Real>, sy: &mut Vec<Real>) {
    let g: &Grid = ctx.grid;
    sx.clear();
    sx.resize(g.n_xfaces(), 0.0);
    sy.clear();
    sy.resize(g.n_yfaces(), 0.0);
    if g.nx == 0 || g.ny == 0 {
        return;
    }
    for j in 0..g.ny {
        for i in 0..=g.nx {
            sx[g.xface(i, j)] = xface_slip(ctx, g, i, j);
        }
    }
    for j in 0..=g.ny {
        for i in 0..g.nx {
            sy[g.yface(i, j)] = yface_slip(ctx, g, i, j);
        }
    }
}

/// Slip speed |u_a − u_b| on the face `at` normal to axis `a` (3D): its normal component
/// and each other component `c` averaged from the four nearest `c`-faces (the cells on
/// either side along `a`, wrapped or clamped by [`sides`], and the two `c`-faces bounding the cell
/// along `c`), summed in storage order, the components in axis order (the z one last).
#[cfg(feature = "dim3")]
#[inline]
fn face_slip(ctx: &ExchangeContext, g: &Grid, a: usize, at: multifield_core::math::Index) -> Real {
    use multifield_core::grid::Lattice;
    let (va, vb) = (&ctx.a.velocity, &ctx.b.velocity);
    let n = g.n();
    let f = g.index(Lattice::face(a), at);
    let mut slip = va[a][f] - vb[a][f];
    for c in AXES.into_iter().filter(|&c| c != a) {
        let lattice = Lattice::face(c);
        let (p, q) = (a.min(c), a.max(c));
        let offset = |axis: usize, o: usize| {
            if axis == a {
                sides(at[a], n[a], ctx.periodic[a])[o]
            } else {
                at[c] + o
            }
        };
        let d = |op: usize, oq: usize| {
            let mut node = at;
            node[p] = offset(p, op);
            node[q] = offset(q, oq);
            let k = g.index(lattice, node);
            va[c][k] - vb[c][k]
        };
        let t = 0.25 * (d(0, 0) + d(1, 0) + d(0, 1) + d(1, 1));
        slip = slip.hypot(t);
    }
    slip
}

/// Fills K on every face for a slip-dependent law (see [`drag_coefficient`]), row by row in
/// parallel (each face's K depends only on the velocities: bit-identical whatever the
/// threads). Where the particles put nothing on a face (mass and θ exactly 0, most of a
/// domain with few particles) K is 0 and its slip is not computed: the exchange reads K
/// only where both fields are present, and the explicit one weighs it with θ_s = 0. The
/// slip is [`face_slip_speeds`]' to the bit.
#[allow(clippy::too_many_arguments)]
pub fn fill_drag(
    ctx: &ExchangeContext,
    k: &mut FaceArrays,
    c: Real,
    g: impl Fn(Real, Real) -> Real + Copy + Sync,
    diameter: Real,
    viscosity: Real,
    di_felice: bool,
) {
    use rayon::prelude::*;
    let grid: &Grid = ctx.grid;
    let rho_f = ctx.density[0];
    let empty = |m: &[Real], t: &[Real], f: usize| m[f] == 0.0 && t[f] == 0.0;
    let k_at = |t: Real, slip: Real| drag_coefficient(c, g, diameter, viscosity, rho_f, t, slip, di_felice);
    #[cfg(feature = "dim3")]
    {
        use multifield_core::grid::Lattice;
        if grid.n().contains(&0) {
            return;
        }
        for a in AXES {
            let lattice = Lattice::face(a);
            let (mass, theta) = (&ctx.b.mass_face[a], &ctx.b.theta_face[a]);
            k[a].par_iter_mut().enumerate().with_min_len(256).for_each(|(f, k)| {
                *k = if empty(mass, theta, f) {
                    0.0
                } else {
                    k_at(ctx.a.theta_face[a][f], face_slip(ctx, grid, a, grid.node(lattice, f)))
                };
            });
        }
    }
    #[cfg(feature = "dim2")]
    let (nx, ny) = (grid.nx, grid.ny);
    #[cfg(feature = "dim2")]
    if nx == 0 || ny == 0 {
        return;
    }
    #[cfg(feature = "dim2")]
    k.u.par_chunks_mut(nx + 1).with_min_len(8).enumerate().for_each(|(j, row)| {
        for (i, k) in row.iter_mut().enumerate() {
            let f = grid.xface(i, j);
            *k = if empty(&ctx.b.mass_face.u, &ctx.b.theta_face.u, f) {
                0.0
            } else {
                k_at(ctx.a.theta_face.u[f], xface_slip(ctx, grid, i, j))
            };
        }
    });
    #[cfg(feature = "dim2")]
    k.v.par_chunks_mut(nx).with_min_len(8).enumerate().for_each(|(j, row)| {
        for (i, k) in row.iter_mut().enumerate() {
            let f = grid.yface(i, j);
            *k = if empty(&ctx.b.mass_face.v, &ctx.b.theta_face.v, f) {
                0.0
            } else {
                k_at(ctx.a.theta_face.v[f], yface_slip(ctx, grid, i, j))
            };
        }
    });
}

/// A drag law's parameters, as the case writes them.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DragParams {
    diameter: Real,
    viscosity: Real,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    di_felice: Option<bool>,
    #[serde(default)]
    added_mass: Real,
    #[serde(default)]
    rotation: bool,
}

/// The parameters of a law with Di Felice's option.
const PARAMS_DI_FELICE: [ParamDoc; 5] =
    [PARTICLE_PARAMS[0], PARTICLE_PARAMS[1], DI_FELICE_PARAM, POINT_PARAMS[0], POINT_PARAMS[1]];
/// The parameters of a law without it.
const PARAMS_PLAIN: [ParamDoc; 4] = [PARTICLE_PARAMS[0], PARTICLE_PARAMS[1], POINT_PARAMS[0], POINT_PARAMS[1]];

/// The exchange model of a drag correlation `C`: particles of diameter d in a fluid of
/// viscosity μ (the first field of `between`), K on every face from the face's slip (see
/// the module's documentation).
pub struct Drag<C> {
    /// Particle diameter d (length).
    pub diameter: Real,
    /// Dynamic viscosity μ of the fluid (the first field of `between`).
    pub viscosity: Real,
    /// Di Felice's (1994) dense-suspension correction (when `C` offers it).
    pub di_felice: bool,
    /// Added-mass coefficient C_A of mass points (implicit; 0 = none).
    pub added_mass: Real,
    /// Rotational torque on mass points.
    pub rotation: bool,
    /// The correlation (a marker: the laws carry no parameters of their own).
    pub law: PhantomData<fn() -> C>,
}

impl<C> Clone for Drag<C> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<C> Copy for Drag<C> {}

impl<C: DragCorrelation> std::fmt::Debug for Drag<C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Drag")
            .field("law", &C::NAME)
            .field("diameter", &self.diameter)
            .field("viscosity", &self.viscosity)
            .field("di_felice", &self.di_felice)
            .field("added_mass", &self.added_mass)
            .field("rotation", &self.rotation)
            .finish()
    }
}

impl<C: DragCorrelation> Drag<C> {
    /// The parameters for `multifield plugins` (and the registry).
    pub const PARAMS: &'static [ParamDoc] = if C::DI_FELICE { &PARAMS_DI_FELICE } else { &PARAMS_PLAIN };

    /// The law for particles of diameter `diameter` in a fluid of viscosity `viscosity`,
    /// without the options.
    pub fn new(diameter: Real, viscosity: Real) -> Self {
        Drag { diameter, viscosity, di_felice: false, added_mass: 0.0, rotation: false, law: PhantomData }
    }
    /// Diameter and viscosity must be positive, the added mass not negative.
    pub fn validate(&mut self) -> Result<(), String> {
        validate_particle(self.diameter, self.viscosity)?;
        validate_added_mass(self.added_mass)
    }
    /// K at a slip speed |Δu|, fluid density ρ_f and fluid fraction θ_f.
    pub fn coefficient(&self, slip: Real, rho_f: Real, theta_f: Real) -> Real {
        match C::CONSTANT_CD_RE {
            Some(g) if !self.di_felice => {
                C::SHAPE.factor() * g * self.viscosity / (self.diameter * self.diameter * theta_f.max(THETA_FLOOR))
            }
            _ => drag_coefficient(
                C::SHAPE.factor(),
                C::cd_re,
                self.diameter,
                self.viscosity,
                rho_f,
                theta_f,
                slip,
                self.di_felice,
            ),
        }
    }
}

impl<C: DragCorrelation> Serialize for Drag<C> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        DragParams {
            diameter: self.diameter,
            viscosity: self.viscosity,
            di_felice: C::DI_FELICE.then_some(self.di_felice),
            added_mass: self.added_mass,
            rotation: self.rotation,
        }
        .serialize(s)
    }
}

impl<'de, C: DragCorrelation> Deserialize<'de> for Drag<C> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let p = DragParams::deserialize(d)?;
        if p.di_felice.is_some() && !C::DI_FELICE {
            let names: Vec<String> = Self::PARAMS.iter().map(|p| format!("`{}`", p.name)).collect();
            return Err(serde::de::Error::custom(format!(
                "unknown field `di_felice`, expected one of {}",
                names.join(", ")
            )));
        }
        Ok(Drag {
            diameter: p.diameter,
            viscosity: p.viscosity,
            di_felice: p.di_felice.unwrap_or(false),
            added_mass: p.added_mass,
            rotation: p.rotation,
            law: PhantomData,
        })
    }
}

impl<C: DragCorrelation> ExchangeModel for Drag<C> {
    fn model(&self) -> &'static str {
        C::NAME
    }
    fn params(&self) -> serde_json::Value {
        params_value(self)
    }
    /// Each face's K from the velocities on and around it (the halo across a rank's cut).
    fn decomposed(&self) -> bool {
        true
    }
    fn drag_law(&self) -> Option<DragLaw> {
        Some(law(C::NAME, self.diameter, self.viscosity, C::VALID_RE, self.added_mass, self.rotation))
    }
    fn coefficients(&self, ctx: &ExchangeContext, k: &mut FaceArrays) {
        if C::CONSTANT_CD_RE.is_some() && !self.di_felice {
            // independent of the slip
            for a in AXES {
                for (k, t) in k[a].iter_mut().zip(&ctx.a.theta_face[a]) {
                    *k = self.coefficient(0.0, ctx.density[0], *t);
                }
            }
        } else {
            fill_drag(ctx, k, C::SHAPE.factor(), C::cd_re, self.diameter, self.viscosity, self.di_felice);
        }
    }
}

#[cfg(all(test, feature = "dim2"))]
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

    #[test]
    fn fill_drag_is_the_law_at_each_faces_slip_and_zero_where_the_particles_are_not() {
        use multifield_core::field::FieldState;
        use multifield_core::math::Vector;
        // 7 × 5 cells, random velocities; the particles on about half of the faces
        let g = Grid::new(7, 5, 0.1, Vector::zeros());
        let (mut a, mut b) = (FieldState::new(&g), FieldState::new(&g));
        let mut seed: u64 = 7;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as Real / (1u64 << 53) as Real
        };
        for s in [&mut a, &mut b] {
            s.velocity.u.iter_mut().chain(s.velocity.v.iter_mut()).for_each(|x| *x = 2.0 * next() - 1.0);
        }
        a.theta_face.u.iter_mut().chain(a.theta_face.v.iter_mut()).for_each(|x| *x = 0.5 + 0.5 * next());
        for (m, t) in b
            .mass_face
            .u
            .iter_mut()
            .zip(b.theta_face.u.iter_mut())
            .chain(b.mass_face.v.iter_mut().zip(b.theta_face.v.iter_mut()))
        {
            if next() < 0.5 {
                (*t, *m) = (0.3 * next(), 1e-3 * next());
            }
        }
        let ctx = ExchangeContext { grid: &g, a: &a, b: &b, density: [1.0, 1.1], periodic: [false; 2] };
        let mut k = FaceArrays { u: vec![Real::NAN; g.n_xfaces()], v: vec![Real::NAN; g.n_yfaces()] };
        let law = super::super::cylinder::cd_re;
        let (c, d, mu) = (2.0 / std::f64::consts::PI, 0.02, 0.01);
        fill_drag(&ctx, &mut k, c, |re, _| law(re), d, mu, false);
        let (mut sx, mut sy) = (Vec::new(), Vec::new());
        face_slip_speeds(&ctx, &mut sx, &mut sy);
        let mut computed = 0;
        for (k, s, t, mb, tb) in
            k.u.iter()
                .zip(&sx)
                .zip(&a.theta_face.u)
                .zip(&b.mass_face.u)
                .zip(&b.theta_face.u)
                .map(|((((k, s), t), m), tb)| (k, s, t, m, tb))
                .chain(
                    k.v.iter()
                        .zip(&sy)
                        .zip(&a.theta_face.v)
                        .zip(&b.mass_face.v)
                        .zip(&b.theta_face.v)
                        .map(|((((k, s), t), m), tb)| (k, s, t, m, tb)),
                )
        {
            if *mb == 0.0 && *tb == 0.0 {
                assert_eq!(*k, 0.0);
            } else {
                let expected = drag_coefficient(c, |re, _| law(re), d, mu, 1.0, *t, *s, false);
                assert_eq!(k.to_bits(), expected.to_bits());
                computed += 1;
            }
        }
        assert!(computed > 20 && computed < g.n_xfaces() + g.n_yfaces() - 20, "{computed}");
    }

    #[test]
    fn on_a_periodic_side_the_slip_averages_across_the_wrap() {
        use multifield_core::field::FieldState;
        use multifield_core::math::Vector;
        // 4 × 3 cells; fluid at rest, the particles' v = 1 + column + 10 row on every y-face
        // and u = 0.5 on every x-face
        let g = Grid::new(4, 3, 0.1, Vector::zeros());
        let (a, mut b) = (FieldState::new(&g), FieldState::new(&g));
        for j in 0..=3 {
            for i in 0..4 {
                b.velocity.v[g.yface(i, j)] = 1.0 + i as Real + 10.0 * j as Real;
            }
        }
        b.velocity.u.fill(0.5);
        let at = |periodic| {
            let ctx = ExchangeContext { grid: &g, a: &a, b: &b, density: [1.0, 1.1], periodic };
            let (mut sx, mut sy) = (Vec::new(), Vec::new());
            face_slip_speeds(&ctx, &mut sx, &mut sy);
            [sx[g.xface(0, 1)], sx[g.xface(4, 1)], sx[g.xface(2, 1)]]
        };
        // row 1: the y-faces of rows 1 and 2 around x-face (i, 1); columns 3 and 0 across the
        // wrap: mean v = 1 + 1.5 + 15 = 17.5; clamped at a wall: column 0 alone (16) on the
        // left, column 3 alone (19) on the right; inside (i = 2), columns 1 and 2: 17.5
        let slip = |v: Real| 0.5f64.hypot(v);
        assert_eq!(at([true, false]), [slip(17.5), slip(17.5), slip(17.5)]);
        assert_eq!(at([false, false]), [slip(16.0), slip(19.0), slip(17.5)]);
    }

    /// The law of docs/plugins.md: one correlation, nothing else.
    struct MyLaw;
    impl DragCorrelation for MyLaw {
        const NAME: &'static str = "my_law";
        const SUMMARY: &'static str = "my drag on spheres: CD = 24/Re (1 + 0.1 Re^0.75)";
        const CITATION: &'static str = "none";
        const SHAPE: Shape = Shape::Sphere;
        const VALID_RE: (Real, Real) = (0.0, 800.0);
        fn cd_re(re: Real, _theta_f: Real) -> Real {
            24.0 * (1.0 + 0.1 * re.powf(0.75))
        }
    }

    #[test]
    fn a_correlation_is_a_whole_exchange_model() {
        // d = 0.1, μ = 0.01, ρ_f = 1, |Δu| = 1.6: Re = 16, Re^0.75 = 8, C_D·Re = 24 · 1.8 = 43.2;
        // K = (3/4) 43.2 μ/(d² θ_f) = 32.4/θ_f
        let mut m: Drag<MyLaw> =
            serde_json::from_value(serde_json::json!({"diameter": 0.1, "viscosity": 0.01})).unwrap();
        m.validate().unwrap();
        assert!((m.coefficient(1.6, 1.0, 0.8) - 32.4 / 0.8).abs() < 1e-12);
        let law = m.drag_law().unwrap();
        assert_eq!((law.model, law.valid_re, law.diameter), ("my_law", (0.0, 800.0), 0.1));
        // the options every law offers, written back with their defaults
        let p = m.params();
        assert_eq!((p["di_felice"].as_bool(), p["added_mass"].as_f64()), (Some(false), Some(0.0)));
        assert_eq!(Drag::<MyLaw>::PARAMS.len(), 5);
        // a law without Di Felice's option refuses it as an unknown parameter
        let e = serde_json::from_value::<Drag<super::super::stokes::Stokes>>(
            serde_json::json!({"diameter": 0.1, "viscosity": 0.01, "di_felice": true}),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("unknown field `di_felice`, expected one of `diameter`, `viscosity`, `added_mass`"), "{e}");
    }
}
