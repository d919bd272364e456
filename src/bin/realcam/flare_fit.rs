//! `realcam flare-fit`: a lens's ghosts traced over a range of angles (or photographed: a
//! folder of EXR captures, `--captures`), fitted as Walch's measured-ghost primitives and
//! written as the lens file's `[[fitted_ghost]]` section.

use crate::common::{progress_bar, LensArgs};
use anyhow::{Context, Result};
use clap::Args;
use realcam::io::lens_file::LensFileWriter;
use realcam::io::output::Outputs;
use realcam::model::camera::{Camera, CameraRequest};
use realcam::model::settings::parse_size_px;
use realcam::session::errors::NameFlags;
use realcam::tools::flare_fit::capture::folder::{fit_captures, CaptureFitOptions};
use realcam::tools::flare_fit::capture::Response;
use realcam::tools::flare_fit::{fit_traced_ghosts, FitOptions, FittedRange, TracedFitOptions};
use std::path::PathBuf;

#[derive(Args)]
pub struct FlareFitArgs {
    #[command(flatten)]
    lens: LensArgs,
    /// The lens file to write: the --lens file with its [[fitted_ghost]] section replaced
    /// (never the --lens file itself).
    #[arg(long)]
    out: PathBuf,
    /// Frame size in pixels (the fitted positions are of this frame).
    #[arg(long, default_value = "1280x720")]
    size: String,
    /// Angles of the light off the axis to trace and fit (degrees, towards +x).
    #[arg(long = "angles", default_value = "0,1,2,3,4,5,6,7,8,9,10,11,12", value_delimiter = ',')]
    angles_deg: Vec<f64>,
    /// Rays across the front lens per wavelength for the traced images.
    #[arg(long, default_value_t = 32)]
    rays: usize,
    /// Cells across a traced image at most (larger ghosts are fitted on coarser cells).
    #[arg(long, default_value_t = 24)]
    cells: u32,
    /// Order of each parameter's polynomial of the angle (Walch ch. 8).
    #[arg(long, default_value_t = 2)]
    order: usize,
    /// Channels to fit (0 red, 1 green, 2 blue).
    #[arg(long, default_value = "0,1,2", value_delimiter = ',')]
    channels: Vec<usize>,
    /// Ghosts to fit as FIRST/SECOND reflecting surfaces, e.g. 4/0,5/2; default all. With
    /// --captures: the labels of the --ghost-box regions, in order (default 1, 2, ...).
    #[arg(long, value_delimiter = ',')]
    ghosts: Vec<String>,
    /// Fit a folder of EXR captures of a point light instead of traced images: each file
    /// names its angle (capture_12.5deg.exr) and, in a bracket, its exposure
    /// (capture_12.5deg_0.25s.exr), or has a sidecar capture_12.5deg.exr.json with
    /// "angle_deg" and "exposure_s". Channels R, G, B, or one channel Y.
    #[arg(long)]
    captures: Option<PathBuf>,
    /// With --captures: a ghost's region X0,Y0,X1,Y1 in frame pixels, once per ghost (a
    /// capture holding several ghosts); the ghost is found within it at every angle. Default:
    /// one ghost anywhere in the frame.
    #[arg(long = "ghost-box")]
    ghost_boxes: Vec<String>,
    /// With --captures: the camera's response, recorded = exposure^(1/gamma) (1: linear raw).
    #[arg(long, default_value_t = 1.0)]
    gamma: f64,
    /// With --captures: recorded values at or above this are clipped (left out of the merge).
    #[arg(long, default_value_t = 1.0)]
    clip: f64,
    /// With --captures: the frame's border (px) whose median is the background, subtracted.
    #[arg(long = "background-border-px", default_value_t = 4)]
    background_border_px: usize,
    /// With --captures: the light's glare (about the brightest pixel) removed out to this
    /// radius (px); 0 removes none.
    #[arg(long = "glare-radius-px", default_value_t = 0.0)]
    glare_radius_px: f64,
}

