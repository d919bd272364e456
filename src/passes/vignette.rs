//! Vignetting pass: the lens's relative-illumination table, or cos^4 of the real field angle
//! (Kyaw 2013 eq 4.14 / 4.9).
//! Shader: glsl/vignette.comp.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "vignette";

/// Push constants of glsl/vignette.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VignetteParams {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub image_distance_mm: f32,
    /// Entries of the relative-illumination table (0: cos^4).
    pub entries: i32,
}

/// The table buffer: heights in mm, then relative illumination; `[0]` for none.
pub fn table_data(table: Option<&crate::optics::distortion::HeightTable>) -> Vec<f32> {
    match table {
        None => vec![0.0],
        Some(t) => t.image_height_mm.iter().chain(&t.values).map(|&v| v as f32).collect(),
    }
}

impl VignetteParams {
    /// The falloff at pixel (x, y): the table (`table_data` layout) or cos^4(theta) with
    /// tan(theta) = r / v; the shader's formula in f32.
    pub fn falloff(&self, x: u32, y: u32, table: &[f32]) -> f32 {
        let rx = (x as f32 + 0.5 - self.centre_px[0]) * self.pixel_pitch_mm;
        let ry = (y as f32 + 0.5 - self.centre_px[1]) * self.pixel_pitch_mm;
        let n = self.entries as usize;
        if n > 0 {
            return super::height_table_lookup(table, 1, n, (rx * rx + ry * ry).sqrt());
        }
        let t2 = (rx * rx + ry * ry) / (self.image_distance_mm * self.image_distance_mm);
        1.0 / ((1.0 + t2) * (1.0 + t2))
    }

    /// The strongest falloff in the frame (at the corner farthest from the centre).
    pub fn corner_falloff(&self, table: &[f32]) -> f32 {
        let (w, h) = (self.size[0].max(1) as u32 - 1, self.size[1].max(1) as u32 - 1);
        [(0, 0), (w, 0), (0, h), (w, h)].iter().map(|&(x, y)| self.falloff(x, y, table)).fold(1.0, f32::min)
    }
}

/// CPU twin on an RGBA image.
pub fn vignette_cpu(rgba: &[f32], params: &VignetteParams, table: &[f32]) -> Vec<f32> {
    let w = params.size[0] as u32;
    rgba.chunks_exact(4)
        .enumerate()
        .flat_map(|(i, px)| {
            let f = params.falloff(i as u32 % w, i as u32 / w, table);
            [px[0] * f, px[1] * f, px[2] * f, px[3]]
        })
        .collect()
}

pub struct VignettePass {
    pipeline: ComputePipeline,
}

impl VignettePass {
    pub fn new(gpu: &Gpu) -> GpuResult<VignettePass> {
        let bindings =
            [vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_BUFFER];
        let size = std::mem::size_of::<VignetteParams>() as u32;
        Ok(VignettePass { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(
        &self,
        rec: &mut Recorder,
        input: &GpuImage,
        output: &GpuImage,
        table: &GpuBuffer,
        params: &VignetteParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // input: written by the previous compute pass (or the upload, made visible to compute by
        //   its own barrier; the extra dependency is then harmless): wait for those writes.
        // output: written from scratch.
        rec.image_barriers(&[after_compute_write(input), overwrite(output)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(input), Bind::Image(output), Bind::Buffer(table)],
            push_bytes(params),
            groups_for(input.width, input.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
