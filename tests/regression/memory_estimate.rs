//! Issue 20: the memory a case needs is estimated from the case alone
//! (`Case::memory_estimate`), before anything is allocated; `check` prints it. This pins the
//! count on a case small enough to add up by hand, and the check's line.

use multifield::core::case::Case;
use std::path::Path;
use std::process::Command;

const CASE: &str = r#"(
    name: "one_field", domain: (size: (1.0, 1.0), cells: (64, 64)),
    time: (end: 0.1, max_dt: 0.01),
    fields: [(name: "fluid", density: 1.0, frame: (model: "eulerian"), region: All)],
)"#;

/// 64 × 64 cells: C = 4,096 cells, X = Y = 65 × 64 = 4,160 faces of each direction.
/// - the simulation's pressure, and the occupied and free volume while seeding: 3 C reals;
/// - the field's grid state (θ at cells; θ and mass on both face lattices; five face
///   velocities): C + 7 (X + Y); and its θ while seeding: C;
/// - the Eulerian frame: θ, θ¹ and its rate (3 C), four face velocities (4 (X + Y)), three
///   lattices with two ghost layers ((64+5)(64+4) + (64+4)(64+5) + (64+4)²), the fluxes of u
///   ((64+2) 64 + 65²), of v (65² + 64 (64+2)) and of θ (X + Y).
///
/// Reals: 3·4096 + (4096 + 7·8320 + 4096) + (3·4096 + 4·8320 + 4692 + 4692 + 4624 + 4224
/// + 4225 + 4225 + 4224 + 8320) = 12,288 + 66,432 + 84,794 = 163,514; × 8 bytes.
const BY_HAND: u64 = 163_514 * 8;

#[test]
fn a_single_eulerian_field_of_64_squared_cells_counts_by_hand() {
    let case = Case::from_ron(CASE, Path::new("one_field.ron")).unwrap();
    let e = case.memory_estimate();
    assert_eq!(e.bytes, BY_HAND, "{:?}", e.breakdown);
    assert_eq!(e.bytes, 1_308_112);
    assert_eq!(e.points, 0);
    // the parts add up to the total
    assert_eq!(e.breakdown.iter().map(|p| p.1).sum::<u64>(), e.bytes);

    // `check` prints it
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("memory_estimate");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("one_field.ron");
    std::fs::write(&file, CASE).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_multifield")).arg("check").arg(&file).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("memory   about 1.3 MB at the peak (1,308,112 bytes"), "{text}");
}

#[test]
fn the_estimate_grows_with_the_grid_as_the_arrays_do_and_saturates() {
    let case = Case::from_ron(CASE, Path::new("one_field.ron")).unwrap();
    let mut big = case.clone();
    big.domain.cells = [1024, 1024];
    let (small, large) = (case.memory_estimate().bytes as f64, big.memory_estimate().bytes as f64);
    // 256 times the cells, a little less than 256 times the bytes (the faces' and ghosts' share shrinks)
    assert!((large / small) > 240.0 && (large / small) < 256.0, "{}", large / small);
    big.domain.cells = [usize::MAX, usize::MAX];
    assert_eq!(big.memory_estimate().bytes, u64::MAX);
}
