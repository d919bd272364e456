//! The fuzzing harness on the stable toolchain: a few thousand seeded mutations of the seed
//! corpus (testdata/fuzz/*.exr, lenses/*.toml, films/*.toml, and the sequence patterns and
//! ranges, `--state` files, OpenColorIO configs and `--flare-lights` files made here) through
//! the entry points that the
//! cargo-fuzz targets in fuzz/ call (`realcam::tools::fuzz`), in this process. Every case must
//! end without a panic, without an abort, without allocating more than the entry points'
//! budget, and with no NaN/Inf in a successful result. The mutations are the same on every run
//! (a fixed seed); a failing case prints its seed file and number.
//!
//! The seed EXRs are written by `write_fuzz_seeds` (ignored; run it with `--ignored` to make
//! them again).

use realcam::tools::fuzz;
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bytes allocated and not yet freed, and the most since the last reset.
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
/// The case being run, for the message of a refused allocation.
static CASE: AtomicUsize = AtomicUsize::new(0);

/// What one case may allocate above what was live before it: the entry points' budget and a
/// little for the harness.
const CASE_LIMIT: usize = fuzz::BUDGET.max_bytes as usize + (32 << 20);

/// The system allocator, counting; it refuses any single allocation above [`CASE_LIMIT`] (the
/// process then aborts, after saying which case asked).
struct Counting;

