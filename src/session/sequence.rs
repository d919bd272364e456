//! A frame sequence through one GPU and one set of pipelines: every path carries the frame
//! number (`crate::io::sequence`); the next frame is read while the GPU renders this one and
//! the last one is written behind it; progress goes to the session's [`Report`].

use super::frame::{load_frame_as, render_loaded, write_outputs, LoadedFrame, RenderedFrame};
use super::settings::Patterns;
use super::{errors::error_text, long_exposure, RenderSettings, Report, SequenceSettings, Session};
use crate::io::output::Outputs;
use crate::io::sequence::IoPriority;
use crate::model::camera::{Camera, ShotCamera};
use anyhow::{bail, Result};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver};
use std::sync::Arc;
use std::time::Instant;

/// Renders the frames of `sequence`, each through its camera of `shot` and with its paths from
/// `settings`' patterns; a long exposure accumulates them into one output. Fails when a frame
/// failed (after the others ran, unless `fail_fast`).
pub fn render_sequence(
    settings: &RenderSettings,
    sequence: &SequenceSettings,
    shot: &ShotCamera,
    report: Arc<dyn Report>,
) -> Result<()> {
    let patterns = Patterns::new(settings, sequence.long_exposure)?;
    if sequence.long_exposure {
        return long_exposure::render(settings, sequence, &patterns, shot, report);
    }
    let range = &sequence.range;
    // Every frame's outputs are checked against every file the run reads and each other, and
    // the first frame's reserved (folders), before any work.
    patterns.check_outputs(settings, range, &[])?;
    if let Some(&first) = range.frames.first() {
        drop(patterns.at_frame(settings, first).outputs()?);
    }
    let velocity = patterns.first_frame_has_velocity(settings, range);
    let started = Instant::now();
    let total = range.frames.len();
    // Each frame's settings and skip check are made as the reader comes to it: nothing per
    // frame is kept ahead (a million frames would take gigabytes before the first).
    let jobs = range.frames.iter().map(|&frame| {
        let one = patterns.at_frame(settings, frame);
        let skip = sequence.skip_existing && complete_outputs(&one, frame, &*report);
        (frame, one, skip)
    });
    let fail_fast = sequence.fail_fast;
    let stop = AtomicBool::new(false);
    // The reading and writing threads yield to a GPU that runs on the CPU (io::sequence).
    let priority = IoPriority::default();
    let mut split = Split::default();
    let tally = std::thread::scope(|scope| {
        let read = read_ahead(scope, jobs, shot, Camera::clone, &stop, &priority);
        let (finish, finished) = sync_channel(1);
        let writer = scope.spawn(|| write_behind(finished, total, fail_fast, &stop, &priority, &*report));
        let mut session = Session::opening(&settings.gpu, shot.base(), velocity, report.clone());
        for ReadFrame { frame, read_s, settings: one, loaded } in read {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let item = match loaded {
                None => Finished::Skipped { frame, output: one.output.clone() },
                Some(loaded) => {
                    let gpu_started = Instant::now();
                    let rendered = loaded.and_then(|loaded| {
                        let outputs = one.outputs()?;
                        Ok((outputs, render_loaded(&one, loaded, &mut session)?))
                    });
                    if rendered.is_ok() {
                        split.frames += 1;
                        split.read_s += read_s;
                        split.gpu_s += gpu_started.elapsed().as_secs_f64();
                    }
                    if let Some(gpu) = session.gpu() {
                        priority.device_opened(gpu.info().on_cpu());
                    }
                    match rendered {
                        Ok((outputs, rendered)) => {
                            Finished::Rendered { frame, settings: Box::new(one), outputs, rendered: Box::new(rendered) }
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
    summary(&*report, tally.done, tally.skipped, tally.failed.len(), total, started, "(--fail-fast)");
    if split.frames > 0 && tally.done > 0 {
        let ms = |s: f64, n: usize| 1e3 * s / n as f64;
        report.say(&format!(
            "per frame: read {:.0} ms, GPU {:.0} ms, write {:.0} ms, overlapped on three threads \
             (wall {:.0} ms per frame)",
            ms(split.read_s, split.frames),
            ms(split.gpu_s, split.frames),
            ms(tally.write_s, tally.done),
            ms(started.elapsed().as_secs_f64(), tally.done + tally.failed.len()),
        ));
    }
    if !tally.failed.is_empty() {
        bail!("{} of {total} frames failed: {}", tally.failed.len(), frame_list(&tally.failed));
    }
    Ok(())
}

/// The most frames a message lists; the others are counted.
const LISTED_FRAMES: usize = 20;

/// `frames` as a list for a message: the first [`LISTED_FRAMES`], then how many more.
fn frame_list(frames: &[i64]) -> String {
    let listed: Vec<String> = frames.iter().take(LISTED_FRAMES).map(i64::to_string).collect();
    match frames.len().saturating_sub(LISTED_FRAMES) {
        0 => listed.join(", "),
        more => format!("{} and {more} more", listed.join(", ")),
    }
}

/// Whether every output of `one` (frame `frame`) exists and reads back whole, for
/// `--skip-existing`; an output that exists but does not is said, and the frame rendered again.
fn complete_outputs(one: &RenderSettings, frame: i64, report: &dyn Report) -> bool {
    one.output_fields().into_iter().all(|(field, path)| {
        if std::fs::symlink_metadata(path).is_err() {
            return false;
        }
        match crate::io::output::incomplete_output(field, path) {
            None => true,
            Some(why) => {
                report.say(&format!(
                    "frame {frame}: {} is not a complete output, {why}; rendering it again",
                    path.display()
                ));
                false
            }
        }
    })
}

/// The summary line: frames done, skipped, failed and not run (`why`), wall time, frames per second.
pub(super) fn summary(
    report: &dyn Report,
    done: usize,
    skipped: usize,
    failed: usize,
    total: usize,
    started: Instant,
    why: &str,
) {
    let wall_s = started.elapsed().as_secs_f64();
    let not_run = total - done - skipped - failed;
    report.say(&format!(
        "frames: {done} done, {skipped} skipped, {failed} failed{} of {total} in {wall_s:.1} s ({:.2} frames/s)",
        if not_run > 0 { format!(", {not_run} not run {why}") } else { String::new() },
        if wall_s > 0.0 { done as f64 / wall_s } else { 0.0 }
    ));
}

/// A frame of the sequence as the reader thread hands it on: its settings and its passes read
/// and planned, or None for a frame it was told to skip.
pub(super) struct ReadFrame {
    pub frame: i64,
    /// Seconds the reader took for the frame (its EXRs read and planned).
    pub read_s: f64,
    pub settings: RenderSettings,
    pub loaded: Option<Result<LoadedFrame>>,
}

/// Reads the frames of `jobs` (frame, its settings, whether to skip it; made as they are
/// reached) in order on a thread of
/// `scope`, at most two frames ahead of the receiver (one in the channel, one being read), so
/// that the next frame's EXRs are read while the GPU renders this one; each frame through its
/// camera of `shot`, made `adapt(camera)`. Stops when `stop` is set or the receiver is gone.
pub(super) fn read_ahead<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    jobs: impl Iterator<Item = (i64, RenderSettings, bool)> + Send + 'scope,
    shot: &'scope ShotCamera,
    adapt: fn(&Camera) -> Camera,
    stop: &'scope AtomicBool,
    priority: &'scope IoPriority,
) -> Receiver<ReadFrame> {
    let (send, receive) = sync_channel(1);
    scope.spawn(move || {
        let mut lowered = false;
        for (frame, settings, skip) in jobs {
            priority.before_frame(&mut lowered);
            if stop.load(Ordering::Relaxed) {
                break;
            }
            // The frame's own camera, its grain seeded by the seed and the frame number.
            let started = Instant::now();
            let loaded = (!skip).then(|| load_frame_as(&settings, shot, Some(frame), adapt));
            let read_s = started.elapsed().as_secs_f64();
            if send.send(ReadFrame { frame, read_s, settings, loaded }).is_err() {
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
    Rendered { frame: i64, settings: Box<RenderSettings>, outputs: Outputs, rendered: Box<RenderedFrame> },
}

/// The frames the writer thread counted.
#[derive(Default)]
struct Tally {
    done: usize,
    skipped: usize,
    failed: Vec<i64>,
    /// Seconds spent writing the frames done.
    write_s: f64,
}

/// Where a sequence's time went, summed over the frames rendered: reading (and planning) on
/// the reader thread, the GPU's work with its recording and download on the render thread,
/// writing on the writer thread. The three overlap: the wall time per frame is about the
/// largest of them, not their sum.
#[derive(Default)]
struct Split {
    frames: usize,
    read_s: f64,
    gpu_s: f64,
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
    report: &dyn Report,
) -> Tally {
    let mut tally = Tally::default();
    let mut lowered = false;
    let mut count = 0;
    for item in finished {
        priority.before_frame(&mut lowered);
        if fail_fast && !tally.failed.is_empty() {
            continue;
        }
        let frame = match item {
            Finished::Skipped { frame, output } => {
                tally.skipped += 1;
                report.say(&format!("frame {frame}: skipped, {} exists", output.display()));
                frame
            }
            Finished::Failed { frame, error } => {
                tally.failed.push(frame);
                report.say(&format!("error: frame {frame}: {}", error_text(&error)));
                frame
            }
            Finished::Rendered { frame, settings, outputs, rendered } => {
                let write_started = Instant::now();
                let written = write_outputs(&settings, outputs, &rendered);
                tally.write_s += write_started.elapsed().as_secs_f64();
                match written {
                    Ok(paths) => {
                        tally.done += 1;
                        let paths: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
                        report.say(&format!("frame {frame}: wrote {}", paths.join(", ")));
                    }
                    Err(error) => {
                        tally.failed.push(frame);
                        report.say(&format!("error: frame {frame}: {}", error_text(&error)));
                    }
                }
                frame
            }
        };
        count += 1;
        report.frame_finished(frame, count, total);
        if fail_fast && !tally.failed.is_empty() {
            stop.store(true, Ordering::Relaxed);
        }
    }
    report.finish();
    tally
}
