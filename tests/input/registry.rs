//! Every plugin the crates say they ship is registered under its role once linked
//! (inventory drops a crate nothing references: `link()` must keep them).

use multifield::core::registry::{entries, Role};

fn registered(role: Role) -> Vec<&'static str> {
    entries(role).iter().map(|e| e.name).collect()
}

#[test]
fn every_shipped_physics_plugin_is_registered_under_its_role() {
    multifield::link_all();
    let mut count = 0;
    for (role_name, names) in multifield::physics::SHIPPED {
        let role = Role::ALL
            .into_iter()
            .find(|r| r.name() == *role_name)
            .unwrap_or_else(|| panic!("physics::SHIPPED names an unknown role `{role_name}`"));
        let have = registered(role);
        for name in *names {
            assert!(have.contains(name), "{role_name} model `{name}` is not registered; registered: {have:?}");
            count += 1;
        }
    }
    assert!(count >= 4, "physics ships at least newtonian, constant, no_slip, pcg; listed {count}");
}

#[test]
fn every_shipped_frame_is_registered() {
    multifield::link_all();
    let have = registered(Role::Frame);
    for name in multifield::frames::SHIPPED {
        assert!(have.contains(name), "frame `{name}` is not registered; registered: {have:?}");
    }
    assert!(multifield::frames::SHIPPED.contains(&"eulerian") && multifield::frames::SHIPPED.contains(&"lagrangian"));
}

#[test]
fn every_registered_plugin_documents_itself() {
    multifield::link_all();
    for role in Role::ALL {
        for e in entries(role) {
            assert!(!e.summary.trim().is_empty(), "{} model `{}` has no summary", role.name(), e.name);
            for p in e.params {
                assert!(
                    !p.unit.is_empty() && !p.default.is_empty() && !p.doc.is_empty(),
                    "{} model `{}`: parameter `{}` lacks a unit, default or doc",
                    role.name(),
                    e.name,
                    p.name
                );
            }
        }
    }
}

/// `multifield plugins` lists every registered plugin under its role with each parameter,
/// its unit and its default.
#[test]
fn the_plugins_command_lists_every_plugin_and_parameter() {
    multifield::link_all();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_multifield")).arg("plugins").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for role in Role::ALL {
        let n = entries(role).len();
        assert!(text.contains(&format!("{} models ({n}):", role.name())), "no `{}` heading:\n{text}", role.name());
        for e in entries(role) {
            assert!(text.contains(&format!("  {:<14} {}", e.name, e.summary)), "`{}` missing:\n{text}", e.name);
            for p in e.params {
                let line = format!("      {:<18} [{}] default {}: {}", p.name, p.unit, p.default, p.doc);
                assert!(text.contains(&line), "parameter line missing: {line}");
            }
        }
    }
    // the binary links the same plugins as the library: the shipped physics are there
    for (_, names) in multifield::physics::SHIPPED {
        for name in *names {
            assert!(text.contains(&format!("  {name:<14} ")), "`{name}` not listed");
        }
    }
}

/// The default `multifield plugins` prints for a parameter is the one the plugin takes:
/// every plugin is built with only its required parameters, and each other parameter's
/// filled-in value (what `case.ron` records) equals its documented default.
#[test]
fn every_documented_default_is_the_default_the_plugin_takes() {
    use multifield::core::registry::{build_contact, build_exchange, build_frame, build_pressure, build_stress};
    multifield::link_all();
    // values for the parameters that have no default
    let required = serde_json::json!({
        "young_modulus": 1.0e5, "poisson_ratio": 0.3, "viscosity": 0.01, "diameter": 0.1,
        "stiffness": 1.0e3, "coefficient": 1.0, "restitution": 0.9, "collision_time": 1.0e-3,
    });
    let mut checked = 0;
    for role in Role::ALL {
        for e in entries(role) {
            let mut params = serde_json::Map::new();
            for p in e.params.iter().filter(|p| p.default.starts_with("required")) {
                let v = required.get(p.name).unwrap_or_else(|| panic!("no test value for required `{}`", p.name));
                params.insert(p.name.to_string(), v.clone());
            }
            let params = serde_json::Value::Object(params);
            let path = format!("{}.{}", role.name(), e.name);
            let filled = match role {
                Role::Frame => build_frame(e.name, &params, &path).map(|m| m.params()),
                Role::Stress => build_stress(e.name, &params, &path).map(|m| m.params()),
                Role::Exchange => build_exchange(e.name, &params, &path).map(|m| m.params()),
                Role::Pressure => build_pressure(e.name, &params, &path).map(|m| m.params()),
                Role::Contact => build_contact(e.name, &params, &path).map(|m| m.params()),
            }
            .unwrap_or_else(|err| panic!("{path} with only its required parameters: {err}"));
            for p in e.params.iter().filter(|p| !p.default.starts_with("required")) {
                let documented = multifield::core::ron_value::parse(p.default)
                    .unwrap_or_else(|err| panic!("{path}.{}: documented default `{}`: {err}", p.name, p.default));
                let taken = &filled[p.name];
                let same = match (documented.as_f64(), taken.as_f64()) {
                    (Some(a), Some(b)) => a == b,
                    _ => &documented == taken,
                };
                assert!(same, "{path}.{}: documented default {documented}, taken {taken}", p.name);
                checked += 1;
            }
        }
    }
    assert!(checked >= 30, "{checked} defaults checked");
}
