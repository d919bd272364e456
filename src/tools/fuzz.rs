//! Entry points for fuzzing: the cargo-fuzz targets in `fuzz/` (nightly) and the seeded
//! mutation test `tests/fuzz_mutations.rs` (stable, in CI) call the same functions (the
//! sequence, state, OpenColorIO and flare-lights ones only the latter, so far). Each takes
//! arbitrary bytes and runs a reader or parser as realcam runs it. Refusing the input with an
//! error is fine; what is not ([`Violation`]) is a successful result with NaN or Inf where
//! realcam promises finite numbers. Panics, aborts and allocations beyond [`BUDGET`] are the
//! harness's to catch.

use crate::io::lens_analysis::analyze_text;
use crate::io::lens_file::LensFile;
use crate::io::{load_passes, DepthKind, MemoryBudget, PassSources};
use crate::model::camera::{Camera, CameraRequest, FilmMode};
use crate::model::frame::Frame;
use std::path::{Path, PathBuf};

/// What the entry points may read: one million pixels, 256 MB.
pub const BUDGET: MemoryBudget = MemoryBudget { max_pixels: Some(1 << 20), max_bytes: 256 << 20 };

/// A successful result that breaks a promise, in words.
pub type Violation = String;

/// How an input ended, when it broke no promise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Refused with an error.
    Refused,
    /// Accepted, and every promised number finite.
    Accepted,
}

use Outcome::{Accepted, Refused};

/// Fails with `what` unless every value is finite.
fn finite(what: &str, values: impl IntoIterator<Item = f64>) -> Result<(), Violation> {
    match values.into_iter().find(|v| !v.is_finite()) {
        Some(v) => Err(format!("{what} is {v}")),
        None => Ok(()),
    }
}

/// A scratch file for this thread, for the readers that take a path.
fn scratch_path(extension: &str) -> PathBuf {
    let thread = format!("{:?}", std::thread::current().id()).replace(|c: char| !c.is_ascii_alphanumeric(), "");
    std::env::temp_dir().join(format!("realcam-fuzz-{}-{thread}.{extension}", std::process::id()))
}

/// The camera the entry points plan with: `lens` at f/2 focused at 2 m (forced); None when
/// no camera takes that (a lens longer than 2 m), which is an error, not a violation.
fn camera(lens: &LensFile) -> Option<Camera> {
    let request = CameraRequest { force: true, ..CameraRequest::default().with_lens(lens.focal_length_mm, 2.0, 2.0) };
    Camera::new(lens, &request).ok()
}

/// Plans `frame`; the plan's facts and every pass's reason must be free of NaN.
fn check_plan(frame: &Frame, camera: &Camera) -> Result<Outcome, Violation> {
    let plan = crate::pipeline::planner::plan(frame, camera);
    let f = &plan.facts;
    finite("the pixel pitch", [f.pixel_pitch_mm])?;
    finite("the CoC range", [f.coc_range_px.0, f.coc_range_px.1, f.max_coc_px])?;
    let explain = plan.explain();
    if explain.split(|c: char| !c.is_ascii_alphanumeric()).any(|word| word == "NaN") {
        return Err(format!("the plan says NaN:\n{explain}"));
    }
    Ok(Accepted)
}

/// An EXR file as the colour (and depth and velocity) passes of a render: loaded within
/// [`BUDGET`], made a frame and planned. Colour and velocity must be finite, depth neither NaN
/// nor negative (+inf is the sky), the plan's CoC range finite.
pub fn exr_passes(bytes: &[u8]) -> Result<Outcome, Violation> {
    let path = scratch_path("exr");
    std::fs::write(&path, bytes).map_err(|e| format!("cannot write the scratch file: {e}"))?;
    let result = exr_passes_at(&path);
    let _ = std::fs::remove_file(&path);
    result
}

fn exr_passes_at(path: &Path) -> Result<Outcome, Violation> {
    let _ = crate::io::read_exr_rgba_within(path, &BUDGET);
    let sources = PassSources { budget: BUDGET, ..PassSources::new(path) };
    let Ok(passes) = load_passes(&sources) else { return Ok(Refused) };
    finite("a colour value", passes.color.data.iter().map(|&v| v as f64))?;
    if let Some(v) = &passes.velocity_px {
        finite("a velocity value", v.data.iter().map(|&v| v as f64))?;
    }
    if let Some(d) = passes.depth_m.data.iter().find(|d| d.is_nan() || **d < 0.0) {
        return Err(format!("a depth of {d} m was accepted"));
    }
    let lens = LensFile::default_lens();
    let Some(camera) = camera(&lens) else { return Err("the default camera is refused".into()) };
    let frame = Frame::from_passes(passes, &camera, DepthKind::Planar);
    if frame.display_size().0 == 0 || frame.display_size().1 == 0 {
        return Err(format!("an empty display window was accepted: {:?}", frame.display_window));
    }
    check_plan(&frame, &camera)
}

