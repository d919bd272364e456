//! `realcam render`: color + depth (+ velocity) passes through a camera.

use crate::common::{GpuArgs, LensArgs};
use crate::flags::NameFlags;
use crate::motion_args::MotionArgs;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use realcam::gpu::Gpu;
use realcam::io::colour_config::{ColourConfig, ColourConfigError, DisplayView};
use realcam::io::output::Outputs;
use realcam::io::{self, DepthKind, ExrWriteOptions, Image, MemoryBudget, PassSources, ScenePasses};
use realcam::model::camera::{BokehMode, Camera, CameraRequest, FilmMode, FilmPreset};
use realcam::model::frame::Frame;
use realcam::model::settings::{parse_coc_limit, parse_flare_light, parse_shutter_s, parse_spherical_aberration};
use realcam::optics::colour::{named_space, space_name, Chromaticities, NAMED_SPACES};
use realcam::pipeline::planner::{self, Plan};
use realcam::pipeline::render::{Rendered, Renderer};
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

/// When the process started (`main` sets it first), for `--profile`'s start-up line.
pub static PROCESS_START: OnceLock<Instant> = OnceLock::new();

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

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
    /// Color pass (RGB/RGBA EXR), or a multilayer EXR with every pass.
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
    /// Shutter time in seconds, e.g. 0.02 or 1/50.
    #[arg(long, default_value = "1/50")]
    shutter: String,
    #[arg(long, default_value_t = CameraRequest::default().iso)]
    iso: f64,
    /// Luminance in cd/m^2 of a scene value of 1.0. The default exposes a scene value of 0.18 as
    /// ISO 12232 middle grey at 1/50 s, ISO 100, f/2.
    #[arg(long = "nits-per-unit", default_value_t = CameraRequest::default().nits_per_unit)]
    nits_per_unit: f64,
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
    #[arg(long = "keep-layers")]
    keep_layers: bool,
    /// A film file (TOML, see films/): its characteristic curve, parametric or tabled,
    /// instead of --film.
    #[arg(long = "film-file", value_name = "FILE")]
    film_file: Option<PathBuf>,
    /// Sensor noise at ISO 100 (standard deviation at sensor value 1, growing with sqrt(ISO)); 0: none.
    #[arg(long, default_value_t = CameraRequest::default().grain)]
    grain: f64,
    /// Seed of the sensor noise (the same seed gives the same noise).
    #[arg(long, default_value_t = CameraRequest::default().seed)]
    seed: u32,
    /// Do not apply the exposure gain (ISO, shutter, f-number): sensor value = scene value.
    #[arg(long = "no-exposure")]
    no_exposure: bool,
    /// Do not apply natural (cos^4) vignetting.
    #[arg(long = "no-vignetting")]
    no_vignetting: bool,
    /// Clamp on the CoC diameter: on the film in mm (1.2mm, the same look at every resolution)
    /// or in pixels (64, 64px). A clamp that changes the picture is said.
    #[arg(long = "max-coc", default_value = "1.2mm")]
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
    pub sequence: crate::sequence::SequenceArgs,
}

/// The lens flare's flags.
#[derive(Args, Clone)]
pub struct FlareArgs {
    /// Record no lens flare (ghosts, starburst, halo) around bright lights.
    #[arg(long = "no-flare")]
    no_flare: bool,
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
}

impl FlareArgs {
    /// The lights the flags give.
    fn lights(&self) -> Result<Vec<realcam::model::flare::FlareLight>> {
        let mut lights = Vec::new();
        for text in &self.flare_light {
            lights.push(parse_flare_light(text).with_context(|| format!("--flare-light {text:?}"))?);
        }
        if let Some(path) = &self.flare_lights {
            lights.extend(realcam::io::flare_lights::load_flare_lights(path)?);
        }
        Ok(lights)
    }
}

