//! Motion blur, step 0: the anti-aliased-edge resolve of the velocity and depth (see
//! glsl/motion/mb_edges.comp for the model; the layer is decided as the depth of field decides
//! it, by [`edge_layer`]). Both methods (`blur`, `reference`) blur from its output. Steps:
//! mb_tiles and mb_neighbor on the velocity as stored list the tiles where a candidate can be
//! (anything within a tile moving a quarter pixel: [`EDGE_TILE_FROM_PX`]); the outputs start as
//! copies of the velocity and depth; glsl/motion/mb_edge_list.comp, over the listed tiles, lists
//! the candidate pixels (two depth layers moving differently around them) with an atomic
//! counter; glsl/motion/mb_edges.comp, dispatched indirectly over that list, resolves them.

use super::gather::listed_tile_pixels;
use super::neighbor::{MbNeighborPush, MbNeighborShader, NeighborOutputs};
use super::path::{clamped_velocity, ShutterPush};
use super::tiles::{MbTilesPush, MbTilesShader};
use super::{neighbor, tiles};
use crate::gpu::shaders::motion::{
    MB_EDGE_ARGS_CHANGED, MB_EDGE_ARGS_COUNT, MB_EDGE_ARGS_DISPATCH, MB_EDGE_ARGS_WORDS, MB_EDGE_GROUP_SIZE,
    MB_TILE_ARGS_MOVING, MB_TILE_ARGS_WORDS,
};
use crate::gpu::{Gpu, GpuImage, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{
    after_compute_write, after_copy, args_for_indirect, buffer_after_compute_write, buffer_after_fill, copy_source,
    copy_target,
};
use crate::passes::dof::coc_edges::{pack_pixel, unpack_pixel};
use crate::passes::edge_layers::{edge_layer, EDGE_NEAR, EDGE_OWN};
use crate::passes::twin::finite_or_zero;
use crate::passes::TILE_SIZE;
use ash::vk;
use std::sync::Arc;

pub const NAME: &str = "mb_edges";
/// The candidates' list (glsl/motion/mb_edge_list.comp), its span in `--profile`.
pub const LIST_NAME: &str = "mb_edge_list";
/// The tiles the list looks at, and the outputs' copies, its span in `--profile`.
pub const TILES_NAME: &str = "mb_edge_tiles";

/// A candidate's 3x3 neighbourhood holds two motions more than half a pixel apart over the open
/// time, so one of them reaches more than a quarter pixel: the tiles whose neighbourhood's
/// longest velocity reaches less (with a margin for rounding) hold no candidate.
pub const EDGE_TILE_FROM_PX: f32 = 0.25 * 0.999;

/// The share of a pixel's light the other layer must bring before the pixel takes that layer's
/// motion. Below it a textured background's brighter texel next to a bright mover could read as
/// the mover's fringe (the far layer has no texture test, glsl/include/edge_layers.glsl); an
/// anti-aliased fringe that holds less loses at most this share of a pixel to the wrong motion.
pub const MIN_SHARE: f32 = 0.2;

/// Two depth layers are parted where the farther is this much farther (depth_classes in
/// glsl/include/motion.glsl parts them fully from 2^0.1).
pub const LAYER_RATIO: f32 = 1.071_773_5;

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbEdgesPush {
    pub size: [i32; 2],
    /// The most frames the shutter is open after the frame time, and before it.
    pub t_fwd: f32,
    pub t_back: f32,
    pub max_speed_px: f32,
    /// [`MIN_SHARE`].
    pub min_share: f32,
}

impl MbEdgesPush {
    /// `extent_frames`: the earliest and latest time any line's shutter is open (frames).
    pub fn new(size: [i32; 2], extent_frames: (f64, f64), max_speed_px: f32) -> MbEdgesPush {
        MbEdgesPush {
            size,
            t_fwd: extent_frames.1.max(0.0) as f32,
            t_back: (-extent_frames.0).max(0.0) as f32,
            max_speed_px,
            min_share: MIN_SHARE,
        }
    }
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_edge_list.comp.
    pub struct MbEdgeListBindings {
        depth_m: image(depth_m),
        velocity: image(velocity),
        args: buffer(Args),
        edge_pixels: buffer(EdgePixels),
        tile_list: buffer(TileList),
    }
}

/// glsl/motion/mb_edge_list.comp: one invocation per pixel of the listed tiles.
pub struct MbEdgeListShader;

impl Shader for MbEdgeListShader {
    const NAME: &'static str = LIST_NAME;
    type Bindings<'a> = MbEdgeListBindings<'a>;
    type Push = MbEdgesPush;
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_edges.comp.
    pub struct MbEdgesBindings {
        color_in: image(color_in),
        depth_m: image(depth_m),
        velocity: image(velocity),
        velocity_out: image(velocity_out),
        depth_out: image(depth_out),
        args: buffer(Args),
        edge_pixels: buffer(EdgePixels),
    }
}

/// glsl/motion/mb_edges.comp: one invocation per pixel of the edge list (indirect).
pub struct MbEdgesShader;

impl Shader for MbEdgesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbEdgesBindings<'a>;
    type Push = MbEdgesPush;
}