fn ghost_label(text: &str) -> Result<(usize, usize)> {
    let parse = || {
        let (a, b) = text.split_once('/')?;
        Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
    };
    parse().with_context(|| format!("--ghosts: {text:?} is not FIRST/SECOND (e.g. 4/0)"))
}

pub fn run(args: &FlareFitArgs) -> Result<()> {
    let (width, height) = parse_size_px(&args.size).context("--size")?;
    let Some(lens_path) = args.lens.lens.lens.as_deref() else {
        anyhow::bail!("--lens: flare-fit needs a lens file with a [[surface]] prescription to write into")
    };
    // The output is checked (and kept apart from the input) before any work.
    let outputs = Outputs::new(&[("out", &args.out)], &[("lens", lens_path)]).context("--out")?;
    let lens_file = args.lens.lens.load()?;
    if args.captures.is_none() && lens_file.surfaces.is_empty() {
        anyhow::bail!("--lens: lens {:?} has no [[surface]] prescription to trace the ghosts through", lens_file.name);
    }
    if args.rays < 2 {
        anyhow::bail!("--rays must be at least 2, not {}", args.rays);
    }
    if let Some(c) = args.channels.iter().find(|&&c| c > 2) {
        anyhow::bail!("--channels: {c} is not 0 (red), 1 (green) or 2 (blue)");
    }
    if args.angles_deg.len() <= args.order {
        anyhow::bail!("--angles: {} angles cannot fit polynomials of --order {}", args.angles_deg.len(), args.order);
    }
    if let Some(dir) = &args.captures {
        return run_captures(args, dir, lens_path, outputs);
    }
    let ghosts = args.ghosts.iter().map(|g| ghost_label(g)).collect::<Result<Vec<_>>>()?;
    let request = args.lens.request(CameraRequest { flare: Some(true), ..CameraRequest::blur_only() });
    let camera = Camera::new(&lens_file, &request).name_flags()?;
    let options = TracedFitOptions {
        width,
        height,
        angles_deg: args.angles_deg.clone(),
        rays_across: args.rays,
        max_cells: args.cells.max(4),
        order: args.order,
        channels: args.channels.clone(),
        ghosts,
        fit: FitOptions::default(),
    };
    let bar = progress_bar(0);
    let fitted = fit_traced_ghosts(&camera, &options, |m| {
        bar.set_message(m.to_string());
        bar.inc(1);
    });
    bar.finish_and_clear();
    if fitted.is_empty() {
        anyhow::bail!("no ghost of {:?} was traced at enough of the angles to fit (try more --angles)", lens_file.name);
    }
    print_table(&fitted);
    let note = format!(
        "Fitted by realcam flare-fit to the ghosts traced at {:?} degrees on a {width}x{height} frame ({} rays across).",
        args.angles_deg, args.rays
    );
    write_fitted(args, lens_path, outputs, &fitted, &note)
}

fn print_table(fitted: &[FittedRange]) {
    println!("| ghost | channel | samples | fit RMSE/peak | fit energy | polynomial RMSE/peak | polynomial energy | centroid px |");
    println!("|---|---|---|---|---|---|---|---|");
    for f in fitted {
        println!(
            "| {} | {} | {} | {:.3} | {:.2}% | {:.3} | {:.2}% | {:.1} |",
            f.spec.ghost,
            f.spec.channel,
            f.samples,
            f.worst_fit_rmse_over_peak,
            100.0 * f.worst_fit_energy_error,
            f.worst_rmse_over_peak,
            100.0 * f.worst_energy_error,
            f.worst_centroid_px
        );
    }
    // Where the polynomials cannot represent the angles' own fits (ch. 8), say so by ghost.
    for warning in fitted.iter().filter_map(FittedRange::warning) {
        eprintln!("warning: {warning}");
    }
}

