//! Exposure and film-response pass. Shader: glsl/film.comp.
//! The exposure gain (sensor value per scene unit, Kyaw 2013 eq 4.1/4.9 with ISO) is applied
//! first; then either the characteristic curve (toe, straight part, shoulder on log exposure)
//! or nothing more, keeping scene-referred linear values for compositing.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuImage, GpuResult, Recorder};
use crate::optics::film::FilmCurve;
use ash::vk;

pub const NAME: &str = "film";

/// Push constants of glsl/film.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmParams {
    pub size: [i32; 2],
    pub exposure_gain: f32,
    pub use_curve: i32,
    pub log10_mid_in: f32,
    pub log10_mid_out: f32,
    pub contrast: f32,
    pub toe_softness_decades: f32,
    pub shoulder_softness_decades: f32,
    pub log10_black_out: f32,
    pub log10_white_out: f32,
}

impl FilmParams {
    pub fn new(width: u32, height: u32, exposure_gain: f64, curve: Option<&FilmCurve>) -> FilmParams {
        let c = curve.copied().unwrap_or_else(FilmCurve::default_filmic);
        FilmParams {
            size: [width as i32, height as i32],
            exposure_gain: exposure_gain as f32,
            use_curve: curve.is_some() as i32,
            log10_mid_in: c.middle_grey_in.log10() as f32,
            log10_mid_out: c.middle_grey_out.log10() as f32,
            contrast: c.contrast as f32,
            toe_softness_decades: c.toe_softness_decades.max(1e-6) as f32,
            shoulder_softness_decades: c.shoulder_softness_decades.max(1e-6) as f32,
            log10_black_out: c.black_out.log10() as f32,
            log10_white_out: c.white_out.log10() as f32,
        }
    }

    /// CPU twin of the shader for one channel value, in f32 like the shader.
    pub fn apply(&self, value: f32) -> f32 {
        let v = if value.is_finite() { value } else { 0.0 };
        let h = v * self.exposure_gain;
        if self.use_curve == 0 {
            return h;
        }
        let smooth_max = |a: f32, b: f32, k: f32| {
            a.max(b) + k * (1.0 + (-(a - b).abs() / k * std::f32::consts::LN_10).exp()).ln() / std::f32::consts::LN_10
        };
        let (lb, lw) = (self.log10_black_out, self.log10_white_out);
        let x = h.clamp(1.0e-30, 1.0e30).log10();
        let mut y = self.log10_mid_out + self.contrast * (x - self.log10_mid_in);
        y = -smooth_max(-y, -lw, self.shoulder_softness_decades);
        y = smooth_max(y, lb, self.toe_softness_decades);
        let ceiling = smooth_max(lw, lb, self.toe_softness_decades);
        y = lb + (y - lb) * ((lw - lb) / (ceiling - lb));
        10f32.powf(y.clamp(lb, lw))
    }
}

/// CPU twin on an RGBA image.
pub fn film_cpu(rgba: &[f32], params: &FilmParams) -> Vec<f32> {
    rgba.chunks_exact(4)
        .flat_map(|px| {
            let a = if px[3].is_finite() { px[3] } else { 0.0 };
            [params.apply(px[0]), params.apply(px[1]), params.apply(px[2]), a]
        })
        .collect()
}

pub struct FilmPass {
    pipeline: ComputePipeline,
}

impl FilmPass {
    pub fn new(gpu: &Gpu) -> GpuResult<FilmPass> {
        let bindings = [vk::DescriptorType::STORAGE_IMAGE; 2];
        let size = std::mem::size_of::<FilmParams>() as u32;
        Ok(FilmPass { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(
        &self,
        rec: &mut Recorder,
        input: &GpuImage,
        output: &GpuImage,
        params: &FilmParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // input: written by the previous compute pass (or the upload): wait for those writes.
        // output: written from scratch.
        rec.image_barriers(&[after_compute_write(input), overwrite(output)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(input), Bind::Image(output)],
            push_bytes(params),
            groups_for(input.width, input.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
