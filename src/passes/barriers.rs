//! The barriers passes record between each other, named for the hazard they resolve. Each pass
//! still writes out which of these it records and why, next to the call.

use crate::gpu::{GpuBuffer, GpuImage};
use ash::vk;

/// An image a pass is about to overwrite completely: its old contents are discarded
/// (UNDEFINED -> GENERAL). The execution dependency on earlier compute and copy work orders this
/// write after any earlier reads of the same image (write-after-read).
pub fn overwrite(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::NONE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .old_layout(vk::ImageLayout::UNDEFINED)
        .new_layout(vk::ImageLayout::GENERAL)
        .image(image.image)
        .subresource_range(crate::gpu::color_range())
}

/// An image an earlier compute pass wrote and this pass reads (read-after-write): the writes
/// must be finished and visible to this pass's storage reads.
pub fn after_compute_write(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ)
        .old_layout(vk::ImageLayout::GENERAL)
        .new_layout(vk::ImageLayout::GENERAL)
        .image(image.image)
        .subresource_range(crate::gpu::color_range())
}

/// An image an earlier compute pass wrote and this pass writes again, other texels or the same
/// (write-after-write; and read-modify-write).
pub fn write_after_write(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
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

/// An image this pass updates in place, each texel read and rewritten by the invocation that
/// owns it, after earlier passes wrote it (a compute pass, or the upload's copy) and read it:
/// their writes finished and visible to these reads and writes (read-after-write,
/// write-after-write), their reads finished before these writes (write-after-read).
pub fn update_in_place(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    // write_after_write's, with the upload's copy among the earlier writes.
    write_after_write(image)
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::TRANSFER_WRITE)
}

/// An image an earlier compute pass or the upload wrote, about to be copied from
/// (read-after-write, into the copy stage).
pub fn copy_source(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    after_compute_write(image)
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::TRANSFER_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COPY)
        .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)
}

/// An image about to be overwritten completely by a copy: its old contents are discarded
/// (UNDEFINED -> GENERAL), after earlier compute and copy work (write-after-read).
pub fn copy_target(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    overwrite(image).dst_stage_mask(vk::PipelineStageFlags2::COPY).dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
}

/// An image a copy wrote, which compute passes then read and update (read-after-write,
/// write-after-write).
pub fn after_copy(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
    write_after_write(image)
        .src_stage_mask(vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
}

/// A buffer an earlier compute pass wrote and this pass reads or updates.
pub fn buffer_after_compute_write(buffer: &GpuBuffer) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .buffer(buffer.buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE)
}

/// A buffer just zeroed (or set) by `vkCmdFillBuffer`, which compute shaders then read and
/// update with atomics. Validation layers place the fill in the COPY stage and the spec in
/// CLEAR: both are in ALL_TRANSFER.
pub fn buffer_after_fill(buffer: &GpuBuffer) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .buffer(buffer.buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE)
}

/// The args buffer after a compute pass wrote it, read as indirect dispatch arguments and by
/// shaders (and updated: it holds counters).
pub fn args_for_indirect(args: &GpuBuffer) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::DRAW_INDIRECT | vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(
            vk::AccessFlags2::INDIRECT_COMMAND_READ
                | vk::AccessFlags2::SHADER_STORAGE_READ
                | vk::AccessFlags2::SHADER_STORAGE_WRITE,
        )
        .buffer(args.buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE)
}