fn added(size: usize) {
    let now = LIVE.fetch_add(size, Ordering::Relaxed) + size;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

fn refused(size: usize) {
    // No allocation here: the message is put together on the stack.
    let mut buf = [0u8; 128];
    let mut n = 0;
    let mut put = |bytes: &[u8]| {
        let take = bytes.len().min(buf.len() - n);
        buf[n..n + take].copy_from_slice(&bytes[..take]);
        n += take;
    };
    let digits = |mut v: usize| {
        let (mut out, mut len) = ([0u8; 20], 0);
        loop {
            out[19 - len] = b'0' + (v % 10) as u8;
            len += 1;
            v /= 10;
            if v == 0 {
                break (out, 20 - len);
            }
        }
    };
    put(b"\nfuzz_mutations: refused an allocation of ");
    let (d, from) = digits(size);
    put(&d[from..]);
    put(b" bytes in case ");
    let (d, from) = digits(CASE.load(Ordering::Relaxed));
    put(&d[from..]);
    put(b"\n");
    // SAFETY: writes `n` initialised bytes of `buf` to standard error.
    unsafe { libc::write(2, buf.as_ptr().cast(), n) };
}

/// `allocate()` unless `size` is beyond [`CASE_LIMIT`], counted.
fn counted(size: usize, allocate: impl FnOnce() -> *mut u8) -> *mut u8 {
    if size > CASE_LIMIT {
        refused(size);
        return std::ptr::null_mut();
    }
    let p = allocate();
    if !p.is_null() {
        added(size);
    }
    p
}

// SAFETY: every call is forwarded to the system allocator with the same layout; the counters
// are plain atomics.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        counted(layout.size(), || System.alloc(layout))
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        counted(layout.size(), || System.alloc_zeroed(layout))
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = counted(new_size, || System.realloc(ptr, layout, new_size));
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// xorshift64*: the same mutations on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Values that break readers: zero, signs, the ends of the integer types, sizes near limits.
const INTERESTING_I32: [i32; 12] = [0, 1, -1, 2, 255, 65535, 100_000, 1 << 20, i32::MAX, i32::MIN, -100_000, 16_385];

/// A binary mutation of `seed`: bit flips, bytes and 32-bit integers set to interesting values
/// (half of them in the header, the first 400 bytes), ranges cut, repeated or truncated.
fn mutate_binary(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    // Mostly one change: a file with several broken places is refused at the first.
    for _ in 0..1 + usize::from(rng.below(4) == 0) {
        if b.is_empty() {
            break;
        }
        let span = if rng.below(2) == 0 { b.len().min(400) } else { b.len() };
        let at = rng.below(span);
        match rng.below(7) {
            0 => b[at] ^= 1 << rng.below(8),
            1 => b[at] = [0x00, 0xff, 0x7f, 0x80, 0x01][rng.below(5)],
            2 | 3 => {
                let v = INTERESTING_I32[rng.below(INTERESTING_I32.len())].to_le_bytes();
                let end = (at + 4).min(b.len());
                b[at..end].copy_from_slice(&v[..end - at]);
            }
            4 => {
                let end = (at + 1 + rng.below(64)).min(b.len());
                b.drain(at..end);
            }
            5 => {
                let end = (at + 1 + rng.below(64)).min(b.len());
                let piece = b[at..end].to_vec();
                let to = rng.below(b.len());
                b.splice(to..to, piece);
            }
            _ => b.truncate(at),
        }
    }
    b
}

/// Numbers that break parsers and the physics behind them.
const INTERESTING_NUMBERS: [&str; 16] = [
    "nan",
    "inf",
    "-inf",
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e-308",
    "-1",
    "1e12",
    "-50",
    "0.5",
    "4294967297",
    "3",
    "\"x\"",
    "[]",
];

/// A text mutation of `seed`: a number replaced by an interesting one, a line dropped, doubled
/// or swapped, a control character put in, or a binary mutation.
fn mutate_text(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let text = String::from_utf8_lossy(seed).into_owned();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return mutate_binary(seed, rng);
    }
    for _ in 0..1 + rng.below(3) {
        let i = rng.below(lines.len());
        match rng.below(8) {
            0..=3 => {
                // The n-th number of the line.
                let line = &lines[i];
                let starts: Vec<usize> = line
                    .char_indices()
                    .filter(|&(k, c)| {
                        (c.is_ascii_digit() || c == '-')
                            && (k == 0
                                || !line.as_bytes()[k - 1].is_ascii_alphanumeric() && line.as_bytes()[k - 1] != b'_')
                    })
                    .map(|(k, _)| k)
                    .collect();
                if let Some(&start) = starts.get(rng.below(starts.len().max(1))) {
                    let end = line[start..]
                        .find(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+' | '_')))
                        .map_or(line.len(), |e| start + e);
                    let value = INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())];
                    lines[i] = format!("{}{value}{}", &line[..start], &line[end..]);
                }
            }
            4 => {
                lines.remove(i);
                if lines.is_empty() {
                    break;
                }
            }
            5 => {
                let line = lines[i].clone();
                lines.insert(i, line);
            }
            6 => {
                let j = rng.below(lines.len());
                lines.swap(i, j);
            }
            _ => {
                let at = rng.below(lines[i].len() + 1);
                if lines[i].is_char_boundary(at) {
                    lines[i].insert(at, ['\0', '\x07', '\u{7f}', '\u{feff}'][rng.below(4)]);
                }
            }
        }
    }
    let mut out = lines.join("\n").into_bytes();
    out.push(b'\n');
    if rng.below(8) == 0 {
        out = mutate_binary(&out, rng);
    }
    out
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// The `.ext` files of a folder of the repository, sorted by name.
fn seeds(folder: &str, ext: &str) -> Seeds {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo(folder))
        .unwrap_or_else(|e| panic!("{folder}: {e}"))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    files.sort();
    files.into_iter().map(|p| (p.display().to_string(), std::fs::read(&p).unwrap())).collect()
}

/// Sequences as `fuzz::sequence` takes them: a path pattern, a newline, a frame range.
const SEQUENCE_SEEDS: [&str; 5] = [
    "shot/beauty.####.exr\n1001-1100",
    "b.%04d.exr\n1-10x3,20,-4--2",
    "render/frame_@@@.exr\n1003-1009:2",
    "f_%d\n-3-3",
    "still.exr\n1",
];

