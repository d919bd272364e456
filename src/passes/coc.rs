//! Circle-of-confusion pass: signed CoC diameter in pixels per pixel, from planar depth
//! (Kyaw 2013 eq 5.3). Shader: glsl/coc.comp.

use super::{groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuImage, GpuResult, Recorder};
use crate::optics::ThinLens;
use ash::vk;

pub const NAME: &str = "coc";

/// Push constants of glsl/coc.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CocParams {
    pub size: [i32; 2],
    /// v^2 / (N' P) / pixel pitch: eq 5.3 is C_px = coc_scale_px_mm * (1/S - 1/u).
    pub coc_scale_px_mm: f32,
    pub inv_focus_distance_per_mm: f32,
    pub max_coc_px: f32,
    pub mm_per_depth_unit: f32,
}

impl CocParams {
    pub fn new(lens: &ThinLens, pixel_pitch_mm: f64, max_coc_px: f64, width: u32, height: u32) -> CocParams {
        let v_mm = lens.image_distance_mm();
        // Kyaw 2013 eq 5.3: C = v^2 |S - u| / (u S N' P) = v^2/(N' P) * (1/S - 1/u), signed.
        let scale_mm2 = v_mm * v_mm / (lens.effective_f_number() * lens.pupil_magnification);
        CocParams {
            size: [width as i32, height as i32],
            coc_scale_px_mm: (scale_mm2 / pixel_pitch_mm) as f32,
            inv_focus_distance_per_mm: (1.0 / lens.focus_distance_mm) as f32,
            max_coc_px: max_coc_px as f32,
            mm_per_depth_unit: 1000.0,
        }
    }

    /// CPU twin of the shader for one depth value, in the same f32 arithmetic.
    pub fn coc_px(&self, depth_m: f32) -> f32 {
        let u_mm = depth_m * self.mm_per_depth_unit;
        let inv_u = 1.0 / u_mm.max(1.0e-30);
        let coc = self.coc_scale_px_mm * (self.inv_focus_distance_per_mm - inv_u);
        coc.clamp(-self.max_coc_px, self.max_coc_px)
    }
}

/// CPU twin: the CoC of every pixel.
pub fn coc_cpu(depth_m: &[f32], params: &CocParams) -> Vec<f32> {
    depth_m.iter().map(|&d| params.coc_px(d)).collect()
}

pub struct CocPass {
    pipeline: ComputePipeline,
}

impl CocPass {
    pub fn new(gpu: &Gpu) -> GpuResult<CocPass> {
        let bindings = [vk::DescriptorType::STORAGE_IMAGE; 2];
        let pipeline =
            ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, std::mem::size_of::<CocParams>() as u32)?;
        Ok(CocPass { pipeline })
    }

    /// `depth` (R32F metres) -> `coc` (R32F signed px).
    pub fn record(&self, rec: &mut Recorder, depth: &GpuImage, coc: &GpuImage, params: &CocParams) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // depth: written by the upload copy, whose own barrier already made it visible to
        //   compute reads in layout GENERAL; nothing to wait for here.
        // coc: written from scratch; discard old contents.
        rec.image_barriers(&[overwrite(coc)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(depth), Bind::Image(coc)],
            push_bytes(params),
            groups_for(depth.width, depth.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
