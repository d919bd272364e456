//! Depth-of-field gather pass: aperture-shaped circles of confusion, background and foreground
//! kept apart (see glsl/bokeh_gather.comp for the rules), energy spread over each CoC's area.

use super::aperture::{aperture_weight, ApertureConstants};
use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::model::aperture::ApertureShape;
use ash::vk;

pub const NAME: &str = "bokeh_gather";

/// Push constants of glsl/bokeh_gather.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherParams {
    pub size: [i32; 2],
    pub radius_px: i32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
}

impl GatherParams {
    /// `sa_max_coc_px`: the CoC diameter at which spherical aberration reaches its full amount
    /// (the user's CoC clamp, like the appendix shader's largest CoC).
    pub fn new(
        width: u32,
        height: u32,
        max_abs_coc_px: f64,
        aperture: &ApertureShape,
        sa_max_coc_px: f64,
        centre_px: [f64; 2],
    ) -> GatherParams {
        GatherParams {
            size: [width as i32, height as i32],
            radius_px: (0.5 * max_abs_coc_px).ceil() as i32 + 1,
            aperture: ApertureConstants::new(aperture, sa_max_coc_px, centre_px, width, height),
            layer_transition_px: 1.0,
        }
    }
}

/// CPU twin of the gather, same rules and f32 arithmetic, for tiny images.
/// `aperture_mask`: the buffer data of src/model/aperture.rs ([0, 0] for none).
pub fn gather_cpu(rgba: &[f32], coc_px: &[f32], p: &GatherParams, aperture_mask: &[f32]) -> Vec<f32> {
    let (w, h) = (p.size[0], p.size[1]);
    let mut out = vec![0.0f32; rgba.len()];
    let finite = |v: f32| if v.is_finite() { v.clamp(-3.0e38, 3.0e38) } else { 0.0 };
    for y in 0..h {
        for x in 0..w {
            let coc_p = coc_px[(y * w + x) as usize];
            let radius_p = (0.5 * coc_p.abs()).max(0.5);
            let (mut bg, mut fg) = ([0.0f32; 4], [0.0f32; 4]);
            let (mut bg_w, mut fg_w) = (0.0f32, 0.0f32);
            for dy in -p.radius_px..=p.radius_px {
                for dx in -p.radius_px..=p.radius_px {
                    // Clamp to edge, like the shader.
                    let (ux, uy) = (x + dx, y + dy);
                    let (qx, qy) = (ux.clamp(0, w - 1), uy.clamp(0, h - 1));
                    let qi = (qy * w + qx) as usize;
                    let coc_q = coc_px[qi];
                    let radius_q = (0.5 * coc_q.abs()).max(0.5);
                    let reach = if coc_q > coc_p { radius_q.min(radius_p) } else { radius_q };
                    if ((dx * dx + dy * dy) as f32) > (reach + 1.0) * (reach + 1.0) {
                        continue;
                    }
                    let flip = if coc_q < 0.0 { -1.0 } else { 1.0 };
                    let o = [-dx as f32 * flip, -dy as f32 * flip];
                    let sample_px = [ux as f32 + 0.5, uy as f32 + 0.5];
                    let cov_over_area = aperture_weight(o, reach, &p.aperture, sample_px, flip, aperture_mask);
                    let s = p.aperture.sa_strength(coc_q);
                    let r_norm = (o[0] * o[0] + o[1] * o[1]).sqrt() / radius_q;
                    let sa = crate::optics::spherical::intensity(s, r_norm as f64) as f32;
                    let wgt = cov_over_area * sa;
                    if wgt <= 0.0 {
                        continue;
                    }
                    let f = ((coc_p - coc_q) / p.layer_transition_px).clamp(0.0, 1.0);
                    for c in 0..4 {
                        let v = finite(rgba[qi * 4 + c]);
                        fg[c] += f * wgt * v;
                        bg[c] += (1.0 - f) * wgt * v;
                    }
                    fg_w += f * wgt;
                    bg_w += (1.0 - f) * wgt;
                }
            }
            let alpha = fg_w.clamp(0.0, 1.0);
            let o = (y * w + x) as usize * 4;
            for c in 0..4 {
                let b = if bg_w > 0.0 { bg[c] / bg_w } else { 0.0 };
                let f = if fg_w > 0.0 { fg[c] / fg_w } else { 0.0 };
                out[o + c] = b + (f - b) * alpha;
            }
        }
    }
    out
}

pub struct BokehGatherPass {
    pipeline: ComputePipeline,
}

impl BokehGatherPass {
    pub fn new(gpu: &Gpu) -> GpuResult<BokehGatherPass> {
        let bindings = [
            vk::DescriptorType::STORAGE_IMAGE,
            vk::DescriptorType::STORAGE_IMAGE,
            vk::DescriptorType::STORAGE_IMAGE,
            vk::DescriptorType::STORAGE_BUFFER,
        ];
        let size = std::mem::size_of::<GatherParams>() as u32;
        Ok(BokehGatherPass { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    pub fn record(
        &self,
        rec: &mut Recorder,
        color: &GpuImage,
        coc: &GpuImage,
        output: &GpuImage,
        aperture_mask: &GpuBuffer,
        params: &GatherParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // coc: written by the CoC pass just before: wait for it (read-after-write).
        // color: the upload's barrier already made it visible to compute reads; waiting on
        //   compute writes as well keeps this pass correct if a compute pass ever precedes it.
        // output: written from scratch.
        rec.image_barriers(&[after_compute_write(coc), after_compute_write(color), overwrite(output)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(color), Bind::Image(coc), Bind::Image(output), Bind::Buffer(aperture_mask)],
            push_bytes(params),
            groups_for(color.width, color.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