/// OpenColorIO configs: a linear space with aliases and an anchor, a matrix (ACEScg), a display
/// with its curve, roles and a file rule; the second names a LUT.
const OCIO_SEEDS: [&str; 2] = [
    "ocio_profile_version: 2\n\
     roles:\n  default: lin_rec709\n  scene_linear: lin_rec709\n\
     file_rules:\n  - !<Rule> {name: Default, colorspace: default}\n\
     displays:\n  sRGB:\n    - !<View> {name: Raw, colorspace: lin_rec709}\n    - !<View> {name: Display, colorspace: srgb}\n\
     colorspaces:\n\
     \x20 - !<ColorSpace>\n    name: lin_rec709\n    aliases: [linear, lin_srgb]\n    family: &fam Scene\n    encoding: scene-linear\n\
     \x20 - !<ColorSpace>\n    name: acescg\n    family: *fam\n\
     \x20   to_scene_reference: !<MatrixTransform> {matrix: [1.7051, -0.6218, -0.0833, 0, -0.1302, 1.1408, -0.0106, 0, -0.0240, -0.1290, 1.1530, 0, 0, 0, 0, 1]}\n\
     \x20 - !<ColorSpace>\n    name: srgb\n    family: Display\n\
     \x20   from_scene_reference: !<ExponentTransform> {value: [2.2, 2.2, 2.2, 1], direction: inverse}\n",
    "ocio_profile_version: 2\nsearch_path: luts\n\
     roles:\n  default: acescg\n\
     displays:\n  sRGB:\n    - !<View> {name: Raw, colorspace: acescg}\n\
     colorspaces:\n\
     \x20 - !<ColorSpace>\n    name: acescg\n\
     \x20   to_scene_reference: !<MatrixTransform> {matrix: [1.7051, -0.6218, -0.0833, 0, -0.1302, 1.1408, -0.0106, 0, -0.0240, -0.1290, 1.1530, 0, 0, 0, 0, 1]}\n\
     \x20 - !<ColorSpace>\n    name: log\n\
     \x20   to_scene_reference: !<FileTransform> {src: curve.spi1d, interpolation: linear}\n",
];

/// `--flare-lights` files: white and coloured lights, in and out of the frame, and none.
const LIGHTS_SEEDS: [&str; 3] = [
    "[\n  {\"x\": 100, \"y\": 50.5, \"energy\": 1000},\n  {\"x\": -20, \"y\": 3e2, \"rgb\": [1, 0.5, 0.25], \"area_px\": 4}\n]\n",
    "[{\"x\": 0.5, \"y\": 0.5, \"rgb\": [0, 0, 1e6]}]\n",
    "[]\n",
];

/// `texts` as seeds named `what` 0, 1, ...
fn text_seeds(what: &str, texts: &[&str]) -> Seeds {
    texts.iter().enumerate().map(|(i, t)| (format!("{what} {i}"), t.as_bytes().to_vec())).collect()
}

/// Long exposures' `--state` files: two frames of a 3x2 RGBA image, and no frame.
fn state_seeds() -> Seeds {
    use realcam::model::long_exposure::LongExposure;
    let image = |v: f32| realcam::io::Image { width: 3, height: 2, channels: 4, data: vec![v; 24] };
    let mut two = LongExposure::new("camera settings");
    two.add(1001, &image(0.25)).unwrap();
    two.add(1003, &image(4.0)).unwrap();
    vec![
        ("state of 2 frames".into(), two.to_bytes()),
        ("state of no frame".into(), LongExposure::new("camera settings").to_bytes()),
    ]
}

type Entry = fn(&[u8]) -> Result<fuzz::Outcome, fuzz::Violation>;

/// Named files and their bytes.
type Seeds = Vec<(String, Vec<u8>)>;

