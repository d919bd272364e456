//! The ghost-sprite kernel: every flare sprite (a ghost's aperture polygon, a starburst spike,
//! a glow) added to the frame, binned per 16x16 tile so that each output pixel is written once
//! whatever the number of sprites. Shader: glsl/flare/ghost_sprites.comp. Walch's fitted ghosts
//! add their light here only to the tiles they cover; `fitted_ghosts` shades those they cross.

use super::sprite::{ghost_channel, ray_in_box};
use super::types::{constants_of, FlareConstants};
use crate::gpu::shaders::flare::{
    ARGS_LIGHTS, ARGS_SPRITE_GROUPS, BIN_COVERING_SHIFT, BIN_SPRITES_PER_WORD, GHOST_SPRITE_CHANNEL_WORDS, KIND_FITTED,
    KIND_GHOST, KIND_GLOW, KIND_SPIKE, LIGHT_MOVED, LIGHT_WORDS, SPRITE_BOUNDS, SPRITE_DATA, SPRITE_INNER, SPRITE_KIND,
    SPRITE_LIST, SPRITE_SOFTNESS, SPRITE_WORDS, TILE_LIGHT, TILE_WORDS,
};
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::optics::flare::AperturePolygon;
use crate::passes::barriers::{args_for_indirect, buffer_after_compute_write, update_in_place};
use crate::passes::twin::floats;
use crate::passes::TILE_SIZE;

pub const NAME: &str = "ghost_sprites";

crate::shader_bindings! {
    /// The bindings of glsl/flare/ghost_sprites.comp.
    pub struct GhostSpritesBindings {
        color: image(color),
        constants: buffer(FlareParams),
        tiles: buffer(FlareTiles),
        lights: buffer(FlareLights),
        sprites: buffer(FlareSprites),
        args: buffer(FlareArgs),
        bins: buffer(FlareBins),
    }
}

/// glsl/flare/ghost_sprites.comp: one workgroup per tile; its push constants are the image size and
/// the bin words of one tile.
pub struct GhostSpritesShader;

impl Shader for GhostSpritesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = GhostSpritesBindings<'a>;
    type Push = [i32; 3];
}

/// The light sprite `s` (its words) adds to pixel (x, y), per channel.
pub fn sprite_light(s: &[f32], aperture: &AperturePolygon, x: u32, y: u32) -> [f64; 3] {
    let f = |k: u32| s[(SPRITE_DATA + k) as usize] as f64;
    let q = [x as f64 + 0.5, y as f64 + 0.5];
    match s[SPRITE_KIND as usize] as u32 {
        KIND_GHOST => {
            let ramp = s[SPRITE_SOFTNESS as usize] as f64;
            std::array::from_fn(|c| {
                let value = f(c as u32 * GHOST_SPRITE_CHANNEL_WORDS + 3);
                if value <= 0.0 {
                    0.0
                } else {
                    value * (0.5 - ghost_channel(s, c).sdf(q, aperture) / ramp).clamp(0.0, 1.0)
                }
            })
        }
        KIND_SPIKE => {
            let (t0, t1) = ray_in_box(
                [f(0), f(1)],
                [f(2), f(3)],
                f(4),
                f(5),
                [x as f64, y as f64],
                [x as f64 + 1.0, y as f64 + 1.0],
            );
            if t1 <= t0 {
                return [0.0; 3];
            }
            std::array::from_fn(|c| f(6 + c as u32) * (1.0 / t0 - 1.0 / t1))
        }
        KIND_FITTED => super::fitted::fitted_light(s, [x as f32 + 0.5, y as f32 + 0.5]),
        KIND_GLOW => {
            let r = (q[0] - f(0)).hypot(q[1] - f(1));
            if r < f(2) || r > f(3) {
                return [0.0; 3];
            }
            let rho = f(10);
            let halo = if rho > 0.0 { (1.0 + r * r / (rho * rho)).powf(-1.5) } else { 0.0 };
            std::array::from_fn(|c| f(4 + c as u32) / (r * r * r) + f(7 + c as u32) * halo)
        }
        _ => [0.0; 3],
    }
}

/// Fitted sprite `s` (slot `slot`) adds its light deep inside (SPRITE_INNER, I_i times its
/// channel's value) to every pixel of the tiles whose bin word covers it, in the channels
/// covered (`size`: the frame's pixels the sums hold).
fn add_covering(s: &[f32], slot: usize, bins: &[u32], words_per_tile: usize, size: [u32; 2], sums: &mut [[f64; 3]]) {
    let (tiles_x, tiles_y) = (size[0].div_ceil(TILE_SIZE), size[1].div_ceil(TILE_SIZE));
    let per_word = BIN_SPRITES_PER_WORD as usize;
    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            let word = bins[(ty * tiles_x + tx) as usize * words_per_tile + slot / per_word];
            let covering = (word >> (8 * (slot % per_word) as u32 + BIN_COVERING_SHIFT)) & 7;
            if covering == 0 {
                continue;
            }
            for y in ty * TILE_SIZE..((ty + 1) * TILE_SIZE).min(size[1]) {
                for x in tx * TILE_SIZE..((tx + 1) * TILE_SIZE).min(size[0]) {
                    let sum = &mut sums[(y * size[0] + x) as usize];
                    (0..3).filter(|c| covering >> c & 1 == 1).for_each(|c| sum[c] += s[SPRITE_INNER as usize] as f64);
                }
            }
        }
    }
}

