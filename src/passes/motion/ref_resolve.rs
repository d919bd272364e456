//! Motion blur reference, step 2 of each sub-frame time: what every pixel shows at that time,
//! added to its running sum with the shutter curve's weight; the last time writes the average.
//! Shader: glsl/motion/mb_ref_resolve.comp.

use super::path::{clamp_speed, depth_classes, shutter_cdf, ShutterPush};
use crate::gpu::{HostData, HostImage, Shader, Twin};
use crate::passes::twin::finite_or_zero;

pub const NAME: &str = "mb_ref_resolve";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbRefResolvePush {
    pub size: [i32; 2],
    pub shutter: ShutterPush,
    pub max_speed_px: f32,
    pub t_frames: f32,
    pub dt_frames: f32,
    pub first: i32,
    pub last: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_ref_resolve.comp.
    pub struct MbRefResolveBindings {
        color_in: image(color_in),
        depth_m: image(depth_m),
        velocity: image(velocity),
        accum: image(accum),
        color_out: image(color_out),
        landing_index: buffer(LandingIndex),
    }
}

/// glsl/motion/mb_ref_resolve.comp: one invocation per pixel.
pub struct MbRefResolveShader;

impl Shader for MbRefResolveShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbRefResolveBindings<'a>;
    type Push = MbRefResolvePush;
}

const NONE: u32 = u32::MAX;

fn color_at(color: &HostImage, x: i32, y: i32) -> [f32; 4] {
    let c = color.clamped(x, y);
    [0, 1, 2, 3].map(|k| finite_or_zero(c[k]))
}

/// `hidden`: what a pixel nothing landed on shows.
fn hidden(pc: &MbRefResolvePush, b: &[HostData], p: [i32; 2]) -> [f32; 4] {
    let (color, depth, velocity, index) = (b[0].image(), b[1].image(), b[2].image(), b[5].words());
    let v = velocity.clamped(p[0], p[1]);
    let dir = if pc.t_frames >= 0.0 {
        clamp_speed([v[0], v[1]], pc.max_speed_px)
    } else {
        clamp_speed([v[2], v[3]], pc.max_speed_px)
    };
    let len = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
    let reach = len * pc.t_frames.abs() + 2.0;
    let z = depth.clamped(p[0], p[1])[0];
    let inside = |q: [i32; 2]| q[0] >= 0 && q[1] >= 0 && q[0] < pc.size[0] && q[1] < pc.size[1];
    if len > 0.0 {
        let d = [dir[0] / len, dir[1] / len];
        for k in 1..=reach.ceil() as i32 {
            for side in [1.0f32, -1.0] {
                let top = pc.shutter.band_top_px;
                let at =
                    [p[0] as f32 + 0.5 + side * k as f32 * d[0], (p[1] + top) as f32 + 0.5 + side * k as f32 * d[1]];
                let q = [at[0].floor() as i32, at[1].floor() as i32 - top];
                if inside(q) && depth_classes(z, depth.clamped(q[0], q[1])[0])[2] >= 1.0 {
                    return color_at(color, q[0], q[1]);
                }
            }
        }
    }
    let (mut sum, mut n) = ([0.0f32; 4], 0.0f32);
    for dy in -1..=1 {
        for dx in -1..=1 {
            let q = [p[0] + dx, p[1] + dy];
            if !inside(q) {
                continue;
            }
            let i = index[(q[1] * pc.size[0] + q[0]) as usize];
            if i != NONE {
                let c = color_at(color, i as i32 % pc.size[0], i as i32 / pc.size[0]);
                (0..4).for_each(|k| sum[k] += c[k]);
                n += 1.0;
            }
        }
    }
    if n > 0.0 {
        sum.map(|s| s / n)
    } else {
        color_at(color, p[0], p[1])
    }
}

impl Twin for MbRefResolveShader {
    fn cpu(pc: &MbRefResolvePush, _groups: [u32; 3], b: &mut [HostData]) {
        let mut accum = b[3].image().clone();
        let mut out = b[4].image().clone();
        for y in 0..pc.size[1] {
            for x in 0..pc.size[0] {
                let mut acc: [f32; 4] =
                    if pc.first != 0 { [0.0; 4] } else { accum.clamped(x, y).try_into().unwrap_or([0.0; 4]) };
                let win = pc.shutter.window([x as f32 + 0.5, y as f32 + 0.5]);
                let (len, ramp, half) = (win[1] - win[0], pc.shutter.ramp_frames, 0.5 * pc.dt_frames);
                let w = shutter_cdf(pc.t_frames + half - win[0], len, ramp)
                    - shutter_cdf(pc.t_frames - half - win[0], len, ramp);
                if w > 0.0 {
                    let i = b[5].words()[(y * pc.size[0] + x) as usize];
                    let c = if i != NONE {
                        color_at(b[0].image(), i as i32 % pc.size[0], i as i32 / pc.size[0])
                    } else {
                        hidden(pc, b, [x, y])
                    };
                    acc = [acc[0] + w * c[0], acc[1] + w * c[1], acc[2] + w * c[2], acc[3] + w];
                }
                if pc.last != 0 {
                    let own = color_at(b[0].image(), x, y);
                    let v =
                        if acc[3] > 0.0 { [acc[0] / acc[3], acc[1] / acc[3], acc[2] / acc[3], own[3]] } else { own };
                    out.texel_mut(x as u32, y as u32).copy_from_slice(&v);
                } else {
                    accum.texel_mut(x as u32, y as u32).copy_from_slice(&acc);
                }
            }
        }
        b[3] = HostData::Image(accum);
        b[4] = HostData::Image(out);
    }
}
