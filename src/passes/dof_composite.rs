//! Tiled depth of field: the large-CoC tiles at full resolution (upsampled half-resolution layers,
//! the exact gather for nearly sharp pixels). Shader: glsl/dof_composite.comp.

use super::aperture::ApertureConstants;
use super::barriers::{after_compute_write, write_after_write};
use super::bokeh_gather::gather_exact;
use super::twin::{floats, listed_tiles};
use super::TILE_SIZE;
use crate::gpu::shaders::dof_tiles::{ARGS_DISPATCH_WORDS, CLASS_LARGE};
use crate::gpu::{GpuBuffer, GpuResult, HostData, Kernel, Recorder, Shader, Twin};

pub const NAME: &str = "dof_composite";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CompositePush {
    pub size: [i32; 2],
    pub half_size: [i32; 2],
    pub tiles: [i32; 2],
    pub small_radius_px: f32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof_composite.comp.
    pub struct CompositeBindings {
        color: image(color_in),
        coc: image(coc_px),
        bg_half: image(bg_half),
        fg_half: image(fg_half),
        output: image(color_out),
        tile_lists: buffer(TileLists),
        aperture_mask: buffer(ApertureMask),
        coc_half: image(coc_half),
        fg_big_half: image(fg_big_half),
        tile_radius: buffer(TileRadius),
    }
}

/// glsl/dof_composite.comp: one workgroup per large tile.
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

impl Twin for CompositeShader {
    fn cpu(pc: &CompositePush, groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (bg_half, fg_half) = (b[2].image().clone(), b[3].image().clone());
        let (lists, mask, radii) = (b[5].words().to_vec(), floats(b[6].words()), floats(b[9].words()));
        let (coc_half, fg_big_half) = (b[7].image().clone(), b[8].image().clone());
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let out = b[4].image_mut();
        // Bilinear from four half-resolution texels (edge texels continue).
        let bilinear = |img: &crate::gpu::HostImage, h0: [i32; 2], f: [f32; 2]| {
            let top = mix4(img.clamped(h0[0], h0[1]), img.clamped(h0[0] + 1, h0[1]), f[0]);
            let bottom = mix4(img.clamped(h0[0], h0[1] + 1), img.clamped(h0[0] + 1, h0[1] + 1), f[0]);
            mix4(&top, &bottom, f[1])
        };
        for tile in listed_tiles(&lists, CLASS_LARGE, pc.tiles, groups[0], TILE_SIZE, pc.size) {
            let t = tile.index;
            for (x, y) in tile.pixels() {
                let p = [x as i32, y as i32];
                let h = [(x as f32 + 0.5) * 0.5 - 0.5, (y as f32 + 0.5) * 0.5 - 0.5];
                let h0 = [h[0].floor() as i32, h[1].floor() as i32];
                let f = [h[0] - h0[0] as f32, h[1] - h0[1] as f32];
                // Joint bilateral upsampling of the background.
                let coc_here = coc.clamped(p[0], p[1])[0];
                let (mut bg, mut bg_weight) = ([0.0f32; 4], 0.0f32);
                for j in 0..2 {
                    for i in 0..2 {
                        let q = [h0[0] + i, h0[1] + j];
                        let bilinear_w =
                            (if i == 0 { 1.0 - f[0] } else { f[0] }) * (if j == 0 { 1.0 - f[1] } else { f[1] });
                        let similar = 1.0 / (1.0 + (coc_half.clamped(q[0], q[1])[0] - coc_here).abs());
                        let texel = bg_half.clamped(q[0], q[1]);
                        for k in 0..4 {
                            bg[k] += bilinear_w * similar * texel[k];
                        }
                        bg_weight += bilinear_w * similar;
                    }
                }
                if bg_weight > 0.0 {
                    bg = bg.map(|v| v / bg_weight);
                } else {
                    bg.copy_from_slice(bg_half.clamped(h0[0], h0[1]));
                }
                let mut fg = bilinear(&fg_half, h0, f);
                let radius_p = 0.5 * coc_here.abs();
                let blurred = smoothstep(pc.small_radius_px - 2.0, pc.small_radius_px - 0.5, radius_p);
                let mut base = bg;
                if blurred < 1.0 {
                    let fg_radius = radii[tile_count + t];
                    let r = (pc.small_radius_px + 1.0).min(radius_p.max(fg_radius)).ceil() as i32 + 1;
                    let mut exact = gather_exact(
                        &color.texels,
                        &coc.texels,
                        pc.size,
                        p,
                        r,
                        &pc.aperture,
                        pc.layer_transition_px,
                        &mask,
                    );
                    let big = bilinear(&fg_big_half, h0, f);
                    for k in 0..3 {
                        exact[k] = exact[k] * (1.0 - big[3]) + big[k] * big[3];
                    }
                    base = mix4(&exact, &bg, blurred);
                    fg[3] *= blurred;
                }
                let texel: [f32; 4] =
                    std::array::from_fn(|k| if k < 3 { base[k] * (1.0 - fg[3]) + fg[k] * fg[3] } else { base[3] });
                out.texel_mut(x, y).copy_from_slice(&texel);
            }
        }
    }
}

pub fn record(
    kernel: &Kernel<CompositeShader>,
    rec: &mut Recorder,
    b: &CompositeBindings<'_>,
    args: &GpuBuffer,
    push: &CompositePush,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // bg_half, fg_half, fg_big_half: written by dof_half_gather (read-after-write).
    // color (the colour less the sprites' energy) and coc_half: written by dof_downsample
    //   (coc_half was already waited for by dof_half_gather; the extra dependency is free).
    // output: the full-resolution tile passes wrote other tiles of it; the write-after-write
    //   dependency keeps sync validation (which tracks whole images) and any driver honest.
    rec.image_barriers(&[
        after_compute_write(b.color),
        after_compute_write(b.coc_half),
        after_compute_write(b.bg_half),
        after_compute_write(b.fg_half),
        after_compute_write(b.fg_big_half),
        write_after_write(b.output),
    ]);
    kernel.dispatch_indirect(rec, b, push, args, (CLASS_LARGE * ARGS_DISPATCH_WORDS * 4) as u64)?;
    rec.end_pass();
    Ok(())
}
