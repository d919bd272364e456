//! Tiled depth of field: level 1 of the pyramid (half resolution, colour and CoC of the pixels
//! that blur) with highlight extraction into sprites. Shader: glsl/dof_downsample.comp.

use super::barriers::overwrite;
use super::groups_for;
use super::twin::finite_or_zero;
use crate::gpu::shaders::dof_tiles::{
    ARGS_BIN_DISPATCH, ARGS_SPRITES_DROPPED, ARGS_SPRITE_COUNT, GROUP_SIZE, SPRITE_WORDS,
};
use crate::gpu::{GpuResult, HostData, HostImage, Kernel, Recorder, Shader, Twin};

pub const NAME: &str = "dof_downsample";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DownsamplePush {
    pub size: [i32; 2],
    pub half_size: [i32; 2],
    /// Sprites come from pixels of a larger CoC radius (px).
    pub small_radius_px: f32,
    /// A highlight is at least this bright (luminance) ...
    pub highlight_min: f32,
    /// ... and this many times its background.
    pub highlight_ratio: f32,
    pub sprite_capacity: i32,
    /// Smallest visible excess per pixel, relative to the background.
    pub sprite_visibility: f32,
    /// Luminance of R, G and B in the frame's colour space.
    pub luminance_weights: [f32; 3],
}

crate::shader_bindings! {
    /// The bindings of glsl/dof_downsample.comp.
    pub struct DownsampleBindings {
        color: image(color_in),
        coc: image(coc_px),
        color_half: image(color_half),
        coc_half: image(coc_half),
        args: buffer(Args),
        sprites: buffer(Sprites),
        color_base: image(color_base),
    }
}

/// glsl/dof_downsample.comp: one invocation per half-resolution texel.
pub struct DownsampleShader;

impl Shader for DownsampleShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = DownsampleBindings<'a>;
    type Push = DownsamplePush;
}

fn luminance(c: &[f32], w: [f32; 3]) -> f32 {
    w[0] * c[0] + w[1] * c[1] + w[2] * c[2]
}

/// The background of a highlight at (x, y): glsl/dof_downsample.comp's `background`.
fn background(color: &HostImage, size: [i32; 2], x: i32, y: i32, weights: [f32; 3]) -> f32 {
    let (mut sum, mut sides) = (0.0f32, 0.0f32);
    for side in 0..4 {
        let mut dimmest = 3.0e38f32;
        for k in -3..3 {
            let (dx, dy) = [(k, -3), (3, k), (-k, 3), (-3, -k)][side];
            let (qx, qy) = (x + dx, y + dy);
            if qx < 0 || qy < 0 || qx >= size[0] || qy >= size[1] {
                continue;
            }
            let q: Vec<f32> = color.clamped(qx, qy).iter().map(|&v| finite_or_zero(v)).collect();
            dimmest = dimmest.min(luminance(&q, weights));
        }
        if dimmest < 3.0e38 {
            sum += dimmest;
            sides += 1.0;
        }
    }
    sum / sides.max(1.0)
}

