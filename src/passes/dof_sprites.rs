//! Tiled depth of field: highlight sprites with the exact aperture shape, binned per tile and
//! added to the large-CoC tiles. Shader: glsl/dof_sprites.comp.

use super::aperture::{aperture_weight, sa_weight, ApertureConstants};
use super::barriers::{buffer_after_compute_write, write_after_write};
use super::twin::{floats, listed_tiles};
use super::TILE_SIZE;
use crate::gpu::shaders::dof_tiles::{ARGS_DISPATCH_WORDS, ARGS_SPRITE_COUNT, CLASS_LARGE, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};

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
    /// The bindings of glsl/dof_sprites.comp.
    pub struct SpritesBindings {
        coc: image(coc_px),
        output: image(color_out),
        args: buffer(Args),
        sprites: buffer(Sprites),
        tile_lists: buffer(TileLists),
        aperture_mask: buffer(ApertureMask),
    }
}

/// glsl/dof_sprites.comp: one workgroup per large tile.
pub struct SpritesShader;

impl Shader for SpritesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = SpritesBindings<'a>;
    type Push = SpritesPush;
}

impl Twin for SpritesShader {
    fn cpu(pc: &SpritesPush, groups: [u32; 3], b: &mut [HostData]) {
        let coc = b[0].image().clone();
        let total = (b[2].words()[ARGS_SPRITE_COUNT as usize] as usize).min(pc.sprite_capacity.max(0) as usize);
        let sprites: Vec<[f32; 8]> = floats(&b[3].words()[..total * SPRITE_WORDS as usize])
            .chunks_exact(SPRITE_WORDS as usize)
            .map(|s| std::array::from_fn(|k| s[k]))
            .collect();
        let (lists, mask) = (b[4].words().to_vec(), floats(b[5].words()));
        let out = b[1].image_mut();
        if total == 0 {
            return;
        }
        for tile in listed_tiles(&lists, CLASS_LARGE, pc.tiles, groups[0], TILE_SIZE, pc.size) {
            let origin = tile.origin.map(|o| o as f32);
            // The sprites whose bounds overlap the tile (the shader's per-tile bin).
            let bin: Vec<&[f32; 8]> = sprites
                .iter()
                .filter(|s| {
                    let r = 0.5 * s[2].abs() + 1.0;
                    let hi = [origin[0] + TILE_SIZE as f32, origin[1] + TILE_SIZE as f32];
                    s[0] + r >= origin[0] && s[0] - r <= hi[0] && s[1] + r >= origin[1] && s[1] - r <= hi[1]
                })
                .collect();
            for (x, y) in tile.pixels() {
                let coc_p = coc.clamped(x as i32, y as i32)[0];
                let radius_p = (0.5 * coc_p.abs()).max(0.5);
                let mut sum = [0.0f32; 3];
                for s in &bin {
                    let (centre, coc_q) = ([s[0], s[1]], s[2]);
                    let radius_q = (0.5 * coc_q.abs()).max(0.5);
                    let reach = if coc_q > coc_p { radius_q.min(radius_p) } else { radius_q };
                    let flip = if coc_q < 0.0 { -1.0 } else { 1.0 };
                    let o = [(x as f32 + 0.5 - centre[0]) * flip, (y as f32 + 0.5 - centre[1]) * flip];
                    let w = aperture_weight(o, reach, &pc.aperture, centre, flip, 1.0, &mask)
                        * sa_weight(o, radius_q, coc_q, &pc.aperture);
                    for k in 0..3 {
                        sum[k] += s[4 + k] * w;
                    }
                }
                let texel = out.texel_mut(x, y);
                for k in 0..3 {
                    texel[k] += sum[k];
                }
            }
        }
    }

    /// Sums of many sprites in a different order: a little more room than a single sum.
    const TOLERANCE: f32 = 2e-4;
}

pub fn record(
    kernel: &Kernel<SpritesShader>,
    rec: &mut Recorder,
    b: &SpritesBindings<'_>,
    push: &SpritesPush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // output: written by dof_composite, now read and added to (read-modify-write).
    // sprites and their count: written by dof_downsample (read-after-write).
    rec.image_barriers(&[write_after_write(b.output)]);
    rec.buffer_barriers(&[buffer_after_compute_write(b.sprites), buffer_after_compute_write(b.args)]);
    kernel.dispatch_indirect(rec, b, push, b.args, (CLASS_LARGE * ARGS_DISPATCH_WORDS * 4) as u64)?;
    rec.end_pass();
    Ok(())
}
