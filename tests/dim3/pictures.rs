//! PNG pictures of 3D cases, drawn on slices (`output.pictures.slice`): the values of a
//! slice against the Taylor–Green vortex's (exactly, on a layer of cells and between two),
//! its pixels against the colour-mapped analytic field, the orientation of the in-plane
//! axes, a slice of a flow uniform along z against the 2D compile's picture of the same
//! flow (the same pixels), the frames of a run (a folder per slice, the same bytes on 1 and
//! 2 threads and after a restart), and bad `slice` input.

use multifield3d::core::case::{Case, PictureSpec, QuantityName, Slice, SliceAxis};
use multifield3d::core::math::Real;
use multifield3d::core::quantity::{self, Place, Sample};
use multifield3d::core::simulation::Simulation;
use multifield3d::picture::{diverging, scalar, sequential, write_slice, Layout, Plane};
use multifield3d::run::{run, RunOptions};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dim3-pictures").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn case3(text: &str) -> Case {
    multifield3d::link_all();
    let case = Case::from_ron(text, Path::new("pictures3.ron")).unwrap_or_else(|e| panic!("{e}"));
    case.validate().unwrap_or_else(|e| panic!("{e}"));
    case
}

/// The Taylor–Green vortex of amplitude 1 on the periodic cube [0, 2π]³ of n³ cells.
fn tgv_text(n: usize, output: &str) -> String {
    let l = 2.0 * PI;
    format!(
        r#"(
    name: "tgv3",
    domain: (size: ({l}, {l}, {l}), cells: ({n}, {n}, {n})),
    boundaries: (left: Periodic, right: Periodic, bottom: Periodic, top: Periodic, back: Periodic, front: Periodic),
    time: (end: 0.1, cfl: 0.5, max_dt: 0.05),
    fields: [(name: "water", frame: (model: "eulerian"), density: 1.0, region: All,
              velocity: TaylorGreen(amplitude: 1.0), stress: [(model: "newtonian", params: {{"viscosity": 0.1}})])],
    pressure: Some((model: "multigrid")),
    output: ({output}),
)"#
    )
}

fn spec(quantity: &str, width: u32, slice: Vec<Slice>) -> PictureSpec {
    PictureSpec {
        interval: 0.05,
        times: Vec::new(),
        at_end: false,
        quantity: QuantityName(quantity.into()),
        field: None,
        width,
        slice,
    }
}

fn z(at: Real) -> Slice {
    Slice { axis: SliceAxis::Z, at }
}

/// A decoded 8-bit RGB(A) PNG.
struct Png {
    width: u32,
    height: u32,
    channels: usize,
    data: Vec<u8>,
}

impl Png {
    fn read(path: &Path) -> Png {
        let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut data = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut data).unwrap();
        assert_eq!(info.bit_depth, png::BitDepth::Eight, "{}", path.display());
        let channels = info.color_type.samples();
        data.truncate(info.buffer_size());
        Png { width: info.width, height: info.height, channels, data }
    }
    fn at(&self, x: i64, y: i64) -> [u8; 3] {
        let k = (y as usize * self.width as usize + x as usize) * self.channels;
        [self.data[k], self.data[k + 1], self.data[k + 2]]
    }
    /// Rows `rows` as RGB bytes.
    fn rows(&self, rows: std::ops::Range<u32>) -> Vec<u8> {
        rows.flat_map(|y| (0..self.width).flat_map(move |x| self.at(x as i64, y as i64))).collect()
    }
}

fn within(a: [u8; 3], b: [u8; 3], tol: i32) -> bool {
    (0..3).all(|k| (a[k] as i32 - b[k] as i32).abs() <= tol)
}

/// The vorticity's z component of the Taylor–Green vortex (amplitude 1) as the code
/// computes it at the cell centres: 2 sin x sin y cos z, times cos(h/2) (a cell's velocity
/// is the mean of its two faces) and sin h / h (central differences across two cells),
/// both exact for these sines.
fn omega_z(h: Real, x: Real, y: Real, z: Real) -> Real {
    2.0 * (0.5 * h).cos() * h.sin() / h * x.sin() * y.sin() * z.cos()
}

