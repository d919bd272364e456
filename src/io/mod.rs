//! Files in and out: OpenEXR passes, PNG previews, lens files, film files, lensfun's database.
//!
//! - [`exr_read`]: loads the color, depth and velocity passes of a rendered frame
//!   ([`load_passes`]), discovering the channel names that Blender, Nuke and other
//!   renderers write; see the table at the top of that file.
//! - [`exr_write`]: writes RGBA or arbitrary channels as half or float32 EXR.
//! - [`png`]: writes an 8-bit sRGB preview.
//! - [`lens_file`], [`film_file`]: realcam's TOML lens and film files, every field checked.
//! - [`flare_lights`]: explicit lights for the lens flare, as a JSON list a renderer can write.
//! - [`lens_analysis`]: a lens file's or a prescription's trace, and the lens file its tables make.
//! - [`lensfun`]: lenses of the lensfun database converted into lens files.
//!
//! - [`output`]: every file realcam writes goes through a temporary beside its target, renamed
//!   onto it only after a complete write of every output of the run, so a failed or interrupted
//!   run never touches an existing file; targets that are not regular files, or are inputs, are
//!   refused before any work.

pub mod camera_file;
pub mod colour_config;
pub mod exr_read;
pub mod exr_write;
mod exr_zip;
pub mod film_file;
pub mod flare_lights;
pub mod lens_analysis;
pub mod lens_file;
pub mod lensfun;
pub mod output;
pub mod png;
pub mod sequence;
pub mod usd_camera;

pub use exr_read::STRUCTURAL_ATTRIBUTES;
pub use exr_read::{
    describes_channels, load_passes, read_exr_channel, read_exr_rgba, read_exr_rgba_within, velocity_likely,
};
pub use exr_write::{
    encode_exr_channels, encode_exr_planes, encode_exr_rgba, rgba_planes, write_exr_channels, write_exr_planes_to_file,
    write_exr_rgba, ExrAttribute, ExrCompression, ExrWriteOptions,
};
pub use png::{encode_png, write_png};

use std::path::{Path, PathBuf};

