//! Tiled depth of field, step 2: dilate each tile's CoC to the neighbours it can reach, classify
//! tiles (copy / exact small gather / half-resolution large), build the tile lists and the
//! indirect dispatch counts. Shader: glsl/dof_classify.comp.

use super::push_bytes;
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "dof_classify";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClassifyParams {
    pub tiles: [i32; 2],
    pub search_tiles: i32,
    pub small_radius_px: f32,
}

pub struct DofClassifyPass {
    pipeline: ComputePipeline,
}

impl DofClassifyPass {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let bindings = [vk::DescriptorType::STORAGE_BUFFER; 4];
        let size = std::mem::size_of::<ClassifyParams>() as u32;
        Ok(Self { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(
        &self,
        rec: &mut Recorder,
        tile_coc: &GpuBuffer,
        args: &GpuBuffer,
        tile_lists: &GpuBuffer,
        tile_radius: &GpuBuffer,
        params: &ClassifyParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // args: zeroed by a transfer fill just before, then counted up with atomics here:
        //   transfer write -> compute read/write.
        // tile_coc: written by dof_tiles: compute write -> compute read.
        rec.buffer_barriers(&[
            vk::BufferMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::CLEAR | vk::PipelineStageFlags2::COPY)
                .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
                .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
                .buffer(args.buffer)
                .offset(0)
                .size(vk::WHOLE_SIZE),
            super::buffer_after_compute_write(tile_coc),
        ]);
        let tile_count = (params.tiles[0] * params.tiles[1]) as u32;
        rec.dispatch(
            &self.pipeline,
            &[Bind::Buffer(tile_coc), Bind::Buffer(args), Bind::Buffer(tile_lists), Bind::Buffer(tile_radius)],
            push_bytes(params),
            [tile_count.div_ceil(64), 1, 1],
        )?;
        rec.end_pass();
        Ok(())
    }
}
