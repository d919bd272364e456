//! Tiled depth of field, step 2: dilate each tile's CoC to the neighbours it can reach, classify
//! tiles (copy / exact small gather / a pyramid level), build the tile lists (a level's tiles with
//! no nearly sharp pixel in a list of their own, for the composite without its exact gather) and
//! the indirect dispatch counts. Shader: glsl/dof/dof_classify.comp.

use crate::gpu::shaders::dof_tiles::{
    ARGS_BIN_DISPATCH, ARGS_BLURRED_TILES_BASE, ARGS_DISPATCH_WORDS, ARGS_HIGHLIGHT_DISPATCH, ARGS_LEVEL_GATHER_BASE,
    ARGS_SPRITE_TILES, CLASS_COPY, CLASS_COUNT, CLASS_LEVEL1, CLASS_SMALL, EXACT_BLEND_ABOVE_SMALL_PX,
    EXACT_MAX_RADIUS_PX, GROUP_SIZE, LEVELS, LEVEL_RADIUS, LIST_BLURRED_LEVEL1, LIST_COUNT, LIST_SPRITE_TILES,
};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{buffer_after_compute_write, buffer_after_fill};
use crate::passes::TILE_SIZE;

pub const NAME: &str = "dof_classify";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClassifyPush {
    pub tiles: [i32; 2],
    /// Neighbours searched in each direction (largest CoC radius / tile + 1).
    pub search_tiles: i32,
    /// Gather radius up to which a tile uses the exact full-resolution gather.
    pub small_radius_px: f32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_classify.comp.
    pub struct ClassifyBindings {
        tile_coc: buffer(TileCoc),
        args: buffer(Args),
        tile_lists: buffer(TileLists),
        tile_radius: buffer(TileRadius),
    }
}

/// glsl/dof/dof_classify.comp: one invocation per tile.
pub struct ClassifyShader;

impl Shader for ClassifyShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = ClassifyBindings<'a>;
    type Push = ClassifyPush;
}

/// The radius below which a pixel of a tile of pyramid level `level` takes the exact gather
/// (glsl/include/dof_tiles.glsl `exact_radius_px`): the small-CoC radius at level 1, above it
/// the largest radius of the level below, at most EXACT_MAX_RADIUS_PX.
pub fn exact_radius_px(level: u32, small_radius_px: f32) -> f32 {
    if level <= 1 {
        return small_radius_px;
    }
    small_radius_px.max(((LEVEL_RADIUS << (level - 1)) as f32).min(EXACT_MAX_RADIUS_PX as f32))
}

impl Twin for ClassifyShader {
    fn cpu(pc: &ClassifyPush, _groups: [u32; 3], b: &mut [HostData]) {
        let tile_coc = crate::passes::twin::floats(b[0].words());
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let (mut radii, mut lists) = (vec![0.0f32; 3 * tile_count], vec![Vec::new(); LIST_COUNT as usize]);
        for t in 0..tile_count {
            let (tx, ty) = ((t as i32) % pc.tiles[0], (t as i32) / pc.tiles[0]);
            let mut fg_radius = 0.0f32;
            for dy in -pc.search_tiles..=pc.search_tiles {
                for dx in -pc.search_tiles..=pc.search_tiles {
                    let (nx, ny) = (tx + dx, ty + dy);
                    if nx < 0 || ny < 0 || nx >= pc.tiles[0] || ny >= pc.tiles[1] {
                        continue;
                    }
                    let n = (ny * pc.tiles[0] + nx) as usize;
                    let range = [tile_coc[2 * n], tile_coc[2 * n + 1]];
                    let gap = [
                        ((dx.abs() - 1).max(0) * TILE_SIZE as i32) as f32,
                        ((dy.abs() - 1).max(0) * TILE_SIZE as i32) as f32,
                    ];
                    let gap_len = (gap[0] * gap[0] + gap[1] * gap[1]).sqrt();
                    let fg_n = if range[0] < 0.0 { -0.5 * range[0] } else { 0.0 };
                    if fg_n + 1.0 > gap_len {
                        fg_radius = fg_radius.max(fg_n);
                    }
                }
            }
            // A sample behind a pixel reaches no farther than the pixel's own CoC: only the
            // foreground's radius is dilated.
            let own = [tile_coc[2 * t], tile_coc[2 * t + 1]];
            let radius = (0.5 * own[0].abs().max(own[1].abs())).max(fg_radius);
            let mut class = if radius <= 0.5 { CLASS_COPY } else { CLASS_SMALL };
            if radius > pc.small_radius_px {
                let mut level = 1;
                while level < LEVELS && radius > (LEVEL_RADIUS << level) as f32 {
                    level += 1;
                }
                class = CLASS_LEVEL1 + level - 1;
            }
            radii[t] = radius;
            radii[tile_count + t] = fg_radius;
            radii[2 * tile_count + t] = class as f32;
            let own_min_radius = 0.5 * if own[0] > 0.0 { own[0] } else { (-own[1]).max(0.0) };
            let blurred = class >= CLASS_LEVEL1
                && own_min_radius
                    >= exact_radius_px(class - CLASS_LEVEL1 + 1, pc.small_radius_px)
                        + EXACT_BLEND_ABOVE_SMALL_PX as f32;
            let list = if blurred { LIST_BLURRED_LEVEL1 + class - CLASS_LEVEL1 } else { class };
            lists[list as usize].push(t as u32);
        }
        let args = b[1].words_mut();
        for (list, tiles) in lists.iter().enumerate() {
            let at = list_tiles_args_word(list as u32);
            args[at] += tiles.len() as u32;
            args[at + 1] = 1;
            args[at + 2] = 1;
        }
        for level in 1..=LEVELS {
            let at = level_gather_args_words(level);
            args[at + 1] = 1;
            args[at + 2] = 1;
        }
        for at in [ARGS_BIN_DISPATCH as usize, ARGS_HIGHLIGHT_DISPATCH as usize] {
            args[at + 1] = 1;
            args[at + 2] = 1;
        }
        let tile_lists = b[2].words_mut();
        for (list, tiles) in lists.iter().enumerate() {
            tile_lists[list * tile_count..list * tile_count + tiles.len()].copy_from_slice(tiles);
        }
        b[3].words_mut().copy_from_slice(&radii.iter().map(|r| r.to_bits()).collect::<Vec<_>>());
    }