/// Every failure of this module. Each names the file involved and, where relevant, the
/// channel.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    #[error("{what}: file \"{}\" does not exist", .path.display())]
    NotFound { what: String, path: PathBuf },
    #[error("{what}: cannot read \"{}\": {source}", .path.display())]
    Read { what: String, path: PathBuf, source: std::io::Error },
    #[error("{what}: \"{}\" is not an OpenEXR file (it does not start with the EXR magic number)", .path.display())]
    NotExr { what: String, path: PathBuf },
    #[error("{what}: cannot decode OpenEXR file \"{}\": {source}", .path.display())]
    Exr { what: String, path: PathBuf, source: exr::error::Error },
    #[error("{what}: channel {channel} in \"{}\" is not supported: {reason}", .path.display())]
    Unsupported { what: String, path: PathBuf, channel: String, reason: String },
    #[error("{what}: no {what} channel in \"{}\" (looked for {looked_for}); channels found: {found}", .path.display())]
    MissingChannel { what: String, path: PathBuf, looked_for: String, found: String },
    #[error("{what}: several layers in \"{}\" could be the {what} ({candidates}); choose one with an explicit channel override", .path.display())]
    AmbiguousChannels { what: String, path: PathBuf, candidates: String },
    #[error("{what}: channel \"{missing}\" (from the override \"{requested}\") not found in \"{}\"; channels found: {found}", .path.display())]
    OverrideNotFound { what: String, path: PathBuf, requested: String, missing: String, found: String },
    #[error("{what}: invalid channel override \"{requested}\": {reason}")]
    BadOverride { what: String, requested: String, reason: String },
    #[error("size mismatch: {a} \"{}\" is {}x{} px but {b} \"{}\" is {}x{} px (the data windows must have the same size)",
        .a_path.display(), .a_size.0, .a_size.1, .b_path.display(), .b_size.0, .b_size.1)]
    SizeMismatch { a: String, a_path: PathBuf, a_size: (u32, u32), b: String, b_path: PathBuf, b_size: (u32, u32) },
    #[error("depth: channel {channel} in \"{}\" has {count} invalid pixel(s) (NaN or negative depth); the first is pixel (x={x}, y={y}) of the data window with {value_m} m", .path.display())]
    InvalidDepth { path: PathBuf, channel: String, x: usize, y: usize, value_m: f32, count: u64 },
    /// A setting of [`PassSources`] out of range, by its field name.
    #[error("{field} must be {allowed}, got {value}")]
    InvalidArgument { field: &'static str, value: f64, allowed: &'static str },
    /// A setting of [`PassSources`] that the file needs but nobody gave, by its field name.
    #[error("velocity: \"{}\" {why}; give {field}", .path.display())]
    MissingSetting { field: &'static str, path: PathBuf, why: String },
    #[error("cannot write \"{}\": the image has {got} channel(s) per pixel, expected {expected}", .path.display())]
    WrongChannelCount { path: PathBuf, expected: String, got: u32 },
    #[error("cannot write \"{}\": channel {channel} holds {got} values, expected {expected} (width x height x channels)", .path.display())]
    DataLength { path: PathBuf, channel: String, expected: usize, got: usize },
    #[error("cannot write \"{}\": {reason}", .path.display())]
    InvalidImage { path: PathBuf, reason: String },
    #[error("{what}: \"{}\": its {attribute} attribute is unusable: {reason}", .path.display())]
    BadAttribute { what: String, path: PathBuf, attribute: &'static str, reason: String },
    #[error("cannot encode OpenEXR file \"{}\": {source}", .path.display())]
    ExrEncode { path: PathBuf, source: exr::error::Error },
    #[error("cannot encode PNG file \"{}\": {source}", .path.display())]
    PngEncode { path: PathBuf, source: image::ImageError },
    #[error("cannot write \"{}\": {source}", .path.display())]
    Write { path: PathBuf, source: std::io::Error },
    /// The view layer asked for is not in the file, or two would be mixed.
    #[error("layer: \"{}\": {reason}", .path.display())]
    Layer { path: PathBuf, reason: String },
    /// An image larger than the memory budget, refused before anything of its size is allocated.
    #[error("{what}: \"{}\" declares a {width}x{height} px image{reason}", .path.display())]
    TooLarge { what: String, path: PathBuf, width: u64, height: u64, reason: String, field: Option<&'static str> },
    /// An output path refused before any work (see [`output::Outputs::new`]), by the field
    /// that named it.
    #[error("{field} \"{}\": {reason}", .path.display())]
    Output { field: &'static str, path: PathBuf, reason: String },
}

/// Interleaved f32 image, row-major, top row first (y down), `channels` values per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub data: Vec<f32>,
}

impl Image {
    /// An image of zeros.
    pub fn new(width: u32, height: u32, channels: u32) -> Image {
        let len = width as usize * height as usize * channels as usize;
        Image { width, height, channels, data: vec![0.0; len] }
    }

    fn index(&self, x: u32, y: u32, c: u32) -> usize {
        debug_assert!(x < self.width && y < self.height && c < self.channels);
        (y as usize * self.width as usize + x as usize) * self.channels as usize + c as usize
    }

    /// Value of channel `c` at pixel (x, y). Panics when out of bounds (a programming error).
    pub fn get(&self, x: u32, y: u32, c: u32) -> f32 {
        self.data[self.index(x, y, c)]
    }

    /// Sets channel `c` at pixel (x, y). Panics when out of bounds (a programming error).
    pub fn set(&mut self, x: u32, y: u32, c: u32, v: f32) {
        let i = self.index(x, y, c);
        self.data[i] = v;
    }
}

/// What a depth value measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DepthKind {
    /// Distance along the view axis (Blender/Cycles Z).
    #[default]
    Planar,
    /// Euclidean distance from the camera along the pixel's ray.
    Ray,
}

/// Where the passes of a frame are, and how to read them. [`PassSources::new`] takes every
/// pass from one file, channels found by name, depth in metres; set what differs with
/// `..PassSources::new(color_path)`.
#[derive(Clone, Debug)]
pub struct PassSources {
    pub color_path: PathBuf,
    /// None: look in `color_path` (multilayer file).
    pub depth_path: Option<PathBuf>,
    /// None: look in `color_path` if present there, else no velocity.
    pub velocity_path: Option<PathBuf>,
    /// The view layer (Blender `<layer>.Combined`, `<layer>.Depth`, `<layer>.Vector`) every
    /// pass is taken from; None: the colour override's, else the file's first (said in the
    /// report).
    pub layer: Option<String>,
    /// Override: a layer prefix ("ViewLayer.Combined") or an explicit comma list "R,G,B[,A]".
    pub color_channels: Option<String>,
    /// Override: exact channel name.
    pub depth_channel: Option<String>,
    /// Override: comma list of 2 channel names (x, y) or 4 (Blender X,Y,Z,W).
    pub velocity_channels: Option<String>,
    /// Metres per depth unit in the file (1.0 = metres, 0.01 = centimetres).
    pub depth_unit_m: f64,
    /// The user asked for velocity: missing velocity is an error.
    pub require_velocity: bool,
    /// What reading may allocate; checked against each file's declared size before reading it.
    pub budget: MemoryBudget,
    /// How the velocity channels are to be read; [`VelocityFormat::Auto`] from their names.
    pub velocity_format: VelocityFormat,
    /// Multiplies the velocity after its format's conversion (1: as the format says).
    pub velocity_scale: f64,
    /// Flips the velocity's y after its format's conversion (a pass written with y the other way).
    pub velocity_flip_y: bool,
    /// The time (frames) the vectors span, for formats that measure over the renderer's
    /// shutter interval rather than per frame (Arnold's raw `motion_vector`).
    pub velocity_interval_frames: Option<f64>,
    /// Keep the input files' other channels (depth, vectors, AOVs) for the output
    /// ([`ScenePasses::kept_channels`]).
    pub keep_layers: bool,
}

/// The conventions of the velocity passes renderers write; each becomes pixels per frame, x right,
/// y down, toward the next frame (and toward the previous one when the pass has both).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VelocityFormat {
    /// From the channel names, when only one format's names are present.
    #[default]
    Auto,
    /// Blender/Cycles `Vector` X,Y,Z,W: px per frame, y up; X,Y = p[f-1]-p[f], Z,W = p[f]-p[f+1].
    Blender,
    /// Nuke `forward.u,v` (+ `backward.u,v`) or `motion.u,v`: px toward the next (previous)
    /// frame, y up.
    Nuke,
    /// Arnold `motion_vector` R,G (raw): px over the renderer's shutter interval, forward, y up.
    Arnold,
    /// V-Ray `velocity`: px from the current to the next frame, y up.
    Vray,
    /// RE:Vision-style single vector: px per frame, forward, +y up.
    Revision,
    /// Normalised device coordinates: a frame width (and height) of 2 per frame, forward, y up.
    Ndc,
}

