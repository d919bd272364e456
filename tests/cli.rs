//! End-to-end tests of the `realcam` command line: error messages, exit codes, that failed
//! runs never clobber existing outputs, and the files a successful render writes.
//!
//! Every test works in its own temporary directory and runs the real binary. Runs that reach
//! the GPU use `--validate` (Khronos validation with synchronization validation): the binary
//! exits non-zero when the layer reports anything.

use realcam::io::{read_exr_channel, read_exr_rgba, write_exr_channels, write_exr_rgba};
use realcam::io::{ExrWriteOptions, Image};
use realcam::tools::synth::{write_scene, SynthScene};
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh directory for one test (and a separate pipeline-cache directory), removed on drop.
struct TestDir {
    path: PathBuf,
    cache: PathBuf,
}

impl TestDir {
    fn new(test: &str) -> TestDir {
        let base = std::env::temp_dir();
        let pid = std::process::id();
        let path = base.join(format!("realcam-cli-{test}-{pid}"));
        let cache = base.join(format!("realcam-cli-cache-{test}-{pid}"));
        for d in [&path, &cache] {
            let _ = std::fs::remove_dir_all(d);
            std::fs::create_dir_all(d).unwrap_or_else(|e| panic!("creating {}: {e}", d.display()));
        }
        TestDir { path, cache }
    }

    fn join(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// Absolute path of `name` in this directory, as a string for the command line.
    fn arg(&self, name: &str) -> String {
        self.join(name).to_str().expect("UTF-8 temp path").to_string()
    }

    /// The names of the entries of this directory.
    fn listing(&self) -> BTreeSet<String> {
        std::fs::read_dir(&self.path).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
    }

    /// Writes the synthetic scene as `<name>_color.exr` and `<name>_depth.exr`.
    fn scene(&self, name: &str, scene: &SynthScene) {
        write_scene(&self.path, name, scene).unwrap_or_else(|e| panic!("{e}"));
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
        let _ = std::fs::remove_dir_all(&self.cache);
    }
}

/// The result of one run of the binary.
struct Run {
    args: Vec<OsString>,
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

impl Run {
    fn describe(&self) -> String {
        format!(
            "realcam {:?}\nexit code: {:?}\n--- stdout ---\n{}\n--- stderr ---\n{}",
            self.args, self.code, self.stdout, self.stderr
        )
    }

    /// Asserts exit code 0; returns self.
    fn success(self) -> Run {
        assert_eq!(self.code, Some(0), "expected success:\n{}", self.describe());
        self
    }

    /// Asserts an ordinary failure (exit code 1, an `error:` line, no panic); returns stderr.
    fn failure(self) -> String {
        assert_eq!(self.code, Some(1), "expected exit code 1:\n{}", self.describe());
        assert!(self.stderr.contains("error: "), "no error line:\n{}", self.describe());
        assert!(!self.stderr.contains("panicked"), "the binary panicked:\n{}", self.describe());
        self.stderr
    }
}

/// Runs `realcam <args>` in `dir` with the pipeline cache in the test's cache directory.
fn realcam<I, S>(dir: &TestDir, args: I) -> Run
where
    I: IntoIterator<Item = S>,
    S: Into<OsString>,
{
    realcam_env(dir, args, &[])
}

/// [`realcam`] with the environment variables `env` set.
fn realcam_env<I, S>(dir: &TestDir, args: I, env: &[(&str, &str)]) -> Run
where
    I: IntoIterator<Item = S>,
    S: Into<OsString>,
{
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    let out = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(&args)
        .env_remove("OCIO")
        .envs(env.iter().copied())
        .current_dir(&dir.path)
        .env("REALCAM_CACHE_DIR", &dir.cache)
        .env_remove("REALCAM_VALIDATE")
        .output()
        .expect("running the realcam binary");
    Run {
        args,
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Runs `realcam render --validate <args>`.
fn render(dir: &TestDir, args: &[String]) -> Run {
    let mut all = vec!["render".to_string(), "--validate".to_string()];
    all.extend(args.iter().cloned());
    realcam(dir, all)
}

/// `["a", "b"]` as owned strings.
fn s(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

fn assert_contains(haystack: &str, needle: &str) {
    assert!(haystack.contains(needle), "expected to find\n  {needle}\nin\n{haystack}");
}

fn float_opts() -> ExrWriteOptions {
    ExrWriteOptions { float32: true, ..ExrWriteOptions::default() }
}

/// A `w`x`h` RGBA image filled with a constant color (alpha 1).
fn rgba(w: u32, h: u32, rgb: [f32; 3]) -> Image {
    let mut im = Image::new(w, h, 4);
    for px in im.data.chunks_exact_mut(4) {
        px.copy_from_slice(&[rgb[0], rgb[1], rgb[2], 1.0]);
    }
    im
}

/// Writes a color-only EXR (channels R, G, B, A; no depth).
fn write_color_only(path: &Path, w: u32, h: u32) {
    write_exr_rgba(path, &rgba(w, h, [0.2, 0.3, 0.4]), &float_opts()).unwrap();
}

/// Writes a one-channel depth EXR (channel Z).
fn write_depth(path: &Path, w: u32, h: u32, z: &[f32]) {
    assert_eq!(z.len(), (w * h) as usize);
    write_exr_channels(path, w, h, &[("Z", z)], &float_opts()).unwrap();
}

/// A small valid scene (`scene_color.exr`, `scene_depth.exr`) and the render arguments that
/// read it; the camera settings under test are appended by the caller.
fn small_scene(dir: &TestDir) -> Vec<String> {
    scene_args(dir, "scene", &SynthScene::point_on_plane(16, 12, 3.0, [5.0; 3]))
}

/// Writes `scene` as `<name>_color.exr` and `<name>_depth.exr`; the arguments that read it and
/// write `out.exr`.
fn scene_args(dir: &TestDir, name: &str, scene: &SynthScene) -> Vec<String> {
    dir.scene(name, scene);
    let (color, depth) = (format!("{name}_color.exr"), format!("{name}_depth.exr"));
    vec!["--color".into(), dir.arg(&color), "--depth".into(), dir.arg(&depth), "-o".into(), dir.arg("out.exr")]
}

/// The first header of an EXR file.
fn exr_header(path: &Path) -> exr::meta::header::Header {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .unwrap_or_else(|e| panic!("reading the header of {}: {e}", path.display()));
    meta.headers.into_iter().next().expect("a header")
}

/// The attribute `key` of the first header's own attributes that the exr crate keeps by name
/// (the standard ones it has fields for are read from those).
fn attribute(path: &Path, key: &str) -> exr::meta::attribute::AttributeValue {
    let header = exr_header(path);
    let other = &header.own_attributes.other;
    other
        .get(&exr::meta::attribute::Text::from(key))
        .cloned()
        .unwrap_or_else(|| panic!("no attribute {key:?} in {:?}", other.keys().collect::<Vec<_>>()))
}

fn text_value(s: &str) -> exr::meta::attribute::AttributeValue {
    exr::meta::attribute::AttributeValue::Text(exr::meta::attribute::Text::from(s))
}

/// No temporary or partial files: every entry of the directory is one of `expected`.
fn assert_listing(dir: &TestDir, expected: &[&str]) {
    let expected: BTreeSet<String> = expected.iter().map(|e| e.to_string()).collect();
    assert_eq!(dir.listing(), expected, "unexpected directory contents");
}

// ---------------------------------------------------------------------------------------------
// 1-5: input files
// ---------------------------------------------------------------------------------------------

#[test]
fn missing_color_file_names_the_path() {
    let dir = TestDir::new("missing_color");
    let color = dir.arg("no_such_color.exr");
    let err = render(&dir, &s(&["--color", &color, "-o", &dir.arg("out.exr")])).failure();
    assert_contains(&err, &format!("error: color: file \"{color}\" does not exist"));
    assert_listing(&dir, &[]);
}

#[test]
fn missing_depth_channel_lists_the_channels_found() {
    let dir = TestDir::new("missing_depth");
    let color = dir.join("color.exr");
    write_color_only(&color, 8, 6);
    let err = render(&dir, &s(&["--color", &dir.arg("color.exr"), "-o", &dir.arg("out.exr")])).failure();
    assert_contains(
        &err,
        &format!(
            "error: depth: no depth channel in \"{}\" (looked for <layer>.Depth.Z, Z, depth.Z, depth.R, depth",
            color.display()
        ),
    );
    assert_contains(&err, "; channels found: A, B, G, R");
    assert_listing(&dir, &["color.exr"]);
}

#[test]
fn depth_channel_override_not_found_lists_the_channels_found() {
    let dir = TestDir::new("depth_override");
    let path = dir.join("passes.exr");
    let n = 8 * 6;
    let (r, g, b, a, z) = (vec![0.5; n], vec![0.4; n], vec![0.3; n], vec![1.0; n], vec![2.0; n]);
    let chans: [(&str, &[f32]); 5] = [("R", &r), ("G", &g), ("B", &b), ("A", &a), ("Z", &z)];
    write_exr_channels(&path, 8, 6, &chans, &float_opts()).unwrap();
    let err =
        render(&dir, &s(&["--color", &dir.arg("passes.exr"), "--depth-channel", "Depth.Z", "-o", &dir.arg("out.exr")]))
            .failure();
    assert_contains(
        &err,
        &format!(
            "error: depth: channel \"Depth.Z\" (from the override \"Depth.Z\") not found in \"{}\"; channels found: A, B, G, R, Z",
            path.display()
        ),
    );
    assert_listing(&dir, &["passes.exr"]);
}

#[test]
fn size_mismatch_names_both_files_and_sizes() {
    let dir = TestDir::new("size_mismatch");
    let (color, depth) = (dir.join("color.exr"), dir.join("depth.exr"));
    write_color_only(&color, 8, 6);
    write_depth(&depth, 4, 3, &[1.0; 12]);
    let err = render(
        &dir,
        &s(&["--color", &dir.arg("color.exr"), "--depth", &dir.arg("depth.exr"), "-o", &dir.arg("out.exr")]),
    )
    .failure();
    assert_contains(
        &err,
        &format!(
            "size mismatch: color (channel R) \"{}\" is 8x6 px but depth (channel Z) \"{}\" is 4x3 px",
            color.display(),
            depth.display()
        ),
    );
    assert_listing(&dir, &["color.exr", "depth.exr"]);
}

#[test]
fn nan_and_negative_depth_give_the_pixel_and_value() {
    let dir = TestDir::new("bad_depth");
    let (color, depth) = (dir.join("color.exr"), dir.join("depth.exr"));
    let (w, h) = (8u32, 6u32);
    write_color_only(&color, w, h);
    let args = s(&["--color", &dir.arg("color.exr"), "--depth", &dir.arg("depth.exr"), "-o", &dir.arg("out.exr")]);
    let at = |x: u32, y: u32| (y * w + x) as usize;

    // NaN at (x=5, y=2), alone.
    let mut z = vec![3.0f32; (w * h) as usize];
    z[at(5, 2)] = f32::NAN;
    write_depth(&depth, w, h, &z);
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!(
            "depth: channel Z in \"{}\" has 1 invalid pixel(s) (NaN or negative depth); \
             the first is pixel (x=5, y=2) of the data window with NaN m",
            depth.display()
        ),
    );

    // Negative at (x=1, y=4), alone.
    let mut z = vec![3.0f32; (w * h) as usize];
    z[at(1, 4)] = -2.5;
    write_depth(&depth, w, h, &z);
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        "has 1 invalid pixel(s) (NaN or negative depth); the first is pixel (x=1, y=4) of the data window with -2.5 m",
    );

    // Both: the count is 2 and the first in row-major order is reported.
    z[at(6, 0)] = f32::NAN;
    write_depth(&depth, w, h, &z);
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        "has 2 invalid pixel(s) (NaN or negative depth); the first is pixel (x=6, y=0) of the data window with NaN m",
    );
    assert_listing(&dir, &["color.exr", "depth.exr"]);
}

// ---------------------------------------------------------------------------------------------
// 6: lens files and the lens's range
// ---------------------------------------------------------------------------------------------

const VALID_LENS: &str = "name = \"test lens\"\nsource = \"test\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\n";

#[test]
fn lens_file_that_does_not_exist_is_named() {
    let dir = TestDir::new("lens_missing");
    let mut args = small_scene(&dir);
    let lens = dir.arg("no_such_lens.toml");
    args.extend(s(&["--lens", &lens]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, &format!("error: lens file {lens}: cannot read it"));
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr"]);
}

#[test]
fn lens_file_syntax_error_gives_the_line() {
    let dir = TestDir::new("lens_syntax");
    let mut args = small_scene(&dir);
    let lens = dir.arg("bad.toml");
    std::fs::write(&lens, "name = \"x\"\nsource = \"y\"\nfocal_length_mm = = 50\nf_number_min = 1.4\n").unwrap();
    args.extend(s(&["--lens", &lens]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, &format!("error: lens file {lens}, line 3: "));
}

#[test]
fn lens_file_unknown_key_is_named() {
    let dir = TestDir::new("lens_unknown_key");
    let mut args = small_scene(&dir);
    let lens = dir.arg("typo.toml");
    std::fs::write(&lens, format!("{VALID_LENS}focal_lenght = 3\n[aperture]\nblades = 9\n")).unwrap();
    args.extend(s(&["--lens", &lens]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, &format!("error: lens file {lens}, line 7: "));
    assert_contains(&err, "focal_lenght");
}

#[test]
fn request_outside_the_lens_range_needs_force() {
    let dir = TestDir::new("lens_range");
    let mut args = small_scene(&dir);
    args.extend(s(&["--fstop", "1.0"]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        "error: f/1 is outside what the lens \"realcam standard 50 mm f/1.4\" allows (f/1.4 to f/16); \
         pass --force to use it anyway",
    );
    assert!(!dir.join("out.exr").exists(), "out.exr written on failure");

    // With --force the same request renders, at the requested f-number.
    args.push("--force".into());
    render(&dir, &args).success();
    assert_eq!(exr_header(&dir.join("out.exr")).own_attributes.aperture, Some(1.0));
    assert_eq!(read_exr_rgba(&dir.join("out.exr")).unwrap().width, 16);
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "out.exr"]);
}

/// `--lens ideal` is the renderers' lens: any focal length and f-number without --force, the
/// renderers' CoC model, no natural vignetting, and `--explain` says why the vignette is skipped.
#[test]
fn the_ideal_lens_takes_any_focal_length_and_does_not_vignette() {
    let dir = TestDir::new("ideal_lens");
    let mut args = small_scene(&dir);
    args.extend(s(&["--lens", "ideal", "--focal-length", "35", "--fstop", "0.9", "--explain"]));
    let err = render(&dir, &args).success().stderr;
    assert_contains(&err, "[skip] vignette");
    assert_contains(&err, "the lens has no natural vignetting (the ideal lens, or natural_vignetting = false)");
    assert!(!err.contains("--no-vignetting"), "{err}");
    assert_eq!(exr_header(&dir.join("out.exr")).own_attributes.aperture, Some(0.9));
    // The renderer's camera draws no lens flare unless --flare asks for it (issue 29).
    let off = "off: --lens ideal is the renderer's camera, which draws none; --flare draws it";
    assert_contains(&err, &format!("lens flare: {off}"));
    assert_contains(&err, &format!("[skip] flare         {off}"));
    let mut args = small_scene(&dir);
    args.extend(s(&["--lens", "ideal", "--flare", "--explain"]));
    let err = render(&dir, &args).success().stderr;
    assert_contains(&err, "lens flare: on");
    assert!(!err.contains(off), "{err}");
    let mut args = small_scene(&dir);
    args.extend(s(&["--lens", "ideal", "--flare", "--no-flare"]));
    let run = render(&dir, &args);
    assert_eq!(run.code, Some(2), "{}", run.describe());
    assert_contains(&run.stderr, "the argument '--flare' cannot be used with '--no-flare'");
    // The other lenses keep their flare by default; --no-flare still turns it off.
    let mut args = small_scene(&dir);
    args.extend(s(&["--explain"]));
    assert_contains(&render(&dir, &args).success().stderr, "lens flare: on");
    let mut args = small_scene(&dir);
    args.extend(s(&["--no-flare", "--explain"]));
    assert_contains(&render(&dir, &args).success().stderr, "lens flare: turned off (--no-flare)");
    // The default lens with --no-vignetting names the flag instead.
    let mut args = small_scene(&dir);
    args.extend(s(&["--no-vignetting", "--explain"]));
    assert_contains(&render(&dir, &args).success().stderr, "turned off (--no-vignetting)");
}

/// A render ends its process without closing the GPU (`exit_now`): the pipeline cache, which
/// closing the device would write, is still written, and every output is complete.
#[test]
fn a_render_that_ends_without_closing_the_gpu_still_keeps_its_pipeline_cache() {
    let dir = TestDir::new("pipeline_cache");
    let mut args = small_scene(&dir);
    args.extend(s(&["--fstop", "2", "--focus", "1", "--png", &dir.arg("out.png")]));
    render(&dir, &args).success();
    let caches: Vec<_> = std::fs::read_dir(&dir.cache).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(caches.len(), 1, "{caches:?}");
    let name = caches[0].file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.starts_with("pipelines-") && name.ends_with(".bin"), "{name}");
    assert!(std::fs::metadata(&caches[0]).unwrap().len() > 0, "{name} is empty");
    assert_eq!(read_exr_rgba(&dir.join("out.exr")).unwrap().width, 16);
    assert!(std::fs::metadata(dir.join("out.png")).unwrap().len() > 0);
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "out.exr", "out.png"]);
}

// ---------------------------------------------------------------------------------------------
// 7: numeric settings
// ---------------------------------------------------------------------------------------------

#[test]
fn bad_numeric_settings_are_rejected_with_the_value() {
    let dir = TestDir::new("bad_numbers");
    let base = small_scene(&dir);
    let run = |extra: &[&str]| {
        let mut args = base.clone();
        args.extend(s(extra));
        render(&dir, &args)
    };

    let err = run(&["--shutter", "0"]).failure();
    assert_contains(&err, "error: --shutter \"0\": must be a positive time in seconds");
    let err = run(&["--shutter", "1/0"]).failure();
    assert_contains(&err, "error: --shutter \"1/0\": must be a positive time in seconds");
    let err = run(&["--shutter", "abc"]).failure();
    assert_contains(&err, "error: --shutter \"abc\": invalid float literal");

    let err = run(&["--iso=-5"]).failure();
    assert_contains(&err, "error: ISO must be a positive number, got -5");
    // Written with a space, clap rejects "-5" before the camera sees it; it must still fail
    // and say what it did not accept.
    let spaced = run(&["--iso", "-5"]);
    assert_ne!(spaced.code, Some(0), "{}", spaced.describe());
    assert_contains(&spaced.stderr, "-5");

    let err = run(&["--sensor", "nonsense"]).failure();
    assert_contains(&err, "error: unknown sensor format \"nonsense\"; give WIDTHxHEIGHT in mm");
    for name in ["full-frame", "super35", "aps-c", "aps-c-canon", "m43", "1in", "apsh", "medium-format"] {
        assert_contains(&err, &format!(" {name}"));
    }

    // 30 mm is inside the 50 mm focal length: even --force cannot make a thin lens focus there.
    let err = run(&["--focus", "0.03", "--force"]).failure();
    assert_contains(&err, "error: focus distance 30 mm is not beyond the focal length 50 mm");
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr"]);
}

// ---------------------------------------------------------------------------------------------
// 8: failed runs never clobber outputs
// ---------------------------------------------------------------------------------------------

/// A failing render (missing depth channel) aimed at existing `out.exr`, `out.png` and
/// `trace.json` leaves all three byte-identical and leaves no temporary file behind.
fn assert_failed_render_does_not_clobber(test: &str, with_png: bool) {
    let dir = TestDir::new(test);
    write_color_only(&dir.join("color.exr"), 8, 6);
    let old_exr: Vec<u8> = b"old out.exr: not an image, must survive".to_vec();
    let old_png: Vec<u8> = b"\x89PNG\r\n\x1a\nold out.png, must survive".to_vec();
    let old_trace: Vec<u8> = b"{\"old\": true}".to_vec();
    std::fs::write(dir.join("out.exr"), &old_exr).unwrap();
    std::fs::write(dir.join("out.png"), &old_png).unwrap();
    std::fs::write(dir.join("trace.json"), &old_trace).unwrap();
    let mut args = s(&[
        "--color",
        &dir.arg("color.exr"),
        "-o",
        &dir.arg("out.exr"),
        "--trace",
        &dir.arg("trace.json"),
        "--profile",
    ]);
    if with_png {
        args.extend(s(&["--png", &dir.arg("out.png")]));
    }
    let err = render(&dir, &args).failure();
    assert_contains(&err, "no depth channel");
    assert_eq!(std::fs::read(dir.join("out.exr")).unwrap(), old_exr);
    assert_eq!(std::fs::read(dir.join("out.png")).unwrap(), old_png);
    assert_eq!(std::fs::read(dir.join("trace.json")).unwrap(), old_trace);
    assert_listing(&dir, &["color.exr", "out.exr", "out.png", "trace.json"]);
}

#[test]
fn failed_render_does_not_clobber_the_exr() {
    assert_failed_render_does_not_clobber("no_clobber_exr", false);
}

#[test]
fn failed_render_does_not_clobber_the_png() {
    assert_failed_render_does_not_clobber("no_clobber_png", true);
}

/// A PNG target that is a folder is refused before any work; the folder and an existing EXR
/// are untouched and no temporary file is left.
#[test]
fn png_target_that_is_a_folder_is_refused_before_rendering() {
    let dir = TestDir::new("png_write_fails");
    let mut args = small_scene(&dir);
    std::fs::create_dir(dir.join("out.png")).unwrap();
    std::fs::write(dir.join("out.png").join("keep.txt"), b"keep").unwrap();
    std::fs::write(dir.join("out.exr"), b"old").unwrap();
    args.extend(s(&["--png", &dir.arg("out.png")]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!("error: png \"{}\": it is a folder; realcam writes only new files", dir.arg("out.png")),
    );
    assert!(!err.contains("device:"), "the GPU was opened:\n{err}");
    assert_eq!(std::fs::read(dir.join("out.png").join("keep.txt")).unwrap(), b"keep");
    assert_eq!(std::fs::read(dir.join("out.exr")).unwrap(), b"old");
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "out.exr", "out.png"]);
}

