//! A case's dimension: read from its `domain.cells`, checked by each library, chosen by
//! the program; what a 3D case cannot have yet is refused by name.

use multifield_core3d::case::{check_dimension, dimension, Case};
use multifield_core3d::registry::{self, Role};
use std::path::Path;
use std::process::Command;

const TGV: &str = r#"(
    name: "taylor_green_3d",
    domain: (size: (6.283185307179586, 6.283185307179586, 6.283185307179586), cells: (8, 8, 8)),
    boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic, back: Periodic, front: Periodic),
    time: (end: 0.5, cfl: 0.5, max_dt: 0.01),
    fields: [(name: "water", frame: (model: "eulerian"), density: 1.0, region: All,
              velocity: TaylorGreen(amplitude: 0.001), stress: [(model: "newtonian", params: {"viscosity": 0.1})])],
    pressure: Some((model: "multigrid")),
)"#;

fn message(text: &str) -> String {
    match Case::from_ron(text, Path::new("t.ron")).and_then(|c| c.validate().map(|_| c)) {
        Ok(_) => String::new(),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_dimension_is_the_count_of_domain_cells() {
    let mut examples = 0;
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/examples")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            let text = std::fs::read_to_string(&path).unwrap();
            assert_eq!(dimension(&text, &[]), Some(2), "{}", path.display());
            assert_eq!(dimension(&text, &["domain.cells=(8, 8, 8)".into()]), Some(3), "{}", path.display());
            examples += 1;
        }
    }
    assert!(examples >= 18, "{examples} examples");
    assert_eq!(dimension(TGV, &[]), Some(3));
    // the last override wins; a text that does not parse that far has none
    assert_eq!(dimension(TGV, &["domain.cells=(8, 8)".into(), "domain.cells=(4, 4, 4, 4)".into()]), Some(4));
    assert_eq!(dimension("(name: \"x\", domain: (size: (1.0, 1.0)", &[]), None);
    let four = check_dimension(TGV, &["domain.cells=(4, 4, 4, 4)".into()]).unwrap_err().to_string();
    assert!(four.contains("domain.cells: 4 numbers: give 2 (a 2D case"), "{four}");
}