/// On a layer of cell centres the slice is that layer of the field's array, bit for bit;
/// half-way between two layers (z = π, a face of 16 cells) it is their mean, which for the
/// vortex is ω_z(z = π) cos(h/2). Both against the discrete analytic vorticity to 1e-13.
#[test]
fn a_slice_holds_the_fields_values_on_a_layer_and_between_two() {
    let n = 16;
    let sim = Simulation::new(&case3(&tgv_text(n, ""))).unwrap();
    let g = &sim.grid;
    let h = g.h;
    let sample = Sample::of(&sim);
    let q = quantity::find("vorticity", Place::Mixture).unwrap();
    let full = sample.cells(q, None).unwrap();
    assert_eq!(full.len(), 3 * n * n * n);
    let k = 5;
    let on_layer = z((k as Real + 0.5) * h);
    let plane = Plane::of(g, [true; 3], Some(&on_layer)).unwrap();
    assert_eq!((plane.cells, plane.axes, plane.layers()), ([n, n], [0, 1, 2], Some((k, k + 1, 0.0))));
    let s = scalar(&sim, &spec("vorticity", 64, vec![on_layer]), &plane).unwrap();
    assert_eq!(s.label, "vorticity_z");
    let mut worst: Real = 0.0;
    for j in 0..n {
        for i in 0..n {
            let c = i + n * (j + n * k);
            assert_eq!(s.values[i + n * j].to_bits(), full[3 * c + 2].to_bits(), "cell ({i}, {j}, {k})");
            let (x, y, zc) = ((i as Real + 0.5) * h, (j as Real + 0.5) * h, on_layer.at);
            worst = worst.max((s.values[i + n * j] - omega_z(h, x, y, zc)).abs());
        }
    }
    assert!(worst < 1e-13, "layer {k}: {worst:e} from the discrete ω_z");
    // z = π: between layers 7 and 8, weight ½
    let plane = Plane::of(g, [true; 3], Some(&z(PI))).unwrap();
    assert_eq!(plane.layers(), Some((7, 8, 0.5)));
    let s = scalar(&sim, &spec("vorticity", 64, vec![z(PI)]), &plane).unwrap();
    let mut worst: Real = 0.0;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = ((i as Real + 0.5) * h, (j as Real + 0.5) * h);
            worst = worst.max((s.values[i + n * j] - omega_z(h, x, y, PI) * (0.5 * h).cos()).abs());
        }
    }
    assert!(worst < 1e-13, "z = π: {worst:e} from the mean of the two layers");
    // the range: ± the 99.5th percentile of |ω_z| on the slice, here its largest value
    // (sixteen cells share it), 2 cos²(h/2) sin h / h sin²(3.5 h)
    let top = 2.0 * (0.5 * h).cos().powi(2) * h.sin() / h * (3.5 * h).sin().powi(2);
    assert!((s.hi - top).abs() < 1e-13 && s.lo == -s.hi, "range ±{} against ±{top}", s.hi);
}

