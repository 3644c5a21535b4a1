//! The lid-driven cube at Re 1000 (examples/dim3/cavity.ron) against Albensoeder & Kuhlmann
//! (J. Comput. Phys. 206, 2005, Tables 5 and 6; validation/dim3/cavity): the coarse version
//! of the comparison in docs/validation.md ("The lid-driven cube"), which runs 32³ and 64³.

use multifield3d::core::case::Case;
use multifield3d::run::{run, RunOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// (station, reference value) of a table of validation/dim3/cavity (its last two columns).
fn table(name: &str) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(Path::new(ROOT).join("validation/dim3/cavity").join(name)).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[2], v[3])
        })
        .collect()
}

/// The last row of a monitor's CSV, by column name.
fn last_row(path: &Path) -> std::collections::HashMap<String, f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names = lines.next().unwrap().split(',');
    let last = lines.last().unwrap().split(',').map(|x| x.parse().unwrap());
    names.map(String::from).zip(last).collect()
}

/// Runs the example on n³ cells to its steady stop; returns the RMS and the largest
/// difference to Table 5 (u on x = y = ½) and Table 6 (w on y = z = ½) over the 15 interior
/// stations of each, as validation/dim3/cavity/cavity.py computes them.
fn errors(n: usize) -> [(f64, f64); 2] {
    multifield3d::link_all();
    let file = Path::new(ROOT).join("examples/dim3/cavity.ron");
    let case = Case::load(&file, &[format!("domain.cells=({n}, {n}, {n})"), "output.charts=false".into()]).unwrap();
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("dim3-cavity").join(n.to_string());
    let _ = std::fs::remove_dir_all(&out);
    let outcome = run(&case, &out, &RunOptions::quiet()).unwrap();
    let reason = &outcome.summary.reason;
    assert!(reason.contains("steady") && outcome.summary.simulated_time < 100.0, "{n}³: {reason}");
    let compare = |csv: &str, monitor: &str, component: &str| {
        let row = last_row(&out.join("monitors").join(format!("{monitor}.csv")));
        let reference = table(csv);
        let d: Vec<f64> =
            (1..reference.len() - 1).map(|i| row[&format!("p{i}_{component}")] - reference[i].1).collect();
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
        (rms, d.iter().fold(0.0_f64, |m, x| m.max(x.abs())))
    };
    [
        compare("albensoeder_kuhlmann2005_re1000_table5.csv", "vertical", "x"),
        compare("albensoeder_kuhlmann2005_re1000_table6.csv", "horizontal", "z"),
    ]
}

/// At 16³ the steady centre-line profiles are within RMS 0.0685 (u, Table 5) and 0.0788
/// (w, Table 6) of the spectral solution, largest differences 0.142 and 0.158, measured;
/// asserted within 5 % of these. A uniform 16³ grid puts 2 cells in the lid's boundary layer
/// and the limited advection is first order at the extrema, so the error is large; what the
/// test guards is that it stays where it is and falls with h: from 12³ (RMS 0.0902 and
/// 0.0952) to 16³ by the factors 0.76 and 0.83 (asserted below 0.80 and 0.87), as a
/// first-order error would (12/16 = 0.75). At 32³ and 64³ see docs/validation.md.
#[test]
fn cavity_re1000_approaches_albensoeder_kuhlmann() {
    let start = Instant::now();
    let coarse = errors(12);
    let fine = errors(16);
    let wall = start.elapsed().as_secs_f64();
    eprintln!("cavity Re 1000, (RMS, max) of u and w: 12³ {coarse:.4?}, 16³ {fine:.4?} ({wall:.1} s)");
    let [(u_rms, u_max), (w_rms, w_max)] = fine;
    assert!(u_rms < 0.0685 * 1.05 && w_rms < 0.0788 * 1.05, "16³: RMS u {u_rms:.4}, w {w_rms:.4}");
    assert!(u_max < 0.142 * 1.05 && w_max < 0.158 * 1.05, "16³: max u {u_max:.4}, w {w_max:.4}");
    let ratios = [fine[0].0 / coarse[0].0, fine[1].0 / coarse[1].0];
    assert!(ratios[0] < 0.80 && ratios[1] < 0.87, "RMS 16³/12³ {ratios:.3?}");
}
