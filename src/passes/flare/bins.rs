//! Lens flare, step 3: the sprites binned to the 16x16 tiles, once per frame. One workgroup per
//! sprite walks the tiles its bounds touch and sorts it against each (away, covering or crossing,
//! channel by channel), OR-ing one byte per sprite into the tile's bin words; `ghost_sprites`
//! then reads only its tile's words. Shader: glsl/flare/flare_bins.comp.

use super::sprite::sprite_bin;
use super::types::{constants_of, FlareConstants};
use crate::gpu::shaders::flare::{ARGS_BIN_GROUPS, ARGS_LIGHTS, BIN_SPRITES_PER_WORD, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::optics::flare::AperturePolygon;
use crate::passes::barriers::{args_for_indirect, buffer_after_compute_write, buffer_after_fill};
use crate::passes::twin::floats;
use crate::passes::TILE_SIZE;

pub const NAME: &str = "flare_bins";

crate::shader_bindings! {
    /// The bindings of glsl/flare/flare_bins.comp.
    pub struct FlareBinsBindings {
        constants: buffer(FlareParams),
        sprites: buffer(FlareSprites),
        args: buffer(FlareArgs),
        bins: buffer(FlareBins),
    }
}

/// glsl/flare/flare_bins.comp: one workgroup per sprite slot; its push constant is the bin words of
/// one tile.
pub struct FlareBinsShader;

impl Shader for FlareBinsShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FlareBinsBindings<'a>;
    type Push = i32;
}

/// The bin words one tile needs for `sprites` sprites.
pub fn words_per_tile(sprites: u64) -> u64 {
    sprites.div_ceil(BIN_SPRITES_PER_WORD as u64).max(1)
}

impl Twin for FlareBinsShader {
    /// Every sprite against every tile of the frame (the shader walks only the tiles its bounds
    /// touch; the others are away from it).
    fn cpu(words_per_tile: &i32, _groups: [u32; 3], b: &mut [HostData]) {
        let fc = constants_of(&b[0]);
        let aperture = AperturePolygon {
            blades: fc.blades.max(0) as u32,
            rotation_rad: fc.rotation as f64,
            curvature: fc.curvature as f64,
        };
        let wpt = (*words_per_tile).max(0) as usize;
        let total = (b[2].words()[ARGS_LIGHTS as usize] as usize * fc.slots_per_light.max(0) as usize)
            .min(wpt * BIN_SPRITES_PER_WORD as usize);
        let sprites = floats(b[1].words());
        let bins = b[3].words_mut();
        for (i, s) in sprites.chunks_exact(SPRITE_WORDS as usize).take(total).enumerate() {
            for ty in 0..fc.tiles_y.max(0) as u32 {
                for tx in 0..fc.tiles_x.max(0) as u32 {
                    let mode = sprite_bin(s, &aperture, [tx * TILE_SIZE, ty * TILE_SIZE]);
                    let word = (ty * fc.tiles_x as u32 + tx) as usize * wpt + i / BIN_SPRITES_PER_WORD as usize;
                    bins[word] |= mode << (8 * (i % BIN_SPRITES_PER_WORD as usize));
                }
            }
        }
    }
}

/// Record the binning: the bins cleared, then every sprite OR-ed into the tiles it reaches;
/// one group per sprite flare_lights made (none without a light), `slots` the sprite buffer's
/// capacity in sprites.
/// The specialization constants of glsl/flare/flare_bins.comp for a frame of `constants`:
/// aperture.glsl's two at their defaults (ghost_sdf uses neither path), and whether it has
/// matrix ghosts and fitted ghosts (without, the pipeline has none of their bin tests' code).
pub fn specialization(constants: &FlareConstants) -> [u32; 4] {
    [1, 1, (constants.ghost_count > 0) as u32, (constants.fitted_count > 0) as u32]
}

