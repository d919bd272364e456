//! What a render reads and writes, as plain data: the session's settings beside the camera.
//! The command line fills them from its flags (`crate::flags`), the Python package from its
//! keyword arguments; a host can fill them itself.

use super::errors::NameFlags;
use crate::gpu::GpuOptions;
use crate::io::output::Outputs;
use crate::io::sequence::{FramePattern, FrameRange};
use crate::io::{DepthKind, ExrCompression, PassSources};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// One render's files and switches (for a sequence: with the frame number still in the paths).
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Where the passes are and how to read them.
    pub sources: PassSources,
    /// What the depth values measure.
    pub depth_kind: DepthKind,
    /// The output EXR.
    pub output: PathBuf,
    /// An sRGB 8-bit PNG preview, when asked for.
    pub png: Option<PathBuf>,
    /// The per-pass GPU times as a Chrome trace JSON, when asked for.
    pub trace: Option<PathBuf>,
    /// The other files the run reads (aperture image, lens file, ...), with what each is:
    /// no output may replace one.
    pub other_inputs: Vec<(&'static str, PathBuf)>,
    /// 32-bit float channels in the EXR instead of half.
    pub float32: bool,
    pub compression: ExrCompression,
    pub colour: ColourSettings,
    /// Say the planned passes and why each runs or is skipped.
    pub explain: bool,
    /// Say the GPU time per pass.
    pub profile: bool,
    pub gpu: GpuOptions,
}

/// The working colour space and the preview's display.
#[derive(Clone, Debug, Default)]
pub struct ColourSettings {
    /// The colour space of the input's RGB (and of the output); default: the colour file's
    /// chromaticities, else Rec.709.
    pub colorspace: Option<String>,
    /// An OpenColorIO config (a file or a built-in `ocio://` name); default: `$OCIO`.
    pub config: Option<String>,
    /// The PNG preview's display and view in the config.
    pub display: Option<String>,
    pub view: Option<String>,
}

/// A frame sequence: which frames, and how to treat the ones done before.
#[derive(Clone, Debug)]
pub struct SequenceSettings {
    pub range: FrameRange,
    /// Skip a frame whose outputs all exist.
    pub skip_existing: bool,
    /// Stop at the first frame that fails.
    pub fail_fast: bool,
    /// Accumulate the frames into one exposure (Kyaw 2013 sec. 7.4) written to the output.
    pub long_exposure: bool,
    /// The long exposure's state, to resume a stopped one.
    pub state: Option<PathBuf>,
}

impl RenderSettings {
    /// The output paths: the EXR, then the PNG and the trace if asked for.
    pub fn output_paths(&self) -> Vec<&Path> {
        [Some(self.output.as_path()), self.png.as_deref(), self.trace.as_deref()].into_iter().flatten().collect()
    }

    /// The outputs, checked against each other and the inputs and reserved, before any work.
    pub fn outputs(&self) -> Result<Outputs> {
        let mut outputs: Vec<(&'static str, &Path)> = vec![("output", &self.output)];
        outputs.extend(self.png.as_deref().map(|p| ("png", p)));
        outputs.extend(self.trace.as_deref().map(|p| ("trace", p)));
        let passes = [
            ("color pass", Some(self.sources.color_path.as_path())),
            ("depth pass", self.sources.depth_path.as_deref()),
            ("velocity pass", self.sources.velocity_path.as_deref()),
        ];
        let mut inputs: Vec<(&'static str, &Path)> = passes.into_iter().filter_map(|(w, p)| Some((w, p?))).collect();
        inputs.extend(self.other_inputs.iter().map(|(what, p)| (*what, p.as_path())));
        Outputs::new(&outputs, &inputs).name_flags()
    }
}

/// The path patterns of a sequence: each path's pattern, or None for a path without a frame
/// number (an input every frame shares).
pub(super) struct Patterns {
    color: Option<FramePattern>,
    depth: Option<FramePattern>,
    velocity: Option<FramePattern>,
    output: Option<FramePattern>,
    png: Option<FramePattern>,
    trace: Option<FramePattern>,
}

impl Patterns {
    /// The patterns of `settings`' paths; an output without a frame number is refused (every
    /// frame would write over it), and one with a frame number for a long exposure (one file).
    pub(super) fn new(settings: &RenderSettings, one_output: bool) -> Result<Patterns> {
        let parse = |flag: &str, path: Option<&Path>| -> Result<Option<FramePattern>> {
            match path {
                Some(path) => FramePattern::parse(path).with_context(|| flag.to_string()),
                None => Ok(None),
            }
        };
        let output = |flag: &str, path: Option<&Path>| -> Result<Option<FramePattern>> {
            let pattern = parse(flag, path)?;
            if let (true, Some(_), Some(path)) = (one_output, &pattern, path) {
                bail!(
                    "{flag} \"{}\" has a frame number, but --long-exposure writes one exposure of all the frames",
                    path.display()
                );
            }
            if let (false, None, Some(path)) = (one_output, &pattern, path) {
                bail!(
                    "{flag} \"{}\" has no frame number (####, %04d): every frame of --frames would write over it",
                    path.display()
                );
            }
            Ok(pattern)
        };
        let sources = &settings.sources;
        Ok(Patterns {
            color: parse("--color", Some(&sources.color_path))?,
            depth: parse("--depth", sources.depth_path.as_deref())?,
            velocity: parse("--velocity", sources.velocity_path.as_deref())?,
            output: output("--output", Some(&settings.output))?,
            png: output("--png", settings.png.as_deref())?,
            trace: output("--trace", settings.trace.as_deref())?,
        })
    }

    /// `settings` with the paths of `frame`.
    pub(super) fn at_frame(&self, settings: &RenderSettings, frame: i64) -> RenderSettings {
        let at = |pattern: &Option<FramePattern>, path: &PathBuf| {
            pattern.as_ref().map_or_else(|| path.clone(), |p| p.path(frame))
        };
        let at_opt =
            |pattern: &Option<FramePattern>, path: &Option<PathBuf>| path.as_ref().map(|path| at(pattern, path));
        let mut one = settings.clone();
        one.sources.color_path = at(&self.color, &settings.sources.color_path);
        one.sources.depth_path = at_opt(&self.depth, &settings.sources.depth_path);
        one.sources.velocity_path = at_opt(&self.velocity, &settings.sources.velocity_path);
        one.output = at(&self.output, &settings.output);
        one.png = at_opt(&self.png, &settings.png);
        one.trace = at_opt(&self.trace, &settings.trace);
        one
    }
}
