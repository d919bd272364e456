//! `realcam accuracy`: every depth-of-field method on a frame against the diffraction reference.

use crate::common::{command_line, progress_bar, write_text, GpuArgs, LensArgs};
use crate::flags::NameFlags;
use anyhow::{Context, Result};
use clap::Args;
use realcam::io::{load_passes, DepthKind, PassSources};
use realcam::model::camera::{BokehMode, Camera, CameraRequest};
use realcam::model::frame::Frame;
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
    /// Clamp on the CoC diameter: on the film in mm (1.2mm) or in pixels (64, 64px).
    #[arg(long = "max-coc", default_value = "1.2mm")]
    max_coc: String,
    /// Folder for accuracy.md, accuracy.csv and accuracy.svg.
    #[arg(long = "out-dir", default_value = "accuracy")]
    out_dir: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub fn run(args: &AccuracyArgs) -> Result<()> {
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
    let bar = progress_bar(7);
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
