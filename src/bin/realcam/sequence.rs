//! `realcam render --frames RANGE`: a frame sequence through one GPU and one set of pipelines,
//! every path carrying the frame number (`realcam::io::sequence`), progress for people and
//! render farms.

use crate::common::progress_bar;
use crate::render::{
    load_frame, output_attributes, render_loaded, write_outputs, LoadedFrame, RenderArgs, RenderedFrame, Session,
};
use anyhow::{bail, Context, Result};
use clap::Args;
use realcam::io::output::Outputs;
use realcam::io::sequence::{FramePattern, FrameRange, IoPriority};
use realcam::io::ExrWriteOptions;
use realcam::model::camera::Camera;
use realcam::model::long_exposure::LongExposure;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver};
use std::time::Instant;

#[derive(Args, Clone, Default)]
pub struct SequenceArgs {
    /// Render a frame sequence: 1001-1100, 1001-1100x2 (every 2nd; 1001-1100:2 alike),
    /// 1001,1005,1010-1020, -5--1.
    /// The paths of --color, --depth, --velocity, --output, --png and --trace carry the frame
    /// number as #### (one digit per #; @ alike) or %04d; an input without one is every frame's.
    #[arg(long, value_name = "RANGE", allow_hyphen_values = true)]
    pub frames: Option<String>,
    /// Render one chunk of --frames: the environment variable VAR holds the chunk's index from 0
    /// (a farm array task: SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX, ...).
    #[arg(long = "frames-from-env", value_name = "VAR", requires = "frames")]
    pub frames_from_env: Option<String>,
    /// Frames per chunk of --frames-from-env.
    #[arg(long = "chunk-size", value_name = "N", default_value_t = 1)]
    pub chunk_size: usize,
    /// Skip a frame whose outputs all exist (to resume an interrupted sequence).
    #[arg(long = "skip-existing", requires = "frames")]
    pub skip_existing: bool,
    /// Stop at the first frame that fails (by default it is reported and the others go on).
    #[arg(long = "fail-fast", requires = "frames")]
    pub fail_fast: bool,
    /// Accumulate the frames of --frames into one exposure, the average of their light (Kyaw
    /// 2013 sec. 7.4) as sensor values, then exposed on the film once (its grain and curve),
    /// written to --output (a path without a frame number).
    #[arg(long = "long-exposure", requires = "frames", conflicts_with = "skip_existing")]
    pub long_exposure: bool,
    /// The long exposure's state: written (atomically) after every frame, read at the start,
    /// so that a stopped exposure resumes where it was (the frames in it are not rendered again).
    #[arg(long, value_name = "FILE", requires = "long_exposure")]
    pub state: Option<PathBuf>,
}

/// The frames to render: --frames, or its chunk that --frames-from-env names.
fn frames(args: &SequenceArgs) -> Result<FrameRange> {
    let text = args.frames.as_deref().unwrap_or_default();
    let range = FrameRange::parse(text).context("--frames")?;
    let Some(var) = &args.frames_from_env else { return Ok(range) };
    let value = std::env::var(var)
        .map_err(|_| anyhow::anyhow!("--frames-from-env: the environment variable {var} is not set"))?;
    let index: u64 = value.trim().parse().map_err(|_| {
        anyhow::anyhow!("--frames-from-env: {var}={value:?} is not a chunk index (a whole number from 0)")
    })?;
    range.chunk(index, args.chunk_size).context("--frames-from-env")
}

/// The path patterns of a sequence: each path flag's pattern, or None for a path without a
/// frame number.
struct Patterns {
    color: Option<FramePattern>,
    depth: Option<FramePattern>,
    velocity: Option<FramePattern>,
    output: Option<FramePattern>,
    png: Option<FramePattern>,
    trace: Option<FramePattern>,
}