/// The pixels of a slice of the vortex (32³, z = π) are the colour-mapped analytic field:
/// ω_z / max on the diverging map and |u| / max on viridis, within 5 and 8 levels. The
/// painter interpolates bilinearly between cell centres, off by at most h²/8 (|f_xx| +
/// |f_yy|) ≤ h²/4 of the range (0.0096 at h = 2π/32); the steepest segment of each map
/// moves a channel by 375 (diverging) and 664 (viridis) levels per unit of the range: 3.6
/// and 6.4 levels, plus one of rounding.
#[test]
fn the_pixels_of_a_taylor_green_slice_are_the_analytic_fields_colours() {
    let n = 32;
    let out = dir("tgv_pixels");
    let sim = Simulation::new(&case3(&tgv_text(n, ""))).unwrap();
    let h = sim.grid.h;
    let size = [2.0 * PI, 2.0 * PI];
    let width = 256;
    let (lay, plane) =
        write_slice(&sim, &spec("vorticity", width, vec![z(PI)]), Some(&z(PI)), &out.join("w.png")).unwrap();
    assert_eq!(lay, Layout::new(size, width));
    assert_eq!(plane.size, size);
    let png = Png::read(&out.join("w.png"));
    assert_eq!((png.width, png.height), (width, lay.height));
    // the largest of a function over the cell centres of the plane
    let centres = (0..n).flat_map(|j| (0..n).map(move |i| ((i as Real + 0.5) * h, (j as Real + 0.5) * h)));
    let largest = |f: &dyn Fn(Real, Real) -> Real| centres.clone().map(|(x, y)| f(x, y).abs()).fold(0.0, Real::max);
    // the slice at z = π: ω = ω_z(π) cos(h/2); the range ± its largest value on the cells
    // (the 99.5th percentile: sixteen cells share the largest)
    let top = largest(&|x, y| omega_z(h, x, y, PI) * (0.5 * h).cos());
    let mut checked = 0;
    for (x, y) in [(0.5 * PI, 0.5 * PI), (1.5 * PI, 0.5 * PI), (0.5 * PI, 1.5 * PI), (PI, PI), (0.3, 2.0), (4.0, 5.5)] {
        let (px, py) = lay.pixel([0.0, 0.0], size, x, y);
        // the pixel's centre
        let cx = (px as Real + 0.5) / width as Real * size[0];
        let cy = (1.0 - (py - lay.field_top as i64) as Real / lay.field_height as Real) * size[1]
            - 0.5 / lay.field_height as Real * size[1];
        let expected = diverging(omega_z(h, cx, cy, PI) * (0.5 * h).cos() / top);
        let drawn = png.at(px, py);
        assert!(within(drawn, expected, 5), "ω_z at ({x}, {y}): drawn {drawn:?}, analytic {expected:?}");
        checked += 1;
    }
    assert_eq!(checked, 6);
    // cos π = −1: negative at (π/2, π/2), blue
    let (px, py) = lay.pixel([0.0, 0.0], size, 0.5 * PI, 0.5 * PI);
    let blue = png.at(px, py);
    assert!(blue[2] as i32 > blue[0] as i32 + 60, "{blue:?}");
    // |u| = cos²(h/2) √(sin²x cos²y + cos²x sin²y) on the slice's cells (w = 0; the faces'
    // mean and the mean of the layers cos(π ± h/2) each give a cos(h/2)): viridis from 0
    // to its largest value on the cells, so the factor cancels
    let (lay, _) = write_slice(&sim, &spec("velocity", width, vec![z(PI)]), Some(&z(PI)), &out.join("u.png")).unwrap();
    let png = Png::read(&out.join("u.png"));
    let speed = |x: Real, y: Real| (x.sin() * y.cos()).hypot(x.cos() * y.sin());
    let top = largest(&speed);
    for (x, y) in [(0.5 * PI, PI), (0.5 * PI, 0.5 * PI), (1.0, 2.5), (5.0, 0.7)] {
        let (px, py) = lay.pixel([0.0, 0.0], size, x, y);
        let cx = (px as Real + 0.5) / width as Real * size[0];
        let cy = (1.0 - (py - lay.field_top as i64) as Real / lay.field_height as Real) * size[1]
            - 0.5 / lay.field_height as Real * size[1];
        let expected = sequential(speed(cx, cy) / top);
        let drawn = png.at(px, py);
        assert!(within(drawn, expected, 8), "|u| at ({x}, {y}): drawn {drawn:?}, analytic {expected:?}");
    }
}

