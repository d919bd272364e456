//! Tiled depth of field: the level tiles at full resolution (the tile's level upsampled, the
//! exact gather for nearly sharp pixels; the highlight sprites come after, dof_sprites). Shader:
//! glsl/dof/dof_composite.comp.

use super::aperture::{ApertureConstants, ApertureData};
use super::bokeh_gather::gather_exact;
use crate::gpu::shaders::dof_tiles::{EXACT_BLEND_ABOVE_SMALL_PX, LIST_BLURRED_LEVEL1};
use crate::gpu::{GpuBuffer, GpuResult, HostData, HostImage, Recorder, Shader, SpecializedKernel, Twin};
use crate::passes::barriers::{after_compute_write, args_for_indirect, buffer_after_compute_write, write_after_write};
use crate::passes::twin::{floats, listed_tiles};
use crate::passes::TILE_SIZE;

pub const NAME: &str = "dof_composite";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CompositePush {
    pub size: [i32; 2],
    pub level_size: [i32; 2],
    pub tiles: [i32; 2],
    pub level: i32,
    pub small_radius_px: f32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
    /// The tile list the dispatch takes: the level's class list (`CLASS_LEVEL1 + level - 1`),
    /// or its blurred list (`LIST_BLURRED_LEVEL1 + level - 1`, the pipeline without the exact
    /// gather).
    pub list: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_composite.comp.
    pub struct CompositeBindings {
        color: image(color_in),
        coc: image(coc_px),
        bg_level: image(bg_level),
        fg_level: image(fg_level),
        output: image(color_out),
        tile_lists: buffer(TileLists),
        aperture_mask: buffer(ApertureMask),
        coc_level: image(coc_level),
        fg_big_level: image(fg_big_level),
        tile_radius: buffer(TileRadius),
        aperture_shape: image(aperture_shape),
        coverage_level: image(coverage_level),
    }
}

/// glsl/dof/dof_composite.comp: one workgroup per tile of the level.
pub struct CompositeShader;

impl Shader for CompositeShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CompositeBindings<'a>;
    type Push = CompositePush;
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Of texels of up to four channels (the coverage layer has two; the others read as 0).
fn mix4(a: &[f32], b: &[f32], t: f32) -> [f32; 4] {
    let at = |v: &[f32], k: usize| v.get(k).copied().unwrap_or(0.0);
    std::array::from_fn(|k| at(a, k) * (1.0 - t) + at(b, k) * t)
}

/// Bilinear between the four level texels from `h0` (edge texels continue).
fn bilinear(img: &HostImage, h0: [i32; 2], f: [f32; 2]) -> [f32; 4] {
    let at = |x: i32, y: i32| img.clamped(x, y);
    let top = mix4(at(h0[0], h0[1]), at(h0[0] + 1, h0[1]), f[0]);
    let bottom = mix4(at(h0[0], h0[1] + 1), at(h0[0] + 1, h0[1] + 1), f[0]);
    mix4(&top, &bottom, f[1])
}

