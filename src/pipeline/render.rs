//! Runs a plan on the GPU: uploads the frame, walks the planned passes in order handing each the
//! frame's images, reads the result back. Pipelines are created once per pass (those of the plan
//! given to [`Renderer::new`] up front, others when a later plan first runs them).

use crate::gpu::{Gpu, GpuError, GpuImage, GpuResult, Profile, Recorder, TwinCheck};
use crate::model::camera::Camera;
use crate::model::frame::Frame;
use crate::passes::{FrameImages, Input, RecordPass, PASS_ORDER};
use crate::pipeline::planner::Plan;
use ash::vk;
use std::sync::OnceLock;

/// The pipelines of the passes, one slot per entry of the pass order.
pub struct Renderer {
    gpu: Gpu,
    passes: Vec<OnceLock<Box<dyn RecordPass>>>,
}

/// What a render returns.
pub struct Rendered {
    /// RGBA, row-major.
    pub rgba: Vec<f32>,
    /// Signed CoC per pixel when the CoC pass ran and `keep_coc` was asked (green's, with
    /// longitudinal colour).
    pub coc_px: Option<Vec<f32>>,
    pub profile: Profile,
}

/// A generous estimate of the GPU memory a render of `frame` takes: the colour (RGBA32F) in and
/// a new one per planned run (the recorder keeps each until the frame is submitted), depth,
/// CoC and tile images, and the staging buffers up and down.
fn estimated_gpu_bytes(frame: &Frame, plan: &Plan) -> u64 {
    frame.width as u64 * frame.height as u64 * estimated_gpu_bytes_per_px(plan)
}

/// [`estimated_gpu_bytes`] per pixel of the frame.
pub fn estimated_gpu_bytes_per_px(plan: &Plan) -> u64 {
    let runs = plan.passes.iter().map(|p| p.run_params().count() as u64).sum::<u64>();
    16 * (2 + 2 * runs) + 4 + 4 + (16 + 4) + 16
}

impl Renderer {
    /// A renderer with the pipelines of the passes `plan` runs, created side by side (each
    /// compiles on the CPU: on lavapipe 1-25 ms a shader).
    pub fn new(gpu: &Gpu, plan: &Plan) -> GpuResult<Renderer> {
        let renderer = Renderer::empty(gpu);
        renderer.prepare(plan)?;
        Ok(renderer)
    }

    /// A renderer with no pipeline yet.
    pub fn empty(gpu: &Gpu) -> Renderer {
        Renderer { gpu: gpu.clone(), passes: PASS_ORDER.iter().map(|_| OnceLock::new()).collect() }
    }

    /// Creates the pipelines of the passes `plan` runs, and those its runs specialise, side by
    /// side; what was created before (by an earlier plan, or [`Renderer::create_likely`]) is kept.
    pub fn prepare(&self, plan: &Plan) -> GpuResult<()> {
        if plan.passes.len() != PASS_ORDER.len() {
            return Err(GpuError::Internal("the plan was made for another pass order".into()));
        }
        let planned: Vec<usize> = (0..plan.passes.len()).filter(|&i| plan.passes[i].runs()).collect();
        self.side_by_side(&planned, |i| {
            let pass = self.pass(i)?;
            plan.passes[i].run_params().try_for_each(|params| pass.prepare_run(params))
        })
    }

    /// Creates, side by side, the pipelines of the passes likely to run through `camera` on
    /// inputs with (`velocity`) or without a velocity pass ([`crate::passes::Pass::likely`])
    /// before a frame is known: a session does this while
    /// its first frame is still being read.
    pub fn create_likely(&self, camera: &Camera, velocity: bool) -> GpuResult<()> {
        let likely: Vec<usize> = (0..PASS_ORDER.len()).filter(|&i| PASS_ORDER[i].likely(camera, velocity)).collect();
        self.side_by_side(&likely, |i| self.pass(i)?.prepare_likely(camera))
    }