/// A slice normal to x is drawn with y across and z up: a rigid rotation about the z axis,
/// u = (−(y − ½), x − ½, 0), has on the plane x = x₀ the speed √((y − ½)² + (x₀ − ½)²),
/// which varies across the picture and not up it. Away from the walls (whose normal faces
/// are 0) the slice's values are that speed to 1e-15.
#[test]
fn a_slice_normal_to_x_has_y_across_and_z_up() {
    let n = 16;
    let text = format!(
        r#"(
    name: "rotation3",
    domain: (size: (1.0, 1.0, 1.0), cells: ({n}, {n}, {n})),
    time: (end: 0.1, max_dt: 0.01),
    fields: [(name: "water", frame: (model: "eulerian"), density: 1.0, region: All,
              velocity: RigidRotation(center: (0.5, 0.5, 0.5), angular_velocity: (0.0, 0.0, 1.0)))],
    pressure: Some((model: "multigrid")),
)"#
    );
    let sim = Simulation::new(&case3(&text)).unwrap();
    let h = sim.grid.h;
    let slice = Slice { axis: SliceAxis::X, at: 4.5 * h };
    let plane = Plane::of(&sim.grid, [false; 3], Some(&slice)).unwrap();
    assert_eq!((plane.axes, plane.layers()), ([1, 2, 0], Some((4, 5, 0.0))));
    assert_eq!(plane.title(), "x = 0.281 (y →, z ↑)");
    let s = scalar(&sim, &spec("velocity", 64, vec![slice]), &plane).unwrap();
    assert_eq!((s.rest.len(), s.label.as_str()), (2, "|velocity|"));
    // the speed on the cells: |u| from the components
    let speed: Vec<Real> = (0..s.values.len()).map(|c| s.values[c].hypot(s.rest[0][c]).hypot(s.rest[1][c])).collect();
    let x0 = 4.5 * h - 0.5;
    for k in 0..n {
        for j in 1..n - 1 {
            let y = (j as Real + 0.5) * h - 0.5;
            let c = j + n * k;
            assert!(
                (speed[c] - y.hypot(x0)).abs() < 1e-15,
                "(y, z) cell ({j}, {k}): {} against {}",
                speed[c],
                y.hypot(x0)
            );
        }
    }
    // drawn: left and right differ, up and down do not
    let out = dir("x_slice");
    let (lay, _) = write_slice(&sim, &spec("velocity", 128, vec![slice]), Some(&slice), &out.join("x.png")).unwrap();
    let png = Png::read(&out.join("x.png"));
    let at = |y: Real, z: Real| {
        let (px, py) = lay.pixel([0.0, 0.0], [1.0, 1.0], y, z);
        png.at(px, py)
    };
    // √(0.4² + x0²) at y = 0.9, |x0| = 0.219 at y = 0.5, for any z
    assert_eq!(at(0.5, 0.2), at(0.5, 0.8));
    assert_eq!(at(0.9, 0.2), at(0.9, 0.8));
    let (centre, edge) = (at(0.5, 0.5), at(0.9, 0.5));
    assert!(centre[0] < 80 && edge[1] > 150, "viridis: the slow centre dark {centre:?}, the fast edge bright {edge:?}");
}

