//! Astigmatism: tangential then sagittal 1D blurs whose lengths follow the lens's tables against
//! image height (Kyaw 2013 sec 6.3.3, sec 7.3). Two dispatches of one shader:
//! glsl/astigmatism.comp.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::optics::distortion::HeightTable;
use ash::vk;

pub const NAME: &str = "astigmatism";

/// Push constants of glsl/astigmatism.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AstigmatismParams {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub entries: i32,
    /// 0: tangential, 1: sagittal (set per dispatch).
    pub direction: i32,
}

/// The table buffer: heights, tangential blur (mm), sagittal blur (mm).
pub fn table_data(tangential_mm: &HeightTable, sagittal_mm: &HeightTable) -> Vec<f32> {
    tangential_mm
        .image_height_mm
        .iter()
        .chain(&tangential_mm.values)
        .chain(&sagittal_mm.values)
        .map(|&v| v as f32)
        .collect()
}

pub struct AstigmatismPass {
    pipeline: ComputePipeline,
}

impl AstigmatismPass {
    pub fn new(gpu: &Gpu) -> GpuResult<AstigmatismPass> {
        let bindings =
            [vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_BUFFER];
        let size = std::mem::size_of::<AstigmatismParams>() as u32;
        Ok(AstigmatismPass { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    /// input -> (tangential) -> between -> (sagittal) -> output.
    pub fn record(
        &self,
        rec: &mut Recorder,
        input: &GpuImage,
        between: &GpuImage,
        output: &GpuImage,
        tables: &GpuBuffer,
        params: &AstigmatismParams,
    ) -> GpuResult<()> {
        let groups = groups_for(input.width, input.height);
        rec.begin_pass("astigmatism_tangential");
        // input: written by the previous compute pass (or the upload). between: from scratch.
        rec.image_barriers(&[after_compute_write(input), overwrite(between)]);
        let tangential = AstigmatismParams { direction: 0, ..*params };
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(input), Bind::Image(between), Bind::Buffer(tables)],
            push_bytes(&tangential),
            groups,
        )?;
        rec.begin_pass("astigmatism_sagittal");
        // between: written by the tangential dispatch just before (read-after-write).
        // output: from scratch.
        rec.image_barriers(&[after_compute_write(between), overwrite(output)]);
        let sagittal = AstigmatismParams { direction: 1, ..*params };
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(between), Bind::Image(output), Bind::Buffer(tables)],
            push_bytes(&sagittal),
            groups,
        )?;
        rec.end_pass();
        Ok(())
    }
}
