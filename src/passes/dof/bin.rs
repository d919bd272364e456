//! Tiled depth of field: the highlight sprites binned to the level tiles their disks reach, one
//! invocation per sprite. Shader: glsl/dof/dof_bin.comp.

use crate::gpu::shaders::dof_tiles::{ARGS_BIN_OVERFLOWS, BIN_CAPACITY, CLASS_LEVEL1, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{args_for_indirect, buffer_after_compute_write, buffer_after_fill};

pub const NAME: &str = "dof_bin";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BinPush {
    pub tiles: [i32; 2],
    pub sprite_capacity: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_bin.comp.
    pub struct BinBindings {
        args: buffer(Args),
        sprites: buffer(Sprites),
        tile_radius: buffer(TileRadius),
        bin_counts: buffer(BinCounts),
        bins: buffer(Bins),
    }
}

/// glsl/dof/dof_bin.comp: one invocation per sprite.
pub struct BinShader;

impl Shader for BinShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = BinBindings<'a>;
    type Push = BinPush;
}

impl Twin for BinShader {
    fn cpu(pc: &BinPush, _groups: [u32; 3], b: &mut [HostData]) {
        let count = crate::passes::twin::sprites_written(b[0].words(), pc.sprite_capacity);
        let sprites = crate::passes::twin::floats(&b[1].words()[..count * SPRITE_WORDS as usize]);
        let radius = crate::passes::twin::floats(b[2].words());
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let (mut counts, mut bins, mut overflows) = (b[3].words().to_vec(), b[4].words().to_vec(), 0u32);
        let tile = crate::passes::TILE_SIZE as f32;
        for (i, s) in sprites.chunks_exact(SPRITE_WORDS as usize).enumerate() {
            let r = 0.5 * s[2].abs() + 1.0;
            let lo = [((s[0] - r) / tile).floor().max(0.0) as i32, ((s[1] - r) / tile).floor().max(0.0) as i32];
            let hi = [
                (((s[0] + r) / tile).floor() as i32).min(pc.tiles[0] - 1),
                (((s[1] + r) / tile).floor() as i32).min(pc.tiles[1] - 1),
            ];
            for ty in lo[1]..=hi[1] {
                for tx in lo[0]..=hi[0] {
                    let t = (ty * pc.tiles[0] + tx) as usize;
                    if radius[2 * tile_count + t] < CLASS_LEVEL1 as f32 {
                        continue;
                    }
                    let n = counts[t];
                    counts[t] += 1;
                    if n < BIN_CAPACITY {
                        bins[t * BIN_CAPACITY as usize + n as usize] = i as u32;
                    } else if n == BIN_CAPACITY {
                        overflows += 1;
                    }
                }
            }
        }
        b[0].words_mut()[ARGS_BIN_OVERFLOWS as usize] += overflows;
        *b[3].words_mut() = counts;
        *b[4].words_mut() = bins;
    }

    /// Sprites enter a bin with atomics, in any order: sort each bin's entries.
    fn canonical(pc: &BinPush, b: &mut [HostData]) {
        let counts = b[3].words().to_vec();
        let bins = b[4].words_mut();
        for (t, &n) in counts.iter().enumerate().take((pc.tiles[0] * pc.tiles[1]) as usize) {
            let start = t * BIN_CAPACITY as usize;
            bins[start..start + n.min(BIN_CAPACITY) as usize].sort_unstable();
        }
    }
}

/// Record the binning (indirect: one invocation per sprite), after zeroing the bins' counts.
pub fn record(
    kernel: &Kernel<BinShader>,
    rec: &mut Recorder,
    b: &BinBindings<'_>,
    push: &BinPush,
    dispatch_offset_bytes: u64,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    rec.fill_buffer(b.bin_counts, 0);
    // bin_counts: zeroed by the transfer fill just before, then counted up with atomics here.
    // sprites, args (the sprite count and this dispatch's size): written by dof_downsample.
    // tile_radius (the tiles' classes): written by dof_classify, already made visible to compute.
    rec.buffer_barriers(&[
        buffer_after_fill(b.bin_counts),
        buffer_after_compute_write(b.sprites),
        args_for_indirect(b.args),
    ]);
    kernel.dispatch_indirect(rec, b, push, b.args, dispatch_offset_bytes)?;
    rec.end_pass();
    Ok(())
}