/// A rigid rotation about z in a box 16 × 16 × 4 periodic along z, with a block of a second
/// field through z, is the 2D rotation with the rectangle in every plane: the slice z = 1/8
/// (between layers 1 and 2) holds the 2D picture's values bit for bit, and its pixels over
/// the domain and the colour bar are the 2D picture's, byte for byte, for the speed, the
/// vorticity (ω_z in 3D) and the block's volume fraction. (The bands of text differ: the
/// title names the slice, the label the component.)
#[test]
fn a_slice_of_a_flow_uniform_along_z_is_the_2d_picture() {
    let common = |dim: usize| {
        let (size, cells, sides, centre, omega, region) = if dim == 3 {
            (
                "(1.0, 1.0, 0.25)",
                "(16, 16, 4)",
                "left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip, back: Periodic, front: Periodic",
                "(0.5, 0.5, 0.0)",
                "(0.0, 0.0, 1.0)",
                "Box(min: (0.125, 0.25, 0.0), max: (0.4375, 0.625, 0.25))",
            )
        } else {
            (
                "(1.0, 1.0)",
                "(16, 16)",
                "left: NoSlip, right: NoSlip, bottom: NoSlip, top: NoSlip",
                "(0.5, 0.5)",
                "1.0",
                "Rectangle(min: (0.125, 0.25), max: (0.4375, 0.625))",
            )
        };
        format!(
            r#"(
    name: "uniform_along_z",
    domain: (size: {size}, cells: {cells}),
    boundaries: ({sides}),
    time: (end: 0.1, max_dt: 0.01),
    fields: [
        (name: "water", frame: (model: "eulerian"), density: 1.0, region: Rest,
         velocity: RigidRotation(center: {centre}, angular_velocity: {omega})),
        (name: "block", frame: (model: "eulerian"), density: 2.0, region: {region}, volume_fraction: 0.5,
         velocity: RigidRotation(center: {centre}, angular_velocity: {omega})),
    ],
    exchange: [(between: ("water", "block"), model: "constant", params: (coefficient: 10.0))],
    pressure: Some((model: "multigrid")),
)"#
        )
    };
    let sim3 = Simulation::new(&case3(&common(3))).unwrap();
    multifield::link_all();
    let case2 = multifield::core::case::Case::from_ron(&common(2), Path::new("uniform2.ron")).unwrap();
    case2.validate().unwrap();
    let sim2 = multifield::core::simulation::Simulation::new(&case2).unwrap();
    let out = dir("uniform_along_z");
    let slice = z(0.125);
    for (quantity, field) in [("velocity", None), ("vorticity", None), ("theta", Some("block"))] {
        let mut s3 = spec(quantity, 96, vec![slice]);
        s3.field = field.map(String::from);
        let s2 = multifield::core::case::PictureSpec {
            interval: s3.interval,
            times: Vec::new(),
            at_end: false,
            quantity: multifield::core::case::QuantityName(quantity.into()),
            field: s3.field.clone(),
            width: s3.width,
            slice: Vec::new(),
        };
        // the values
        let plane3 = Plane::of(&sim3.grid, [false, false, true], Some(&slice)).unwrap();
        assert_eq!(plane3.layers(), Some((1, 2, 0.5)));
        let v3 = scalar(&sim3, &s3, &plane3).unwrap();
        let plane2 = multifield::picture::Plane::of(&sim2.grid, [false; 2], None).unwrap();
        let v2 = multifield::picture::scalar(&sim2, &s2, &plane2).unwrap();
        let bits = |v: &[Real]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&v3.values), bits(&v2.values), "{quantity}");
        assert_eq!(v3.rest.len(), v2.rest.len() + usize::from(quantity == "velocity"), "{quantity}");
        assert_eq!(bits(&v3.rest[..v2.rest.len()].concat()), bits(&v2.rest.concat()), "{quantity}");
        assert!(v3.rest.get(1).is_none_or(|w| w.iter().all(|&w| w == 0.0)), "{quantity}: w = 0");
        assert_eq!((v3.lo.to_bits(), v3.hi.to_bits()), (v2.lo.to_bits(), v2.hi.to_bits()), "{quantity}: range");
        // the pixels
        let (p3, p2) = (out.join(format!("{quantity}3.png")), out.join(format!("{quantity}2.png")));
        let (lay3, _) = write_slice(&sim3, &s3, Some(&slice), &p3).unwrap();
        let lay2 = multifield::picture::write_frame(&sim2, &s2, &p2).unwrap();
        let parts = |l: (u32, u32, u32, u32, u32)| l;
        assert_eq!(
            parts((lay3.width, lay3.height, lay3.field_top, lay3.field_height, lay3.bar_row)),
            (lay2.width, lay2.height, lay2.field_top, lay2.field_height, lay2.bar_row)
        );
        let (png3, png2) = (Png::read(&p3), Png::read(&p2));
        assert_eq!((png3.width, png3.height), (png2.width, png2.height));
        // the domain, the colour bar and its frame
        let bar_bottom = lay3.bar_row - lay3.font / 2 + lay3.font;
        let rows = lay3.field_top..bar_bottom + 1;
        assert!(png3.rows(rows.clone()) == png2.rows(rows.clone()), "{quantity}: the pixels differ");
        // and not all of one colour: the picture shows the flow
        let first = png3.at(2, lay3.field_top as i64 + 2);
        let varied =
            (0..png3.width as i64).any(|x| png3.at(x, (lay3.field_top + lay3.field_height / 2) as i64) != first);
        assert!(varied, "{quantity}: a picture of one colour");
        // the text bands differ (the slice in the title)
        assert!(png3.rows(0..lay3.field_top) != png2.rows(0..lay3.field_top), "{quantity}: the title");
    }
}

