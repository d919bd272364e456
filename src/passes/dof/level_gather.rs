//! Tiled depth of field: the gather of one pyramid level's tiles at that level's resolution.
//! Shader: glsl/dof/dof_level_gather.comp.

use super::aperture::{gather_reach, tap_disc_rows, tap_weight_at_reach, ApertureConstants, ApertureData};
use super::classify::tiles_per_group;
use crate::gpu::shaders::dof_tiles::{ARGS_LEVEL_TILES_BASE, CLASS_LEVEL1, LEVEL_LIST_TILE_BITS};
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::passes::barriers::{after_compute_write, overwrite};
use crate::passes::twin::floats;

pub const NAME: &str = "dof_level_gather";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LevelGatherPush {
    pub level_size: [i32; 2],
    pub tiles: [i32; 2],
    pub level: i32,
    /// In level units.
    pub aperture: ApertureConstants,
    /// In level units.
    pub layer_transition_px: f32,
    /// In level units: samples with a larger CoC radius also go to the large-CoC foreground.
    pub small_radius_px: f32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_level_gather.comp.
    pub struct LevelGatherBindings {
        color_level: image(color_level),
        coc_level: image(coc_level),
        bg_level: image(bg_level),
        fg_level: image(fg_level),
        level_lists: buffer(LevelLists),
        tile_radius: buffer(TileRadius),
        aperture_mask: buffer(ApertureMask),
        fg_big_level: image(fg_big_level),
        args: buffer(Args),
        aperture_shape: image(aperture_shape),
        coverage_level: image(coverage_level),
    }
}

/// Bit (dy + 1) * 3 + (dx + 1): the tile at (dx, dy) from tile `tc` (the tile itself at bit 4) is
/// of level `level`'s class; `class` holds every tile's class (the tile radius buffer's third part).
pub fn level_neighbours(class: &[f32], tiles: [i32; 2], tc: [i32; 2], level: i32) -> u32 {
    let mut near = 0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let n = [tc[0] + dx, tc[1] + dy];
            if n[0] < 0 || n[1] < 0 || n[0] >= tiles[0] || n[1] >= tiles[1] {
                continue;
            }
            if class[(n[1] * tiles[0] + n[0]) as usize] as i32 == (CLASS_LEVEL1 as i32) + level - 1 {
                near |= 1 << ((dy + 1) * 3 + dx + 1);
            }
        }
    }
    near
}

/// Whether a level's composite reads texel `xy` of a tile of side `side` whose neighbours of the
/// level's class are `near` (level_neighbours): the composite upsamples bilinearly, so a level
/// tile's composite reads its own texels and a ring of one texel around them.
pub fn texel_read(xy: [i32; 2], side: i32, near: u32) -> bool {
    let edges = |v: i32| 2 | u32::from(v == 0) | (u32::from(v == side - 1) << 2);
    let (xs, ys) = (edges(xy[0]), edges(xy[1]));
    let next_to = (0..3).filter(|&row| ys & (1 << row) != 0).fold(0, |m, row| m | xs << (3 * row));
    next_to & near != 0
}

/// A sample's reach on a level (texels), less the blur the pyramid's box and the composite's
/// bilinear tent add (1/4 texel^2 per axis against the disc's r^2 / 4): sqrt(r^2 - 1).
pub fn level_reach(reach: f32) -> f32 {
    (reach * reach - 1.0).max(0.25).sqrt()
}

/// glsl/dof/dof_level_gather.comp: GROUP_SIZE texels of the level's tiles per workgroup.
pub struct LevelGatherShader;

impl Shader for LevelGatherShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = LevelGatherBindings<'a>;
    type Push = LevelGatherPush;
}