/// The resolve's pipelines: the tiles and their list, the candidates' list, the resolve.
pub struct EdgeKernels {
    /// Also the fast path's own tile steps (src/passes/motion/blur.rs): one pipeline each.
    pub(super) tiles: Kernel<MbTilesShader>,
    pub(super) neighbor: Kernel<MbNeighborShader>,
    list: Kernel<MbEdgeListShader>,
    resolve: Kernel<MbEdgesShader>,
}

impl EdgeKernels {
    pub fn new(gpu: &Gpu) -> GpuResult<EdgeKernels> {
        Ok(EdgeKernels {
            tiles: Kernel::new(gpu)?,
            neighbor: Kernel::new(gpu)?,
            list: Kernel::new(gpu)?,
            resolve: Kernel::new(gpu)?,
        })
    }
}

/// The frame's colour (RGBA), depth (m) and velocity (next.xy, prev.xy) as the resolve reads them.
pub struct EdgeInputs<'a> {
    pub width: u32,
    pub height: u32,
    pub color: &'a [f32],
    pub depth: &'a [f32],
    pub velocity: &'a [f32],
}

impl EdgeInputs<'_> {
    fn index(&self, x: i32, y: i32) -> usize {
        let (x, y) = (x.clamp(0, self.width as i32 - 1), y.clamp(0, self.height as i32 - 1));
        (y as u32 * self.width + x as u32) as usize
    }
}

/// The layer key: inverse depth of a depth kept finite and positive (the shader's `layer_key`).
fn layer_key(z: f32) -> f32 {
    1.0 / z.clamp(1.0e-6, 1.0e30)
}

fn length(a: f32, b: f32) -> f32 {
    (a * a + b * b).sqrt()
}

/// Whether the resolve looks at pixel (x, y): its 3x3 neighbourhood spans two depth layers
/// ([`LAYER_RATIO`] apart) whose motions differ by more than half a pixel over the open time.
/// glsl/motion/mb_edge_list.comp's test, which lists such pixels, in the same f32 arithmetic.
pub fn candidate(input: &EdgeInputs, pc: &MbEdgesPush, x: i32, y: i32) -> bool {
    let i_p = input.index(x, y);
    let at = |i: usize| input.index(x + i as i32 % 3 - 1, y + i as i32 / 3 - 1);
    let w_p = layer_key(input.depth[i_p]);
    let (w_near, w_far) =
        (0..9).map(|i| layer_key(input.depth[at(i)])).fold((w_p, w_p), |(n, f), v| (n.max(v), f.min(v)));
    // The depths first (most pixels lie within one layer), then the motions, as the shader.
    // Not "greater" includes NaN, as in the shader.
    if w_near.partial_cmp(&(w_far * LAYER_RATIO)) != Some(std::cmp::Ordering::Greater) {
        return false;
    }
    let velocity = |i: usize| clamped_velocity(&input.velocity[4 * i..4 * i + 4], pc.max_speed_px);
    let v_p = velocity(i_p);
    let motion = (0..9).map(|i| velocity(at(i))).fold(0.0f32, |m, v| {
        let next = length(v[0] - v_p[0], v[1] - v_p[1]) * pc.t_fwd;
        let prev = length(v[2] - v_p[2], v[3] - v_p[3]) * pc.t_back;
        m.max(next.max(prev))
    });
    motion.partial_cmp(&0.5) == Some(std::cmp::Ordering::Greater)
}