/// A run writes each slice's frames into its own folder with its own index; the frames are
/// the same bytes on 1 and 2 threads, and a run continued from a checkpoint draws the
/// frames of the uninterrupted one.
#[test]
fn a_run_draws_each_slice_into_its_folder_the_same_on_any_threads_and_after_a_restart() {
    let output = "pictures: Some((interval: 0.05, width: 48, slice: [(axis: z, at: 3.14), (axis: y, at: 0.0)])), \
                  checkpoints: Some((interval: 0.05)), charts: false";
    let case = case3(&tgv_text(8, output));
    let list = |d: &Path| {
        let mut v: Vec<String> = walk(d);
        v.sort();
        v
    };
    let one = dir("run1");
    let a = run(&case, &one, &RunOptions { threads: 1, ..RunOptions::quiet() }).unwrap();
    assert_eq!(a.summary.steps, 2);
    let frames = list(&one.join("frames"));
    assert_eq!(
        frames,
        [
            "y_0/frame_000000.png",
            "y_0/frame_000001.png",
            "y_0/frame_000002.png",
            "y_0/frames.csv",
            "z_3.14/frame_000000.png",
            "z_3.14/frame_000001.png",
            "z_3.14/frame_000002.png",
            "z_3.14/frames.csv",
        ]
    );
    let png = Png::read(&one.join("frames/z_3.14/frame_000001.png"));
    let lay = Layout::new([2.0 * PI, 2.0 * PI], 48);
    assert_eq!((png.width, png.height), (48, lay.height));
    let index = std::fs::read_to_string(one.join("frames/y_0/frames.csv")).unwrap();
    assert_eq!(index.lines().count(), 4, "{index}");
    let two = dir("run2");
    run(&case, &two, &RunOptions { threads: 2, ..RunOptions::quiet() }).unwrap();
    let restarted = dir("restarted");
    run(&case, &restarted, &RunOptions { threads: 2, ..RunOptions::quiet() }).unwrap();
    let checkpoint = multifield3d::checkpoint::list(&restarted).into_iter().min_by_key(|c| c.0).unwrap();
    assert_eq!(checkpoint.0, 1);
    std::fs::write(restarted.join("frames/z_3.14/frame_000002.png"), b"junk").unwrap();
    run(&case, &restarted, &RunOptions { restart: Some(checkpoint.1), threads: 1, ..RunOptions::quiet() }).unwrap();
    for f in &frames {
        let bytes = std::fs::read(one.join("frames").join(f)).unwrap();
        assert!(bytes == std::fs::read(two.join("frames").join(f)).unwrap(), "{f}: 1 and 2 threads differ");
        assert!(bytes == std::fs::read(restarted.join("frames").join(f)).unwrap(), "{f}: the restart differs");
    }
}

fn walk(d: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if p.is_dir() {
            out.extend(walk(&p).into_iter().map(|f| format!("{name}/{f}")));
        } else {
            out.push(name);
        }
    }
    out
}

/// Bad `slice` input: an unknown axis or key at its line and column with the valid
/// choices; a coordinate outside the domain with the valid range; none in 3D with an
/// example; one in 2D, which is drawn whole.
#[test]
fn bad_slices_are_refused_with_the_place_and_the_fix() {
    multifield3d::link_all();
    let text = |slice: &str| tgv_text(8, &format!("pictures: Some((interval: 0.05,\n        slice: {slice}))"));
    let err = |t: &str| match Case::from_ron(t, Path::new("bad.ron")).and_then(|c| c.validate().map(|_| c)) {
        Ok(_) => panic!("accepted: {t}"),
        Err(e) => e.to_string(),
    };
    // the slice is on line 10 of the case
    let line = text("X").lines().position(|l| l.contains("slice: X")).unwrap() + 1;
    assert_eq!(line, 10);
    let e = err(&text("(axis: w, at: 1.0)"));
    assert!(e.starts_with("bad.ron:10:") && e.contains("`w`") && e.contains("x, y, z"), "{e}");
    let e = err(&text("(axis: z, position: 1.0)"));
    assert!(e.starts_with("bad.ron:10:") && e.contains("unknown key `position`") && e.contains("axis, at"), "{e}");
    let e = err(&text("[(axis: z, at: 1.0), (axis: q, at: 2.0)]"));
    assert!(e.starts_with("bad.ron:10:") && e.contains("`q`"), "{e}");
    let e = err(&text("(axis: y, at: 7.0)"));
    assert!(
        e.contains(
            "output.pictures.slice: at = 7: outside the domain along y; give a coordinate in [0, 6.28318530717958"
        ),
        "{e}"
    );
    let e = err(&text("[(axis: z, at: 1.0), (axis: x, at: -0.5)]"));
    assert!(e.contains("output.pictures.slice.1: at = -0.5: outside the domain along x"), "{e}");
    let e = err(&text("[(axis: z, at: 1.0), (axis: z, at: 1.0)]"));
    assert!(e.contains("output.pictures.slice.1: (z, at: 1) is listed twice"), "{e}");
    let e = err(&tgv_text(8, "pictures: Some((interval: 0.05))"));
    assert!(e.contains("output.pictures.slice: a 3D picture is a plane of cells") && e.contains("at: 3.14159"), "{e}");
    // in 2D
    multifield::link_all();
    let two = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/taylor_green.ron")).unwrap();
    let case = multifield::core::case::Case::from_ron(&two, Path::new("tg.ron"))
        .unwrap()
        .with_overrides(&["output.pictures=Some((interval: 0.1, slice: (axis: z, at: 0.5)))".into()])
        .unwrap();
    let e = case.validate().unwrap_err().to_string();
    assert!(e.contains("output.pictures.slice: a 2D case is drawn whole"), "{e}");
}