impl RenderArgs {
    /// The camera these flags ask for.
    pub fn camera(&self) -> Result<Camera> {
        let lens_file = self.lens.lens.load()?;
        let shutter_s = parse_shutter_s(&self.shutter).with_context(|| format!("--shutter {:?}", self.shutter))?;
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
            iso: self.iso,
            nits_per_unit: self.nits_per_unit,
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
            grain: self.grain,
            seed: self.seed,
            flare: !self.flare.no_flare,
            flare_threshold: self.flare.flare_threshold,
            flare_lights: self.flare.lights()?,
            ..CameraRequest::default()
        })?);
        let mut camera = Camera::new(&lens_file, &request).name_flags()?;
        if let Some(path) = &self.aperture_image {
            camera.aperture_mask =
                Some(realcam::model::aperture::ApertureMask::load(path, &self.budget()).name_flags()?);
        }
        Ok(camera)
    }

    /// The output paths these flags name: the EXR, then the PNG and the trace if asked for.
    pub fn output_paths(&self) -> Vec<&Path> {
        [Some(self.output.as_path()), self.png.as_deref(), self.trace.as_deref()].into_iter().flatten().collect()
    }

    /// The outputs, checked against each other and the inputs and reserved, before any work.
    pub fn outputs(&self) -> Result<Outputs> {
        let mut outputs: Vec<(&'static str, &Path)> = vec![("output", &self.output)];
        outputs.extend(self.png.as_deref().map(|p| ("png", p)));
        outputs.extend(self.trace.as_deref().map(|p| ("trace", p)));
        let inputs = [
            ("color pass", Some(self.color.as_path())),
            ("depth pass", self.depth.as_deref()),
            ("velocity pass", self.velocity.as_deref()),
            ("aperture image", self.aperture_image.as_deref()),
            ("lens file", self.lens.lens.lens.as_deref()),
            ("film file", self.film_file.as_deref()),
            ("flare light list", self.flare.flare_lights.as_deref()),
        ];
        let inputs: Vec<(&'static str, &Path)> = inputs.into_iter().filter_map(|(w, p)| Some((w, p?))).collect();
        Outputs::new(&outputs, &inputs).name_flags()
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

/// Renders what `args` asks; a single frame's session comes back still open, every output
/// written and renamed, for `main` to end the process without closing its GPU.
pub fn run(args: &RenderArgs) -> Result<Option<Session>> {
    if args.sequence.frames.is_some() {
        return crate::sequence::run(args).map(|()| None);
    }
    let outputs = args.outputs()?;
    let camera = args.camera()?;
    let mut session = Session::opening(args, &camera);
    for path in render_frame(args, &camera, outputs, &mut session)? {
        eprintln!("wrote {}", path.display());
    }
    Ok(Some(session))
}

/// The GPU and the pipelines of a run, opened at the first frame that reaches the GPU and kept
/// for the frames after it (a later frame's plan creates the pipelines it adds).
#[derive(Default)]
pub struct Session {
    gpu: Option<(Gpu, Renderer)>,
    /// The GPU opening on another thread (`Session::opening`), with the pipelines the camera
    /// will likely need; joined by the first frame.
    opening: Option<std::thread::JoinHandle<Result<(Gpu, Renderer)>>>,
    /// How the first frame reached the GPU, for `--profile`'s start-up line; taken when printed.
    startup: Option<String>,
}

impl Drop for Session {
    fn drop(&mut self) {
        // A run that failed before its first frame reached the GPU still waits for the device
        // to finish opening, so it is closed before the process exits.
        if let Some(opening) = self.opening.take() {
            let _ = opening.join();
        }
    }
}

impl Session {
    /// A session whose GPU starts opening now, on another thread: loading the Vulkan driver
    /// and creating the device (about 30-100 ms on lavapipe) overlap the first frame's EXR read,
    /// and so does creating the pipelines of the passes `camera` will likely run
    /// ([`Renderer::create_likely`]; on lavapipe about 30 ms of CPU for the tiled depth of field).
    pub fn opening(args: &RenderArgs, camera: &Camera) -> Session {
        let gpu_args = args.gpu.clone();
        let camera = camera.clone();
        let opening = std::thread::Builder::new().name("gpu-open".into()).spawn(move || {
            let gpu = gpu_args.open_quietly()?;
            let renderer = Renderer::empty(&gpu);
            // Only a head start: a pipeline that fails here is created again, and its error
            // reported, once the frame's plan asks for it.
            let _ = renderer.create_likely(&camera);
            Ok((gpu, renderer))
        });
        // Without a thread, the first frame opens the GPU itself.
        Session { gpu: None, opening: opening.ok(), startup: None }
    }

    /// The GPU: the one opening on another thread (with the pipelines created there), else
    /// opened now; prints it. With it, what the wait for it was, for the start-up line.
    fn open_gpu(&mut self, args: &RenderArgs) -> Result<(Gpu, Renderer, String)> {
        let waited = Instant::now();
        let (gpu, renderer, how) = match self.opening.take().map(std::thread::JoinHandle::join) {
            Some(Ok(opened)) => {
                let (gpu, renderer) = opened?;
                (gpu, renderer, "waited for the GPU opened beside the read")
            }
            Some(Err(_)) => bail!("opening the GPU failed (its thread panicked)"),
            None => {
                let gpu = args.gpu.open_quietly()?;
                let renderer = Renderer::empty(&gpu);
                (gpu, renderer, "opened the GPU")
            }
        };
        eprintln!("device: {}", gpu.info());
        Ok((gpu, renderer, format!("{how} {:.1} ms", ms_since(waited))))
    }

    /// The start-up line of `--profile` after the first frame: when its GPU work was submitted,
    /// counted from the process's start (None before, and after it was taken).
    pub fn take_startup(&mut self) -> Option<String> {
        self.startup.take()
    }

    /// The GPU, once a frame has opened it (the Python package's `Camera.device`).
    #[allow(dead_code)]
    pub fn gpu(&self) -> Option<&Gpu> {
        self.gpu.as_ref().map(|(gpu, _)| gpu)
    }

    /// Renders `frame` by `plan` on the session's GPU, opened (as `args` say) at the first call;
    /// Vulkan validation messages are an error.
    fn render(&mut self, args: &RenderArgs, frame: &mut Frame, plan: &Plan) -> Result<Rendered> {
        // The first frame: how its GPU was waited for, and when its pipelines began.
        let mut first = None;
        let opened = match self.gpu.take() {
            Some(opened) => opened,
            None => {
                let (gpu, renderer, waited) = self.open_gpu(args)?;
                first = Some((waited, Instant::now()));
                (gpu, renderer)
            }
        };
        let (gpu, renderer) = self.gpu.insert(opened);
        renderer.prepare(plan)?;
        let messages_before = gpu.validation_message_count();
        // The frame's colour is not needed after its upload: its memory takes the result.
        let rendered = renderer.render_taking_colour(frame, plan, false)?;
        // The first frame: from the process's start to its submit, and what came between.
        if let (Some((waited, created)), Some(submitted), Some(start)) =
            (first, rendered.profile.submitted_at, PROCESS_START.get())
        {
            let ms = |from: Instant| submitted.saturating_duration_since(from).as_secs_f64() * 1e3;
            self.startup = Some(format!(
                "start-up: the first frame's GPU work submitted {:.1} ms after the process started ({waited}; \
                 pipelines and recording {:.1} ms)",
                ms(*start),
                ms(created)
            ));
        }
        let messages = gpu.validation_message_count() - messages_before;
        if messages > 0 {
            bail!("{messages} Vulkan validation messages (see above)");
        }
        Ok(rendered)
    }

    /// Exposes a long exposure's `average` of sensor values on `camera`'s film (its grain and
    /// curve; nothing when the film is linear without grain), on the session's GPU.
    pub fn expose_on_film(&mut self, args: &RenderArgs, camera: &Camera, average: Image) -> Result<Image> {
        if !planner::film_changes_sensor_values(camera) {
            return Ok(average);
        }
        let Image { width, height, data, .. } = average;
        let mut frame = Frame::new(width, height, data, vec![f32::INFINITY; width as usize * height as usize]);
        let plan = planner::film_plan(&frame, camera);
        if args.explain {
            eprintln!("the long exposure's {}", plan.explain());
        }
        let rendered = self.render(args, &mut frame, &plan)?;
        Ok(Image { width, height, channels: 4, data: rendered.rgba })
    }
}

/// One frame rendered, ready to write.
pub struct RenderedFrame {
    pub image: Image,
    /// The PNG preview's image (display-encoded: through the config's view, or the film curve
    /// and the sRGB curve), when a PNG is asked for.
    pub preview: Option<Image>,
    /// The input's other channels (--keep-layers), written beside R, G, B, A.
    pub kept_channels: Vec<(String, Vec<f32>)>,
    /// The colour space of `image`.
    pub working_space: Chromaticities,
    /// The OpenColorIO display and view of the preview, when a config gives one.
    pub display_view: Option<Arc<DisplayView>>,
    pub exr_options: ExrWriteOptions,
    pub profile: realcam::gpu::Profile,
}

/// Renders the frame whose passes `args` names into its reserved `outputs` through `camera`;
/// the paths written.
pub fn render_frame(
    args: &RenderArgs,
    camera: &Camera,
    outputs: Outputs,
    session: &mut Session,
) -> Result<Vec<PathBuf>> {
    let rendered = render_image(args, camera, session)?;
    write_outputs(args, outputs, &rendered)
}

/// Renders the frame whose passes `args` names through `camera`.
pub fn render_image(args: &RenderArgs, camera: &Camera, session: &mut Session) -> Result<RenderedFrame> {
    render_loaded(args, camera, load_frame(args, camera)?, session)
}

/// A frame's passes read, in their working colour space, and planned: the work before the GPU,
/// which a sequence does for the next frame while the GPU renders this one.
pub struct LoadedFrame {
    pub frame: Frame,
    pub plan: Plan,
    /// The input's other channels (--keep-layers), written beside R, G, B, A.
    pub kept_channels: Vec<(String, Vec<f32>)>,
    channel_report: String,
    space_line: String,
    /// The OpenColorIO display and view of the preview, when a config gives one.
    display_view: Option<Arc<DisplayView>>,
    focal_length_warning: Option<String>,
}

/// Reads the passes `args` names and plans the frame through `camera`.
pub fn load_frame(args: &RenderArgs, camera: &Camera) -> Result<LoadedFrame> {
    let passes = io::load_passes(&args.sources()).name_flags()?;
    plan_frame(args, camera, passes)
}

/// The frame of loaded `passes` (from files, or the Python package's arrays) in its working
/// colour space, its plan, and whether the lens file was made for another focal length than
/// the render's.
pub fn plan_frame(args: &RenderArgs, camera: &Camera, mut passes: ScenePasses) -> Result<LoadedFrame> {
    let channel_report = passes.channel_report.clone();
    let kept_channels = std::mem::take(&mut passes.kept_channels);
    let render_focal_length = passes.render_focal_length_mm.clone();
    let mut frame = Frame::from_passes(passes, camera, args.depth_kind.into());
    let (space_line, display_view) = choose_working_space(args, &mut frame)?;
    let plan = planner::plan(&frame, camera);
    // The render's focal length: what the input says, else --focal-length's.
    let render_mm = render_focal_length.as_ref().map_or(camera.lens.focal_length_mm, |(mm, _)| *mm);
    let focal_length_warning = camera.focal_length_warning(Some(render_mm)).map(|w| match &render_focal_length {
        Some((_, attribute)) => format!("{w} (its {attribute} attribute)"),
        None => w,
    });
    Ok(LoadedFrame { frame, plan, kept_channels, channel_report, space_line, display_view, focal_length_warning })
}

/// Renders the `loaded` frame through `camera` on the session's GPU; `--explain` and the
/// warnings are printed here, in frame order.
pub fn render_loaded(
    args: &RenderArgs,
    camera: &Camera,
    loaded: LoadedFrame,
    session: &mut Session,
) -> Result<RenderedFrame> {
    let LoadedFrame { mut frame, plan, kept_channels, channel_report, space_line, display_view, focal_length_warning } =
        loaded;
    if args.explain {
        eprintln!("inputs:\n{}", indent(&channel_report));
        let (_, _, w, h) = frame.display_window;
        eprintln!("{}", camera.explain_camera(w, h));
        let film = match (args.film_in_exr, &display_view) {
            (true, None) => "in the EXR and the PNG (--film-in-exr)",
            (false, None) => "in the PNG preview only; the EXR is scene-referred",
            (true, Some(_)) => "in the EXR (--film-in-exr); the PNG shows the EXR through the config's view",
            (false, Some(_)) => {
                "not used: the PNG preview's tone curve is the config's view; the EXR is scene-referred"
            }
        };
        eprintln!("  film curve: {film}");
        eprintln!("  {space_line}");
        if let Some(dv) = &display_view {
            eprintln!("  preview: OpenColorIO display {:?}, view {:?} (from {})", dv.display, dv.view, dv.space);
        }
        eprintln!("{}", plan.explain());
    }
    if let Some(warning) = &focal_length_warning {
        eprintln!("warning: {warning}");
    }
    if let Some(warning) = &plan.coc_clamp_warning {
        let hint = if plan.facts.clamp_is_frame_cover { "" } else { "; raise the clamp with --max-coc" };
        eprintln!("warning: {warning}{hint}");
    }

    let rendered = session.render(args, &mut frame, &plan)?;
    if args.profile {
        eprint!("{}", rendered.profile.table());
        if let Some(line) = session.take_startup() {
            eprintln!("{line}");
        }
    }
    let image = Image { width: frame.width, height: frame.height, channels: 4, data: rendered.rgba };
    let preview = args.png.as_ref().map(|_| Image {
        data: realcam::pipeline::render::preview_rgba(
            camera,
            &frame.working_space,
            &image.data,
            image.width,
            display_view.as_deref(),
        ),
        ..image.clone()
    });
    let (_, _, w, h) = frame.display_window;
    let attributes = output_attributes(camera, w, h, &frame.working_space);
    let exr_options = ExrWriteOptions {
        float32: args.float,
        display_window: Some(frame.display_window),
        data_origin: frame.data_origin,
        attributes,
        float32_channels: Vec::new(),
        compression: args.compression.into(),
    };
    let working_space = frame.working_space;
    Ok(RenderedFrame {
        image,
        preview,
        kept_channels,
        exr_options,
        working_space,
        display_view,
        profile: rendered.profile,
    })
}

/// The output's EXR attributes: the camera's for a `width` x `height` frame, and the colour
/// space the output is in (the input's) as OpenEXR's chromaticities.
pub fn output_attributes(
    camera: &Camera,
    width: u32,
    height: u32,
    space: &Chromaticities,
) -> Vec<(String, io::ExrAttribute)> {
    let mut attributes = camera.attributes(width, height);
    let xy = [space.red, space.green, space.blue, space.white].map(|[x, y]| [x as f32, y as f32]);
    attributes.push(("chromaticities".into(), io::ExrAttribute::Chromaticities(xy)));
    attributes
}

/// Writes `rendered` into the reserved `outputs` that `args` names; the paths written.
pub fn write_outputs(args: &RenderArgs, mut outputs: Outputs, rendered: &RenderedFrame) -> Result<Vec<PathBuf>> {
    let image = &rendered.image;
    // Every output to its temporary first; renamed together only when all were written.
    let mut channels = io::rgba_planes(image);
    channels.extend(rendered.kept_channels.iter().map(|(name, data)| (name.as_str(), Cow::Borrowed(data.as_slice()))));
    // Kept channels as float32: a depth of 1e10 stays 1e10 (half ends at 65504).
    let exr_options = ExrWriteOptions {
        float32_channels: rendered.kept_channels.iter().map(|(name, _)| name.clone()).collect(),
        ..rendered.exr_options.clone()
    };
    outputs.write_with("output", |file, _| {
        io::write_exr_planes_to_file(file, &args.output, image.width, image.height, channels, &exr_options)
    })?;
    if let Some(png) = &args.png {
        outputs.write("png", &io::encode_png(png, rendered.preview.as_ref().unwrap_or(image))?)?;
    }
    if args.trace.is_some() {
        outputs.write("trace", rendered.profile.chrome_trace_json().as_bytes())?;
    }
    outputs.commit()?;
    Ok(args.output_paths().into_iter().map(Path::to_path_buf).collect())
}

/// Sets the frame's colour space from --colorspace (else it keeps the colour file's
/// chromaticities, or Rec.709); the `--explain` line that says which, with its luminance
/// weights; and the preview's display and view when there is an OpenColorIO config.
fn choose_working_space(args: &RenderArgs, frame: &mut Frame) -> Result<(String, Option<Arc<DisplayView>>)> {
    let from_file = frame.working_space;
    let config = match &args.config {
        Some(path) => Some(memo(&CONFIG, path.clone(), || ColourConfig::load(path).context("--config"))?),
        None => match std::env::var("OCIO") {
            Ok(path) if !path.is_empty() => Some(memo(&CONFIG, format!("$OCIO={path}"), || {
                ColourConfig::from_env().context("$OCIO")?.context("$OCIO is empty")
            })?),
            _ => None,
        },
    };
    let mut config_space = None;
    let (name, how) = match (&args.colorspace, &config) {
        (Some(text), Some(config)) => {
            let (name, space) = config.working_space(text).context(format!("--colorspace {text:?}"))?;
            frame.working_space = space;
            config_space = Some(name.clone());
            // A file stores its chromaticities as 32-bit floats.
            let differs = if same_space(&from_file, &space) { "" } else { ", not the file's chromaticities" };
            (name, format!("--colorspace in OpenColorIO config {}{differs}", config.name))
        }
        (Some(text), None) => {
            let Some((name, space)) = named_space(text) else {
                let known: Vec<&str> = NAMED_SPACES.iter().map(|(name, _, _)| *name).collect();
                bail!(
                    "--colorspace {text:?}: not a colour space realcam knows; known: {} (or any space of an \
                     OpenColorIO config: --config FILE, $OCIO)",
                    known.join(", ")
                );
            };
            frame.working_space = space;
            let differs = if space_name(&from_file) != Some(name) { ", not the file's chromaticities" } else { "" };
            (name.to_string(), format!("--colorspace{differs}"))
        }
        (None, _) => {
            let name = space_name(&from_file).unwrap_or("custom primaries");
            // The config's space of these primaries: the one of realcam's name, else its
            // scene_linear role.
            if let Some(config) = &config {
                config_space = [name, "scene_linear"]
                    .into_iter()
                    .filter_map(|n| config.working_space(n).ok())
                    .find(|(_, space)| same_space(space, &from_file))
                    .map(|(n, _)| n);
            }
            (name.to_string(), "the colour file's chromaticities, or Rec.709 without them".to_string())
        }
    };
    let [r, g, b] = frame.working_space.luminance_weights();
    let [nm_r, nm_g, nm_b] = frame.channel_wavelengths_nm();
    let line = format!(
        "colour space: {name} ({how}); luminance = {r:.4} R + {g:.4} G + {b:.4} B; chromatic effects at \
         {nm_r:.1}, {nm_g:.1}, {nm_b:.1} nm (the primaries' dominant wavelengths)"
    );
    let wants_view = args.png.is_some() || args.display.is_some() || args.view.is_some();
    let display_view = match (&config, config_space) {
        (Some(config), Some(space)) if wants_view => {
            let key = (config.name.clone(), space.clone(), args.display.clone(), args.view.clone());
            Some(memo(&VIEW, key, || {
                config.display_view(&space, args.display.as_deref(), args.view.as_deref()).map_err(|e| {
                    let flag =
                        if matches!(e, ColourConfigError::UnknownDisplay { .. }) { "--display" } else { "--view" };
                    anyhow::Error::new(e).context(flag)
                })
            })?)
        }
        (Some(config), None) if args.display.is_some() || args.view.is_some() => bail!(
            "--display/--view: OpenColorIO config {} has no colour space of the input's primaries ({name}); \
             name it with --colorspace",
            config.name
        ),
        (None, _) if args.display.is_some() || args.view.is_some() => {
            bail!("--display/--view: no OpenColorIO config (--config FILE, $OCIO)")
        }
        _ => None,
    };
    Ok((line, display_view))
}

/// The OpenColorIO config and the preview's view of the run, made once: a sequence plans every
/// frame with the same ones (reading the config and building the view took about 18 ms a frame).
type Memo<K, V> = Mutex<Option<(K, Arc<V>)>>;
static CONFIG: Memo<String, ColourConfig> = Mutex::new(None);
static VIEW: Memo<(String, String, Option<String>, Option<String>), DisplayView> = Mutex::new(None);

/// `cell`'s value if it was made for `key`, else `make`'s, kept for the next call.
fn memo<K: PartialEq, V>(cell: &Memo<K, V>, key: K, make: impl FnOnce() -> Result<V>) -> Result<Arc<V>> {
    // A poisoned lock only means another thread panicked while holding it: make it again.
    let mut kept = cell.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((k, v)) = kept.as_ref() {
        if *k == key {
            return Ok(v.clone());
        }
    }
    let value = Arc::new(make()?);
    *kept = Some((key, value.clone()));
    Ok(value)
}

/// The same primaries and white within 1e-6 (a file stores them as 32-bit floats).
fn same_space(a: &Chromaticities, b: &Chromaticities) -> bool {
    let coords = |c: &Chromaticities| [c.red, c.green, c.blue, c.white].concat();
    coords(a).iter().zip(coords(b)).all(|(x, y)| (x - y).abs() < 1e-6)
}

fn indent(text: &str) -> String {
    text.lines().map(|l| format!("  {l}\n")).collect()
}
