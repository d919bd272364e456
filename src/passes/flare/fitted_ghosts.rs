//! Lens flare, step 5 (a lens with Walch's fitted ghosts only): the fitted sprites' light added
//! to the tiles they cross; `ghost_sprites` added it to the tiles they cover (I_i there). One
//! invocation per 16x16 tile walks its tile's crossing fitted sprites in sprite order. Each
//! sprite's distance is searched at the tile's five nodes (its corner pixels and its centre).
//! A sprite whose light is smooth over the tile adds its corners' light to four sums,
//! interpolated over the tile once at the end. The others are shaded by blocks of 16, 8 and
//! 4 px, their distance interpolated bilinearly where near linear; pixels of a 4 px block that
//! is still not near linear are searched one by one. Shader: glsl/flare/fitted_ghosts.comp.
//!
//! Why a kernel of its own, one invocation per tile: inside `ghost_sprites`' 256-invocation
//! groups, the search's code slowed that whole kernel on lavapipe, whether it ran or not. At
//! 1280x720 with one light of the fitted Tessar: 695 ms with the search in the kernel, 372 ms
//! without its per-pixel shading, 134 ms with no fitted code at all.

use super::fitted::fitted_distance;
use super::ghost_shape::transfer;
use super::sprite::TILE_REACH_PX;
use super::types::constants_of;
use crate::gpu::shaders::bezier_ghost::{BEZIER_COLOUR, BEZIER_TRANSFER};
use crate::gpu::shaders::flare::{ARGS_LIGHTS, BIN_SPRITES_PER_WORD, SPRITE_DATA, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::passes::barriers::update_in_place;
use crate::passes::twin::{finite_or_zero, floats};
use crate::passes::TILE_SIZE;

pub const NAME: &str = "fitted_ghosts";

crate::shader_bindings! {
    /// The bindings of glsl/flare/fitted_ghosts.comp.
    pub struct FittedGhostsBindings {
        color: image(color),
        constants: buffer(FlareParams),
        sprites: buffer(FlareSprites),
        args: buffer(FlareArgs),
        bins: buffer(FlareBins),
    }
}

/// glsl/flare/fitted_ghosts.comp: one invocation per tile in groups of 8x8 tiles; its push
/// constants are the image size and the bin words of one tile.
pub struct FittedGhostsShader;

impl Shader for FittedGhostsShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FittedGhostsBindings<'a>;
    type Push = [i32; 3];
}

/// Tiles per workgroup side (the shader's local size).
const GROUP_TILES: u32 = 8;
/// A block's distance is interpolated from its nodes where its centre's lies within this (px)
/// of its corners' mean (FITTED_LINEAR in glsl/include/fitted_ghost.glsl).
pub const LINEAR_PX: f32 = 0.05;
/// A sprite's light is interpolated from the tile's corners where its centre's lies within this
/// share of the sprite's brightest of the corners' mean (FITTED_SMOOTH).
pub const SMOOTH: f32 = 1e-3;
/// The smallest block (px) interpolated; past it, pixels are searched (FITTED_SMALLEST_BLOCK).
pub const SMALLEST_BLOCK_PX: u32 = 4;

/// The signed distance of the primitive of BEZIER words `w` at the five nodes of the `n`-px
/// block whose first pixel is `at`: the corner pixels' centres row by row, then the centre.
pub fn block_nodes(w: &[f32], at: [u32; 2], n: u32) -> [f32; 5] {
    let span = (n - 1) as f32;
    let first = [at[0] as f32 + 0.5, at[1] as f32 + 0.5];
    std::array::from_fn(|j| {
        let o = if j == 4 { [0.5 * span; 2] } else { [span * (j & 1) as f32, span * (j >> 1) as f32] };
        fitted_distance(w, [first[0] + o[0], first[1] + o[1]])
    })
}

/// Whether nodes `g` are near linear enough to interpolate.
pub fn linear(g: &[f32; 5]) -> bool {
    (g[4] - 0.25 * (g[0] + g[1] + g[2] + g[3])).abs() <= LINEAR_PX
}

/// GLSL's mix.
fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// The corner nodes of `g` interpolated at `o` px from the first pixel of an `n`-px block.
pub fn interpolated(g: &[f32; 5], o: [u32; 2], n: u32) -> f32 {
    let span = (n - 1) as f32;
    bilinear([g[0], g[1], g[2], g[3]], [o[0] as f32 / span, o[1] as f32 / span])
}

