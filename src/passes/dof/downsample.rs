//! Tiled depth of field: level 1 of the pyramid (half resolution, colour and CoC of the pixels
//! that blur), and the list of texels holding highlight candidates for dof_highlights.
//! Shader: glsl/dof/dof_downsample.comp.

use crate::gpu::shaders::dof_tiles::{ARGS_HIGHLIGHT_COUNT, ARGS_HIGHLIGHT_DISPATCH, GROUP_SIZE, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, HostImage, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::overwrite;
use crate::passes::groups_for;
use crate::passes::twin::finite_or_zero;

pub const NAME: &str = "dof_downsample";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DownsamplePush {
    pub size: [i32; 2],
    pub half_size: [i32; 2],
    /// Highlight candidates are pixels of a larger CoC radius (px) ...
    pub small_radius_px: f32,
    /// ... at least this bright (luminance).
    pub highlight_min: f32,
    /// Luminance of R, G and B in the frame's colour space.
    pub luminance_weights: [f32; 3],
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_downsample.comp.
    pub struct DownsampleBindings {
        color: image(color_in),
        coc: image(coc_px),
        color_half: image(color_half),
        coc_half: image(coc_half),
        args: buffer(Args),
        candidates: buffer(Candidates),
    }
}

/// glsl/dof/dof_downsample.comp: one invocation per half-resolution texel.
pub struct DownsampleShader;

impl Shader for DownsampleShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = DownsampleBindings<'a>;
    type Push = DownsamplePush;
}

/// Luminance in the frame's colour space (`weights`: the Y row of its RGB to XYZ matrix): the
/// highlight tests' brightness.
pub fn luminance(c: &[f32], weights: [f32; 3]) -> f32 {
    weights[0] * c[0] + weights[1] * c[1] + weights[2] * c[2]
}

/// The pixels of half-resolution texel (hx, hy) inside a frame of `size`: each position, its
/// colour (non-finite values as 0, as the shaders read it) and its signed CoC.
pub fn texel_pixels<'a>(
    color: &'a HostImage,
    coc: &'a HostImage,
    size: [i32; 2],
    hx: i32,
    hy: i32,
) -> impl Iterator<Item = (i32, i32, [f32; 4], f32)> + 'a {
    [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().filter_map(move |(i, j)| {
        let (x, y) = (2 * hx + i, 2 * hy + j);
        if x >= size[0] || y >= size[1] {
            return None;
        }
        let c: [f32; 4] = std::array::from_fn(|k| finite_or_zero(color.clamped(x, y)[k]));
        Some((x, y, c, coc.clamped(x, y)[0]))
    })
}

/// A half-resolution texel in the candidate list: x | y << 16.
pub fn pack_texel(x: i32, y: i32) -> u32 {
    x as u32 | ((y as u32) << 16)
}

impl Twin for DownsampleShader {
    fn cpu(pc: &DownsamplePush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (mut color_half, mut coc_half) = (b[2].image().clone(), b[3].image().clone());
        let mut listed = Vec::new();
        for hy in 0..pc.half_size[1] {
            for hx in 0..pc.half_size[0] {
                let (mut sum, mut coc_near, mut weight, mut candidate) = ([0.0f32; 4], f32::INFINITY, 0.0f32, false);
                for (_, _, c, coc_p) in texel_pixels(&color, &coc, pc.size, hx, hy) {
                    let radius = 0.5 * coc_p.abs();
                    candidate |= radius > pc.small_radius_px && luminance(&c, pc.luminance_weights) > pc.highlight_min;
                    let w = (radius - 0.5).clamp(0.0, 1.0);
                    for k in 0..4 {
                        sum[k] += w * c[k];
                    }
                    weight += w;
                    if w > 0.0 {
                        coc_near = coc_near.min(coc_p);
                    }
                }
                color_half.texel_mut(hx as u32, hy as u32).copy_from_slice(&sum.map(|v| 0.25 * v));
                let cw = [if weight > 0.0 { coc_near } else { 0.0 }, 0.25 * weight];
                coc_half.texel_mut(hx as u32, hy as u32).copy_from_slice(&cw);
                if candidate {
                    listed.push(pack_texel(hx, hy));
                }
            }
        }
        b[2] = HostData::Image(color_half);
        b[3] = HostData::Image(coc_half);
        let args = b[4].words_mut();
        let first = args[ARGS_HIGHLIGHT_COUNT as usize];
        let groups = (first..first + listed.len() as u32).filter(|slot| slot % GROUP_SIZE == 0).count() as u32;
        args[ARGS_HIGHLIGHT_COUNT as usize] += listed.len() as u32;
        args[ARGS_HIGHLIGHT_DISPATCH as usize] += groups;
        let words = b[5].words_mut();
        words[first as usize..first as usize + listed.len()].copy_from_slice(&listed);
    }

    /// Texels take slots with atomics, in any order: sort the list.
    fn canonical(_pc: &DownsamplePush, b: &mut [HostData]) {
        let count = b[4].words()[ARGS_HIGHLIGHT_COUNT as usize] as usize;
        let words = b[5].words_mut();
        let count = count.min(words.len());
        words[..count].sort_unstable();
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
    // color_half, coc_half: written from scratch. The inputs (colour, CoC) and the args buffer
    // were made visible to compute by the barriers around dof_classify. The candidate list is
    // this frame's own buffer, written here first.
    rec.image_barriers(&[overwrite(b.color_half), overwrite(b.coc_half)]);
    kernel.dispatch(rec, b, push, groups_for(b.color_half.width, b.color_half.height))?;
    rec.end_pass();
    Ok(())
}

/// The size of the candidate list of a half-resolution level of `texels` texels, in bytes.
pub fn candidate_buffer_bytes(texels: u64) -> u64 {
    texels.max(1) * 4
}

/// The size of the sprite buffer for `capacity` sprites, in bytes.
pub fn sprite_buffer_bytes(capacity: u32) -> u64 {
    capacity as u64 * SPRITE_WORDS as u64 * 4
}
