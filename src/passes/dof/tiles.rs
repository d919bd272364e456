//! Tiled depth of field, step 1: the signed CoC range of every 16x16 tile, one invocation per
//! tile. Shader: glsl/dof/dof_tiles.comp.

use crate::gpu::{GpuBuffer, GpuImage, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::after_compute_write;

pub const NAME: &str = "dof_tiles";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TilesPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_tiles.comp.
    pub struct TilesBindings {
        coc_px: image(coc_px),
        tile_coc: buffer(TileCoc),
    }
}

/// glsl/dof/dof_tiles.comp: one invocation per tile, 8x8 tiles per workgroup.
pub struct TilesShader;

impl Shader for TilesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = TilesBindings<'a>;
    type Push = TilesPush;
}

impl Twin for TilesShader {
    fn cpu(push: &TilesPush, _groups: [u32; 3], b: &mut [HostData]) {
        let coc = b[0].image().clone();
        let tile_size = crate::passes::TILE_SIZE;
        let words = b[1].words_mut();
        for ty in 0..push.tiles[1] as u32 {
            for tx in 0..push.tiles[0] as u32 {
                let (mut lo, mut hi) = (3.0e38f32, -3.0e38f32);
                for y in ty * tile_size..(ty + 1) * tile_size {
                    for x in tx * tile_size..(tx + 1) * tile_size {
                        if (x as i32) < push.size[0] && (y as i32) < push.size[1] {
                            let c = coc.clamped(x as i32, y as i32)[0];
                            lo = lo.min(c);
                            hi = hi.max(c);
                        }
                    }
                }
                let t = (ty as i32 * push.tiles[0] + tx as i32) as usize;
                words[2 * t] = lo.to_bits();
                words[2 * t + 1] = hi.to_bits();
            }
        }
    }
}

/// Record the tile reduction: `coc` -> `tile_coc` ((min, max) per tile).
pub fn record(
    kernel: &Kernel<TilesShader>,
    rec: &mut Recorder,
    coc: &GpuImage,
    tile_coc: &GpuBuffer,
    push: &TilesPush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // coc: written by the CoC pass (read-after-write). tile_coc is fully overwritten and no
    // earlier pass of this recording touched it, so it needs no barrier.
    rec.image_barriers(&[after_compute_write(coc)]);
    let groups = [(push.tiles[0] as u32).div_ceil(8), (push.tiles[1] as u32).div_ceil(8), 1];
    kernel.dispatch(rec, &TilesBindings { coc_px: coc, tile_coc }, push, groups)?;
    rec.end_pass();
    Ok(())
}
