//! Tiled depth of field: the tiles each pyramid level gathers, its own and their neighbours (so
//! the composite's upsampling finds every texel it reads), each entry with the tile's neighbours
//! of the level (dof_tiles.glsl `level_list_near`). Shader: glsl/dof/dof_level_lists.comp.

use super::classify::{level_gather_args_words, tiles_per_group};
use super::level_gather::level_neighbours;
use crate::gpu::shaders::dof_tiles::{ARGS_LEVEL_TILES_BASE, LEVELS, LEVEL_LIST_TILE_BITS};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::twin::floats;

pub const NAME: &str = "dof_level_lists";

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_level_lists.comp.
    pub struct LevelListsBindings {
        args: buffer(Args),
        tile_radius: buffer(TileRadius),
        level_lists: buffer(LevelLists),
    }
}

/// glsl/dof/dof_level_lists.comp: one invocation per tile; its push constants are the tile grid.
pub struct LevelListsShader;

impl Shader for LevelListsShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = LevelListsBindings<'a>;
    type Push = [i32; 2];
}

impl Twin for LevelListsShader {
    fn cpu(tiles: &[i32; 2], _groups: [u32; 3], b: &mut [HostData]) {
        let tile_count = (tiles[0] * tiles[1]) as usize;
        let class = floats(&b[1].words()[2 * tile_count..3 * tile_count]);
        let mut lists = vec![Vec::new(); LEVELS as usize];
        for t in 0..tile_count {
            let tc = [(t as i32) % tiles[0], (t as i32) / tiles[0]];
            for level in 1..=LEVELS {
                let near = level_neighbours(&class, *tiles, tc, level as i32);
                if near != 0 {
                    lists[level as usize - 1].push(t as u32 | near << LEVEL_LIST_TILE_BITS);
                }
            }
        }
        let args = b[0].words_mut();
        for level in 1..=LEVELS {
            let n = lists[level as usize - 1].len() as u32;
            args[(ARGS_LEVEL_TILES_BASE + level - 1) as usize] += n;
            args[level_gather_args_words(level)] += n.div_ceil(tiles_per_group(level));
        }
        let out = b[2].words_mut();
        for (level, list) in lists.iter().enumerate() {
            out[level * tile_count..level * tile_count + list.len()].copy_from_slice(list);
        }
    }

    /// Tiles enter a list with atomics, in any order: sort each list.
    fn canonical(tiles: &[i32; 2], b: &mut [HostData]) {
        let tile_count = (tiles[0] * tiles[1]) as usize;
        let counts: Vec<usize> =
            (0..LEVELS).map(|l| b[0].words()[(ARGS_LEVEL_TILES_BASE + l) as usize] as usize).collect();
        let lists = b[2].words_mut();
        for (level, &n) in counts.iter().enumerate() {
            let start = level * tile_count;
            lists[start..start + n.min(tile_count)].sort_unstable();
        }
    }
}

/// Record the level lists; the classification's barrier already made the classes visible and
/// the args buffer writable to compute.
pub fn record(
    kernel: &Kernel<LevelListsShader>,
    rec: &mut Recorder,
    b: &LevelListsBindings<'_>,
    tiles: [i32; 2],
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    let tile_count = (tiles[0] * tiles[1]) as u32;
    kernel.dispatch(rec, b, &tiles, [tile_count.div_ceil(64), 1, 1])?;
    rec.end_pass();
    Ok(())
}