/// Runs `entry` on every seed and `count` mutations of them; returns the cases run and how
/// many were accepted.
fn run(
    name: &str,
    entry: Entry,
    seeds: &[(String, Vec<u8>)],
    count: usize,
    text: bool,
    rng: &mut Rng,
) -> (usize, usize) {
    assert!(!seeds.is_empty(), "{name}: no seeds");
    let (mut cases, mut accepted) = (0, 0);
    let mut check = |label: &str, input: &[u8]| {
        let case = CASE.fetch_add(1, Ordering::Relaxed);
        let before = LIVE.load(Ordering::Relaxed);
        PEAK.store(before, Ordering::Relaxed);
        let outcome = std::panic::catch_unwind(|| entry(input));
        let peak = PEAK.load(Ordering::Relaxed).saturating_sub(before);
        // A failing input is kept to run again (target/fuzz-failure-NAME-CASE.bin).
        let keep = || {
            let path = repo(&format!("target/fuzz-failure-{name}-{case}.bin"));
            let _ = std::fs::write(&path, input);
            path.display().to_string()
        };
        match outcome {
            Err(_) => panic!("{name} case {case} ({label}): panicked; the input is in {}", keep()),
            Ok(Err(violation)) => panic!("{name} case {case} ({label}): {violation}; the input is in {}", keep()),
            Ok(Ok(outcome)) => accepted += usize::from(outcome == fuzz::Outcome::Accepted),
        }
        assert!(peak <= CASE_LIMIT, "{name} case {case} ({label}): allocated {peak} bytes at once");
        cases += 1;
    };
    for (path, bytes) in seeds {
        check(&format!("seed {path}"), bytes);
    }
    for i in 0..count {
        let (path, seed) = &seeds[i % seeds.len()];
        let input = if text { mutate_text(seed, rng) } else { mutate_binary(seed, rng) };
        check(&format!("mutation {i} of {path}"), &input);
    }
    (cases, accepted)
}

#[test]
fn seeded_mutations_neither_panic_nor_abort_nor_overallocate_nor_give_nan() {
    let start = std::time::Instant::now();
    let mut rng = Rng(0x5eed_2026_0c0f_fee5);
    let lenses = seeds("lenses", "toml");
    let films = seeds("films", "toml");
    let prescriptions: Vec<_> = lenses.iter().filter(|(p, _)| p.contains("tessar")).cloned().collect();
    let groups: [(&str, Entry, Seeds, usize, bool); 8] = [
        ("exr_passes", fuzz::exr_passes, seeds("testdata/fuzz", "exr"), 6000, false),
        ("lens_file", fuzz::lens_file, lenses, 6000, true),
        ("film_file", fuzz::film_file, films, 3000, true),
        ("prescription", fuzz::prescription, prescriptions, 1500, true),
        ("sequence", fuzz::sequence, text_seeds("sequence", &SEQUENCE_SEEDS), 3000, true),
        ("state_file", fuzz::state_file, state_seeds(), 2000, false),
        ("ocio_config", fuzz::ocio_config, text_seeds("config", &OCIO_SEEDS), 1500, true),
        ("flare_lights", fuzz::flare_lights, text_seeds("lights", &LIGHTS_SEEDS), 3000, true),
    ];
    let mut total = 0;
    for (name, entry, seeds, count, text) in groups {
        let t = std::time::Instant::now();
        let (cases, accepted) = run(name, entry, &seeds, count, text, &mut rng);
        eprintln!("{name}: {cases} cases ({accepted} accepted) in {:.1} s", t.elapsed().as_secs_f64());
        // Mutations that all fail at the first check would test nothing behind it.
        assert!(accepted * 10 >= cases, "{name}: only {accepted} of {cases} accepted");
        total += cases;
    }
    eprintln!("{total} cases in {:.1} s", start.elapsed().as_secs_f64());
    let decoder_panics = realcam::io::exr_read::DECODER_PANICS.load(Ordering::Relaxed);
    assert_eq!(decoder_panics, 0, "the exr crate panicked {decoder_panics} time(s) (caught, made errors)");
    assert!(total >= 26_000);
}