/// Whether the light of transfer `t` (I_b, I_i, F_i, F_o, E_i, E_o) is smooth over the tile of
/// nodes `g`: its border and fades' ends over the tile's reach from its centre, the centre's
/// light within [`SMOOTH`] of the peak of the corners' mean.
pub fn smooth(t: &[f32], g: &[f32; 5]) -> bool {
    let reach = (TILE_REACH_PX + super::fitted::FITTED_MARGIN_PX) as f32;
    let d = g[4];
    let clear = d.abs() > reach && (d + t[3]).abs() > reach && (d - t[2]).abs() > reach;
    let mean = 0.25 * (transfer(g[0], t) + transfer(g[1], t) + transfer(g[2], t) + transfer(g[3], t));
    clear && (transfer(d, t) - mean).abs() <= SMOOTH * t[0].max(t[1])
}

/// The light (before its colour) of the primitive of BEZIER words `w` over the tile whose first
/// pixel is `origin`, as the kernel shades it: the corners' light where smooth (the caller sums
/// these over the sprites and interpolates the sums once), else `add(x, y, light)` per pixel
/// (whole-frame coordinates), block by block.
pub fn shade_tile(w: &[f32], origin: [u32; 2], add: &mut impl FnMut(u32, u32, f32)) -> Option<[f32; 4]> {
    let t = &w[BEZIER_TRANSFER as usize..][..6];
    let g = block_nodes(w, origin, TILE_SIZE);
    if smooth(t, &g) {
        return Some(std::array::from_fn(|j| transfer(g[j], t)));
    }
    shade_block(w, origin, TILE_SIZE, &g, add);
    None
}

/// The `n`-px block at `at` of nodes `g`: interpolated where near linear, else its quarters
/// (each with its own nodes), else (under [`SMALLEST_BLOCK_PX`]) its pixels searched.
fn shade_block(w: &[f32], at: [u32; 2], n: u32, g: &[f32; 5], add: &mut impl FnMut(u32, u32, f32)) {
    let t = &w[BEZIER_TRANSFER as usize..][..6];
    if linear(g) {
        for y in 0..n {
            for x in 0..n {
                add(at[0] + x, at[1] + y, transfer(interpolated(g, [x, y], n), t));
            }
        }
    } else if n > SMALLEST_BLOCK_PX {
        for k in 0..4 {
            let sub = [at[0] + n / 2 * (k & 1), at[1] + n / 2 * (k >> 1)];
            shade_block(w, sub, n / 2, &block_nodes(w, sub, n / 2), add);
        }
    } else {
        for y in 0..n {
            for x in 0..n {
                let q = [(at[0] + x) as f32 + 0.5, (at[1] + y) as f32 + 0.5];
                add(at[0] + x, at[1] + y, transfer(fitted_distance(w, q), t));
            }
        }
    }
}

/// Each pixel of the tile whose first pixel is `origin`, with its fraction of the way between
/// the tile's corner pixels (the sweep that adds the smooth sprites' corner sums).
fn corner_sweep(origin: [u32; 2], mut at: impl FnMut(u32, u32, [f32; 2])) {
    let span = (TILE_SIZE - 1) as f32;
    for y in 0..TILE_SIZE {
        for x in 0..TILE_SIZE {
            at(origin[0] + x, origin[1] + y, [x as f32 / span, y as f32 / span]);
        }
    }
}

/// The corner values `c` (row by row) interpolated bilinearly at fraction `f`.
fn bilinear(c: [f32; 4], f: [f32; 2]) -> f32 {
    mix(mix(c[0], c[1], f[0]), mix(c[2], c[3], f[0]), f[1])
}

/// Fitted sprite `s`'s light added to `sums` (a `width` x `height` frame) over every tile its
/// bounds touch, as the kernel shades a tile it crosses (on a covered tile, I_i at every pixel).
pub fn add_sprite(s: &[f32], width: u32, height: u32, sums: &mut [[f64; 3]]) {
    let w = &s[SPRITE_DATA as usize..];
    let colour: [f64; 3] = std::array::from_fn(|c| w[BEZIER_COLOUR as usize + c] as f64);
    let bx = &s[..4];
    let (x0, y0) = (bx[0].floor().max(0.0) as u32, bx[1].floor().max(0.0) as u32);
    let (x1, y1) = ((bx[2].ceil() as u32).min(width), (bx[3].ceil() as u32).min(height));
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    let mut add = |x: u32, y: u32, light: f32| {
        if x < width && y < height {
            (0..3).for_each(|c| sums[(y * width + x) as usize][c] += light as f64 * colour[c]);
        }
    };
    for ty in y0 / TILE_SIZE..=(y1 - 1) / TILE_SIZE {
        for tx in x0 / TILE_SIZE..=(x1 - 1) / TILE_SIZE {
            let origin = [tx * TILE_SIZE, ty * TILE_SIZE];
            if let Some(corners) = shade_tile(w, origin, &mut add) {
                corner_sweep(origin, |x, y, f| add(x, y, bilinear(corners, f)));
            }
        }
    }
}

