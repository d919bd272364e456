//! Tiled depth of field, the last step: the highlight sprites binned to each level tile added to
//! the composite's pixels with the exact aperture shape, over the tiles whose bin holds a sprite
//! (dof_bin_order lists them). Shader: glsl/dof/dof_sprites.comp, and its variant without
//! subgroup operations (`dof_sprites_plain`) for devices that have none.

use super::aperture::{aperture_weight_at, sa_weight, ApertureConstants, ApertureData};
use crate::gpu::shaders::dof_tiles::{ARGS_SPRITE_TILES, BIN_CAPACITY, LIST_SPRITE_TILES, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::passes::barriers::{args_for_indirect, buffer_after_compute_write, write_after_write};
use crate::passes::twin::{floats, listed_tiles, sprites_written};
use crate::passes::TILE_SIZE;

pub const NAME: &str = "dof_sprites";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SpritesPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    pub aperture: ApertureConstants,
    pub sprite_capacity: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_sprites.comp.
    pub struct SpritesBindings {
        output: image(color),
        coc: image(coc_px),
        tile_lists: buffer(TileLists),
        sprites: buffer(Sprites),
        bin_counts: buffer(BinCounts),
        bins: buffer(Bins),
        args: buffer(Args),
        aperture_mask: buffer(ApertureMask),
        aperture_shape: image(aperture_shape),
    }
}

/// glsl/dof/dof_sprites.comp: one workgroup per tile with sprites.
pub struct SpritesShader;

impl Shader for SpritesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = SpritesBindings<'a>;
    type Push = SpritesPush;
    /// A subgroup reads each of its tile's sprites once where the device can broadcast within a
    /// subgroup (on lavapipe, 99 -> 65 ms at a CoC radius of 32 px, 1280x720); elsewhere every
    /// invocation reads it. Both give the same bits.
    const WITHOUT_SUBGROUP_OPS: Option<&'static str> = Some("dof_sprites_plain");
}

/// The light of one sprite (its 8 words) at pixel p of signed CoC `coc_p`.
pub fn sprite_light(s: &[f32], p: [i32; 2], coc_p: f32, ap: &ApertureConstants, data: &ApertureData) -> [f32; 3] {
    let (centre, coc_q) = ([s[0], s[1]], s[2]);
    let radius_p = (0.5 * coc_p.abs()).max(0.5);
    let radius_q = (0.5 * coc_q.abs()).max(0.5);
    let reach = if coc_q > coc_p { radius_q.min(radius_p) } else { radius_q };
    let flip = if coc_q < 0.0 { -1 } else { 1 };
    let o = [(p[0] - centre[0].floor() as i32) * flip, (p[1] - centre[1].floor() as i32) * flip];
    let w = aperture_weight_at(o, reach, ap, centre, flip as f32, 1.0, data)
        * sa_weight([o[0] as f32, o[1] as f32], radius_q, coc_q, ap);
    [s[4] * w, s[5] * w, s[6] * w]
}

impl Twin for SpritesShader {
    fn cpu(pc: &SpritesPush, groups: [u32; 3], b: &mut [HostData]) {
        let coc = b[1].image().clone();
        let lists = b[2].words().to_vec();
        let sprite_count = sprites_written(b[6].words(), pc.sprite_capacity);
        let sprites = floats(&b[3].words()[..sprite_count * SPRITE_WORDS as usize]);
        let (counts, bins) = (b[4].words().to_vec(), b[5].words().to_vec());
        let data = ApertureData::from_bindings(&b[7], &b[8], pc.aperture.shape_radius);
        let out = b[0].image_mut();
        for tile in listed_tiles(&lists, LIST_SPRITE_TILES, pc.tiles, groups[0], TILE_SIZE, pc.size) {
            let t = tile.index;
            // The tile's bin in its order; every sprite if the bin overflowed.
            let n = counts[t];
            let indices: Vec<usize> = if n > BIN_CAPACITY {
                (0..sprite_count).collect()
            } else {
                let start = t * BIN_CAPACITY as usize;
                bins[start..start + n as usize].iter().map(|&i| i as usize).collect()
            };
            for (x, y) in tile.pixels() {
                let coc_here = coc.clamped(x as i32, y as i32)[0];
                let texel = out.texel_mut(x, y);
                for &i in &indices {
                    let s = &sprites[i * SPRITE_WORDS as usize..(i + 1) * SPRITE_WORDS as usize];
                    let light = sprite_light(s, [x as i32, y as i32], coc_here, &pc.aperture, &data);
                    for k in 0..3 {
                        texel[k] += light[k];
                    }
                }
            }
        }
    }

    /// A pixel sums many sprites, in the bin's order on the GPU: a little more room.
    const TOLERANCE: f32 = 2e-4;
}

/// Record the sprites over the tiles that have any, after every composite wrote its tiles.
pub fn record(
    kernel: &SpecializedKernel<SpritesShader>,
    specialization: &[u32],
    rec: &mut Recorder,
    b: &SpritesBindings<'_>,
    push: &SpritesPush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // output: written by the composites (and the full-resolution tile passes); read and
    //   rewritten here (read-modify-write).
    // args (the sprite tiles' count: this dispatch's size), the sprite tiles' list, the bins
    //   and their counts: written by dof_bin and dof_bin_order.
    // coc, sprites, the aperture's data: made visible to compute reads before the tiled path's
    //   first readers of them.
    rec.image_barriers(&[write_after_write(b.output)]);
    rec.buffer_barriers(&[
        args_for_indirect(b.args),
        buffer_after_compute_write(b.tile_lists),
        buffer_after_compute_write(b.bins),
        buffer_after_compute_write(b.bin_counts),
    ]);
    kernel.dispatch_indirect(rec, specialization, b, push, b.args, ARGS_SPRITE_TILES as u64 * 4)?;
    rec.end_pass();
    Ok(())
}
