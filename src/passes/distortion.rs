//! Distortion and lateral colour from the lens's tables (Kyaw 2013 eq 6.8; the first aberration
//! pass of sec 7.3). Shader: glsl/distortion.comp.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::optics::distortion::DistortionTables;
use ash::vk;

pub const NAME: &str = "distortion";

/// Push constants of glsl/distortion.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistortionParams {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub entries: i32,
}

/// The table buffer: heights, then green, red-extra and blue-extra percent.
pub fn table_data(tables: &DistortionTables) -> Vec<f32> {
    let mut data: Vec<f32> = tables.green_percent.image_height_mm.iter().map(|&h| h as f32).collect();
    for t in [&tables.green_percent, &tables.red_extra_percent, &tables.blue_extra_percent] {
        data.extend(t.values.iter().map(|&v| v as f32));
    }
    data
}

/// CPU twin on an RGBA image (f64 mapping, bilinear with clamp to edge like the shader).
pub fn distortion_cpu(rgba: &[f32], params: &DistortionParams, tables: &DistortionTables) -> Vec<f32> {
    let (w, h) = (params.size[0], params.size[1]);
    let load = |x: i32, y: i32, c: usize| rgba[((y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) * 4) as usize + c];
    let mut out = rgba.to_vec();
    for y in 0..h {
        for x in 0..w {
            let d = [x as f64 + 0.5 - params.centre_px[0] as f64, y as f64 + 0.5 - params.centre_px[1] as f64];
            let real_mm = (d[0] * d[0] + d[1] * d[1]).sqrt() * params.pixel_pitch_mm as f64;
            for c in 0..3 {
                let r = tables.ideal_height_mm(c, real_mm);
                let scale = if real_mm > 0.0 { r / real_mm } else { 1.0 };
                let sx = params.centre_px[0] as f64 + d[0] * scale - 0.5;
                let sy = params.centre_px[1] as f64 + d[1] * scale - 0.5;
                let (ix, iy) = (sx.floor() as i32, sy.floor() as i32);
                let (fx, fy) = ((sx - ix as f64) as f32, (sy - iy as f64) as f32);
                let top = load(ix, iy, c) + (load(ix + 1, iy, c) - load(ix, iy, c)) * fx;
                let bottom = load(ix, iy + 1, c) + (load(ix + 1, iy + 1, c) - load(ix, iy + 1, c)) * fx;
                out[((y * w + x) * 4) as usize + c] = top + (bottom - top) * fy;
            }
        }
    }
    out
}

pub struct DistortionPass {
    pipeline: ComputePipeline,
}

impl DistortionPass {
    pub fn new(gpu: &Gpu) -> GpuResult<DistortionPass> {
        let bindings =
            [vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_BUFFER];
        let size = std::mem::size_of::<DistortionParams>() as u32;
        Ok(DistortionPass { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(
        &self,
        rec: &mut Recorder,
        input: &GpuImage,
        output: &GpuImage,
        tables: &GpuBuffer,
        params: &DistortionParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // input: written by the previous compute pass (or the upload): wait for those writes.
        // tables: uploaded with its own barrier. output: written from scratch.
        rec.image_barriers(&[after_compute_write(input), overwrite(output)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(input), Bind::Image(output), Bind::Buffer(tables)],
            push_bytes(params),
            groups_for(input.width, input.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
