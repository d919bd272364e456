//! Tiled depth of field, step 1: the signed CoC range of every 16x16 tile. Shader: glsl/dof_tiles.comp.

use super::{after_compute_write, push_bytes, TILE_SIZE};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_tiles";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TilesParams {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
}

pub struct DofTilesPass {
    pipeline: ComputePipeline,
}

impl DofTilesPass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let bindings = [vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_BUFFER];
        let size = std::mem::size_of::<TilesParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(
        &self,
        rec: &mut Recorder,
        coc: &GpuImage,
        tile_coc: &GpuBuffer,
        params: &TilesParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // coc: written by the CoC pass (read-after-write). tile_coc is fully overwritten and no
        // earlier pass of this recording touched it, so it needs no barrier.
        rec.image_barriers(&[after_compute_write(coc)]);
        let groups = [coc.width.div_ceil(TILE_SIZE), coc.height.div_ceil(TILE_SIZE), 1];
        rec.dispatch(&self.pipeline, &[Bind::Image(coc), Bind::Buffer(tile_coc)], push_bytes(params), groups)?;
        rec.end_pass();
        Ok(())
    }
}
