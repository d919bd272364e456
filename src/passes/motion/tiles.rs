//! Motion blur, step 1: the longest next and previous velocity of every 16x16 tile.
//! Shader: glsl/motion/mb_tiles.comp.

use super::path::clamped_velocity;
use crate::gpu::{GpuBuffer, GpuImage, GpuResult, HostData, Kernel, Recorder, Shader, Twin};

pub const NAME: &str = "mb_tiles";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbTilesPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    pub max_speed_px: f32,
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_tiles.comp.
    pub struct MbTilesBindings {
        velocity: image(velocity),
        tile_motion: buffer(TileMotion),
    }
}

/// glsl/motion/mb_tiles.comp: one invocation per tile.
pub struct MbTilesShader;

impl Shader for MbTilesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbTilesBindings<'a>;
    type Push = MbTilesPush;
}

/// The longer of two vectors by squared length; `a` on a tie (the scan order's first).
pub fn longer(a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
    if b[0] * b[0] + b[1] * b[1] > a[0] * a[0] + a[1] * a[1] {
        b
    } else {
        a
    }
}

impl Twin for MbTilesShader {
    fn cpu(pc: &MbTilesPush, _groups: [u32; 3], b: &mut [HostData]) {
        let velocity = b[0].image().clone();
        let tile_size = crate::passes::TILE_SIZE;
        let words = b[1].words_mut();
        for ty in 0..pc.tiles[1] as u32 {
            for tx in 0..pc.tiles[0] as u32 {
                // Row-major scan: of equal lengths the first, as the shader.
                let (mut next, mut prev) = (None::<[f32; 2]>, None::<[f32; 2]>);
                for y in ty * tile_size..(ty + 1) * tile_size {
                    for x in tx * tile_size..(tx + 1) * tile_size {
                        if (x as i32) >= pc.size[0] || (y as i32) >= pc.size[1] {
                            continue;
                        }
                        let v = clamped_velocity(velocity.clamped(x as i32, y as i32), pc.max_speed_px);
                        next = Some(next.map_or([v[0], v[1]], |n| longer(n, [v[0], v[1]])));
                        prev = Some(prev.map_or([v[2], v[3]], |p| longer(p, [v[2], v[3]])));
                    }
                }
                let (n, p) = (next.unwrap_or_default(), prev.unwrap_or_default());
                let t = (ty as i32 * pc.tiles[0] + tx as i32) as usize;
                for (k, value) in [n[0], n[1], p[0], p[1]].into_iter().enumerate() {
                    words[4 * t + k] = value.to_bits();
                }
            }
        }
    }
}

/// Record the tile reduction: `velocity` -> `tile_motion`.
pub fn record(
    kernel: &Kernel<MbTilesShader>,
    rec: &mut Recorder,
    velocity: &GpuImage,
    tile_motion: &GpuBuffer,
    push: &MbTilesPush,
) -> GpuResult<()> {
    // velocity: written by the upload copy, whose own barrier made it visible to compute reads.
    // tile_motion: fully overwritten, touched by no earlier pass of this recording.
    let groups = [((push.tiles[0] * push.tiles[1]) as u32).div_ceil(64), 1, 1];
    kernel.dispatch(rec, &MbTilesBindings { velocity, tile_motion }, push, groups)
}
