//! Pictures and charts: frames at output times (count, size, content) and the charts of a
//! run (PNG and SVG). The PNG files are decoded here (a small inflate below), so the tests
//! read the pixels the run wrote.

use multifield::core::case::{Case, PictureSpec, QuantityName};
use multifield::core::simulation::Simulation;
use multifield::picture::{diverging, sequential, Layout};
use multifield::run::{run, RunOptions};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;
use std::time::Instant;

fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("multifield-pictures-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn load(file: &str, sets: &[&str]) -> Case {
    multifield::link_all();
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    Case::load(file.as_ref(), &sets).unwrap()
}

fn frames(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    names.sort();
    names
}

/// Tests that read the DKT run; the last one to finish removes it.
static DKT_READERS: AtomicUsize = AtomicUsize::new(2);

fn done_with_dkt_run() {
    if DKT_READERS.fetch_sub(1, Ordering::SeqCst) == 1 {
        let _ = std::fs::remove_dir_all(dkt_run());
    }
}

/// The Uhlmann DKT scene, coarse and short, run once for the tests that read it.
fn dkt_run() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let case = load(
            "examples/dkt_uhlmann2005.ron",
            &["domain.cells=(16, 48)", "time.end=0.01", "output.pictures=Some((interval: 0.005, width: 200))"],
        );
        let dir = fresh_dir("dkt");
        let t = Instant::now();
        let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
        eprintln!("dkt run: {} steps in {:.2} s", out.summary.steps, t.elapsed().as_secs_f64());
        assert_eq!(out.summary.status, "completed", "{}", out.summary.reason);
        dir
    })
}

#[test]
fn dkt_frames_are_numbered_sized_and_show_the_bodies() {
    let dir = dkt_run();
    // t = 0, 0.005 and the last step at 0.01 (due then too: drawn once)
    assert_eq!(frames(dir), ["frame_000000.png", "frame_000001.png", "frame_000002.png"]);
    let (origin, size) = ([0.0, 0.0], [2.0, 6.0]);
    let lay = Layout::new(size, 200);
    assert_eq!(lay.field_height, 600, "the domain keeps its aspect (2 × 6)");
    for name in frames(dir) {
        let png = decode_png(&std::fs::read(dir.join("frames").join(&name)).unwrap());
        assert_eq!((png.width, png.height), (200, lay.height), "{name}");
        assert_eq!(png.height % 2, 0, "even height for yuv420p");
    }
    let png = decode_png(&std::fs::read(dir.join("frames/frame_000000.png")).unwrap());
    let r = 0.125;
    for (cx, cy) in [(1.001, 5.0), (0.999, 4.5)] {
        // the outline: dark on the circle, on all four sides
        for (dx, dy) in [(r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r)] {
            let (x, y) = lay.pixel(origin, size, cx + dx, cy + dy);
            let near = (-1..=1).flat_map(|a| (-1..=1).map(move |b| (a, b)));
            let darkest = near.map(|(a, b)| luminance(png.at(x + a, y + b))).fold(f64::MAX, f64::min);
            assert!(darkest < 90.0, "outline of the body at ({cx}, {cy}) missing at offset ({dx}, {dy}): {darkest}");
        }
        // inside: the body's material points as dots; the fluid at rest around it is white
        let inside = dark_pixels(&png, &lay, origin, size, (cx, cy), 0.7 * r);
        let away = dark_pixels(&png, &lay, origin, size, (0.5, 1.5), 0.7 * r);
        assert!(inside >= 4, "only {inside} dark pixels inside the body at ({cx}, {cy})");
        assert_eq!(away, 0, "the fluid at rest far from the bodies is white");
    }
    let (x, y) = lay.pixel(origin, size, 0.5, 1.5);
    assert_eq!(png.at(x, y), [255, 255, 255], "zero vorticity is white");
    // time stamp band and colour-bar band hold text and the bar (not all white)
    let band_dark = |rows: std::ops::Range<u32>| {
        rows.flat_map(|row| (0..png.width).map(move |c| (c, row)))
            .filter(|&(c, r)| luminance(png.at(c as i64, r as i64)) < 128.0)
            .count()
    };
    assert!(band_dark(0..lay.field_top) > 20, "no text above the domain");
    assert!(band_dark(lay.field_top + lay.field_height..lay.height) > 20, "no colour bar below the domain");
    done_with_dkt_run();
}

