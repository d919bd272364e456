//! Tiled depth of field: the fixed-cost half-resolution gather of large-CoC tiles.
//! Shader: glsl/dof_half_gather.comp.

use super::aperture::{aperture_weight, sa_weight, ApertureConstants};
use super::barriers::{after_compute_write, overwrite};
use super::twin::{floats, listed_tiles};
use super::TILE_SIZE;
use crate::gpu::shaders::dof_tiles::{ARGS_DISPATCH_WORDS, CLASS_LARGE};
use crate::gpu::{GpuBuffer, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use std::f32::consts::PI;

pub const NAME: &str = "dof_half_gather";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HalfGatherPush {
    pub half_size: [i32; 2],
    pub tiles: [i32; 2],
    pub rings: i32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
    /// In half-resolution px: samples with a larger CoC radius also go to the large-CoC
    /// foreground layer.
    pub small_radius_px: f32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof_half_gather.comp.
    pub struct HalfGatherBindings {
        color_half: image(color_half),
        coc_half: image(coc_half),
        bg_half: image(bg_half),
        fg_half: image(fg_half),
        tile_lists: buffer(TileLists),
        tile_radius: buffer(TileRadius),
        aperture_mask: buffer(ApertureMask),
        fg_big_half: image(fg_big_half),
    }
}

/// glsl/dof_half_gather.comp: one 8x8 workgroup per large tile.
pub struct HalfGatherShader;

impl Shader for HalfGatherShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = HalfGatherBindings<'a>;
    type Push = HalfGatherPush;
}

/// Interleaved gradient noise of the shader, in f32: the rotation of the rings at a pixel.
pub fn ring_jitter(x: i32, y: i32) -> f32 {
    let fract = |v: f32| v - v.floor();
    fract(52.982_918 * fract(x as f32 * 0.067_110_56 + y as f32 * 0.005_837_15))
}

impl Twin for HalfGatherShader {
    fn cpu(pc: &HalfGatherPush, groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (lists, radii, mask) = (b[4].words().to_vec(), floats(b[5].words()), floats(b[6].words()));
        let half_tile = TILE_SIZE / 2;
        let (mut bg_out, mut fg_out, mut big_out) = (b[2].image().clone(), b[3].image().clone(), b[7].image().clone());
        for tile in listed_tiles(&lists, CLASS_LARGE, pc.tiles, groups[0], half_tile, pc.half_size) {
            let t = tile.index;
            for (hx, hy) in tile.pixels() {
                let (x, y) = (hx as i32, hy as i32);
                let ap = &pc.aperture;
                // Half-resolution units: CoC diameters and distances halve.
                let coc_p = 0.5 * coc.clamped(x, y)[0];
                let radius_p = (0.5 * coc_p.abs()).max(0.5);
                let extent = 0.5 * radii[t] + 1.0;
                let spacing = extent / pc.rings as f32;
                let ramp = spacing.max(1.0);
                let jitter = ring_jitter(x, y);
                let (mut bg, mut fg, mut big) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
                let (mut bg_w, mut fg_w, mut big_w) = (0.0f32, 0.0f32, 0.0f32);
                for k in 0..=pc.rings {
                    let n = if k == 0 { 1 } else { 6 * k };
                    let rho = k as f32 * spacing;
                    let tap_area = if k == 0 { PI * 0.25 * spacing * spacing } else { PI * spacing * spacing / 3.0 };
                    for j in 0..n {
                        let theta = (j as f32 + jitter) * 2.0 * PI / n as f32;
                        let qu = [x + (rho * theta.cos()).round() as i32, y + (rho * theta.sin()).round() as i32];
                        let coc_q = 0.5 * coc.clamped(qu[0], qu[1])[0];
                        let radius_q = (0.5 * coc_q.abs()).max(0.5);
                        let reach = if coc_q > coc_p { radius_q.min(radius_p) } else { radius_q };
                        let flip = if coc_q < 0.0 { -1.0 } else { 1.0 };
                        let o = [(x - qu[0]) as f32 * flip, (y - qu[1]) as f32 * flip];
                        let sample = [qu[0] as f32 + 0.5, qu[1] as f32 + 0.5];
                        let w = tap_area
                            * aperture_weight(o, reach, ap, sample, flip, ramp, &mask)
                            * sa_weight(o, radius_q, coc_q, ap);
                        if w <= 0.0 {
                            continue;
                        }
                        let c = color.clamped(qu[0], qu[1]);
                        let f = ((coc_p - coc_q) / pc.layer_transition_px).clamp(0.0, 1.0);
                        for ch in 0..4 {
                            fg[ch] += f * w * c[ch];
                            bg[ch] += (1.0 - f) * w * c[ch];
                        }
                        fg_w += f * w;
                        bg_w += (1.0 - f) * w;
                        if radius_q > pc.small_radius_px {
                            for ch in 0..4 {
                                big[ch] += f * w * c[ch];
                            }
                            big_w += f * w;
                        }
                    }
                }
                let background: Vec<f32> =
                    if bg_w > 0.0 { bg.iter().map(|v| v / bg_w).collect() } else { color.clamped(x, y).to_vec() };
                let layer = |sum: [f32; 4], weight: f32| {
                    let rgb: [f32; 3] = std::array::from_fn(|ch| if weight > 0.0 { sum[ch] / weight } else { 0.0 });
                    [rgb[0], rgb[1], rgb[2], weight.clamp(0.0, 1.0)]
                };
                bg_out.texel_mut(hx, hy).copy_from_slice(&background);
                fg_out.texel_mut(hx, hy).copy_from_slice(&layer(fg, fg_w));
                big_out.texel_mut(hx, hy).copy_from_slice(&layer(big, big_w));
            }
        }
        b[2] = HostData::Image(bg_out);
        b[3] = HostData::Image(fg_out);
        b[7] = HostData::Image(big_out);
    }
}

pub fn record(
    kernel: &Kernel<HalfGatherShader>,
    rec: &mut Recorder,
    b: &HalfGatherBindings<'_>,
    args: &GpuBuffer,
    push: &HalfGatherPush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // color_half, coc_half: written by dof_downsample (read-after-write).
    // bg_half, fg_half, fg_big_half: written from scratch (only the large tiles' pixels; the
    //   rest is never read).
    rec.image_barriers(&[
        after_compute_write(b.color_half),
        after_compute_write(b.coc_half),
        overwrite(b.bg_half),
        overwrite(b.fg_half),
        overwrite(b.fg_big_half),
    ]);
    kernel.dispatch_indirect(rec, b, push, args, (CLASS_LARGE * ARGS_DISPATCH_WORDS * 4) as u64)?;
    rec.end_pass();
    Ok(())
}