impl Twin for GhostSpritesShader {
    /// Every sprite at every pixel of its bounds (the bins only skip sprites whose light there is
    /// 0, and add covering ones once per tile: the same light); a fitted sprite on the tiles it
    /// covers only.
    fn cpu(size: &[i32; 3], groups: [u32; 3], b: &mut [HostData]) {
        let fc = constants_of(&b[1]);
        let aperture = AperturePolygon {
            blades: fc.blades.max(0) as u32,
            rotation_rad: fc.rotation as f64,
            curvature: fc.curvature as f64,
        };
        let (tiles, lights, sprites) = (floats(b[2].words()), floats(b[3].words()), floats(b[4].words()));
        let total = b[5].words()[ARGS_LIGHTS as usize] as usize * fc.slots_per_light.max(0) as usize;
        let input = b[0].image().clone();
        // The sprites' light over the whole frame's tiles; the image is the band of size[1] rows
        // from band_top_px (the whole frame: 0).
        let top = fc.band_top_px.max(0) as u32;
        let (w, h) =
            ((groups[0] * TILE_SIZE).min(size[0] as u32), (top + groups[1] * TILE_SIZE).min(top + size[1] as u32));
        let mut sums = vec![[0.0f64; 3]; (w * h) as usize];
        let bins = b[6].words();
        let words_per_tile = size[2].max(0) as usize;
        for (i, s) in sprites.chunks_exact(SPRITE_WORDS as usize).take(total).enumerate() {
            if s[SPRITE_KIND as usize] as u32 == KIND_FITTED {
                // A fitted sprite here adds I_i to the tiles it covers (fitted_ghosts shades
                // those it crosses).
                add_covering(s, i, bins, words_per_tile, [w, h], &mut sums);
                continue;
            }
            let bx = &s[SPRITE_BOUNDS as usize..][..4];
            if !matches!(bx[0].partial_cmp(&bx[2]), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)) {
                continue;
            }
            let (x0, y0) = (bx[0].floor().max(0.0) as u32, bx[1].floor().max(0.0) as u32);
            let (x1, y1) = ((bx[2].ceil() as u32).min(w), (bx[3].ceil() as u32).min(h));
            for y in y0..y1 {
                for x in x0..x1 {
                    let add = sprite_light(s, &aperture, x, y);
                    let sum = &mut sums[(y * w + x) as usize];
                    (0..3).for_each(|c| sum[c] += add[c]);
                }
            }
        }
        let out = b[0].image_mut();
        for y in top..h {
            for x in 0..w {
                let c = input.clamped(x as i32, (y - top) as i32);
                let mut rgb = [c[0], c[1], c[2]].map(crate::passes::twin::finite_or_zero);
                let tile = (y / TILE_SIZE) * fc.tiles_x as u32 + x / TILE_SIZE;
                let light = tiles[(tile * TILE_WORDS + TILE_LIGHT) as usize];
                if light >= 0.0 && rgb.iter().fold(f32::MIN, |m, &v| m.max(v)) >= fc.threshold {
                    let moved = &lights[light as usize * LIGHT_WORDS as usize + LIGHT_MOVED as usize..][..3];
                    (0..3).for_each(|k| rgb[k] *= 1.0 - moved[k]);
                }
                let sum = sums[(y * w + x) as usize];
                let texel = out.texel_mut(x, y - top);
                for k in 0..3 {
                    texel[k] = (rgb[k] as f64 + sum[k]) as f32;
                }
                texel[3] = crate::passes::twin::finite_or_zero(c[3]);
            }
        }
    }

    /// Sums of many sprites in another order (and covering sprites added once per tile).
    const TOLERANCE: f32 = 2e-4;
}

/// The specialization constants of glsl/flare/ghost_sprites.comp for a frame of `constants` with
/// `words_per_tile` bin words per tile: aperture.glsl's two (at their defaults: ghost_sdf uses
/// neither path), whether it has ghost sprites and spike sprites (a pipeline without a kind has
/// no loop for it, which lavapipe would run once per tile), and whether a tile's sprites may
/// be more than one list holds (only then the batches' loop, whose mere presence costs lavapipe),
/// and whether it has fitted sprites (Walch's primitives).
pub fn specialization(constants: &FlareConstants, words_per_tile: u64) -> [u32; 6] {
    let batches = words_per_tile * BIN_SPRITES_PER_WORD as u64 > SPRITE_LIST as u64;
    [
        1,
        1,
        (constants.ghost_count > 0) as u32,
        (constants.spike_count > 0) as u32,
        batches as u32,
        (constants.fitted_count > 0) as u32,
    ]
}

/// Record the kernel: the sprites added to the frame's colour in place; `constants` from
/// [`specialization`]. flare_lights chose the group count: every tile with a light, none
/// without one (the colour is then left as it is: a frame with nothing to draw costs nothing
/// here).
pub fn record(
    kernel: &SpecializedKernel<GhostSpritesShader>,
    rec: &mut Recorder,
    constants: &[u32; 6],
    b: &GhostSpritesBindings<'_>,
    words_per_tile: u64,
) -> GpuResult<()> {
    let size = [b.color.width as i32, b.color.height as i32];
    rec.begin_pass(NAME);
    // tiles (their light), lights, sprites and the counts: written by flare_lights
    //   (read-after-write); the bins: written by flare_bins (read-after-write).
    // color: written by the pass before the flare (or the upload) and read by flare_tiles
    //   since; each texel is now read and rewritten: those writes visible, those reads done.
    rec.buffer_barriers(&[
        buffer_after_compute_write(b.tiles),
        buffer_after_compute_write(b.lights),
        buffer_after_compute_write(b.sprites),
        args_for_indirect(b.args),
        buffer_after_compute_write(b.bins),
    ]);
    rec.image_barriers(&[update_in_place(b.color)]);
    let push = [size[0], size[1], words_per_tile as i32];
    kernel.dispatch_indirect(rec, constants, b, &push, b.args, ARGS_SPRITE_GROUPS as u64 * 4)?;
    rec.end_pass();
    Ok(())
}