impl Patterns {
    /// The patterns of `args`' paths; an output without a frame number is refused (every frame
    /// would write over it), and with one for a long exposure (one file).
    fn new(args: &RenderArgs) -> Result<Patterns> {
        let one_output = args.sequence.long_exposure;
        let parse = |flag: &str, path: Option<&std::path::Path>| -> Result<Option<FramePattern>> {
            match path {
                Some(path) => FramePattern::parse(path).with_context(|| flag.to_string()),
                None => Ok(None),
            }
        };
        let output = |flag: &str, path: Option<&std::path::Path>| -> Result<Option<FramePattern>> {
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
        Ok(Patterns {
            color: parse("--color", Some(&args.color))?,
            depth: parse("--depth", args.depth.as_deref())?,
            velocity: parse("--velocity", args.velocity.as_deref())?,
            output: output("--output", Some(&args.output))?,
            png: output("--png", args.png.as_deref())?,
            trace: output("--trace", args.trace.as_deref())?,
        })
    }

    /// `args` with the paths of `frame`.
    fn frame_args(&self, args: &RenderArgs, frame: i64) -> RenderArgs {
        let at = |pattern: &Option<FramePattern>, path: &PathBuf| {
            pattern.as_ref().map_or_else(|| path.clone(), |p| p.path(frame))
        };
        let at_opt =
            |pattern: &Option<FramePattern>, path: &Option<PathBuf>| path.as_ref().map(|path| at(pattern, path));
        let mut one = args.clone();
        one.color = at(&self.color, &args.color);
        one.depth = at_opt(&self.depth, &args.depth);
        one.velocity = at_opt(&self.velocity, &args.velocity);
        one.output = at(&self.output, &args.output);
        one.png = at_opt(&self.png, &args.png);
        one.trace = at_opt(&self.trace, &args.trace);
        one
    }
}

/// Progress: a bar on a terminal; otherwise, after each frame, the lines render-farm managers
/// read (Open Job Description / AWS Deadline Cloud, Tractor, Deadline 10 and others).
enum Progress {
    Bar(indicatif::ProgressBar),
    Lines { total: usize, finished: usize },
}

impl Progress {
    fn new(total: usize) -> Progress {
        if std::io::stderr().is_terminal() {
            Progress::Bar(progress_bar(total as u64))
        } else {
            Progress::Lines { total, finished: 0 }
        }
    }

    /// Says `line` above the bar (or as a line).
    fn say(&self, line: &str) {
        match self {
            Progress::Bar(bar) => bar.println(line),
            Progress::Lines { .. } => eprintln!("{line}"),
        }
    }

    /// One more frame finished (rendered, skipped or failed).
    fn frame_finished(&mut self, frame: i64) {
        match self {
            Progress::Bar(bar) => {
                bar.set_message(format!("frame {frame}"));
                bar.inc(1);
            }
            Progress::Lines { total, finished } => {
                *finished += 1;
                let percent = farm_percent(*finished, *total);
                eprintln!("openjd_progress: {percent}\nALF_PROGRESS {percent}%\nProgress: {percent}%");
            }
        }
    }

    fn finish(&self) {
        if let Progress::Bar(bar) = self {
            bar.finish_and_clear();
        }
    }
}

/// Whole percent of `finished` of `total` frames, rounded down (100 only when all are).
fn farm_percent(finished: usize, total: usize) -> usize {
    (finished * 100).checked_div(total).unwrap_or(100)
}

/// A frame of the sequence as the reader thread hands it on: its arguments and its passes read
/// and planned, or None for a frame it was told to skip.
struct ReadFrame {
    frame: i64,
    args: RenderArgs,
    loaded: Option<Result<LoadedFrame>>,
}

/// Reads the frames of `jobs` (frame, its arguments, whether to skip it) in order on a thread of
/// `scope`, at most two frames ahead of the receiver (one in the channel, one being read), so
/// that the next frame's EXRs are read while the GPU renders this one. Stops when `stop` is set
/// or the receiver is gone.
fn read_ahead<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    jobs: Vec<(i64, RenderArgs, bool)>,
    camera: &'scope Camera,
    stop: &'scope AtomicBool,
    priority: &'scope IoPriority,
) -> Receiver<ReadFrame> {
    let (send, receive) = sync_channel(1);
    scope.spawn(move || {
        let mut lowered = false;
        for (frame, args, skip) in jobs {
            priority.before_frame(&mut lowered);
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let loaded = (!skip).then(|| load_frame(&args, camera));
            if send.send(ReadFrame { frame, args, loaded }).is_err() {
                break;
            }
        }
    });
    receive
}