// ---------------------------------------------------------------------------------------------
// 8b: never lose a file (outputs are checked first, written together, never over an input)
// ---------------------------------------------------------------------------------------------

/// `-o` at a device, a FIFO, a symlink or a folder is refused before any work, and the thing
/// at the path is left as it was.
#[test]
fn outputs_that_are_not_regular_files_are_refused() {
    use std::os::unix::fs::FileTypeExt;
    let dir = TestDir::new("not_regular");
    let base = small_scene(&dir);
    let with_output = |output: &str| {
        let mut args = base.clone();
        let at = args.iter().position(|a| a == "-o").unwrap();
        args[at + 1] = output.to_string();
        args
    };
    std::fs::write(dir.join("kept.exr"), b"kept").unwrap();
    std::os::unix::fs::symlink(dir.join("kept.exr"), dir.join("link.exr")).unwrap();
    let fifo = Command::new("mkfifo").arg(dir.join("fifo.exr")).status().unwrap();
    assert!(fifo.success());
    std::fs::create_dir(dir.join("folder.exr")).unwrap();
    for (name, kind) in [
        ("link.exr", "a symbolic link"),
        ("fifo.exr", "a FIFO"),
        ("folder.exr", "a folder"),
        ("/dev/null", "a character device"),
    ] {
        let path = if name.starts_with('/') { name.to_string() } else { dir.arg(name) };
        let err = render(&dir, &with_output(&path)).failure();
        assert_contains(
            &err,
            &format!("error: output \"{path}\": it is {kind}; realcam writes only new files or replaces regular ones (--output)"),
        );
        assert!(!err.contains("device:"), "the GPU was opened:\n{err}");
    }
    assert!(std::fs::symlink_metadata(dir.join("link.exr")).unwrap().file_type().is_symlink());
    assert_eq!(std::fs::read(dir.join("kept.exr")).unwrap(), b"kept");
    assert!(std::fs::symlink_metadata(dir.join("fifo.exr")).unwrap().file_type().is_fifo());
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "kept.exr", "link.exr", "fifo.exr", "folder.exr"]);
}

/// An output that resolves to an input (the same path, another spelling, a symlink or a hard
/// link to it) or to another output is refused; the inputs are left byte for byte.
#[test]
fn outputs_that_are_inputs_are_refused() {
    let dir = TestDir::new("output_is_input");
    let base = small_scene(&dir);
    let color = std::fs::read(dir.join("scene_color.exr")).unwrap();
    let depth = std::fs::read(dir.join("scene_depth.exr")).unwrap();
    std::os::unix::fs::symlink(dir.join("scene_color.exr"), dir.join("color_link.exr")).unwrap();
    std::fs::hard_link(dir.join("scene_depth.exr"), dir.join("depth_hard.exr")).unwrap();
    let run = |output: &str, extra: &[&str]| {
        let mut args = base.clone();
        let at = args.iter().position(|a| a == "-o").unwrap();
        args[at + 1] = output.to_string();
        args.extend(s(extra));
        render(&dir, &args).failure()
    };
    let color_arg = dir.arg("scene_color.exr");
    let depth_arg = dir.arg("scene_depth.exr");
    let err = run(&color_arg, &[]);
    assert_contains(
        &err,
        &format!("error: output \"{color_arg}\": it is the input color pass \"{color_arg}\"; realcam never writes over its inputs (--output)"),
    );
    let other_spelling = format!("{}/./scene_depth.exr", dir.path.display());
    assert_contains(&run(&other_spelling, &[]), &format!("it is the input depth pass \"{depth_arg}\""));
    // Through the current folder, relative.
    assert_contains(&run("scene_color.exr", &[]), "it is the input color pass");
    // A hard link to the depth pass, and --color given through a symlink.
    assert_contains(&run(&dir.arg("depth_hard.exr"), &[]), "it is the input depth pass");
    let mut args = base.clone();
    let at = args.iter().position(|a| a == "--color").unwrap();
    args[at + 1] = dir.arg("color_link.exr");
    let at = args.iter().position(|a| a == "-o").unwrap();
    args[at + 1] = color_arg.clone();
    assert_contains(&render(&dir, &args).failure(), "it is the input color pass");
    // The flare's light list is an input too.
    let lights = dir.arg("lights.json");
    std::fs::write(&lights, r#"[{"x": 8, "y": 6, "energy": 1e6}]"#).unwrap();
    let err = run(&lights, &["--flare-lights", &lights]);
    assert_contains(&err, &format!("it is the input flare light list \"{lights}\""));
    assert_eq!(std::fs::read_to_string(&lights).unwrap(), r#"[{"x": 8, "y": 6, "energy": 1e6}]"#);
    std::fs::remove_file(&lights).unwrap();
    // --png and -o the same file.
    let out = dir.arg("out.exr");
    let err = run(&out, &["--png", &out]);
    assert_contains(&err, &format!("error: png \"{out}\": the output \"{out}\" is the same file (--png)"));
    assert_eq!(std::fs::read(dir.join("scene_color.exr")).unwrap(), color);
    assert_eq!(std::fs::read(dir.join("scene_depth.exr")).unwrap(), depth);
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "color_link.exr", "depth_hard.exr"]);
}

/// Every output of a run is renamed into place only when all were written (a write failing
/// after the render: `output::tests::outputs_are_renamed_together_or_not_at_all`); a lens name
/// an EXR attribute cannot hold is refused when the lens file is read (issue 34, 8), and a
/// missing PNG folder, before the render; the existing EXR, PNG and trace stay as they were.
#[test]
fn outputs_are_replaced_all_together_or_not_at_all() {
    let dir = TestDir::new("all_or_nothing");
    let mut args = small_scene(&dir);
    let old: [(&str, &[u8]); 3] = [("out.exr", b"old exr"), ("out.png", b"old png"), ("trace.json", b"{}")];
    for (name, bytes) in old {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let lens = dir.arg("lens.toml");
    std::fs::write(&lens, VALID_LENS.replace("test lens", "\u{30ec}\u{30f3}\u{30ba}") + "[aperture]\nblades = 9\n")
        .unwrap();
    let mut failing = args.clone();
    failing.extend(s(&["--png", &dir.arg("out.png"), "--trace", &dir.arg("trace.json"), "--lens", &lens]));
    let err = render(&dir, &failing).failure();
    assert_contains(
        &err,
        &format!(
            "error: lens file {lens}: name = \"\u{30ec}\u{30f3}\u{30ba}\" has the character '\u{30ec}' (U+30EC), \
             outside Latin-1, which EXR headers (lensModel) cannot hold"
        ),
    );
    assert!(!err.contains("device:"), "the GPU was opened before the lens file was checked:\n{err}");
    for (name, bytes) in old {
        assert_eq!(std::fs::read(dir.join(name)).unwrap(), bytes, "{name} was replaced");
    }
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "out.exr", "out.png", "trace.json", "lens.toml"]);

    args.extend(s(&["--png", "/missing-dir/p.png"]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, "error: png \"/missing-dir/p.png\": the folder \"/missing-dir\" does not exist (--png)");
    assert!(!err.contains("device:"), "the GPU was opened before the output folder was checked:\n{err}");
    assert_eq!(std::fs::read(dir.join("out.exr")).unwrap(), b"old exr");
}

/// The output folder is checked before anything is read: a missing or read-only folder is
/// the first error, even before a missing input.
#[test]
fn the_output_folder_is_checked_before_any_work() {
    let dir = TestDir::new("output_folder");
    let out = dir.arg("no-such-folder/out.exr");
    let err = render(&dir, &s(&["--color", &dir.arg("missing.exr"), "-o", &out])).failure();
    assert_contains(
        &err,
        &format!("error: output \"{out}\": the folder \"{}\" does not exist (--output)", dir.arg("no-such-folder")),
    );
    assert_listing(&dir, &[]);
}

/// The `.NAME.realcam-HOST-PID-N.tmp` files in `dir`.
fn temporaries(dir: &TestDir) -> Vec<String> {
    dir.listing().into_iter().filter(|n| n.contains(".realcam-") && n.ends_with(".tmp")).collect()
}

/// Starts a slow render (the reference bokeh on the demo scene, wide open) into `dir` and
/// waits until its temporary output exists.
fn start_slow_render(dir: &TestDir) -> std::process::Child {
    let testdata = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata");
    let child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(["render", "--color"])
        .arg(testdata.join("demo_color.exr"))
        .arg("--depth")
        .arg(testdata.join("demo_depth.exr"))
        .args(["--fstop", "1.4", "--focus", "0.6", "--bokeh", "reference", "-o"])
        .arg(dir.join("out.exr"))
        .current_dir(&dir.path)
        .env("REALCAM_CACHE_DIR", &dir.cache)
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("running the realcam binary");
    let start = std::time::Instant::now();
    while temporaries(dir).is_empty() {
        assert!(start.elapsed().as_secs() < 60, "no temporary output appeared");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child
}

/// SIGINT and SIGTERM during a run remove its temporary output, and the process still ends by
/// that signal; a SIGKILLed run's temporary is removed by the next run into the same folder.
#[test]
fn interrupted_runs_leave_no_temporary_file() {
    use std::os::unix::process::ExitStatusExt;
    let dir = TestDir::new("signals");
    for (signal, number) in [("INT", 2), ("TERM", 15)] {
        let mut child = start_slow_render(&dir);
        let kill = Command::new("kill").args([format!("-{signal}"), child.id().to_string()]).status().unwrap();
        assert!(kill.success());
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(number), "SIG{signal}: {status:?}");
        assert_eq!(temporaries(&dir), Vec::<String>::new(), "SIG{signal} left a temporary file");
        assert!(!dir.join("out.exr").exists());
    }
    let mut child = start_slow_render(&dir);
    child.kill().unwrap();
    child.wait().unwrap();
    let left = temporaries(&dir);
    assert_eq!(left.len(), 1, "{left:?}");
    // The next run into this folder (here one that fails on its input) removes it.
    let err = render(&dir, &s(&["--color", &dir.arg("missing.exr"), "-o", &dir.arg("other.exr")])).failure();
    assert_contains(&err, "does not exist");
    assert_listing(&dir, &[]);
}

// ---------------------------------------------------------------------------------------------
// 9-10: successful renders
// ---------------------------------------------------------------------------------------------

/// The time in ms on the `--profile` table's line for `pass` ("  <pass>   <time> ms ...").
fn profile_ms(stderr: &str, pass: &str) -> f64 {
    let value = stderr.lines().find_map(|l| {
        let mut words = l.split_whitespace();
        if l.starts_with("  ") && words.next() == Some(pass) {
            let v = words.next()?.parse::<f64>().ok()?;
            (words.next() == Some("ms")).then_some(v)
        } else {
            None
        }
    });
    let value = value.unwrap_or_else(|| panic!("no profile line \"{pass} ... ms\" in\n{stderr}"));
    assert!(value.is_finite() && value >= 0.0, "{pass}: {value} ms");
    value
}