    /// Tiles are appended to their list with atomics, in any order: sort each list.
    fn canonical(pc: &ClassifyPush, b: &mut [HostData]) {
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let counts: Vec<usize> = (0..LIST_COUNT).map(|l| b[1].words()[list_tiles_args_word(l)] as usize).collect();
        let lists = b[2].words_mut();
        for (list, &count) in counts.iter().enumerate() {
            let start = list * tile_count;
            let end = (start + count).min(lists.len());
            lists[start..end].sort_unstable();
        }
    }
}

/// Tiles of pyramid level `level` one workgroup of the level gather takes.
pub fn tiles_per_group(level: u32) -> u32 {
    let side = crate::passes::TILE_SIZE >> level;
    GROUP_SIZE / (side * side)
}

/// The word of the args buffer holding the number of tiles in tile list `list` (a class's, from
/// `LIST_BLURRED_LEVEL1` a level's blurred tiles, or `LIST_SPRITE_TILES`): the x of its
/// one-workgroup-per-tile dispatch.
pub fn list_tiles_args_word(list: u32) -> usize {
    if list < CLASS_COUNT {
        (list * ARGS_DISPATCH_WORDS) as usize
    } else if list == LIST_SPRITE_TILES {
        ARGS_SPRITE_TILES as usize
    } else {
        (ARGS_BLURRED_TILES_BASE + (list - LIST_BLURRED_LEVEL1) * ARGS_DISPATCH_WORDS) as usize
    }
}

/// The first word of the level gather's indirect dispatch in the args buffer.
pub fn level_gather_args_words(level: u32) -> usize {
    (ARGS_LEVEL_GATHER_BASE + (level - 1) * ARGS_DISPATCH_WORDS) as usize
}

/// Record the classification of the tiles in `tile_coc` into `args` (zeroed first), the tile
/// lists and the gather radii.
pub fn record(
    kernel: &Kernel<ClassifyShader>,
    rec: &mut Recorder,
    b: &ClassifyBindings<'_>,
    push: &ClassifyPush,
) -> GpuResult<()> {
    let (tile_coc, args) = (b.tile_coc, b.args);
    rec.begin_pass(NAME);
    // The counters start at zero every frame.
    rec.fill_buffer(args, 0);
    // args: zeroed by the transfer fill just before, then counted up with atomics here:
    //   transfer write -> compute read/write.
    // tile_coc: written by dof_tiles: compute write -> compute read.
    rec.buffer_barriers(&[buffer_after_fill(args), buffer_after_compute_write(tile_coc)]);
    let tile_count = (push.tiles[0] * push.tiles[1]) as u32;
    kernel.dispatch(rec, b, push, [tile_count.div_ceil(64), 1, 1])?;
    rec.end_pass();
    Ok(())
}
