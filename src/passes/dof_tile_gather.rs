//! Tiled depth of field, full-resolution tiles: copy where nothing defocused reaches, the exact
//! gather with the tile's own radius where the CoC is small. Dispatched indirectly over the
//! tile lists of dof_classify. Shader: glsl/dof_tile_gather.comp.

use super::aperture::ApertureConstants;
use super::push_bytes;
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_tile_gather";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileGatherParams {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    pub tile_class: i32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
}

pub struct DofTileGatherPass {
    pipeline: ComputePipeline,
}

pub struct TileGatherBindings<'a> {
    pub color: &'a GpuImage,
    pub coc: &'a GpuImage,
    pub output: &'a GpuImage,
    pub tile_lists: &'a GpuBuffer,
    pub tile_radius: &'a GpuBuffer,
    pub args: &'a GpuBuffer,
    pub aperture_mask: &'a GpuBuffer,
}

impl DofTileGatherPass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let mut bindings = vec![vk::DescriptorType::STORAGE_IMAGE; 3];
        bindings.extend([vk::DescriptorType::STORAGE_BUFFER; 3]);
        let size = std::mem::size_of::<TileGatherParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    /// Record the copy tiles and the small-CoC tiles (two indirect dispatches). The caller has
    /// made the classification visible (see `tiled_dof`).
    pub fn record(&self, rec: &mut Recorder, b: &TileGatherBindings<'_>, params: &TileGatherParams) -> GpuResult<()> {
        let binds = [
            Bind::Image(b.color),
            Bind::Image(b.coc),
            Bind::Image(b.output),
            Bind::Buffer(b.tile_lists),
            Bind::Buffer(b.tile_radius),
            Bind::Buffer(b.aperture_mask),
        ];
        for (class, label) in [(0, "dof_copy_tiles"), (1, "dof_small_tiles")] {
            rec.begin_pass(label);
            let p = TileGatherParams { tile_class: class, ..*params };
            rec.dispatch_indirect(&self.pipeline, &binds, push_bytes(&p), b.args, class as u64 * 12)?;
            rec.end_pass();
        }
        Ok(())
    }
}
