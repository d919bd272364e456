//! Tiled depth of field: each tile's bin of sprites put in a fixed order (by the sprites'
//! centres), so that dof_sprites adds their light in the same order on every run: dof_bin fills
//! the bins with atomics, in an order that changes from run to run. The tiles whose bin holds a
//! sprite are listed for dof_sprites. One invocation per tile. Shader: glsl/dof/dof_bin_order.comp.

use super::classify::list_tiles_args_word;
use crate::gpu::shaders::dof_tiles::{BIN_CAPACITY, GROUP_SIZE, LIST_SPRITE_TILES, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::buffer_after_compute_write;

pub const NAME: &str = "dof_bin_order";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BinOrderPush {
    pub tile_count: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_bin_order.comp.
    pub struct BinOrderBindings {
        sprites: buffer(Sprites),
        bin_counts: buffer(BinCounts),
        bins: buffer(Bins),
        args: buffer(Args),
        tile_lists: buffer(TileLists),
    }
}

/// glsl/dof/dof_bin_order.comp: one invocation per tile.
pub struct BinOrderShader;

impl Shader for BinOrderShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = BinOrderBindings<'a>;
    type Push = BinOrderPush;
}

/// Orders the first `n` entries of a bin (sprite indices) by their sprites' centres, row then
/// column, as the shader does; `sprites` holds SPRITE_WORDS words per sprite, the centre first.
pub fn order_bin(entries: &mut [u32], sprites: &[u32]) {
    let centre = |i: u32| {
        let at = i as usize * SPRITE_WORDS as usize;
        (f32::from_bits(sprites[at + 1]), f32::from_bits(sprites[at]))
    };
    // A stable sort by (row, column); centres are unique, so any correct sort gives this order.
    entries.sort_by(|&a, &b| centre(a).partial_cmp(&centre(b)).unwrap_or(std::cmp::Ordering::Equal));
}

impl Twin for BinOrderShader {
    fn cpu(pc: &BinOrderPush, _groups: [u32; 3], b: &mut [HostData]) {
        let sprites = b[0].words().to_vec();
        let counts = b[1].words().to_vec();
        let tile_count = pc.tile_count.max(0) as usize;
        let bins = b[2].words_mut();
        for (t, &n) in counts.iter().enumerate().take(tile_count) {
            if n > BIN_CAPACITY {
                continue;
            }
            let start = t * BIN_CAPACITY as usize;
            order_bin(&mut bins[start..start + n as usize], &sprites);
        }
        // The tiles with sprites, listed and counted (in tile order; the GPU's order is any).
        let listed: Vec<u32> = (0..tile_count as u32).filter(|&t| counts[t as usize] > 0).collect();
        b[3].words_mut()[list_tiles_args_word(LIST_SPRITE_TILES)] += listed.len() as u32;
        let start = LIST_SPRITE_TILES as usize * tile_count;
        b[4].words_mut()[start..start + listed.len()].copy_from_slice(&listed);
    }

    /// Tiles are appended to the list with atomics, in any order: sort it.
    fn canonical(pc: &BinOrderPush, b: &mut [HostData]) {
        let tile_count = pc.tile_count.max(0) as usize;
        let count = b[3].words()[list_tiles_args_word(LIST_SPRITE_TILES)] as usize;
        let start = LIST_SPRITE_TILES as usize * tile_count;
        let lists = b[4].words_mut();
        let end = (start + count).min(lists.len());
        lists[start..end].sort_unstable();
    }
}

/// Record the ordering of every tile's bin, after dof_bin filled them, and the list of the tiles
/// with sprites.
pub fn record(
    kernel: &Kernel<BinOrderShader>,
    rec: &mut Recorder,
    b: &BinOrderBindings<'_>,
    tile_count: u32,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // bins, bin counts: written by dof_bin with atomics; read and reordered here. The sprites
    // were made visible to compute before dof_bin read them.
    // args: its counters updated by dof_bin (the bins' overflows); the sprite tiles counted up
    //   here. tile_lists: dof_classify's lists, read by the tile passes; the sprite tiles'
    //   list written here (write-after-read and -write).
    rec.buffer_barriers(&[
        buffer_after_compute_write(b.bins),
        buffer_after_compute_write(b.bin_counts),
        buffer_after_compute_write(b.args),
        buffer_after_compute_write(b.tile_lists),
    ]);
    let push = BinOrderPush { tile_count: tile_count as i32 };
    kernel.dispatch(rec, b, &push, [tile_count.div_ceil(GROUP_SIZE), 1, 1])?;
    rec.end_pass();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sprite_words(centres: &[(f32, f32)]) -> Vec<u32> {
        centres
            .iter()
            .flat_map(|&(x, y)| {
                let mut s = vec![0u32; SPRITE_WORDS as usize];
                s[0] = x.to_bits();
                s[1] = y.to_bits();
                s
            })
            .collect()
    }

    #[test]
    fn a_bin_is_ordered_by_row_then_column_whatever_order_it_was_filled_in() {
        // Four sprites: (x, y) centres; rows first, then columns.
        let sprites = sprite_words(&[(40.5, 8.5), (3.5, 8.5), (100.5, 2.5), (3.5, 30.5)]);
        let expected = vec![2u32, 1, 0, 3];
        for filled in [[0u32, 1, 2, 3], [3, 2, 1, 0], [1, 3, 0, 2]] {
            let mut bin = filled.to_vec();
            order_bin(&mut bin, &sprites);
            assert_eq!(bin, expected, "filled as {filled:?}");
        }
    }
}