/// The velocity and depth pixel (x, y) takes where the resolve changes it (a [`candidate`]
/// whose light is mostly the other layer's: glsl/motion/mb_edges.comp's `main`), else None (it
/// keeps its own).
pub fn resolve_pixel(input: &EdgeInputs, pc: &MbEdgesPush, x: i32, y: i32) -> Option<([f32; 4], f32)> {
    if !candidate(input, pc, x, y) {
        return None;
    }
    let i_p = input.index(x, y);
    let at = |i: usize| input.index(x + i as i32 % 3 - 1, y + i as i32 / 3 - 1);
    let w: [f32; 9] = std::array::from_fn(|i| layer_key(input.depth[at(i)]));
    let w_p = layer_key(input.depth[i_p]);
    let (w_near, w_far) = w.iter().fold((w_p, w_p), |(n, f), &v| (n.max(v), f.min(v)));
    let v9: [[f32; 4]; 9] =
        std::array::from_fn(|i| clamped_velocity(&input.velocity[4 * at(i)..4 * at(i) + 4], pc.max_speed_px));
    let c9: [[f32; 3]; 9] =
        std::array::from_fn(|i| std::array::from_fn(|k| finite_or_zero(input.color[4 * at(i) + k])));
    let layer = edge_layer(&w, &c9, c9[4], w_near, w_far, pc.min_share);
    if layer == EDGE_OWN {
        return None;
    }
    let w_mid = 0.5 * (w_near + w_far);
    let (mut v_sum, mut w_sum, mut n) = ([0.0f32; 4], 0.0f32, 0.0f32);
    for i in (0..9).filter(|&i| i != 4 && (w[i] > w_mid) == (layer == EDGE_NEAR)) {
        for k in 0..4 {
            v_sum[k] += v9[i][k];
        }
        w_sum += w[i];
        n += 1.0;
    }
    Some((v_sum.map(|v| v / n), 1.0 / (w_sum / n)))
}

/// How many pixels of the frame the resolve changes (`--explain`), the twin's count.
pub fn changed_pixels(input: &EdgeInputs, pc: &MbEdgesPush) -> usize {
    (0..input.height as i32)
        .flat_map(|y| (0..input.width as i32).map(move |x| (x, y)))
        .filter(|&(x, y)| resolve_pixel(input, pc, x, y).is_some())
        .count()
}

fn edge_inputs<'a>(pc: &MbEdgesPush, color: &'a [f32], depth: &'a [f32], velocity: &'a [f32]) -> EdgeInputs<'a> {
    EdgeInputs { width: pc.size[0] as u32, height: pc.size[1] as u32, color, depth, velocity }
}

impl Twin for MbEdgeListShader {
    fn cpu(pc: &MbEdgesPush, groups: [u32; 3], b: &mut [HostData]) {
        let (depth, velocity) = (b[0].image().clone(), b[1].image().clone());
        // The list's test reads no colour.
        let input = edge_inputs(pc, &[], &depth.texels, &velocity.texels);
        let tiles = b[4].words()[..groups[0] as usize].to_vec();
        let listed: Vec<u32> = tiles
            .into_iter()
            .flat_map(|t| listed_tile_pixels(t, pc.size))
            .filter(|&[x, y]| candidate(&input, pc, x, y))
            .map(|[x, y]| pack_pixel(x, y))
            .collect();
        let args = b[2].words_mut();
        if groups[0] > 0 {
            args[MB_EDGE_ARGS_DISPATCH as usize + 1] = 1;
            args[MB_EDGE_ARGS_DISPATCH as usize + 2] = 1;
        }
        let first = args[MB_EDGE_ARGS_COUNT as usize];
        let groups = (first..first + listed.len() as u32).filter(|slot| slot % MB_EDGE_GROUP_SIZE == 0).count() as u32;
        args[MB_EDGE_ARGS_COUNT as usize] += listed.len() as u32;
        args[MB_EDGE_ARGS_DISPATCH as usize] += groups;
        b[3].words_mut()[first as usize..first as usize + listed.len()].copy_from_slice(&listed);
    }

    /// Pixels take slots of the edge list with atomics, in any order: sort the list.
    fn canonical(_pc: &MbEdgesPush, b: &mut [HostData]) {
        let count = b[2].words()[MB_EDGE_ARGS_COUNT as usize] as usize;
        let words = b[3].words_mut();
        let count = count.min(words.len());
        words[..count].sort_unstable();
    }
}