#[test]
fn each_library_names_a_case_of_the_other_dimension() {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/taylor_green.ron");
    let e = Case::load(Path::new(example), &[]).unwrap_err().to_string();
    assert!(
        e.contains("domain.cells: 2 numbers: this is a 2D case, and this library is the 3D one")
            && e.contains("loads a 2D case with `multifield`"),
        "{e}"
    );
    let dir = std::env::temp_dir().join(format!("multifield-dim3-case-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("tgv3.ron");
    std::fs::write(&file, TGV).unwrap();
    let e = multifield::core::case::Case::load(&file, &[]).unwrap_err().to_string();
    assert!(
        e.contains("3 numbers: this is a 3D case, and this library is the 2D one") && e.contains("`multifield3d`"),
        "{e}"
    );
    // the program chooses the 3D library for it: the 3D registry answers
    let out = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["check", file.to_str().unwrap(), "--set", "fields.water.frame.model=lagrangian"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("fields.water.frame: frame `lagrangian` is not available in 3D yet"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_third_axis_has_front_and_back_sides_and_cubic_cells() {
    // a 2D case with `front` is refused by the 2D library
    let example = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/taylor_green.ron")).unwrap();
    let with_front = example.replacen("boundaries: (", "boundaries: (front: NoSlip, ", 1);
    assert_ne!(with_front, example);
    let e = multifield::core::case::Case::from_ron(&with_front, Path::new("t.ron")).unwrap_err().to_string();
    assert!(e.contains("front"), "{e}");
    // the 3D case parses with them; non-cubic cells are refused with a suggestion
    let c = Case::from_ron(TGV, Path::new("t.ron")).unwrap();
    assert_eq!(c.cells(), [8, 8, 8]);
    let flat = TGV.replace("cells: (8, 8, 8)", "cells: (8, 8, 4)");
    let e = message(&flat);
    assert!(e.contains("cells must be cubes") && e.contains("e.g. (8, 8, 8)"), "{e}");
}

#[test]
fn what_a_3d_case_cannot_have_yet_is_refused_by_name() {
    for (role, name) in
        [(Role::Frame, "lagrangian"), (Role::Frame, "mass_point"), (Role::Contact, "dem"), (Role::Stress, "rigid")]
    {
        let e = registry::find(role, name, "here").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains(&format!("`{name}` is not available in 3D yet")), "{e}");
    }
    let e = registry::find(Role::Frame, "eulerain", "here").err().map(|e| e.to_string()).unwrap_or_default();
    assert!(!e.contains("not available in 3D"), "an unknown name is not a 2D one: {e}");
    for (change, path, what) in [
        ("region: All", "fields.water.region", "bodies (`Bodies([...])`) are not available in 3D yet"),
        ("region: All", "fields.water.region", "`Rectangle` and `Disk` are 2D regions"),
        ("density: 1.0,", "fields.water.representation", "mass points are not available in 3D yet"),
        // pictures are drawn in 3D on slices (tests/dim3/pictures.rs): one without is refused
        ("max_dt: 0.01)", "output.pictures.slice", "a 3D picture is a plane of cells: give one"),
    ] {
        let replacement = match path {
            "fields.water.region" if what.starts_with("bodies") => "region: Bodies([])",
            "fields.water.region" => "region: Rectangle(min: (0.0, 0.0), max: (1.0, 1.0))",
            "fields.water.representation" => "density: 1.0, representation: MassPoint,",
            _ => "max_dt: 0.01), output: (pictures: Some((interval: 0.1)))",
        };
        let text = TGV.replacen(change, replacement, 1);
        assert_ne!(text, TGV);
        let e = message(&text);
        assert!(e.contains(path) && e.contains(what), "{path}: {e}");
    }
}

#[test]
fn a_grid_beyond_the_memory_is_refused_with_the_number_before_anything_is_built() {
    let dir = std::env::temp_dir().join(format!("multifield-dim3-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("tgv3.ron");
    std::fs::write(&file, TGV).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield"))
        .args(["check", file.to_str().unwrap(), "--set", "domain.cells=(768, 768, 768)", "--max-memory", "16GB"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    // 4.5·10⁸ cells, under the cap of 2³⁰: the memory refuses it, with the estimate
    let estimate = Case::from_ron(&TGV.replace("cells: (8, 8, 8)", "cells: (768, 768, 768)"), Path::new("t.ron"))
        .unwrap()
        .memory_estimate();
    assert!(estimate.bytes > 16_000_000_000 && estimate.bytes / (768 * 768 * 768) > 500, "{}", estimate.bytes);
    assert!(stderr.contains("GB needed for 768 × 768 × 768 cells") && stderr.contains("16"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_study_of_a_3d_case_is_refused_by_name() {
    let dir = std::env::temp_dir().join(format!("multifield-dim3-study-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("tgv3.ron"), TGV).unwrap();
    let study =
        r#"(name: "s", base: "tgv3.ron", axes: [(name: "n", values: List(path: "time.end", values: [0.1, 0.2]))])"#;
    std::fs::write(dir.join("s.ron"), study).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).arg("study").arg(dir.join("s.ron")).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("its base case is a 3D case") && stderr.contains("studies run 2D cases only"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_memory_estimate_counts_the_3d_fill_of_a_cholesky_factor() {
    // 64³ cells: the factor alone about 2 n^{3/2} = 4.3·10⁸ entries of 24 bytes, 10 GB;
    // the multigrid's levels a few hundred MB
    let case = |p: &str| {
        Case::from_ron(
            &TGV.replace("cells: (8, 8, 8)", "cells: (64, 64, 64)").replace("\"multigrid\"", p),
            Path::new("t"),
        )
        .unwrap()
        .memory_estimate()
        .bytes
    };
    let n = 64.0f64.powi(3);
    let factor = 2.0 * n * n.sqrt() * 24.0;
    let (cholesky, multigrid) = (case("\"cholesky\""), case("\"multigrid\""));
    assert!(cholesky > multigrid, "{cholesky} {multigrid}");
    let difference = (cholesky - multigrid) as f64;
    assert!((difference / factor - 1.0).abs() < 0.05, "{difference} against {factor}");
}
