//! Motion blur, step 0: the anti-aliased-edge resolve of the velocity and depth (see
//! glsl/motion/mb_edges.comp for the model; the layer is decided as the depth of field decides
//! it, by [`edge_layer`]). Both methods (`blur`, `reference`) blur from its output.
//! Shader: glsl/motion/mb_edges.comp.

use super::path::clamped_velocity;
use crate::gpu::{GpuImage, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{after_compute_write, buffer_after_fill, overwrite};
use crate::passes::edge_layers::{edge_layer, EDGE_NEAR, EDGE_OWN};
use crate::passes::groups_for;
use crate::passes::twin::finite_or_zero;
use ash::vk;
use std::sync::Arc;

pub const NAME: &str = "mb_edges";

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
    /// The bindings of glsl/motion/mb_edges.comp.
    pub struct MbEdgesBindings {
        color_in: image(color_in),
        depth_m: image(depth_m),
        velocity: image(velocity),
        velocity_out: image(velocity_out),
        depth_out: image(depth_out),
        changed: buffer(Changed),
    }
}

/// glsl/motion/mb_edges.comp: one invocation per pixel.
pub struct MbEdgesShader;

impl Shader for MbEdgesShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbEdgesBindings<'a>;
    type Push = MbEdgesPush;
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

/// The velocity and depth pixel (x, y) takes where the resolve changes it (the shader's `main`),
/// else None (it keeps its own).
pub fn resolve_pixel(input: &EdgeInputs, pc: &MbEdgesPush, x: i32, y: i32) -> Option<([f32; 4], f32)> {
    let i_p = input.index(x, y);
    let at = |i: usize| input.index(x + i as i32 % 3 - 1, y + i as i32 / 3 - 1);
    let w: [f32; 9] = std::array::from_fn(|i| layer_key(input.depth[at(i)]));
    let w_p = layer_key(input.depth[i_p]);
    let (w_near, w_far) = w.iter().fold((w_p, w_p), |(n, f), &v| (n.max(v), f.min(v)));
    // The depths first (most pixels lie within one layer), then the motions: the shader's one
    // loop, in another order (max and min are exact).
    // Not "greater" includes NaN, as in the shader.
    if w_near.partial_cmp(&(w_far * LAYER_RATIO)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let velocity = |i: usize| clamped_velocity(&input.velocity[4 * i..4 * i + 4], pc.max_speed_px);
    let v_p = velocity(i_p);
    let v9: [[f32; 4]; 9] = std::array::from_fn(|i| velocity(at(i)));
    let motion = v9.iter().fold(0.0f32, |m, v| {
        let next = length(v[0] - v_p[0], v[1] - v_p[1]) * pc.t_fwd;
        let prev = length(v[2] - v_p[2], v[3] - v_p[3]) * pc.t_back;
        m.max(next.max(prev))
    });
    if motion.partial_cmp(&0.5) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
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

impl Twin for MbEdgesShader {
    fn cpu(pc: &MbEdgesPush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, depth, velocity) = (b[0].image().clone(), b[1].image().clone(), b[2].image().clone());
        let input = EdgeInputs {
            width: pc.size[0] as u32,
            height: pc.size[1] as u32,
            color: &color.texels,
            depth: &depth.texels,
            velocity: &velocity.texels,
        };
        let mut changed = 0u32;
        for y in 0..pc.size[1] {
            for x in 0..pc.size[0] {
                let i = input.index(x, y);
                let (v, z) = match resolve_pixel(&input, pc, x, y) {
                    Some(r) => {
                        changed += 1;
                        r
                    }
                    None => (std::array::from_fn(|k| velocity.texels[4 * i + k]), depth.texels[i]),
                };
                b[3].image_mut().texel_mut(x as u32, y as u32).copy_from_slice(&v);
                b[4].image_mut().texel_mut(x as u32, y as u32)[0] = z;
            }
        }
        b[5].words_mut()[0] += changed;
    }
}

/// The frame's colour, and its depth and velocity with the anti-aliased edges resolved when
/// `push` asks for it (else as stored): the inputs both motion-blur paths start from.
pub fn inputs(
    kernel: &Kernel<MbEdgesShader>,
    rec: &mut Recorder,
    images: &crate::passes::FrameImages,
    push: Option<&MbEdgesPush>,
) -> GpuResult<(Arc<GpuImage>, Arc<GpuImage>, Arc<GpuImage>)> {
    let (color, depth, velocity) = (images.color().clone(), images.depth()?.clone(), images.velocity()?.clone());
    let Some(push) = push else { return Ok((color, depth, velocity)) };
    rec.begin_pass(NAME);
    let (depth, velocity) = record(kernel, rec, &color, &depth, &velocity, push)?;
    Ok((color, depth, velocity))
}

/// Record the resolve: the colour, depth and velocity in; new depth and velocity images out (in
/// that order), complete and visible to the compute passes after it.
pub fn record(
    kernel: &Kernel<MbEdgesShader>,
    rec: &mut Recorder,
    color: &GpuImage,
    depth: &GpuImage,
    velocity: &GpuImage,
    push: &MbEdgesPush,
) -> GpuResult<(Arc<GpuImage>, Arc<GpuImage>)> {
    let (w, h) = (push.size[0] as u32, push.size[1] as u32);
    let velocity_out = rec.create_image("velocity (edges resolved)", w, h, vk::Format::R32G32B32A32_SFLOAT)?;
    let depth_out = rec.create_image("depth (edges resolved)", w, h, vk::Format::R32_SFLOAT)?;
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
    let changed = rec.create_buffer("motion edge resolve count", 4, usage)?;
    // changed: counted up with atomics from zero. velocity_out, depth_out: written from scratch.
    // color, depth, velocity: written by the upload (its own barrier) or an earlier compute pass,
    //   read around each pixel.
    rec.fill_buffer(&changed, 0);
    rec.buffer_barriers(&[buffer_after_fill(&changed)]);
    rec.image_barriers(&[after_compute_write(color), overwrite(&velocity_out), overwrite(&depth_out)]);
    let bindings = MbEdgesBindings {
        color_in: color,
        depth_m: depth,
        velocity,
        velocity_out: &velocity_out,
        depth_out: &depth_out,
        changed: &changed,
    };
    kernel.dispatch(rec, &bindings, push, groups_for(w, h))?;
    // The resolved images, complete before the blur's steps read them anywhere.
    rec.image_barriers(&[after_compute_write(&velocity_out), after_compute_write(&depth_out)]);
    Ok((depth_out, velocity_out))
}