impl Twin for FittedGhostsShader {
    /// Each tile of the band, its crossing fitted sprites in sprite order, each addition to
    /// the image in f32 as the kernel makes it.
    fn cpu(push: &[i32; 3], _groups: [u32; 3], b: &mut [HostData]) {
        let fc = constants_of(&b[1]);
        let sprites = floats(b[2].words());
        let lights = b[3].words()[ARGS_LIGHTS as usize];
        let bins = b[4].words().to_vec();
        let (width, rows, words_per_tile) = (push[0].max(0) as u32, push[1].max(0) as u32, push[2].max(0) as usize);
        let top = fc.band_top_px.max(0) as u32;
        let (slots, ghosts) = (fc.slots_per_light.max(0) as u32, fc.ghost_count.max(0) as u32);
        let image = b[0].image_mut();
        let mut add_rgb = |x: u32, y: u32, rgb: [f32; 3]| {
            if x < width && y >= top && y - top < rows {
                let texel = image.texel_mut(x, y - top);
                for c in 0..4 {
                    texel[c] = finite_or_zero(texel[c]) + if c < 3 { rgb[c] } else { 0.0 };
                }
            }
        };
        for ty in top / TILE_SIZE..(top + rows).div_ceil(TILE_SIZE) {
            for tx in 0..fc.tiles_x.max(0) as u32 {
                let origin = [tx * TILE_SIZE, ty * TILE_SIZE];
                let base = (ty * fc.tiles_x as u32 + tx) as usize * words_per_tile;
                let mut corners = [[0.0f32; 3]; 4];
                let mut smooth_any = false;
                for s in
                    (0..lights).flat_map(|l| (0..fc.fitted_count.max(0) as u32).map(move |k| l * slots + ghosts + k))
                {
                    let byte = bins[base + (s / BIN_SPRITES_PER_WORD) as usize] >> (8 * (s % BIN_SPRITES_PER_WORD));
                    if byte & 7 == 0 {
                        continue;
                    }
                    let w = &sprites[(s * SPRITE_WORDS + SPRITE_DATA) as usize..((s + 1) * SPRITE_WORDS) as usize];
                    let colour: [f32; 3] = std::array::from_fn(|c| w[BEZIER_COLOUR as usize + c]);
                    let shaded = shade_tile(w, origin, &mut |x, y, light| add_rgb(x, y, colour.map(|v| light * v)));
                    if let Some(light) = shaded {
                        for j in 0..4 {
                            (0..3).for_each(|c| corners[j][c] += light[j] * colour[c]);
                        }
                        smooth_any = true;
                    }
                }
                if !smooth_any {
                    continue;
                }
                corner_sweep(origin, |x, y, f| {
                    add_rgb(x, y, std::array::from_fn(|c| bilinear(corners.map(|corner| corner[c]), f)))
                });
            }
        }
    }

    /// eq 6.4's pow and the search in f32 on another compiler.
    const TOLERANCE: f32 = 2e-4;
}

/// Record the step after `ghost_sprites` (the lens has fitted ghosts): one invocation per tile
/// of the band; without a light each returns at once.
pub fn record(
    kernel: &SpecializedKernel<FittedGhostsShader>,
    rec: &mut Recorder,
    b: &FittedGhostsBindings<'_>,
    tiles_x: u32,
    words_per_tile: u64,
) -> GpuResult<()> {
    let size = [b.color.width as i32, b.color.height as i32];
    rec.begin_pass(NAME);
    // color: read and rewritten by ghost_sprites; each texel is now read and rewritten again:
    //   those writes visible, those reads done. The sprites, counts and bins were made visible
    //   to compute reads by ghost_sprites' barrier, and nothing wrote them since.
    rec.image_barriers(&[update_in_place(b.color)]);
    let rows = (b.color.height).div_ceil(TILE_SIZE);
    let groups = [tiles_x.div_ceil(GROUP_TILES), rows.div_ceil(GROUP_TILES), 1];
    let push = [size[0], size[1], words_per_tile as i32];
    kernel.dispatch(rec, &[], b, &push, groups)?;
    rec.end_pass();
    Ok(())
}