fn luminance(c: [u8; 3]) -> f64 {
    0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64
}

/// Pixels darker than mid-grey within `radius` of `centre`.
fn dark_pixels(png: &Png, lay: &Layout, origin: [f64; 2], size: [f64; 2], centre: (f64, f64), radius: f64) -> usize {
    let (x0, y0) = lay.pixel(origin, size, centre.0 - radius, centre.1 + radius);
    let (x1, y1) = lay.pixel(origin, size, centre.0 + radius, centre.1 - radius);
    let (cx, cy) = lay.pixel(origin, size, centre.0, centre.1);
    let rp = (x1 - x0) as f64 / 2.0;
    let mut n = 0;
    for y in y0..=y1 {
        for x in x0..=x1 {
            if ((x - cx) as f64).hypot((y - cy) as f64) <= rp && luminance(png.at(x, y)) < 160.0 {
                n += 1;
            }
        }
    }
    n
}

fn close(a: [u8; 3], b: [u8; 3], tol: i32) -> bool {
    (0..3).all(|k| (a[k] as i32 - b[k] as i32).abs() <= tol)
}

#[test]
fn taylor_green_frame_shows_the_vorticity_and_its_sign() {
    let case = load(
        "examples/taylor_green.ron",
        &["time.end=0.05", "output.pictures=Some((interval: 0.05, quantity: Vorticity, width: 160))"],
    );
    let dir = fresh_dir("tg");
    // a frame an earlier run left is removed by a run from t = 0
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    std::fs::write(dir.join("frames/frame_000099.png"), b"stale").unwrap();
    let out = run(&case, &dir, &RunOptions::quiet()).unwrap();
    assert_eq!(out.summary.status, "completed");
    assert_eq!(frames(&dir), ["frame_000000.png", "frame_000001.png"]);
    let size = [2.0 * PI, 2.0 * PI];
    let lay = Layout::new(size, 160);
    assert_eq!(lay.field_height, 160);
    // u = sin x cos y, v = −cos x sin y: ω = ∂v/∂x − ∂u/∂y = 2 sin x sin y, the same
    // picture at every time (the range follows the decay)
    for name in frames(&dir) {
        let png = decode_png(&std::fs::read(dir.join("frames").join(&name)).unwrap());
        assert_eq!((png.width, png.height), (160, lay.height), "{name}");
        let at = |x: f64, y: f64| {
            let (px, py) = lay.pixel([0.0, 0.0], size, x, y);
            png.at(px, py)
        };
        let (pos, neg, zero) = (at(PI / 2.0, PI / 2.0), at(1.5 * PI, PI / 2.0), at(PI, PI));
        assert!(close(pos, diverging(1.0), 10), "{name}: ω = +2 at (π/2, π/2) drawn {pos:?}");
        assert!(close(neg, diverging(-1.0), 10), "{name}: ω = −2 at (3π/2, π/2) drawn {neg:?}");
        assert!(close(at(PI / 2.0, 1.5 * PI), diverging(-1.0), 10), "{name}: ω = −2 at (π/2, 3π/2)");
        assert!(close(zero, [255, 255, 255], 6), "{name}: ω = 0 at (π, π) drawn {zero:?}");
        assert!(close(at(PI / 2.0, PI), [255, 255, 255], 6), "{name}: ω = 0 at (π/2, π)");
        // independent of the map's table: positive red, negative blue
        assert!(pos[0] as i32 > pos[2] as i32 + 60 && neg[2] as i32 > neg[0] as i32 + 60, "{pos:?} {neg:?}");
        // the colour bar runs from the negative end through white to the positive end
        let row = lay.bar_row as i64;
        let (c0, c1) = (lay.bar_columns.0 as i64, lay.bar_columns.1 as i64);
        assert!(close(png.at(c0 + 1, row), diverging(-1.0), 12), "{:?}", png.at(c0 + 1, row));
        assert!(close(png.at(c1 - 1, row), diverging(1.0), 12), "{:?}", png.at(c1 - 1, row));
        assert!(close(png.at((c0 + c1) / 2, row + 2), [255, 255, 255], 20), "{:?}", png.at((c0 + c1) / 2, row + 2));
    }
    // a case without bodies has no body chart
    assert!(dir.join("charts/diagnostics.png").exists());
    assert!(!dir.join("charts/bodies.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn speed_and_volume_fraction_use_the_sequential_map() {
    let dir = fresh_dir("maps");
    // the velocity of the Taylor–Green vortex, drawn as |u| with its components interpolated
    // apart: |u| = 1 at (π/2, π), 0 at (π/2, π/2)
    let sim = Simulation::new(&load("examples/taylor_green.ron", &[])).unwrap();
    let spec = picture("velocity", 128);
    let lay = multifield::picture::write_frame(&sim, &spec, &dir.join("speed.png")).unwrap();
    let png = decode_png(&std::fs::read(dir.join("speed.png")).unwrap());
    let size = [2.0 * PI, 2.0 * PI];
    let at = |x: f64, y: f64| {
        let (px, py) = lay.pixel([0.0, 0.0], size, x, y);
        png.at(px, py)
    };
    assert!(close(at(PI / 2.0, PI), sequential(1.0), 10), "{:?}", at(PI / 2.0, PI));
    // (half a pixel from the zero: |u| ≈ 0.035 there)
    assert!(close(at(PI / 2.0, PI / 2.0), sequential(0.0), 16), "{:?}", at(PI / 2.0, PI / 2.0));
    // the water's volume fraction around the seed's disks: 1 in the water, 0 in a disk
    let sim = Simulation::new(&load("examples/dkt_seed.ron", &[])).unwrap();
    let spec = picture("theta", 200);
    let lay = multifield::picture::write_frame(&sim, &spec, &dir.join("theta.png")).unwrap();
    let png = decode_png(&std::fs::read(dir.join("theta.png")).unwrap());
    let (origin, size) = ([0.0, 0.0], [2.0, 8.0]);
    let (x, y) = lay.pixel(origin, size, 1.0, 3.0);
    assert_eq!(png.at(x, y), sequential(1.0), "water");
    // inside the lower disk (centre (1, 6.8), r = 0.1): the empty end, between the dots
    let (cx, cy) = lay.pixel(origin, size, 1.0, 6.8);
    let inside: Vec<[u8; 3]> =
        (-3..=3).flat_map(|a| (-3..=3).map(move |b| (a, b))).map(|(a, b)| png.at(cx + a, cy + b)).collect();
    let empty = inside.iter().filter(|c| close(**c, sequential(0.0), 25)).count();
    assert!(empty * 2 > inside.len(), "{empty} of {} pixels inside the disk at θ = 0: {inside:?}", inside.len());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_continued_run_draws_the_frames_of_an_uninterrupted_one() {
    let case = load(
        "examples/taylor_green.ron",
        &[
            "time.end=0.2",
            "output.checkpoints=Some((interval: 0.1))",
            "output.pictures=Some((interval: 0.05, width: 64))",
        ],
    );
    let dir = fresh_dir("restart");
    run(&case, &dir, &RunOptions::quiet()).unwrap();
    let read = |name: &str| std::fs::read(dir.join("frames").join(name)).unwrap();
    let names = frames(&dir);
    assert_eq!(names.len(), 5, "t = 0, 0.05, 0.1, 0.15, 0.2: {names:?}");
    let before: Vec<Vec<u8>> = names.iter().map(|n| read(n)).collect();
    // continue from the checkpoint at t = 0.1: frames 0–2 (t ≤ 0.1) are kept, 3–4 redrawn
    let (step, checkpoint) = multifield::checkpoint::list(&dir).into_iter().min_by_key(|c| c.0).unwrap();
    assert_eq!(step, 2);
    for (name, bytes) in [("frame_000002.png", b"kept"), ("frame_000004.png", b"junk")] {
        std::fs::write(dir.join("frames").join(name), bytes).unwrap();
    }
    std::fs::write(dir.join("frames/frame_000007.png"), b"stale").unwrap();
    let options = RunOptions { restart: Some(checkpoint), ..RunOptions::quiet() };
    run(&case, &dir, &options).unwrap();
    assert_eq!(frames(&dir), names);
    assert_eq!(read("frame_000002.png"), b"kept");
    for k in [0, 1, 3, 4] {
        assert!(read(&names[k]) == before[k], "{} differs from the uninterrupted run's", names[k]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Steps longer than the pictures' interval (Δt = 0.05, a frame every 0.02): a frame per
/// step, not per interval, and a continued run keeps the frames `frames/frames.csv` lists
/// up to the checkpoint's step (three, not ⌊0.1/0.02⌋ + 1 = 6), then draws the rest as the
/// uninterrupted run did.
#[test]
fn a_continued_run_keeps_the_frames_drawn_when_steps_are_longer_than_the_interval() {
    let case = load(
        "examples/taylor_green.ron",
        &[
            "time.end=0.2",
            "time.fixed_dt=Some(0.05)",
            "output.checkpoints=Some((interval: 0.1))",
            "output.pictures=Some((interval: 0.02, width: 64))",
        ],
    );
    let dir = fresh_dir("restart_long_steps");
    run(&case, &dir, &RunOptions::quiet()).unwrap();
    let names = frames(&dir);
    assert_eq!(names.len(), 5, "steps 0 to 4: {names:?}");
    let index = std::fs::read_to_string(dir.join("frames/frames.csv")).unwrap();
    assert_eq!(index.lines().nth(3), Some("2,0.1,2"), "{index}");
    let before: Vec<Vec<u8>> = names.iter().map(|n| std::fs::read(dir.join("frames").join(n)).unwrap()).collect();
    let (step, checkpoint) = multifield::checkpoint::list(&dir).into_iter().min_by_key(|c| c.0).unwrap();
    assert_eq!(step, 2);
    let options = RunOptions { restart: Some(checkpoint), ..RunOptions::quiet() };
    run(&case, &dir, &options).unwrap();
    assert_eq!(frames(&dir), names);
    assert_eq!(std::fs::read_to_string(dir.join("frames/frames.csv")).unwrap(), index);
    for (k, n) in names.iter().enumerate() {
        assert!(std::fs::read(dir.join("frames").join(n)).unwrap() == before[k], "{n} differs");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn charts_are_written_as_png_and_svg_with_their_labels() {
    let dir = dkt_run();
    for stem in ["diagnostics", "bodies"] {
        let png = decode_png(&std::fs::read(dir.join(format!("charts/{stem}.png"))).unwrap());
        assert_eq!((png.width, png.height), (1200, 800), "{stem}.png");
        assert!(!dir.join(format!("charts/{stem}.partial.png")).exists());
    }
    let svg = std::fs::read_to_string(dir.join("charts/diagnostics.svg")).unwrap();
    for label in ["kinetic energy", "Δt", "max divergence", "pressure iterations", "time", "dkt_uhlmann2005"] {
        assert!(svg.contains(label), "diagnostics.svg lacks `{label}`");
    }
    let svg = std::fs::read_to_string(dir.join("charts/bodies.svg")).unwrap();
    for label in ["trajectories", "trailing", "leading", "domain", "vx", "vy", "time"] {
        assert!(svg.contains(label), "bodies.svg lacks `{label}`");
    }
    done_with_dkt_run();
}

#[test]
fn charts_skip_missing_data_and_name_the_file_they_cannot_write() {
    let dir = fresh_dir("charts");
    multifield::charts::write(&dir).unwrap();
    std::fs::write(dir.join("diagnostics.csv"), format!("{}\n", multifield::run::CSV_HEADER)).unwrap();
    multifield::charts::write(&dir).unwrap();
    assert!(!dir.join("charts").exists(), "no chart without data");
    std::fs::write(
        dir.join("diagnostics.csv"),
        format!("{}\n1,0.1,0.1,cfl,1,0,0,1,1,1e-9,0,5,1e-11,0,1\n", multifield::run::CSV_HEADER),
    )
    .unwrap();
    // a folder where the chart should go: the rename fails, and the error says which file
    std::fs::create_dir_all(dir.join("charts/diagnostics.png")).unwrap();
    let e = multifield::charts::write(&dir).unwrap_err().to_string();
    assert!(e.contains("diagnostics.png"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Time of one frame of the seed's DKT scene at 320 × 1280 cells, 640 pixels wide, on two
/// threads (run with `--ignored --nocapture`; prints the times).
#[test]
#[ignore]
fn frame_time_at_320_by_1280_cells() {
    // a flow everywhere (not the white of a fluid at rest, which costs nothing to encode)
    let case = load(
        "examples/dkt_seed.ron",
        &["domain.cells=(320, 1280)", "fields.water.velocity=TaylorGreen(amplitude: 1.0)"],
    );
    let sim = Simulation::new(&case).unwrap();
    let dir = fresh_dir("timing");
    let spec = picture("vorticity", 640);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    for k in 0..4 {
        let t = Instant::now();
        pool.install(|| multifield::picture::write_frame(&sim, &spec, &dir.join(format!("f{k}.png")))).unwrap();
        eprintln!("frame {k}: {:.3} s", t.elapsed().as_secs_f64());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- a PNG reader: zlib inflate (RFC 1950/1951) and the PNG filters, 8-bit RGB/RGBA ----

struct Png {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Png {
    fn at(&self, x: i64, y: i64) -> [u8; 3] {
        assert!(x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height, "pixel ({x}, {y}) outside");
        let k = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }
}

fn decode_png(bytes: &[u8]) -> Png {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    let (mut pos, mut idat, mut head) = (8, Vec::new(), None);
    while pos + 8 <= bytes.len() {
        let len = be(&bytes[pos..]) as usize;
        let kind = &bytes[pos + 4..pos + 8];
        let data = &bytes[pos + 8..pos + 8 + len];
        match kind {
            b"IHDR" => head = Some((be(data), be(&data[4..]), data[8], data[9], data[12])),
            b"IDAT" => idat.extend_from_slice(data),
            b"IEND" => break,
            _ => {}
        }
        pos += 12 + len;
    }
    let (width, height, depth, color, interlace) = head.expect("IHDR");
    assert!(depth == 8 && (color == 2 || color == 6) && interlace == 0, "8-bit RGB(A) only: {depth} {color}");
    let bpp = if color == 2 { 3 } else { 4 };
    let raw = inflate(&idat[2..]);
    let stride = width as usize * bpp;
    assert_eq!(raw.len(), height as usize * (stride + 1), "image data size");
    let mut img = vec![0u8; height as usize * stride];
    for r in 0..height as usize {
        let filter = raw[r * (stride + 1)];
        let line = &raw[r * (stride + 1) + 1..(r + 1) * (stride + 1)];
        for i in 0..stride {
            let a = if i >= bpp { img[r * stride + i - bpp] as i32 } else { 0 };
            let b = if r > 0 { img[(r - 1) * stride + i] as i32 } else { 0 };
            let c = if r > 0 && i >= bpp { img[(r - 1) * stride + i - bpp] as i32 } else { 0 };
            let pred = match filter {
                0 => 0,
                1 => a,
                2 => b,
                3 => (a + b) / 2,
                4 => {
                    let p = a + b - c;
                    let (pa, pb, pc) = ((p - a).abs(), (p - b).abs(), (p - c).abs());
                    if pa <= pb && pa <= pc {
                        a
                    } else if pb <= pc {
                        b
                    } else {
                        c
                    }
                }
                f => panic!("filter {f}"),
            };
            img[r * stride + i] = (line[i] as i32 + pred) as u8;
        }
    }
    let rgb = if bpp == 3 { img } else { img.chunks(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
    Png { width, height, rgb }
}

struct Bits<'a> {
    data: &'a [u8],
    pos: usize,
    buf: u32,
    n: u32,
}

impl Bits<'_> {
    fn get(&mut self, need: u32) -> u32 {
        while self.n < need {
            self.buf |= (self.data[self.pos] as u32) << self.n;
            self.pos += 1;
            self.n += 8;
        }
        let v = self.buf & ((1u32 << need) - 1);
        self.buf >>= need;
        self.n -= need;
        v
    }
}

/// Canonical Huffman code: counts per length and symbols in code order.
struct Huffman {
    counts: [u16; 16],
    symbols: Vec<u16>,
}

impl Huffman {
    fn new(lengths: &[u8]) -> Self {
        let mut counts = [0u16; 16];
        for &l in lengths {
            counts[l as usize] += 1;
        }
        counts[0] = 0;
        let mut offs = [0u16; 16];
        for l in 1..16 {
            offs[l] = offs[l - 1] + counts[l - 1];
        }
        let mut symbols = vec![0u16; lengths.len()];
        for (s, &l) in lengths.iter().enumerate() {
            if l > 0 {
                symbols[offs[l as usize] as usize] = s as u16;
                offs[l as usize] += 1;
            }
        }
        Huffman { counts, symbols }
    }

    fn decode(&self, bits: &mut Bits) -> u16 {
        let (mut code, mut first, mut index) = (0i32, 0i32, 0i32);
        for len in 1..16 {
            code |= bits.get(1) as i32;
            let count = self.counts[len] as i32;
            if code - first < count {
                return self.symbols[(index + code - first) as usize];
            }
            index += count;
            first = (first + count) << 1;
            code <<= 1;
        }
        panic!("bad Huffman code")
    }
}

fn inflate(data: &[u8]) -> Vec<u8> {
    const LBASE: [u16; 29] = [
        3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227,
        258,
    ];
    const LEXT: [u8; 29] = [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0];
    const DBASE: [u16; 30] = [
        1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537, 2049, 3073, 4097,
        6145, 8193, 12289, 16385, 24577,
    ];
    const DEXT: [u8; 30] =
        [0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13];
    const ORDER: [usize; 19] = [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15];
    let mut bits = Bits { data, pos: 0, buf: 0, n: 0 };
    let mut out: Vec<u8> = Vec::new();
    loop {
        let last = bits.get(1);
        match bits.get(2) {
            0 => {
                bits.buf = 0;
                bits.n = 0;
                let p = bits.pos;
                let len = u16::from_le_bytes([data[p], data[p + 1]]) as usize;
                out.extend_from_slice(&data[p + 4..p + 4 + len]);
                bits.pos = p + 4 + len;
            }
            kind @ (1 | 2) => {
                let (lit, dist) = if kind == 1 {
                    let mut l = [8u8; 288];
                    l[144..256].fill(9);
                    l[256..280].fill(7);
                    (Huffman::new(&l), Huffman::new(&[5u8; 30]))
                } else {
                    let hlit = bits.get(5) as usize + 257;
                    let hdist = bits.get(5) as usize + 1;
                    let hclen = bits.get(4) as usize + 4;
                    let mut cl = [0u8; 19];
                    for &o in ORDER.iter().take(hclen) {
                        cl[o] = bits.get(3) as u8;
                    }
                    let clh = Huffman::new(&cl);
                    let mut lengths = Vec::with_capacity(hlit + hdist);
                    while lengths.len() < hlit + hdist {
                        match clh.decode(&mut bits) {
                            s @ 0..=15 => lengths.push(s as u8),
                            16 => {
                                let prev = *lengths.last().expect("repeat with no length");
                                let n = 3 + bits.get(2) as usize;
                                lengths.resize(lengths.len() + n, prev);
                            }
                            17 => {
                                let n = 3 + bits.get(3) as usize;
                                lengths.resize(lengths.len() + n, 0);
                            }
                            _ => {
                                let n = 11 + bits.get(7) as usize;
                                lengths.resize(lengths.len() + n, 0);
                            }
                        }
                    }
                    (Huffman::new(&lengths[..hlit]), Huffman::new(&lengths[hlit..]))
                };
                loop {
                    let s = lit.decode(&mut bits) as usize;
                    if s < 256 {
                        out.push(s as u8);
                    } else if s == 256 {
                        break;
                    } else {
                        let k = s - 257;
                        let len = LBASE[k] as usize + bits.get(LEXT[k] as u32) as usize;
                        let d = dist.decode(&mut bits) as usize;
                        let back = DBASE[d] as usize + bits.get(DEXT[d] as u32) as usize;
                        let start = out.len() - back;
                        for i in 0..len {
                            out.push(out[start + i]);
                        }
                    }
                }
            }
            t => panic!("deflate block type {t}"),
        }
        if last == 1 {
            return out;
        }
    }
}

/// A picture of `quantity` (the mixture's, or the field that fills the rest) every 0.1.
fn picture(quantity: &str, width: u32) -> PictureSpec {
    PictureSpec {
        interval: 0.1,
        times: Vec::new(),
        at_end: false,
        quantity: QuantityName(quantity.into()),
        field: None,
        width,
        slice: Vec::new(),
    }
}
