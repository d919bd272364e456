//! The bare pass: reads the frame's colour and writes it to a new image, nothing else
//! (glsl/copy.comp). Not part of a render: `realcam bench` times it in the same run as the other
//! passes and gives every figure as a multiple of it, so the numbers carry over between devices.

use super::barriers::{after_compute_write, overwrite};
use super::{groups_for, FrameImages};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};

pub const NAME: &str = "copy";

crate::shader_bindings! {
    /// The bindings of glsl/copy.comp.
    pub struct CopyBindings {
        color_in: image(color_in),
        color_out: image(color_out),
    }
}

/// glsl/copy.comp; its push constants are the image size.
pub struct CopyShader;

impl Shader for CopyShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CopyBindings<'a>;
    type Push = [i32; 2];
}

impl Twin for CopyShader {
    fn cpu(_size: &[i32; 2], _groups: [u32; 3], b: &mut [HostData]) {
        b[1].image_mut().texels = b[0].image().texels.clone();
    }

    /// A copy is exact.
    const TOLERANCE: f32 = 0.0;
}

/// Record the bare pass: the colour copied into a new image, which becomes the colour.
pub fn record(kernel: &Kernel<CopyShader>, rec: &mut Recorder, images: &mut FrameImages) -> GpuResult<()> {
    rec.begin_pass(NAME);
    let input = images.color().clone();
    let output = rec.create_image("color (copy)", input.width, input.height, input.format)?;
    // input: written by the upload (its own barrier made it visible to compute reads) or by an
    //   earlier compute pass: wait for those writes. output: written from scratch.
    rec.image_barriers(&[after_compute_write(&input), overwrite(&output)]);
    let size = [input.width as i32, input.height as i32];
    let bindings = CopyBindings { color_in: &input, color_out: &output };
    kernel.dispatch(rec, &bindings, &size, groups_for(input.width, input.height))?;
    rec.end_pass();
    images.set_color(None, output);
    Ok(())
}