/// What the render loop hands the writer thread, in frame order.
enum Finished {
    Skipped { frame: i64, output: PathBuf },
    Failed { frame: i64, error: anyhow::Error },
    Rendered { frame: i64, args: Box<RenderArgs>, outputs: Outputs, rendered: Box<RenderedFrame> },
}

/// The frames the writer thread counted.
#[derive(Default)]
struct Tally {
    done: usize,
    skipped: usize,
    failed: Vec<i64>,
}

/// The writer thread: writes each rendered frame's outputs (atomically, as a single frame's)
/// while the GPU renders the next, and reports every frame in order: its line, then the
/// progress. With `fail_fast`, the first failure sets `stop` and the frames after it are
/// dropped unwritten (their temporaries removed).
fn write_behind(
    finished: Receiver<Finished>,
    total: usize,
    fail_fast: bool,
    stop: &AtomicBool,
    priority: &IoPriority,
) -> Tally {
    let mut progress = Progress::new(total);
    let mut tally = Tally::default();
    let mut lowered = false;
    for item in finished {
        priority.before_frame(&mut lowered);
        if fail_fast && !tally.failed.is_empty() {
            continue;
        }
        let frame = match item {
            Finished::Skipped { frame, output } => {
                tally.skipped += 1;
                progress.say(&format!("frame {frame}: skipped, {} exists", output.display()));
                frame
            }
            Finished::Failed { frame, error } => {
                tally.failed.push(frame);
                progress.say(&format!("error: frame {frame}: {}", crate::error_text(&error)));
                frame
            }
            Finished::Rendered { frame, args, outputs, rendered } => {
                match write_outputs(&args, outputs, &rendered) {
                    Ok(paths) => {
                        tally.done += 1;
                        let paths: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
                        progress.say(&format!("frame {frame}: wrote {}", paths.join(", ")));
                    }
                    Err(error) => {
                        tally.failed.push(frame);
                        progress.say(&format!("error: frame {frame}: {}", crate::error_text(&error)));
                    }
                }
                frame
            }
        };
        progress.frame_finished(frame);
        if fail_fast && !tally.failed.is_empty() {
            stop.store(true, Ordering::Relaxed);
        }
    }
    progress.finish();
    tally
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let range = frames(&args.sequence)?;
    let patterns = Patterns::new(args)?;
    let camera = args.camera()?;
    if args.sequence.long_exposure {
        return long_exposure(args, &range, &patterns, &camera);
    }
    // The first frame's outputs are checked (folders, inputs, each other) before any work.
    if let Some(&first) = range.frames.first() {
        drop(patterns.frame_args(args, first).outputs()?);
    }
    let started = Instant::now();
    let total = range.frames.len();
    let jobs: Vec<(i64, RenderArgs, bool)> = range
        .frames
        .iter()
        .map(|&frame| {
            let one = patterns.frame_args(args, frame);
            let skip = args.sequence.skip_existing && one.output_paths().iter().all(|p| p.exists());
            (frame, one, skip)
        })
        .collect();
    let fail_fast = args.sequence.fail_fast;
    let stop = AtomicBool::new(false);
    // The reading and writing threads yield to a GPU that runs on the CPU (io::sequence).
    let priority = IoPriority::default();
    let tally = std::thread::scope(|scope| {
        let read = read_ahead(scope, jobs, &camera, &stop, &priority);
        let (finish, finished) = sync_channel(1);
        let writer = scope.spawn(|| write_behind(finished, total, fail_fast, &stop, &priority));
        let mut session = Session::opening(args, &camera);
        for ReadFrame { frame, args: one, loaded } in read {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let item = match loaded {
                None => Finished::Skipped { frame, output: one.output.clone() },
                Some(loaded) => {
                    let rendered = loaded.and_then(|loaded| {
                        let outputs = one.outputs()?;
                        Ok((outputs, render_loaded(&one, &camera, loaded, &mut session)?))
                    });
                    if let Some(gpu) = session.gpu() {
                        priority.device_opened(gpu.info().on_cpu());
                    }
                    match rendered {
                        Ok((outputs, rendered)) => {
                            Finished::Rendered { frame, args: Box::new(one), outputs, rendered: Box::new(rendered) }
                        }
                        Err(error) => Finished::Failed { frame, error },
                    }
                }
            };
            let failed = matches!(item, Finished::Failed { .. });
            if finish.send(item).is_err() || (fail_fast && failed) {
                stop.store(true, Ordering::Relaxed);
                break;
            }
        }
        drop(finish);
        writer.join().map_err(|_| anyhow::anyhow!("the thread writing the frames' outputs panicked"))
    })?;
    summary(tally.done, tally.skipped, tally.failed.len(), total, started, "(--fail-fast)");
    if !tally.failed.is_empty() {
        let list: Vec<String> = tally.failed.iter().map(i64::to_string).collect();
        bail!("{} of {total} frames failed: {}", tally.failed.len(), list.join(", "));
    }
    Ok(())
}

