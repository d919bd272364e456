//! `realcam warm-up`: render small synthetic frames through every configuration a render commonly
//! plans, so the driver compiles their pipelines once and keeps them in its shader cache (Mesa:
//! `MESA_SHADER_CACHE_DIR`, by default `~/.cache/mesa_shader_cache`) and realcam's pipeline cache.
//! On lavapipe a pipeline is compiled by LLVM at its first use: a process on a fresh machine or
//! container (a render-farm node, CI) pays ~1.7 s for the demo that a warm one renders in 0.2 s
//! (docs/measurements.md, "Start-up"). Run once when the machine or the farm's image is built.
//!
//! The frame has what makes each pass plan itself: a far, an in-focus and a near band (every
//! tile class, the edge resolves), sparse highlights (the sprites, the lens flare), a moving
//! square (the motion blur and its edge resolve). Pipelines are specialised by the aperture and
//! the film, so the frame goes through each camera the caller gives (`realcam warm-up`: those of
//! the render flags it warms up for).

use crate::gpu::{Gpu, GpuResult};
use crate::model::camera::Camera;
use crate::model::frame::Frame;
use crate::pipeline::planner::plan;
use crate::pipeline::render::Renderer;

/// The warm-up frame's size: a common frame size, so a full-frame sensor's pixels see the CoCs
/// of real renders (every tile class and pyramid level).
pub const WIDTH: u32 = 1280;
pub const HEIGHT: u32 = 720;

/// One configuration rendered: its name, the passes its plan ran, and the wall time (the
/// compile of the pipelines it was the first to use, and its GPU work).
#[derive(Clone, Debug)]
pub struct WarmUpRun {
    pub name: String,
    pub passes: Vec<&'static str>,
    pub seconds: f64,
}

/// The warm-up frame: a wall whose depth runs from 0.3 m on the left to 1e4 m on the right
/// (every CoC, so every tile class and pyramid level), a card at 0.6 m over its lower half with
/// anti-aliased edges (colour half card, depth the card's: the edge resolves), a 50x highlight
/// every 37 px, and a 64-px square moving 12 px to the right per frame.
pub fn frame() -> Frame {
    let (w, h) = (WIDTH as usize, HEIGHT as usize);
    let mut color = Vec::with_capacity(w * h * 4);
    let mut depth_m = Vec::with_capacity(w * h);
    let mut velocity_px = vec![0.0f32; w * h * 2];
    let card = |x: usize, y: usize| (200..1000).contains(&x) && y >= 2 * h / 3;
    for y in 0..h {
        for x in 0..w {
            let checker = if ((x / 24) + (y / 24)) % 2 == 0 { 0.6 } else { 0.15 };
            let highlight = if x % 37 == 5 && y % 37 == 9 { 50.0 } else { 0.0 };
            let wall = checker + highlight;
            // The card's edge pixels: half the card's colour, the card's depth.
            let edge = card(x, y) && (!card(x - 1, y) || !card(x + 1, y) || !card(x, y - 1));
            let v = if edge {
                0.5 * (wall + 0.05)
            } else if card(x, y) {
                0.05
            } else {
                wall
            };
            color.extend([v, 0.8 * v, 0.6 * v, 1.0]);
            let wall_m = 0.3 * (1e4f32 / 0.3).powf(x as f32 / (w - 1) as f32);
            depth_m.push(if card(x, y) { 0.6 } else { wall_m });
            if (480..544).contains(&x) && (280..344).contains(&y) {
                velocity_px[2 * (y * w + x)] = 12.0;
            }
        }
    }
    let mut frame = Frame::new(WIDTH, HEIGHT, color, depth_m);
    frame.velocity_px = Some(velocity_px);
    frame
}

/// Render the warm-up frame through each named camera on `gpu` (the cameras `realcam render`
/// makes of the flags to warm up for: pipelines are specialised by the aperture and the film);
/// `progress` hears each one.
pub fn run(
    gpu: &Gpu,
    cameras: &[(String, Camera)],
    mut progress: impl FnMut(&WarmUpRun),
) -> Result<Vec<WarmUpRun>, String> {
    let frame = frame();
    let mut runs = Vec::new();
    for (name, camera) in cameras {
        let start = std::time::Instant::now();
        let passes = render(gpu, &frame, camera).map_err(|e| format!("{name}: {e}"))?;
        let run = WarmUpRun { name: name.clone(), passes, seconds: start.elapsed().as_secs_f64() };
        progress(&run);
        runs.push(run);
    }
    gpu.save_pipeline_cache();
    Ok(runs)
}

fn render(gpu: &Gpu, frame: &Frame, camera: &Camera) -> GpuResult<Vec<&'static str>> {
    let plan = plan(frame, camera);
    Renderer::new(gpu, &plan)?.render(frame, &plan, false)?;
    Ok(plan.passes.iter().filter(|p| p.runs()).map(|p| p.name).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::lens_file::LensFile;
    use crate::model::camera::CameraRequest;

    /// The frame asks for every effect: the planner runs the depth of field, the motion blur,
    /// the lens flare and the film for the default lens.
    #[test]
    fn the_warm_up_frame_plans_every_effect() {
        let camera = Camera::new(&LensFile::default_lens(), &CameraRequest::default()).unwrap();
        let planned = plan(&frame(), &camera);
        let runs: Vec<&str> = planned.passes.iter().filter(|p| p.runs()).map(|p| p.name).collect();
        for pass in ["coc", "bokeh_tiled", "motion_blur", "flare", "film"] {
            assert!(runs.contains(&pass), "{pass} not planned: {runs:?}");
        }
    }
}