    /// `create` for each of the passes `indices`, each on a thread of its own.
    fn side_by_side(&self, indices: &[usize], create: impl Fn(usize) -> GpuResult<()> + Sync) -> GpuResult<()> {
        let create = &create;
        std::thread::scope(|scope| {
            let created: Vec<_> = indices.iter().map(|&i| scope.spawn(move || create(i))).collect();
            created.into_iter().try_for_each(|thread| {
                thread.join().unwrap_or_else(|_| Err(GpuError::Internal("creating a pipeline panicked".into())))
            })
        })
    }

    /// The created pass `i` of the pass order.
    fn pass(&self, i: usize) -> GpuResult<&dyn RecordPass> {
        if let Some(p) = self.passes[i].get() {
            return Ok(p.as_ref());
        }
        let created = PASS_ORDER[i].create(&self.gpu)?;
        Ok(self.passes[i].get_or_init(|| created).as_ref())
    }

    pub fn render(&self, frame: &Frame, plan: &Plan, keep_coc: bool) -> GpuResult<Rendered> {
        self.run(FrameUse::Kept(frame), plan, keep_coc, false).map(|(rendered, _)| rendered)
    }

    /// [`Renderer::render`] of a frame whose colour the caller no longer needs: once it is
    /// uploaded its memory takes the result (left empty in `frame`). A frame-sized result in
    /// memory the process already touched: a 1280x720 frame's 15 MB of fresh pages are 3,300
    /// page faults, 8-10 ms on lavapipe's 2-core machine.
    pub fn render_taking_colour(&self, frame: &mut Frame, plan: &Plan, keep_coc: bool) -> GpuResult<Rendered> {
        self.run(FrameUse::ColourTaken(frame), plan, keep_coc, false).map(|(rendered, _)| rendered)
    }

    /// Render, running every dispatch against its shader's CPU twin (slow; for tests).
    pub fn render_with_twin_checks(&self, frame: &Frame, plan: &Plan) -> GpuResult<(Rendered, Vec<TwinCheck>)> {
        self.run(FrameUse::Kept(frame), plan, false, true)
    }

    fn run(
        &self,
        mut use_of: FrameUse<'_>,
        plan: &Plan,
        keep_coc: bool,
        twin_checks: bool,
    ) -> GpuResult<(Rendered, Vec<TwinCheck>)> {
        if !plan.runs_any() {
            // Nothing to simulate: the pinhole image is the camera image; the GPU is not touched.
            let profile = Profile { device: self.gpu.info().to_string(), ..Default::default() };
            let rgba = use_of.take_colour().unwrap_or_else(|| use_of.frame().color.clone());
            return Ok((Rendered { rgba, coc_px: None, profile }, Vec::new()));
        }
        let frame = use_of.frame();
        if plan.passes.len() != PASS_ORDER.len() {
            return Err(GpuError::Internal("the plan was made for another pass order".into()));
        }
        let (w, h) = (frame.width, frame.height);
        self.gpu.check_fits(w, h, estimated_gpu_bytes(frame, plan))?;
        let mut rec = if twin_checks {
            Recorder::with_twin_checks(&self.gpu, "realcam frame")?
        } else {
            Recorder::new(&self.gpu, "realcam frame")?
        };
        rec.begin_pass("upload");
        let color = rec.create_image("color (input)", w, h, vk::Format::R32G32B32A32_SFLOAT)?;
        let mut uploads: Vec<(&GpuImage, &[f32])> = vec![(&color, &frame.color)];
        let depth = match plan.needs(Input::Depth) {
            true => Some(rec.create_image("depth (m)", w, h, vk::Format::R32_SFLOAT)?),
            false => None,
        };
        if let Some(d) = &depth {
            uploads.push((d, &frame.depth_m));
        }
        let velocity_rgba = if plan.needs(Input::Velocity) { frame.velocity_rgba() } else { None };
        let velocity = match &velocity_rgba {
            Some(_) => Some(rec.create_image("velocity (px/frame)", w, h, vk::Format::R32G32B32A32_SFLOAT)?),
            None => None,
        };
        if let (Some(v), Some(data)) = (&velocity, &velocity_rgba) {
            uploads.push((v, data));
        }
        rec.upload_images(&uploads)?;
        rec.end_pass();
        drop(uploads);
        // Uploaded: a colour the caller gave up holds the result (see render_taking_colour).
        let recycled = use_of.take_colour();

        let mut images = FrameImages::new(color, depth).with_velocity(velocity);
        for (i, planned) in plan.passes.iter().enumerate() {
            for params in planned.run_params() {
                self.pass(i)?.record_run(&mut rec, &mut images, params)?;
            }
        }

        rec.begin_pass("download");
        let out_id = rec.download_image_into(images.color(), 4, recycled.unwrap_or_default())?;
        let coc_id = match (images.main_coc(), keep_coc) {
            (Some(coc), true) => Some(rec.download_image(coc, 1)?),
            _ => None,
        };
        rec.end_pass();
        let (profile, mut data, checks) = rec.submit_checked()?;
        let coc_px = coc_id.map(|id| std::mem::take(&mut data[id.index()]));
        let rgba = std::mem::take(&mut data[out_id.index()]);
        Ok((Rendered { rgba, coc_px, profile }, checks))
    }
}

