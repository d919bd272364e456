//! The realcam command line. Only argument handling lives here; the work is in the library.

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use realcam::gpu::{Gpu, GpuOptions};
use realcam::io::lens_file::LensFile;
use realcam::io::{self, DepthKind, ExrWriteOptions, Image, PassSources};
use realcam::model::camera::{Camera, CameraRequest, FilmMode};
use realcam::model::frame::Frame;
use realcam::optics::dof::{dof_report, CocCriterion};
use realcam::optics::film::FilmCurve;
use realcam::optics::sensor::SensorFit;
use realcam::optics::{Sensor, ThinLens};
use realcam::pipeline::render::Renderer;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(name = "realcam", version, about = "A realistic camera for rendered images (Vulkan compute)")]
#[command(args_override_self = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render color + depth (+ velocity) EXR passes through a camera.
    Render(Box<RenderArgs>),
    /// Print focusing, field of view, exposure and depth-of-field numbers for a lens setting.
    Dof(DofArgs),
    /// List the Vulkan devices.
    Devices,
    /// Lenses: analyse a prescription by real ray tracing (paraxial data, distortion, field
    /// curves, spherical aberration, coma, relative illumination, colour) and write its tables
    /// into a lens file; import a lens from the lensfun database.
    Lens {
        #[command(subcommand)]
        command: LensCommand,
    },
    /// Every depth-of-field method on your frame against the diffraction reference: GPU time,
    /// RMSE, PSNR, energy and FLIP, as Markdown, CSV and an SVG plot of error against time.
    Accuracy(AccuracyArgs),
    /// GPU time per pass of the depth-of-field methods against the CoC radius (whole frame
    /// defocused), with the fast path's error against the reference.
    Bench(BenchArgs),
    /// Error of an image against a reference (RMSE, PSNR, energy), e.g. against a ray-traced
    /// ground truth.
    Compare {
        /// The image to judge (EXR).
        test: PathBuf,
        /// The reference (EXR).
        reference: PathBuf,
    },
    /// Write the deterministic synthetic test scenes (testdata/ is made with this).
    Synth {
        /// Output directory.
        #[arg(long, default_value = "testdata")]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum LensCommand {
    /// Analyze a prescription (a prescription file such as lenses/tessar-walch.toml, or a lens
    /// file with [[surface]] tables) by real ray tracing.
    Analyze {
        file: PathBuf,
        /// f-number to analyze at; default: the prescription's own stop.
        #[arg(long = "fstop")]
        f_number: Option<f64>,
        /// Field angles in degrees (the first must be 0 for --write-tables).
        #[arg(long = "field", default_value = "0,5,10,15,20", value_delimiter = ',')]
        field_deg: Vec<f64>,
        /// Write a lens file with the derived tables: FILE's own settings (or, for a bare
        /// prescription, ones derived from it) plus its surfaces, [tables] and
        /// [longitudinal_color] replaced by the traced values.
        #[arg(long = "write-tables", value_name = "LENS_FILE")]
        write_tables: Option<PathBuf>,
    },
    /// Convert a lens of the lensfun database (its distortion, lateral colour and vignetting
    /// calibrations) into a lens file: printed, or written with --out.
    ImportLensfun(ImportLensfunArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum FilmArg {
    /// The characteristic curve (toe, straight part, shoulder): display-referred.
    Filmic,
    /// A steeper curve with a harder shoulder (slide-film-like).
    Contrast,
    /// A flatter curve with a long toe and shoulder.
    Soft,
    /// Scene-referred linear sensor values, for compositing.
    Linear,
}

#[derive(Clone, Copy, ValueEnum)]
enum BokehArg {
    /// Tiled gather-scatter: cost nearly flat in the CoC radius.
    Tiled,
    /// Exact aperture sprite of every pixel (the geometric reference; cost grows with CoC^2).
    Reference,
    /// Potmesil & Chakravarty's diffraction focus processor (the accuracy reference; slow).
    Diffraction,
}

#[derive(Clone, Copy, ValueEnum)]
enum DepthKindArg {
    /// Distance along the view axis (Blender/Cycles Z).
    Planar,
    /// Distance from the camera along each pixel's ray.
    Ray,
}

#[derive(Clone, Copy, ValueEnum)]
enum FitArg {
    Horizontal,
    Vertical,
    Auto,
}

#[derive(Args)]
struct LensArgs {
    /// Lens file (TOML, see lenses/) or --lens-lensfun MODEL; the built-in default lens when absent.
    #[command(flatten)]
    lens: LensChoice,
    /// Focal length in mm (must match a prime lens file unless --force).
    #[arg(long = "focal-length")]
    focal_length_mm: Option<f64>,
    /// f-number N.
    #[arg(long = "fstop")]
    f_number: Option<f64>,
    /// Focus distance in metres (planar, from the lens).
    #[arg(long = "focus", default_value_t = 2.0)]
    focus_m: f64,
    /// Sensor: full-frame (36x24), super35, aps-c, aps-c-canon, m43, 1in, apsh, medium-format, or WxH in mm.
    #[arg(long, default_value = "full-frame")]
    sensor: String,
    /// Which image dimension the sensor width maps to (Blender's sensor fit).
    #[arg(long = "sensor-fit", value_enum, default_value = "horizontal")]
    sensor_fit: FitArg,
    /// Allow settings outside the lens file's range.
    #[arg(long)]
    force: bool,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct RenderArgs {
    /// Color pass (RGB/RGBA EXR), or a multilayer EXR with every pass.
    #[arg(long)]
    color: PathBuf,
    /// Depth pass EXR (a Z channel); default: look in the color file.
    #[arg(long)]
    depth: Option<PathBuf>,
    /// Velocity pass EXR; default: use one in the color file if present.
    #[arg(long)]
    velocity: Option<PathBuf>,
    #[command(flatten)]
    lens: LensArgs,
    /// Shutter time in seconds, e.g. 0.02 or 1/50.
    #[arg(long, default_value = "1/50")]
    shutter: String,
    #[arg(long, default_value_t = 100.0)]
    iso: f64,
    /// Luminance in cd/m^2 of a scene value of 1.0. The default exposes a scene value of 0.18 as
    /// ISO 12232 middle grey at 1/50 s, ISO 100, f/2.
    #[arg(long = "nits-per-unit", default_value_t = 160.0)]
    nits_per_unit: f64,
    /// Aperture blades (0 = circular); default from the lens file.
    #[arg(long)]
    blades: Option<u32>,
    /// Aperture rotation in degrees; default from the lens file.
    #[arg(long = "blade-rotation")]
    blade_rotation_deg: Option<f64>,
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
    /// Film response.
    #[arg(long, value_enum, default_value = "filmic")]
    film: FilmArg,
    /// A film file (TOML, see films/): its characteristic curve, parametric or tabled,
    /// instead of --film.
    #[arg(long = "film-file", value_name = "FILE")]
    film_file: Option<PathBuf>,
    /// Sensor noise at ISO 100 (standard deviation at sensor value 1, growing with sqrt(ISO)); 0: none.
    #[arg(long, default_value_t = 0.0)]
    grain: f64,
    /// Seed of the sensor noise (the same seed gives the same noise).
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Do not apply the exposure gain (ISO, shutter, f-number): sensor value = scene value.
    #[arg(long = "no-exposure")]
    no_exposure: bool,
    /// Do not apply natural (cos^4) vignetting.
    #[arg(long = "no-vignetting")]
    no_vignetting: bool,
    /// Clamp on the CoC diameter in pixels.
    #[arg(long = "max-coc", default_value_t = 64.0)]
    max_coc_px: f64,
    /// What the depth values measure.
    #[arg(long = "depth-kind", value_enum, default_value = "planar")]
    depth_kind: DepthKindArg,
    /// Metres per depth unit in the file (0.01 for centimetres).
    #[arg(long = "depth-unit", default_value_t = 1.0)]
    depth_unit_m: f64,
    /// Color channel override: a layer prefix (ViewLayer.Combined) or a list "R,G,B[,A]".
    #[arg(long = "color-channels")]
    color_channels: Option<String>,
    /// Depth channel override (exact name).
    #[arg(long = "depth-channel")]
    depth_channel: Option<String>,
    /// Velocity channel override: "x,y" or Blender "X,Y,Z,W".
    #[arg(long = "velocity-channels")]
    velocity_channels: Option<String>,
    /// Output EXR.
    #[arg(short, long)]
    output: PathBuf,
    /// Write 32-bit float EXR instead of half.
    #[arg(long)]
    float: bool,
    /// Also write an sRGB 8-bit PNG preview here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Print the planned passes and why each runs or is skipped.
    #[arg(long)]
    explain: bool,
    /// Print GPU time per pass (timestamp queries).
    #[arg(long)]
    profile: bool,
    /// Write the per-pass GPU times as a Chrome trace JSON (opens in Perfetto).
    #[arg(long)]
    trace: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
struct GpuArgs {
    /// Enable the Khronos validation layer with synchronization validation (also REALCAM_VALIDATE=1).
    #[arg(long)]
    validate: bool,
    /// Vulkan device: index from `realcam devices` or part of its name (also REALCAM_DEVICE).
    #[arg(long)]
    device: Option<String>,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct AccuracyArgs {
    /// Color pass (RGB/RGBA EXR), or a multilayer EXR with every pass.
    #[arg(long)]
    color: PathBuf,
    /// Depth pass EXR (a Z channel); default: look in the color file.
    #[arg(long)]
    depth: Option<PathBuf>,
    #[command(flatten)]
    lens: LensArgs,
    /// Aperture blades (0 = circular); default from the lens file.
    #[arg(long)]
    blades: Option<u32>,
    /// Clamp on the CoC diameter in pixels.
    #[arg(long = "max-coc", default_value_t = 64.0)]
    max_coc_px: f64,
    /// Folder for accuracy.md, accuracy.csv and accuracy.svg.
    #[arg(long = "out-dir", default_value = "accuracy")]
    out_dir: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
struct BenchArgs {
    /// Resolutions, e.g. 1280x720,1920x1080.
    #[arg(long, default_value = "1280x720,1920x1080", value_delimiter = ',')]
    resolutions: Vec<String>,
    /// Largest CoC radii in pixels.
    #[arg(long = "radii", default_value = "4,8,16,32,64", value_delimiter = ',')]
    radii_px: Vec<f64>,
    /// Timed runs per configuration (after one warm-up); the median is reported.
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Run the reference only up to this CoC radius (its cost grows with the radius squared).
    #[arg(long = "reference-max-radius", default_value_t = 16.0)]
    reference_max_radius_px: f64,
    /// Also write the Markdown table here.
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct DofArgs {
    #[command(flatten)]
    lens: LensArgs,
    /// CoC criterion: an image CoC in mm (e.g. 0.03mm) or an angular ratio like 1/1000 (Potmesil & Chakravarty).
    #[arg(long, default_value = "0.03mm")]
    coc: String,
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(*args),
        Command::Dof(args) => dof(args),
        Command::Devices => devices(),
        Command::Lens { command: LensCommand::Analyze { file, f_number, field_deg, write_tables } } => {
            lens_analyze(&file, f_number, &field_deg, write_tables.as_deref())
        }
        Command::Lens { command: LensCommand::ImportLensfun(args) } => lens_import_lensfun(&args),
        Command::Bench(args) => bench(args),
        Command::Accuracy(args) => accuracy(args),
        Command::Compare { test, reference } => compare(&test, &reference),
        Command::Synth { out } => synth(&out),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn parse_shutter(text: &str) -> Result<f64> {
    let value = match text.split_once('/') {
        Some((a, b)) => {
            let (a, b): (f64, f64) = (a.trim().parse()?, b.trim().parse()?);
            a / b
        }
        None => text.trim().parse()?,
    };
    if !(value.is_finite() && value > 0.0) {
        bail!("must be a positive time in seconds");
    }
    Ok(value)
}

fn load_lens(choice: &LensChoice) -> Result<LensFile> {
    Ok(match (&choice.lens, &choice.lens_lensfun) {
        (Some(p), _) => LensFile::load(p)?,
        (None, Some(model)) => {
            let options = realcam::io::lensfun::ImportOptions::default();
            realcam::io::lensfun::import_lens_file(model, &options, None)
                .with_context(|| format!("--lens-lensfun {model:?}"))?
        }
        (None, None) => LensFile::default_lens(),
    })
}

fn fit(arg: FitArg) -> SensorFit {
    match arg {
        FitArg::Horizontal => SensorFit::Horizontal,
        FitArg::Vertical => SensorFit::Vertical,
        FitArg::Auto => SensorFit::Auto,
    }
}

fn render(args: RenderArgs) -> Result<()> {
    let lens_file = load_lens(&args.lens.lens)?;
    let shutter_s = parse_shutter(&args.shutter).with_context(|| format!("--shutter {:?}", args.shutter))?;
    let request = CameraRequest {
        focal_length_mm: args.lens.focal_length_mm,
        f_number: args.lens.f_number,
        focus_distance_m: args.lens.focus_m,
        sensor: Some(args.lens.sensor.clone()),
        sensor_fit: Some(fit(args.lens.sensor_fit)),
        shutter_s,
        iso: args.iso,
        nits_per_unit: args.nits_per_unit,
        blades: args.blades,
        blade_rotation_deg: args.blade_rotation_deg,
        spherical_aberration: None,
        cats_eye: args.cats_eye,
        exposure: !args.no_exposure,
        vignetting: !args.no_vignetting,
        film: Some(match (&args.film_file, args.film) {
            (Some(path), _) => FilmMode::from_file(&realcam::io::film_file::FilmFile::load(path)?),
            (None, film) => match film {
                FilmArg::Filmic => FilmMode::Curve(FilmCurve::default_filmic()),
                FilmArg::Contrast => {
                    FilmMode::Curve(FilmCurve::preset("contrast").unwrap_or_else(FilmCurve::default_filmic))
                }
                FilmArg::Soft => FilmMode::Curve(FilmCurve::preset("soft").unwrap_or_else(FilmCurve::default_filmic)),
                FilmArg::Linear => FilmMode::Linear,
            },
        }),
        max_coc_px: args.max_coc_px,
        force: args.lens.force,
        bokeh: match args.bokeh {
            BokehArg::Tiled => realcam::model::camera::BokehMode::Tiled,
            BokehArg::Reference => realcam::model::camera::BokehMode::Reference,
            BokehArg::Diffraction => realcam::model::camera::BokehMode::Diffraction,
        },
    };
    let mut request = request;
    request.spherical_aberration = match args.spherical_aberration.as_deref() {
        None => None,
        Some("uniform") => Some(0.0),
        Some(text) => Some(
            text.trim()
                .parse::<f64>()
                .with_context(|| format!("--spherical-aberration {text:?}: a number in [-1, 1] or 'uniform'"))?,
        ),
    };
    let mut camera = Camera::new(&lens_file, &request)?;
    if !(args.grain.is_finite() && args.grain >= 0.0) {
        bail!("--grain must be a non-negative number, got {}", args.grain);
    }
    camera.grain = args.grain;
    camera.seed = args.seed;
    if let Some(path) = &args.aperture_image {
        camera.aperture_mask = Some(realcam::model::aperture::ApertureMask::load(path)?);
    }
    if !(args.depth_unit_m.is_finite() && args.depth_unit_m > 0.0) {
        bail!("--depth-unit must be a positive number of metres, got {}", args.depth_unit_m);
    }

    let sources = PassSources {
        color_path: args.color.clone(),
        depth_path: args.depth.clone(),
        velocity_path: args.velocity.clone(),
        color_channels: args.color_channels.clone(),
        depth_channel: args.depth_channel.clone(),
        velocity_channels: args.velocity_channels.clone(),
        depth_unit_m: args.depth_unit_m,
        require_velocity: args.velocity.is_some(),
    };
    let passes = io::load_passes(&sources)?;
    let depth_kind = match args.depth_kind {
        DepthKindArg::Planar => DepthKind::Planar,
        DepthKindArg::Ray => DepthKind::Ray,
    };
    let channel_report = passes.channel_report.clone();
    let frame = Frame::from_passes(passes, &camera, depth_kind);
    let plan = realcam::pipeline::planner::plan(&frame, &camera);
    if args.explain {
        eprintln!("inputs:\n{}", indent(&channel_report));
        eprintln!("{}", plan.explain());
    }

    let gpu = open_gpu(&args.gpu)?;
    let renderer = Renderer::new(&gpu, &plan)?;
    let rendered = renderer.render(&frame, &plan, false)?;
    if args.profile {
        eprint!("{}", rendered.profile.table());
    }
    if let Some(trace) = &args.trace {
        write_text_atomically(trace, &rendered.profile.chrome_trace_json())
            .with_context(|| format!("writing the trace {}", trace.display()))?;
    }
    if gpu.validation_message_count() > 0 {
        bail!("{} Vulkan validation messages (see above)", gpu.validation_message_count());
    }

    let image = Image { width: frame.width, height: frame.height, channels: 4, data: rendered.rgba };
    let exr_options = ExrWriteOptions {
        float32: args.float,
        display_window: Some(frame.display_window),
        data_origin: frame.data_origin,
        attributes: camera.attributes(),
    };
    io::write_exr_rgba(&args.output, &image, &exr_options)?;
    eprintln!("wrote {}", args.output.display());
    if let Some(png) = &args.png {
        io::write_png_srgb(png, &image)?;
        eprintln!("wrote {}", png.display());
    }
    Ok(())
}

/// The GPU, with validation and the device as the flags and the environment ask; prints it.
fn open_gpu(args: &GpuArgs) -> Result<Gpu> {
    let mut options = GpuOptions::from_env();
    options.validation |= args.validate;
    if args.device.is_some() {
        options.device = args.device.clone();
    }
    let gpu = Gpu::new(&options)?;
    eprintln!("device: {}", gpu.info());
    Ok(gpu)
}

fn indent(text: &str) -> String {
    text.lines().map(|l| format!("  {l}\n")).collect()
}

fn write_text_atomically(path: &Path, text: &str) -> std::io::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let tmp = dir.join(format!(".realcam-{}.tmp", std::process::id()));
    std::fs::write(&tmp, text).and_then(|_| std::fs::rename(&tmp, path)).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

fn dof(args: DofArgs) -> Result<()> {
    let lens_file = load_lens(&args.lens.lens)?;
    let f_number = args.lens.f_number.unwrap_or(lens_file.f_number_min);
    let focal_length_mm = args.lens.focal_length_mm.unwrap_or(lens_file.focal_length_mm);
    let lens = ThinLens::new(focal_length_mm, f_number, args.lens.focus_m * 1000.0)?
        .with_pupil_magnification(lens_file.pupil_magnification)?
        .with_transmittance(lens_file.transmittance)?;
    let sensor = Sensor::parse(&args.lens.sensor)?;
    let criterion = CocCriterion::parse(&args.coc)?;
    println!("lens: {}", lens_file.name);
    print!("{}", dof_report(&lens, &sensor, criterion));
    Ok(())
}

fn devices() -> Result<()> {
    for d in Gpu::list_devices()? {
        println!("[{}] {}", d.index, d);
    }
    Ok(())
}

fn synth(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    for (name, scene) in realcam::tools::synth::testdata_scenes() {
        realcam::tools::synth::write_scene(out, name, &scene)?;
        println!("wrote {0}/{name}_color.exr and {0}/{name}_depth.exr", out.display());
    }
    Ok(())
}

fn compare(test: &Path, reference: &Path) -> Result<()> {
    let a = io::read_exr_rgba(test)?;
    let b = io::read_exr_rgba(reference)?;
    if (a.width, a.height) != (b.width, b.height) {
        bail!(
            "size mismatch: {} is {}x{} px but {} is {}x{} px",
            test.display(),
            a.width,
            a.height,
            reference.display(),
            b.width,
            b.height
        );
    }
    let e = realcam::tools::metrics::compare_rgba(&a.data, &b.data);
    println!(
        "rmse {:.6}  rmse_display {:.6}  mean_abs {:.6}  psnr {:.2} dB  energy {:+.3}%",
        e.rmse,
        e.rmse_display,
        e.mean_abs,
        e.psnr_db,
        e.relative_energy_error * 100.0
    );
    Ok(())
}

fn bench(args: BenchArgs) -> Result<()> {
    let mut resolutions = Vec::new();
    for r in &args.resolutions {
        let parsed =
            r.split_once('x').and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
        match parsed {
            Some((w, h)) if w > 0 && h > 0 => resolutions.push((w, h)),
            _ => bail!("--resolutions: {r:?} is not WIDTHxHEIGHT"),
        }
    }
    let gpu = open_gpu(&args.gpu)?;
    let bench_options = realcam::tools::bench::BenchOptions {
        resolutions,
        radii_px: args.radii_px.clone(),
        runs: args.runs,
        reference_max_radius_px: args.reference_max_radius_px,
    };
    let total = (bench_options.resolutions.len() * bench_options.radii_px.len()) as u64;
    let bar = indicatif::ProgressBar::new(total * 2);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let rows = realcam::tools::bench::run(&gpu, &bench_options, |step| {
        bar.set_message(step.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let table = realcam::tools::bench::markdown(&gpu.info().to_string(), &command, &rows);
    print!("{table}");
    if let Some(out) = &args.out {
        write_text_atomically(out, &table).with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(())
}

fn accuracy(args: AccuracyArgs) -> Result<()> {
    let lens_file = load_lens(&args.lens.lens)?;
    // The blur alone: no exposure, vignetting or film curve; no aberrations in the bokeh, which
    // the diffraction reference does not model.
    let request = CameraRequest {
        focal_length_mm: args.lens.focal_length_mm,
        f_number: args.lens.f_number,
        focus_distance_m: args.lens.focus_m,
        sensor: Some(args.lens.sensor.clone()),
        sensor_fit: Some(fit(args.lens.sensor_fit)),
        shutter_s: 0.02,
        iso: 100.0,
        nits_per_unit: 160.0,
        blades: Some(args.blades.unwrap_or(0)),
        blade_rotation_deg: None,
        spherical_aberration: Some(0.0),
        cats_eye: Some(0.0),
        exposure: false,
        vignetting: false,
        film: Some(FilmMode::Linear),
        max_coc_px: args.max_coc_px,
        force: args.lens.force,
        bokeh: realcam::model::camera::BokehMode::Reference,
    };
    let camera = Camera::new(&lens_file, &request)?;
    let sources = PassSources {
        color_path: args.color.clone(),
        depth_path: args.depth.clone(),
        depth_unit_m: 1.0,
        ..Default::default()
    };
    let frame = Frame::from_passes(io::load_passes(&sources)?, &camera, DepthKind::Planar);
    let gpu = open_gpu(&args.gpu)?;
    let bar = indicatif::ProgressBar::new(7);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let results = realcam::tools::accuracy::run(&gpu, &frame, &camera, |m| {
        bar.set_message(m.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let device = gpu.info().to_string();
    let table = realcam::tools::accuracy::markdown(&device, &command, &results);
    print!("{table}");
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    for (name, text) in [
        ("accuracy.md", table.clone()),
        ("accuracy.csv", realcam::tools::accuracy::csv(&results)),
        ("accuracy.svg", realcam::tools::accuracy::svg(&device, &results)),
    ] {
        let path = args.out_dir.join(name);
        write_text_atomically(&path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    eprintln!("wrote {}/accuracy.{{md,csv,svg}}", args.out_dir.display());
    Ok(())
}

fn lens_analyze(file: &Path, f_number: Option<f64>, field_deg: &[f64], write_tables: Option<&Path>) -> Result<()> {
    use realcam::io::lens_file::LensFile;
    use realcam::optics::prescription::Prescription;
    let text =
        std::fs::read_to_string(file).with_context(|| format!("lens file {}: cannot read it", file.display()))?;
    // A lens file has a focal length; a bare prescription only a name, a source and surfaces.
    let is_lens_file = text.parse::<toml::Table>().is_ok_and(|t| t.contains_key("focal_length_mm"));
    let (prescription, lens) = if is_lens_file {
        let lens = LensFile::parse(&text, file)?;
        if lens.surfaces.is_empty() {
            bail!("lens file {}: it has no [[surface]] tables to analyze", file.display());
        }
        (lens.prescription(file, &text)?, Some(lens))
    } else {
        (Prescription::parse_toml(&text, &file.display().to_string())?, None)
    };
    let f_number = match f_number {
        Some(n) if n.is_finite() && n > 0.0 => n,
        Some(n) => bail!("--fstop must be a positive number, got {n}"),
        None => lens.as_ref().map_or_else(|| prescription.f_number_at_table_stop(), |l| l.f_number_min),
    };
    let analysis = prescription.analyze(f_number, field_deg);
    print!("{analysis}");
    if let Some(out) = write_tables {
        let derived = analysis.derived_tables().map_err(|e| anyhow!("--write-tables: {e}"))?;
        let new_text = realcam::io::lens_file::with_derived_tables(
            &text,
            lens.is_some(),
            &analysis,
            &derived,
            &file.display().to_string(),
        )
        .with_context(|| format!("--write-tables {}", out.display()))?;
        // Check what we write parses as a lens file before it replaces anything.
        LensFile::parse(&new_text, out)
            .with_context(|| format!("--write-tables {}: the derived file", out.display()))?;
        write_text_atomically(out, &new_text).with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// The lens of a command: a lens file, or a lens of the lensfun database.
#[derive(Args)]
struct LensChoice {
    /// Lens file (TOML, see lenses/); the built-in default lens when neither this nor
    /// --lens-lensfun is given.
    #[arg(long)]
    lens: Option<PathBuf>,
    /// A lens of the lensfun database by model name (as `realcam lens import-lensfun` converts
    /// it with its defaults; for a zoom, its shortest calibrated focal length).
    #[arg(long = "lens-lensfun", value_name = "MODEL", conflicts_with = "lens")]
    lens_lensfun: Option<String>,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct ImportLensfunArgs {
    /// The lens model as lensfun names it, e.g. "Carl Zeiss Planar T* 1,4/50 ZF.2" (case,
    /// ',' or '.' and spacing do not matter; the maker may be prefixed).
    model: String,
    /// Write the lens file here (atomically) instead of printing it.
    #[arg(long)]
    out: Option<PathBuf>,
    /// For a zoom: use the calibrations at the focal length nearest this (no interpolation);
    /// default the shortest.
    #[arg(long = "focal-length", value_name = "MM")]
    focal_length_mm: Option<f64>,
    /// Vignetting: per f-number, the calibration at the focus distance nearest this; default the farthest.
    #[arg(long = "distance-m", value_name = "M")]
    distance_m: Option<f64>,
    /// The widest f-number, when lensfun's entry and the model name do not give it (overrides them).
    #[arg(long = "f-number-min", value_name = "N")]
    f_number_min: Option<f64>,
    /// Closest focus in metres (not in lensfun; default 10 focal lengths, marked as assumed).
    #[arg(long = "focus-min-m", value_name = "M")]
    focus_min_m: Option<f64>,
    /// Aperture blades (not in lensfun; default 0, circular, marked as assumed).
    #[arg(long)]
    blades: Option<u32>,
    /// Diagonal of the sensor the tables are for, in mm; default full frame (43.27 mm).
    #[arg(long = "sensor-diagonal-mm", value_name = "MM")]
    sensor_diagonal_mm: Option<f64>,
    /// The lensfun database folder; default $REALCAM_LENSFUN_DIR or /usr/share/lensfun/version_1.
    #[arg(long = "lensfun-dir", value_name = "DIR")]
    lensfun_dir: Option<PathBuf>,
}

fn lens_import_lensfun(args: &ImportLensfunArgs) -> Result<()> {
    let options = realcam::io::lensfun::ImportOptions {
        focal_length_mm: args.focal_length_mm,
        distance_m: args.distance_m,
        f_number_min: args.f_number_min,
        focus_min_m: args.focus_min_m,
        blades: args.blades,
        sensor_diagonal_mm: args.sensor_diagonal_mm,
    };
    let imported = realcam::io::lensfun::import(&args.model, &options, args.lensfun_dir.as_deref())?;
    let crop = imported.entry.crop_factor.map_or_else(|| "not given".to_string(), |c| c.to_string());
    eprintln!("lensfun entry: {} (crop factor {crop})", imported.entry.at);
    for other in &imported.others {
        let crop = other.crop_factor.map_or_else(|| "not given".to_string(), |c| c.to_string());
        eprintln!("  not used: the same model at {} (crop factor {crop})", other.at);
    }
    match &args.out {
        Some(out) => {
            write_text_atomically(out, &imported.toml).with_context(|| format!("writing {}", out.display()))?;
            eprintln!("wrote {}", out.display());
        }
        None => print!("{}", imported.toml),
    }
    Ok(())
}
