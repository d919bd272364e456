//! The flags of `realcam render`, shared by the command line and the Python package (whose
//! keyword arguments are these flags: `Camera(fstop=2)` is `--fstop=2`). They only parse: each
//! group turns into the library's plain settings ([`RenderArgs::camera`],
//! [`RenderArgs::settings`]), and the render session ([`crate::session`]) does the work.

mod lens;
mod motion;
mod sequence;

pub use lens::{CocModelArg, FitArg, GpuArgs, LensArgs, LensChoice};
pub use motion::MotionArgs;
pub use sequence::SequenceArgs;

use crate::io::{self, DepthKind, MemoryBudget, PassSources};
use crate::model::camera::{BokehMode, Camera, CameraField, CameraRequest, FilmMode, FilmPreset, ShotCamera};
use crate::model::settings::{parse_coc_limit, parse_flare_light, parse_shutter_s, parse_spherical_aberration};
use crate::session::errors::NameFlags;
use crate::session::{ColourSettings, RenderSettings};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// `--compression`: the EXR codecs, by the names compositors use.
#[derive(Clone, Copy, ValueEnum)]
pub enum CompressionArg {
    Zip,
    Zips,
    Piz,
    Rle,
    None,
}

impl From<CompressionArg> for io::ExrCompression {
    fn from(c: CompressionArg) -> Self {
        match c {
            CompressionArg::Zip => io::ExrCompression::Zip,
            CompressionArg::Zips => io::ExrCompression::Zips,
            CompressionArg::Piz => io::ExrCompression::Piz,
            CompressionArg::Rle => io::ExrCompression::Rle,
            CompressionArg::None => io::ExrCompression::None,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum FilmArg {
    /// The characteristic curve (toe, straight part, shoulder): display-referred.
    Filmic,
    /// A steeper curve with a harder shoulder (slide-film-like).
    Contrast,
    /// A flatter curve with a long toe and shoulder.
    Soft,
    /// Scene-referred linear sensor values, for compositing.
    Linear,
}

impl From<FilmArg> for FilmPreset {
    fn from(film: FilmArg) -> FilmPreset {
        match film {
            FilmArg::Filmic => FilmPreset::Filmic,
            FilmArg::Contrast => FilmPreset::Contrast,
            FilmArg::Soft => FilmPreset::Soft,
            FilmArg::Linear => FilmPreset::Linear,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum BokehArg {
    /// Tiled gather-scatter: cost nearly flat in the CoC radius.
    Tiled,
    /// Exact aperture sprite of every pixel (the geometric reference; cost grows with CoC^2).
    Reference,
    /// Potmesil & Chakravarty's diffraction focus processor (the accuracy reference; slow).
    Diffraction,
}

impl From<BokehArg> for BokehMode {
    fn from(bokeh: BokehArg) -> BokehMode {
        match bokeh {
            BokehArg::Tiled => BokehMode::Tiled,
            BokehArg::Reference => BokehMode::Reference,
            BokehArg::Diffraction => BokehMode::Diffraction,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum DepthKindArg {
    /// Distance along the view axis (Blender/Cycles Z).
    Planar,
    /// Distance from the camera along each pixel's ray.
    Ray,
}

impl From<DepthKindArg> for DepthKind {
    fn from(kind: DepthKindArg) -> DepthKind {
        match kind {
            DepthKindArg::Planar => DepthKind::Planar,
            DepthKindArg::Ray => DepthKind::Ray,
        }
    }
}

#[derive(Args, Clone)]
#[command(allow_negative_numbers = true)]
pub struct RenderArgs {
    /// Color pass (RGB/RGBA EXR), or a multilayer EXR with every pass. Alpha is premultiplied,
    /// as OpenEXR stores it (RGB already multiplied by A), in the input and in the output.
    #[arg(long)]
    pub color: PathBuf,
    /// Depth pass EXR (a Z channel); default: look in the color file.
    #[arg(long)]
    pub depth: Option<PathBuf>,
    /// Velocity pass EXR; default: use one in the color file if present.
    #[arg(long)]
    pub velocity: Option<PathBuf>,
    #[command(flatten)]
    lens: LensArgs,
    /// Shutter time in seconds, e.g. 0.02 or 1/50; default: the camera file's, else the input's
    /// `expTime` attribute, else 1/50.
    #[arg(long)]
    shutter: Option<String>,
    /// ISO speed; default: the camera file's, else the input's `isoSpeed` attribute, else 100.
    #[arg(long)]
    iso: Option<f64>,
    /// Luminance in cd/m^2 of a scene value of 1.0; default 160, which exposes a scene value of
    /// 0.18 as ISO 12232 middle grey at 1/50 s, ISO 100, f/2.
    #[arg(long = "nits-per-unit")]
    nits_per_unit: Option<f64>,
    /// A camera file (TOML): the camera's settings keyframed over the shot's frames (a rack
    /// focus, an iris pull, a zoom), with linear or smooth interpolation; or a USD file's camera
    /// (.usda, .usdc, .usdz; FILE:/Prim/Path to name one of several): its focal length, f-stop,
    /// focus distance and shutter with their time samples. A flag wins over the file, the file
    /// over the input's header attributes.
    #[arg(long = "camera-file", value_name = "FILE")]
    camera_file: Option<PathBuf>,
    /// The frame number of a single render (without --frames): where a camera file's keys are
    /// evaluated and what seeds the grain.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "frames")]
    frame: Option<i64>,
    /// Aperture blades (0 = circular); default from the lens file.
    #[arg(long)]
    blades: Option<u32>,
    /// Aperture rotation in degrees; default from the lens file.
    #[arg(long = "blade-rotation")]
    blade_rotation_deg: Option<f64>,
    /// Blade curvature, 0 (straight blades: a polygon) .. 1 (round); default from the lens file.
    #[arg(long = "blade-curvature")]
    blade_curvature: Option<f64>,
    /// Use the depth pass as stored at anti-aliased edges. By default a pixel at an edge takes
    /// the depth of the layer that brings most of its light (renderers filter the colour pass
    /// but keep one depth sample per pixel).
    #[arg(long = "keep-edge-depth")]
    keep_edge_depth: bool,
    /// Spherical aberration in the bokeh: an amount in [-1, 1] (> 0 under-corrected: soft
    /// background, ringed foreground; < 0 over-corrected) or `uniform`; default from the lens file.
    #[arg(long = "spherical-aberration")]
    spherical_aberration: Option<String>,
    /// An aperture image (PNG or EXR, grey levels = transmission) used as the iris shape instead
    /// of the blades; upright for background bokeh, turned by --blade-rotation.
    #[arg(long = "aperture-image")]
    aperture_image: Option<PathBuf>,
    /// Cat's eye (optical vignetting of the bokeh) at the frame corners, 0..1; default from the lens file.
    #[arg(long = "cats-eye")]
    cats_eye: Option<f64>,
    /// Depth-of-field method.
    #[arg(long, value_enum, default_value = "tiled")]
    bokeh: BokehArg,
    /// Film response of the PNG preview; of the EXR too with --film-in-exr (the EXR is
    /// scene-referred by default).
    #[arg(long, value_enum, default_value = "filmic")]
    film: FilmArg,
    /// Apply the film curve to the EXR too (display-referred, clipped at the film's white);
    /// by default the EXR keeps scene-referred linear sensor values and only the PNG preview
    /// goes through the curve.
    #[arg(long = "film-in-exr")]
    film_in_exr: bool,
    /// The colour space of the input's RGB (and of the output): ACEScg, ACES2065-1,
    /// "Linear Rec.709 (sRGB)", "Linear Rec.2020", "Linear P3-D65"; default: the colour
    /// file's chromaticities attribute, else Rec.709.
    #[arg(long)]
    colorspace: Option<String>,
    /// An OpenColorIO config whose colour space names --colorspace takes: a file (.ocio,
    /// .ocioz) or a built-in one (ocio://cg-config-latest, ocio://studio-config-latest);
    /// default: $OCIO when set.
    #[arg(long, value_name = "FILE")]
    config: Option<String>,
    /// The PNG preview's display in the OpenColorIO config (--config, $OCIO); default: the
    /// config's default display ("sRGB - Display" in the ACES configs).
    #[arg(long)]
    display: Option<String>,
    /// The PNG preview's view of --display: its tone curve (the ACES configs: the ACES output
    /// transform); default: the display's default view for the working space.
    #[arg(long)]
    view: Option<String>,
    /// Keep the input files' other channels (depth, vectors, AOVs, other view layers) in the
    /// output EXR, as stored; a name the output has already gets its pass as prefix (depth.R).
    /// Cryptomatte's header attributes come with its channels.
    #[arg(long = "keep-layers")]
    keep_layers: bool,
    /// A film file (TOML, see films/): its characteristic curve, parametric or tabled,
    /// instead of --film.
    #[arg(long = "film-file", value_name = "FILE")]
    film_file: Option<PathBuf>,
    /// Sensor noise at ISO 100 (standard deviation at sensor value 1, growing with sqrt(ISO));
    /// default 0: none.
    #[arg(long)]
    grain: Option<f64>,
    /// Seed of the sensor noise: the same seed and frame give the same noise; each frame of a
    /// sequence mixes its frame number in, so neighbouring frames' grain is independent.
    #[arg(long, default_value_t = CameraRequest::default().seed, value_parser = parse_seed)]
    seed: u32,
    /// Do not apply the exposure gain (ISO, shutter, f-number): sensor value = scene value.
    #[arg(long = "no-exposure")]
    no_exposure: bool,
    /// Do not apply natural (cos^4) vignetting.
    #[arg(long = "no-vignetting")]
    no_vignetting: bool,
    /// Clamp on the CoC diameter: `none` (the default: every disc as large as the lens draws
    /// it), on the film in mm (1.2mm, the same look at every resolution) or in pixels (64,
    /// 64px). Whatever the clamp, a disc is at most twice the frame's diagonal across (one
    /// centred on any pixel covers the whole frame). A clamp that changes the picture is said,
    /// in --explain and as a warning.
    #[arg(long = "max-coc", default_value = "none")]
    max_coc: String,
    #[command(flatten)]
    flare: FlareArgs,
    /// What the depth values measure.
    #[arg(long = "depth-kind", value_enum, default_value = "planar")]
    depth_kind: DepthKindArg,
    /// Metres per depth unit in the file (0.01 for centimetres).
    #[arg(long = "depth-unit", default_value_t = PassSources::default().depth_unit_m)]
    depth_unit_m: f64,
    /// The view layer of a multilayer EXR every pass is taken from (Blender: ViewLayer);
    /// default: the colour override's, else the first (said in --explain and a warning).
    #[arg(long)]
    layer: Option<String>,
    /// Color channel override: a layer prefix (ViewLayer.Combined) or a list "R,G,B[,A]".
    #[arg(long = "color-channels")]
    color_channels: Option<String>,
    /// Depth channel override (exact name).
    #[arg(long = "depth-channel")]
    depth_channel: Option<String>,
    /// Velocity channel override: "x,y" or Blender "X,Y,Z,W".
    #[arg(long = "velocity-channels")]
    velocity_channels: Option<String>,
    /// Refuse an input or aperture image larger than this many pixels (width x height); the
    /// memory available is checked in any case.
    #[arg(long = "max-pixels")]
    max_pixels: Option<u64>,
    /// Output EXR.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Write 32-bit float EXR instead of half.
    #[arg(long)]
    float: bool,
    /// The EXR's codec: zip (16 scanlines, the default), zips (1 scanline), piz, rle or none
    /// (the fastest to write and read, the largest file).
    #[arg(long, value_enum, default_value_t = CompressionArg::Zip)]
    compression: CompressionArg,
    /// Also write an sRGB 8-bit PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Print the planned passes and why each runs or is skipped.
    #[arg(long)]
    explain: bool,
    /// Print GPU time per pass (timestamp queries).
    #[arg(long)]
    profile: bool,
    /// Write the per-pass GPU times as a Chrome trace JSON (opens in Perfetto).
    #[arg(long)]
    pub trace: Option<PathBuf>,
    #[command(flatten)]
    motion: MotionArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    pub sequence: SequenceArgs,
}

/// The lens flare's flags.
#[derive(Args, Clone)]
pub struct FlareArgs {
    /// Record no lens flare (ghosts, starburst, halo) around bright lights.
    #[arg(long = "no-flare")]
    no_flare: bool,
    /// Record lens flare with `--lens ideal` too, which draws none by default (the renderer's
    /// camera has no ghosts, starburst or halo); the other lenses draw it unless --no-flare.
    #[arg(long, conflicts_with = "no_flare")]
    flare: bool,
    /// A pixel with a channel at this many times the sensor's saturation (after the exposure)
    /// belongs to a light.
    #[arg(long = "flare-threshold", default_value_t = CameraRequest::default().flare_threshold)]
    flare_threshold: f64,
    /// A light given explicitly, X,Y,ENERGY[,AREA]: pixels (may be outside the frame), the sum
    /// of scene values over the pixels it covers, its area in pixels; repeat for more.
    #[arg(long = "flare-light", value_name = "X,Y,ENERGY", allow_hyphen_values = true)]
    flare_light: Vec<String>,
    /// Lights given explicitly as a JSON list: [{"x": .., "y": .., "energy": .. | "rgb": [r, g, b], "area_px": ..}].
    #[arg(long = "flare-lights", value_name = "FILE")]
    flare_lights: Option<PathBuf>,
    /// Which model draws the ghosts: the lens file's fitted primitives (Walch ch. 6-8,
    /// `[[fitted_ghost]]`), the prescription's ray-transfer matrices, or auto (fitted when the
    /// lens file has fits).
    #[arg(long = "flare-ghosts", value_enum, default_value_t = FlareGhostsArg::Auto)]
    flare_ghosts: FlareGhostsArg,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FlareGhostsArg {
    /// Fitted when the lens file has `[[fitted_ghost]]`, else the matrices.
    Auto,
    /// The lens file's `[[fitted_ghost]]` primitives (an error without them).
    Fitted,
    /// The prescription's ray-transfer matrices.
    Matrix,
}

/// The keys of `--camera-file`: a camera file (TOML), or a USD file's camera (`shot.usda`, or
/// `shot.usda:/World/Camera` to name one of several).
fn load_camera_keys(path: &std::path::Path) -> Result<crate::model::camera::keys::CameraKeys> {
    use crate::io::usd_camera::{is_usd, load_usd_camera};
    let text = path.to_string_lossy();
    if let Some((file, prim)) =
        text.rsplit_once(':').filter(|(f, p)| p.starts_with('/') && !path.exists() && is_usd(std::path::Path::new(f)))
    {
        return Ok(load_usd_camera(std::path::Path::new(file), Some(prim))?);
    }
    if is_usd(path) {
        return Ok(load_usd_camera(path, None)?);
    }
    Ok(crate::io::camera_file::load_camera_file(path)?)
}

/// `--seed`: a whole number the seed's 32 bits hold, else the range in the message.
fn parse_seed(text: &str) -> Result<u32, String> {
    text.trim().parse::<u32>().map_err(|_| format!("the seed is a whole number from 0 to {}", u32::MAX))
}

impl FlareArgs {
    /// The lights the flags give.
    fn lights(&self) -> Result<Vec<crate::model::flare::FlareLight>> {
        let mut lights = Vec::new();
        for text in &self.flare_light {
            lights.push(parse_flare_light(text).with_context(|| format!("--flare-light {text:?}"))?);
        }
        if let Some(path) = &self.flare_lights {
            lights.extend(crate::io::flare_lights::load_flare_lights(path)?);
        }
        Ok(lights)
    }

    /// The ghost model the flags ask for; `fitted` needs the lens file's fits.
    fn ghosts(&self, lens_file: &crate::io::lens_file::LensFile) -> Result<crate::model::flare::FlareGhosts> {
        use crate::model::flare::FlareGhosts;
        Ok(match self.flare_ghosts {
            FlareGhostsArg::Auto => FlareGhosts::Auto,
            FlareGhostsArg::Matrix => FlareGhosts::Matrix,
            FlareGhostsArg::Fitted if lens_file.fitted_ghosts.is_empty() => anyhow::bail!(
                "--flare-ghosts fitted: lens {:?} has no [[fitted_ghost]] section (write one with realcam flare-fit, or use --flare-ghosts matrix)",
                lens_file.name
            ),
            FlareGhostsArg::Fitted => FlareGhosts::Fitted,
        })
    }
}

impl RenderArgs {
    /// The camera these flags ask for, without a camera file's keys or an input's settings
    /// (at the camera file's first key).
    pub fn camera(&self) -> Result<Camera> {
        Ok(self.shot_camera()?.base().clone())
    }

    /// The frame number of a single render (--frame).
    pub fn frame(&self) -> Option<i64> {
        self.frame
    }

    /// The shot these flags ask for: the flags' settings, a camera file's keys for the rest,
    /// then each frame's input header ([`ShotCamera`]).
    pub fn shot_camera(&self) -> Result<ShotCamera> {
        let lens_file = self.lens.lens.load()?;
        let default = CameraRequest::default();
        let shutter_s = match &self.shutter {
            Some(text) => parse_shutter_s(text).with_context(|| format!("--shutter {text:?}"))?,
            None => default.shutter_s,
        };
        let film = FilmMode::choose(self.film.into(), self.film_file.as_deref())?;
        let spherical_aberration = match &self.spherical_aberration {
            Some(text) => {
                Some(parse_spherical_aberration(text).with_context(|| format!("--spherical-aberration {text:?}"))?)
            }
            None => None,
        };
        let max_coc = parse_coc_limit(&self.max_coc).with_context(|| format!("--max-coc {:?}", self.max_coc))?;
        let request = self.lens.request(self.motion.request(CameraRequest {
            shutter_s,
            iso: self.iso.unwrap_or(default.iso),
            nits_per_unit: self.nits_per_unit.unwrap_or(default.nits_per_unit),
            blades: self.blades,
            blade_rotation_deg: self.blade_rotation_deg,
            blade_curvature: self.blade_curvature,
            resolve_depth_edges: !self.keep_edge_depth,
            spherical_aberration,
            cats_eye: self.cats_eye,
            exposure: !self.no_exposure,
            vignetting: !self.no_vignetting,
            film: Some(film),
            film_on_output: self.film_in_exr,
            max_coc,
            bokeh: self.bokeh.into(),
            grain: self.grain.unwrap_or(default.grain),
            seed: self.seed,
            flare: match (self.flare.flare, self.flare.no_flare) {
                (_, true) => Some(false),
                (true, false) => Some(true),
                // The lens's default: off for the ideal lens, on for the others.
                (false, false) => None,
            },
            flare_threshold: self.flare.flare_threshold,
            flare_lights: self.flare.lights()?,
            flare_ghosts: self.flare.ghosts(&lens_file)?,
            ..CameraRequest::default()
        })?);
        let aperture_mask = match &self.aperture_image {
            Some(path) => Some(crate::model::aperture::ApertureMask::load(path, &self.budget()).name_flags()?),
            None => None,
        };
        let keys = match &self.camera_file {
            Some(path) => Some(load_camera_keys(path).context("--camera-file")?),
            None => None,
        };
        ShotCamera::new(lens_file, request, self.given(), keys, aperture_mask).name_flags()
    }

    /// A single render (no --frames) of a camera file that changes a setting must say its
    /// frame (--frame): refused otherwise, with the range the file animates.
    pub fn check_single_frame(&self, shot: &ShotCamera) -> Result<()> {
        let Some(keys) = shot.keys().filter(|_| self.frame.is_none() && self.sequence.frames.is_none()) else {
            return Ok(());
        };
        if let Some((field, track)) = keys.tracks.iter().find(|(_, t)| t.is_animated()) {
            let (first, last) = (track.keys()[0].0, track.keys()[track.keys().len() - 1].0);
            bail!(
                "--camera-file: {} changes {} over frames {first} to {last}: say which frame this render is \
                 with --frame N, or render the shot with --frames",
                keys.origin,
                field.name()
            );
        }
        Ok(())
    }

    /// The settings of a shot these flags give.
    fn given(&self) -> Vec<CameraField> {
        let mut given = self.lens.given();
        let shutter_angle = self.motion.shutter_angle_given();
        let flags = [
            (CameraField::ShutterS, self.shutter.is_some() || shutter_angle),
            (CameraField::ShutterAngleDeg, shutter_angle),
            (CameraField::Iso, self.iso.is_some()),
            (CameraField::NitsPerUnit, self.nits_per_unit.is_some()),
            (CameraField::Blades, self.blades.is_some()),
            (CameraField::BladeRotationDeg, self.blade_rotation_deg.is_some()),
            (CameraField::BladeCurvature, self.blade_curvature.is_some()),
            (CameraField::SphericalAberration, self.spherical_aberration.is_some()),
            (CameraField::CatsEye, self.cats_eye.is_some()),
            (CameraField::Grain, self.grain.is_some()),
        ];
        given.extend(flags.into_iter().filter_map(|(field, given)| given.then_some(field)));
        given
    }

    /// The session's settings these flags give: where the passes are, what to write, how.
    pub fn settings(&self) -> RenderSettings {
        let inputs = [
            ("aperture image", self.aperture_image.as_deref()),
            ("lens file", self.lens.lens.lens.as_deref()),
            ("film file", self.film_file.as_deref()),
            ("flare light list", self.flare.flare_lights.as_deref()),
            ("camera file", self.camera_file.as_deref()),
        ];
        RenderSettings {
            sources: self.sources(),
            depth_kind: self.depth_kind.into(),
            output: self.output.clone(),
            png: self.png.clone(),
            trace: self.trace.clone(),
            other_inputs: inputs.into_iter().filter_map(|(what, p)| Some((what, p?.to_path_buf()))).collect(),
            float32: self.float,
            compression: self.compression.into(),
            colour: ColourSettings {
                colorspace: self.colorspace.clone(),
                config: self.config.clone(),
                display: self.display.clone(),
                view: self.view.clone(),
            },
            explain: self.explain,
            profile: self.profile,
            gpu: self.gpu.options(),
        }
    }

    /// What reading an image may take.
    fn budget(&self) -> MemoryBudget {
        MemoryBudget { max_pixels: self.max_pixels, ..MemoryBudget::system() }
    }

    /// Where the passes are, as these flags say.
    pub fn sources(&self) -> PassSources {
        self.motion.sources(PassSources {
            color_path: self.color.clone(),
            depth_path: self.depth.clone(),
            velocity_path: self.velocity.clone(),
            layer: self.layer.clone(),
            color_channels: self.color_channels.clone(),
            depth_channel: self.depth_channel.clone(),
            velocity_channels: self.velocity_channels.clone(),
            depth_unit_m: self.depth_unit_m,
            require_velocity: self.velocity.is_some(),
            budget: self.budget(),
            keep_layers: self.keep_layers,
            ..PassSources::default()
        })
    }
}
