//! Tiled depth of field, full-resolution tiles: copy where nothing defocused reaches, the exact
//! gather with the tile's own radius where the CoC is small. Dispatched indirectly over the
//! tile lists of dof_classify. Shader: glsl/dof/dof_tile_gather.comp.

use super::aperture::ApertureConstants;
use super::bokeh_gather::gather_exact;
use crate::gpu::shaders::dof_tiles::{CLASS_COPY, CLASS_SMALL};
use crate::gpu::{GpuBuffer, GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::passes::twin::{finite_or_zero, floats, listed_tiles};
use crate::passes::TILE_SIZE;

pub const NAME: &str = "dof_tile_gather";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TileGatherPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    /// Which list: CLASS_COPY or CLASS_SMALL.
    pub tile_class: i32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_tile_gather.comp.
    pub struct TileGatherBindings {
        color: image(color_in),
        coc: image(coc_px),
        output: image(color_out),
        tile_lists: buffer(TileLists),
        tile_radius: buffer(TileRadius),
        aperture_mask: buffer(ApertureMask),
        aperture_shape: image(aperture_shape),
    }
}

/// glsl/dof/dof_tile_gather.comp: one workgroup per tile of the class's list.
pub struct TileGatherShader;

impl Shader for TileGatherShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = TileGatherBindings<'a>;
    type Push = TileGatherPush;
}

impl Twin for TileGatherShader {
    fn cpu(pc: &TileGatherPush, groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (lists, radii) = (b[3].words().to_vec(), floats(b[4].words()));
        let data = super::aperture::ApertureData::from_bindings(&b[5], &b[6], pc.aperture.shape_radius);
        let tile_count = (pc.tiles[0] * pc.tiles[1]) as usize;
        let out = b[2].image_mut();
        for tile in listed_tiles(&lists, pc.tile_class as u32, pc.tiles, groups[0], TILE_SIZE, pc.size) {
            let t = tile.index;
            for (x, y) in tile.pixels() {
                let p = [x as i32, y as i32];
                let texel = if pc.tile_class == CLASS_COPY as i32 {
                    color.clamped(p[0], p[1]).iter().map(|&v| finite_or_zero(v)).collect::<Vec<_>>()
                } else {
                    // Samples behind p reach no farther than p's own CoC; only foreground
                    // samples can reach farther, and the tile knows the largest of those.
                    let radius_p = 0.5 * coc.clamped(p[0], p[1])[0].abs();
                    let disc_px = data.tap_disc_px(radii[t].min(radius_p.max(radii[tile_count + t])));
                    let (a, l) = (&pc.aperture, pc.layer_transition_px);
                    gather_exact(&color.texels, &coc.texels, pc.size, p, disc_px, a, l, &data).to_vec()
                };
                out.texel_mut(x, y).copy_from_slice(&texel);
            }
        }
    }
}

/// Record the copy tiles and the small-CoC tiles (two indirect dispatches over their lists).
/// The caller made the classification visible (see `tiled_dof`).
pub fn record(
    kernel: &SpecializedKernel<TileGatherShader>,
    specialization: &[u32],
    rec: &mut Recorder,
    b: &TileGatherBindings<'_>,
    args: &GpuBuffer,
    push: &TileGatherPush,
) -> GpuResult<()> {
    // The two dispatches write disjoint tiles of `output`: no barrier between them.
    for (class, label) in [(CLASS_COPY, "dof_copy_tiles"), (CLASS_SMALL, "dof_small_tiles")] {
        rec.begin_pass(label);
        let p = TileGatherPush { tile_class: class as i32, ..*push };
        let offset = super::classify::list_tiles_args_word(class) as u64 * 4;
        kernel.dispatch_indirect(rec, specialization, b, &p, args, offset)?;
        rec.end_pass();
    }
    Ok(())
}