impl Twin for LevelGatherShader {
    fn cpu(pc: &LevelGatherPush, groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (lists, radii) = (b[4].words().to_vec(), floats(b[5].words()));
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let data = ApertureData::from_bindings(&b[6], &b[9], pc.aperture.shape_radius);
        let count = b[8].words()[(ARGS_LEVEL_TILES_BASE + pc.level as u32 - 1) as usize] as usize;
        let side = (crate::passes::TILE_SIZE >> pc.level) as i32;
        let per_group = tiles_per_group(pc.level as u32) as usize;
        let to_level = 1.0 / (1 << pc.level) as f32;
        let (mut bg_out, mut fg_out, mut big_out) = (b[2].image().clone(), b[3].image().clone(), b[7].image().clone());
        let mut coverage_out = b[10].image().clone();
        let slots = (groups[0] as usize * per_group).min(count);
        for slot in 0..slots {
            let entry = lists[(pc.level as usize - 1) * tile_count + slot];
            let (t, near) = ((entry & ((1 << LEVEL_LIST_TILE_BITS) - 1)) as usize, entry >> LEVEL_LIST_TILE_BITS);
            let tc = [(t % pc.tiles[0] as usize) as i32, (t / pc.tiles[0] as usize) as i32];
            let origin = [tc[0] * side, tc[1] * side];
            for texel in 0..side * side {
                let xy = [texel % side, texel / side];
                let p = [origin[0] + xy[0], origin[1] + xy[1]];
                if p[0] >= pc.level_size[0] || p[1] >= pc.level_size[1] {
                    continue;
                }
                // A texel no composite reads (of a neighbour tile, away from the level's tiles): zero.
                if !texel_read(xy, side, near) {
                    for out in [&mut bg_out, &mut fg_out, &mut big_out, &mut coverage_out] {
                        out.texel_mut(p[0] as u32, p[1] as u32).fill(0.0);
                    }
                    continue;
                }
                let coc_p = coc.clamped(p[0], p[1])[0] * to_level;
                let tap_disc = data.tap_disc_px(radii[t] * to_level);
                let radius_p = (0.5 * coc_p.abs()).max(0.5);
                let reach_p = level_reach(radius_p);
                let area_p = pc.aperture.area_factor * reach_p * reach_p;
                let (mut bg, mut fg, mut big, mut hidden) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
                let (mut bg_w, mut fg_w, mut big_w) = (0.0f32, 0.0f32, 0.0f32);
                let (mut hidden_n, mut hidden_near_w, mut own_n) = (0.0f32, 0.0f32, 0.0f32);
                for (dy, half_width) in tap_disc_rows(tap_disc) {
                    for dx in -half_width..=half_width {
                        let q =
                            [(p[0] + dx).clamp(0, pc.level_size[0] - 1), (p[1] + dy).clamp(0, pc.level_size[1] - 1)];
                        let cw = coc.clamped(q[0], q[1]);
                        if cw[1] <= 0.0 {
                            continue;
                        }
                        let coc_q = cw[0] * to_level;
                        let radius_q = (0.5 * coc_q.abs()).max(0.5);
                        let sample = [(p[0] + dx) as f32 + 0.5, (p[1] + dy) as f32 + 0.5];
                        let reach = level_reach(gather_reach(coc_p, coc_q));
                        let w = tap_weight_at_reach([dx, dy], reach, coc_q, &pc.aperture, sample, &data);
                        let c = color.clamped(q[0], q[1]);
                        let f = ((coc_p - coc_q) / pc.layer_transition_px).clamp(0.0, 1.0);
                        // The background p's surface hides (the shader's fill), each texel by its weight.
                        let d2 = (dx * dx + dy * dy) as f32;
                        let in_p = if d2 <= radius_p * radius_p { 1.0 } else { 0.0 };
                        let behind = ((coc_q - coc_p) / pc.layer_transition_px).clamp(0.0, 1.0);
                        let unreached = in_p * behind * (1.0 - (w * area_p).min(1.0));
                        let closeness = radius_q * radius_q / (radius_q * radius_q + d2);
                        let near = unreached * closeness * closeness * closeness;
                        // c is premultiplied by the texel's weight cw[1].
                        for k in 0..4 {
                            hidden[k] += near * c[k];
                        }
                        hidden_near_w += near * cw[1];
                        hidden_n += unreached * cw[1];
                        own_n += in_p * (1.0 - f) * cw[1];
                        if w <= 0.0 {
                            continue;
                        }
                        for k in 0..4 {
                            fg[k] += f * w * c[k];
                            bg[k] += (1.0 - f) * w * c[k];
                        }
                        fg_w += f * w * cw[1];
                        bg_w += (1.0 - f) * w * cw[1];
                        if radius_q > pc.small_radius_px {
                            for k in 0..4 {
                                big[k] += f * w * c[k];
                            }
                            big_w += f * w * cw[1];
                        }
                    }
                }
                // Each layer the weighted mean of its samples' premultiplied RGBA (alpha as colour).
                let layer = |sum: [f32; 4], weight: f32| sum.map(|v| if weight > 0.0 { v / weight } else { 0.0 });
                // The weight missing from p's layer and behind, up to the hidden background's
                // share of p's disc, is that background's; the rest normalises.
                let hidden_share = if own_n > 0.0 { hidden_n / own_n } else { 0.0 };
                let missing = (1.0 - bg_w).max(0.0).min(hidden_share);
                let hidden_colour = layer(hidden, hidden_near_w);
                let lit: [f32; 4] = std::array::from_fn(|k| bg[k] + missing * hidden_colour[k]);
                bg_out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&layer(lit, bg_w + missing));
                // The foregrounds premultiplied by their coverage.
                let (coverage, big_coverage) = (fg_w.clamp(0.0, 1.0), big_w.clamp(0.0, 1.0));
                let fg = layer(fg, fg_w).map(|v| v * coverage);
                fg_out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&fg);
                let big = layer(big, big_w).map(|v| v * big_coverage);
                big_out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&big);
                let out = coverage_out.texel_mut(p[0] as u32, p[1] as u32);
                out[0] = coverage;
                out[1] = big_coverage;
            }
        }
        b[2] = HostData::Image(bg_out);
        b[3] = HostData::Image(fg_out);
        b[7] = HostData::Image(big_out);
        b[10] = HostData::Image(coverage_out);
    }
}