/// A small frame for planning a lens: a ramp of depths from 0.3 m to the sky.
fn lens_frame() -> Frame {
    let (w, h) = (8, 6);
    let depth_m = (0..w * h).map(|i| if i == 0 { 1.0e10 } else { 0.3 + i as f32 * 0.1 }).collect();
    Frame::new(w, h, vec![0.5; (w * h * 4) as usize], depth_m)
}

/// A lens file: parsed, made a camera at f/2 (forced) and planned on a small frame. Every
/// number of the camera must be finite, and the plan free of NaN.
pub fn lens_file(bytes: &[u8]) -> Result<Outcome, Violation> {
    let Ok(text) = std::str::from_utf8(bytes) else { return Ok(Refused) };
    let Ok(lens) = LensFile::parse(text, Path::new("fuzz.toml")) else { return Ok(Refused) };
    let Some(camera) = camera(&lens) else { return Ok(Refused) };
    let l = &camera.lens;
    finite("the thin lens", [l.focal_length_mm, l.f_number, l.focus_distance_mm, l.image_distance_mm()])?;
    finite("the exposure gain", [camera.exposure_gain()])?;
    let a = &camera.aperture;
    finite("the aperture", [a.rotation_deg, a.curvature, a.spherical_aberration, a.cats_eye])?;
    finite("the aperture's LSA", a.lsa_rim_mm)?;
    let tables = [
        camera.field_curvature.as_ref(),
        camera.relative_illumination.as_ref(),
        camera.coma.as_ref(),
        camera.astigmatism.as_ref().map(|t| &t.0),
        camera.astigmatism.as_ref().map(|t| &t.1),
        camera.distortion.as_ref().map(|d| &d.green_percent),
    ];
    for t in tables.into_iter().flatten() {
        finite("a table value", t.values.iter().chain(&t.image_height_mm).copied())?;
    }
    finite("the longitudinal colour", camera.longitudinal_color_mm.into_iter().flatten())?;
    check_plan(&lens_frame(), &camera)
}

/// A film file: parsed, and its curve applied from black to far beyond saturation: every
/// output finite and not negative.
pub fn film_file(bytes: &[u8]) -> Result<Outcome, Violation> {
    let Ok(text) = std::str::from_utf8(bytes) else { return Ok(Refused) };
    let Ok(film) = crate::io::film_file::FilmFile::parse(text, Path::new("fuzz.toml")) else { return Ok(Refused) };
    let apply = |x: f64| match FilmMode::from_file(&film) {
        FilmMode::Curve(c) => c.apply(x),
        FilmMode::Table(t) => t.apply(x),
        FilmMode::Linear => x,
    };
    for x in [0.0, 1e-30, 1e-6, 0.01, 0.128, 0.5, 1.0, 10.0, 1e6, 1e30] {
        let y = apply(x);
        if !(y.is_finite() && y >= 0.0) {
            return Err(format!("the film gives {y} for a sensor value of {x}"));
        }
    }
    Ok(Accepted)
}

/// A prescription or a lens file with `[[surface]]`s: analysed as `realcam lens analyze` does
/// (f-number of the file, fields 0 to 20 degrees) and, when that succeeds, made a lens file with
/// the traced tables. The report must print no NaN or inf, and the EFL be finite.
pub fn prescription(bytes: &[u8]) -> Result<Outcome, Violation> {
    let Ok(text) = std::str::from_utf8(bytes) else { return Ok(Refused) };
    let Ok(report) = analyze_text(text.to_string(), Path::new("fuzz.toml"), None, &[0.0, 10.0, 20.0]) else {
        return Ok(Refused);
    };
    finite("the EFL", [report.analysis.paraxial.efl_mm])?;
    let printed = report.analysis.to_string();
    // The lens's name is the file's own text (a mutation may write "inf" into it): not checked.
    let numbers = printed.lines().filter(|l| !l.starts_with("Lens: ")).collect::<Vec<_>>().join("\n");
    if numbers.split(|c: char| !c.is_ascii_alphanumeric()).any(|word| word == "NaN" || word == "inf") {
        return Err(format!("the report prints NaN or inf:\n{printed}"));
    }
    if let Ok(derived) = report.lens_file_with_tables(Path::new("derived.toml")) {
        lens_file(derived.as_bytes())?;
    }
    Ok(Accepted)
}

