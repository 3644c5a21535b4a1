//! Plugin registries: a name maps to a builder that turns RON parameters into a typed model.
//!
//! Crates register with `inventory::submit!` (see [`crate::register!`]);
//! the core never lists them. Inventory drops a crate nobody references, so each plugin
//! crate exposes a `link()` function that the binary and the tests call.

use crate::error::{did_you_mean, Error, Result};
use crate::plugin::{ContactModel, ExchangeModel, Frame, PressureSolver, StressModel};
use serde::de::DeserializeOwned;

/// The role a plugin plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    /// Where a field's state lives (Eulerian, Lagrangian).
    Frame,
    /// A field's stress (viscosity, elasticity, rigidity).
    Stress,
    /// Momentum exchange between two fields.
    Exchange,
    /// The pressure solve.
    Pressure,
    /// Repulsion between bodies.
    Contact,
}

impl Role {
    /// The role's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Role::Frame => "frame",
            Role::Stress => "stress",
            Role::Exchange => "exchange",
            Role::Pressure => "pressure",
            Role::Contact => "contact",
        }
    }
    /// All roles.
    pub const ALL: [Role; 5] = [Role::Frame, Role::Stress, Role::Exchange, Role::Pressure, Role::Contact];
}

/// Documentation of one parameter, for `multifield plugins`.
#[derive(Clone, Copy, Debug)]
pub struct ParamDoc {
    /// Key in the `params` of a case.
    pub name: &'static str,
    /// Unit, e.g. "g/(cm·s)", or "-" for dimensionless.
    pub unit: &'static str,
    /// Default value, or "required".
    pub default: &'static str,
    /// What it is.
    pub doc: &'static str,
}

/// A builder for one role.
#[derive(Clone, Copy)]
pub enum Builder {
    /// Builds a frame.
    Frame(fn(&serde_json::Value) -> Result<Box<dyn Frame>, String>),
    /// Builds a stress model.
    Stress(fn(&serde_json::Value) -> Result<Box<dyn StressModel>, String>),
    /// Builds an exchange model.
    Exchange(fn(&serde_json::Value) -> Result<Box<dyn ExchangeModel>, String>),
    /// Builds a pressure solver.
    Pressure(fn(&serde_json::Value) -> Result<Box<dyn PressureSolver>, String>),
    /// Builds a contact model.
    Contact(fn(&serde_json::Value) -> Result<Box<dyn ContactModel>, String>),
}

impl Builder {
    /// The role this builder fills.
    pub fn role(&self) -> Role {
        match self {
            Builder::Frame(_) => Role::Frame,
            Builder::Stress(_) => Role::Stress,
            Builder::Exchange(_) => Role::Exchange,
            Builder::Pressure(_) => Role::Pressure,
            Builder::Contact(_) => Role::Contact,
        }
    }
}

/// One registered plugin.
pub struct PluginEntry {
    /// Registered name (also the file and, in CamelCase, the type name).
    pub name: &'static str,
    /// One line on what it is, with its equation or citation.
    pub summary: &'static str,
    /// Its parameters.
    pub params: &'static [ParamDoc],
    /// The builder.
    pub build: Builder,
}

inventory::collect!(PluginEntry);

/// Every registered plugin of `role`, sorted by name.
pub fn entries(role: Role) -> Vec<&'static PluginEntry> {
    let mut v: Vec<_> = inventory::iter::<PluginEntry>.into_iter().filter(|e| e.build.role() == role).collect();
    v.sort_by_key(|e| e.name);
    v
}

/// The shipped plugins of the 2D build that the 3D build does not have yet: a 3D case
/// naming one is told so ([`find`]), not that the name is unknown.
#[cfg(feature = "dim3")]
pub const NOT_YET_3D: &[(Role, &str)] = &[
    (Role::Frame, "eulerian"),
    (Role::Frame, "lagrangian"),
    (Role::Frame, "mass_point"),
    (Role::Stress, "newtonian"),
    (Role::Stress, "rigid"),
    (Role::Stress, "linear_elastic"),
    (Role::Stress, "neo_hookean"),
    (Role::Stress, "weakly_compressible"),
    (Role::Exchange, "constant"),
    (Role::Exchange, "no_slip"),
    (Role::Exchange, "stokes"),
    (Role::Exchange, "schiller_naumann"),
    (Role::Exchange, "cylinder"),
    (Role::Exchange, "direct_forcing"),
    (Role::Pressure, "pcg"),
    (Role::Pressure, "multigrid"),
    (Role::Pressure, "cholesky"),
    (Role::Contact, "dem"),
    (Role::Contact, "repulsion"),
];

