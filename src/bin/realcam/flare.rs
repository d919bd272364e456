//! `realcam flare`: the ghost models of the lens flare against the traced reference (error and
//! time side by side).

use crate::common::{command_line, progress_bar, write_text, GpuArgs, LensArgs};
use anyhow::{Context, Result};
use clap::Args;
use realcam::model::camera::{Camera, CameraRequest};
use realcam::model::settings::parse_size_px;
use realcam::session::errors::NameFlags;
use realcam::tools::accuracy_flare::{markdown, run as run_report, FlareAccuracyOptions};
use std::path::PathBuf;

#[derive(Args)]
pub struct FlareArgs {
    #[command(flatten)]
    lens: LensArgs,
    /// Frame size in pixels.
    #[arg(long, default_value = "1280x720")]
    size: String,
    /// Angles of the point light off the axis (degrees, towards the upper right corner).
    #[arg(long = "angles", default_value = "0,1,2,4,8", value_delimiter = ',')]
    angles_deg: Vec<f64>,
    /// Rays across the front lens per wavelength for the traced reference.
    #[arg(long, default_value_t = 64)]
    rays: usize,
    /// Timed GPU runs per angle (after one warm-up); the median is reported.
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Folder for flare-accuracy.md.
    #[arg(long = "out-dir", default_value = "accuracy")]
    out_dir: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub fn run(args: &FlareArgs) -> Result<()> {
    let (width, height) = parse_size_px(&args.size).context("--size")?;
    let lens_file = args.lens.lens.load()?;
    if lens_file.surfaces.is_empty() {
        anyhow::bail!(
            "--lens: lens {:?} has no [[surface]] prescription, and the ghosts are traced through one (e.g. --lens lenses/tessar-walch-lens.toml)",
            lens_file.name
        );
    }
    if args.rays < 2 {
        anyhow::bail!("--rays must be at least 2, not {}", args.rays);
    }
    let request = args.lens.request(CameraRequest { flare: Some(true), ..CameraRequest::blur_only() });
    let camera = Camera::new(&lens_file, &request).name_flags()?;
    if let Some(g) = lens_file.fitted_ghosts.iter().find(|g| g.frame_px != [width, height]) {
        anyhow::bail!(
            "--size {width}x{height}: fitted_ghost {:?} of the lens is of a {}x{} frame (fit again with flare-fit --size)",
            g.ghost,
            g.frame_px[0],
            g.frame_px[1]
        );
    }
    let gpu = args.gpu.open()?;
    let options = FlareAccuracyOptions {
        width,
        height,
        angles_deg: args.angles_deg.clone(),
        rays_across: args.rays,
        runs: args.runs,
        fitted: lens_file.fitted_ghosts.clone(),
    };
    let bar = progress_bar(2 * options.angles_deg.len() as u64);
    let rows = run_report(&gpu, &camera, &options, |m| {
        bar.set_message(m.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let table = markdown(&gpu.info().to_string(), &command_line(), &lens_file.name, &options, &rows);
    print!("{table}");
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    write_text(&args.out_dir.join("flare-accuracy.md"), &table)?;
    Ok(())
}
