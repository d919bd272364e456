//! Tiled depth of field: the highlights among the candidate texels dof_downsample listed become
//! sprites, their excess over the background taken out of the pyramid's level 1 (and, by
//! dof_sprite_excess, out of the colour the composite's exact gathers read). Shader:
//! glsl/dof/dof_highlights.comp.

use super::downsample::{luminance, texel_pixels};
use crate::gpu::shaders::dof_tiles::{
    ARGS_BIN_DISPATCH, ARGS_HIGHLIGHT_COUNT, ARGS_HIGHLIGHT_DISPATCH, ARGS_SPRITES_DROPPED, ARGS_SPRITE_COUNT,
    GROUP_SIZE, SPRITE_WORDS,
};
use crate::gpu::{GpuResult, HostData, HostImage, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{args_for_indirect, buffer_after_compute_write, write_after_write};
use crate::passes::twin::finite_or_zero;

pub const NAME: &str = "dof_highlights";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HighlightsPush {
    pub size: [i32; 2],
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
    /// The bindings of glsl/dof/dof_highlights.comp.
    pub struct HighlightsBindings {
        color: image(color_in),
        coc: image(coc_px),
        color_half: image(color_half),
        args: buffer(Args),
        candidates: buffer(Candidates),
        sprites: buffer(Sprites),
    }
}

/// glsl/dof/dof_highlights.comp: one invocation per listed texel (indirect).
pub struct HighlightsShader;

impl Shader for HighlightsShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = HighlightsBindings<'a>;
    type Push = HighlightsPush;
}

/// The background of a highlight at (x, y): glsl/dof/dof_highlights.comp's `background`.
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

/// The brightest luminance of (x, y)'s 3x3 neighbourhood in the frame (glsl/dof/dof_highlights.comp's
/// `neighbourhood_peak`).
pub fn neighbourhood_peak(color: &HostImage, size: [i32; 2], x: i32, y: i32, weights: [f32; 3]) -> f32 {
    let mut peak = f32::MIN;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let (qx, qy) = (x + dx, y + dy);
            if qx < 0 || qy < 0 || qx >= size[0] || qy >= size[1] {
                continue;
            }
            let q: Vec<f32> = color.clamped(qx, qy).iter().map(|&v| finite_or_zero(v)).collect();
            peak = peak.max(luminance(&q, weights));
        }
    }
    peak
}

impl Twin for HighlightsShader {
    fn cpu(pc: &HighlightsPush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let mut color_half = b[2].image().clone();
        let candidates = b[4].words().to_vec();
        let listed = (b[3].words()[ARGS_HIGHLIGHT_COUNT as usize] as usize).min(candidates.len());
        let mut sprites = Vec::new();
        let (mut count, mut dropped, mut bin_groups) = (b[3].words()[ARGS_SPRITE_COUNT as usize], 0u32, 0u32);
        for &packed in &candidates[..listed] {
            let (hx, hy) = ((packed & 0xffff) as i32, (packed >> 16) as i32);
            let mut removed = [0.0f32; 3];
            for (x, y, c, coc_p) in texel_pixels(&color, &coc, pc.size, hx, hy) {
                let radius = 0.5 * coc_p.abs();
                let lum = luminance(&c, pc.luminance_weights);
                if radius <= pc.small_radius_px || lum <= pc.highlight_min {
                    continue;
                }
                let bg = background(&color, pc.size, x, y, pc.luminance_weights);
                let reference = pc.highlight_min.max(pc.highlight_ratio * bg);
                let area = std::f32::consts::PI * 0.25 * coc_p * coc_p;
                let peak = neighbourhood_peak(&color, pc.size, x, y, pc.luminance_weights);
                let visible =
                    (peak - reference) / area.max(1.0) > pc.sprite_visibility * bg.max(pc.highlight_min * 0.01);
                if lum <= reference || !visible {
                    continue;
                }
                let excess: [f32; 3] = std::array::from_fn(|k| c[k] * (1.0 - bg / lum));
                let slot = count;
                count += 1;
                if (slot as i32) < pc.sprite_capacity {
                    let centre = [x as f32 + 0.5, y as f32 + 0.5];
                    sprites.push((slot, [centre[0], centre[1], coc_p, 0.0, excess[0], excess[1], excess[2], 0.0]));
                    let w = (radius - 0.5).clamp(0.0, 1.0);
                    for k in 0..3 {
                        removed[k] += w * excess[k];
                    }
                    if slot % GROUP_SIZE == 0 {
                        bin_groups += 1;
                    }
                } else {
                    dropped += 1;
                }
            }
            let texel = color_half.texel_mut(hx as u32, hy as u32);
            for k in 0..3 {
                texel[k] -= 0.25 * removed[k];
            }
        }
        b[2] = HostData::Image(color_half);
        let args = b[3].words_mut();
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
    fn canonical(pc: &HighlightsPush, b: &mut [HostData]) {
        let count = crate::passes::twin::sprites_written(b[3].words(), pc.sprite_capacity);
        super::downsample::sort_sprites(b[5].words_mut(), count);
    }
}

pub fn record(
    kernel: &Kernel<HighlightsShader>,
    rec: &mut Recorder,
    b: &HighlightsBindings<'_>,
    push: &HighlightsPush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // args (this dispatch's size, the candidate count) and the candidate list: written by
    //   dof_downsample with atomics; read here as indirect arguments and by the shader.
    // color_half: written by dof_downsample; this pass takes the sprites' excess out of some of
    //   its texels (read-modify-write). The colour it reads has had no writer since
    //   dof_downsample read it (dof_sprite_excess comes after this pass).
    rec.buffer_barriers(&[args_for_indirect(b.args), buffer_after_compute_write(b.candidates)]);
    rec.image_barriers(&[write_after_write(b.color_half)]);
    kernel.dispatch_indirect(rec, b, push, b.args, ARGS_HIGHLIGHT_DISPATCH as u64 * 4)?;
    rec.end_pass();
    Ok(())
}