impl Twin for CompositeShader {
    fn cpu(pc: &CompositePush, groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (bg_level, fg_level) = (b[2].image().clone(), b[3].image().clone());
        let (lists, radii) = (b[5].words().to_vec(), floats(b[9].words()));
        let data = ApertureData::from_bindings(&b[6], &b[10], pc.aperture.shape_radius);
        let (coc_level, fg_big_level) = (b[7].image().clone(), b[8].image().clone());
        let coverage_level = b[11].image().clone();
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let scale = (1 << pc.level) as f32;
        let out = b[4].image_mut();
        // The pipeline of the blurred lists has no exact gather; their tiles' pixels all have
        // `blurred` 1, so the rule below is both pipelines'.
        for tile in listed_tiles(&lists, pc.list as u32, pc.tiles, groups[0], TILE_SIZE, pc.size) {
            let t = tile.index;
            for (x, y) in tile.pixels() {
                let p = [x as i32, y as i32];
                let h = [(x as f32 + 0.5) / scale - 0.5, (y as f32 + 0.5) / scale - 0.5];
                let h0 = [h[0].floor() as i32, h[1].floor() as i32];
                let f = [h[0] - h0[0] as f32, h[1] - h0[1] as f32];
                let coc_here = coc.clamped(p[0], p[1])[0];
                let (mut bg, mut bg_weight) = ([0.0f32; 4], 0.0f32);
                for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let q = [(h0[0] + i).clamp(0, pc.level_size[0] - 1), (h0[1] + j).clamp(0, pc.level_size[1] - 1)];
                    let cw = coc_level.clamped(q[0], q[1]);
                    let bilinear_w =
                        (if i == 0 { 1.0 - f[0] } else { f[0] }) * (if j == 0 { 1.0 - f[1] } else { f[1] });
                    let similar = cw[1];
                    let texel = bg_level.clamped(q[0], q[1]);
                    for k in 0..4 {
                        bg[k] += bilinear_w * similar * texel[k];
                    }
                    bg_weight += bilinear_w * similar;
                }
                if bg_weight > 0.0 {
                    bg = bg.map(|v| v / bg_weight);
                } else {
                    bg.copy_from_slice(bg_level.clamped(h0[0], h0[1]));
                }
                let mut fg = bilinear(&fg_level, h0, f);
                let coverage = bilinear(&coverage_level, h0, f);
                let mut fg_coverage = coverage[0];
                let radius_p = 0.5 * coc_here.abs();
                let blend_top_px = pc.small_radius_px + EXACT_BLEND_ABOVE_SMALL_PX as f32;
                let blurred = smoothstep(pc.small_radius_px - 0.5, blend_top_px, radius_p);
                let mut base = bg;
                if blurred < 1.0 {
                    let fg_radius = radii[tile_count + t];
                    let disc_px = data.tap_disc_px((pc.small_radius_px + 1.0).min(radius_p.max(fg_radius)));
                    let (a, l) = (&pc.aperture, pc.layer_transition_px);
                    let mut exact = gather_exact(&color.texels, &coc.texels, pc.size, p, disc_px, a, l, &data);
                    let big = bilinear(&fg_big_level, h0, f);
                    exact = std::array::from_fn(|k| exact[k] * (1.0 - coverage[1]) + big[k]);
                    base = mix4(&exact, &bg, blurred);
                    fg_coverage *= blurred;
                    fg = fg.map(|v| v * blurred);
                }
                // The foregrounds premultiplied by their coverage; alpha composited as the colour.
                let rgba: [f32; 4] = std::array::from_fn(|k| base[k] * (1.0 - fg_coverage) + fg[k]);
                out.texel_mut(x, y).copy_from_slice(&rgba);
            }
        }
    }
}

/// The composite's specialisation: the aperture's two constants, then whether the exact gather is
/// in the code (off for the blurred lists).
pub fn specialization(aperture: [u32; 2], exact_gather: bool) -> [u32; 3] {
    [aperture[0], aperture[1], exact_gather as u32]
}

/// Record the composite over the tile list `push.list`, with the pipeline of `specialization`.
pub fn record(
    kernel: &SpecializedKernel<CompositeShader>,
    specialization: &[u32],
    rec: &mut Recorder,
    b: &CompositeBindings<'_>,
    args: &GpuBuffer,
    push: &CompositePush,
) -> GpuResult<()> {
    let blurred = push.list as u32 >= LIST_BLURRED_LEVEL1;
    rec.begin_pass(&format!("{NAME}_{}{}", push.level, if blurred { "_blurred" } else { "" }));
    // bg/fg/fg_big_level: written by the level gather (read-after-write).
    // color (the input colour less the sprites' energy): written in place by dof_sprite_excess.
    // coc_level: written by the pyramid passes.
    // output: the full-resolution tile passes and the other composites (the other levels', and
    //   the level's other list) wrote other tiles of it; the write-after-write dependency keeps
    //   sync validation (which tracks whole images) and any driver honest.
    // tile_lists, args (this dispatch's list and size): dof_classify wrote them, and
    //   dof_bin_order has since appended its list of sprite tiles and counted them (another
    //   list, other words; sync validation tracks whole buffers).
    rec.image_barriers(&[
        after_compute_write(b.color),
        after_compute_write(b.coc_level),
        after_compute_write(b.bg_level),
        after_compute_write(b.fg_level),
        after_compute_write(b.fg_big_level),
        after_compute_write(b.coverage_level),
        write_after_write(b.output),
    ]);
    rec.buffer_barriers(&[buffer_after_compute_write(b.tile_lists), args_for_indirect(args)]);
    let offset = super::classify::list_tiles_args_word(push.list as u32) as u64 * 4;
    kernel.dispatch_indirect(rec, specialization, b, push, args, offset)?;
    rec.end_pass();
    Ok(())
}