/// The summary line: frames done, skipped, failed and not run (`why`), wall time, frames per second.
fn summary(done: usize, skipped: usize, failed: usize, total: usize, started: Instant, why: &str) {
    let wall_s = started.elapsed().as_secs_f64();
    let not_run = total - done - skipped - failed;
    eprintln!(
        "frames: {done} done, {skipped} skipped, {failed} failed{} of {total} in {wall_s:.1} s ({:.2} frames/s)",
        if not_run > 0 { format!(", {not_run} not run {why}") } else { String::new() },
        if wall_s > 0.0 { done as f64 / wall_s } else { 0.0 }
    );
}

/// `--long-exposure`: the frames of `range` rendered and accumulated into one exposure, written
/// only when every frame was.
fn long_exposure(args: &RenderArgs, range: &FrameRange, patterns: &Patterns, camera: &Camera) -> Result<()> {
    if args.trace.is_some() {
        bail!("--trace: GPU times are per frame; --long-exposure writes no trace");
    }
    let outputs = args.outputs()?;
    let state = args.sequence.state.as_deref();
    // The frames are rendered up to the sensor and averaged; the film comes once, after.
    let sensor = realcam::pipeline::planner::sensor_camera(camera);
    // Every setting of the camera, so a resumed exposure is refused other settings.
    let settings = format!("{sensor:?}");
    let mut exposure = match state.filter(|p| p.exists()) {
        Some(path) => read_state(path, range, &settings)?,
        None => LongExposure::new(&settings),
    };
    let started = Instant::now();
    let total = range.frames.len();
    let mut progress = Progress::new(total);
    let mut exr_options = None;
    let mut working_space = realcam::optics::colour::Chromaticities::REC709;
    let mut display_view = None;
    let mut failed = None;
    let mut skipped = 0;
    let jobs = range.frames.iter().map(|&f| (f, patterns.frame_args(args, f), exposure.has(f))).collect();
    let stop = AtomicBool::new(false);
    let priority = IoPriority::default();
    let mut session = Session::opening(args, &sensor);
    std::thread::scope(|scope| {
        // The next frame is read while this one renders; accumulating is quick beside both.
        let read = read_ahead(scope, jobs, &sensor, &stop, &priority);
        for ReadFrame { frame, args: one, loaded } in read {
            let Some(loaded) = loaded else {
                skipped += 1;
                progress.say(&format!("frame {frame}: already in the exposure (--state)"));
                progress.frame_finished(frame);
                continue;
            };
            let rendered = loaded.and_then(|loaded| render_loaded(&one, &sensor, loaded, &mut session));
            if let Some(gpu) = session.gpu() {
                priority.device_opened(gpu.info().on_cpu());
            }
            let added = rendered.and_then(|rendered| {
                exposure.add(frame, &rendered.image)?;
                exr_options = Some(rendered.exr_options);
                working_space = rendered.working_space;
                display_view = rendered.display_view;
                if let Some(path) = state {
                    realcam::io::output::write_file("state", path, &exposure.to_bytes()).context("--state")?;
                }
                Ok(())
            });
            if let Err(e) = added {
                progress.say(&format!("error: frame {frame}: {}", crate::error_text(&e)));
                failed = Some(frame);
            }
            progress.frame_finished(frame);
            if failed.is_some() {
                stop.store(true, Ordering::Relaxed);
                break;
            }
        }
    });
    progress.finish();
    let done = exposure.frames() as usize - skipped;
    summary(done, skipped, usize::from(failed.is_some()), total, started, "(the exposure stopped)");
    if let Some(frame) = failed {
        bail!("frame {frame} failed: the long exposure of {total} frames is not written");
    }
    // The frames were rendered to sensor values and averaged; the film comes once, now: on
    // the GPU into the EXR with --film-in-exr, else only into the PNG preview (the EXR stays
    // scene-referred). The header names the camera's film, not the sensor's.
    let average = exposure.image()?;
    let image = if camera.film_on_output { session.expose_on_film(args, camera, average)? } else { average };
    let preview = args.png.as_ref().map(|_| realcam::io::Image {
        data: realcam::pipeline::render::preview_rgba(
            camera,
            &working_space,
            &image.data,
            image.width,
            display_view.as_deref(),
        ),
        ..image.clone()
    });
    let attributes = output_attributes(camera, image.width, image.height, &working_space);
    let exr_options = ExrWriteOptions { attributes, ..exr_options.unwrap_or_default() };
    let rendered = RenderedFrame {
        image,
        preview,
        kept_channels: Vec::new(),
        exr_options,
        working_space,
        display_view,
        profile: Default::default(),
    };
    for path in write_outputs(args, outputs, &rendered)? {
        eprintln!("wrote {} (a long exposure of {} frames)", path.display(), exposure.frames());
    }
    Ok(())
}

