//! Motion blur reference, step 1 of each sub-frame time: every texel moved to where its path has
//! it at that time; the nearest one landing on each pixel wins. Shader: glsl/motion/mb_ref_splat.comp.

use super::path::{clamp_speed, ShutterPush};
use crate::gpu::{HostData, Shader, Twin};

pub const NAME: &str = "mb_ref_splat";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbRefSplatPush {
    pub size: [i32; 2],
    pub shutter: ShutterPush,
    pub max_speed_px: f32,
    pub t_frames: f32,
    /// 0: the nearest depth per landing pixel; 1: the lowest index at that depth.
    pub stage: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_ref_splat.comp.
    pub struct MbRefSplatBindings {
        depth_m: image(depth_m),
        velocity: image(velocity),
        landing_depth: buffer(LandingDepth),
        landing_index: buffer(LandingIndex),
    }
}

/// glsl/motion/mb_ref_splat.comp: one invocation per source texel.
pub struct MbRefSplatShader;

impl Shader for MbRefSplatShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbRefSplatBindings<'a>;
    type Push = MbRefSplatPush;
}

/// Where texel `y` is at time `t` (frames): the pixel it lands on, if inside the frame and that
/// pixel's shutter is open at `t`.
pub fn landing(pc: &MbRefSplatPush, y: [i32; 2], velocity: &[f32]) -> Option<usize> {
    let t = pc.t_frames;
    let v = if t >= 0.0 {
        clamp_speed([velocity[0], velocity[1]], pc.max_speed_px).map(|c| t * c)
    } else {
        clamp_speed([velocity[2], velocity[3]], pc.max_speed_px).map(|c| -t * c)
    };
    let top = pc.shutter.band_top_px;
    let at = [y[0] as f32 + 0.5 + v[0], (y[1] + top) as f32 + 0.5 + v[1]];
    let l = [at[0].floor() as i32, at[1].floor() as i32 - top];
    if l[0] < 0 || l[1] < 0 || l[0] >= pc.size[0] || l[1] >= pc.size[1] {
        return None;
    }
    let win = pc.shutter.window([l[0] as f32 + 0.5, l[1] as f32 + 0.5]);
    if t < win[0] || t > win[1] {
        return None;
    }
    Some((l[1] * pc.size[0] + l[0]) as usize)
}

impl Twin for MbRefSplatShader {
    fn cpu(pc: &MbRefSplatPush, _groups: [u32; 3], b: &mut [HostData]) {
        let (depth, velocity) = (b[0].image().clone(), b[1].image().clone());
        for y in 0..pc.size[1] {
            for x in 0..pc.size[0] {
                let Some(i) = landing(pc, [x, y], velocity.clamped(x, y)) else { continue };
                let z = depth.clamped(x, y)[0].clamp(0.0, 3.0e38).to_bits();
                if pc.stage == 0 {
                    let d = &mut b[2].words_mut()[i];
                    *d = (*d).min(z);
                } else if b[2].words()[i] == z {
                    let index = &mut b[3].words_mut()[i];
                    *index = (*index).min((y * pc.size[0] + x) as u32);
                }
            }
        }
    }
}
