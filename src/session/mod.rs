//! The render session: the library API that the command line, the Python package and the
//! Blender add-on (through the command line) share. A [`Session`] opens the GPU once and keeps
//! its pipelines; per frame it loads the passes ([`load_frame`]), plans the frame
//! ([`plan_frame`]), renders it ([`render_loaded`]) and writes it ([`write_outputs`]).
//! [`render_sequence`] drives a frame sequence (read-ahead, write-behind, skip-existing, long
//! exposure) and reports progress through a [`Report`].
//!
//! Settings are plain data ([`RenderSettings`], [`SequenceSettings`]) beside the
//! [`Camera`](crate::model::camera::Camera); `crate::flags` turns the command line's flags
//! into them.

mod colour;
pub mod errors;
mod frame;
mod long_exposure;
pub mod report;
mod sequence;
mod settings;

pub use frame::{
    input_camera, load_frame, output_attributes, plan_frame, render_loaded, write_outputs, LoadedFrame, RenderedFrame,
};
pub use report::{Report, StderrReport};
pub use sequence::render_sequence;
pub use settings::{ColourSettings, RenderSettings, SequenceSettings};

use crate::gpu::{Gpu, GpuOptions};
use crate::io::Image;
use crate::model::camera::{Camera, ShotCamera};
use crate::model::frame::Frame;
use crate::pipeline::bands::{self, FrameRender};
use crate::pipeline::planner::{self, Plan};
use crate::pipeline::render::Renderer;
use anyhow::{bail, Result};
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};
use std::time::Instant;

/// When the process started (the command line's `main` sets it first), for `--profile`'s
/// start-up line.
pub static PROCESS_START: OnceLock<Instant> = OnceLock::new();

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The GPU `options` ask for, not printed.
pub fn open_gpu(options: &GpuOptions) -> Result<Gpu> {
    Gpu::new(options).map_err(|e| match e {
        crate::gpu::GpuError::DeviceNotFound { .. } => anyhow::anyhow!("{e} (--device or REALCAM_DEVICE)"),
        e => e.into(),
    })
}

/// Renders one frame as `settings` say, frame `frame` of `shot` (None: a frame without a
/// number), into its outputs, every output written and renamed; the session comes back still
/// open (the command line ends the process without closing its GPU) and the paths written.
pub fn render_single(
    settings: &RenderSettings,
    shot: &ShotCamera,
    frame: Option<i64>,
    report: Arc<dyn Report>,
) -> Result<(Session, Vec<PathBuf>)> {
    let outputs = settings.outputs()?;
    let velocity = crate::io::velocity_likely(&settings.sources);
    let mut session = Session::opening(&settings.gpu, shot.base(), velocity, report);
    let rendered = frame::render_image(settings, shot, frame, &mut session)?;
    let paths = write_outputs(settings, outputs, &rendered)?;
    Ok((session, paths))
}

/// The GPU and the pipelines of a run, opened at the first frame that reaches the GPU and kept
/// for the frames after it (a later frame's plan creates the pipelines it adds).
pub struct Session {
    gpu: Option<(Gpu, Renderer)>,
    /// The GPU to open.
    options: GpuOptions,
    /// Where messages go.
    report: Arc<dyn Report>,
    /// The GPU opening on another thread (`Session::opening`), with the pipelines the camera
    /// will likely need; joined by the first frame.
    opening: Option<std::thread::JoinHandle<Result<(Gpu, Renderer)>>>,
    /// How the first frame reached the GPU, for `--profile`'s start-up line; taken when printed.
    startup: Option<String>,
}

impl Drop for Session {
    fn drop(&mut self) {
        // A run that failed before its first frame reached the GPU still waits for the device
        // to finish opening, so it is closed before the process exits.
        if let Some(opening) = self.opening.take() {
            let _ = opening.join();
        }
    }
}

impl Session {
    /// A session whose GPU starts opening now, on another thread: loading the Vulkan driver
    /// and creating the device (about 30-100 ms on lavapipe) overlap the first frame's EXR read,
    /// and so does creating the pipelines of the passes `camera` will likely run on inputs with
    /// (`velocity`, `io::velocity_likely`) or without a velocity pass ([`Renderer::create_likely`];
    /// on lavapipe about 30 ms of CPU for the tiled depth of field, 65 ms for the motion blur).
    pub fn opening(options: &GpuOptions, camera: &Camera, velocity: bool, report: Arc<dyn Report>) -> Session {
        let gpu_options = options.clone();
        let camera = camera.clone();
        let opening = std::thread::Builder::new().name("gpu-open".into()).spawn(move || {
            let gpu = open_gpu(&gpu_options)?;
            let renderer = Renderer::empty(&gpu);
            // Only a head start: a pipeline that fails here is created again, and its error
            // reported, once the frame's plan asks for it.
            let _ = renderer.create_likely(&camera, velocity);
            Ok((gpu, renderer))
        });
        // Without a thread, the first frame opens the GPU itself.
        Session { gpu: None, options: options.clone(), report, opening: opening.ok(), startup: None }
    }