/// The state of a stopped long exposure, all of whose frames are in `range`, made with
/// `settings` (a version 1 state has none and is taken as made with these).
fn read_state(path: &std::path::Path, range: &FrameRange, settings: &str) -> Result<LongExposure> {
    let context = || format!("--state \"{}\"", path.display());
    let bytes = std::fs::read(path).with_context(context)?;
    let exposure = LongExposure::from_bytes(&bytes).with_context(context)?;
    if let Some(frame) = exposure.done().iter().find(|f| !range.frames.contains(f)) {
        bail!("{}: frame {frame} of the exposure is not in --frames \"{}\"", context(), range.text);
    }
    if let Some((there, here)) = first_difference(exposure.settings(), settings) {
        bail!(
            "{}: the exposure was started with other camera settings ({there} there, {here} here); resume it \
             with the same settings, or start another --state file",
            context()
        );
    }
    Ok(exposure)
}

/// The first field (`name: value`) in which two settings lines differ; None when they are the
/// same or `stored` is empty (a version 1 state).
fn first_difference<'a>(stored: &'a str, current: &'a str) -> Option<(&'a str, &'a str)> {
    if stored.is_empty() || stored == current {
        return None;
    }
    // Debug's `Camera { lens: ThinLens { focal_length_mm: 50.0, f_number: 2.0, .. } .. }`: the
    // fields without the struct names that open them or the braces that close them.
    let fields = |s: &'a str| s.split(", ").map(|f| f.rsplit("{ ").next().unwrap_or(f).trim_end_matches([' ', '}']));
    let pair = fields(stored).zip(fields(current)).find(|(a, b)| a != b);
    Some(pair.unwrap_or((stored, current)))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_first_differing_camera_setting_is_named() {
        let stored = "Camera { lens: ThinLens { focal_length_mm: 50.0, f_number: 2.0 }, blades: 6 }";
        let current = "Camera { lens: ThinLens { focal_length_mm: 50.0, f_number: 5.6 }, blades: 6 }";
        assert_eq!(super::first_difference(stored, current), Some(("f_number: 2.0", "f_number: 5.6")));
        let current = "Camera { lens: ThinLens { focal_length_mm: 35.0, f_number: 2.0 }, blades: 6 }";
        assert_eq!(super::first_difference(stored, current), Some(("focal_length_mm: 50.0", "focal_length_mm: 35.0")));
        assert_eq!(super::first_difference(stored, stored), None);
        // A version 1 state has no settings: any resume is taken as the same.
        assert_eq!(super::first_difference("", current), None);
    }

    #[test]
    fn farm_percent_reaches_100_only_at_the_end() {
        assert_eq!(super::farm_percent(1, 3), 33);
        assert_eq!(super::farm_percent(2, 3), 66);
        assert_eq!(super::farm_percent(299, 300), 99);
        assert_eq!(super::farm_percent(3, 3), 100);
        assert_eq!(super::farm_percent(0, 0), 100);
    }
}
