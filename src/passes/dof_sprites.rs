//! Tiled depth of field: highlight sprites with the exact aperture shape, binned per tile and
//! added to the large-CoC tiles. Shader: glsl/dof_sprites.comp.

use super::aperture::ApertureConstants;
use super::push_bytes;
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_sprites";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpritesParams {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    pub aperture: ApertureConstants,
    pub sprite_capacity: i32,
}

pub struct DofSpritesPass {
    pipeline: ComputePipeline,
}

impl DofSpritesPass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let mut bindings = vec![vk::DescriptorType::STORAGE_IMAGE; 2];
        bindings.extend([vk::DescriptorType::STORAGE_BUFFER; 4]);
        let size = std::mem::size_of::<SpritesParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        rec: &mut Recorder,
        coc: &GpuImage,
        output: &GpuImage,
        args: &GpuBuffer,
        sprites: &GpuBuffer,
        tile_lists: &GpuBuffer,
        aperture_mask: &GpuBuffer,
        params: &SpritesParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // output: written by dof_composite, now read and added to (read-modify-write).
        // sprites and their count: written by dof_downsample (read-after-write).
        rec.image_barriers(&[super::dof_composite::write_after_write(output)]);
        rec.buffer_barriers(&[super::buffer_after_compute_write(sprites), super::buffer_after_compute_write(args)]);
        rec.dispatch_indirect(
            &self.pipeline,
            &[
                Bind::Image(coc),
                Bind::Image(output),
                Bind::Buffer(args),
                Bind::Buffer(sprites),
                Bind::Buffer(tile_lists),
                Bind::Buffer(aperture_mask),
            ],
            push_bytes(params),
            args,
            2 * 12,
        )?;
        rec.end_pass();
        Ok(())
    }
}