#[test]
fn render_writes_exr_png_trace_with_explain_and_profile() {
    let dir = TestDir::new("success");
    let (w, h) = (64u32, 48u32);
    dir.scene("p", &SynthScene::point_on_plane(w, h, 4.0, [50.0; 3]));
    let args = s(&[
        "--color",
        &dir.arg("p_color.exr"),
        "--depth",
        &dir.arg("p_depth.exr"),
        "--fstop",
        "2",
        "--focus",
        "2",
        "--sensor",
        "9.6x7.2",
        "--bokeh",
        "reference",
        "--explain",
        "--profile",
        "--trace",
        &dir.arg("trace.json"),
        "--png",
        &dir.arg("out.png"),
        "-o",
        &dir.arg("out.exr"),
        "--float",
    ]);
    let run = render(&dir, &args).success();
    let err = &run.stderr;

    // The plan: the plane at 4 m is ~2.1 px out of focus (f/2, 50 mm, focus 2 m, 0.15 mm px).
    assert_contains(err, "pass plan:");
    assert_contains(err, "[run ] coc");
    assert_contains(err, "[run ] bokeh_gather");
    assert_contains(err, "[run ] vignette");
    assert_contains(err, "applied in the film pass's dispatch (one read and write of the frame fewer)");
    assert_contains(err, "[run ] film");
    assert_contains(err, "the vignette's falloff first, in the same dispatch");
    assert_contains(err, "[skip] motion_blur");
    // The profile table.
    assert_contains(err, "GPU time per pass");
    let passes_ms = profile_ms(err, "coc") + profile_ms(err, "bokeh_gather");
    assert!(
        profile_ms(err, "total") >= passes_ms * 0.999,
        "the total is less than the sum of coc and bokeh_gather:\n{err}"
    );
    assert_contains(err, &format!("wrote {}", dir.arg("out.exr")));
    assert_contains(err, &format!("wrote {}", dir.arg("out.png")));
    // Start-up: the GPU opened beside the EXR read; the time to the first submit covers the
    // wait for it, the pipelines' creation and the recording.
    let startup =
        err.lines().find(|l| l.starts_with("start-up: ")).unwrap_or_else(|| panic!("no start-up line:\n{err}"));
    let numbers: Vec<f64> =
        startup.split(|c: char| !(c.is_ascii_digit() || c == '.')).filter_map(|t| t.parse().ok()).collect();
    let [first_submit_ms, waited_ms, pipelines_ms] = numbers[..] else { panic!("{startup}") };
    assert_contains(startup, "after the process started (waited for the GPU opened beside the read ");
    assert_contains(startup, " ms; pipelines and recording ");
    assert!(first_submit_ms >= waited_ms + pipelines_ms && pipelines_ms > 0.0, "{startup}");

    // Chrome trace.
    let trace = std::fs::read_to_string(dir.join("trace.json")).unwrap();
    assert!(trace.trim_start().starts_with('{') && trace.trim_end().ends_with('}'));
    assert_contains(&trace, "\"traceEvents\"");
    assert_contains(&trace, "\"ph\":\"X\"");
    // The vignette runs in the film's dispatch.
    for pass in ["coc", "bokeh_gather", "vignette+film"] {
        assert_contains(&trace, &format!("\"name\":\"{pass}\""));
    }

    // The EXR: size, float samples, finite values, the highlight spread by defocus.
    let out = read_exr_rgba(&dir.join("out.exr")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((out.width, out.height, out.channels), (w, h, 4));
    assert!(out.data.iter().all(|v| v.is_finite()), "non-finite output");
    let lum = |x: u32, y: u32| (0..3).map(|c| out.get(x, y, c)).sum::<f32>();
    let (cx, cy) = (w / 2, h / 2);
    assert!(lum(cx, cy) > lum(cx + 8, cy), "highlight lost");
    assert!(
        lum(cx + 1, cy) > lum(cx + 8, cy) && lum(cx, cy - 1) > lum(cx, cy + 8),
        "highlight not spread to its neighbours by a ~2 px CoC"
    );
    assert!((lum(cx + 5, cy) - lum(cx + 8, cy)).abs() < 0.01, "the highlight leaks beyond the 3 px gather radius");
    assert!(lum(cx + 8, cy) > lum(0, 0), "vignetting should darken the corner");
    let meta = exr::meta::MetaData::read_from_file(dir.join("out.exr"), false).unwrap();
    for ch in &meta.headers[0].channels.list {
        assert_eq!(ch.sample_type, exr::meta::attribute::SampleType::F32, "{}", ch.name);
    }
    // The camera as OpenEXR's typed standard attributes, read back.
    use exr::meta::attribute::AttributeValue;
    let out_exr = dir.join("out.exr");
    let a = exr_header(&out_exr).own_attributes;
    assert_eq!((a.aperture, a.focus, a.exposure, a.iso_speed), (Some(2.0), Some(2.0), Some(0.02), Some(100.0)));
    assert_eq!(a.frames_per_second, Some((24, 1)));
    assert_eq!(attribute(&out_exr, "nominalFocalLength"), AttributeValue::F32(50.0));
    assert_eq!(attribute(&out_exr, "effectiveFocalLength"), AttributeValue::F32(50.0));
    assert_eq!(attribute(&out_exr, "sensorOverallDimensions"), AttributeValue::FloatVec2(exr::math::Vec2(9.6, 7.2)));
    // 9.6 mm over 64 px: 150 um.
    assert_eq!(attribute(&out_exr, "sensorPhotositePitch"), AttributeValue::F32(150.0));
    // 0.02 s at 24 fps: 0.48 of a frame, 172.8 degrees.
    assert_eq!(attribute(&out_exr, "shutterAngle"), AttributeValue::F32(172.8));
    // T-stop = N / sqrt(T): the default lens transmits 0.92.
    assert_eq!(attribute(&out_exr, "tStop"), AttributeValue::F32((2.0 / 0.92f64.sqrt()) as f32));
    assert_eq!(attribute(&out_exr, "lensModel"), text_value("realcam standard 50 mm f/1.4"));
    assert_eq!(attribute(&out_exr, "realcam/aperture_blades"), AttributeValue::I32(9));
    assert_eq!(attribute(&out_exr, "realcam/film"), text_value("linear (scene-referred)"));

    // The PNG: signature and IHDR size.
    let png = std::fs::read(dir.join("out.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert_eq!(&png[12..16], b"IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    assert_eq!((be(&png[16..20]), be(&png[20..24])), (w, h));

    assert_listing(&dir, &["p_color.exr", "p_depth.exr", "out.exr", "out.png", "trace.json"]);
}

#[test]
fn planner_skips_invisible_effects_and_output_equals_input() {
    let dir = TestDir::new("all_skipped");
    let (w, h) = (64u32, 48u32);
    // A point just under 2x saturation: no light for the lens flare either.
    dir.scene("p", &SynthScene::point_on_plane(w, h, 2.0, [1.9; 3]));
    let args = s(&[
        "--color",
        &dir.arg("p_color.exr"),
        "--depth",
        &dir.arg("p_depth.exr"),
        "--focus",
        "2",
        "--no-vignetting",
        "--film",
        "linear",
        "--no-exposure",
        "--explain",
        "-o",
        &dir.arg("out.exr"),
        "--float",
    ]);
    let run = render(&dir, &args).success();
    let err = &run.stderr;
    for pass in ["coc", "bokeh_tiled", "flare", "vignette", "film"] {
        assert_contains(err, &format!("[skip] {pass}"));
        assert!(!err.contains(&format!("[run ] {pass}")), "{pass} runs:\n{err}");
    }
    assert_contains(err, "depth of field is invisible");
    assert_contains(err, "turned off (--no-vignetting)");
    assert_contains(err, "linear film with exposure off and no grain: the sensor value is the scene value");
    assert_contains(err, "no pixel reaches 2 x saturation (scene value 2.0000) and no light is given");

    let input = read_exr_rgba(&dir.join("p_color.exr")).unwrap();
    let out = read_exr_rgba(&dir.join("out.exr")).unwrap();
    assert_eq!((out.width, out.height, out.channels), (w, h, 4));
    let worst = input.data.iter().zip(&out.data).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst <= 1e-6, "output differs from input by up to {worst}");
    assert_eq!(out.get(w / 2, h / 2, 0), 1.9);
    // The depth pass itself was not modified either.
    let depth = read_exr_channel(&dir.join("p_depth.exr"), "Z").unwrap();
    assert!(depth.data.iter().all(|&d| d == 2.0));
}

// ---------------------------------------------------------------------------------------------
// 11-12: other subcommands
// ---------------------------------------------------------------------------------------------

/// The value in mm of the report row `label`.
fn report_mm(report: &str, label: &str) -> f64 {
    let line = report
        .lines()
        .find(|l| l.trim_start().starts_with(label))
        .unwrap_or_else(|| panic!("no {label:?} row in\n{report}"));
    let value = line.trim_start()[label.len()..].trim();
    value.strip_suffix(" mm").and_then(|v| v.trim().parse().ok()).unwrap_or_else(|| panic!("no mm value in {line:?}"))
}

#[test]
fn dof_matches_potmesil_chakravarty_table_1() {
    let dir = TestDir::new("dof");
    let run = realcam(
        &dir,
        s(&["dof", "--focal-length", "55", "--fstop", "5.6", "--focus", "2", "--coc", "1/1000", "--force"]),
    )
    .success();
    let out = &run.stdout;
    assert_contains(out, "f/5.6");
    assert_contains(out, "patch of distance/1000 at the focus plane");
    let near = report_mm(out, "near limit");
    let far = report_mm(out, "far limit");
    let depth = report_mm(out, "total depth of field");
    // Table 1, f/5.6, U = 2000 mm: U- = 1662, U+ = 2511, depth 849.
    assert!((near - 1662.0).abs() <= 1.0, "near limit {near} mm");
    assert!((far - 2511.0).abs() <= 1.0, "far limit {far} mm");
    assert!((depth - 849.0).abs() <= 1.0, "depth of field {depth} mm");
    assert!((report_mm(out, "focal length f") - 55.0).abs() < 1e-9);
    assert!((report_mm(out, "focus distance S") - 2000.0).abs() < 1e-9);
}

#[test]
fn devices_lists_at_least_one_device() {
    let dir = TestDir::new("devices");
    let run = realcam(&dir, ["devices"]).success();
    let lines: Vec<&str> = run.stdout.lines().collect();
    assert!(!lines.is_empty(), "no devices listed:\n{}", run.describe());
    assert!(lines[0].starts_with("[0] "), "{}", run.describe());
    for (i, line) in lines.iter().enumerate() {
        let prefix = format!("[{i}] ");
        assert!(line.starts_with(&prefix) && line.len() > prefix.len(), "{line:?}");
    }
}

/// The repository's lenses/ directory.
fn lenses_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses")
}

#[test]
fn shipped_prescription_lens_matches_a_fresh_trace() {
    // lenses/tessar-walch-lens.toml was written by `lens analyze --write-tables`; tracing the
    // prescription again gives the same tables, so the shipped file cannot drift from the tracer.
    let dir = TestDir::new("tessar_tables");
    let out = dir.arg("tessar.toml");
    let prescription = lenses_dir().join("tessar-walch.toml");
    let run = realcam(
        &dir,
        s(&[
            "lens",
            "analyze",
            prescription.to_str().unwrap(),
            "--field",
            "0,2,4,6,8,10,12,14,16,18,20",
            "--write-tables",
            &out,
        ]),
    );
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    // The design's published focal length, 100 mm (Schott's SF7 and LLF7 give 100.013 mm).
    assert_contains(&run.stdout, "EFL 100.0129 mm");
    // From [aperture] on, less the comment naming the prescription's path.
    let tables = |text: &str| {
        let from = &text[text.find("[aperture]").expect("derived tables")..];
        from.lines().filter(|l| !l.starts_with("# Derived by")).collect::<Vec<_>>().join("\n")
    };
    let fresh = std::fs::read_to_string(&out).unwrap();
    let shipped = std::fs::read_to_string(lenses_dir().join("tessar-walch-lens.toml")).unwrap();
    assert_eq!(tables(&fresh), tables(&shipped));
    // The derived lens file renders, and its plan runs the passes its tables call for: on the
    // 640 px demo the comets are up to 2.8 px long; on a 16 px frame (2.25 mm pixels) they are
    // a tenth of a pixel and the coma pass is not recorded.
    let testdata = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata");
    let demo = |name: &str| testdata.join(name).to_str().unwrap().to_string();
    let args = [
        "--color",
        &demo("demo_color.exr"),
        "--depth",
        &demo("demo_depth.exr"),
        "-o",
        &dir.arg("demo.exr"),
        "--lens",
        &out,
        "--fstop",
        "2.8",
        "--focus",
        "3",
        "--explain",
    ];
    let run = render(&dir, &s(&args));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    for pass in ["[run ] distortion", "[run ] astigmatism", "[run ] coma", "comets up to 2.8 px long"] {
        assert_contains(&run.stderr, pass);
    }
    let mut args = small_scene(&dir);
    args.extend(s(&["--lens", &out, "--fstop", "2.8", "--focus", "3", "--explain"]));
    let run = render(&dir, &args);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert_contains(&run.stderr, "[skip] coma");
    assert_contains(&run.stderr, "(< 1 px): invisible");
}

#[test]
fn analysing_a_lens_file_without_surfaces_is_an_error() {
    let dir = TestDir::new("analyze_no_surfaces");
    let run = realcam(&dir, s(&["lens", "analyze", lenses_dir().join("default.toml").to_str().unwrap()]));
    let err = run.failure();
    assert_contains(&err, "has no [[surface]] tables to analyze");
}

#[test]
fn film_file_errors_name_the_line_and_tables_render() {
    let dir = TestDir::new("film_file");
    let mut args = small_scene(&dir);
    let film = dir.arg("film.toml");
    std::fs::write(
        &film,
        "name = \"f\"\nsource = \"s\"\n[table]\nlog10_sensor_value = [0, -1]\nlog10_output = [0, 1]\n",
    )
    .unwrap();
    let mut bad = args.clone();
    bad.extend(s(&["--film-file", &film]));
    let err = render(&dir, &bad).failure();
    assert_contains(
        &err,
        &format!("error: film file {film}, line 4: table.log10_sensor_value is not increasing at entry 2: 0 then -1"),
    );
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("films/reversal-example.toml");
    args.extend(s(&["--film-file", example.to_str().unwrap(), "--explain"]));
    let run = render(&dir, &args);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert_contains(&run.stderr, "characteristic curve from a table of 14 entries");
}

#[test]
fn dof_uses_a_0_03_mm_circle_of_confusion_by_default() {
    // Hyperfocal distance H = f^2 / (N c) + f = 50^2 / (2 x 0.03) + 50 = 41716.67 mm.
    let dir = TestDir::new("dof_default");
    let run = realcam(&dir, s(&["dof", "--focal-length", "50", "--fstop", "2", "--focus", "3"]));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert_contains(&run.stdout, "Depth of field (0.03 mm circle of confusion on the film)");
    assert_contains(&run.stdout, "hyperfocal distance           41716.67 mm");
}

#[test]
fn every_film_file_in_films_parses_and_the_presets_match_the_built_ins() {
    use realcam::io::film_file::{FilmFile, FilmResponse};
    use realcam::optics::film::FilmCurve;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("films");
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let film = FilmFile::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let stem = path.file_stem().unwrap().to_str().unwrap().to_string();
        if let Some(preset) = FilmCurve::preset(&stem) {
            assert_eq!(film.response, FilmResponse::Curve(preset), "{stem}");
        }
        names.push(stem);
    }
    names.sort();
    assert_eq!(names, ["contrast", "neutral", "reversal-example", "soft"]);
}

// ---------------------------------------------------------------------------------------------
// Hostile inputs: declared sizes checked against the memory before anything is allocated
// ---------------------------------------------------------------------------------------------