/// The seed EXRs of testdata/fuzz/ are what `write_fuzz_seeds` makes: written again into a
/// temporary folder, each decodes to the same layers, channels, windows and samples as the
/// committed file (`REALCAM_WRITE_FUZZ_SEEDS=1` writes them into testdata/fuzz/ instead).
/// huge_tiled_header.exr is a hand-made header, not generated.
#[test]
fn fuzz_seeds_are_what_the_generator_writes() {
    if std::env::var_os("REALCAM_WRITE_FUZZ_SEEDS").is_some() {
        write_fuzz_seeds(&repo("testdata/fuzz"));
        return;
    }
    let dir = std::env::temp_dir().join(format!("realcam-fuzz-seeds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_fuzz_seeds(&dir);
    for name in ["blender_layers.exr", "nuke_window.exr", "two_parts.exr", "tiled.exr"] {
        let read = |path: PathBuf| {
            exr::prelude::read_all_data_from_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        };
        let fresh = read(dir.join(name));
        let committed = read(repo("testdata/fuzz").join(name));
        assert!(fresh == committed, "testdata/fuzz/{name} is not what write_fuzz_seeds makes");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The seed EXRs: small files that reach every branch of the pass reader.
fn write_fuzz_seeds(dir: &Path) {
    use exr::prelude::*;
    std::fs::create_dir_all(dir).unwrap();
    let (w, h) = (4usize, 3usize);
    let ramp = |base: f32| (0..w * h).map(|i| base + i as f32 * 0.125).collect::<Vec<f32>>();
    let layer = |name: Option<&str>, chans: &[(&str, Vec<f32>)], encoding: Encoding, position: (i32, i32)| {
        let list = chans.iter().map(|(c, v)| AnyChannel::new(*c, FlatSamples::F32(v.clone()))).collect();
        let mut attrs = name.map_or_else(LayerAttributes::default, LayerAttributes::named);
        attrs.layer_position = Vec2(position.0, position.1);
        Layer::new((w, h), attrs, encoding, AnyChannels::sort(list))
    };
    let display = IntegerBounds::new(Vec2(0, 0), Vec2(8, 6));
    // Blender multilayer, two view layers, half samples (ZIP).
    let mut chans = Vec::new();
    for (l, base) in [("Alpha", 0.25f32), ("Beta", 2.0)] {
        for c in ["R", "G", "B", "A"] {
            chans.push((format!("{l}.Combined.{c}"), ramp(base)));
        }
        chans.push((format!("{l}.Depth.Z"), ramp(1.0)));
        for c in ["X", "Y", "Z", "W"] {
            chans.push((format!("{l}.Vector.{c}"), ramp(-1.0)));
        }
    }
    let half: Vec<AnyChannel<FlatSamples>> = chans
        .iter()
        .map(|(c, v)| {
            AnyChannel::new(c.as_str(), FlatSamples::F16(v.iter().map(|&x| half::f16::from_f32(x)).collect()))
        })
        .collect();
    let blender =
        Layer::new((w, h), LayerAttributes::default(), Encoding::SMALL_LOSSLESS, AnyChannels::sort(half.into()));
    Image::from_layer(blender).write().to_file(dir.join("blender_layers.exr")).unwrap();
    // Nuke naming, float, a data window inside a larger display window, RLE.
    let nuke: Vec<(&str, Vec<f32>)> = vec![
        ("R", ramp(0.5)),
        ("G", ramp(0.25)),
        ("B", ramp(0.125)),
        ("A", ramp(1.0)),
        ("Z", ramp(3.0)),
        ("forward.u", ramp(1.0)),
        ("forward.v", ramp(-1.0)),
    ];
    let encoding = Encoding { compression: Compression::RLE, ..Encoding::UNCOMPRESSED };
    Image::from_layers(ImageAttributes::new(display), vec![layer(None, &nuke, encoding, (2, 1))])
        .write()
        .to_file(dir.join("nuke_window.exr"))
        .unwrap();
    // Two parts, uncompressed.
    let parts = vec![
        layer(Some("beauty"), &[("R", ramp(0.5)), ("G", ramp(0.5)), ("B", ramp(0.5))], Encoding::UNCOMPRESSED, (0, 0)),
        layer(Some("depth"), &[("Z", ramp(2.0))], Encoding::UNCOMPRESSED, (0, 0)),
    ];
    Image::from_layers(ImageAttributes::new(display), parts).write().to_file(dir.join("two_parts.exr")).unwrap();
    // Tiled (2x2 tiles), PIZ.
    let tiled_encoding = Encoding {
        compression: Compression::PIZ,
        blocks: Blocks::Tiles(Vec2(2, 2)),
        line_order: LineOrder::Increasing,
    };
    Image::from_layers(
        ImageAttributes::new(IntegerBounds::new(Vec2(0, 0), Vec2(w, h))),
        vec![layer(
            None,
            &[("R", ramp(0.5)), ("G", ramp(0.5)), ("B", ramp(0.5)), ("depth", ramp(4.0))],
            tiled_encoding,
            (0, 0),
        )],
    )
    .write()
    .to_file(dir.join("tiled.exr"))
    .unwrap();
}
