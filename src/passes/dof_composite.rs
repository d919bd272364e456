//! Tiled depth of field: the large-CoC tiles at full resolution (upsampled half-resolution layers,
//! the exact gather for nearly sharp pixels). Shader: glsl/dof_composite.comp.

use super::aperture::ApertureConstants;
use super::push_bytes;
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_composite";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompositeParams {
    pub size: [i32; 2],
    pub half_size: [i32; 2],
    pub tiles: [i32; 2],
    pub small_radius_px: f32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
}

pub struct DofCompositePass {
    pipeline: ComputePipeline,
}

pub struct CompositeBindings<'a> {
    pub color: &'a GpuImage,
    pub coc: &'a GpuImage,
    pub bg_half: &'a GpuImage,
    pub fg_half: &'a GpuImage,
    pub output: &'a GpuImage,
    pub tile_lists: &'a GpuBuffer,
    pub args: &'a GpuBuffer,
    pub aperture_mask: &'a GpuBuffer,
    pub coc_half: &'a GpuImage,
    pub fg_big_half: &'a GpuImage,
    pub tile_radius: &'a GpuBuffer,
}

impl DofCompositePass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let mut bindings = vec![vk::DescriptorType::STORAGE_IMAGE; 5];
        bindings.extend([vk::DescriptorType::STORAGE_BUFFER; 2]);
        bindings.extend([vk::DescriptorType::STORAGE_IMAGE; 2]);
        bindings.push(vk::DescriptorType::STORAGE_BUFFER);
        let size = std::mem::size_of::<CompositeParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(&self, rec: &mut Recorder, b: &CompositeBindings<'_>, params: &CompositeParams) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // bg_half, fg_half: written by dof_half_gather (read-after-write).
        // color (the colour less the sprites' energy) and coc_half: written by dof_downsample
        //   (coc_half was already waited for by dof_half_gather; the extra dependency is free).
        // output: the full-resolution tile passes wrote other tiles of it; the write-after-write
        //   dependency keeps sync validation (which tracks whole images) and any driver honest.
        rec.image_barriers(&[
            super::after_compute_write(b.color),
            super::after_compute_write(b.coc_half),
            super::after_compute_write(b.bg_half),
            super::after_compute_write(b.fg_half),
            super::after_compute_write(b.fg_big_half),
            write_after_write(b.output),
        ]);
        rec.dispatch_indirect(
            &self.pipeline,
            &[
                Bind::Image(b.color),
                Bind::Image(b.coc),
                Bind::Image(b.bg_half),
                Bind::Image(b.fg_half),
                Bind::Image(b.output),
                Bind::Buffer(b.tile_lists),
                Bind::Buffer(b.aperture_mask),
                Bind::Image(b.coc_half),
                Bind::Image(b.fg_big_half),
                Bind::Buffer(b.tile_radius),
            ],
            push_bytes(params),
            b.args,
            2 * 12,
        )?;
        rec.end_pass();
        Ok(())
    }
}

/// An image an earlier compute pass wrote and this pass writes again (other pixels or the same).
pub(crate) fn write_after_write(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .old_layout(vk::ImageLayout::GENERAL)
        .new_layout(vk::ImageLayout::GENERAL)
        .image(image.image)
        .subresource_range(crate::gpu::color_range())
}