/// A single-part tiled EXR whose header declares a `w`x`h` image of one tile (channels B, G,
/// R, Z as half) followed by one empty chunk: 395 bytes, whatever it declares.
fn tiled_exr_header(w: i32, h: i32) -> Vec<u8> {
    fn attr(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
        for text in [name, kind] {
            out.extend(text.as_bytes());
            out.push(0);
        }
        out.extend((value.len() as i32).to_le_bytes());
        out.extend(value);
    }
    let ints = |v: &[i32]| v.iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<u8>>();
    let mut channels = Vec::new();
    for name in ["B", "G", "R", "Z"] {
        channels.extend(name.as_bytes());
        channels.extend([0, 1, 0, 0, 0, 0, 0, 0, 0]); // \0, type HALF, pLinear, reserved
        channels.extend(ints(&[1, 1]));
    }
    channels.push(0);
    let window = ints(&[0, 0, w - 1, h - 1]);
    let mut header = Vec::new();
    attr(&mut header, "channels", "chlist", &channels);
    attr(&mut header, "compression", "compression", &[0]);
    attr(&mut header, "dataWindow", "box2i", &window);
    attr(&mut header, "displayWindow", "box2i", &window);
    attr(&mut header, "lineOrder", "lineOrder", &[0]);
    attr(&mut header, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attr(&mut header, "screenWindowCenter", "v2f", &[0; 8]);
    attr(&mut header, "screenWindowWidth", "float", &1f32.to_le_bytes());
    let mut tiles = ints(&[w, h]);
    tiles.push(0); // one level
    attr(&mut header, "tiles", "tiledesc", &tiles);
    header.push(0);
    let mut file = ints(&[20000630, 2 | 0x200]); // magic, version 2 with the tiled flag
    let chunk_at = (file.len() + header.len() + 8) as u64;
    file.extend(header);
    file.extend(chunk_at.to_le_bytes());
    file.extend(ints(&[0, 0, 0, 0, 8]));
    file.extend([0; 8]);
    file
}

#[test]
fn a_header_declaring_a_huge_image_is_refused_before_allocating() {
    let dir = TestDir::new("huge_header");
    std::fs::write(dir.join("huge.exr"), tiled_exr_header(100_000, 100_000)).unwrap();
    assert_eq!(std::fs::metadata(dir.join("huge.exr")).unwrap().len(), 395);
    let err = render(&dir, &s(&["--color", &dir.arg("huge.exr"), "-o", &dir.arg("out.exr")])).failure();
    assert_contains(
        &err,
        &format!(
            "error: color: \"{}\" declares a 100000x100000 px image: reading it takes 400.0 GB, more than the ",
            dir.arg("huge.exr")
        ),
    );
    assert_contains(&err, "of memory available (free memory, address-space limit)");
    // With --max-pixels, that limit.
    let err =
        render(&dir, &s(&["--color", &dir.arg("huge.exr"), "--max-pixels", "8294400", "-o", &dir.arg("out.exr")]))
            .failure();
    assert_contains(
        &err,
        "declares a 100000x100000 px image (10000000000 pixels), more than the limit of 8294400 pixels (--max-pixels)",
    );
    assert_listing(&dir, &["huge.exr"]);
}

/// Under a 4 GB address-space limit a 20000x20000 header is refused with the limit, not an
/// abort; a small frame still renders under the same limit.
#[test]
fn a_memory_limit_refuses_what_does_not_fit_and_renders_what_does() {
    let dir = TestDir::new("ulimit");
    std::fs::write(dir.join("big.exr"), tiled_exr_header(20_000, 20_000)).unwrap();
    let bin = env!("CARGO_BIN_EXE_realcam");
    let limited = |args: &str| {
        let out = Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -v 4194304 && exec {bin} render {args}"))
            .current_dir(&dir.path)
            .env("REALCAM_CACHE_DIR", &dir.cache)
            .output()
            .unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = limited(&format!("--color {} -o {}", dir.arg("big.exr"), dir.arg("out.exr")));
    assert_eq!(code, Some(1), "{err}");
    assert_contains(&err, "declares a 20000x20000 px image: reading it takes 16.0 GB, more than the ");
    dir.scene("p", &SynthScene::point_on_plane(16, 12, 3.0, [5.0; 3]));
    let (code, err) = limited(&format!(
        "--color {} --depth {} -o {}",
        dir.arg("p_color.exr"),
        dir.arg("p_depth.exr"),
        dir.arg("out.exr")
    ));
    assert_eq!(code, Some(0), "{err}");
}

/// A PNG whose header declares `w`x`h` px (8-bit grey), with an empty IDAT chunk.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= b as u32;
            for _ in 0..8 {
                crc = if crc & 1 != 0 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 0, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    png.extend([0, 0, 0, 0]);
    png.extend(b"IDAT");
    png.extend(crc32(b"IDAT").to_be_bytes());
    png.extend([0, 0, 0, 0]);
    png.extend(b"IEND");
    png.extend(crc32(b"IEND").to_be_bytes());
    png
}

#[test]
fn a_huge_aperture_image_is_refused_with_its_size_and_the_limit() {
    let dir = TestDir::new("huge_aperture");
    let mut args = small_scene(&dir);
    std::fs::write(dir.join("iris.png"), png_header(100_000, 100_000)).unwrap();
    args.extend(s(&["--aperture-image", &dir.arg("iris.png"), "--max-pixels", "16777216"]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!(
            "error: aperture image: \"{}\" declares a 100000x100000 px image (10000000000 pixels), more than the limit of 16777216 pixels (--max-pixels)",
            dir.arg("iris.png")
        ),
    );
    let at = args.iter().position(|a| a == "--max-pixels").unwrap();
    args.truncate(at);
    let err = render(&dir, &args).failure();
    assert_contains(&err, "declares a 100000x100000 px image: reading it takes 200.0 GB, more than the ");
}

/// A frame wider than the device's largest image is an error naming the device's limit
/// (lavapipe: 16384 px), before any GPU image is made.
#[test]
fn a_frame_larger_than_the_device_takes_is_a_clear_error() {
    let dir = TestDir::new("wide_frame");
    let w = 16_400u32;
    write_color_only(&dir.join("c.exr"), w, 1);
    write_depth(&dir.join("d.exr"), w, 1, &vec![2.0; w as usize]);
    let err =
        render(&dir, &s(&["--color", &dir.arg("c.exr"), "--depth", &dir.arg("d.exr"), "-o", &dir.arg("out.exr")]))
            .failure();
    assert_contains(&err, "error: a frame of 16400x1 px does not fit the device");
    assert_contains(&err, "its images may be at most");
    assert_listing(&dir, &["c.exr", "d.exr"]);
}

#[test]
fn a_frame_beyond_the_gpu_memory_given_renders_in_bands_with_the_bytes_of_a_whole_render() {
    // The README demo at f/2 (depth of field, flare, vignetting, the film) with grain: whole,
    // then with 30 MB of GPU memory, where it needs about 47: the same output file bytes, and
    // --explain says how it was cut.
    let dir = TestDir::new("bands");
    let mut args = scene_args(&dir, "demo", &SynthScene::demo());
    args.extend(s(&["--fstop", "2", "--focus", "2", "--grain", "0.05", "--explain"]));
    let whole = render(&dir, &args).success().describe();
    assert!(!whole.contains("in bands"), "{whole}");
    let expected = std::fs::read(dir.join("out.exr")).unwrap();
    args.extend(s(&["--max-gpu-memory", "30M"]));
    let banded = render(&dir, &args).success().describe();
    assert_contains(&banded, "  in bands: the frame needs about 0.");
    assert_contains(&banded, "GB of GPU memory and the device has 0.03 GB: ");
    assert_contains(&banded, "rows above and below (the passes' reach)");
    assert_eq!(std::fs::read(dir.join("out.exr")).unwrap(), expected, "the banded output's bytes");
    // A budget that cannot hold one row of tiles with its aprons, and a size that is not one.
    let last = args.len() - 1;
    args[last] = "2M".into();
    let err = render(&dir, &args).failure();
    assert_contains(&err, "error: a band of 640 px by one tile row with aprons of");
    assert_contains(&err, "more than the 2.0 MB the frame may use (the device's memory or --max-gpu-memory)");
    args[last] = "2X".into();
    let run = render(&dir, &args);
    assert_eq!(run.code, Some(2), "{}", run.describe());
    assert_contains(&run.stderr, "invalid value '2X' for '--max-gpu-memory <BYTES>': \"2X\" is not a size in bytes");
}

#[test]
fn a_frame_taller_than_the_device_images_renders_in_bands() {
    // 17,000 rows: more than the 16,384 an image may have on lavapipe.
    let dir = TestDir::new("tall_frame");
    let h = 17_000u32;
    write_color_only(&dir.join("c.exr"), 4, h);
    write_depth(&dir.join("d.exr"), 4, h, &vec![2.0; (4 * h) as usize]);
    let out = render(
        &dir,
        &s(&[
            "--color",
            &dir.arg("c.exr"),
            "--depth",
            &dir.arg("d.exr"),
            "--grain",
            "0.05",
            "--explain",
            "-o",
            &dir.arg("out.exr"),
        ]),
    )
    .success()
    .describe();
    assert_contains(&out, "(and its images may be at most 16384 px high): 2 bands of");
    let header = exr_header(&dir.join("out.exr"));
    assert_eq!(header.layer_size.height(), h as usize);
}

// ---------------------------------------------------------------------------------------------
// Bad values and messages
// ---------------------------------------------------------------------------------------------

#[test]
fn a_rotation_that_is_not_finite_is_refused() {
    let dir = TestDir::new("rotation_nan");
    let base = small_scene(&dir);
    for (value, shown) in [("nan", "NaN"), ("inf", "inf"), ("-inf", "-inf")] {
        let mut args = base.clone();
        args.push(format!("--blade-rotation={value}"));
        let err = render(&dir, &args).failure();
        assert_contains(
            &err,
            &format!("error: aperture rotation must be a finite angle in degrees, got {shown} (--blade-rotation)"),
        );
    }
    let lens = dir.arg("lens.toml");
    std::fs::write(&lens, format!("{VALID_LENS}[aperture]\nblades = 6\nrotation_deg = nan\n")).unwrap();
    let mut args = base.clone();
    args.extend(s(&["--lens", &lens]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!("error: lens file {lens}: aperture.rotation_deg = NaN must be a finite angle in degrees"),
    );
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "lens.toml"]);
}

#[test]
fn lens_file_values_are_checked_with_their_units() {
    let dir = TestDir::new("lens_values");
    let base = small_scene(&dir);
    let lens = dir.arg("lens.toml");
    let head = format!("{VALID_LENS}[aperture]\nblades = 9\n[tables]\nimage_height_mm = [0, 10, 21.6]\n");
    for (table, message) in [
        (
            "relative_illumination = [1, 0.8, -0.5]",
            "tables.relative_illumination value -0.5 is out of range (in (0, 2])",
        ),
        ("relative_illumination = [1, 3, 1]", "tables.relative_illumination value 3 is out of range (in (0, 2])"),
        ("coma_mm = [0, 0.01, 49]", "tables.coma_mm value 49 is out of range (-5..5 mm, a tenth of the focal length)"),
        (
            "tangential_blur_mm = [0, 0.01, 49]",
            "tables.tangential_blur_mm value 49 is out of range (from 0 to 5 mm, a tenth of the focal length)",
        ),
    ] {
        std::fs::write(&lens, format!("{head}{table}\n")).unwrap();
        let mut args = base.clone();
        args.extend(s(&["--lens", &lens]));
        assert_contains(&render(&dir, &args).failure(), &format!("error: lens file {lens}, line 11: {message}"));
    }
    // A prescription with impossible glass: lens analyze refuses it instead of printing NaN.
    let prescription = dir.arg("p.toml");
    let surfaces =
        "name = \"p\"\n[[surface]]\nradius_mm = 50\nthickness_mm = 5\nn_d = 1.5\nsemi_diameter_mm = 10\nstop = true\n\
                    [[surface]]\nradius_mm = -50\nthickness_mm = 48\nsemi_diameter_mm = 10\n";
    for (from, to, message) in [
        ("n_d = 1.5", "n_d = 1e12", "surface 0: n_d = 1e12 must be at most 3 (no optical material has more)"),
        ("thickness_mm = 5", "thickness_mm = -5", "surface 0: thickness_mm = -5 must not be negative"),
    ] {
        std::fs::write(&prescription, surfaces.replace(from, to)).unwrap();
        let err = realcam(&dir, s(&["lens", "analyze", &prescription])).failure();
        assert_contains(&err, &format!("error: {prescription}:2: {message}"));
    }
    std::fs::write(&prescription, surfaces).unwrap();
    let run = realcam(&dir, s(&["lens", "analyze", &prescription])).success();
    assert!(!run.stdout.contains("NaN") && !run.stdout.contains("EFL 0.0000"), "{}", run.stdout);
}

#[test]
fn messages_say_each_cause_once_and_numbers_shortly() {
    let dir = TestDir::new("messages");
    let base = small_scene(&dir);
    // A folder as the colour pass.
    std::fs::create_dir(dir.join("folder.exr")).unwrap();
    let folder = dir.arg("folder.exr");
    let err = render(&dir, &s(&["--color", &folder, "-o", &dir.arg("out.exr")])).failure();
    assert_contains(&err, &format!("error: color: cannot read \"{folder}\": it is a directory\n"));
    // Missing files: the system's cause once.
    for extra in [["--lens", "missing.toml"], ["--aperture-image", "missing.png"], ["--film-file", "missing.toml"]] {
        let mut args = base.clone();
        args.extend(s(&extra));
        let err = render(&dir, &args).failure();
        assert_eq!(err.matches("(os error 2)").count(), 1, "{err}");
    }
    let err = realcam(&dir, s(&["lens", "analyze", "missing.toml"])).failure();
    assert_contains(&err, "error: lens file missing.toml: cannot read it: No such file or directory (os error 2)\n");
    // A truncated EXR: the decoder's message once.
    let color = std::fs::read(dir.join("scene_color.exr")).unwrap();
    std::fs::write(dir.join("cut.exr"), &color[..color.len() / 2]).unwrap();
    let err = render(&dir, &s(&["--color", &dir.arg("cut.exr"), "-o", &dir.arg("out.exr")])).failure();
    let line = err.lines().find(|l| l.starts_with("error: ")).unwrap();
    let cause = line.rsplit(": ").next().unwrap();
    assert_eq!(line.matches(cause).count(), 1, "{line}");
    // A NUL in a lens-file comment.
    let lens = dir.arg("nul.toml");
    std::fs::write(&lens, format!("{VALID_LENS}# a comment with a \0\n[aperture]\nblades = 9\n")).unwrap();
    let mut args = base.clone();
    args.extend(s(&["--lens", &lens]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!("error: lens file {lens}, line 7: control character U+0000 is not allowed in a TOML file, not even in a comment"),
    );
    // f/0 is no setting --force could allow.
    for force in [false, true] {
        let mut args = base.clone();
        args.extend(s(&["--fstop", "0"]));
        if force {
            args.push("--force".into());
        }
        let err = render(&dir, &args).failure();
        assert_contains(&err, "error: f-number must be positive, got f/0\n");
        assert!(!err.contains("--force"), "{err}");
    }
    // A limit of 1e308 in a lens file is written 1e308.
    std::fs::write(&lens, VALID_LENS.replace("f_number_max = 16", "f_number_max = 1e308") + "[aperture]\nblades = 9\n")
        .unwrap();
    let mut args = base.clone();
    args.extend(s(&["--lens", &lens, "--fstop", "1"]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, "error: f/1 is outside what the lens \"test lens\" allows (f/1.4 to f/1e308); pass --force");
}

/// Two identical runs write identical bytes (the EXR header's attributes in name order).
#[test]
fn identical_runs_write_identical_bytes() {
    let dir = TestDir::new("deterministic");
    let mut args = small_scene(&dir);
    args.extend(s(&["--fstop", "2", "--focus", "1"]));
    render(&dir, &args).success();
    let first = std::fs::read(dir.join("out.exr")).unwrap();
    render(&dir, &args).success();
    assert_eq!(std::fs::read(dir.join("out.exr")).unwrap(), first, "two identical runs wrote different bytes");
    assert!(exr_header(&dir.join("out.exr")).own_attributes.other.len() >= 10);
}

/// Several view layers in one EXR: the passes come from one layer as a whole (the first, with
/// a warning; the colour override's; or --layer's), and --explain says which.
#[test]
fn view_layers_are_chosen_whole_and_said() {
    let dir = TestDir::new("layers");
    let (w, h) = (8u32, 6u32);
    let n = (w * h) as usize;
    let mut planes: Vec<(String, Vec<f32>)> = Vec::new();
    for (layer, colour, depth) in [("Alpha", 0.25f32, 1.0f32), ("Beta", 0.75, 5.0)] {
        for c in ["R", "G", "B", "A"] {
            planes.push((format!("{layer}.Combined.{c}"), vec![if c == "A" { 1.0 } else { colour }; n]));
        }
        planes.push((format!("{layer}.Depth.Z"), vec![depth; n]));
        for c in ["X", "Y", "Z", "W"] {
            planes.push((format!("{layer}.Vector.{c}"), vec![0.0; n]));
        }
    }
    let chans: Vec<(&str, &[f32])> = planes.iter().map(|(name, v)| (name.as_str(), v.as_slice())).collect();
    write_exr_channels(&dir.join("layers.exr"), w, h, &chans, &float_opts()).unwrap();
    let base = s(&["--color", &dir.arg("layers.exr"), "-o", &dir.arg("out.exr"), "--explain", "--focus", "5"]);
    let run = |extra: &[&str]| {
        let mut args = base.clone();
        args.extend(s(extra));
        render(&dir, &args).success().stderr
    };
    let err = run(&[]);
    assert_contains(&err, "has 2 view layers (Alpha, Beta); every pass is taken from Alpha");
    assert_contains(&err, "view layer: Alpha (the first; choose another with a layer option;");
    assert_contains(&err, "channel Alpha.Depth.Z");
    let err = run(&["--color-channels", "Beta.Combined"]);
    assert_contains(&err, "view layer: Beta (the colour override's;");
    assert_contains(&err, "channel Beta.Depth.Z");
    assert!(!err.contains("Alpha.Depth.Z") && !err.contains("every pass is taken from"), "{err}");
    let err = run(&["--layer", "Beta"]);
    assert_contains(&err, "view layer: Beta (asked for;");
    assert_contains(&err, "channel Beta.Depth.Z");
    assert_contains(&err, "channels Beta.Vector.Z, Beta.Vector.W, Beta.Vector.X, Beta.Vector.Y");
    assert!(!err.contains("Alpha.Vector"), "{err}");
    // Focused at 5 m, Beta's plane is sharp: no depth of field runs.
    assert_contains(&err, "[skip] coc");
    let mut args = base.clone();
    args.extend(s(&["--layer", "Alpha", "--color-channels", "Beta.Combined"]));
    assert_contains(&render(&dir, &args).failure(), "passes of two layers are never mixed");
}

/// --max-coc takes none (the default), a diameter on the film or in pixels; a clamp that
/// changes the picture is said, in --explain and as a warning.
#[test]
fn a_clamp_that_changes_the_picture_is_said() {
    let dir = TestDir::new("max_coc");
    let mut base = scene_args(&dir, "p", &SynthScene::point_on_plane(64, 48, 0.6, [5.0; 3]));
    base.extend(s(&["--fstop", "1.4", "--focus", "5", "--explain"]));
    let run = |extra: &[&str]| {
        let mut args = base.clone();
        args.extend(s(extra));
        render(&dir, &args)
    };
    // Full frame on 64 px: 0.5625 mm pixels, so 1.2 mm is 2.13 px; the plane at 0.6 m is 4.6 px
    // out of focus (f/1.4, 50 mm, focused at 5 m).
    // No clamp by default: the plane's 4.6 px are drawn (issue 29).
    let err = run(&[]).success().stderr;
    assert!(!err.contains("clamp"), "{err}");
    assert_contains(&err, "[run ] coc           CoC from -4.");
    let err = run(&["--max-coc", "1.2mm"]).success().stderr;
    assert_contains(&err, "warning: the CoC is clamped to +-2.13 px (1.2 mm on the film): the lens gives -4.");
    assert_contains(&err, "so the clamp changes the picture; raise the clamp with --max-coc");
    assert_contains(&err, "[run ] coc           CoC from -2.13 px");
    for wide in ["3mm", "8", "8px", "none"] {
        let err = run(&["--max-coc", wide]).success().stderr;
        assert!(!err.contains("clamp"), "--max-coc {wide}:\n{err}");
    }
    let err = run(&["--max-coc", "1.2cm"]).failure();
    assert_contains(
        &err,
        "error: --max-coc \"1.2cm\": \"1.2cm\" is not `none`, a diameter in px (64, 64px) or on the film in mm (1.2mm)",
    );
    let err = run(&["--max-coc=-1mm"]).failure();
    assert_contains(
        &err,
        "error: maximum CoC diameter must be a diameter >= 0 (px, or mm on the film), got -1 (--max-coc)",
    );
}

#[test]
fn motion_blur_settings_and_velocity_conventions_are_checked_with_their_flags() {
    let dir = TestDir::new("motion_settings");
    let base = small_scene(&dir);
    let run = |extra: &[&str]| {
        let mut args = base.clone();
        args.extend(s(extra));
        render(&dir, &args)
    };
    let err = run(&["--fps=-24"]).failure();
    assert_contains(&err, "error: frame rate must be a positive number of frames per second, got -24 (--fps)");
    let err = run(&["--shutter-angle", "400"]).failure();
    assert_contains(&err, "error: shutter angle must be in (0, 360] degrees, got 400 (--shutter-angle)");
    let err = run(&["--shutter-curve", "trapezoid:0.7"]).failure();
    assert_contains(&err, "error: shutter curve ramp must be in (0, 0.5] of the open time, got 0.7 (--shutter-curve)");
    let err = run(&["--shutter-curve", "round"]).failure();
    assert_contains(&err, "error: --shutter-curve: \"round\" is not box, trapezoid or trapezoid:RAMP");
    let both = run(&["--shutter", "1/50", "--shutter-angle", "180"]);
    assert_ne!(both.code, Some(0), "{}", both.describe());
    assert_contains(&both.stderr, "--shutter-angle");
    // Arnold's raw vectors without the renderer's shutter interval: the file, the channels and
    // the flag.
    let (w, h) = (16u32, 12u32);
    let n = (w * h) as usize;
    let path = dir.join("arnold.exr");
    let (one, z, v) = (vec![1.0f32; n], vec![3.0f32; n], vec![2.0f32; n]);
    let channels: Vec<(&str, &[f32])> =
        vec![("R", &one), ("G", &one), ("B", &one), ("Z", &z), ("motion_vector.R", &v), ("motion_vector.G", &v)];
    write_exr_channels(&path, w, h, &channels, &float_opts()).unwrap();
    let arnold = |extra: &[&str]| {
        let mut args = s(&["--color", &dir.arg("arnold.exr"), "-o", &dir.arg("arnold_out.exr"), "--explain"]);
        args.extend(s(extra));
        render(&dir, &args)
    };
    let err = arnold(&[]).failure();
    assert_contains(
        &err,
        &format!(
            "error: velocity: \"{}\" holds Arnold motion vectors (motion_vector.R, motion_vector.G), which span the renderer's shutter interval; the file does not say how long it was; give velocity_interval_frames (--velocity-interval)",
            path.display()
        ),
    );
    let ok = arnold(&["--velocity-interval", "0.5", "--fps", "24", "--shutter-angle", "180"]);
    assert_eq!(ok.code, Some(0), "{}", ok.describe());
    // (2, 2) px over half a frame is (4, -4) px per frame (y up in the file), 5.66 px per frame:
    // 2.83 px of blur over a 180 degree shutter; the plan says so, and the order with the depth
    // of field.
    assert_contains(&ok.stderr, "Arnold raw motion_vector");
    assert_contains(
        &ok.stderr,
        "[run ] motion_blur   velocity up to 5.7 px/frame (arnold) at 24 fps, shutter 0.0208 s = 180 deg centred, box",
    );
    assert_contains(&ok.stderr, "blur up to 2.8 px");
    assert_contains(&ok.stderr, "before the depth of field");
}

#[test]
fn the_flare_report_needs_a_prescription_and_says_so() {
    // The ghosts are traced through the lens's [[surface]]s: the default lens has none, and the
    // error names the flag and a lens that has them; nothing is written.
    let dir = TestDir::new("flare_report_no_prescription");
    let out = dir.arg("report");
    let run = realcam(&dir, s(&["flare", "--out-dir", &out]));
    assert_eq!(run.code, Some(1), "{}", run.stderr);
    assert_contains(&run.stderr, "--lens: lens \"realcam standard 50 mm f/1.4\" has no [[surface]] prescription");
    assert_contains(&run.stderr, "--lens lenses/tessar-walch-lens.toml");
    assert!(!dir.join("report").exists());
}

// ---- Frame sequences (`render --frames`) ----

/// The frames of the generated sequence.
const SEQUENCE: [i64; 6] = [1001, 1002, 1003, 1004, 1005, 1006];

/// Writes a 6-frame sequence `c.1001.exr` .. `c.1006.exr` and `d.1001.exr` .. (24x16 px crops of
/// the demo passes, each frame's crop 8 px further right and 25 % brighter, so that every
/// frame differs) and
/// returns the sequence arguments that read it and write `o.####.exr`.
fn sequence_args(dir: &TestDir) -> Vec<String> {
    let testdata = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata");
    let color = read_exr_rgba(&testdata.join("demo_color.exr")).unwrap();
    let depth = read_exr_channel(&testdata.join("demo_depth.exr"), "Z").unwrap();
    let (w, h) = (24u32, 16u32);
    for (i, frame) in SEQUENCE.iter().enumerate() {
        let (x0, y0) = (300 + 8 * i as u32, 200u32);
        let crop = |im: &Image, gain: f32| {
            let mut out = Image::new(w, h, im.channels);
            for y in 0..h {
                for x in 0..w {
                    for c in 0..im.channels {
                        out.set(x, y, c, im.get(x0 + x, y0 + y, c) * if c < 3 { gain } else { 1.0 });
                    }
                }
            }
            out
        };
        write_exr_rgba(&dir.join(&format!("c.{frame}.exr")), &crop(&color, 1.0 + 0.25 * i as f32), &float_opts())
            .unwrap();
        let z = crop(&depth, 1.0);
        write_exr_channels(&dir.join(&format!("d.{frame}.exr")), w, h, &[("Z", &z.data)], &float_opts()).unwrap();
    }
    let mut args = vec!["--color".into(), dir.arg("c.####.exr"), "--depth".into(), dir.arg("d.%04d.exr")];
    args.extend(["-o".into(), dir.arg("o.####.exr"), "--fstop".into(), "1.4".into(), "--focus".into(), "2".into()]);
    args
}

/// The percentages of the `openjd_progress:` lines of `stderr`, checking that each comes with
/// its Tractor and Deadline lines.
fn farm_progress(stderr: &str) -> Vec<u32> {
    let lines: Vec<&str> = stderr.lines().collect();
    let mut percents = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if let Some(n) = line.strip_prefix("openjd_progress: ") {
            assert_eq!(lines.get(i + 1), Some(&format!("ALF_PROGRESS {n}%").as_str()), "{stderr}");
            assert_eq!(lines.get(i + 2), Some(&format!("Progress: {n}%").as_str()), "{stderr}");
            percents.push(n.parse().unwrap());
        }
    }
    percents
}

#[test]
fn a_sequence_renders_each_frame_as_a_single_run_would() {
    let dir = TestDir::new("sequence");
    let mut args = sequence_args(&dir);
    args.extend(s(&["--frames", "1001-1006", "--png", &dir.arg("p.@@@@.png")]));
    let run = render(&dir, &args).success();
    // One device for the whole sequence; the farm lines after each frame; the summary.
    assert_eq!(run.stderr.matches("device: ").count(), 1, "{}", run.stderr);
    assert_eq!(farm_progress(&run.stderr), [16, 33, 50, 66, 83, 100]);
    assert_contains(&run.stderr, "frames: 6 done, 0 skipped, 0 failed of 6 in ");
    assert_contains(&run.stderr, &format!("frame 1004: wrote {}, {}", dir.arg("o.1004.exr"), dir.arg("p.1004.png")));
    for frame in SEQUENCE {
        let mut one = sequence_args(&dir);
        let (exr, png) = (format!("single.{frame}.exr"), format!("single.{frame}.png"));
        for arg in one.iter_mut() {
            *arg = arg.replace("####", &frame.to_string()).replace("%04d", &frame.to_string());
            if *arg == dir.arg(&format!("o.{frame}.exr")) {
                *arg = dir.arg(&exr);
            }
        }
        one.extend(s(&["--png", &dir.arg(&png)]));
        render(&dir, &one).success();
        let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
        assert!(read(&format!("o.{frame}.exr")) == read(&exr), "frame {frame}: EXR differs from a single run");
        assert!(read(&format!("p.{frame}.png")) == read(&png), "frame {frame}: PNG differs from a single run");
    }
    // The frames differ: a sequence writing one frame six times would not pass.
    let first = std::fs::read(dir.join("o.1001.exr")).unwrap();
    assert!(SEQUENCE[1..].iter().all(|f| std::fs::read(dir.join(&format!("o.{f}.exr"))).unwrap() != first));
    assert!(temporaries(&dir).is_empty());
}

#[test]
fn skip_existing_skips_exactly_the_frames_whose_outputs_all_exist() {
    let dir = TestDir::new("sequence_skip");
    let mut args = sequence_args(&dir);
    args.extend(s(&["--frames", "1001-1006", "--png", &dir.arg("p.####.png"), "--skip-existing"]));
    // Complete outputs (an EXR and a PNG that read back whole) are kept.
    for name in ["o.1002.exr", "o.1005.exr", "o.1003.exr"] {
        write_exr_rgba(&dir.join(name), &rgba(2, 2, [1.0; 3]), &float_opts()).unwrap();
    }
    for name in ["p.1002.png", "p.1005.png"] {
        realcam::io::png::write_png(&dir.join(name), &rgba(2, 2, [1.0; 3])).unwrap();
    }
    let kept = snapshot(&dir, &["o.1002.exr", "p.1002.png", "o.1005.exr", "p.1005.png"]);
    let run = render(&dir, &args).success();
    assert_contains(&run.stderr, "frames: 4 done, 2 skipped, 0 failed of 6 in ");
    assert_contains(&run.stderr, &format!("frame 1002: skipped, {} exists", dir.arg("o.1002.exr")));
    assert_eq!(snapshot(&dir, &["o.1002.exr", "p.1002.png", "o.1005.exr", "p.1005.png"]), kept);
    // Frame 1003 had its EXR but not its PNG: rendered again, both written.
    for frame in [1001, 1003, 1004, 1006] {
        let image = read_exr_rgba(&dir.join(&format!("o.{frame}.exr"))).unwrap();
        assert_eq!((image.width, image.height), (24, 16));
        assert!(dir.join(&format!("p.{frame}.png")).exists());
    }
    assert_eq!(farm_progress(&run.stderr).len(), 6);
}

#[test]
fn a_corrupt_frame_is_named_and_the_others_are_written() {
    let dir = TestDir::new("sequence_corrupt");
    let mut args = sequence_args(&dir);
    std::fs::write(dir.join("c.1003.exr"), b"not an EXR").unwrap();
    args.extend(s(&["--frames", "1001-1006"]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!(
            "error: frame 1003: color: \"{}\" is not an OpenEXR file (it does not start with the EXR magic number)",
            dir.arg("c.1003.exr")
        ),
    );
    assert_contains(&err, "frames: 5 done, 0 skipped, 1 failed of 6 in ");
    assert_contains(&err, "error: 1 of 6 frames failed: 1003");
    for frame in SEQUENCE {
        assert_eq!(dir.join(&format!("o.{frame}.exr")).exists(), frame != 1003, "frame {frame}");
    }
    assert!(temporaries(&dir).is_empty());
    // --fail-fast: stops at 1003; 1004.. are not rendered.
    let dir = TestDir::new("sequence_fail_fast");
    let mut args = sequence_args(&dir);
    std::fs::write(dir.join("c.1003.exr"), b"not an EXR").unwrap();
    args.extend(s(&["--frames", "1001-1006", "--fail-fast"]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, "frames: 2 done, 0 skipped, 1 failed, 3 not run (--fail-fast) of 6 in ");
    for frame in SEQUENCE {
        assert_eq!(dir.join(&format!("o.{frame}.exr")).exists(), frame < 1003, "frame {frame}");
    }
}

#[test]
fn an_array_task_renders_its_chunk_of_the_range() {
    let dir = TestDir::new("sequence_chunk");
    let mut args = vec!["render".to_string(), "--validate".to_string()];
    args.extend(sequence_args(&dir));
    args.extend(s(&["--frames", "1001-1006", "--frames-from-env", "TASK_INDEX", "--chunk-size", "2"]));
    realcam_env(&dir, &args, &[("TASK_INDEX", "1")]).success();
    for frame in SEQUENCE {
        assert_eq!(dir.join(&format!("o.{frame}.exr")).exists(), [1003, 1004].contains(&frame), "frame {frame}");
    }
    let err = realcam_env(&dir, &args, &[("TASK_INDEX", "3")]).failure();
    assert_contains(
        &err,
        "error: --frames-from-env: chunk 3 of frame range \"1001-1006\" in chunks of 2: the range has 6 frames, 3 chunk(s) (indices 0 to 2)",
    );
    let err = realcam_env(&dir, &args, &[("TASK_INDEX", "one")]).failure();
    assert_contains(&err, "error: --frames-from-env: TASK_INDEX=\"one\" is not a chunk index (a whole number from 0)");
    let err = realcam(&dir, &args).failure();
    assert_contains(&err, "error: --frames-from-env: the environment variable TASK_INDEX is not set");
}

/// The `openjd` command of openjd-cli: `$REALCAM_OPENJD`, else the virtual environment
/// scripts/test.sh installs it into, else `openjd` on the PATH; None when there is none and
/// `$REALCAM_REQUIRE_OPENJD` is not set (scripts/test.sh sets it, so CI never skips).
fn openjd() -> Option<PathBuf> {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/openjd-venv/bin/openjd");
    let found =
        std::env::var_os("REALCAM_OPENJD").map(PathBuf::from).or_else(|| venv.exists().then_some(venv)).or_else(|| {
            Command::new("openjd").arg("--version").output().is_ok_and(|o| o.status.success()).then(|| "openjd".into())
        });
    if found.is_none() {
        assert!(
            std::env::var_os("REALCAM_REQUIRE_OPENJD").is_none(),
            "REALCAM_REQUIRE_OPENJD is set but openjd-cli is not installed (scripts/test.sh installs it)"
        );
        eprintln!("skipped: openjd-cli is not installed (scripts/test.sh installs it into target/openjd-venv)");
    }
    found
}

#[test]
fn the_open_job_description_template_renders_the_range_in_chunks() {
    let Some(openjd) = openjd() else { return };
    let dir = TestDir::new("openjd");
    let args = sequence_args(&dir);
    let flag = |name: &str| args[args.iter().position(|a| a == name).unwrap() + 1].clone();
    let template = Path::new(env!("CARGO_MANIFEST_DIR")).join("jobs/realcam.yaml");
    let check = Command::new(&openjd).arg("check").arg(&template).output().unwrap();
    assert!(check.status.success(), "openjd check: {}", String::from_utf8_lossy(&check.stderr));
    let params = [
        format!("Realcam={}", env!("CARGO_BIN_EXE_realcam")),
        format!("Color={}", flag("--color")),
        format!("Depth={}", flag("--depth")),
        format!("Output={}", flag("-o")),
        "Frames=1001-1006".to_string(),
        "ChunkSize=2".to_string(),
        "ExtraArgs=--fstop 1.4 --focus 2 --validate".to_string(),
    ];
    let mut run = Command::new(&openjd);
    run.arg("run").arg(&template).env("REALCAM_CACHE_DIR", &dir.cache).env_remove("REALCAM_VALIDATE");
    for p in &params {
        run.arg("-p").arg(p);
    }
    let out = run.output().unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "openjd run failed:\n{log}");
    // Three tasks of two frames, each one GPU session rendering its chunk as a sequence.
    assert_contains(&log, "Chunks run: 3");
    for chunk in ["1001,1002", "1003,1004", "1005,1006"] {
        assert_contains(&log, &format!("Frame(CHUNK[INT]) = {chunk}"));
    }
    assert_eq!(log.matches("device: ").count(), 3, "{log}");
    assert_eq!(log.matches("frames: 2 done, 0 skipped, 0 failed of 2 in ").count(), 3, "{log}");
    assert_eq!(log.matches("openjd_progress: 100").count(), 3, "{log}");
    // Every frame as a single run of realcam writes it.
    for frame in SEQUENCE {
        let single: Vec<String> = args
            .iter()
            .map(|a| a.replace("####", &frame.to_string()).replace("%04d", &frame.to_string()))
            .map(|a| if a == dir.arg(&format!("o.{frame}.exr")) { dir.arg("single.exr") } else { a })
            .collect();
        render(&dir, &single).success();
        let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
        assert!(read(&format!("o.{frame}.exr")) == read("single.exr"), "frame {frame}: differs from a single run");
    }
    assert!(temporaries(&dir).is_empty());
}

#[test]
fn sequence_errors_name_the_flag_before_any_work() {
    let dir = TestDir::new("sequence_errors");
    let mut args = sequence_args(&dir);
    args.extend(s(&["--frames", "1006-1001"]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        "error: --frames: frame range \"1006-1001\": \"1006-1001\": the span ends before it starts (1001 < 1006)",
    );
    let mut args = sequence_args(&dir);
    args.extend(s(&["--frames", "1001-1006", "--png", &dir.arg("preview.png")]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!(
            "error: --png \"{}\" has no frame number (####, %04d): every frame of --frames would write over it",
            dir.arg("preview.png")
        ),
    );
    let mut args = sequence_args(&dir);
    args.extend(s(&["--frames", "1001-1006", "--png", &dir.arg("p.%4d.png")]));
    let err = render(&dir, &args).failure();
    assert_contains(&err, "\"%4d\" pads with spaces; write \"%04d\" for a zero-padded frame number");
    assert!(!err.contains("device:"), "{err}");
    assert!(dir.listing().iter().all(|name| name.starts_with("c.") || name.starts_with("d.")), "{:?}", dir.listing());
}

#[test]
fn a_long_exposure_is_the_average_of_the_frames() {
    let dir = TestDir::new("long_exposure");
    let linear = ["--film", "linear", "--float"];
    let mut args = sequence_args(&dir);
    for arg in args.iter_mut() {
        if *arg == dir.arg("o.####.exr") {
            *arg = dir.arg("exposure.exr");
        }
    }
    args.extend(s(&["--frames", "1001-1006", "--long-exposure"]));
    args.extend(s(&linear));
    let run = render(&dir, &args).success();
    assert_contains(&run.stderr, &format!("wrote {} (a long exposure of 6 frames)", dir.arg("exposure.exr")));
    assert_eq!(farm_progress(&run.stderr), [16, 33, 50, 66, 83, 100]);
    // The same frames one by one, averaged here in f64.
    let mut sequence = sequence_args(&dir);
    sequence.extend(s(&["--frames", "1001-1006"]));
    sequence.extend(s(&linear));
    render(&dir, &sequence).success();
    let exposure = read_exr_rgba(&dir.join("exposure.exr")).unwrap();
    let frames: Vec<Image> =
        SEQUENCE.iter().map(|f| read_exr_rgba(&dir.join(&format!("o.{f}.exr"))).unwrap()).collect();
    for (i, &value) in exposure.data.iter().enumerate() {
        let mean = frames.iter().map(|f| f64::from(f.data[i])).sum::<f64>() / 6.0;
        assert!((f64::from(value) - mean).abs() <= 1e-6 * mean.abs().max(1e-3), "value {i}: {value} against {mean}");
    }
    // Frames differ, so the average is none of them.
    assert!(frames.iter().all(|f| f.data != exposure.data));

    // Refused before any work: an output with a frame number.
    let mut patterned = sequence_args(&dir);
    patterned.extend(s(&["--frames", "1001-1006", "--long-exposure"]));
    patterned.extend(s(&linear));
    let err = render(&dir, &patterned).failure();
    assert_contains(
        &err,
        &format!(
            "error: --output \"{}\" has a frame number, but --long-exposure writes one exposure of all the frames",
            dir.arg("o.####.exr")
        ),
    );
    assert!(!err.contains("device:"), "{err}");

    // A frame that fails stops the exposure; the one written before stays as it was.
    let before = std::fs::read(dir.join("exposure.exr")).unwrap();
    std::fs::write(dir.join("c.1004.exr"), b"not an EXR").unwrap();
    let err = render(&dir, &args).failure();
    assert_contains(&err, "error: frame 1004: color: ");
    assert_contains(&err, "frames: 3 done, 0 skipped, 1 failed, 2 not run (the exposure stopped) of 6 in ");
    assert_contains(&err, "error: frame 1004 failed: the long exposure of 6 frames is not written");
    assert_eq!(std::fs::read(dir.join("exposure.exr")).unwrap(), before);
    assert!(temporaries(&dir).is_empty());
}

/// Column sums of channel R of `image`.
fn column_sums(image: &Image) -> Vec<f64> {
    (0..image.width).map(|x| (0..image.height).map(|y| f64::from(image.get(x, y, 0))).sum()).collect()
}

/// Where `profile` crosses `level` going up (first) and down (last), interpolated between
/// pixel centres.
fn crossings(profile: &[f64], level: f64) -> (f64, f64) {
    let cross = |i: usize| i as f64 + (level - profile[i]) / (profile[i + 1] - profile[i]);
    let up = (0..profile.len() - 1).find(|&i| profile[i] < level && profile[i + 1] >= level).unwrap();
    let down = (0..profile.len() - 1).rev().find(|&i| profile[i] >= level && profile[i + 1] < level).unwrap();
    (cross(up), cross(down))
}

#[test]
fn a_moving_highlight_leaves_a_trail_as_long_as_its_motion() {
    // A 3x3 px square of value 50 at 2 m moving 6 px per frame to the right over 8 frames in
    // front of black at 10 m (Nuke forward.u = 6 px toward the next frame), each frame motion-blurred over a 360
    // degree shutter so that the frames' blurs join: the exposure is the square swept over
    // 8 x 6 = 48 px, a trapezoid whose half-maximum width is the motion (box 3 px convolved
    // with box 48 px), with the square's energy (Kyaw 2013 sec. 7.4: the average of the frames).
    let dir = TestDir::new("long_exposure_trail");
    let (w, h, side, step_px, frames, value) = (72u32, 16u32, 3u32, 6u32, 8u32, 50.0f32);
    let (x0, y0) = (10u32, 6u32);
    let n = (w * h) as usize;
    for i in 0..frames {
        let mut rgb = vec![0.0f32; n];
        let alpha = vec![1.0f32; n];
        let mut u = vec![0.0f32; n];
        let mut z = vec![10.0f32; n];
        for y in y0..y0 + side {
            for x in x0 + i * step_px..x0 + i * step_px + side {
                let at = (y * w + x) as usize;
                (rgb[at], u[at], z[at]) = (value, step_px as f32, 2.0);
            }
        }
        let v = vec![0.0f32; n];
        let channels: Vec<(&str, &[f32])> =
            vec![("R", &rgb), ("G", &rgb), ("B", &rgb), ("A", &alpha), ("Z", &z), ("forward.u", &u), ("forward.v", &v)];
        write_exr_channels(&dir.join(&format!("m.{}.exr", 1001 + i)), w, h, &channels, &float_opts()).unwrap();
    }
    // The fast gather and the reference (every pixel scattered along its path).
    for (mode, pass) in [("fast", "motion_blur"), ("reference", "motion_blur_reference")] {
        let camera: Vec<String> =
            "--lens ideal --fstop 8 --focus 2 --no-exposure --no-vignetting --no-flare --grain 0 \
            --film linear --float --fps 24 --shutter-angle 360 --frames 1001-1008 --motion-blur"
                .split_whitespace()
                .map(String::from)
                .chain([mode.to_string()])
                .collect();
        let mut exposure =
            s(&["--color", &dir.arg("m.####.exr"), "-o", &dir.arg(&format!("exposure-{mode}.exr")), "--long-exposure"]);
        exposure.extend(camera.iter().cloned());
        render(&dir, &exposure).success();
        let mut each =
            s(&["--color", &dir.arg("m.####.exr"), "-o", &dir.arg(&format!("o-{mode}.####.exr")), "--explain"]);
        each.extend(camera.iter().cloned());
        let run = render(&dir, &each).success();
        assert_contains(&run.stderr, &format!("[run ] {pass} "));
        let image = read_exr_rgba(&dir.join(&format!("exposure-{mode}.exr"))).unwrap();
        assert!(image.data.iter().all(|v| v.is_finite()));

        // Energy: the exposure's is the mean of the frames' (1e-4), which is the square's (1 %).
        let energy = |im: &Image| column_sums(im).iter().sum::<f64>();
        let frame_energies: Vec<f64> =
            (1001..=1008).map(|f| energy(&read_exr_rgba(&dir.join(&format!("o-{mode}.{f}.exr"))).unwrap())).collect();
        let mean = frame_energies.iter().sum::<f64>() / f64::from(frames);
        let total = energy(&image);
        assert!((total - mean).abs() <= 1e-4 * mean, "{mode}: exposure energy {total} against the frames' mean {mean}");
        let square = f64::from(value) * f64::from(side * side);
        assert!(
            (total - square).abs() <= 0.01 * square,
            "{mode}: exposure energy {total} against the square's {square}"
        );

        // Length: at half the plateau (the square's column sum spread over the motion), the trail
        // is as long as the motion, 48 px.
        let profile = column_sums(&image);
        let plateau = square / f64::from(frames * step_px);
        let middle = &profile[(x0 + 12) as usize..(x0 + 36) as usize];
        assert!(
            middle.iter().all(|&c| (c - plateau).abs() <= 0.1 * plateau),
            "{mode}: {profile:?} against plateau {plateau}"
        );
        let (start, end) = crossings(&profile, plateau / 2.0);
        let length = end - start;
        assert!(
            (length - f64::from(frames * step_px)).abs() <= 1.5,
            "{mode}: trail {length} px, {start}..{end}: {profile:?}"
        );
        // Each frame alone is a blur of one frame's motion, 6 px, not a trail.
        let one = column_sums(&read_exr_rgba(&dir.join(&format!("o-{mode}.1004.exr"))).unwrap());
        let peak = one.iter().cloned().fold(0.0, f64::max);
        let (a, b) = crossings(&one, peak / 2.0);
        assert!((b - a - f64::from(step_px)).abs() <= 1.5, "{mode}: frame 1004's blur {} px: {one:?}", b - a);
    }
}

#[test]
fn a_long_exposure_of_identical_frames_on_film_is_the_single_frame_on_that_film() {
    // The frames are averaged as sensor values and the film's curve and grain come once, after:
    // 3 identical frames through a non-linear film with grain give the single frame's bytes (a
    // curve applied per frame and averaged would too, but grain averaged over frames would not,
    // and neither would the contrast film's curve of an average of different frames).
    let dir = TestDir::new("long_exposure_film");
    let mut args = sequence_args(&dir);
    for frame in [1002, 1003] {
        std::fs::copy(dir.join("c.1001.exr"), dir.join(&format!("c.{frame}.exr"))).unwrap();
        std::fs::copy(dir.join("d.1001.exr"), dir.join(&format!("d.{frame}.exr"))).unwrap();
    }
    // The film in the EXR (by default it is only in the PNG preview).
    let film = ["--film", "contrast", "--grain", "0.05", "--iso", "800", "--film-in-exr"];
    let mut single = args.clone();
    for arg in args.iter_mut() {
        if *arg == dir.arg("o.####.exr") {
            *arg = dir.arg("exposure.exr");
        }
    }
    args.extend(s(&["--frames", "1001-1003", "--long-exposure", "--explain"]));
    args.extend(s(&film));
    let run = render(&dir, &args).success();
    assert_contains(&run.stderr, "the long exposure's pass plan:\n");
    assert_contains(&run.stderr, "[run ] film          exposure off, characteristic curve, sensor noise sigma");
    for arg in single.iter_mut() {
        *arg = arg.replace("####", "1001").replace("%04d", "1001");
    }
    single.extend(s(&film));
    render(&dir, &single).success();
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert!(read("exposure.exr") == read("o.1001.exr"), "the exposure of 3 identical frames differs from one frame");
    // The grain is there (the linear film without grain differs), once.
    let mut linear = single.clone();
    linear.truncate(linear.len() - film.len());
    linear.extend(s(&["--film", "contrast", "--iso", "800", "--film-in-exr"]));
    linear = linear.into_iter().map(|a| a.replace("o.1001.exr", "plain.exr")).collect();
    render(&dir, &linear).success();
    assert!(read("plain.exr") != read("o.1001.exr"), "the grain changed nothing");
}

#[test]
fn each_frame_of_a_sequence_gets_its_own_grain_and_the_same_frame_the_same_grain() {
    // Issue 31: grain seeded by the seed and the frame number. Three identical frames: the
    // noise (the grainy frame less the same frame without grain) of neighbouring frames is
    // uncorrelated, and a frame rendered again in another run has the same bytes.
    let dir = TestDir::new("grain_per_frame");
    let mut args = sequence_args(&dir);
    for frame in [1002, 1003] {
        std::fs::copy(dir.join("c.1001.exr"), dir.join(&format!("c.{frame}.exr"))).unwrap();
        std::fs::copy(dir.join("d.1001.exr"), dir.join(&format!("d.{frame}.exr"))).unwrap();
    }
    let film = ["--film", "linear", "--film-in-exr", "--iso", "800", "--seed", "7"];
    let mut plain = args.clone();
    args.extend(s(&["--frames", "1001-1003", "--grain", "0.05"]));
    args.extend(s(&film));
    render(&dir, &args).success();
    for arg in plain.iter_mut() {
        *arg = arg.replace("####", "1001").replace("%04d", "1001").replace("o.1001", "plain");
    }
    plain.extend(s(&film));
    render(&dir, &plain).success();
    let pixels = |name: &str| read_exr_rgba(&dir.join(name)).unwrap().data;
    let clean = pixels("plain.exr");
    let noise = |name: &str| -> Vec<f64> {
        let grainy = pixels(name);
        grainy.iter().zip(&clean).enumerate().filter(|(i, _)| i % 4 != 3).map(|(_, (g, c))| f64::from(g - c)).collect()
    };
    let correlation = |a: &[f64], b: &[f64]| {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (ma, mb) = (mean(a), mean(b));
        let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
        let var = |v: &[f64], m: f64| v.iter().map(|x| (x - m).powi(2)).sum::<f64>();
        cov / (var(a, ma) * var(b, mb)).sqrt()
    };
    let (n1, n2, n3) = (noise("o.1001.exr"), noise("o.1002.exr"), noise("o.1003.exr"));
    assert!(n1.iter().any(|&v| v.abs() > 1e-4), "no grain in frame 1001");
    for (pair, r) in [("1001/1002", correlation(&n1, &n2)), ("1002/1003", correlation(&n2, &n3))] {
        assert!(r.abs() < 0.1, "frames {pair}: their grain correlates {r:.3}");
    }
    // Frame 1002 again, alone, in another run: the same bytes.
    let first = std::fs::read(dir.join("o.1002.exr")).unwrap();
    let again: Vec<String> = args
        .iter()
        .map(|a| if a == "1001-1003" { "1002".to_string() } else { a.replace("o.####", "again.####") })
        .collect();
    render(&dir, &again).success();
    assert!(std::fs::read(dir.join("again.1002.exr")).unwrap() == first, "frame 1002 rendered again differs");
}

#[test]
fn a_closed_stderr_does_not_stop_a_sequence() {
    // Issue 34 (5): `render ... --frames 1001-1003 2>&1 | head -2` panicked ("failed printing to
    // stderr: Broken pipe") after frame 1002. The reader of stderr goes away after its first
    // line; every frame is still written and the run succeeds.
    use std::io::BufRead;
    let dir = TestDir::new("closed_stderr");
    let mut args = vec!["render".to_string(), "--validate".to_string()];
    args.extend(sequence_args(&dir));
    args.extend(s(&["--frames", "1001-1003", "--explain"]));
    let mut child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(&args)
        .env_remove("OCIO")
        .current_dir(&dir.path)
        .env("REALCAM_CACHE_DIR", &dir.cache)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("running the realcam binary");
    let mut first = String::new();
    std::io::BufReader::new(child.stderr.take().unwrap()).read_line(&mut first).unwrap();
    // The reader (and the pipe's only read end) is dropped here.
    let status = child.wait().unwrap();
    assert!(status.success(), "exit status {status:?} after stderr closed (first line {first:?})");
    for frame in 1001..=1003 {
        assert!(dir.join(&format!("o.{frame}.exr")).is_file(), "frame {frame} was not written");
    }
}

#[test]
fn a_stopped_long_exposure_resumes_to_the_uninterrupted_one() {
    let dir = TestDir::new("long_exposure_state");
    let mut args = sequence_args(&dir);
    for arg in args.iter_mut() {
        if *arg == dir.arg("o.####.exr") {
            *arg = dir.arg("whole.exr");
        }
    }
    args.extend(s(&["--frames", "1001-1006", "--long-exposure", "--film", "linear", "--float"]));
    render(&dir, &args).success();
    // Frame 1004 is broken: the run stops there, the state keeps 1001-1003.
    let with_state = |out: &str| {
        let mut a: Vec<String> = args.iter().map(|x| x.replace("whole.exr", out)).collect();
        a.extend(s(&["--state", &dir.arg("exposure.state")]));
        a
    };
    std::fs::write(dir.join("c.1004.exr"), b"not an EXR").unwrap();
    let err = render(&dir, &with_state("resumed.exr")).failure();
    assert_contains(&err, "frames: 3 done, 0 skipped, 1 failed, 2 not run (the exposure stopped) of 6 in ");
    assert!(!dir.join("resumed.exr").exists());
    // Repaired and run again: 1001-1003 come from the state, the sums are the same, the bytes too.
    sequence_args(&dir);
    let run = render(&dir, &with_state("resumed.exr")).success();
    assert_contains(&run.stderr, "frame 1002: already in the exposure (--state)");
    assert_contains(&run.stderr, "frames: 3 done, 3 skipped, 0 failed of 6 in ");
    assert_contains(&run.stderr, "(a long exposure of 6 frames)");
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert!(read("resumed.exr") == read("whole.exr"), "the resumed exposure differs from the uninterrupted one");
    // A state resumed with another f-number is refused, the setting named; nothing is written.
    let mut other = with_state("other.exr");
    let fstop_at = other.iter().position(|a| a == "1.4").unwrap();
    other[fstop_at] = "2.8".into();
    let err = render(&dir, &other).failure();
    assert_contains(
        &err,
        &format!(
            "error: --state \"{}\": the exposure was started with other camera settings (f_number: 1.4 there, \
             f_number: 2.8 here); resume it with the same settings, or start another --state file",
            dir.arg("exposure.state")
        ),
    );
    // A state from another range, and a state that is not one, are named.
    let mut other = with_state("other.exr");
    let frames_at = other.iter().position(|a| a == "1001-1006").unwrap();
    other[frames_at] = "1004-1006".into();
    let err = render(&dir, &other).failure();
    assert_contains(
        &err,
        &format!(
            "error: --state \"{}\": frame 1001 of the exposure is not in --frames \"1004-1006\"",
            dir.arg("exposure.state")
        ),
    );
    std::fs::write(dir.join("exposure.state"), b"hello").unwrap();
    let err = render(&dir, &with_state("other.exr")).failure();
    assert_contains(
        &err,
        &format!(
            "error: --state \"{}\": not a long-exposure state of realcam: the first line is not \"realcam-long-exposure 2\"",
            dir.arg("exposure.state")
        ),
    );
    assert!(!dir.join("other.exr").exists());
}

// ---------------------------------------------------------------------------------------------
// Defaults that fit a compositor (issue 16, part 4)
// ---------------------------------------------------------------------------------------------

/// The 8-bit samples of a PNG.
fn png_samples(path: &Path) -> Vec<u8> {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8().into_raw()
}

/// The EXR is scene-referred by default: a highlight of 1e6 in focus keeps its light times the
/// exposure gain instead of becoming the film's white, and the PNG preview is the film curve of
/// those values: the same, within one level of 255, as the GPU's curve with --film-in-exr,
/// whose EXR stops at the film's white.
#[test]
fn the_exr_is_scene_referred_and_the_png_previews_the_film_curve() {
    let dir = TestDir::new("scene_referred");
    let mut args = scene_args(&dir, "p", &SynthScene::point_on_plane(16, 12, 2.0, [1.0e6; 3]));
    args.extend(s(&["--fstop", "2", "--focus", "2", "--float", "--no-flare", "--no-vignetting", "--validate"]));
    args.extend(s(&["--png", &dir.arg("out.png")]));
    render(&dir, &args).success();
    let scene = read_exr_rgba(&dir.join("out.exr")).unwrap();
    let gain = match attribute(&dir.join("out.exr"), "realcam/exposure_gain") {
        exr::meta::attribute::AttributeValue::F32(g) => f64::from(g),
        other => panic!("realcam/exposure_gain is {other:?}"),
    };
    // ISO 100, 1/50 s, f/2 focused at 2 m, 160 cd/m^2 per unit: 0.7045 (the demo's plan).
    assert!((gain - 0.7045).abs() < 1e-4, "gain {gain}");
    let centre = f64::from(scene.get(8, 6, 0));
    assert!((centre / (1.0e6 * gain) - 1.0).abs() < 1e-5, "highlight {centre} against {}", 1.0e6 * gain);
    assert_eq!(attribute(&dir.join("out.exr"), "realcam/film"), text_value("linear (scene-referred)"));
    let preview = png_samples(&dir.join("out.png"));

    args.push("--film-in-exr".into());
    render(&dir, &args).success();
    let display = read_exr_rgba(&dir.join("out.exr")).unwrap();
    assert!(display.data.iter().all(|&v| (0.0..=1.0).contains(&v)), "the film curve ends at its white");
    assert!(display.get(8, 6, 0) > 0.95, "the highlight is near the film's white: {}", display.get(8, 6, 0));
    assert_eq!(attribute(&dir.join("out.exr"), "realcam/film"), text_value("characteristic curve"));
    let gpu_curve = png_samples(&dir.join("out.png"));
    assert_eq!(preview.len(), gpu_curve.len());
    let worst = preview.iter().zip(&gpu_curve).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    assert!(worst <= 1, "the preview differs from the GPU's film curve by {worst} levels");
    // The plane (0.1 x gain ~ 0.07, under the film's middle grey 0.128) is dark but not black.
    assert!((20..120).contains(&preview[0]), "plane preview {}", preview[0]);
}

/// --keep-layers: the input's other channels (depth, vectors, AOVs, another view layer) come
/// out beside the camera's R, G, B, A as stored (float, a sky at 1e10 included, in a half
/// output too); the colour pass's own channels do not; a name the output already has takes
/// its pass as prefix. Without the flag only R, G, B, A.
#[test]
fn keep_layers_writes_the_inputs_other_channels_as_stored() {
    let dir = TestDir::new("keep_layers");
    let (w, h) = (12u32, 8u32);
    let n = (w * h) as usize;
    let ramp = |k: f32| (0..n).map(|i| k * i as f32 + 0.25).collect::<Vec<f32>>();
    let mut depth = vec![3.0f32; n];
    depth[5] = 1.0e10;
    let (grey, one, zero) = (vec![0.2f32; n], vec![1.0f32; n], vec![0.0f32; n]);
    let (ao, crypto) = (ramp(0.01), ramp(-3.5));
    let channels: Vec<(&str, &[f32])> = vec![
        ("ViewLayer.Combined.R", &grey),
        ("ViewLayer.Combined.G", &grey),
        ("ViewLayer.Combined.B", &grey),
        ("ViewLayer.Combined.A", &one),
        ("ViewLayer.Depth.Z", &depth),
        ("ViewLayer.Vector.X", &zero),
        ("ViewLayer.Vector.Y", &zero),
        ("ViewLayer.Vector.Z", &zero),
        ("ViewLayer.Vector.W", &zero),
        ("ViewLayer.AO.R", &ao),
        ("ViewLayer.CryptoObject00.R", &crypto),
    ];
    let color = dir.join("passes.exr");
    write_exr_channels(&color, w, h, &channels, &float_opts()).unwrap();
    let base = s(&["--color", &dir.arg("passes.exr"), "-o", &dir.arg("out.exr"), "--fstop", "2", "--focus", "3"]);
    let mut args = base.clone();
    args.extend(s(&["--keep-layers", "--explain", "--validate"]));
    let run = render(&dir, &args).success();
    assert_contains(&run.stderr, "kept for the output: 7 channel(s)");
    let names = |path: &Path| -> Vec<String> {
        exr_header(path).channels.list.iter().map(|c| c.name.to_string()).collect::<Vec<String>>()
    };
    let mut expected: Vec<&str> = channels[4..].iter().map(|(name, _)| *name).collect();
    expected.extend(["A", "B", "G", "R"]);
    expected.sort();
    assert_eq!(names(&dir.join("out.exr")), expected);
    for (name, values) in &channels[4..] {
        let kept = read_exr_channel(&dir.join("out.exr"), name).unwrap();
        assert_eq!(&kept.data[..], *values, "{name}");
    }
    // Without the flag: the camera's image alone.
    render(&dir, &base).success();
    assert_eq!(names(&dir.join("out.exr")), ["A", "B", "G", "R"]);

    // Separate files: the depth file's own R would be the output's: it becomes depth.R.
    let mut args = scene_args(&dir, "p", &SynthScene::point_on_plane(w, h, 2.0, [1.0; 3]));
    let depth_file = dir.join("p_depth.exr");
    let stored_depth = read_exr_channel(&depth_file, "Z").unwrap().data;
    write_exr_channels(&depth_file, w, h, &[("Z", &stored_depth), ("R", &ao)], &float_opts()).unwrap();
    args.extend(s(&["--fstop", "2", "--focus", "2", "--keep-layers"]));
    render(&dir, &args).success();
    assert_eq!(names(&dir.join("out.exr")), ["A", "B", "G", "R", "Z", "depth.R"]);
    assert_eq!(read_exr_channel(&dir.join("out.exr"), "depth.R").unwrap().data, ao);
}

/// --explain prints what a user matches against the 3D camera (focal length, sensor and fit,
/// pixel pitch, field of view, the lens and its aberrations); a lens file made for another
/// focal length than the render's (--focal-length, or the input's header) is warned about.
#[test]
fn explain_prints_the_camera_and_a_lens_of_another_focal_length_is_warned_about() {
    let dir = TestDir::new("explain_camera");
    let mut args = small_scene(&dir);
    args.extend(s(&["--sensor", "9.6x7.2", "--fstop", "2", "--focus", "3", "--explain"]));
    let err = render(&dir, &args).success().stderr;
    assert_contains(&err, "lens: \"realcam standard 50 mm f/1.4\" (50 mm lens file)");
    assert_contains(&err, "focal length 50 mm, f/2, focus 3 m, 9 blades rotated 0 deg; shutter 0.02 s, ISO 100");
    // 9.6 mm across 16 px: 0.6 mm a pixel; the field of view 2 atan(4.8 / 50) by 2 atan(3.6 / 50).
    let fov = |half_mm: f64| 2.0 * (half_mm / 50.0f64).atan().to_degrees();
    assert_contains(
        &err,
        &format!(
            "sensor 9.6 x 7.2 mm, fit horizontal: the frame is 9.600 x 7.200 mm, pixel pitch 0.600000 mm \
             (600.000 um); field of view {:.2} x {:.2} deg",
            fov(4.8),
            fov(3.6)
        ),
    );
    assert_contains(&err, "aberrations: spherical aberration 0.3, natural vignetting (cos^4), lens flare");
    assert_contains(&err, "film curve: in the PNG preview only; the EXR is scene-referred");
    assert!(!err.contains("warning: the lens file"), "{err}");

    // The default 50 mm lens forced to 35 mm.
    args.extend(s(&["--focal-length", "35", "--force"]));
    let err = render(&dir, &args).success().stderr;
    assert_contains(
        &err,
        "warning: the lens file \"realcam standard 50 mm f/1.4\" is for 50 mm but the render was made with 35 mm",
    );

    // The renderer's focal length from the colour file's header: OpenEXR's pinholeFocalLength,
    // or Blender's Lens stamp.
    let mut args = small_scene(&dir);
    args.extend(s(&["--fstop", "2", "--focus", "3"]));
    let color = dir.join("scene_color.exr");
    let image = read_exr_rgba(&color).unwrap();
    let stamps = [
        ("pinholeFocalLength", realcam::io::ExrAttribute::F32(85.0)),
        ("Lens", realcam::io::ExrAttribute::Text("85.00 mm".into())),
    ];
    for (name, value) in stamps {
        let opts = ExrWriteOptions { attributes: vec![(name.into(), value)], ..float_opts() };
        write_exr_rgba(&color, &image, &opts).unwrap();
        let err = render(&dir, &args).success().stderr;
        assert_contains(
            &err,
            &format!(
                "warning: the lens file \"realcam standard 50 mm f/1.4\" is for 50 mm but the render was made with \
                 85 mm: its field of view, tables and aberrations do not match the render's camera (its {name} attribute)"
            ),
        );
    }
    // The ideal lens takes the render's focal length: nothing to warn about.
    args.extend(s(&["--lens", "ideal", "--focal-length", "85"]));
    assert!(!render(&dir, &args).success().stderr.contains("warning: the lens file"));
}

/// The colour space (issue 16, part 1): the colour file's chromaticities attribute is read and
/// written back on the output; --colorspace names one instead; an unknown name lists the known
/// ones, and chromaticities that are no RGB space are an error naming the file.
#[test]
fn the_colour_space_comes_from_the_file_or_colorspace_and_goes_to_the_output() {
    use realcam::io::ExrAttribute;
    use realcam::optics::colour::Chromaticities;
    let dir = TestDir::new("colour_space");
    let mut args = small_scene(&dir);
    args.extend(s(&["--fstop", "2", "--focus", "3", "--explain"]));
    let xy = |c: Chromaticities| [c.red, c.green, c.blue, c.white].map(|[x, y]| [x as f32, y as f32]);
    let written = || {
        let c = exr_header(&dir.join("out.exr")).shared_attributes.chromaticities.expect("chromaticities");
        [c.red, c.green, c.blue, c.white].map(|v| [v.0, v.1])
    };
    let err = render(&dir, &args).success().stderr;
    assert_contains(
        &err,
        "colour space: Linear Rec.709 (sRGB) (the colour file's chromaticities, or Rec.709 without them); \
         luminance = 0.2126 R + 0.7152 G + 0.0722 B",
    );
    assert_eq!(written(), xy(Chromaticities::REC709));

    // A file in ACEScg says so.
    let color = dir.join("scene_color.exr");
    let image = read_exr_rgba(&color).unwrap();
    let with = |c: [[f32; 2]; 4]| ExrWriteOptions {
        attributes: vec![("chromaticities".into(), ExrAttribute::Chromaticities(c))],
        ..float_opts()
    };
    write_exr_rgba(&color, &image, &with(xy(Chromaticities::ACES_AP1))).unwrap();
    let err = render(&dir, &args).success().stderr;
    assert_contains(&err, "colour space: ACEScg (the colour file's chromaticities");
    assert_contains(&err, "luminance = 0.2722 R + 0.6741 G + 0.0537 B");
    assert_contains(&err, "chromatic effects at 628.8, 532.9, 467.2 nm (the primaries' dominant wavelengths)");
    assert_eq!(written(), xy(Chromaticities::ACES_AP1));

    // --colorspace wins.
    let mut named = args.clone();
    named.extend(s(&["--colorspace", "ACES2065-1"]));
    let err = render(&dir, &named).success().stderr;
    assert_contains(&err, "colour space: ACES2065-1 (--colorspace, not the file's chromaticities)");
    assert_eq!(written(), xy(Chromaticities::ACES_AP0));
    let mut unknown = args.clone();
    unknown.extend(s(&["--colorspace", "sRGB - Texture"]));
    assert_contains(
        &render(&dir, &unknown).failure(),
        "error: --colorspace \"sRGB - Texture\": not a colour space realcam knows; known: Linear Rec.709 (sRGB), \
         ACEScg, ACES2065-1, Linear Rec.2020, Linear P3-D65 (or any space of an OpenColorIO config: --config FILE, \
         $OCIO)",
    );

    // An OpenColorIO config's names, from --config or $OCIO; its errors name the config and the space.
    let mut in_config = args.clone();
    in_config.extend(s(&["--config", "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5", "--colorspace", "lin_ap0"]));
    let err = render(&dir, &in_config).success().stderr;
    assert_contains(
        &err,
        "colour space: ACES2065-1 (--colorspace in OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5, \
         not the file's chromaticities)",
    );
    assert_eq!(written(), xy(Chromaticities::ACES_AP0));
    // The config knows "sRGB - Texture" (an alias of its sRGB-encoded Rec.709), which is no
    // scene-linear input.
    unknown.extend(s(&["--config", "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5"]));
    assert_contains(
        &render(&dir, &unknown).failure(),
        "error: --colorspace \"sRGB - Texture\": OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5: \
         colour space \"sRGB Encoded Rec.709 (sRGB)\" is not linear (realcam's passes add light, so the input must \
         be scene-linear)",
    );
    let mut typo = args.clone();
    typo.extend(s(&["--config", "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5", "--colorspace", "ACEScgg"]));
    assert_contains(
        &render(&dir, &typo).failure(),
        "error: --colorspace \"ACEScgg\": OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5: no \
         colour space \"ACEScgg\"; its colour spaces: ",
    );
    let missing = dir.join("missing.ocio");
    let mut from_env = args.clone();
    from_env.extend(s(&["--colorspace", "ACEScg"]));
    let mut all = s(&["render"]);
    all.extend(from_env);
    let missing_text = missing.display().to_string();
    assert_contains(
        &realcam_env(&dir, all, &[("OCIO", missing_text.as_str())]).failure(),
        &format!(
            "error: $OCIO: OpenColorIO config \"{}\": cannot read it: '{}' file does not exist.",
            missing.display(),
            missing.display()
        ),
    );
    let mut all = s(&["render", "--colorspace", "lin_ap1"]);
    all.extend(args.clone());
    let err = realcam_env(&dir, all, &[("OCIO", "ocio://cg-config-latest")]).success().stderr;
    assert_contains(
        &err,
        "colour space: ACEScg (--colorspace in OpenColorIO config ocio://cg-config-latest from $OCIO); luminance",
    );
    assert_eq!(written(), xy(Chromaticities::ACES_AP1));

    // Green on the line from red to blue (binary fractions, exact in the file): no RGB space.
    let white = xy(Chromaticities::REC709)[3];
    write_exr_rgba(&color, &image, &with([[0.625, 0.375], [0.375, 0.25], [0.125, 0.125], white])).unwrap();
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!("error: color: \"{}\": its chromaticities attribute is unusable: chromaticities", color.display()),
    );
    assert_contains(&err, "are not an RGB space: the primaries lie on one line");
}

/// The PNG preview through an OpenColorIO config's display and view (issue 16, part 1): a flat
/// ACEScg frame through optics that leave it flat (the ideal lens, no exposure gain, no
/// vignetting, no flare) shows OpenColorIO's own display values of its colour, within one level
/// of 255; the film curve is not applied on top. An unknown display or view names the config's
/// list; --display without a config is refused.
#[test]
fn the_png_preview_goes_through_the_configs_display_and_view() {
    let dir = TestDir::new("ocio_preview");
    let flat = SynthScene {
        width: 16,
        height: 12,
        background_depth_m: 3.0,
        background_rgb: [0.5, 0.25, 0.1],
        planes: Vec::new(),
        highlights: Vec::new(),
    };
    let mut args = scene_args(&dir, "flat", &flat);
    let png = dir.arg("out.png");
    args.extend(s(&["--lens", "ideal", "--focal-length", "50", "--fstop", "2", "--focus", "3", "--no-exposure"]));
    args.extend(s(&["--no-vignetting", "--no-flare", "--png", &png, "--colorspace", "ACEScg"]));
    let mut with_config = args.clone();
    with_config.extend(s(&["--config", "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5", "--explain"]));
    let err = render(&dir, &with_config).success().stderr;
    assert_contains(
        &err,
        "preview: OpenColorIO display \"sRGB - Display\", view \"ACES 2.0 - SDR 100 nits (Rec.709)\" (from ACEScg)",
    );
    assert_contains(&err, "film curve: not used: the PNG preview's tone curve is the config's view");
    // PyOpenColorIO 2.6.0's display values of ACEScg (0.5, 0.25, 0.1) through that view
    // (tests/ocio.rs, SRGB_ACES2_VIEW; scripts/ocio-reference.py).
    let want = [0.6656523f32, 0.3968449, 0.2320423].map(|v| v * 255.0);
    let samples = png_samples(&dir.join("out.png"));
    assert_eq!(samples.len(), 16 * 12 * 3);
    for px in samples.chunks_exact(3) {
        assert!((0..3).all(|c| (f32::from(px[c]) - want[c]).abs() <= 1.0), "{px:?} vs OpenColorIO {want:?}");
    }
    // Without the config: the film curve and the sRGB curve, another picture.
    let without = png_samples(&{
        render(&dir, &args).success();
        dir.join("out.png")
    });
    assert!(without.chunks_exact(3).all(|px| (f32::from(px[0]) - want[0]).abs() > 3.0), "{:?}", &without[..3]);

    let mut view = with_config.clone();
    view.extend(s(&["--view", "Filmic"]));
    assert_contains(
        &render(&dir, &view).failure(),
        "error: --view: OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5: display \"sRGB - Display\" \
         has no view \"Filmic\" for \"ACEScg\"; its views: ACES 2.0 - SDR 100 nits (Rec.709), Un-tone-mapped, ",
    );
    let mut display = with_config.clone();
    display.extend(s(&["--display", "sRGB"]));
    assert_contains(
        &render(&dir, &display).failure(),
        "error: --display: OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5: no display \"sRGB\"; \
         its displays: sRGB - Display, Display P3 - Display, ",
    );
    args.extend(s(&["--display", "sRGB - Display"]));
    assert_contains(
        &render(&dir, &args).failure(),
        "error: --display/--view: no OpenColorIO config (--config FILE, $OCIO)",
    );
}

/// The Tessar's lens file with one fitted ghost: a 10 x 6 px box of light 2 in the green
/// channel of a 40 x 20 px frame (sharp edges on pixel borders), its centre at x = 10 + 1 px
/// per degree (fitted 0..30 deg).
fn lens_with_a_box_ghost(dir: &TestDir) -> String {
    let tessar =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/lenses/tessar-walch-lens.toml")).unwrap();
    let ghost = "\n[[fitted_ghost]]\nghost = \"2/1\"\nchannel = 1\nframe_px = [40, 20]\nangles_deg = [0.0, 30.0]\n\
        centre_x_px = [10.0, 1.0]\ncentre_y_px = [10.0]\nheight_px = [3.0]\nleft_px = [5.0]\nright_px = [5.0]\n\
        left_control = [1.0]\nright_control = [1.0]\nborder = [2.0]\ninner = [2.0]\ninner_falloff_px = [0.0]\n\
        outer_falloff_px = [0.0]\ninner_exponent = [1.0]\nouter_exponent = [1.0]\n";
    std::fs::write(dir.join("box.toml"), tessar + ghost).unwrap();
    dir.arg("box.toml")
}

#[test]
fn flare_predict_prints_walchs_estimators_for_a_light() {
    let dir = TestDir::new("flare-predict");
    let lens = lens_with_a_box_ghost(&dir);
    // 45 deg straight right (clamped to the fitted 30: the box at x 35..45, half out of the
    // frame: 30 px); one stop more ISO than measured: scale 2, so 2 x 2 / 3 = 4/3 on the mean
    // of the channels. Sum 40, average 40 / 800 = 0.05; log-average
    // exp((30 ln(1e-6 + 4/3) + 770 ln 1e-6) / 800); eq 9.3 with 100 and 1: 101 / 101.1.
    let run = realcam(
        &dir,
        s(&["flare-predict", "--lens", &lens, "--light", "1,0,-1", "--iso", "200", "--measured-iso", "100"])
            .into_iter()
            .chain(s(&["--scene-max", "100", "--scene-min", "1"])),
    )
    .success();
    assert_eq!(
        run.stdout,
        "constellation angle (eq 8.1): 45.0000 deg\nroll (eq 8.2): 0.0000 deg\nbrightness scale (eq 8.3): 2.000000\n\
         flare of 1 fitted ghosts on 40x20 px (sec. 9.1):\n  min 0.000000e0\n  max 1.333333e0\n  sum 4.000000e1\n  \
         average 5.000000e-2\n  log-average 1.697013e-6\ncontrast ratio K_real/K_ideal (eq 9.3): 0.999011\n"
    );
    // A lens without fitted ghosts, and a light at the camera, are named.
    let tessar = concat!(env!("CARGO_MANIFEST_DIR"), "/lenses/tessar-walch-lens.toml");
    let e = realcam(&dir, s(&["flare-predict", "--lens", tessar, "--light", "0,0,-1"])).failure();
    assert_contains(&e, "tessar-walch-lens.toml: the lens has no [[fitted_ghost]] section");
    let e = realcam(&dir, s(&["flare-predict", "--lens", &lens, "--light", "0,0,0"])).failure();
    assert_contains(&e, "the light is at the camera");
    let e = realcam(&dir, s(&["flare-predict", "--lens", &lens, "--light", "1,2"])).failure();
    assert_contains(&e, "--light takes three numbers X,Y,Z, not 2");
}

#[test]
fn flare_fit_writes_the_fitted_ghosts_into_a_new_lens_file_and_predict_reads_them() {
    // The tiny case: the Tessar's ghost 4/0 in green at f/2.8 on a 320x180 frame, 2..5 deg.
    let dir = TestDir::new("flare-fit");
    let tessar = concat!(env!("CARGO_MANIFEST_DIR"), "/lenses/tessar-walch-lens.toml");
    let before = std::fs::read_to_string(tessar).unwrap();
    let out = dir.arg("fitted.toml");
    let args = |out: &str| {
        s(&["flare-fit", "--lens", tessar, "--fstop", "2.8", "--sensor", "36x20.25", "--size", "320x180"])
            .into_iter()
            .chain(s(&["--angles", "2,3,4,5", "--rays", "24", "--cells", "16", "--channels", "1", "--ghosts", "4/0"]))
            .chain(s(&["--out", out]))
            .collect::<Vec<_>>()
    };
    let run = realcam(&dir, args(&out)).success();
    assert_contains(&run.stdout, "| 4/0 | 1 | 4 | ");
    let lens = realcam::io::lens_file::LensFile::load(Path::new(&out)).unwrap();
    assert_eq!(lens.fitted_ghosts.len(), 1);
    let g = &lens.fitted_ghosts[0];
    assert_eq!((g.ghost.as_str(), g.channel, g.frame_px, g.angles_deg), ("4/0", 1, [320, 180], [2.0, 5.0]));
    // The rest of the lens is the input's.
    let original = realcam::io::lens_file::LensFile::load(Path::new(tessar)).unwrap();
    assert_eq!(realcam::io::lens_file::LensFile { fitted_ghosts: Vec::new(), ..lens }, original);
    // The written file predicts; the input is never the output, and is left as it was.
    realcam(&dir, s(&["flare-predict", "--lens", &out, "--light", "0.05,0,-1"])).success();
    // The report compares the fitted primitives only on the frame they were fitted on.
    let e =
        realcam(&dir, s(&["flare", "--lens", &out, "--size", "640x360", "--out-dir", &dir.arg("report")])).failure();
    assert_contains(&e, "--size 640x360: fitted_ghost \"4/0\" of the lens is of a 320x180 frame");
    assert!(!dir.join("report").exists());
    let e = realcam(&dir, args(tessar)).failure();
    assert_contains(&e, "--out");
    assert_eq!(std::fs::read_to_string(tessar).unwrap(), before);
    let e = realcam(&dir, s(&["flare-fit", "--lens", tessar, "--out", &out, "--ghosts", "4-0"])).failure();
    assert_contains(&e, "--ghosts: \"4-0\" is not FIRST/SECOND (e.g. 4/0)");
}

#[test]
fn compare_measures_the_highlights_discs_and_names_a_bad_description() {
    // A 64x48 frame of scene A's camera (50 mm, 0.028125 mm pixels, focus 2 m): a point at 7.5 m
    // at f/2 has a disc of circumradius 8.15 px. The test image's disc is a hexagon 3% larger
    // in radius (6% in area) than the reference's, which the table reports.
    let dir = TestDir::new("compare-highlights");
    let (w, h, cx, cy) = (64u32, 48u32, 32.3, 24.4);
    let hexagon = |r: f64| {
        let mut im = rgba(w, h, [0.5, 0.5, 0.5]);
        for y in 0..h {
            for x in 0..w {
                let inside = (0..256)
                    .filter(|s| {
                        let (dx, dy) = (
                            x as f64 + (s % 16) as f64 / 16.0 + 1.0 / 32.0 - cx,
                            y as f64 + (s / 16) as f64 / 16.0 + 1.0 / 32.0 - cy,
                        );
                        (0..6).all(|k| {
                            let a = (60.0 * k as f64).to_radians();
                            dx * a.cos() + dy * a.sin() <= r * 0.75f64.sqrt()
                        })
                    })
                    .count();
                let v = 0.5 + 40.0 * inside as f32 / 256.0;
                let i = 4 * (y * w + x) as usize;
                im.data[i..i + 3].copy_from_slice(&[v, v, v]);
            }
        }
        im
    };
    write_exr_rgba(&dir.join("test.exr"), &hexagon(8.15 * 1.03), &float_opts()).unwrap();
    write_exr_rgba(&dir.join("reference.exr"), &hexagon(8.15), &float_opts()).unwrap();
    let camera = |depth: &str| {
        format!(
            r#"{{"camera": {{"focal_length_mm": 50, "pixel_pitch_mm": 0.028125, "resolution": [64, 48]}},
               "ground_truth": {{"dof": {{"focus_distance_m": 2.0}}}},
               "objects": [{{"name": "HL", "role": "highlight_background", "depth_m": {depth},
                             "pixel_xy_topleft_ydown": [32.3, 24.4]}}]}}"#
        )
    };
    std::fs::write(dir.join("camera.json"), camera("7.5")).unwrap();
    let args = |json: &str| s(&["compare", "test.exr", "reference.exr", "--highlights", json, "--fstop", "2"]);
    let run = realcam(&dir, args("camera.json")).success();
    assert_contains(&run.stdout, "rmse_matched");
    assert_contains(&run.stdout, "| HL | 7.50 | 8.15 | ");
    let ratio: f64 = run
        .stdout
        .lines()
        .find(|l| l.starts_with("| HL |"))
        .unwrap()
        .split('|')
        .nth(6)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!((ratio - 1.03f64.powi(2)).abs() < 0.005, "{}", run.stdout);
    assert_contains(&run.stdout, "f/2: areas within 2%: 0 of 1 measured");
    // A bad description: the file and the field, exit code 1.
    std::fs::write(dir.join("bad.json"), camera("\"far\"")).unwrap();
    let e = realcam(&dir, args("bad.json")).failure();
    assert_contains(&e, "bad.json\": field \"objects[0].depth_m\" must be a number, got a string");
    // --highlights needs the f-number.
    let run = realcam(&dir, s(&["compare", "test.exr", "reference.exr", "--highlights", "camera.json"]));
    assert_eq!(run.code, Some(2), "{}", run.describe());
    assert_contains(&run.stderr, "--fstop");
}

// ---------------------------------------------------------------------------------------------
// Issue 34: reliability, round 3
// ---------------------------------------------------------------------------------------------

/// The bytes of the files `names` of `dir`.
fn snapshot(dir: &TestDir, names: &[&str]) -> Vec<Vec<u8>> {
    names.iter().map(|n| std::fs::read(dir.join(n)).unwrap_or_else(|e| panic!("{n}: {e}"))).collect()
}

/// `args` with the value after `flag` replaced by `value`.
fn with_value(args: &[String], flag: &str, value: &str) -> Vec<String> {
    let mut args = args.to_vec();
    let at = args.iter().position(|a| a == flag).unwrap_or_else(|| panic!("no {flag} in {args:?}"));
    args[at + 1] = value.to_string();
    args
}

/// Issue 34, 1: a long exposure's outputs are checked against every frame it reads, not the
/// `####` pattern; a sequence's outputs of every frame against every frame's inputs.
#[test]
fn outputs_that_are_frames_of_the_run_are_refused_before_any_work() {
    let dir = TestDir::new("output_is_a_frame");
    let base = sequence_args(&dir);
    let frames = ["c.1002.exr", "d.1003.exr", "c.1001.exr"];
    let before = snapshot(&dir, &frames);
    let mut args = with_value(&base, "-o", &dir.arg("c.1002.exr"));
    args.extend(s(&["--frames", "1001-1003", "--long-exposure"]));
    let err = render(&dir, &args).failure();
    let c2 = dir.arg("c.1002.exr");
    assert_contains(
        &err,
        &format!("error: output \"{c2}\": it is the input color pass \"{c2}\"; realcam never writes over its inputs (--output)"),
    );
    assert!(!err.contains("frame 1001"), "work started:\n{err}");
    let mut args = with_value(&base, "-o", &dir.arg("exposure.exr"));
    args.extend(s(&["--frames", "1001-1003", "--long-exposure", "--png", &dir.arg("d.1003.exr")]));
    let d3 = dir.arg("d.1003.exr");
    assert_contains(
        &render(&dir, &args).failure(),
        &format!(
            "error: png \"{d3}\": it is the input depth pass \"{d3}\"; realcam never writes over its inputs (--png)"
        ),
    );
    // A sequence whose frame 1's output is frame 1001's colour pass.
    let mut args = with_value(&base, "-o", &dir.arg("c.100#.exr"));
    args.extend(s(&["--frames", "1,1001-1003"]));
    let c1 = dir.arg("c.1001.exr");
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: output \"{c1}\": it is the input color pass \"{c1}\""),
    );
    assert_eq!(snapshot(&dir, &frames), before);
    assert!(!dir.join("exposure.exr").exists());
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// Issue 34, 2: the OpenColorIO config (--config or $OCIO) is an input no output may replace.
#[test]
fn the_colour_config_is_an_input_no_output_may_replace() {
    let dir = TestDir::new("config_is_input");
    let base = small_scene(&dir);
    let config = dir.arg("cfg.ocio");
    std::fs::write(&config, b"ocio_profile_version: 2\n").unwrap();
    let mut args = with_value(&base, "-o", &config);
    args.extend(s(&["--config", &config]));
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: output \"{config}\": it is the input OpenColorIO config \"{config}\"; realcam never writes over its inputs (--output)"),
    );
    let mut args = base.clone();
    args.extend(s(&["--config", &config, "--png", &config]));
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: png \"{config}\": it is the input OpenColorIO config"),
    );
    let mut all = s(&["render", "--validate"]);
    all.extend(base.iter().cloned());
    all.extend(s(&["--trace", &config]));
    let err = realcam_env(&dir, all, &[("OCIO", &config)]).failure();
    assert_contains(
        &err,
        &format!("error: trace \"{config}\": it is the input OpenColorIO config of $OCIO \"{config}\""),
    );
    assert_eq!(std::fs::read(&config).unwrap(), b"ocio_profile_version: 2\n");
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "cfg.ocio"]);
}

