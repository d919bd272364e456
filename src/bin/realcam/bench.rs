//! `realcam bench`: GPU time per pass of the depth-of-field methods against the CoC radius (or
//! of the motion blur, `--motion-blur`, or of the lens flare, `--flare`), or a frame sequence's
//! throughput against one process per frame (`--sequence`).

use crate::common::{command_line, progress_bar, write_text, GpuArgs};
use anyhow::{Context, Result};
use clap::Args;
use realcam::model::settings::parse_size_px;
use realcam::tools::bench::{markdown, BenchOptions};
use std::path::PathBuf;

#[derive(Args)]
pub struct BenchArgs {
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
    /// Benchmark the motion blur instead (against the longest blur, --blur).
    #[arg(long = "motion-blur")]
    motion_blur: bool,
    /// Run the motion-blur reference only up to this blur (px; its cost grows with the blur).
    #[arg(long = "reference-max-blur", default_value_t = 8.0)]
    reference_max_blur_px: f64,
    /// Longest motion blurs in pixels (with --motion-blur).
    #[arg(long = "blur", default_value = "8,32,128", value_delimiter = ',')]
    blurs_px: Vec<f64>,
    /// Benchmark the lens flare instead (the Tessar's ghosts, starburst and halo for --lights
    /// lights found in the frame).
    #[arg(long, conflicts_with = "motion_blur")]
    flare: bool,
    /// Numbers of lights in the frame (with --flare).
    #[arg(long = "lights", default_value = "1,4,16", value_delimiter = ',')]
    light_counts: Vec<usize>,
    /// Benchmark a frame sequence instead: --frames frames of the first of --resolutions as one
    /// `render --frames` process against one process per frame (wall time, frames per second).
    #[arg(long, conflicts_with_all = ["motion_blur", "flare"])]
    sequence: bool,
    /// Frames of the sequence (with --sequence).
    #[arg(long, default_value_t = 24)]
    frames: usize,
    /// More `render` flags for both sides of --sequence, in one argument (e.g. "--no-flare").
    #[arg(long, requires = "sequence", allow_hyphen_values = true)]
    render_flags: Option<String>,
    /// Also write the Markdown table here.
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let resolutions =
        args.resolutions.iter().map(|r| parse_size_px(r).context("--resolutions")).collect::<Result<Vec<_>>>()?;
    let gpu = args.gpu.open()?;
    let table = if args.sequence {
        use realcam::tools::bench_sequence::{markdown, run, SequenceBenchOptions};
        let &(width, height) = resolutions.first().context("--resolutions: none given")?;
        let dir = std::env::temp_dir().join(format!("realcam-bench-sequence-{}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let realcam = std::env::current_exe().context("the realcam executable")?;
        let render_flags = args.render_flags.iter().flat_map(|f| f.split_whitespace()).map(String::from).collect();
        let options =
            SequenceBenchOptions { width, height, frames: args.frames, runs: args.runs, realcam, dir, render_flags };
        let steps = 2 * (args.runs.max(1) + 1) + 2;
        let row = with_progress(steps.div_ceil(2), |step| run(&gpu, &options, step));
        let _ = std::fs::remove_dir_all(&options.dir);
        markdown(&gpu.info().to_string(), &command_line(), &row?)
    } else if args.flare {
        use realcam::tools::bench_flare::{markdown, run, FlareBenchOptions};
        let options = FlareBenchOptions { resolutions, light_counts: args.light_counts.clone(), runs: args.runs };
        // Two progress steps per configuration: the bare pass and each light count are one each.
        let steps = (options.resolutions.len() * (options.light_counts.len() + 1)).div_ceil(2);
        let rows = with_progress(steps, |step| run(&gpu, &options, step))?;
        markdown(&gpu.info().to_string(), &command_line(), &rows)
    } else if args.motion_blur {
        use realcam::tools::bench_motion::{markdown, run, MotionBenchOptions};
        let options = MotionBenchOptions {
            resolutions,
            blurs_px: args.blurs_px.clone(),
            runs: args.runs,
            reference_max_blur_px: args.reference_max_blur_px,
        };
        let steps = options.resolutions.len() * options.blurs_px.len();
        let rows = with_progress(steps, |step| run(&gpu, &options, step))?;
        markdown(&gpu.info().to_string(), &command_line(), &rows)
    } else {
        let options = BenchOptions {
            resolutions,
            radii_px: args.radii_px.clone(),
            runs: args.runs,
            reference_max_radius_px: args.reference_max_radius_px,
        };
        let steps = options.resolutions.len() * options.radii_px.len();
        let rows = with_progress(steps, |step| realcam::tools::bench::run(&gpu, &options, step))?;
        markdown(&gpu.info().to_string(), &command_line(), &rows)
    };
    print!("{table}");
    if let Some(out) = &args.out {
        write_text(out, &table)?;
    }
    Ok(())
}

/// Run a benchmark of `configurations` (two steps each) with a progress bar.
fn with_progress<T, E: std::error::Error + Send + Sync + 'static>(
    configurations: usize,
    bench: impl FnOnce(&mut dyn FnMut(&str)) -> Result<T, E>,
) -> Result<T> {
    let bar = progress_bar(configurations as u64 * 2);
    let rows = bench(&mut |step: &str| {
        bar.set_message(step.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    Ok(rows)
}
