//! Motion blur, step 2: the longest next and previous velocity among the tiles around each tile,
//! and the lists of the tiles the gather runs on and of those it copies.
//! Shader: glsl/motion/mb_neighbor.comp.

use super::path::ShutterPush;
use super::tiles::longer;
use crate::gpu::shaders::motion::{MB_TILE_ARGS_MOVING, MB_TILE_ARGS_STILL};
use crate::gpu::{GpuBuffer, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{buffer_after_compute_write, buffer_after_fill};
use crate::passes::dof::coc_edges::pack_pixel;
use crate::passes::TILE_SIZE;

pub const NAME: &str = "mb_neighbor";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbNeighborPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    pub shutter: ShutterPush,
    /// Tiles searched in each direction: enough for the longest blur to reach.
    pub search_tiles: i32,
    /// A tile is listed for the gather where the neighbourhood's longest velocity reaches this
    /// far (px) over one of its pixels' open time: [`GATHER_FROM_PX`].
    pub gather_from_px: f32,
}

/// The reach from which a tile is listed for the gather: under the half pixel from which the
/// gather itself blurs a pixel, by a margin for the rounding of each pixel's open time, so that
/// every pixel of a listed tile decides as it would in a gather over the whole frame.
pub const GATHER_FROM_PX: f32 = 0.5 * 0.999;

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_neighbor.comp.
    pub struct MbNeighborBindings {
        tile_motion: buffer(TileMotion),
        neighbor_motion: buffer(NeighborMotion),
        args: buffer(Args),
        tile_list: buffer(TileList),
    }
}

/// glsl/motion/mb_neighbor.comp: one invocation per tile.
pub struct MbNeighborShader;

impl Shader for MbNeighborShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbNeighborBindings<'a>;
    type Push = MbNeighborPush;
}

/// Whether tile `t`'s pixels gather: the neighbourhood's longest velocities `nm` reach
/// `gather_from_px` over the open time of one of its corner pixels (the open time is linear over
/// the frame, so its ends reach farthest at a corner).
fn tile_moves(pc: &MbNeighborPush, t: i32, nm: [f32; 4]) -> bool {
    let first = [(t % pc.tiles[0]) * TILE_SIZE as i32, (t / pc.tiles[0]) * TILE_SIZE as i32];
    let last =
        [(first[0] + TILE_SIZE as i32 - 1).min(pc.size[0] - 1), (first[1] + TILE_SIZE as i32 - 1).min(pc.size[1] - 1)];
    let (mut t_fwd, mut t_back) = (0.0f32, 0.0f32);
    for i in 0..4 {
        let corner = [if i & 1 == 0 { first[0] } else { last[0] }, if i & 2 == 0 { first[1] } else { last[1] }];
        let win = pc.shutter.window([corner[0] as f32 + 0.5, corner[1] as f32 + 0.5]);
        t_fwd = t_fwd.max(win[1]);
        t_back = t_back.max(-win[0]);
    }
    let length = |x: f32, y: f32| (x * x + y * y).sqrt();
    let reach = (t_fwd * length(nm[0], nm[1])).max(t_back * length(nm[2], nm[3]));
    reach >= pc.gather_from_px
}

impl Twin for MbNeighborShader {
    fn cpu(pc: &MbNeighborPush, _groups: [u32; 3], b: &mut [HostData]) {
        let tiles = crate::passes::twin::floats(b[0].words());
        let k = pc.search_tiles;
        let count = pc.tiles[0] * pc.tiles[1];
        let (mut moving, mut still) = (Vec::new(), Vec::new());
        for t in 0..count {
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
            let nm = [n[0], n[1], p[0], p[1]];
            for (i, value) in nm.into_iter().enumerate() {
                b[1].words_mut()[4 * t as usize + i] = value.to_bits();
            }
            let packed = pack_pixel(cx, cy);
            if tile_moves(pc, t, nm) {
                moving.push(packed)
            } else {
                still.push(packed)
            }
        }
        let args = b[2].words_mut();
        for (at, n) in [(MB_TILE_ARGS_MOVING, moving.len()), (MB_TILE_ARGS_STILL, still.len())] {
            args[at as usize] += n as u32;
            args[at as usize + 1] = 1;
            args[at as usize + 2] = 1;
        }
        let list = b[3].words_mut();
        list[..moving.len()].copy_from_slice(&moving);
        list[count as usize..][..still.len()].copy_from_slice(&still);
    }

    /// Tiles are appended to their list with atomics, in any order: sort each list.
    fn canonical(pc: &MbNeighborPush, b: &mut [HostData]) {
        let count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let moving = b[2].words()[MB_TILE_ARGS_MOVING as usize] as usize;
        let still = b[2].words()[MB_TILE_ARGS_STILL as usize] as usize;
        let list = b[3].words_mut();
        list[..moving.min(count)].sort_unstable();
        list[count..(count + still).min(2 * count)].sort_unstable();
    }
}