/// Issue 34, 13: --state is neither an output nor a frame of the exposure.
#[test]
fn a_state_file_that_is_an_output_or_an_input_is_refused() {
    let dir = TestDir::new("state_is_output");
    let base = sequence_args(&dir);
    let out = dir.arg("exposure.exr");
    let mut args = with_value(&base, "-o", &out);
    args.extend(s(&["--frames", "1001-1003", "--long-exposure", "--state", &out]));
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: state \"{out}\": the output \"{out}\" is the same file (--state)"),
    );
    assert!(!dir.join("exposure.exr").exists());
    let c1 = dir.arg("c.1001.exr");
    let before = snapshot(&dir, &["c.1001.exr"]);
    let mut args = with_value(&base, "-o", &out);
    args.extend(s(&["--frames", "1001-1003", "--long-exposure", "--state", &c1]));
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: state \"{c1}\": it is the input color pass \"{c1}\""),
    );
    assert_eq!(snapshot(&dir, &["c.1001.exr"]), before);
    assert!(!dir.join("exposure.exr").exists());
}

/// Issue 34, 9: --skip-existing keeps only outputs that read back whole; an empty or truncated
/// EXR is rendered again (and said), a folder in an output's place fails that frame by name.
#[test]
fn skip_existing_renders_incomplete_outputs_again() {
    let dir = TestDir::new("skip_incomplete");
    let mut args = sequence_args(&dir);
    args.extend(s(&["--frames", "1001-1004", "--skip-existing"]));
    render(&dir, &with_value(&args, "--frames", "1001")).success();
    let whole = std::fs::read(dir.join("o.1001.exr")).unwrap();
    std::fs::write(dir.join("o.1002.exr"), b"").unwrap();
    std::fs::write(dir.join("o.1003.exr"), &whole[..whole.len() / 2]).unwrap();
    std::fs::create_dir(dir.join("o.1004.exr")).unwrap();
    let run = render(&dir, &args);
    let err = run.failure();
    assert_contains(&err, &format!("frame 1001: skipped, {} exists", dir.arg("o.1001.exr")));
    assert_contains(
        &err,
        &format!(
            "frame 1002: {} is not a complete output, it is empty (0 bytes); rendering it again",
            dir.arg("o.1002.exr")
        ),
    );
    assert_contains(
        &err,
        &format!("frame 1003: {} is not a complete output, it does not read back whole", dir.arg("o.1003.exr")),
    );
    assert_contains(&err, &format!("frame 1004: {} is not a complete output, it is a folder", dir.arg("o.1004.exr")));
    assert_contains(&err, "frames: 2 done, 1 skipped, 1 failed of 4 in ");
    assert_contains(&err, "1 of 4 frames failed: 1004");
    for frame in [1002, 1003] {
        let image = read_exr_rgba(&dir.join(&format!("o.{frame}.exr"))).unwrap();
        assert_eq!((image.width, image.height), (24, 16));
    }
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// Issue 34, 10: an output name of 236-255 bytes is written (its temporary's name is cut short
/// to fit the 255-byte limit, in the same folder) and leaves no temporary.
#[test]
fn output_names_up_to_255_bytes_are_written() {
    let dir = TestDir::new("long_name");
    let base = small_scene(&dir);
    let name = format!("{}.exr", "o".repeat(251));
    assert_eq!(name.len(), 255);
    let png = format!("{}.png", "p".repeat(236));
    let mut args = with_value(&base, "-o", &dir.arg(&name));
    args.extend(s(&["--png", &dir.arg(&png)]));
    render(&dir, &args).success();
    assert_eq!(read_exr_rgba(&dir.join(&name)).unwrap().width, 16);
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", &name, &png]);
}

/// Issue 34, 12: a state file with sums that are not finite, a frame listed more than once, an
/// empty size or one whose values overflow is refused, the file and the line named.
#[test]
fn a_state_file_is_validated_before_it_is_resumed() {
    let dir = TestDir::new("state_validated");
    let mut args = with_value(&sequence_args(&dir), "-o", &dir.arg("exposure.exr"));
    let state = dir.arg("exposure.state");
    args.extend(s(&["--frames", "1001-1003", "--long-exposure", "--state", &state]));
    let sums = |first: f64| {
        let mut v = first.to_le_bytes().to_vec();
        v.extend(vec![0u8; (24 * 16 * 4 - 1) * 8]);
        v
    };
    let header = |size: &str, frames: &str| format!("realcam-long-exposure 1\n{size}\n{frames}\n").into_bytes();
    let cases: Vec<(Vec<u8>, &str)> = vec![
        ([header("24 16 4", "1001"), sums(f64::NAN)].concat(), "the sum of pixel (0, 0) channel 0 is NaN"),
        ([header("24 16 4", "1001"), sums(f64::INFINITY)].concat(), "the sum of pixel (0, 0) channel 0 is inf"),
        ([header("24 16 4", "1001"), sums(1e300)].concat(), "the sum of pixel (0, 0) channel 0 is 1e300"),
        ([header("24 16 4", "1001,1002,1001"), sums(1.0)].concat(), "the frames line lists frame 1001 more than once"),
        (header("0 0 0", "1001"), "the size line \"0 0 0\" is an empty image, but the frames line lists 1 frame(s)"),
        (
            header("4294967295 4294967295 4294967295", "1001"),
            "the size line \"4294967295 4294967295 4294967295\" holds more values than memory can",
        ),
    ];
    for (bytes, reason) in cases {
        std::fs::write(&state, &bytes).unwrap();
        let err = render(&dir, &args).failure();
        assert_contains(&err, &format!("error: --state \"{state}\": not a long-exposure state of realcam: {reason}"));
        assert_eq!(std::fs::read(&state).unwrap(), bytes);
        assert!(!dir.join("exposure.exr").exists());
    }
}

/// Issue 34, 6: a 4x4 patch of 1e37 (finite) with the flare on and no exposure gives a finite
/// frame: the flare's sums no longer overflow into Inf and then NaN.
#[test]
fn a_finite_highlight_gives_a_finite_frame_through_the_flare() {
    let dir = TestDir::new("flare_huge_patch");
    let (w, h) = (64u32, 48u32);
    let mut color = rgba(w, h, [0.2, 0.3, 0.4]);
    for y in 20..24 {
        for x in 30..34 {
            for c in 0..3 {
                color.set(x, y, c, 1e37);
            }
        }
    }
    write_exr_rgba(&dir.join("c.exr"), &color, &float_opts()).unwrap();
    write_depth(&dir.join("d.exr"), w, h, &vec![3.0; (w * h) as usize]);
    let args = s(&["--color", &dir.arg("c.exr"), "--depth", &dir.arg("d.exr"), "-o", &dir.arg("o.exr")]);
    let mut args = args;
    args.extend(s(&["--flare", "--no-exposure", "--float", "--film", "linear"]));
    render(&dir, &args).success();
    let out = read_exr_rgba(&dir.join("o.exr")).unwrap();
    let bad = out.data.iter().filter(|v| !v.is_finite()).count();
    assert_eq!(bad, 0, "{bad} of {} values are not finite", out.data.len());
    // The light is still there, and a flare around it.
    assert!(out.get(31, 21, 0) > 1e30, "{}", out.get(31, 21, 0));
}

/// Issue 34, 7: exposure settings whose gain (or grain whose spread) overflows are refused
/// before any work, the flag and the bound named, instead of writing +Inf everywhere.
#[test]
fn exposure_settings_that_overflow_are_refused_with_the_flag_and_the_bound() {
    let dir = TestDir::new("exposure_overflow");
    let base = small_scene(&dir);
    let cases: [(&[&str], &str, &str); 5] = [
        (
            &["--iso", "1e300"],
            "error: ISO 1e300 makes the exposure's gain (scene value to sensor value) ",
            "at most ISO ",
        ),
        (&["--shutter", "1e308"], "error: shutter time 1e308 s makes the exposure's gain ", "at most shutter time "),
        (
            &["--nits-per-unit", "1e308"],
            "error: nits per unit 1e308 makes the exposure's gain ",
            "at most nits per unit ",
        ),
        (&["--fstop", "1e-308", "--force"], "error: f/1e-308 makes the exposure's gain ", "at least f/"),
        (
            &["--grain", "1e308"],
            "error: grain 1e308 makes the grain's spread at sensor value 1 1e308, more than 1e30",
            "at most grain ",
        ),
    ];
    let flags = ["(--iso)", "(--shutter)", "(--nits-per-unit)", "(--fstop)", "(--grain)"];
    for ((extra, start, bound), flag) in cases.into_iter().zip(flags) {
        let mut args = base.clone();
        args.extend(s(extra));
        let err = render(&dir, &args).failure();
        assert_contains(&err, start);
        assert_contains(
            &err,
            &format!("the output cannot be finite; with the other settings as they are, it must be {bound}"),
        );
        assert_contains(&err, flag);
    }
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr"]);
}

/// Issue 34, 3 and 4: a flare-lights file of 30,000 nested lists and an OpenColorIO config
/// whose aliases expand a billion-fold are refused with the file named: no stack overflow, no
/// unbounded memory, no temporary left.
#[test]
fn deeply_nested_lights_and_alias_bombs_are_refused() {
    let dir = TestDir::new("nesting_bombs");
    let base = small_scene(&dir);
    let lights = dir.arg("lights.json");
    std::fs::write(&lights, format!("{}{}", "[".repeat(30_000), "]".repeat(30_000))).unwrap();
    let mut args = base.clone();
    args.extend(s(&["--flare-lights", &lights]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!("error: flare lights {lights}, line 1: lists and objects nested more than 64 deep (a list of lights needs 3)"),
    );
    let config = dir.arg("bomb.ocio");
    let mut yaml = String::from("ocio_profile_version: 2\nl0: &l0 [x, x, x, x, x, x, x, x, x, x]\n");
    for i in 1..10 {
        yaml += &format!("l{i}: &l{i} [{}]\n", vec![format!("*l{}", i - 1); 10].join(", "));
    }
    std::fs::write(&config, &yaml).unwrap();
    let mut args = base.clone();
    args.extend(s(&["--config", &config, "--colorspace", "ACEScg"]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!(
            "OpenColorIO config \"{config}\": cannot read it: its YAML holds more than 10000000 nodes with its aliases \
             expanded (nested aliases, a \"billion laughs\")"
        ),
    );
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "lights.json", "bomb.ocio"]);
}

/// Issue 34, 15: messages that said the wrong thing: a thin aperture image is not "empty", an
/// output path ending in "/" is refused before the render, a seed out of range says the range.
#[test]
fn thin_apertures_folder_paths_and_big_seeds_are_named_exactly() {
    let dir = TestDir::new("misleading_messages");
    let base = small_scene(&dir);
    let iris = dir.arg("iris.png");
    realcam::io::png::write_png(Path::new(&iris), &rgba(1000, 1, [1.0; 3])).unwrap();
    let mut args = base.clone();
    args.extend(s(&["--aperture-image", &iris]));
    let err = render(&dir, &args).failure();
    assert_contains(
        &err,
        &format!("error: aperture image {iris}: its open part (values above 0) is too thin or small to show in the 64x64 mask made of its 1000x1 px"),
    );
    assert!(!err.contains("empty"), "{err}");
    std::fs::create_dir(dir.join("out")).unwrap();
    let folder = format!("{}/new.exr/", dir.arg("out"));
    let err = render(&dir, &with_value(&base, "-o", &folder)).failure();
    assert_contains(
        &err,
        &format!("error: output \"{folder}\": the path ends with \"/\": it names a folder, not a file (--output)"),
    );
    assert!(!err.contains("device:"), "the GPU was opened before the output was checked:\n{err}");
    let mut args = base.clone();
    args.extend(s(&["--seed", "18446744073709551615"]));
    let run = render(&dir, &args);
    assert_ne!(run.code, Some(0), "{}", run.describe());
    assert_contains(&run.stderr, "the seed is a whole number from 0 to 4294967295");
    assert_listing(&dir, &["scene_color.exr", "scene_depth.exr", "iris.png", "out"]);
}

/// Issue 34, 15: a finite lens-file value beyond any lens (1e308) is refused naming the file and
/// the key, not later by the optics without the file.
#[test]
fn huge_lens_file_values_name_the_file() {
    let dir = TestDir::new("lens_1e308");
    let mut args = small_scene(&dir);
    let lens = dir.arg("lens.toml");
    let aperture = "[aperture]\nblades = 9\n";
    std::fs::write(&lens, VALID_LENS.replace("focal_length_mm = 50", "focal_length_mm = 1e308") + aperture).unwrap();
    args.extend(s(&["--lens", &lens]));
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: lens file {lens}: focal_length_mm = 1e308 must be at most 1000000 (1 km)"),
    );
    std::fs::write(&lens, VALID_LENS.replace("focus_min_m = 0.45", "focus_min_m = 1e308") + aperture).unwrap();
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: lens file {lens}: focus_min_m = 1e308 must be at most 1000000 (1000 km)"),
    );
}

