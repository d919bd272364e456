//! One module per compute pass. Each owns its pipeline, descriptor layout and push constants,
//! records its dispatch with the barriers it needs (written out by hand, with the reason), and
//! has a CPU twin used as its test oracle on small images.

pub mod aperture;
pub mod astigmatism;
pub mod bokeh_gather;
pub mod coc;
pub mod coma;
pub mod diffraction;
pub mod distortion;
pub mod dof_classify;
pub mod dof_composite;
pub mod dof_downsample;
pub mod dof_half_gather;
pub mod dof_sprites;
pub mod dof_tile_gather;
pub mod dof_tiles;
pub mod film;
pub mod longitudinal_color;
pub mod tiled_dof;
pub mod vignette;

use crate::gpu::GpuImage;
use ash::vk;

/// Linear lookup in a height-table buffer (`n` heights, then columns of `n` values), the twin of
/// glsl/include/height_table.glsl.
pub fn height_table_lookup(table: &[f32], column: usize, n: usize, h_mm: f32) -> f32 {
    if h_mm <= table[0] {
        return table[column * n];
    }
    for i in 1..n {
        if h_mm <= table[i] {
            let t = (h_mm - table[i - 1]) / (table[i] - table[i - 1]);
            return table[column * n + i - 1] + (table[column * n + i] - table[column * n + i - 1]) * t;
        }
    }
    table[column * n + n - 1]
}

/// Workgroup edge of every 2D pass (TILE_SIZE in glsl/include/common.glsl).
pub const TILE_SIZE: u32 = 16;

/// Workgroups covering a width x height image.
pub fn groups_for(width: u32, height: u32) -> [u32; 3] {
    [width.div_ceil(TILE_SIZE), height.div_ceil(TILE_SIZE), 1]
}

/// The bytes of a `#[repr(C)]` push-constant block made only of 4-byte fields.
pub(crate) fn push_bytes<T: Copy>(value: &T) -> &[u8] {
    // SAFETY: callers pass #[repr(C)] structs of i32/f32 fields, which have no padding bytes.
    unsafe { std::slice::from_raw_parts((value as *const T).cast::<u8>(), std::mem::size_of::<T>()) }
}

/// Barrier for an image a pass is about to overwrite completely: its old contents are discarded
/// (UNDEFINED -> GENERAL). The execution dependency on earlier compute and copy work orders this
/// write after any earlier reads of the same image (write-after-read).
pub(crate) fn overwrite(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
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

/// Barrier for an image an earlier compute pass wrote and this pass reads (read-after-write):
/// the writes must be finished and visible to this pass's storage reads.
pub(crate) fn after_compute_write(image: &GpuImage) -> vk::ImageMemoryBarrier2<'static> {
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

/// Barrier for a buffer an earlier compute pass wrote and this pass reads or updates.
pub(crate) fn buffer_after_compute_write(buffer: &crate::gpu::GpuBuffer) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .buffer(buffer.buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE)
}
