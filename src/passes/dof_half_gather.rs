//! Tiled depth of field: the fixed-cost half-resolution gather of large-CoC tiles.
//! Shader: glsl/dof_half_gather.comp.

use super::aperture::ApertureConstants;
use super::push_bytes;
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_half_gather";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfGatherParams {
    pub half_size: [i32; 2],
    pub tiles: [i32; 2],
    pub rings: i32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
    /// In half-resolution px: samples with a larger CoC radius also go to the large-CoC
    /// foreground layer.
    pub small_radius_px: f32,
}

pub struct DofHalfGatherPass {
    pipeline: ComputePipeline,
}

impl DofHalfGatherPass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let mut bindings = vec![vk::DescriptorType::STORAGE_IMAGE; 4];
        bindings.extend([vk::DescriptorType::STORAGE_BUFFER; 3]);
        bindings.push(vk::DescriptorType::STORAGE_IMAGE);
        let size = std::mem::size_of::<HalfGatherParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        rec: &mut Recorder,
        color_half: &GpuImage,
        coc_half: &GpuImage,
        bg_half: &GpuImage,
        fg_half: &GpuImage,
        fg_big_half: &GpuImage,
        tile_lists: &GpuBuffer,
        tile_radius: &GpuBuffer,
        args: &GpuBuffer,
        aperture_mask: &GpuBuffer,
        params: &HalfGatherParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // color_half, coc_half: written by dof_downsample (read-after-write).
        // bg_half, fg_half, fg_big_half: written from scratch (only the large tiles' pixels; the rest is
        //   never read).
        rec.image_barriers(&[
            super::after_compute_write(color_half),
            super::after_compute_write(coc_half),
            super::overwrite(bg_half),
            super::overwrite(fg_half),
            super::overwrite(fg_big_half),
        ]);
        rec.dispatch_indirect(
            &self.pipeline,
            &[
                Bind::Image(color_half),
                Bind::Image(coc_half),
                Bind::Image(bg_half),
                Bind::Image(fg_half),
                Bind::Buffer(tile_lists),
                Bind::Buffer(tile_radius),
                Bind::Buffer(aperture_mask),
                Bind::Image(fg_big_half),
            ],
            push_bytes(params),
            args,
            2 * 12,
        )?;
        rec.end_pass();
        Ok(())
    }
}