/// Issue 34, 11: a sequence pattern with bytes that are not UTF-8 reads and writes those very
/// bytes (no U+FFFD in their place).
#[test]
fn patterns_that_are_not_utf8_keep_their_bytes() {
    use std::os::unix::ffi::OsStrExt;
    let dir = TestDir::new("non_utf8_pattern");
    let args = sequence_args(&dir);
    let raw =
        |prefix: &[u8], rest: &str| dir.path.join(std::ffi::OsStr::from_bytes(&[prefix, rest.as_bytes()].concat()));
    for frame in [1001, 1002] {
        std::fs::copy(dir.join(&format!("c.{frame}.exr")), raw(b"c\xfe.", &format!("{frame}.exr"))).unwrap();
    }
    let mut all: Vec<std::ffi::OsString> = s(&["render", "--validate"]).into_iter().map(Into::into).collect();
    all.extend(args.into_iter().map(std::ffi::OsString::from));
    let at = all.iter().position(|a| a == "--color").unwrap();
    all[at + 1] = raw(b"c\xfe.", "####.exr").into_os_string();
    let at = all.iter().position(|a| a == "-o").unwrap();
    all[at + 1] = raw(b"q\xfe.", "####.exr").into_os_string();
    all.extend(["--frames", "1001-1002"].map(std::ffi::OsString::from));
    realcam(&dir, all).success();
    for frame in [1001, 1002] {
        let written = raw(b"q\xfe.", &format!("{frame}.exr"));
        assert!(written.is_file(), "{} was not written", written.display());
        assert!(!raw("q\u{fffd}.".as_bytes(), &format!("{frame}.exr")).exists(), "the byte became U+FFFD");
    }
}

