//! Tiled depth of field: levels 2 .. 4 of the pyramid, each from the level below (the weighted
//! colour averages and nearest CoC of dof_downsample.comp). Shader: glsl/dof/dof_pyramid.comp.

use crate::gpu::{GpuImage, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{after_compute_write, overwrite};

pub const NAME: &str = "dof_pyramid";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PyramidPush {
    pub fine_size: [i32; 2],
    pub coarse_size: [i32; 2],
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_pyramid.comp.
    pub struct PyramidBindings {
        color_fine: image(color_fine),
        coc_fine: image(coc_fine),
        color_coarse: image(color_coarse),
        coc_coarse: image(coc_coarse),
    }
}

/// glsl/dof/dof_pyramid.comp: one invocation per coarse texel.
pub struct PyramidShader;

impl Shader for PyramidShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = PyramidBindings<'a>;
    type Push = PyramidPush;
}

impl Twin for PyramidShader {
    fn cpu(pc: &PyramidPush, _groups: [u32; 3], b: &mut [HostData]) {
        let (color, coc) = (b[0].image().clone(), b[1].image().clone());
        let (mut color_coarse, mut coc_coarse) = (b[2].image().clone(), b[3].image().clone());
        for y in 0..pc.coarse_size[1] {
            for x in 0..pc.coarse_size[0] {
                let (mut sum, mut coc_near, mut weight) = ([0.0f32; 4], f32::INFINITY, 0.0f32);
                for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (qx, qy) = (2 * x + i, 2 * y + j);
                    if qx >= pc.fine_size[0] || qy >= pc.fine_size[1] {
                        continue;
                    }
                    let cw = coc.clamped(qx, qy);
                    let c = color.clamped(qx, qy);
                    for k in 0..4 {
                        sum[k] += c[k];
                    }
                    weight += cw[1];
                    if cw[1] > 0.0 {
                        coc_near = coc_near.min(cw[0]);
                    }
                }
                color_coarse.texel_mut(x as u32, y as u32).copy_from_slice(&sum.map(|v| 0.25 * v));
                let cw = [if weight > 0.0 { coc_near } else { 0.0 }, 0.25 * weight];
                coc_coarse.texel_mut(x as u32, y as u32).copy_from_slice(&cw);
            }
        }
        b[2] = HostData::Image(color_coarse);
        b[3] = HostData::Image(coc_coarse);
    }
}

/// Record one level from the level below it.
pub fn record(
    kernel: &Kernel<PyramidShader>,
    rec: &mut Recorder,
    b: &PyramidBindings<'_>,
    level: u32,
) -> GpuResult<()> {
    rec.begin_pass(&format!("{NAME}_{level}"));
    // The finer level: just written by the previous step (read-after-write). The coarser one:
    // written from scratch.
    rec.image_barriers(&[
        after_compute_write(b.color_fine),
        after_compute_write(b.coc_fine),
        overwrite(b.color_coarse),
        overwrite(b.coc_coarse),
    ]);
    let size = |i: &GpuImage| [i.width as i32, i.height as i32];
    let push = PyramidPush { fine_size: size(b.color_fine), coarse_size: size(b.color_coarse) };
    let groups = [b.color_coarse.width.div_ceil(8), b.color_coarse.height.div_ceil(8), 1];
    kernel.dispatch(rec, b, &push, groups)?;
    rec.end_pass();
    Ok(())
}
