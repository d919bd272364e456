//! Tiled depth of field: the level tiles at full resolution (the tile's level upsampled, the
//! exact gather for nearly sharp pixels, the binned highlight sprites). Shader:
//! glsl/dof_composite.comp.

use super::aperture::{aperture_weight_at, sa_weight, ApertureConstants, ApertureData};
use super::barriers::{after_compute_write, buffer_after_compute_write, write_after_write};
use super::bokeh_gather::gather_exact;
use super::twin::{floats, listed_tiles};
use super::TILE_SIZE;
use crate::gpu::shaders::dof_tiles::{BIN_CAPACITY, LIST_BLURRED_LEVEL1, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, HostImage, Recorder, Shader, SpecializedKernel, Twin};

pub const NAME: &str = "dof_composite";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CompositePush {
    pub size: [i32; 2],
    pub level_size: [i32; 2],
    pub tiles: [i32; 2],
    pub level: i32,
    pub small_radius_px: f32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
    pub sprite_capacity: i32,
    /// The tile list the dispatch takes: the level's class list (`CLASS_LEVEL1 + level - 1`),
    /// or its blurred list (`LIST_BLURRED_LEVEL1 + level - 1`, the pipeline without the exact
    /// gather).
    pub list: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof_composite.comp.
    pub struct CompositeBindings {
        color: image(color_in),
        coc: image(coc_px),
        bg_level: image(bg_level),
        fg_level: image(fg_level),
        output: image(color_out),
        tile_lists: buffer(TileLists),
        aperture_mask: buffer(ApertureMask),
        coc_level: image(coc_level),
        fg_big_level: image(fg_big_level),
        tile_radius: buffer(TileRadius),
        sprites: buffer(Sprites),
        bin_counts: buffer(BinCounts),
        bins: buffer(Bins),
        aperture_shape: image(aperture_shape),
        args: buffer(Args),
    }
}

/// glsl/dof_composite.comp: one workgroup per tile of the level.
pub struct CompositeShader;

impl Shader for CompositeShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CompositeBindings<'a>;
    type Push = CompositePush;
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn mix4(a: &[f32], b: &[f32], t: f32) -> [f32; 4] {
    std::array::from_fn(|k| a[k] * (1.0 - t) + b[k] * t)
}

/// Bilinear between the four level texels from `h0` (edge texels continue).
fn bilinear(img: &HostImage, h0: [i32; 2], f: [f32; 2]) -> [f32; 4] {
    let at = |x: i32, y: i32| img.clamped(x, y);
    let top = mix4(at(h0[0], h0[1]), at(h0[0] + 1, h0[1]), f[0]);
    let bottom = mix4(at(h0[0], h0[1] + 1), at(h0[0] + 1, h0[1] + 1), f[0]);
    mix4(&top, &bottom, f[1])
}

/// The light of one sprite (its 8 words) at pixel p of signed CoC `coc_p`.
pub fn sprite_light(s: &[f32], p: [i32; 2], coc_p: f32, ap: &ApertureConstants, data: &ApertureData) -> [f32; 3] {
    let (centre, coc_q) = ([s[0], s[1]], s[2]);
    let radius_p = (0.5 * coc_p.abs()).max(0.5);
    let radius_q = (0.5 * coc_q.abs()).max(0.5);
    let reach = if coc_q > coc_p { radius_q.min(radius_p) } else { radius_q };
    let flip = if coc_q < 0.0 { -1 } else { 1 };
    let o = [(p[0] - centre[0].floor() as i32) * flip, (p[1] - centre[1].floor() as i32) * flip];
    let w = aperture_weight_at(o, reach, ap, centre, flip as f32, 1.0, data)
        * sa_weight([o[0] as f32, o[1] as f32], radius_q, coc_q, ap);
    [s[4] * w, s[5] * w, s[6] * w]
}