/// Record the gather of level `push.level`'s tiles (indirect, over its tile list).
pub fn record(
    kernel: &SpecializedKernel<LevelGatherShader>,
    specialization: &[u32],
    rec: &mut Recorder,
    b: &LevelGatherBindings<'_>,
    push: &LevelGatherPush,
) -> GpuResult<()> {
    rec.begin_pass(&format!("{NAME}_{}", push.level));
    // color_level, coc_level: written by the pyramid passes (read-after-write).
    // bg/fg/fg_big_level: written from scratch (only the texels of the level's tiles and their
    //   neighbours; the rest is never read).
    rec.image_barriers(&[
        after_compute_write(b.color_level),
        after_compute_write(b.coc_level),
        overwrite(b.bg_level),
        overwrite(b.fg_level),
        overwrite(b.fg_big_level),
        overwrite(b.coverage_level),
    ]);
    let offset = super::classify::level_gather_args_words(push.level as u32) as u64 * 4;
    kernel.dispatch_indirect(rec, specialization, b, push, b.args, offset)?;
    rec.end_pass();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shaders::dof_tiles::{CLASS_COUNT, LEVELS};
    use crate::passes::TILE_SIZE;

    /// The rule's premise: every level texel that a level tile's composite reads (the bilinear
    /// taps h0 and h0 + 1 of each of its pixels, clamped to the level, as dof_composite.comp
    /// takes them) lies in a tile of the level's list (the tile or a neighbour of a level tile)
    /// and is one the gather computes. Random classes on a grid with partial tiles.
    #[test]
    fn the_level_gather_computes_every_texel_a_composite_reads() {
        let size = [5 * TILE_SIZE + 7, 4 * TILE_SIZE + 3];
        let tiles = size.map(|v| v.div_ceil(TILE_SIZE) as i32);
        let size = size.map(|v| v as i32);
        let mut seed = 12345u32;
        for _ in 0..20 {
            let class: Vec<f32> = (0..tiles[0] * tiles[1])
                .map(|_| {
                    seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    ((seed >> 24) % CLASS_COUNT) as f32
                })
                .collect();
            for level in 1..=LEVELS as i32 {
                let (side, scale) = (TILE_SIZE as i32 >> level, (1 << level) as f32);
                let level_size = size.map(|v| (v as u32).div_ceil(1 << level) as i32);
                for t in 0..tiles[0] * tiles[1] {
                    if class[t as usize] as i32 != CLASS_LEVEL1 as i32 + level - 1 {
                        continue;
                    }
                    let origin = [(t % tiles[0]) * TILE_SIZE as i32, (t / tiles[0]) * TILE_SIZE as i32];
                    for (x, y) in (0..TILE_SIZE as i32).flat_map(|y| (0..TILE_SIZE as i32).map(move |x| (x, y))) {
                        let p = [origin[0] + x, origin[1] + y];
                        if p[0] >= size[0] || p[1] >= size[1] {
                            continue;
                        }
                        let h0 = p.map(|v| ((v as f32 + 0.5) / scale - 0.5).floor() as i32);
                        for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            let q = [(h0[0] + i).clamp(0, level_size[0] - 1), (h0[1] + j).clamp(0, level_size[1] - 1)];
                            let tq = [q[0] / side, q[1] / side];
                            let near = level_neighbours(&class, tiles, tq, level);
                            let xy = [q[0] - tq[0] * side, q[1] - tq[1] * side];
                            assert!(near != 0, "level {level}: texel {q:?} of a tile not in the list");
                            assert!(texel_read(xy, side, near), "level {level}: texel {q:?} read but not gathered");
                        }
                    }
                }
            }
        }
    }

    /// A neighbour tile gathers only its edge (or corner) next to the level's tiles; a level
    /// tile gathers every texel.
    #[test]
    fn a_neighbour_tile_gathers_only_its_ring_next_to_the_level_tiles() {
        let side = TILE_SIZE as i32 >> 1;
        let read = |near: u32| -> Vec<[i32; 2]> {
            (0..side * side).map(|k| [k % side, k / side]).filter(|&xy| texel_read(xy, side, near)).collect()
        };
        let (west, north_west, north, own) = (1 << 3, 1 << 0, 1 << 1, 1 << 4);
        assert_eq!(read(west), (0..side).map(|y| [0, y]).collect::<Vec<_>>());
        assert_eq!(read(north_west), vec![[0, 0]]);
        assert_eq!(read(west | north).len() as i32, 2 * side - 1);
        assert_eq!(read(own).len() as i32, side * side);
        assert_eq!(read(0).len(), 0);
        // Side 1 (the top level): the one texel, next to any level tile.
        assert!(texel_read([0, 0], 1, 1 << 8));
    }
}