impl VelocityFormat {
    pub fn name(self) -> &'static str {
        match self {
            VelocityFormat::Auto => "auto",
            VelocityFormat::Blender => "blender",
            VelocityFormat::Nuke => "nuke",
            VelocityFormat::Arnold => "arnold",
            VelocityFormat::Vray => "vray",
            VelocityFormat::Revision => "revision",
            VelocityFormat::Ndc => "ndc",
        }
    }
}

impl Default for PassSources {
    /// No color file yet; the rest as [`PassSources::new`].
    fn default() -> Self {
        PassSources::new(PathBuf::new())
    }
}

impl PassSources {
    pub fn new(color_path: impl Into<PathBuf>) -> PassSources {
        PassSources {
            color_path: color_path.into(),
            depth_path: None,
            velocity_path: None,
            layer: None,
            color_channels: None,
            depth_channel: None,
            velocity_channels: None,
            depth_unit_m: 1.0,
            require_velocity: false,
            budget: MemoryBudget::system(),
            velocity_format: VelocityFormat::Auto,
            velocity_scale: 1.0,
            velocity_flip_y: false,
            velocity_interval_frames: None,
            keep_layers: false,
        }
    }
}

/// How large an image realcam reads: a limit on its pixels (`--max-pixels`), and the memory
/// this process may still take (free memory and the address-space limit, `ulimit -v`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MemoryBudget {
    /// Largest image (width x height); None: no limit but memory.
    pub max_pixels: Option<u64>,
    /// Bytes reading one image may allocate.
    pub max_bytes: u64,
}

impl MemoryBudget {
    /// No pixel limit; the memory available now ([`available_memory_bytes`]).
    pub fn system() -> MemoryBudget {
        MemoryBudget { max_pixels: None, max_bytes: available_memory_bytes() }
    }

    /// Errors, naming the file and its declared size, unless an image of `width` x `height`
    /// px whose reading takes `bytes` fits this budget.
    pub fn check(&self, what: &str, path: &Path, width: u64, height: u64, bytes: u64) -> Result<(), IoError> {
        let too_large = |reason: String, field| IoError::TooLarge {
            what: what.into(),
            path: path.into(),
            width,
            height,
            reason,
            field,
        };
        let pixels = width.saturating_mul(height);
        if let Some(max) = self.max_pixels.filter(|&max| pixels > max) {
            return Err(too_large(
                format!(" ({pixels} pixels), more than the limit of {max} pixels"),
                Some("max_pixels"),
            ));
        }
        if bytes > self.max_bytes {
            return Err(too_large(
                format!(
                    ": reading it takes {}, more than the {} of memory available (free memory, address-space limit)",
                    gigabytes(bytes),
                    gigabytes(self.max_bytes)
                ),
                None,
            ));
        }
        Ok(())
    }
}

/// `bytes` as "12.3 GB" (or MB below a gigabyte).
fn gigabytes(bytes: u64) -> String {
    if bytes >= 1_000_000_000 {
        format!("{:.1} GB", bytes as f64 / 1e9)
    } else {
        format!("{:.1} MB", bytes as f64 / 1e6)
    }
}

