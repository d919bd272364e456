//! Longitudinal (axial) chromatic aberration: red and blue focus in front of or behind green, so
//! each channel has its own signed CoC, shifted by a constant (Camera::longitudinal_color_coc_px).
//! The renderer runs the CoC pass and the depth-of-field method once per channel; this pass
//! (glsl/longitudinal_color.comp) joins the three runs. It costs three depth-of-field runs:
//! the planner records it only for lenses with a longitudinal-colour entry whose offset is
//! visible.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "longitudinal_color";

/// CPU twin: red of `red`, green and alpha of `green`, blue of `blue` (RGBA rows).
pub fn join_cpu(red: &[f32], green: &[f32], blue: &[f32]) -> Vec<f32> {
    let mut out = green.to_vec();
    for (i, px) in out.chunks_exact_mut(4).enumerate() {
        px[0] = red[4 * i];
        px[2] = blue[4 * i + 2];
    }
    out
}

pub struct LongitudinalColorPass {
    pipeline: ComputePipeline,
}

impl LongitudinalColorPass {
    pub fn new(gpu: &Gpu) -> GpuResult<LongitudinalColorPass> {
        let bindings = [vk::DescriptorType::STORAGE_IMAGE; 4];
        let pipeline = ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, 8)?;
        Ok(LongitudinalColorPass { pipeline })
    }

    pub fn record(&self, rec: &mut Recorder, runs: [&GpuImage; 3], output: &GpuImage) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // The three runs were written by the depth-of-field passes before; the output is
        // written from scratch.
        rec.image_barriers(&[
            after_compute_write(runs[0]),
            after_compute_write(runs[1]),
            after_compute_write(runs[2]),
            overwrite(output),
        ]);
        let size = [output.width as i32, output.height as i32];
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(runs[0]), Bind::Image(runs[1]), Bind::Image(runs[2]), Bind::Image(output)],
            push_bytes(&size),
            groups_for(output.width, output.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