impl Twin for CompositeShader {
    fn cpu(pc: &CompositePush, groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (bg_level, fg_level) = (b[2].image().clone(), b[3].image().clone());
        let (lists, radii) = (b[5].words().to_vec(), floats(b[9].words()));
        let data = ApertureData::from_bindings(&b[6], &b[13], pc.aperture.shape_radius);
        let (coc_level, fg_big_level) = (b[7].image().clone(), b[8].image().clone());
        let sprite_count = super::twin::sprites_written(b[14].words(), pc.sprite_capacity);
        let sprites = floats(&b[10].words()[..sprite_count * SPRITE_WORDS as usize]);
        let (counts, bins) = (b[11].words().to_vec(), b[12].words().to_vec());
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let scale = (1 << pc.level) as f32;
        let out = b[4].image_mut();
        // The pipeline of the blurred lists has no exact gather; their tiles' pixels all have
        // `blurred` 1, so the rule below is both pipelines'.
        for tile in listed_tiles(&lists, pc.list as u32, pc.tiles, groups[0], TILE_SIZE, pc.size) {
            let t = tile.index;
            for (x, y) in tile.pixels() {
                let p = [x as i32, y as i32];
                let h = [(x as f32 + 0.5) / scale - 0.5, (y as f32 + 0.5) / scale - 0.5];
                let h0 = [h[0].floor() as i32, h[1].floor() as i32];
                let f = [h[0] - h0[0] as f32, h[1] - h0[1] as f32];
                let coc_here = coc.clamped(p[0], p[1])[0];
                let (mut bg, mut bg_weight) = ([0.0f32; 4], 0.0f32);
                for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let q = [(h0[0] + i).clamp(0, pc.level_size[0] - 1), (h0[1] + j).clamp(0, pc.level_size[1] - 1)];
                    let cw = coc_level.clamped(q[0], q[1]);
                    let bilinear_w =
                        (if i == 0 { 1.0 - f[0] } else { f[0] }) * (if j == 0 { 1.0 - f[1] } else { f[1] });
                    let similar = cw[1];
                    let texel = bg_level.clamped(q[0], q[1]);
                    for k in 0..4 {
                        bg[k] += bilinear_w * similar * texel[k];
                    }
                    bg_weight += bilinear_w * similar;
                }
                if bg_weight > 0.0 {
                    bg = bg.map(|v| v / bg_weight);
                } else {
                    bg.copy_from_slice(bg_level.clamped(h0[0], h0[1]));
                }
                let mut fg = bilinear(&fg_level, h0, f);
                let radius_p = 0.5 * coc_here.abs();
                let blurred = smoothstep(pc.small_radius_px - 2.0, pc.small_radius_px - 0.5, radius_p);
                let mut base = bg;
                if blurred < 1.0 {
                    let fg_radius = radii[tile_count + t];
                    let disc_px = data.tap_disc_px((pc.small_radius_px + 1.0).min(radius_p.max(fg_radius)));
                    let (a, l) = (&pc.aperture, pc.layer_transition_px);
                    let mut exact = gather_exact(&color.texels, &coc.texels, pc.size, p, disc_px, a, l, &data);
                    let big = bilinear(&fg_big_level, h0, f);
                    for k in 0..3 {
                        exact[k] = exact[k] * (1.0 - big[3]) + big[k] * big[3];
                    }
                    base = mix4(&exact, &bg, blurred);
                    fg[3] *= blurred;
                }
                let mut rgb: [f32; 3] = std::array::from_fn(|k| base[k] * (1.0 - fg[3]) + fg[k] * fg[3]);
                let n = counts[t];
                let indices: Vec<usize> = if n > BIN_CAPACITY {
                    (0..sprite_count).collect()
                } else {
                    bins[t * BIN_CAPACITY as usize..t * BIN_CAPACITY as usize + n as usize]
                        .iter()
                        .map(|&i| i as usize)
                        .collect()
                };
                for i in indices {
                    let s = &sprites[i * SPRITE_WORDS as usize..(i + 1) * SPRITE_WORDS as usize];
                    let light = sprite_light(s, p, coc_here, &pc.aperture, &data);
                    for k in 0..3 {
                        rgb[k] += light[k];
                    }
                }
                out.texel_mut(x, y).copy_from_slice(&[rgb[0], rgb[1], rgb[2], base[3]]);
            }
        }
    }

    /// A pixel sums many sprites, in the bin's order on the GPU: a little more room.
    const TOLERANCE: f32 = 2e-4;
}

/// The composite's specialisation: the aperture's two constants, then whether the exact gather is
/// in the code (off for the blurred lists).
pub fn specialization(aperture: [u32; 2], exact_gather: bool) -> [u32; 3] {
    [aperture[0], aperture[1], exact_gather as u32]
}

/// Record the composite over the tile list `push.list`, with the pipeline of `specialization`.
pub fn record(
    kernel: &SpecializedKernel<CompositeShader>,
    specialization: &[u32],
    rec: &mut Recorder,
    b: &CompositeBindings<'_>,
    push: &CompositePush,
) -> GpuResult<()> {
    let blurred = push.list as u32 >= LIST_BLURRED_LEVEL1;
    rec.begin_pass(&format!("{NAME}_{}{}", push.level, if blurred { "_blurred" } else { "" }));
    // bg/fg/fg_big_level: written by the level gather (read-after-write).
    // color (the input colour less the sprites' energy): written in place by dof_sprite_excess.
    // coc_level: written by the pyramid passes.
    // output: the full-resolution tile passes and the other composites (the other levels', and
    //   the level's other list) wrote other tiles of it; the write-after-write dependency keeps
    //   sync validation (which tracks whole images) and any driver honest.
    // bins, bin counts: written by dof_bin and put in order by dof_bin_order (read-after-write).
    rec.image_barriers(&[
        after_compute_write(b.color),
        after_compute_write(b.coc_level),
        after_compute_write(b.bg_level),
        after_compute_write(b.fg_level),
        after_compute_write(b.fg_big_level),
        write_after_write(b.output),
    ]);
    rec.buffer_barriers(&[buffer_after_compute_write(b.bins), buffer_after_compute_write(b.bin_counts)]);
    let offset = super::dof_classify::list_tiles_args_word(push.list as u32) as u64 * 4;
    kernel.dispatch_indirect(rec, specialization, b, push, b.args, offset)?;
    rec.end_pass();
    Ok(())
}