    /// A session that opens the GPU at its first frame.
    pub fn new(options: &GpuOptions, report: Arc<dyn Report>) -> Session {
        Session { gpu: None, options: options.clone(), report, opening: None, startup: None }
    }

    /// Where the session's messages go.
    pub fn report(&self) -> &dyn Report {
        &*self.report
    }

    /// The GPU: the one opening on another thread (with the pipelines created there), else
    /// opened now; prints it. With it, what the wait for it was, for the start-up line.
    fn open_gpu(&mut self) -> Result<(Gpu, Renderer, String)> {
        let waited = Instant::now();
        let (gpu, renderer, how) = match self.opening.take().map(std::thread::JoinHandle::join) {
            Some(Ok(opened)) => {
                let (gpu, renderer) = opened?;
                (gpu, renderer, "waited for the GPU opened beside the read")
            }
            Some(Err(_)) => bail!("opening the GPU failed (its thread panicked)"),
            None => {
                let gpu = open_gpu(&self.options)?;
                let renderer = Renderer::empty(&gpu);
                (gpu, renderer, "opened the GPU")
            }
        };
        self.report.say(&format!("device: {}", gpu.info()));
        Ok((gpu, renderer, format!("{how} {:.1} ms", ms_since(waited))))
    }

    /// The start-up line of `--profile` after the first frame: when its GPU work was submitted,
    /// counted from the process's start (None before, and after it was taken).
    pub fn take_startup(&mut self) -> Option<String> {
        self.startup.take()
    }

    /// The GPU, once a frame has opened it (the Python package's `Camera.device`).
    pub fn gpu(&self) -> Option<&Gpu> {
        self.gpu.as_ref().map(|(gpu, _)| gpu)
    }

    /// Renders `frame` by `plan` on the session's GPU, opened at the first call, in bands when
    /// the frame does not fit the device (each band planned by `plan_band`); Vulkan validation
    /// messages are an error.
    pub(crate) fn render(
        &mut self,
        frame: &mut Frame,
        plan: &Plan,
        plan_band: &dyn Fn(&Frame) -> Plan,
    ) -> Result<FrameRender> {
        // The first frame: how its GPU was waited for, and when its pipelines began.
        let mut first = None;
        let opened = match self.gpu.take() {
            Some(opened) => opened,
            None => {
                let (gpu, renderer, waited) = self.open_gpu()?;
                first = Some((waited, Instant::now()));
                (gpu, renderer)
            }
        };
        let (gpu, renderer) = self.gpu.insert(opened);
        renderer.prepare(plan)?;
        let messages_before = gpu.validation_message_count();
        // The frame's colour is not needed after its upload: its memory takes the result.
        let frame_render = bands::render_frame(gpu, renderer, frame, plan, plan_band)?;
        let rendered = &frame_render.rendered;
        // The first frame: from the process's start to its submit, and what came between.
        if let (Some((waited, created)), Some(submitted), Some(start)) =
            (first, rendered.profile.submitted_at, PROCESS_START.get())
        {
            let ms = |from: Instant| submitted.saturating_duration_since(from).as_secs_f64() * 1e3;
            self.startup = Some(format!(
                "start-up: the first frame's GPU work submitted {:.1} ms after the process started ({waited}; \
                 pipelines and recording {:.1} ms)",
                ms(*start),
                ms(created)
            ));
        }
        let messages = gpu.validation_message_count() - messages_before;
        if messages > 0 {
            bail!("{messages} Vulkan validation messages (see above)");
        }
        Ok(frame_render)
    }

    /// Exposes a long exposure's `average` of sensor values on `camera`'s film (its grain and
    /// curve; nothing when the film is linear without grain), on the session's GPU.
    pub fn expose_on_film(&mut self, explain: bool, camera: &Camera, average: Image) -> Result<Image> {
        if !planner::film_changes_sensor_values(camera) {
            return Ok(average);
        }
        let Image { width, height, data, .. } = average;
        let mut frame = Frame::new(width, height, data, vec![f32::INFINITY; width as usize * height as usize]);
        let plan = planner::film_plan(&frame, camera);
        if explain {
            self.report.say(&format!("the long exposure's {}", plan.explain()));
        }
        let rendered = self.render(&mut frame, &plan, &|band| planner::film_plan(band, camera))?.rendered;
        Ok(Image { width, height, channels: 4, data: rendered.rgba })
    }
}