/// The neighbourhood step's outputs: the neighbourhood maximum per tile, and the two tile lists
/// with their dispatches.
pub struct NeighborOutputs<'a> {
    pub neighbor_motion: &'a GpuBuffer,
    /// `MB_TILE_ARGS_WORDS` words: zeroed here, counted up by the shader.
    pub args: &'a GpuBuffer,
    /// Two words per tile: the moving tiles from word 0, the still ones from the tile count
    /// (column | row << 16).
    pub tile_list: &'a GpuBuffer,
}

/// Record the neighbourhood maximum and the tile lists: `tile_motion` -> `out`.
pub fn record(
    kernel: &Kernel<MbNeighborShader>,
    rec: &mut Recorder,
    tile_motion: &GpuBuffer,
    out: &NeighborOutputs,
    push: &MbNeighborPush,
) -> GpuResult<()> {
    // args: the counts and the dispatches' x start at zero (counted up with atomics): transfer
    //   write -> compute read/write.
    rec.fill_buffer(out.args, 0);
    // tile_motion: written by mb_tiles (read-after-write). neighbor_motion, tile_list: written
    // here first in this recording (the lists only up to the counts, which is all that is read).
    rec.buffer_barriers(&[buffer_after_compute_write(tile_motion), buffer_after_fill(out.args)]);
    let groups = [((push.tiles[0] * push.tiles[1]) as u32).div_ceil(64), 1, 1];
    let bindings = MbNeighborBindings {
        tile_motion,
        neighbor_motion: out.neighbor_motion,
        args: out.args,
        tile_list: out.tile_list,
    };
    kernel.dispatch(rec, &bindings, push, groups)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::shutter::{RollingDirection, ShutterCurve, ShutterPosition, ShutterTiming};

    #[test]
    fn a_tile_listed_as_still_has_no_pixel_the_gather_would_blur() {
        // The gather blurs a pixel whose open time lets its neighbourhood's longest velocity reach
        // half a pixel (mb_gather's per-pixel test); every pixel of a tile the list copies must
        // fall short of it, with a rolling shutter's open time changing over the tile. Speeds are
        // drawn around the threshold, where a tile's corners decide.
        let (w, h) = (100u32, 70u32);
        let tiles = [w.div_ceil(TILE_SIZE) as i32, h.div_ceil(TILE_SIZE) as i32];
        let mut state = 12345u32;
        let mut uniform = move || {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            (state >> 8) as f32 / 16777216.0
        };
        let (mut still, mut moving) = (0, 0);
        for position in [ShutterPosition::Centred, ShutterPosition::Start, ShutterPosition::End] {
            for direction in
                [RollingDirection::Down, RollingDirection::Up, RollingDirection::Right, RollingDirection::Left]
            {
                let timing = ShutterTiming::new(0.5 / 24.0, 24.0, position, ShutterCurve::Box)
                    .with_rolling(0.02, 24.0, direction);
                let shutter = ShutterPush::new(&timing, w, h);
                let pc = MbNeighborPush {
                    size: [w as i32, h as i32],
                    tiles,
                    shutter,
                    search_tiles: 1,
                    gather_from_px: GATHER_FROM_PX,
                };
                for t in 0..tiles[0] * tiles[1] {
                    let speed = |u: f32| 0.5 / (0.2 + 0.8 * u);
                    let (a, b) = (std::f32::consts::TAU * uniform(), std::f32::consts::TAU * uniform());
                    let (s, r) = (speed(uniform()), speed(uniform()));
                    let nm = [s * a.cos(), s * a.sin(), r * b.cos(), r * b.sin()];
                    if tile_moves(&pc, t, nm) {
                        moving += 1;
                        continue;
                    }
                    still += 1;
                    let (tx, ty) = (t % tiles[0], t / tiles[0]);
                    for y in ty * 16..((ty + 1) * 16).min(h as i32) {
                        for x in tx * 16..((tx + 1) * 16).min(w as i32) {
                            let win = shutter.window([x as f32 + 0.5, y as f32 + 0.5]);
                            let reach = (win[1].max(0.0) * (nm[0] * nm[0] + nm[1] * nm[1]).sqrt())
                                .max((-win[0]).max(0.0) * (nm[2] * nm[2] + nm[3] * nm[3]).sqrt());
                            assert!(reach < 0.5, "tile {t} listed still, pixel ({x}, {y}) reaches {reach} px");
                        }
                    }
                }
            }
        }
        assert!(still > 50 && moving > 50, "the speeds should put tiles on both sides: {still} still, {moving} moving");
    }
}