/// The frame a render reads: kept as it is, or with its colour taken once uploaded.
enum FrameUse<'a> {
    Kept(&'a Frame),
    ColourTaken(&'a mut Frame),
}

impl FrameUse<'_> {
    fn frame(&self) -> &Frame {
        match self {
            FrameUse::Kept(frame) => frame,
            FrameUse::ColourTaken(frame) => frame,
        }
    }

    /// The frame's colour, if the caller gave it up (left empty in the frame).
    fn take_colour(&mut self) -> Option<Vec<f32>> {
        match self {
            FrameUse::Kept(_) => None,
            FrameUse::ColourTaken(frame) => Some(std::mem::take(&mut frame.color)),
        }
    }
}

/// The preview of a rendered image (RGBA in the colour space `space`, `width` px per row) as
/// display-encoded values for an 8-bit PNG.
///
/// Through an OpenColorIO display and view when one is given: the view is the preview's tone
/// curve (for the ACES configs the ACES output transform), applied to the image as it is
/// (scene-referred, or through the film curve with `--film-in-exr`): what a compositor sees of
/// the EXR through that view. Without one, for an sRGB display: the image converted to linear
/// Rec.709 with its white adapted by Bradford as OpenColorIO does (ACES's white shows white),
/// the film's characteristic curve applied to those sensor values unless it is already in the
/// image ([`crate::model::camera::Camera::film_on_output`]), then the sRGB curve.
pub fn preview_rgba(
    camera: &crate::model::camera::Camera,
    space: &crate::optics::colour::Chromaticities,
    rgba: &[f32],
    width: u32,
    view: Option<&crate::io::colour_config::DisplayView>,
) -> Vec<f32> {
    use crate::optics::colour::{mul_vec, srgb_oetf, Chromaticities};
    let mut out = rgba.to_vec();
    if let Some(view) = view {
        // The ACES 2.0 output transform costs about 0.75 us a pixel on one core (10x the film
        // curve): spread over the cores.
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk_px = (out.len() / 4).div_ceil(threads).max(16384);
        std::thread::scope(|scope| {
            for part in out.chunks_mut(4 * chunk_px) {
                scope.spawn(|| view.processor.apply_rgba_slice(part));
            }
        });
        return out;
    }
    if *space != Chromaticities::REC709 {
        let m = space.rgb_to_adapted(&Chromaticities::REC709);
        for px in out.chunks_exact_mut(4) {
            let c = mul_vec(&m, [px[0], px[1], px[2]].map(f64::from));
            px[..3].copy_from_slice(&c.map(|v| v as f32));
        }
    }
    if !camera.film_on_output {
        out = crate::passes::film::film_response_cpu(&out, width, &camera.film);
    }
    for px in out.chunks_exact_mut(4) {
        for v in &mut px[..3] {
            *v = srgb_oetf(*v);
        }
    }
    out
}
