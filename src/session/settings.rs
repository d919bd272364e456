//! What a render reads and writes, as plain data: the session's settings beside the camera.
//! The command line fills them from its flags (`crate::flags`), the Python package from its
//! keyword arguments; a host can fill them itself.

use super::errors::NameFlags;
use crate::gpu::GpuOptions;
use crate::io::output::{InputFiles, Outputs};
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

    /// The outputs (the field that names each, its path): the EXR, then the PNG and the trace
    /// if asked for.
    pub fn output_fields(&self) -> Vec<(&'static str, &Path)> {
        let mut outputs: Vec<(&'static str, &Path)> = vec![("output", &self.output)];
        outputs.extend(self.png.as_deref().map(|p| ("png", p)));
        outputs.extend(self.trace.as_deref().map(|p| ("trace", p)));
        outputs
    }

    /// The passes this render reads (what each is, its path).
    fn pass_inputs(&self) -> Vec<(&'static str, PathBuf)> {
        let passes = [
            ("color pass", Some(&self.sources.color_path)),
            ("depth pass", self.sources.depth_path.as_ref()),
            ("velocity pass", self.sources.velocity_path.as_ref()),
        ];
        passes.into_iter().filter_map(|(w, p)| Some((w, p?.clone()))).collect()
    }

    /// The files this render reads besides its passes: `other_inputs` and the OpenColorIO
    /// config file (--config, else `$OCIO`; a built-in `ocio://` config is no file).
    pub fn other_input_files(&self) -> Vec<(&'static str, PathBuf)> {
        let mut inputs = self.other_inputs.clone();
        let config = match &self.colour.config {
            Some(config) => Some(("OpenColorIO config", config.clone())),
            None => std::env::var("OCIO").ok().map(|c| ("OpenColorIO config of $OCIO", c)),
        };
        if let Some((what, config)) = config.filter(|(_, c)| !c.is_empty() && !c.starts_with("ocio://")) {
            let luts = crate::io::colour_config::config_lut_files(Path::new(&config));
            inputs.push((what, PathBuf::from(config)));
            inputs.extend(luts.into_iter().map(|lut| ("LUT of the OpenColorIO config", lut)));
        }
        inputs
    }

    /// The outputs, checked against each other and the inputs and reserved, before any work.
    pub fn outputs(&self) -> Result<Outputs> {
        let mut inputs = InputFiles::new(self.pass_inputs().into_iter().chain(self.other_input_files()));
        Outputs::new_beside(&self.output_fields(), &mut inputs).name_flags()
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

    /// Whether the first frame of `range` likely holds a velocity pass, from its files' headers
    /// ([`crate::io::velocity_likely`]): the session then creates the motion blur's pipelines
    /// while that frame is read.
    pub(super) fn first_frame_has_velocity(&self, settings: &RenderSettings, range: &FrameRange) -> bool {
        range.frames.first().is_some_and(|&f| crate::io::velocity_likely(&self.at_frame(settings, f).sources))
    }

    /// Every file the frames of `range` read: each frame's passes, and the files all share.
    pub(super) fn input_files(&self, settings: &RenderSettings, range: &FrameRange) -> InputFiles {
        let mut inputs = InputFiles::new(settings.other_input_files());
        let sources = &settings.sources;
        let passes = [
            ("color pass", &self.color, Some(&sources.color_path)),
            ("depth pass", &self.depth, sources.depth_path.as_ref()),
            ("velocity pass", &self.velocity, sources.velocity_path.as_ref()),
        ];
        for (what, pattern, path) in passes {
            match (pattern, path) {
                (Some(pattern), _) => inputs.add_frames(what, pattern, &range.frames),
                (None, Some(path)) => inputs.add(what, path.clone()),
                (None, None) => {}
            }
        }
        inputs
    }

    /// Checks every output of every frame of `range` (and `extra`, such as the long exposure's
    /// state) against every file the run reads and against the frame's other outputs, before
    /// any work.
    pub(super) fn check_outputs(
        &self,
        settings: &RenderSettings,
        range: &FrameRange,
        extra: &[(&'static str, &Path)],
    ) -> Result<()> {
        let mut inputs = self.input_files(settings, range);
        // A long exposure's outputs have no frame number: one set for every frame.
        let frames = if self.output.is_none() { &range.frames[..range.frames.len().min(1)] } else { &range.frames[..] };
        let outputs = [
            ("output", &self.output, Some(&settings.output)),
            ("png", &self.png, settings.png.as_ref()),
            ("trace", &self.trace, settings.trace.as_ref()),
        ];
        for &frame in frames {
            let mut seen: Vec<(&'static str, PathBuf, PathBuf)> = Vec::new();
            let paths = outputs.iter().filter_map(|&(field, pattern, path)| {
                Some((field, pattern.as_ref().map_or_else(|| path.cloned(), |p| Some(p.path(frame)))?))
            });
            let extra = extra.iter().map(|&(field, path)| (field, path.to_path_buf()));
            for (field, path) in paths.chain(extra) {
                let real = inputs.check_output(field, &path).name_flags()?;
                if let Some((other, other_path, _)) = seen.iter().find(|s| s.2 == real) {
                    return Err(crate::io::IoError::Output {
                        field,
                        path: path.clone(),
                        reason: format!("the {other} \"{}\" is the same file", other_path.display()),
                    })
                    .name_flags();
                }
                seen.push((field, path, real));
            }
        }
        Ok(())
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
