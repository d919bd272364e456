//! `realcam accuracy`: every depth-of-field method on a frame against the diffraction reference.

use crate::common::{command_line, progress_bar, write_text, GpuArgs, LensArgs};
use anyhow::{Context, Result};
use clap::Args;
use realcam::io::{load_passes, DepthKind, PassSources};
use realcam::model::camera::{BokehMode, Camera, CameraRequest};
use realcam::model::frame::Frame;
use realcam::session::errors::NameFlags;
use realcam::tools::accuracy::{csv, markdown, svg};
use std::path::PathBuf;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct AccuracyArgs {
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
    /// Clamp on the CoC diameter: `none` (the default, as `render`: every disc as large as the
    /// lens draws it), on the film in mm (1.2mm) or in pixels (64, 64px).
    #[arg(long = "max-coc", default_value = "none")]
    max_coc: String,
    /// Ray-traced ground truth (EXR of the frame's size): compare the pinhole input and the tiled
    /// and reference depth of field with it (energy-matched, clamped RMSE and its error budget;
    /// the share of 16-px tiles off by more than 5%, the worst tile, FLIP and the alpha)
    /// instead of running every method against the diffraction reference. The camera's lens
    /// and settings are used as given (e.g. --lens ideal). `realcam synth --layered SEED`
    /// writes a scene with its truth.
    #[arg(long = "ground-truth", visible_alias = "truth", value_name = "EXR")]
    ground_truth: Option<PathBuf>,
    /// Judge the motion blur instead: the pinhole input, a plain single-direction blur, the fast
    /// path and the reference against this ground truth (EXR), energy matched, values clamped at 4.
    #[arg(long = "motion-blur", value_name = "GROUND_TRUTH", conflicts_with = "ground_truth")]
    motion_ground_truth: Option<PathBuf>,
    /// Frames per second (with --motion-blur).
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// Shutter angle in degrees (with --motion-blur).
    #[arg(long = "shutter-angle", default_value_t = 180.0)]
    shutter_angle_deg: f64,
    /// Folder for accuracy.md, accuracy.csv and accuracy.svg.
    #[arg(long = "out-dir", default_value = "accuracy")]
    out_dir: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub fn run(args: &AccuracyArgs) -> Result<()> {
    if let Some(truth) = &args.motion_ground_truth {
        return motion(args, truth);
    }
    let lens_file = args.lens.lens.load()?;
    // The blur alone, on the geometric reference (the report runs every method).
    let max_coc = realcam::model::settings::parse_coc_limit(&args.max_coc)
        .with_context(|| format!("--max-coc {:?}", args.max_coc))?;
    let request = args.lens.request(CameraRequest {
        blades: Some(args.blades.unwrap_or(0)),
        max_coc,
        bokeh: BokehMode::Reference,
        ..CameraRequest::blur_only()
    });
    let camera = Camera::new(&lens_file, &request).name_flags()?;
    let sources = PassSources { depth_path: args.depth.clone(), ..PassSources::new(&args.color) };
    let frame = Frame::from_passes(load_passes(&sources).name_flags()?, &camera, DepthKind::Planar);
    let gpu = args.gpu.open()?;
    if let Some(path) = &args.ground_truth {
        let truth = read_ground_truth(path, &frame)?;
        let bar = progress_bar(2);
        let results = realcam::tools::accuracy::against_ground_truth(&gpu, &frame, &camera, &truth.data, |m| {
            bar.set_message(m.to_string());
            bar.inc(1);
        })?;
        bar.finish_and_clear();
        let table = realcam::tools::accuracy::ground_truth_markdown(&gpu.info().to_string(), &command_line(), &results);
        print!("{table}");
        std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
        write_text(&args.out_dir.join("ground-truth.md"), &table)?;
        return Ok(());
    }
    let bar = progress_bar(8);
    let results = realcam::tools::accuracy::run(&gpu, &frame, &camera, |m| {
        bar.set_message(m.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let device = gpu.info().to_string();
    let table = markdown(&device, &command_line(), &results);
    print!("{table}");
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    for (name, text) in
        [("accuracy.md", table.clone()), ("accuracy.csv", csv(&results)), ("accuracy.svg", svg(&device, &results))]
    {
        write_text(&args.out_dir.join(name), &text)?;
    }
    eprintln!("wrote {}/accuracy.{{md,csv,svg}}", args.out_dir.display());
    Ok(())
}

/// A ground truth of the frame's size.
fn read_ground_truth(path: &std::path::Path, frame: &Frame) -> Result<realcam::io::Image> {
    let truth = realcam::io::read_exr_rgba(path)?;
    if (truth.width, truth.height) != (frame.width, frame.height) {
        anyhow::bail!(
            "{} is {}x{} px but the frame is {}x{} px",
            path.display(),
            truth.width,
            truth.height,
            frame.width,
            frame.height
        );
    }
    Ok(truth)
}

/// `--motion-blur GROUND_TRUTH`: the motion-blur methods against a ground truth.
fn motion(args: &AccuracyArgs, truth: &std::path::Path) -> Result<()> {
    let lens_file = args.lens.lens.load()?;
    let request = args.lens.request(CameraRequest {
        max_coc: realcam::model::camera::CocLimit::Px(0.0),
        fps: Some(args.fps),
        shutter_angle_deg: Some(args.shutter_angle_deg),
        ..CameraRequest::blur_only()
    });
    let camera = Camera::new(&lens_file, &request).name_flags()?;
    let sources =
        PassSources { depth_path: args.depth.clone(), require_velocity: true, ..PassSources::new(&args.color) };
    let frame = Frame::from_passes(load_passes(&sources).name_flags()?, &camera, DepthKind::Planar);
    let reference = read_ground_truth(truth, &frame)?;
    let gpu = args.gpu.open()?;
    let rows = realcam::tools::bench_motion::accuracy(&gpu, &frame, &camera, &reference.data, |m| eprintln!("{m}"))?;
    let table = realcam::tools::bench_motion::accuracy_markdown(&gpu.info().to_string(), &command_line(), &rows);
    print!("{table}");
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    write_text(&args.out_dir.join("motion-accuracy.md"), &table)?;
    Ok(())
}
