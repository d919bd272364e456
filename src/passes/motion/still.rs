//! Motion blur, step 3b: the tiles nothing near moves in, copied (mb_neighbor lists them).
//! Shader: glsl/motion/mb_still.comp.

use super::gather::listed_tile_pixels;
use crate::gpu::{HostData, Shader, Twin};
use crate::passes::twin::finite_or_zero;

pub const NAME: &str = "mb_still";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbStillPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_still.comp.
    pub struct MbStillBindings {
        color_in: image(color_in),
        color_out: image(color_out),
        tile_list: buffer(TileList),
    }
}

/// glsl/motion/mb_still.comp: one invocation per pixel of the still tiles.
pub struct MbStillShader;

impl Shader for MbStillShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbStillBindings<'a>;
    type Push = MbStillPush;
}

impl Twin for MbStillShader {
    fn cpu(pc: &MbStillPush, groups: [u32; 3], b: &mut [HostData]) {
        let first_still = (pc.tiles[0] * pc.tiles[1]) as usize;
        let listed = b[2].words()[first_still..][..groups[0] as usize].to_vec();
        let input = b[0].image().clone();
        let out = b[1].image_mut();
        for [x, y] in listed.into_iter().flat_map(|t| listed_tile_pixels(t, pc.size)) {
            let c = input.clamped(x, y);
            for (o, v) in out.texel_mut(x as u32, y as u32).iter_mut().zip(c) {
                *o = finite_or_zero(*v);
            }
        }
    }

    /// A copy is exact.
    const TOLERANCE: f32 = 0.0;
}
