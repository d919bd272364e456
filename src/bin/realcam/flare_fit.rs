//! `realcam flare-fit`: a lens's ghosts traced over a range of angles, fitted as Walch's
//! measured-ghost primitives and written as the lens file's `[[fitted_ghost]]` section.

use crate::common::{progress_bar, LensArgs};
use anyhow::{Context, Result};
use clap::Args;
use realcam::io::lens_file::LensFileWriter;
use realcam::io::output::Outputs;
use realcam::model::camera::{Camera, CameraRequest};
use realcam::model::settings::parse_size_px;
use realcam::session::errors::NameFlags;
use realcam::tools::flare_fit::{fit_traced_ghosts, FitOptions, TracedFitOptions};
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
    /// Ghosts to fit as FIRST/SECOND reflecting surfaces, e.g. 4/0,5/2; default all.
    #[arg(long, value_delimiter = ',')]
    ghosts: Vec<String>,
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
    let mut outputs = Outputs::new(&[("out", &args.out)], &[("lens", lens_path)]).context("--out")?;
    let lens_file = args.lens.lens.load()?;
    if lens_file.surfaces.is_empty() {
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
    println!("| ghost | channel | samples | fit RMSE/peak | fit energy | polynomial RMSE/peak | polynomial energy | centroid px |");
    println!("|---|---|---|---|---|---|---|---|");
    for f in &fitted {
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
    let text = std::fs::read_to_string(lens_path).with_context(|| format!("reading {}", lens_path.display()))?;
    let mut writer = LensFileWriter::edit(&text).with_context(|| format!("--lens {}", lens_path.display()))?;
    let specs: Vec<_> = fitted.iter().map(|f| f.spec.clone()).collect();
    let note = format!(
        "Fitted by realcam flare-fit to the ghosts traced at {:?} degrees on a {width}x{height} frame ({} rays across).",
        args.angles_deg, args.rays
    );
    writer.fitted_ghosts(&specs, Some(&note));
    outputs.write("out", writer.finish().as_bytes())?;
    outputs.commit()?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