/// Issue 34, 2: a LUT an OpenColorIO config names (a file transform's `src` along its
/// `search_path`) is an input too.
#[test]
fn a_lut_the_colour_config_names_is_an_input_too() {
    let dir = TestDir::new("config_lut_is_input");
    let base = small_scene(&dir);
    let config = dir.arg("cfg.ocio");
    std::fs::write(
        &config,
        "ocio_profile_version: 2\nsearch_path: luts\ncolorspaces:\n  - !<ColorSpace>\n    name: log\n    \
         to_scene_reference: !<FileTransform> {src: curve.spi1d, interpolation: linear}\n",
    )
    .unwrap();
    std::fs::create_dir(dir.join("luts")).unwrap();
    let lut = dir.arg("luts/curve.spi1d");
    std::fs::write(&lut, b"Version 1\n").unwrap();
    let mut args = base.clone();
    args.extend(s(&["--config", &config, "--png", &lut]));
    assert_contains(
        &render(&dir, &args).failure(),
        &format!("error: png \"{lut}\": it is the input LUT of the OpenColorIO config \"{lut}\"; realcam never writes over its inputs (--png)"),
    );
    assert_eq!(std::fs::read(&lut).unwrap(), b"Version 1\n");
}

/// Issue 34, 14: a range of a million frames keeps nothing per frame ahead of the reader (it
/// took 672 MB before the first frame, 1.3 GB with more passes): under a 150 MB data limit
/// the first missing frame is named and --fail-fast stops there; a list of failed frames in
/// the last message is cut at 20.
#[test]
fn a_million_frame_range_fits_a_small_memory_limit_and_names_the_first_missing_frame() {
    let dir = TestDir::new("million_frames");
    let bin = env!("CARGO_BIN_EXE_realcam");
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -d 150000 && exec {bin} render --color c.####.exr -o o.####.exr --frames 1-1000000 --fail-fast"
        ))
        .current_dir(&dir.path)
        .env("REALCAM_CACHE_DIR", &dir.cache)
        .env_remove("OCIO")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_contains(&err, "error: frame 1: color: file \"c.0001.exr\" does not exist");
    assert_contains(&err, "frames: 0 done, 0 skipped, 1 failed, 999999 not run (--fail-fast) of 1000000");
    assert_contains(&err, "error: 1 of 1000000 frames failed: 1\n");
    let err = realcam(&dir, s(&["render", "--color", "c.####.exr", "-o", "o.####.exr", "--frames", "1-25"])).failure();
    let listed: Vec<String> = (1..=20).map(|f| f.to_string()).collect();
    assert_contains(&err, &format!("error: 25 of 25 frames failed: {} and 5 more\n", listed.join(", ")));
}