/// A sequence: the first line a path pattern (any bytes), the rest a frame range. The pattern's
/// path of a frame must be its prefix, the number and its suffix; the range must hold at most
/// [`MAX_FRAMES`](crate::io::sequence::MAX_FRAMES) frames, none twice, and split into chunks.
pub fn sequence(bytes: &[u8]) -> Result<Outcome, Violation> {
    use crate::io::sequence::{FramePattern, FrameRange, MAX_FRAMES};
    use std::os::unix::ffi::OsStrExt;
    let (text, range) = match bytes.iter().position(|&b| b == b'\n') {
        Some(at) => (&bytes[..at], &bytes[at + 1..]),
        None => (bytes, &b""[..]),
    };
    let pattern = FramePattern::parse(Path::new(std::ffi::OsStr::from_bytes(text)));
    let Ok(range) = FrameRange::parse(&String::from_utf8_lossy(range)) else { return Ok(Refused) };
    if range.frames.len() > MAX_FRAMES {
        return Err(format!("a range of {} frames was accepted", range.frames.len()));
    }
    let mut sorted = range.frames.clone();
    sorted.sort_unstable();
    if let Some(pair) = sorted.windows(2).find(|p| p[0] == p[1]) {
        return Err(format!("frame {} was accepted twice", pair[0]));
    }
    let chunked: usize = (0..range.frames.len().div_ceil(1000) as u64)
        .map(|i| range.chunk(i, 1000).map(|c| c.frames.len()).unwrap_or(0))
        .sum();
    if chunked != range.frames.len() {
        return Err(format!("chunks of 1000 hold {chunked} of the {} frames", range.frames.len()));
    }
    let Ok(Some(pattern)) = pattern else { return Ok(Refused) };
    for &frame in range.frames.iter().take(100).chain(&[i64::MIN, i64::MAX]) {
        let path = pattern.path(frame);
        let bytes = path.as_os_str().as_bytes();
        // Its digits (a negative frame's sign may come before padding zeros: -004).
        let number = frame.unsigned_abs().to_string();
        // The token (at least one byte) becomes the number, padded to at most 20 bytes.
        let longest = text.len() + (number.len() + 1).max(20);
        if bytes.len() > longest || !bytes.windows(number.len()).any(|w| w == number.as_bytes()) {
            return Err(format!("frame {frame} has the path {}", path.display()));
        }
    }
    Ok(Accepted)
}

/// A long exposure's `--state` file: read, and its exposure (the average of its frames) every
/// value finite; written again, it reads back the same.
pub fn state_file(bytes: &[u8]) -> Result<Outcome, Violation> {
    use crate::model::long_exposure::LongExposure;
    let Ok(exposure) = LongExposure::from_bytes(bytes) else { return Ok(Refused) };
    if let Ok(image) = exposure.image() {
        finite("an exposure value", image.data.iter().map(|&v| f64::from(v)))?;
    }
    let again = LongExposure::from_bytes(&exposure.to_bytes()).map_err(|e| format!("written again: {e}"))?;
    if again.done() != exposure.done() || again.settings() != exposure.settings() {
        return Err("the state reads back otherwise".into());
    }
    Ok(Accepted)
}

/// An OpenColorIO config: the LUTs it names found, loaded as `--config` loads it, its first
/// colour space made the working space (primaries finite) and its default display and view
/// made a processor.
pub fn ocio_config(bytes: &[u8]) -> Result<Outcome, Violation> {
    let path = scratch_path("ocio");
    std::fs::write(&path, bytes).map_err(|e| format!("cannot write the scratch file: {e}"))?;
    let result = ocio_config_at(&path);
    let _ = std::fs::remove_file(&path);
    result
}

fn ocio_config_at(path: &Path) -> Result<Outcome, Violation> {
    use crate::io::colour_config::ColourConfig;
    let _ = crate::io::colour_config::config_lut_files(path);
    let Ok(config) = ColourConfig::load(&path.to_string_lossy()) else { return Ok(Refused) };
    if config.config.num_color_spaces() == 0 {
        return Ok(Refused);
    }
    let space = config.config.color_space_name_by_index(0).to_string();
    let Ok((_, c)) = config.working_space(&space) else { return Ok(Refused) };
    finite("a primary", c.red.into_iter().chain(c.green).chain(c.blue).chain(c.white))?;
    let _ = config.display_view(&space, None, None);
    Ok(Accepted)
}

/// A `--flare-lights` file: read; every light's position, energy and area finite, energy and
/// area not negative.
pub fn flare_lights(bytes: &[u8]) -> Result<Outcome, Violation> {
    let Ok(text) = std::str::from_utf8(bytes) else { return Ok(Refused) };
    let Ok(lights) = crate::io::flare_lights::parse_flare_lights(text, Path::new("fuzz.json")) else {
        return Ok(Refused);
    };
    for l in &lights {
        finite("a light", [l.x_px, l.y_px, l.area_px].into_iter().chain(l.energy))?;
        if l.area_px < 0.0 || l.energy.iter().any(|&e| e < 0.0) {
            return Err(format!("a light of energy {:?} and area {} was accepted", l.energy, l.area_px));
        }
    }
    Ok(Accepted)
}
