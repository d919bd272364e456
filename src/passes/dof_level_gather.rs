//! Tiled depth of field: the gather of one pyramid level's tiles at that level's resolution.
//! Shader: glsl/dof_level_gather.comp.

use super::aperture::{tap_weight, ApertureConstants, ApertureData};
use super::barriers::{after_compute_write, overwrite};
use super::dof_classify::tiles_per_group;
use super::twin::floats;
use crate::gpu::shaders::dof_tiles::ARGS_LEVEL_TILES_BASE;
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};

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
    /// The bindings of glsl/dof_level_gather.comp.
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
    }
}

/// glsl/dof_level_gather.comp: GROUP_SIZE texels of the level's tiles per workgroup.
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
        let data = ApertureData::from_bindings(&b[6], &b[9], pc.aperture.shape_radius);
        let count = b[8].words()[(ARGS_LEVEL_TILES_BASE + pc.level as u32 - 1) as usize] as usize;
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let side = (super::TILE_SIZE >> pc.level) as i32;
        let per_group = tiles_per_group(pc.level as u32) as usize;
        let to_level = 1.0 / (1 << pc.level) as f32;
        let (mut bg_out, mut fg_out, mut big_out) = (b[2].image().clone(), b[3].image().clone(), b[7].image().clone());
        let slots = (groups[0] as usize * per_group).min(count);
        for slot in 0..slots {
            let t = lists[(pc.level as usize - 1) * tile_count + slot] as usize;
            let origin = [(t % pc.tiles[0] as usize) as i32 * side, (t / pc.tiles[0] as usize) as i32 * side];
            for texel in 0..side * side {
                let p = [origin[0] + texel % side, origin[1] + texel / side];
                if p[0] >= pc.level_size[0] || p[1] >= pc.level_size[1] {
                    continue;
                }
                let coc_p = coc.clamped(p[0], p[1])[0] * to_level;
                let r = (radii[t] * to_level).ceil() as i32 + 1;
                let (mut bg, mut fg, mut big) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
                let (mut bg_w, mut fg_w, mut big_w) = (0.0f32, 0.0f32, 0.0f32);
                for dy in -r..=r {
                    for dx in -r..=r {
                        if dx * dx + dy * dy > r * r + r {
                            continue;
                        }
                        let q =
                            [(p[0] + dx).clamp(0, pc.level_size[0] - 1), (p[1] + dy).clamp(0, pc.level_size[1] - 1)];
                        let cw = coc.clamped(q[0], q[1]);
                        if cw[1] <= 0.0 {
                            continue;
                        }
                        let coc_q = cw[0] * to_level;
                        let radius_q = (0.5 * coc_q.abs()).max(0.5);
                        let sample = [(p[0] + dx) as f32 + 0.5, (p[1] + dy) as f32 + 0.5];
                        let w = tap_weight([dx, dy], coc_p, coc_q, &pc.aperture, sample, &data);
                        if w <= 0.0 {
                            continue;
                        }
                        let c = color.clamped(q[0], q[1]);
                        let f = ((coc_p - coc_q) / pc.layer_transition_px).clamp(0.0, 1.0);
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
                let layer = |sum: [f32; 4], weight: f32| -> [f32; 4] {
                    let rgb: [f32; 3] = std::array::from_fn(|k| if weight > 0.0 { sum[k] / weight } else { 0.0 });
                    [rgb[0], rgb[1], rgb[2], weight.clamp(0.0, 1.0)]
                };
                let background = bg.map(|v| if bg_w > 0.0 { v / bg_w } else { 0.0 });
                bg_out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&background);
                fg_out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&layer(fg, fg_w));
                big_out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&layer(big, big_w));
            }
        }
        b[2] = HostData::Image(bg_out);
        b[3] = HostData::Image(fg_out);
        b[7] = HostData::Image(big_out);
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
    // bg/fg/fg_big_level: written from scratch (only the level's tiles' texels; the rest is
    //   never read).
    rec.image_barriers(&[
        after_compute_write(b.color_level),
        after_compute_write(b.coc_level),
        overwrite(b.bg_level),
        overwrite(b.fg_level),
        overwrite(b.fg_big_level),
    ]);
    let offset = super::dof_classify::level_gather_args_words(push.level as u32) as u64 * 4;
    kernel.dispatch_indirect(rec, specialization, b, push, b.args, offset)?;
    rec.end_pass();
    Ok(())
}