/// The --lens file with its [[fitted_ghost]] section replaced by `fitted`, written to --out.
fn write_fitted(
    args: &FlareFitArgs,
    lens_path: &std::path::Path,
    mut outputs: Outputs,
    fitted: &[FittedRange],
    note: &str,
) -> Result<()> {
    let text = std::fs::read_to_string(lens_path).with_context(|| format!("reading {}", lens_path.display()))?;
    let mut writer = LensFileWriter::edit(&text).with_context(|| format!("--lens {}", lens_path.display()))?;
    let specs: Vec<_> = fitted.iter().map(|f| f.spec.clone()).collect();
    writer.fitted_ghosts(&specs, Some(note));
    outputs.write("out", writer.finish().as_bytes())?;
    outputs.commit()?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

/// `X0,Y0,X1,Y1` with X0 < X1 and Y0 < Y1.
fn ghost_box(text: &str) -> Result<[f64; 4]> {
    let v: Option<Vec<f64>> = text.split(',').map(|n| n.trim().parse::<f64>().ok().filter(|x| x.is_finite())).collect();
    match v.as_deref() {
        Some(&[x0, y0, x1, y1]) if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        _ => anyhow::bail!("--ghost-box: {text:?} is not X0,Y0,X1,Y1 in frame pixels with X0 < X1 and Y0 < Y1"),
    }
}

/// `--captures`: the folder's captures fitted and written as the traced fits are.
fn run_captures(
    args: &FlareFitArgs,
    dir: &std::path::Path,
    lens_path: &std::path::Path,
    outputs: Outputs,
) -> Result<()> {
    if !(args.gamma.is_finite() && args.gamma > 0.0) {
        anyhow::bail!("--gamma must be above 0, not {}", args.gamma);
    }
    if !(args.clip.is_finite() && args.clip > 0.0) {
        anyhow::bail!("--clip must be above 0, not {}", args.clip);
    }
    if !(args.glare_radius_px.is_finite() && args.glare_radius_px >= 0.0) {
        anyhow::bail!("--glare-radius-px must be 0 or more, not {}", args.glare_radius_px);
    }
    let boxes = args.ghost_boxes.iter().map(|b| ghost_box(b)).collect::<Result<Vec<_>>>()?;
    if !args.ghosts.is_empty() && args.ghosts.len() != boxes.len().max(1) {
        anyhow::bail!(
            "--ghosts: {} labels for {} --ghost-box regions (one label each)",
            args.ghosts.len(),
            boxes.len()
        );
    }
    let label = |i: usize| args.ghosts.get(i).cloned().unwrap_or_else(|| (i + 1).to_string());
    let ghosts: Vec<(String, Option<[f64; 4]>)> = if boxes.is_empty() {
        vec![(label(0), None)]
    } else {
        boxes.iter().enumerate().map(|(i, b)| (label(i), Some(*b))).collect()
    };
    let options = CaptureFitOptions {
        response: Response { gamma: args.gamma, clip: args.clip },
        border_px: args.background_border_px,
        glare_radius_px: args.glare_radius_px,
        ghosts,
        channels: args.channels.clone(),
        max_cells: args.cells.max(4),
        order: args.order,
        fit: FitOptions::default(),
    };
    let bar = progress_bar(0);
    let found = fit_captures(dir, &options, |m| {
        bar.set_message(m.to_string());
        bar.inc(1);
    });
    bar.finish_and_clear();
    let found = found?;
    if found.fitted.is_empty() {
        anyhow::bail!(
            "--captures {}: no ghost was found at more than --order {} of the {} angles {:?} (a ghost needs order + 1)",
            dir.display(),
            args.order,
            found.angles_deg.len(),
            found.angles_deg
        );
    }
    print_table(&found.fitted);
    let note = format!(
        "Fitted by realcam flare-fit to {} captures in {} at {:?} degrees on a {}x{} frame (gamma {}, clip {}).",
        found.files,
        dir.display(),
        found.angles_deg,
        found.frame_px[0],
        found.frame_px[1],
        args.gamma,
        args.clip
    );
    write_fitted(args, lens_path, outputs, &found.fitted, &note)
}
