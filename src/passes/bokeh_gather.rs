//! Depth-of-field gather pass: aperture-shaped circles of confusion, background and foreground
//! kept apart (see glsl/bokeh_gather.comp for the rules), energy spread over each CoC's area.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use ash::vk;

pub const NAME: &str = "bokeh_gather";

/// The iris: n blades (< 3 means circular), rotation, blade curvature 0 (straight) .. 1 (round).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApertureShape {
    pub blades: u32,
    pub rotation_deg: f64,
    pub curvature: f64,
    /// Spherical aberration amount (-1..1): > 0 under-corrected, < 0 over-corrected, 0 uniform
    /// disks (src/optics/spherical.rs).
    pub spherical_aberration: f64,
    /// Cat's eye (optical vignetting) at the frame's farthest corner, 0..1: the aperture is
    /// clipped by a circle shifted by this fraction of its radius there (less nearer the centre).
    pub cats_eye: f64,
}

impl ApertureShape {
    pub const CIRCLE: ApertureShape =
        ApertureShape { blades: 0, rotation_deg: 0.0, curvature: 1.0, spherical_aberration: 0.0, cats_eye: 0.0 };

    /// cats_eye / (distance from the optical centre to the farthest corner), per pixel.
    pub fn cats_eye_per_px(&self, width: u32, height: u32, centre_px: [f64; 2]) -> f64 {
        let corner = [(0.0, 0.0), (width as f64, 0.0), (0.0, height as f64), (width as f64, height as f64)]
            .iter()
            .map(|&(x, y)| ((x - centre_px[0]).powi(2) + (y - centre_px[1]).powi(2)).sqrt())
            .fold(0.0, f64::max);
        if corner > 0.0 {
            self.cats_eye.clamp(0.0, 1.0) / corner
        } else {
            0.0
        }
    }
}

/// Push constants of glsl/bokeh_gather.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherParams {
    pub size: [i32; 2],
    pub radius_px: i32,
    pub blades: i32,
    pub rotation_rad: f32,
    pub curvature: f32,
    pub sa_amount: f32,
    pub sa_max_coc_px: f32,
    pub centre_x_px: f32,
    pub centre_y_px: f32,
    pub cats_eye_per_px: f32,
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
            blades: aperture.blades as i32,
            rotation_rad: aperture.rotation_deg.to_radians() as f32,
            curvature: if aperture.blades < 3 { 1.0 } else { aperture.curvature.clamp(0.0, 1.0) as f32 },
            sa_amount: aperture.spherical_aberration as f32,
            sa_max_coc_px: sa_max_coc_px as f32,
            centre_x_px: centre_px[0] as f32,
            centre_y_px: centre_px[1] as f32,
            cats_eye_per_px: aperture.cats_eye_per_px(width, height, centre_px) as f32,
            layer_transition_px: 1.0,
        }
    }
}

/// Signed distance to the aperture image of circumradius r (glsl/include/aperture.glsl).
pub fn aperture_sdf(o: [f32; 2], r: f32, p: &GatherParams) -> f32 {
    let len = (o[0] * o[0] + o[1] * o[1]).sqrt();
    let d_circle = len - r;
    if p.blades < 3 || p.curvature >= 1.0 {
        return d_circle;
    }
    let sector = 2.0 * std::f32::consts::PI / p.blades as f32;
    let mut phi = (-o[1]).atan2(o[0]) - (0.5 * std::f32::consts::PI + p.rotation_rad + 0.5 * sector);
    phi -= sector * (phi / sector + 0.5).floor();
    let d_poly = len * phi.cos() - r * (0.5 * sector).cos();
    d_poly + (d_circle - d_poly) * p.curvature
}

pub fn aperture_area(r: f32, p: &GatherParams) -> f32 {
    let circle = std::f32::consts::PI * r * r;
    if p.blades < 3 {
        return circle;
    }
    let n = p.blades as f32;
    let polygon = 0.5 * n * r * r * (2.0 * std::f32::consts::PI / n).sin();
    polygon + (circle - polygon) * p.curvature
}

/// The aperture image, bilinear, at uv in [-1, 1]^2 (mask_value in glsl/include/aperture.glsl).
pub fn mask_value(mask: &[f32], uv: [f32; 2]) -> f32 {
    let n = mask[0] as i32;
    let texel = |x: i32, y: i32| if x < 0 || y < 0 || x >= n || y >= n { 0.0 } else { mask[2 + (y * n + x) as usize] };
    let t = [(uv[0] * 0.5 + 0.5) * n as f32 - 0.5, (uv[1] * 0.5 + 0.5) * n as f32 - 0.5];
    let (i, j) = (t[0].floor() as i32, t[1].floor() as i32);
    let (fx, fy) = (t[0] - i as f32, t[1] - j as f32);
    let top = texel(i, j) + (texel(i + 1, j) - texel(i, j)) * fx;
    let bottom = texel(i, j + 1) + (texel(i + 1, j + 1) - texel(i, j + 1)) * fx;
    top + (bottom - top) * fy
}

/// Coverage over area of a sample's aperture image, with the cat's eye
/// (aperture_weight in glsl/include/aperture.glsl).
pub fn aperture_weight(o: [f32; 2], r: f32, p: &GatherParams, sample_px: [f32; 2], flip: f32, mask: &[f32]) -> f32 {
    let (mut cov, mut area);
    if mask.first().copied().unwrap_or(0.0) > 0.0 && r > 1.0 {
        let (c, s) = (p.rotation_rad.cos(), p.rotation_rad.sin());
        let up = [o[0], -o[1]];
        let turned = [c * up[0] + s * up[1], -s * up[0] + c * up[1]];
        cov = mask_value(mask, [turned[0] / r, -turned[1] / r]);
        area = mask[1] * 4.0 * r * r;
    } else {
        if o[0] * o[0] + o[1] * o[1] >= (r + 0.5) * (r + 0.5) {
            return 0.0;
        }
        cov = (0.5 - aperture_sdf(o, r, p)).clamp(0.0, 1.0);
        area = aperture_area(r, p);
    }
    if p.cats_eye_per_px > 0.0 && cov > 0.0 {
        let k = p.cats_eye_per_px * r * flip;
        let c = [(p.centre_x_px - sample_px[0]) * k, (p.centre_y_px - sample_px[1]) * k];
        let d = (c[0] * c[0] + c[1] * c[1]).sqrt().min(2.0 * r);
        let dist = ((o[0] - c[0]).powi(2) + (o[1] - c[1]).powi(2)).sqrt();
        cov = cov.min((0.5 - (dist - r)).clamp(0.0, 1.0));
        let h = 0.5 * d / r.max(1e-6);
        let overlap = (2.0 * h.acos() - 2.0 * h * (1.0 - h * h).max(0.0).sqrt()) / std::f32::consts::PI;
        area *= overlap.max(1e-3);
    }
    cov / area
}

/// CPU twin of the gather, same rules and f32 arithmetic, for tiny images.
/// `aperture_mask`: the buffer data of src/aperture_mask.rs ([0, 0] for none).
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
                    let cov_over_area = aperture_weight(o, reach, p, sample_px, flip, aperture_mask);
                    let s =
                        crate::optics::spherical::strength(p.sa_amount as f64, coc_q as f64, p.sa_max_coc_px as f64);
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
