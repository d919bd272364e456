//! Lens flare, step 1: the light pixels of each 16x16 tile (a channel at or over the threshold)
//! summed: energy per channel, count, energy-weighted position. Shader: glsl/flare/flare_tiles.comp.

use super::types::{constants_of, FlareConstants};
use crate::gpu::shaders::flare::{TILE_COUNT, TILE_LIGHT, TILE_W, TILE_WORDS, TILE_WX, TILE_WY};
use crate::gpu::{GpuBuffer, GpuImage, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::after_compute_write;
use crate::passes::TILE_SIZE;

pub const NAME: &str = "flare_tiles";

crate::shader_bindings! {
    /// The bindings of glsl/flare/flare_tiles.comp.
    pub struct FlareTilesBindings {
        color: image(color_in),
        constants: buffer(FlareParams),
        tiles: buffer(FlareTiles),
    }
}

/// glsl/flare/flare_tiles.comp: one workgroup per tile; its push constants are the image size.
pub struct FlareTilesShader;

impl Shader for FlareTilesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FlareTilesBindings<'a>;
    type Push = [i32; 2];
}

/// A light pixel's channels count at most this much in the sums (the shader's
/// `FLARE_MAX_VALUE`): the sums over a tile (x 256 pixels x 65536 px of position) and over the
/// tiles of a light (x 4096^2 tiles) of a frame of finite values stay within f32 (issue 34: a
/// 4x4 patch of 1e37 made them Inf, then every pixel NaN).
pub const FLARE_MAX_VALUE: f32 = 1e20;

/// Whether the pixel value `rgb` belongs to a light at `threshold` (finite, a channel at or
/// over it), and then its weight R + G + B.
pub fn light_weight(rgb: &[f32], threshold: f32) -> Option<f32> {
    let finite = rgb.iter().all(|v| v.is_finite());
    (finite && rgb.iter().fold(f32::MIN, |m, &v| m.max(v)) >= threshold).then(|| (rgb[0] + rgb[1] + rgb[2]).max(0.0))
}

impl Twin for FlareTilesShader {
    fn cpu(size: &[i32; 2], groups: [u32; 3], b: &mut [HostData]) {
        let fc: FlareConstants = constants_of(&b[1]);
        let image = b[0].image().clone();
        let records = tile_records(|x, y| image.clamped(x as i32, y as i32), [size[0] as u32, size[1] as u32], &fc);
        let tiles = b[2].words_mut();
        let n = (groups[0] * groups[1]) as usize * TILE_WORDS as usize;
        tiles[..n].iter_mut().zip(&records).for_each(|(t, r)| *t = r.to_bits());
    }
}

/// The step's tile records of an image of `size` px whose pixel (x, y) is `rgba(x, y)`, for the
/// tile grid of `fc`: f32 sums in the shader's order (pixels row by row). Banded rendering sums
/// the whole frame's here before its bands draw the flare.
pub fn tile_records<'a>(rgba: impl Fn(u32, u32) -> &'a [f32], size: [u32; 2], fc: &FlareConstants) -> Vec<f32> {
    let (tiles_x, tiles_y) = (fc.tiles_x.max(0) as u32, fc.tiles_y.max(0) as u32);
    let mut tiles = vec![0.0f32; (tiles_x * tiles_y) as usize * TILE_WORDS as usize];
    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            let mut sums = [0.0f32; 7];
            for y in ty * TILE_SIZE..((ty + 1) * TILE_SIZE).min(size[1]) {
                for x in tx * TILE_SIZE..((tx + 1) * TILE_SIZE).min(size[0]) {
                    let c = &rgba(x, y)[..3];
                    if light_weight(c, fc.threshold).is_some() {
                        let c = [c[0], c[1], c[2]].map(|v| v.clamp(-FLARE_MAX_VALUE, FLARE_MAX_VALUE));
                        let w = (c[0] + c[1] + c[2]).max(0.0);
                        let values = [c[0], c[1], c[2], w * (x as f32 + 0.5), w * (y as f32 + 0.5), w, 1.0];
                        sums.iter_mut().zip(values).for_each(|(s, v)| *s += v);
                    }
                }
            }
            let t = (ty * tiles_x + tx) as usize * TILE_WORDS as usize;
            tiles[t..t + 7].copy_from_slice(&sums);
            tiles[t + TILE_LIGHT as usize] = -1.0;
        }
    }
    debug_assert_eq!((TILE_WX, TILE_WY, TILE_W, TILE_COUNT), (3, 4, 5, 6));
    tiles
}

/// Record the step: `tiles` gets one record per tile of `color`.
pub fn record(
    kernel: &Kernel<FlareTilesShader>,
    rec: &mut Recorder,
    color: &GpuImage,
    constants: &GpuBuffer,
    tiles: &GpuBuffer,
    tile_grid: [u32; 2],
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // color: written by the previous pass (or the upload, whose own barrier made it visible):
    //   wait for those writes before reading. tiles: a buffer of this recording nothing has
    //   touched yet; constants: uploaded with their own copy -> compute-read barrier.
    rec.image_barriers(&[after_compute_write(color)]);
    let bindings = FlareTilesBindings { color, constants, tiles };
    kernel.dispatch(rec, &bindings, &[color.width as i32, color.height as i32], [tile_grid[0], tile_grid[1], 1])?;
    rec.end_pass();
    Ok(())
}
