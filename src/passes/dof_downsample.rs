//! Tiled depth of field: half-resolution colour and CoC for the large-CoC path, with highlight
//! extraction into sprites. Shader: glsl/dof_downsample.comp.

use super::{groups_for, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_downsample";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DownsampleParams {
    pub size: [i32; 2],
    pub half_size: [i32; 2],
    pub small_radius_px: f32,
    pub highlight_min: f32,
    pub highlight_ratio: f32,
    pub sprite_capacity: i32,
    pub sprite_visibility: f32,
}

pub struct DofDownsamplePass {
    pipeline: ComputePipeline,
}

impl DofDownsamplePass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let mut bindings = vec![vk::DescriptorType::STORAGE_IMAGE; 4];
        bindings.extend([vk::DescriptorType::STORAGE_BUFFER; 2]);
        bindings.push(vk::DescriptorType::STORAGE_IMAGE);
        let size = std::mem::size_of::<DownsampleParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        rec: &mut Recorder,
        color: &GpuImage,
        coc: &GpuImage,
        color_half: &GpuImage,
        coc_half: &GpuImage,
        args: &GpuBuffer,
        sprites: &GpuBuffer,
        color_base: &GpuImage,
        params: &DownsampleParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // color_half, coc_half, color_base: written from scratch. The inputs (colour, CoC) and
        // the args buffer were made visible to compute by the barriers before dof_classify.
        rec.image_barriers(&[super::overwrite(color_half), super::overwrite(coc_half), super::overwrite(color_base)]);
        rec.dispatch(
            &self.pipeline,
            &[
                Bind::Image(color),
                Bind::Image(coc),
                Bind::Image(color_half),
                Bind::Image(coc_half),
                Bind::Buffer(args),
                Bind::Buffer(sprites),
                Bind::Image(color_base),
            ],
            push_bytes(params),
            groups_for(color_half.width, color_half.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
