//! Tiled depth of field: half-resolution colour and CoC for the large-CoC path, with highlight
//! extraction into sprites. Shader: glsl/dof_downsample.comp.

use super::barriers::overwrite;
use super::groups_for;
use super::twin::finite_or_zero;
use crate::gpu::shaders::dof_tiles::{ARGS_SPRITES_DROPPED, ARGS_SPRITE_COUNT, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};

pub const NAME: &str = "dof_downsample";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DownsamplePush {
    pub size: [i32; 2],
    pub half_size: [i32; 2],
    pub small_radius_px: f32,
    /// A highlight is at least this bright (luminance) ...
    pub highlight_min: f32,
    /// ... and this many times its neighbours' mean.
    pub highlight_ratio: f32,
    pub sprite_capacity: i32,
    /// Smallest visible excess per pixel, relative to the surroundings.
    pub sprite_visibility: f32,
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

/// glsl/dof_downsample.comp: one invocation per half-resolution pixel.
pub struct DownsampleShader;

impl Shader for DownsampleShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = DownsampleBindings<'a>;
    type Push = DownsamplePush;
}

fn luminance(c: &[f32]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

impl Twin for DownsampleShader {
    fn cpu(pc: &DownsamplePush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let inside = |x: i32, y: i32| x >= 0 && y >= 0 && x < pc.size[0] && y < pc.size[1];
        let mut sprites = Vec::new();
        let mut dropped = 0u32;
        let mut base = b[6].image().clone();
        let (mut color_half, mut coc_half) = (b[2].image().clone(), b[3].image().clone());
        let mut sprite_count = b[4].words()[ARGS_SPRITE_COUNT as usize];
        for hy in 0..pc.half_size[1] {
            for hx in 0..pc.half_size[0] {
                let (mut sum, mut coc_sum, mut n) = ([0.0f32; 4], 0.0f32, 0.0f32);
                for j in 0..2 {
                    for i in 0..2 {
                        let (x, y) = (2 * hx + i, 2 * hy + j);
                        if !inside(x, y) {
                            continue;
                        }
                        let mut c: [f32; 4] = std::array::from_fn(|k| finite_or_zero(color.clamped(x, y)[k]));
                        let coc_p = coc.clamped(x, y)[0];
                        let lum = luminance(&c);
                        if 0.5 * coc_p.abs() > pc.small_radius_px && lum > pc.highlight_min {
                            // The ring of pixels 3 px away: the highlight's surroundings.
                            let (mut neighbours, mut count) = (0.0f32, 0.0f32);
                            for k in -3..3 {
                                for (dx, dy) in [(k, -3), (3, k), (-k, 3), (-3, -k)] {
                                    if inside(x + dx, y + dy) {
                                        let q: Vec<f32> =
                                            color.clamped(x + dx, y + dy).iter().map(|&v| finite_or_zero(v)).collect();
                                        neighbours += luminance(&q);
                                        count += 1.0;
                                    }
                                }
                            }
                            let mean = neighbours / count.max(1.0);
                            let reference = pc.highlight_min.max(pc.highlight_ratio * mean);
                            let area = std::f32::consts::PI * 0.25 * coc_p * coc_p;
                            let visible = (lum - reference) / area.max(1.0)
                                > pc.sprite_visibility * mean.max(pc.highlight_min * 0.01);
                            if lum > reference && visible {
                                let excess: [f32; 3] = std::array::from_fn(|k| c[k] * (1.0 - reference / lum));
                                let slot = sprite_count;
                                sprite_count += 1;
                                if (slot as i32) < pc.sprite_capacity {
                                    sprites.push((
                                        slot,
                                        [
                                            x as f32 + 0.5,
                                            y as f32 + 0.5,
                                            coc_p,
                                            0.0,
                                            excess[0],
                                            excess[1],
                                            excess[2],
                                            0.0,
                                        ],
                                    ));
                                    for k in 0..3 {
                                        c[k] -= excess[k];
                                    }
                                } else {
                                    dropped += 1;
                                }
                            }
                        }
                        base.texel_mut(x as u32, y as u32).copy_from_slice(&c);
                        for k in 0..4 {
                            sum[k] += c[k];
                        }
                        coc_sum += coc_p;
                        n += 1.0;
                    }
                }
                let texel = sum.map(|v| v / n.max(1.0));
                color_half.texel_mut(hx as u32, hy as u32).copy_from_slice(&texel);
                coc_half.texel_mut(hx as u32, hy as u32)[0] = coc_sum / n.max(1.0);
            }
        }
        b[2] = HostData::Image(color_half);
        b[3] = HostData::Image(coc_half);
        b[6] = HostData::Image(base);
        let args = b[4].words_mut();
        args[ARGS_SPRITE_COUNT as usize] = sprite_count;
        args[ARGS_SPRITES_DROPPED as usize] += dropped;
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
        let stride = SPRITE_WORDS as usize;
        let words = b[5].words_mut();
        let mut sprites: Vec<Vec<u32>> = words[..count * stride].chunks_exact(stride).map(|s| s.to_vec()).collect();
        let key = |s: &Vec<u32>| (f32::from_bits(s[1]).to_bits(), f32::from_bits(s[0]).to_bits());
        sprites.sort_by_key(key);
        for (i, s) in sprites.iter().enumerate() {
            words[i * stride..(i + 1) * stride].copy_from_slice(s);
        }
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
    // args buffer were made visible to compute by the barriers before dof_classify and after it.
    rec.image_barriers(&[overwrite(b.color_half), overwrite(b.coc_half), overwrite(b.color_base)]);
    kernel.dispatch(rec, b, push, groups_for(b.color_half.width, b.color_half.height))?;
    rec.end_pass();
    Ok(())
}