/// The memory this process may still allocate: the free memory (`MemAvailable`), and under an
/// address-space limit (`ulimit -v`) what is left of it. `u64::MAX` where neither is known.
pub fn available_memory_bytes() -> u64 {
    let kb_field = |file: &str, key: &str| {
        let text = std::fs::read_to_string(file).ok()?;
        let line = text.lines().find(|l| l.starts_with(key))?;
        let kb: u64 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
        Some(kb.saturating_mul(1024))
    };
    let free = kb_field("/proc/meminfo", "MemAvailable:");
    let address_space = std::fs::read_to_string("/proc/self/limits").ok().and_then(|text| {
        let line = text.lines().find(|l| l.starts_with("Max address space"))?;
        let limit: u64 = line["Max address space".len()..].split_whitespace().next()?.parse().ok()?;
        let used = kb_field("/proc/self/status", "VmSize:").unwrap_or(0);
        Some(limit.saturating_sub(used))
    });
    free.into_iter().chain(address_space).min().unwrap_or(u64::MAX)
}

impl IoError {
    /// The field of [`PassSources`] the error is about, if it is about one.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            IoError::InvalidArgument { field, .. }
            | IoError::Output { field, .. }
            | IoError::MissingSetting { field, .. } => Some(field),
            IoError::TooLarge { field, .. } => *field,
            _ => None,
        }
    }
}

/// The passes of one frame, as loaded by [`load_passes`].
#[derive(Clone, Debug)]
pub struct ScenePasses {
    /// 4 channels RGBA (alpha = 1 when the file has none), scene-linear.
    pub color: Image,
    /// 1 channel, metres, exactly as stored times `depth_unit_m` (no ray/planar conversion).
    pub depth_m: Image,
    /// 2 channels: motion in pixels per frame toward the NEXT frame, x right, y DOWN.
    pub velocity_px: Option<Image>,
    /// 2 channels: motion in pixels per frame toward the PREVIOUS frame, x right, y DOWN, when
    /// the pass has it (Blender's X,Y; Nuke's backward); None: constant velocity is assumed.
    pub velocity_prev_px: Option<Image>,
    /// The format the velocity was read as.
    pub velocity_format: Option<VelocityFormat>,
    /// x, y, width, height (px) of the display window.
    pub display_window: (i32, i32, u32, u32),
    /// Position (px) of pixel (0,0) of these images in the same absolute coordinates as
    /// `display_window`'s x, y (the EXR data window's minimum corner).
    pub data_origin: (i32, i32),
    /// Which file/channel each pass came from, and the conventions applied (multi-line).
    pub channel_report: String,
    /// Number of NaN/Inf color values replaced by 0.
    pub color_nan_count: u64,
    /// With [`PassSources::keep_layers`]: every other channel of the input files of the frame's
    /// size (name, values as stored, row-major), the colour pass's own channels left out; a
    /// name the output already has (R, G, B, A or an earlier file's) gets its pass as a
    /// prefix (`depth.R`).
    pub kept_channels: Vec<(String, Vec<f32>)>,
    /// The focal length (mm) the colour file says it was rendered with: OpenEXR's
    /// `pinholeFocalLength`, `effectiveFocalLength` or `nominalFocalLength`, or Blender's
    /// `Lens` stamp ("50.00 mm"); with the attribute's name.
    pub render_focal_length_mm: Option<(f64, String)>,
    /// The colour file's `chromaticities` attribute: the colour space of its RGB.
    pub chromaticities: Option<crate::optics::colour::Chromaticities>,
    /// The colour file's header attributes (its first part's), any of OpenEXR's types, as
    /// stored, in name order, for the output ([`ExrWriteOptions::input_attributes`]): those
    /// of the file's layout ([`STRUCTURAL_ATTRIBUTES`]) left out, and those describing
    /// channels ([`describes_channels`]: Cryptomatte's) unless [`PassSources::keep_layers`].
    pub header_attributes: Vec<(String, exr::meta::attribute::AttributeValue)>,
}

/// A fresh, empty directory under the system temp dir for one test.
#[cfg(test)]
pub(crate) fn test_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("realcam-test-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create test dir");
    dir
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_get_set_layout() {
        let mut im = Image::new(3, 2, 4);
        assert_eq!(im.data.len(), 24);
        im.set(2, 1, 3, 7.0);
        assert_eq!(im.get(2, 1, 3), 7.0);
        assert_eq!(im.data[(3 + 2) * 4 + 3], 7.0);
    }

    #[test]
    fn writes_replace_and_clean_up() {
        let dir = test_dir("atomic");
        let target = dir.join("a.bin");
        output::write_file("output", &target, b"one").unwrap();
        output::write_file("output", &target, b"two").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"two");
        let err = output::write_file("output", &dir.join("missing/a.bin"), b"x").unwrap_err();
        assert!(err.to_string().contains("missing/a.bin"), "{err}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