/// Record the step; `constants` from [`specialization`].
pub fn record(
    kernel: &SpecializedKernel<FlareBinsShader>,
    rec: &mut Recorder,
    constants: &[u32; 4],
    b: &FlareBinsBindings<'_>,
    slots: u32,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // bins: a new buffer, cleared by a transfer fill before the atomic ORs (write-after-write).
    rec.fill_buffer(b.bins, 0);
    // sprites: written by flare_lights (read-after-write); the counts too, and read here also
    //   as this dispatch's group counts.
    rec.buffer_barriers(&[buffer_after_fill(b.bins), buffer_after_compute_write(b.sprites), args_for_indirect(b.args)]);
    let words = words_per_tile(slots as u64) as i32;
    kernel.dispatch_indirect(rec, constants, b, &words, b.args, ARGS_BIN_GROUPS as u64 * 4)?;
    rec.end_pass();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shaders::flare::{
        BIN_COVERING_SHIFT, GHOST_SPRITE_CHANNEL_WORDS, KIND_GHOST, SPRITE_DATA, SPRITE_KIND, SPRITE_SOFTNESS,
    };
    use crate::passes::flare::ghost_sprites::sprite_light;

    /// A 5-bladed ghost per channel (radius 20, 23, 26 px; channel 1 flipped), clipped by a
    /// circle, with a 3 px ramp, as flare_lights writes it.
    fn ghost() -> Vec<f32> {
        let mut s = vec![0.0f32; SPRITE_WORDS as usize];
        s[..4].copy_from_slice(&[8.0, 0.0, 90.0, 62.0]);
        s[SPRITE_KIND as usize] = KIND_GHOST as f32;
        s[SPRITE_SOFTNESS as usize] = 3.0;
        for c in 0..3 {
            let w = (SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS) as usize;
            let r = 20.0 + 3.0 * c as f32;
            s[w..w + 7].copy_from_slice(&[47.0, 31.0, if c == 1 { -r } else { r }, 2.0 + c as f32, 52.0, 33.0, 24.0]);
        }
        s
    }

    /// The sorting's bound: a channel sorted away adds nothing at any pixel of the tile, a
    /// covering one its full value at every pixel (the distance is 1-Lipschitz: the tile's
    /// centre is within TILE_REACH_PX of each pixel centre), and some tiles are each.
    #[test]
    fn sorted_tiles_bound_every_pixel() {
        let aperture = AperturePolygon { blades: 5, rotation_rad: 0.3, curvature: 0.2 };
        let s = ghost();
        let mut seen = [0usize; 3];
        for ty in 0..5u32 {
            for tx in 0..7u32 {
                let mode = sprite_bin(&s, &aperture, [tx * TILE_SIZE, ty * TILE_SIZE]);
                for c in 0..3 {
                    let value = (2 + c) as f64;
                    let kind = if mode & (1 << (c + BIN_COVERING_SHIFT as usize)) != 0 {
                        1
                    } else if mode & (1 << c) != 0 {
                        2
                    } else {
                        0
                    };
                    seen[kind] += 1;
                    for y in ty * TILE_SIZE..(ty + 1) * TILE_SIZE {
                        for x in tx * TILE_SIZE..(tx + 1) * TILE_SIZE {
                            let light = sprite_light(&s, &aperture, x, y)[c];
                            match kind {
                                0 => assert_eq!(light, 0.0, "tile {tx},{ty} channel {c} pixel {x},{y}"),
                                1 => assert_eq!(light, value, "tile {tx},{ty} channel {c} pixel {x},{y}"),
                                _ => {}
                            }
                        }
                    }
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 0), "away, covering, crossing tile-channels: {seen:?}");
    }

    /// A sprite whose bounds are empty (or NaN) is away from every tile.
    #[test]
    fn empty_or_nan_bounds_are_away() {
        let aperture = AperturePolygon { blades: 0, rotation_rad: 0.0, curvature: 0.0 };
        let mut s = ghost();
        s[..4].copy_from_slice(&[50.0, 0.0, 40.0, 62.0]);
        assert_eq!(sprite_bin(&s, &aperture, [32, 16]), 0);
        s[..4].copy_from_slice(&[f32::NAN, 0.0, 90.0, 62.0]);
        assert_eq!(sprite_bin(&s, &aperture, [32, 16]), 0);
    }
}