impl Twin for DownsampleShader {
    fn cpu(pc: &DownsamplePush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (mut color_half, mut coc_half, mut base) =
            (b[2].image().clone(), b[3].image().clone(), b[6].image().clone());
        let mut sprites = Vec::new();
        let (mut count, mut dropped, mut bin_groups) = (b[4].words()[ARGS_SPRITE_COUNT as usize], 0u32, 0u32);
        for hy in 0..pc.half_size[1] {
            for hx in 0..pc.half_size[0] {
                let (mut sum, mut coc_sum, mut weight) = ([0.0f32; 4], 0.0f32, 0.0f32);
                for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (x, y) = (2 * hx + i, 2 * hy + j);
                    if x >= pc.size[0] || y >= pc.size[1] {
                        continue;
                    }
                    let mut c: [f32; 4] = std::array::from_fn(|k| finite_or_zero(color.clamped(x, y)[k]));
                    let coc_p = coc.clamped(x, y)[0];
                    let radius = 0.5 * coc_p.abs();
                    let lum = luminance(&c, pc.luminance_weights);
                    if radius > pc.small_radius_px && lum > pc.highlight_min {
                        let bg = background(&color, pc.size, x, y, pc.luminance_weights);
                        let reference = pc.highlight_min.max(pc.highlight_ratio * bg);
                        let area = std::f32::consts::PI * 0.25 * coc_p * coc_p;
                        let visible =
                            (lum - reference) / area.max(1.0) > pc.sprite_visibility * bg.max(pc.highlight_min * 0.01);
                        if lum > reference && visible {
                            let excess: [f32; 3] = std::array::from_fn(|k| c[k] * (1.0 - bg / lum));
                            let slot = count;
                            count += 1;
                            if (slot as i32) < pc.sprite_capacity {
                                let centre = [x as f32 + 0.5, y as f32 + 0.5];
                                sprites.push((
                                    slot,
                                    [centre[0], centre[1], coc_p, 0.0, excess[0], excess[1], excess[2], 0.0],
                                ));
                                for k in 0..3 {
                                    c[k] -= excess[k];
                                }
                                if slot % GROUP_SIZE == 0 {
                                    bin_groups += 1;
                                }
                            } else {
                                dropped += 1;
                            }
                        }
                    }
                    base.texel_mut(x as u32, y as u32).copy_from_slice(&c);
                    let w = (radius - 0.5).clamp(0.0, 1.0);
                    for k in 0..4 {
                        sum[k] += w * c[k];
                    }
                    coc_sum += w * coc_p;
                    weight += w;
                }
                color_half.texel_mut(hx as u32, hy as u32).copy_from_slice(&sum.map(|v| 0.25 * v));
                let cw = [if weight > 0.0 { coc_sum / weight } else { 0.0 }, 0.25 * weight];
                coc_half.texel_mut(hx as u32, hy as u32).copy_from_slice(&cw);
            }
        }
        b[2] = HostData::Image(color_half);
        b[3] = HostData::Image(coc_half);
        b[6] = HostData::Image(base);
        let args = b[4].words_mut();
        args[ARGS_SPRITE_COUNT as usize] = count;
        args[ARGS_SPRITES_DROPPED as usize] += dropped;
        args[ARGS_BIN_DISPATCH as usize] += bin_groups;
        let words = b[5].words_mut();
        for (slot, sprite) in sprites {
            let at = slot as usize * SPRITE_WORDS as usize;
            for (k, v) in sprite.iter().enumerate() {
                words[at + k] = v.to_bits();
            }
        }
    }

    /// Sprites take slots with atomics, in any order: sort them by their centre.
    fn canonical(pc: &DownsamplePush, b: &mut [HostData]) {
        let count = (b[4].words()[ARGS_SPRITE_COUNT as usize] as usize).min(pc.sprite_capacity.max(0) as usize);
        sort_sprites(b[5].words_mut(), count);
    }
}

/// The first `count` sprites of a sprite buffer sorted by their centre (row, then column).
pub fn sort_sprites(words: &mut [u32], count: usize) {
    let stride = SPRITE_WORDS as usize;
    let mut sprites: Vec<Vec<u32>> = words[..count * stride].chunks_exact(stride).map(|s| s.to_vec()).collect();
    sprites.sort_by_key(|s| (s[1], s[0]));
    for (i, s) in sprites.iter().enumerate() {
        words[i * stride..(i + 1) * stride].copy_from_slice(s);
    }
}

pub fn record(
    kernel: &Kernel<DownsampleShader>,
    rec: &mut Recorder,
    b: &DownsampleBindings<'_>,
    push: &DownsamplePush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // color_half, coc_half, color_base: written from scratch. The inputs (colour, CoC) and the
    // args buffer were made visible to compute by the barriers around dof_classify.
    rec.image_barriers(&[overwrite(b.color_half), overwrite(b.coc_half), overwrite(b.color_base)]);
    kernel.dispatch(rec, b, push, groups_for(b.color_half.width, b.color_half.height))?;
    rec.end_pass();
    Ok(())
}

/// The size of the sprite buffer for `capacity` sprites, in bytes.
pub fn sprite_buffer_bytes(capacity: u32) -> u64 {
    capacity as u64 * SPRITE_WORDS as u64 * 4
}