impl Twin for MbEdgesShader {
    fn cpu(pc: &MbEdgesPush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, depth, velocity) = (b[0].image().clone(), b[1].image().clone(), b[2].image().clone());
        let input = edge_inputs(pc, &color.texels, &depth.texels, &velocity.texels);
        let count = b[5].words()[MB_EDGE_ARGS_COUNT as usize] as usize;
        let listed = b[6].words()[..count].to_vec();
        let mut changed = 0u32;
        for (x, y) in listed.into_iter().map(unpack_pixel) {
            if let Some((v, z)) = resolve_pixel(&input, pc, x, y) {
                changed += 1;
                b[3].image_mut().texel_mut(x as u32, y as u32).copy_from_slice(&v);
                b[4].image_mut().texel_mut(x as u32, y as u32)[0] = z;
            }
        }
        b[5].words_mut()[MB_EDGE_ARGS_CHANGED as usize] += changed;
    }
}

/// The pushes of the steps that list the tiles where a candidate can be: `mb_tiles` on the
/// velocity as stored, then `mb_neighbor` over each tile's 3x3 tiles (a candidate's neighbours
/// lie within one pixel) with every line's open time the whole extent (the list's test takes
/// the extent's ends), from [`EDGE_TILE_FROM_PX`] of reach.
pub fn tile_pushes(push: &MbEdgesPush) -> (MbTilesPush, MbNeighborPush) {
    let size = push.size;
    let tiles = [(size[0] as u32).div_ceil(TILE_SIZE) as i32, (size[1] as u32).div_ceil(TILE_SIZE) as i32];
    let neighbor = MbNeighborPush {
        size,
        tiles,
        shutter: ShutterPush::spanning(-push.t_back, push.t_fwd),
        search_tiles: 1,
        gather_from_px: EDGE_TILE_FROM_PX,
    };
    (MbTilesPush { size, tiles, max_speed_px: push.max_speed_px }, neighbor)
}

/// The frame's colour, and its depth and velocity with the anti-aliased edges resolved when
/// `push` asks for it (else as stored): the inputs both motion-blur paths start from.
pub fn inputs(
    kernels: &EdgeKernels,
    rec: &mut Recorder,
    images: &crate::passes::FrameImages,
    push: Option<&MbEdgesPush>,
) -> GpuResult<(Arc<GpuImage>, Arc<GpuImage>, Arc<GpuImage>)> {
    let (color, depth, velocity) = (images.color().clone(), images.depth()?.clone(), images.velocity()?.clone());
    let Some(push) = push else { return Ok((color, depth, velocity)) };
    let (depth, velocity) = record(kernels, rec, &color, &depth, &velocity, push)?;
    Ok((color, depth, velocity))
}