/// Looks up `name` for `role`; an unknown name lists the registered ones.
pub fn find(role: Role, name: &str, path: &str) -> Result<&'static PluginEntry> {
    let all = entries(role);
    #[cfg(feature = "dim3")]
    if !all.iter().any(|e| e.name == name) && NOT_YET_3D.contains(&(role, name)) {
        return Err(Error::invalid(
            path,
            format!(
                "{} `{name}` is not available in 3D yet: issue 17 brings Eulerian fields to 3D first, \
                 Lagrangian fields, bodies and contact come next; {}",
                role.name(),
                if all.is_empty() {
                    "nothing of this role is in 3D yet".to_string()
                } else {
                    format!("the 3D choices are: {}", all.iter().map(|e| e.name).collect::<Vec<_>>().join(", "))
                }
            ),
        ));
    }
    all.iter().find(|e| e.name == name).copied().ok_or_else(|| Error::UnknownPlugin {
        role: role.name(),
        name: name.to_string(),
        path: path.to_string(),
        choices: if all.is_empty() {
            "none (is the plugin crate linked? call its link())".to_string()
        } else {
            all.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
        },
        hint: did_you_mean(name, all.iter().map(|e| e.name)),
    })
}

fn wrap(name: &str, path: &str, r: Result<(), String>) -> Result<()> {
    r.map_err(|m| Error::invalid(path, format!("{name}: {m}")))
}

/// Builds the frame `name` with `params`.
pub fn build_frame(name: &str, params: &serde_json::Value, path: &str) -> Result<Box<dyn Frame>> {
    match find(Role::Frame, name, path)?.build {
        Builder::Frame(f) => f(params).map_err(|m| Error::invalid(path, format!("{name}: {m}"))),
        _ => unreachable!("filtered by role"),
    }
}
/// Builds the stress model `name` with `params`.
pub fn build_stress(name: &str, params: &serde_json::Value, path: &str) -> Result<Box<dyn StressModel>> {
    match find(Role::Stress, name, path)?.build {
        Builder::Stress(f) => f(params).map_err(|m| Error::invalid(path, format!("{name}: {m}"))),
        _ => unreachable!("filtered by role"),
    }
}
/// Builds the exchange model `name` with `params`.
pub fn build_exchange(name: &str, params: &serde_json::Value, path: &str) -> Result<Box<dyn ExchangeModel>> {
    match find(Role::Exchange, name, path)?.build {
        Builder::Exchange(f) => f(params).map_err(|m| Error::invalid(path, format!("{name}: {m}"))),
        _ => unreachable!("filtered by role"),
    }
}
/// Builds the pressure solver `name` with `params`.
pub fn build_pressure(name: &str, params: &serde_json::Value, path: &str) -> Result<Box<dyn PressureSolver>> {
    match find(Role::Pressure, name, path)?.build {
        Builder::Pressure(f) => f(params).map_err(|m| Error::invalid(path, format!("{name}: {m}"))),
        _ => unreachable!("filtered by role"),
    }
}

/// Builds the contact model `name` with `params`.
pub fn build_contact(name: &str, params: &serde_json::Value, path: &str) -> Result<Box<dyn ContactModel>> {
    match find(Role::Contact, name, path)?.build {
        Builder::Contact(f) => f(params).map_err(|m| Error::invalid(path, format!("{name}: {m}"))),
        _ => unreachable!("filtered by role"),
    }
}

/// Deserializes a plugin's parameters into its typed struct (which should carry
/// `#[serde(deny_unknown_fields)]`). A `null` or missing `params` means all defaults.
pub fn parse_params<T: DeserializeOwned>(params: &serde_json::Value) -> Result<T, String> {
    let v = if params.is_null() { serde_json::Value::Object(Default::default()) } else { params.clone() };
    serde_json::from_value(v).map_err(|e| {
        let m = e.to_string();
        // serde says "unknown field `x`, expected one of `a`, `b`": say "key" as the case does
        m.replace("unknown field", "unknown parameter").replace("missing field", "missing parameter")
    })
}

/// Serializes a plugin's typed parameters back (for `case.ron`).
pub fn params_value<T: serde::Serialize>(p: &T) -> serde_json::Value {
    serde_json::to_value(p).unwrap_or(serde_json::Value::Null)
}

/// Keeps `wrap` used by callers that validate after building.
pub fn check(name: &str, path: &str, r: Result<(), String>) -> Result<()> {
    wrap(name, path, r)
}

/// Registers a plugin: `register!(Stress, "newtonian", Newtonian, "summary", [ParamDoc…])`.
/// The type must implement `serde::Deserialize`, a `fn validate(&mut self) -> Result<(), String>`
/// and the role's trait.
#[macro_export]
macro_rules! register {
    ($role:ident, $name:literal, $ty:ty, $summary:expr, $params:expr) => {
        $crate::inventory::submit! {
            $crate::registry::PluginEntry {
                name: $name,
                summary: $summary,
                params: $params,
                build: $crate::registry::Builder::$role(|p| {
                    let mut m: $ty = $crate::registry::parse_params(p)?;
                    m.validate()?;
                    Ok(Box::new(m))
                }),
            }
        }
    };
}
