//! The CoC pass's anti-aliased-edge resolve (glsl/dof/coc_edges.comp): which pixels it looks
//! at (glsl/dof/coc.comp lists them), the depth whose light an edge pixel mostly holds, and the
//! shader's declaration and CPU twin. Recorded by the coc pass (`coc`), after its own dispatch.

/// The edge resolve's dispatch (glsl/dof/coc_edges.comp), also its span in `--profile`.
use super::coc_push::CocPush;
use crate::gpu::shaders::coc::COC_ARGS_COUNT;
use crate::gpu::{HostData, HostImage, Shader, Twin};
use crate::passes::edge_layers::{edge_layer, EDGE_FAR, EDGE_NEAR};
use crate::passes::twin::{finite_or_zero, floats};

pub const NAME: &str = "coc_edges";

/// The edge resolve looks at a pixel only where the CoC diameters in its 3x3 neighbourhood span
/// more than this (px; glsl/dof/coc.comp has the same number). At 1 px, the fringe of a highlight
/// 0.5 m in front of a wall 8 m away kept the wall's CoC, up to a pixel wider: scene A's
/// background highlights came out 1-3.5% larger in area than Cycles' (a fringe holds some 10-30%
/// of a small sphere's light). A quarter pixel leaves at most 0.3% at f/2; the coc pass's time on
/// scene A did not change (11.3 ms on lavapipe).
pub const EDGE_RESOLVE_MIN_PX: f32 = 0.25;

/// Whether the edge resolve looks at pixel (x, y): the CoCs of the nearest and the farthest
/// depth of its 3x3 neighbourhood differ by more than [`EDGE_RESOLVE_MIN_PX`]. glsl/dof/coc.comp's
/// `at_edge`, which lists such pixels for glsl/dof/coc_edges.comp, in the same f32 arithmetic.
pub fn at_edge(depth: &HostImage, push: &CocPush, x: i32, y: i32) -> bool {
    let d_p = push.depth_mm(depth.clamped(x, y)[0]);
    let (d_min, d_max) = (0..9)
        .map(|i| push.depth_mm(depth.clamped(x + i % 3 - 1, y + i / 3 - 1)[0]))
        .fold((d_p, d_p), |(lo, hi), d| (lo.min(d), hi.max(d)));
    push.coc_scale_px_mm * (1.0 / d_min - 1.0 / d_max) > EDGE_RESOLVE_MIN_PX
}

/// The inverse depth (1/mm) whose light pixel (x, y) mostly holds: its own, or where the edge
/// resolve is on and the pixel is [`at_edge`], [`edge_inverse_depth`].
pub fn resolved_inverse_depth(depth: &HostImage, color: &HostImage, push: &CocPush, x: i32, y: i32) -> f32 {
    if push.resolve_edges != 0 && at_edge(depth, push, x, y) {
        edge_inverse_depth(depth, color, push, x, y)
    } else {
        push.inverse_depth(depth.clamped(x, y)[0])
    }
}

/// The inverse depth (1/mm) whose light a pixel (x, y) at an edge mostly holds:
/// glsl/dof/coc_edges.comp's, in the same f32 arithmetic. The layer is decided by
/// [`edge_layer`] (shared with the motion blur's edge resolve); the pixel takes its mean.
pub fn edge_inverse_depth(depth: &HostImage, color: &HostImage, push: &CocPush, x: i32, y: i32) -> f32 {
    let w_p = push.inverse_depth(depth.clamped(x, y)[0]);
    let offset = |i: i32| (x + i % 3 - 1, y + i / 3 - 1);
    let w: [f32; 9] = std::array::from_fn(|i| {
        let (qx, qy) = offset(i as i32);
        push.inverse_depth(depth.clamped(qx, qy)[0])
    });
    let (w_near, w_far) = w.iter().fold((w_p, w_p), |(n, f), &v| (n.max(v), f.min(v)));
    let w_mid = 0.5 * (w_near + w_far);
    let c9: [[f32; 3]; 9] = std::array::from_fn(|i| {
        let (qx, qy) = offset(i as i32);
        std::array::from_fn(|k| finite_or_zero(color.clamped(qx, qy)[k]))
    });
    let c_p: [f32; 3] = std::array::from_fn(|k| finite_or_zero(color.clamped(x, y)[k]));
    let (mut near, mut far) = ((0.0f32, 0.0f32), (0.0f32, 0.0f32));
    for i in (0..9).filter(|&i| i != 4) {
        let layer = if w[i] > w_mid { &mut near } else { &mut far };
        layer.0 += 1.0;
        layer.1 += w[i];
    }
    match edge_layer(&w, &c9, c_p, w_near, w_far, 0.0) {
        EDGE_NEAR => near.1 / near.0,
        EDGE_FAR => far.1 / far.0,
        _ => w_p,
    }
}

/// A pixel in the edge list: x | y << 16.
pub fn pack_pixel(x: i32, y: i32) -> u32 {
    x as u32 | ((y as u32) << 16)
}

/// The pixel of an edge-list entry.
pub fn unpack_pixel(v: u32) -> (i32, i32) {
    ((v & 0xffff) as i32, (v >> 16) as i32)
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/coc_edges.comp.
    pub struct CocEdgesBindings {
        depth_m: image(depth_m),
        coc_px: image(coc_px),
        field_curvature: buffer(FieldCurvature),
        color_in: image(color_in),
        args: buffer(Args),
        edge_pixels: buffer(EdgePixels),
    }
}

/// glsl/dof/coc_edges.comp: one invocation per pixel of the edge list (indirect).
pub struct CocEdgesShader;

impl Shader for CocEdgesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CocEdgesBindings<'a>;
    type Push = CocPush;
}

impl Twin for CocEdgesShader {
    fn cpu(push: &CocPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table = floats(b[2].words());
        let (depth, color) = (b[0].image().clone(), b[3].image().clone());
        let count = b[4].words()[COC_ARGS_COUNT as usize] as usize;
        let listed = b[5].words()[..count].to_vec();
        let out = b[1].image_mut();
        for (x, y) in listed.into_iter().map(unpack_pixel) {
            let inv_u = edge_inverse_depth(&depth, &color, push, x, y);
            out.texel_mut(x as u32, y as u32)[0] = push.coc_px_of_inverse_depth(inv_u, x as u32, y as u32, &table);
        }
    }
}
