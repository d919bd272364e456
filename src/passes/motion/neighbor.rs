//! Motion blur, step 2: the longest next and previous velocity among the tiles around each tile.
//! Shader: glsl/motion/mb_neighbor.comp.

use super::tiles::longer;
use crate::gpu::{GpuBuffer, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::buffer_after_compute_write;

pub const NAME: &str = "mb_neighbor";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbNeighborPush {
    pub tiles: [i32; 2],
    /// Tiles searched in each direction: enough for the longest blur to reach.
    pub search_tiles: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_neighbor.comp.
    pub struct MbNeighborBindings {
        tile_motion: buffer(TileMotion),
        neighbor_motion: buffer(NeighborMotion),
    }
}

/// glsl/motion/mb_neighbor.comp: one invocation per tile.
pub struct MbNeighborShader;

impl Shader for MbNeighborShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbNeighborBindings<'a>;
    type Push = MbNeighborPush;
}

impl Twin for MbNeighborShader {
    fn cpu(pc: &MbNeighborPush, _groups: [u32; 3], b: &mut [HostData]) {
        let tiles = crate::passes::twin::floats(b[0].words());
        let out = b[1].words_mut();
        let k = pc.search_tiles;
        for t in 0..(pc.tiles[0] * pc.tiles[1]) {
            let (cx, cy) = (t % pc.tiles[0], t / pc.tiles[0]);
            let (mut next, mut prev) = (None::<[f32; 2]>, None::<[f32; 2]>);
            for dy in -k..=k {
                for dx in -k..=k {
                    let (nx, ny) = (cx + dx, cy + dy);
                    if nx < 0 || ny < 0 || nx >= pc.tiles[0] || ny >= pc.tiles[1] {
                        continue;
                    }
                    let v = &tiles[4 * (ny * pc.tiles[0] + nx) as usize..][..4];
                    next = Some(next.map_or([v[0], v[1]], |n| longer(n, [v[0], v[1]])));
                    prev = Some(prev.map_or([v[2], v[3]], |p| longer(p, [v[2], v[3]])));
                }
            }
            let (n, p) = (next.unwrap_or_default(), prev.unwrap_or_default());
            for (i, value) in [n[0], n[1], p[0], p[1]].into_iter().enumerate() {
                out[4 * t as usize + i] = value.to_bits();
            }
        }
    }
}

/// Record the neighbourhood maximum: `tile_motion` -> `neighbor_motion`.
pub fn record(
    kernel: &Kernel<MbNeighborShader>,
    rec: &mut Recorder,
    tile_motion: &GpuBuffer,
    neighbor_motion: &GpuBuffer,
    push: &MbNeighborPush,
) -> GpuResult<()> {
    // tile_motion: written by mb_tiles (read-after-write). neighbor_motion: fully overwritten,
    // touched by no earlier pass of this recording.
    rec.buffer_barriers(&[buffer_after_compute_write(tile_motion)]);
    let groups = [((push.tiles[0] * push.tiles[1]) as u32).div_ceil(64), 1, 1];
    kernel.dispatch(rec, &MbNeighborBindings { tile_motion, neighbor_motion }, push, groups)
}