/// Record the resolve: the colour, depth and velocity in; new depth and velocity images out (in
/// that order), complete and visible to the compute passes after it. Two spans in `--profile`:
/// [`LIST_NAME`] and [`NAME`].
pub fn record(
    kernels: &EdgeKernels,
    rec: &mut Recorder,
    color: &GpuImage,
    depth: &GpuImage,
    velocity: &GpuImage,
    push: &MbEdgesPush,
) -> GpuResult<(Arc<GpuImage>, Arc<GpuImage>)> {
    let (w, h) = (push.size[0] as u32, push.size[1] as u32);
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    rec.begin_pass(TILES_NAME);
    let tile_count = (w.div_ceil(TILE_SIZE) * h.div_ceil(TILE_SIZE)) as u64;
    let tile_motion = rec.create_buffer("motion edge tiles' longest velocities", tile_count * 16, storage)?;
    let neighbor_motion = rec.create_buffer("motion edge tiles' neighbourhoods", tile_count * 16, storage)?;
    let tile_args = rec.create_args_buffer("motion edge tile list (indirect dispatch)", MB_TILE_ARGS_WORDS)?;
    let tile_list = rec.create_buffer("motion edge tile list", 2 * tile_count * 4, storage)?;
    let (tiles_push, neighbor) = tile_pushes(push);
    tiles::record(&kernels.tiles, rec, velocity, &tile_motion, &tiles_push)?;
    let lists = NeighborOutputs { neighbor_motion: &neighbor_motion, args: &tile_args, tile_list: &tile_list };
    neighbor::record(&kernels.neighbor, rec, &tile_motion, &lists, &neighbor)?;
    let velocity_out = rec.create_image("velocity (edges resolved)", w, h, vk::Format::R32G32B32A32_SFLOAT)?;
    let depth_out = rec.create_image("depth (edges resolved)", w, h, vk::Format::R32_SFLOAT)?;
    // depth, velocity: written by the upload or a compute pass, now read by copies.
    // velocity_out, depth_out: overwritten by the copies.
    rec.image_barriers(&[
        copy_source(depth),
        copy_source(velocity),
        copy_target(&velocity_out),
        copy_target(&depth_out),
    ]);
    rec.copy_image(velocity, &velocity_out);
    rec.copy_image(depth, &depth_out);
    rec.begin_pass(LIST_NAME);
    let args = rec.create_args_buffer("motion edge resolve args (indirect dispatch, counts)", MB_EDGE_ARGS_WORDS)?;
    let edge_pixels = rec.create_buffer("motion edge pixels", (w as u64 * h as u64).max(1) * 4, storage)?;
    // args: the counts and the dispatch's x start at zero every run (counted up with atomics):
    //   transfer write -> compute read/write. The edge list is this run's own buffer, written
    //   by the list first.
    // tile_args, tile_list: written by mb_neighbor, read as this dispatch's size and by the shader.
    // depth, velocity: read around each pixel here and by the resolve (read-after-read since
    //   the upload's barrier and the copies).
    rec.fill_buffer(&args, 0);
    rec.buffer_barriers(&[
        buffer_after_fill(&args),
        args_for_indirect(&tile_args),
        buffer_after_compute_write(&tile_list),
    ]);
    let list =
        MbEdgeListBindings { depth_m: depth, velocity, args: &args, edge_pixels: &edge_pixels, tile_list: &tile_list };
    kernels.list.dispatch_indirect(rec, &list, push, &tile_args, MB_TILE_ARGS_MOVING as u64 * 4)?;
    rec.begin_pass(NAME);
    // args (this dispatch's size, the counts) and the edge list: written by the list with
    //   atomics; read here as indirect arguments and by the shader (the changed count updated).
    // velocity_out, depth_out: written by the list; overwritten here at the listed pixels
    //   (write-after-write).
    // color: written by the upload (its own barrier) or an earlier compute pass, read around
    //   each listed pixel.
    rec.buffer_barriers(&[args_for_indirect(&args), buffer_after_compute_write(&edge_pixels)]);
    rec.image_barriers(&[after_compute_write(color), after_copy(&velocity_out), after_copy(&depth_out)]);
    let resolve = MbEdgesBindings {
        color_in: color,
        depth_m: depth,
        velocity,
        velocity_out: &velocity_out,
        depth_out: &depth_out,
        args: &args,
        edge_pixels: &edge_pixels,
    };
    kernels.resolve.dispatch_indirect(rec, &resolve, push, &args, MB_EDGE_ARGS_DISPATCH as u64 * 4)?;
    // The resolved images, complete before the blur's steps read them anywhere.
    rec.image_barriers(&[after_compute_write(&velocity_out), after_compute_write(&depth_out)]);
    Ok((depth_out, velocity_out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::HostImage;

    /// A 12x6 frame: a still background (8 m, colour 0.1) and a bar (2 m, colour 1) in columns
    /// 4..8 moving `bar_px` px per frame to the right (both vectors: next = bar_px, prev =
    /// -bar_px); column 8 is the bar's anti-aliased fringe: 70% bar light, background depth and
    /// vector (one sample per pixel).
    fn bar_frame(bar_px: f32) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let (w, h) = (12usize, 6usize);
        let (mut color, mut depth, mut velocity) = (Vec::new(), Vec::new(), Vec::new());
        for _y in 0..h {
            for x in 0..w {
                let on_bar = (4..8).contains(&x);
                let c = if on_bar {
                    1.0
                } else if x == 8 {
                    0.7 + 0.3 * 0.1
                } else {
                    0.1
                };
                color.extend([c, c, c, 1.0]);
                depth.push(if on_bar { 2.0 } else { 8.0 });
                velocity.extend(if on_bar { [bar_px, 0.0, -bar_px, 0.0] } else { [0.0; 4] });
            }
        }
        (color, depth, velocity)
    }

    /// The resolve's two twins chained as `record` dispatches them: the list (every pixel's
    /// velocity and depth copied, the candidates listed), then the resolve over the list.
    /// Returns the velocity, the depth, the sorted list and the changed count.
    fn two_dispatches(
        color: &[f32],
        depth: &[f32],
        velocity: &[f32],
        pc: &MbEdgesPush,
    ) -> (Vec<f32>, Vec<f32>, Vec<u32>, u32) {
        let (w, h) = (pc.size[0] as u32, pc.size[1] as u32);
        let image = |channels, texels: Vec<f32>| HostData::Image(HostImage::new(w, h, channels, texels));
        let n = (w * h) as usize;
        // The tiles' step: mb_tiles, then mb_neighbor's lists.
        let (tiles_push, neighbor_push) = tile_pushes(pc);
        let tile_count = (tiles_push.tiles[0] * tiles_push.tiles[1]) as usize;
        let mut tiles = vec![image(4, velocity.to_vec()), HostData::Buffer(vec![0; 4 * tile_count])];
        MbTilesShader::cpu(&tiles_push, [1, 1, 1], &mut tiles);
        let mut lists = vec![
            tiles[1].clone(),
            HostData::Buffer(vec![0; 4 * tile_count]),
            HostData::Buffer(vec![0; MB_TILE_ARGS_WORDS as usize]),
            HostData::Buffer(vec![u32::MAX; 2 * tile_count]),
        ];
        MbNeighborShader::cpu(&neighbor_push, [1, 1, 1], &mut lists);
        let listed_tiles = lists[2].words()[MB_TILE_ARGS_MOVING as usize];
        let mut list = vec![
            image(1, depth.to_vec()),
            image(4, velocity.to_vec()),
            HostData::Buffer(vec![0; MB_EDGE_ARGS_WORDS as usize]),
            HostData::Buffer(vec![u32::MAX; n]),
            lists[3].clone(),
        ];
        MbEdgeListShader::cpu(pc, [listed_tiles, 1, 1], &mut list);
        let args = list[2].words().to_vec();
        let count = args[MB_EDGE_ARGS_COUNT as usize];
        assert_eq!(args[MB_EDGE_ARGS_DISPATCH as usize], count.div_ceil(MB_EDGE_GROUP_SIZE));
        assert_eq!(args[1..3], [1, 1]);
        // The resolve's outputs start as copies of the velocity and depth (transfer copies).
        let mut resolve = vec![
            image(4, color.to_vec()),
            list[0].clone(),
            list[1].clone(),
            list[1].clone(),
            list[0].clone(),
            list[2].clone(),
            list[3].clone(),
        ];
        MbEdgesShader::cpu(pc, [args[MB_EDGE_ARGS_DISPATCH as usize], 1, 1], &mut resolve);
        let mut listed = list[3].words()[..count as usize].to_vec();
        listed.sort_unstable();
        let changed = resolve[5].words()[MB_EDGE_ARGS_CHANGED as usize];
        (resolve[3].image().texels.clone(), resolve[4].image().texels.clone(), listed, changed)
    }

    #[test]
    fn the_resolve_lists_the_pixels_beside_two_layers_moving_apart_and_changes_the_fringe_alone() {
        // At 16 px per frame and a centred half-frame shutter the bar moves 4 px over the open
        // time each way: the two columns either side of each of its edges (3, 4 and 7, 8) are
        // listed, 24 of 72 pixels. The fringe column 8 holds 70% of the bar's light: it alone
        // takes the bar's velocity and depth, and the count (`--explain`'s) says 6 pixels.
        let (color, depth, velocity) = bar_frame(16.0);
        let pc = MbEdgesPush::new([12, 6], (-0.25, 0.25), 512.0);
        let (v_out, z_out, listed, changed) = two_dispatches(&color, &depth, &velocity, &pc);
        let expected: Vec<u32> = {
            let mut e: Vec<u32> = (0..6).flat_map(|y| [3, 4, 7, 8].map(|x| pack_pixel(x, y))).collect();
            e.sort_unstable();
            e
        };
        assert_eq!(listed, expected);
        assert_eq!(changed, 6);
        let input = EdgeInputs { width: 12, height: 6, color: &color, depth: &depth, velocity: &velocity };
        assert_eq!(changed as usize, changed_pixels(&input, &pc));
        for y in 0..6 {
            for x in 0..12 {
                let i = y * 12 + x;
                let (v, z) = if x == 8 {
                    ([16.0, 0.0, -16.0, 0.0], 2.0)
                } else {
                    ([velocity[4 * i], 0.0, velocity[4 * i + 2], 0.0], depth[i])
                };
                assert_eq!(v_out[4 * i..4 * i + 4], v, "velocity at ({x}, {y})");
                assert!((z_out[i] - z).abs() < 1e-5 * z, "depth at ({x}, {y}): {} vs {z}", z_out[i]);
            }
        }
        // A bar moving less than half a pixel either way over the open time lists nothing.
        let (color, depth, velocity) = bar_frame(1.9);
        let (v_out, z_out, listed, changed) = two_dispatches(&color, &depth, &velocity, &pc);
        assert!(listed.is_empty() && changed == 0);
        assert_eq!((v_out, z_out), (velocity, depth));
    }
}
