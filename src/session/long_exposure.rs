//! `--long-exposure`: the frames of a sequence rendered up to the sensor and accumulated into
//! one exposure (Kyaw 2013 sec. 7.4), then exposed on the film once; a `--state` file lets a
//! stopped exposure resume where it was.

use super::frame::{output_attributes, render_loaded, write_outputs, RenderedFrame};
use super::sequence::{read_ahead, summary, ReadFrame};
use super::settings::Patterns;
use super::{errors::error_text, RenderSettings, Report, SequenceSettings, Session};
use crate::io::sequence::{FrameRange, IoPriority};
use crate::io::ExrWriteOptions;
use crate::model::camera::ShotCamera;
use crate::model::long_exposure::LongExposure;
use anyhow::{bail, Context, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The frames of `sequence` rendered and accumulated into one exposure, written only when
/// every frame was.
pub(super) fn render(
    settings: &RenderSettings,
    sequence: &SequenceSettings,
    patterns: &Patterns,
    shot: &ShotCamera,
    report: Arc<dyn Report>,
) -> Result<()> {
    if settings.trace.is_some() {
        bail!("--trace: GPU times are per frame; --long-exposure writes no trace");
    }
    let range = &sequence.range;
    let state = sequence.state.as_deref();
    // The outputs and the state against every frame the exposure reads and each other.
    let state_output: Vec<(&'static str, &std::path::Path)> = state.map(|p| ("state", p)).into_iter().collect();
    patterns.check_outputs(settings, range, &state_output)?;
    let outputs = settings.outputs()?;
    // The frames are rendered up to the sensor and averaged; the film comes once, after.
    // (Each frame's camera is the shot's at that frame; the film is the base camera's.)
    let camera = shot.base();
    let sensor = crate::pipeline::planner::sensor_camera(camera);
    // Every setting of the camera and the shot's keys, so a resumed exposure is refused others.
    let camera_settings = match shot.keys() {
        Some(keys) => format!("{sensor:?}, keys: {:?}", keys.tracks),
        None => format!("{sensor:?}"),
    };
    let mut exposure = match state.filter(|p| p.exists()) {
        Some(path) => read_state(path, range, &camera_settings)?,
        None => LongExposure::new(&camera_settings),
    };
    let started = Instant::now();
    let total = range.frames.len();
    let mut finished = 0;
    let mut exr_options = None;
    let mut working_space = crate::optics::colour::Chromaticities::REC709;
    let mut display_view = None;
    let mut failed = None;
    let mut skipped = 0;
    // Which frames the state holds, then each frame's settings as the reader comes to it.
    let mut in_state = exposure.done().to_vec();
    in_state.sort_unstable();
    let held: Vec<bool> = range.frames.iter().map(|f| in_state.binary_search(f).is_ok()).collect();
    let jobs = range.frames.iter().zip(held).map(|(&f, held)| (f, patterns.at_frame(settings, f), held));
    let stop = AtomicBool::new(false);
    let priority = IoPriority::default();
    let velocity = patterns.first_frame_has_velocity(settings, range);
    let mut session = Session::opening(&settings.gpu, &sensor, velocity, report.clone());
    std::thread::scope(|scope| {
        // The next frame is read while this one renders; accumulating is quick beside both.
        let read = read_ahead(scope, jobs, shot, crate::pipeline::planner::sensor_camera, &stop, &priority);
        for ReadFrame { frame, settings: one, loaded, .. } in read {
            finished += 1;
            let Some(loaded) = loaded else {
                skipped += 1;
                report.say(&format!("frame {frame}: already in the exposure (--state)"));
                report.frame_finished(frame, finished, total);
                continue;
            };
            let rendered = loaded.and_then(|loaded| render_loaded(&one, loaded, &mut session));
            if let Some(gpu) = session.gpu() {
                priority.device_opened(gpu.info().on_cpu());
            }
            let added = rendered.and_then(|rendered| {
                exposure.add(frame, &rendered.image)?;
                exr_options = Some(rendered.exr_options);
                working_space = rendered.working_space;
                display_view = rendered.display_view;
                if let Some(path) = state {
                    crate::io::output::write_file("state", path, &exposure.to_bytes()).context("--state")?;
                }
                Ok(())
            });
            if let Err(e) = added {
                report.say(&format!("error: frame {frame}: {}", error_text(&e)));
                failed = Some(frame);
            }
            report.frame_finished(frame, finished, total);
            if failed.is_some() {
                stop.store(true, Ordering::Relaxed);
                break;
            }
        }
    });
    report.finish();
    let done = exposure.frames() as usize - skipped;
    summary(&*report, done, skipped, usize::from(failed.is_some()), total, started, "(the exposure stopped)");
    if let Some(frame) = failed {
        bail!("frame {frame} failed: the long exposure of {total} frames is not written");
    }
    // The frames were rendered to sensor values and averaged; the film comes once, now: on
    // the GPU into the EXR with --film-in-exr, else only into the PNG preview (the EXR stays
    // scene-referred). The header names the camera's film, not the sensor's.
    let average = exposure.image()?;
    let image =
        if camera.film_on_output { session.expose_on_film(settings.explain, camera, average)? } else { average };
    let preview = settings.png.as_ref().map(|_| crate::io::Image {
        data: crate::pipeline::render::preview_rgba(
            camera,
            &working_space,
            &image.data,
            image.width,
            display_view.as_deref(),
        ),
        ..image.clone()
    });
    let attributes = output_attributes(camera, image.width, image.height, &working_space);
    let mut exr_options = ExrWriteOptions { attributes, ..exr_options.unwrap_or_default() };
    // The last frame's header attributes; those describing channels (Cryptomatte's) go, as
    // the long exposure keeps no channels of its inputs.
    exr_options.input_attributes.retain(|(name, _)| !crate::io::describes_channels(name));
    let rendered = RenderedFrame {
        image,
        preview,
        kept_channels: Vec::new(),
        exr_options,
        working_space,
        display_view,
        profile: Default::default(),
    };
    for path in write_outputs(settings, outputs, &rendered)? {
        report.say(&format!("wrote {} (a long exposure of {} frames)", path.display(), exposure.frames()));
    }
    Ok(())
}
/// The state of a stopped long exposure, all of whose frames are in `range`, made with
/// `settings` (a version 1 state has none and is taken as made with these).
fn read_state(path: &std::path::Path, range: &FrameRange, settings: &str) -> Result<LongExposure> {
    let context = || format!("--state \"{}\"", path.display());
    let bytes = std::fs::read(path).with_context(context)?;
    let exposure = LongExposure::from_bytes(&bytes).with_context(context)?;
    let mut frames = range.frames.clone();
    frames.sort_unstable();
    if let Some(frame) = exposure.done().iter().find(|f| frames.binary_search(f).is_err()) {
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
}
