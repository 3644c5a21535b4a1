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
